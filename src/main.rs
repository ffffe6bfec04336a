//! The `raycaster` command: parses the command line and hands it to the library.

mod app;

use app::backend::Backend;
use app::cli::{self, BackendChoice, Command, Habits, RenderArgs, Verbosity};
use std::process::ExitCode;

fn main() -> ExitCode {
    give_mesa_a_runtime_dir();
    let line = match cli::parse_command_line(std::env::args_os().skip(1)) {
        Ok(line) => line,
        Err(e) => {
            eprintln!("raycaster: {e}");
            return ExitCode::from(2);
        }
    };
    let habits = line.habits;
    if let Some(threads) = habits.threads {
        // Before anything uses rayon: the reference's rows run on the global pool.
        if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(threads).build_global() {
            eprintln!("raycaster: --threads {threads}: {e}");
            return ExitCode::FAILURE;
        }
    }
    match line.command {
        Command::Help => {
            println!("{}", cli::USAGE);
            ExitCode::SUCCESS
        }
        Command::Version => {
            println!("raycaster {}", env!("CARGO_PKG_VERSION"));
            ExitCode::SUCCESS
        }
        Command::Render(args) => render(&args, habits),
        Command::Compare { args, max_diff_pixels } => compare(&args, max_diff_pixels, habits),
        Command::Batch { file, backend } => batch(&file, backend, habits),
        Command::Bench(bench_args) => bench(&bench_args, habits),
    }
}

