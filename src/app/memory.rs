//! The process's peak resident memory, for `--verbose` and `raycaster bench`. Linux only (its
//! /proc can reset the peak, which the bench needs between cases): elsewhere the figure is
//! reported as not available rather than as 0.

/// The peak resident memory of the process so far, in MiB, where the system tells it.
pub fn peak_mib() -> Option<f64> {
    if !cfg!(target_os = "linux") {
        return None;
    }
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib = status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?;
    kib.trim().trim_end_matches("kB").trim().parse::<f64>().ok().map(|kib| kib / 1024.0)
}

/// `peak resident 42 MiB`, or says that the figure is not available.
pub fn describe_peak() -> String {
    match peak_mib() {
        Some(mib) => format!("peak resident {mib:.0} MiB"),
        None => "peak resident not available on this system".into(),
    }
}

/// Starts the peak over from the current use, so that a measurement covers only what
/// follows (Linux: writing 5 to clear_refs resets VmHWM).
pub fn reset_peak() {
    if cfg!(target_os = "linux") {
        let _ = std::fs::write("/proc/self/clear_refs", "5");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_is_measured_on_linux_only() {
        assert_eq!(peak_mib().is_some_and(|mib| mib > 0.0), cfg!(target_os = "linux"), "{}", describe_peak());
    }
}