fn render(args: &RenderArgs, habits: Habits) -> ExitCode {
    let Some(backend) = open_backend(args.backend, habits) else { return ExitCode::FAILURE };
    match app::job::run(args, &backend, habits.verbosity != Verbosity::Quiet) {
        Ok(report) => {
            warn(&report.warnings, habits);
            if habits.verbosity == Verbosity::Verbose {
                notice(&report.verbose_lines(&backend, args));
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            ExitCode::FAILURE
        }
    }
}

fn compare(args: &RenderArgs, max_diff_pixels: Option<u64>, habits: Habits) -> ExitCode {
    let Some(Backend::Gpu(gpu)) = open_backend(BackendChoice::Gpu, habits) else { return ExitCode::FAILURE };
    match app::job::compare(args, &gpu) {
        Ok(comparison) => {
            warn(&comparison.warnings, habits);
            println!(
                "gpu ({}) against the f64 reference ({} triangles, {} spheres):",
                gpu.adapter_info().name,
                args.triangle_test.name(),
                args.sphere_test.name()
            );
            print!("{}", raycaster::metrics::errors_table(&comparison.errors));
            if comparison.passes(max_diff_pixels) {
                ExitCode::SUCCESS
            } else {
                eprintln!("raycaster: compare: the GPU's result exceeds the limit or holds NaN/infinity");
                ExitCode::FAILURE
            }
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            ExitCode::FAILURE
        }
    }
}

fn batch(file: &std::path::Path, choice: BackendChoice, habits: Habits) -> ExitCode {
    let text = match std::fs::read_to_string(file) {
        Ok(text) => text,
        Err(e) => {
            eprintln!("raycaster: {}: {e}", file.display());
            return ExitCode::FAILURE;
        }
    };
    let Some(backend) = open_backend(choice, habits) else { return ExitCode::FAILURE };
    let (done, failures) = app::job::run_batch(&text, &backend, habits.verbosity != Verbosity::Quiet);
    for line in &done {
        warn(&line.report.warnings, habits);
    }
    if habits.verbosity == Verbosity::Verbose {
        notice(&[format!("backend: {}", backend.describe())]);
        for line in &done {
            let report = &line.report;
            let ms = report.parse_ms + report.render_ms + report.write_ms;
            notice(&[format!("{}:{}: {ms:.1} ms", file.display(), line.line)]);
        }
        notice(&[format!("memory: peak resident {:.0} MiB", app::bench::peak_memory_mib())]);
    }
    for f in &failures {
        eprintln!("raycaster: {}:{}: {}", file.display(), f.line, f.message);
    }
    if failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn bench(args: &cli::BenchArgs, habits: Habits) -> ExitCode {
    use app::bench;
    let Some(Backend::Gpu(gpu)) = open_backend(BackendChoice::Gpu, habits) else { return ExitCode::FAILURE };
    let cases = match bench::standard_cases(&args.corpus, args.quick) {
        Ok(cases) => cases
            .into_iter()
            .filter(|c| args.only.as_ref().is_none_or(|o| c.name.contains(o.as_str())))
            .collect::<Vec<_>>(),
        Err(e) => {
            eprintln!("raycaster: bench: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut rows = Vec::new();
    for case in &cases {
        if habits.verbosity != Verbosity::Quiet {
            eprintln!("bench: {} {}×{} ({})", case.name, case.width, case.height, case.triangle_test.name());
        }
        match bench::run_case(&gpu, case, args.runs) {
            Ok(row) => rows.push(row),
            Err(e) => {
                eprintln!("raycaster: bench: {}: {e}", case.name);
                return ExitCode::FAILURE;
            }
        }
    }
    print!("{}", bench::markdown(&rows, &gpu.adapter_info().name));
    let written = std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: {e}", args.out.display()))
        .and_then(|()| std::fs::write(args.out.join("bench.csv"), bench::csv(&rows)).map_err(|e| e.to_string()))
        .and_then(|()| write_plot(&rows, &args.out));
    match written {
        Ok(()) => {
            if habits.verbosity != Verbosity::Quiet {
                eprintln!(
                    "bench: wrote {}/bench.csv{}",
                    args.out.display(),
                    if cfg!(feature = "plot") { " and bench.png" } else { "" }
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("raycaster: bench: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(feature = "plot")]
fn write_plot(rows: &[app::bench::Row], out: &std::path::Path) -> Result<(), String> {
    app::bench::plot(rows, &out.join("bench.png")).map_err(|e| e.to_string())
}

/// Built without the `plot` feature: the table and the CSV only.
#[cfg(not(feature = "plot"))]
fn write_plot(_: &[app::bench::Row], _: &std::path::Path) -> Result<(), String> {
    Ok(())
}

fn open_backend(choice: BackendChoice, habits: Habits) -> Option<Backend> {
    match Backend::open(choice) {
        Ok((backend, fallback)) => {
            if let Some(fallback) = fallback.filter(|_| habits.verbosity != Verbosity::Quiet) {
                eprintln!("raycaster: {fallback}");
            }
            Some(backend)
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            None
        }
    }
}

fn warn(warnings: &[String], habits: Habits) {
    if habits.verbosity == Verbosity::Quiet {
        return;
    }
    for w in warnings {
        eprintln!("raycaster: warning: {w}");
    }
}

/// `--verbose`'s lines, on stderr so that stdout stays the command's output.
fn notice(lines: &[String]) {
    for line in lines {
        eprintln!("raycaster: {line}");
    }
}
/// Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" on every start when
/// the variable is missing (headless machines, CI). Point it at a private folder of ours
/// before any thread exists, so the message does not bury our own.
fn give_mesa_a_runtime_dir() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("raycaster-runtime-{}", user_id()));
    if make_private_dir(&dir).is_ok() {
        std::env::set_var("XDG_RUNTIME_DIR", dir);
    }
}

#[cfg(unix)]
fn user_id() -> u32 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").map(|m| m.uid()).unwrap_or(0)
}

#[cfg(not(unix))]
fn user_id() -> u32 {
    0
}

#[cfg(unix)]
fn make_private_dir(dir: &std::path::Path) -> std::io::Result<()> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    match std::fs::DirBuilder::new().mode(0o700).create(dir) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            let meta = std::fs::metadata(dir)?;
            let ours = meta.is_dir() && meta.uid() == user_id() && meta.permissions().mode() & 0o077 == 0;
            if ours {
                Ok(())
            } else {
                Err(std::io::Error::other("not a private directory of ours"))
            }
        }
        Err(e) => Err(e),
    }
}

#[cfg(not(unix))]
fn make_private_dir(_: &std::path::Path) -> std::io::Result<()> {
    Err(std::io::Error::other("unused"))
}
