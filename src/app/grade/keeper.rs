//! The keeper: the first process inside a line's sandbox (pid 1 of its pid namespace, as
//! isolate's keeper is), which bubblewrap starts as `raycaster --grade-keeper …`. It is our
//! code, run in the sandbox as the student's user, with no capabilities and not dumpable (so
//! that the student's processes, the same user, cannot trace it, read its memory or take its
//! descriptors). It
//! 1. starts the student's program with the per-process limits (`setrlimit`: CPU time,
//!    address space, processes, file size, no core files);
//! 2. waits for it until the wall time, reaping every process of the namespace (orphans come
//!    to pid 1) and noting the limits they hit;
//! 3. kills every process left (`kill(-1)` from pid 1 reaches the whole namespace, and
//!    nothing else), until none remains;
//! 4. copies the line's outputs out of the working folder, which is a tmpfs of the sandbox's
//!    own and goes with it, into the outbox: a folder the student never sees, reached only
//!    through a descriptor that the keeper closes for the student's program;
//! 5. writes there `status`, a few lines saying how the program ended, which limits it hit,
//!    and what became of each output.
//!
//! Its command line: `--grade-keeper LIMITS OUTBOX_FD OUTPUT… -- PROGRAM ARG…`, LIMITS being
//! `wall_ms:cpu_s:memory:processes:file:folder` ([`limits_word`]).

use crate::app::args::{LimitKind, Limits};
use crate::app::grade::untrusted;
use std::ffi::OsString;
use std::io::Write;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The keeper's first argument.
pub const ARG: &str = "--grade-keeper";
/// The status file's name in the outbox; outputs are `0`, `1`, … in the order given.
pub const STATUS: &str = "status";
/// How often the keeper looks at the namespace's processes.
const POLL: Duration = Duration::from_millis(2);

/// `limits` as the keeper's LIMITS word.
pub fn limits_word(limits: &Limits) -> String {
    let wall_ms = (limits.wall * 1000.0).ceil() as u64;
    format!("{wall_ms}:{}:{}:{}:{}:{}", limits.cpu, limits.memory, limits.processes, limits.file, limits.folder)
}

fn parse_limits(word: &str) -> Option<Limits> {
    let numbers: Vec<u64> = word.split(':').map(|n| n.parse().ok()).collect::<Option<_>>()?;
    let [wall_ms, cpu, memory, processes, file, folder] = numbers[..] else { return None };
    Some(Limits { wall: wall_ms as f64 / 1000.0, cpu, memory, processes, file, folder })
}

/// Runs the keeper when the process was started as one: `Some(status)` then.
pub fn main_if_asked() -> Option<u8> {
    let mut args = std::env::args_os().skip(1);
    if args.next()? != ARG {
        return None;
    }
    match keep(args.collect()) {
        Ok(()) => Some(0),
        Err(why) => {
            let _ = writeln!(std::io::stderr(), "raycaster keeper: {why}");
            Some(1)
        }
    }
}

fn keep(args: Vec<OsString>) -> Result<(), String> {
    // SAFETY: prctl with integer arguments.
    unsafe { libc::prctl(libc::PR_SET_DUMPABLE, 0, 0, 0, 0) };
    let split = args.iter().position(|a| a == "--").ok_or("no -- before the program")?;
    let (head, program) = (&args[..split], &args[split + 1..]);
    let [limits, outbox, outputs @ ..] = head else { return Err("no limits or outbox".into()) };
    let limits = parse_limits(&limits.to_string_lossy()).ok_or("malformed limits")?;
    let outbox = take_outbox(outbox.to_string_lossy().parse().map_err(|_| "malformed outbox")?)?;
    let outputs: Vec<PathBuf> = outputs.iter().map(PathBuf::from).collect();
    let mut status = String::new();
    let watch = match start(program, &limits) {
        Ok(child) => watch(child, &limits),
        Err(why) => Watch { ending: format!("not-started {why}"), hits: Vec::new() },
    };
    kill_everything_left();
    let mut hits = watch.hits;
    let (here, tmp) = (Path::new("."), Path::new("/tmp"));
    if folder_full(here) || folder_full(tmp) {
        hits.push(LimitKind::Folder);
    }
    // A write past the file size limit stops at it (SIGXFSZ ends the writer, whose parent,
    // not the keeper, may be the one to see it): a file of exactly that size shows it.
    if has_file_of(here, limits.file) || has_file_of(tmp, limits.file) {
        hits.push(LimitKind::File);
    }
    hits.sort_by_key(|h| *h as u8);
    status += &format!("ended {}\n", watch.ending);
    hits.dedup();
    for hit in hits {
        status += &format!("hit {}\n", hit.name());
    }
    for (k, output) in outputs.iter().enumerate() {
        let copied = copy_out(output, &outbox, &k.to_string(), limits.file);
        status += &format!("output {k} {}\n", copied.err().unwrap_or_else(|| "copied".into()));
    }
    let mut file = create_in(&outbox, STATUS)?;
    file.write_all(status.as_bytes()).map_err(|e| format!("status: {e}"))
}

/// The outbox's descriptor, made close-on-exec with every other one the keeper inherited:
/// the student's program gets only its standard streams.
fn take_outbox(fd: i32) -> Result<OwnedFd, String> {
    // SAFETY: fcntl on a descriptor number; a closed one gives EBADF, checked.
    if fd < 3 || unsafe { libc::fcntl(fd, libc::F_GETFD) } < 0 {
        return Err("no outbox descriptor".into());
    }
    const CLOSE_RANGE_CLOEXEC: libc::c_uint = 1 << 2;
    // SAFETY: close_range with flags only marks descriptors; no memory is involved.
    let marked = unsafe { libc::syscall(libc::SYS_close_range, 3u32, u32::MAX, CLOSE_RANGE_CLOEXEC) };
    if marked != 0 {
        return Err(format!("close_range: {}", std::io::Error::last_os_error()));
    }
    // SAFETY: the descriptor is open (checked above) and owned by nothing else here.
    Ok(unsafe { OwnedFd::from_raw_fd(fd) })
}

/// The student's program, started with the per-process limits.
fn start(program: &[OsString], limits: &Limits) -> Result<std::process::Child, String> {
    let (name, args) = program.split_first().ok_or("no program")?;
    let mut command = std::process::Command::new(name);
    command.args(args);
    let limits = *limits;
    // SAFETY: only setrlimit, which is async-signal-safe, between fork and exec.
    unsafe {
        command.pre_exec(move || {
            let set = |resource, soft: u64, hard: u64| {
                let limit = libc::rlimit { rlim_cur: soft, rlim_max: hard };
                if libc::setrlimit(resource, &limit) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            };
            // SIGXCPU at the limit, SIGKILL a second later for a program that catches it.
            set(libc::RLIMIT_CPU, limits.cpu, limits.cpu + 1)?;
            set(libc::RLIMIT_AS, limits.memory, limits.memory)?;
            set(libc::RLIMIT_NPROC, limits.processes, limits.processes)?;
            set(libc::RLIMIT_FSIZE, limits.file, limits.file)?;
            set(libc::RLIMIT_CORE, 0, 0)
        });
    }
    command.spawn().map_err(|e| format!("{}: {e}", name.to_string_lossy()))
}

/// How the program ended (`exited N`, `signal N`, `not-started WHY`) and the limits hit.
struct Watch {
    ending: String,
    hits: Vec<LimitKind>,
}

/// Waits for `child` until it ends or the wall time passes, reaping every process that
/// ends meanwhile and noting what they hit.
fn watch(child: std::process::Child, limits: &Limits) -> Watch {
    let main = child.id() as libc::pid_t;
    // The child is reaped below with wait4, not through `Child`.
    drop(child);
    let deadline = Instant::now() + Duration::from_secs_f64(limits.wall);
    let mut hits = Vec::new();
    loop {
        while let Some((pid, status, usage)) = reap(libc::WNOHANG) {
            note_hits(status, &usage, limits, &mut hits);
            if pid == main {
                return Watch { ending: ending(status), hits };
            }
        }
        if Instant::now() >= deadline {
            hits.push(LimitKind::Wall);
            return Watch { ending: "killed at the wall time".into(), hits };
        }
        // Near the limit rather than at it: where forks fail, the processes that made them
        // end, and a namespace at its limit is seldom seen full.
        if processes_now() + 1 >= (limits.processes * 3 / 4).max(2) {
            hits.push(LimitKind::Processes);
        }
        std::thread::sleep(POLL);
    }
}

/// One ended process of the namespace, with its status and use.
fn reap(flags: i32) -> Option<(libc::pid_t, i32, libc::rusage)> {
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid value for wait4 to fill.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: pointers to locals.
    let pid = unsafe { libc::wait4(-1, &mut status, flags, &mut usage) };
    (pid > 0).then_some((pid, status, usage))
}

fn ending(status: i32) -> String {
    if libc::WIFEXITED(status) {
        format!("exited {}", libc::WEXITSTATUS(status))
    } else {
        format!("signal {}", libc::WTERMSIG(status))
    }
}

/// The limits an ended process's status and use show it hit. Memory: its resident peak
/// reached nine tenths of the address space allowed (a refused allocation leaves no other
/// trace the keeper can see).
fn note_hits(status: i32, usage: &libc::rusage, limits: &Limits, hits: &mut Vec<LimitKind>) {
    let signal = libc::WIFSIGNALED(status).then(|| libc::WTERMSIG(status));
    let cpu = usage.ru_utime.tv_sec + usage.ru_stime.tv_sec;
    if signal == Some(libc::SIGXCPU) || (signal == Some(libc::SIGKILL) && cpu as u64 >= limits.cpu) {
        hits.push(LimitKind::Cpu);
    }
    if signal == Some(libc::SIGXFSZ) {
        hits.push(LimitKind::File);
    }
    if (usage.ru_maxrss as u64) * 1024 >= limits.memory / 10 * 9 {
        hits.push(LimitKind::Memory);
    }
}

/// The processes of the namespace now, the keeper aside.
fn processes_now() -> u64 {
    let Ok(entries) = std::fs::read_dir("/proc") else { return 0 };
    let numbered = entries.flatten().filter(|e| e.file_name().to_string_lossy().bytes().all(|b| b.is_ascii_digit()));
    (numbered.count() as u64).saturating_sub(1)
}

/// SIGKILL to every process of the namespace, again after each one reaped, until none is
/// left: a process forked during one sweep is caught by the next.
fn kill_everything_left() {
    loop {
        // SAFETY: kill with plain integers; from pid 1 of a pid namespace, -1 reaches every
        // process of that namespace but the caller.
        unsafe { libc::kill(-1, libc::SIGKILL) };
        if reap(0).is_none() {
            return;
        }
    }
}

/// Whether `folder`'s file system has no room left for another block of a file.
fn folder_full(folder: &Path) -> bool {
    let Ok(path) = std::ffi::CString::new(folder.as_os_str().as_encoded_bytes()) else { return false };
    // SAFETY: a zeroed statvfs is a valid value to fill; a NUL-terminated path.
    let mut stats: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(path.as_ptr(), &mut stats) } != 0 {
        return false;
    }
    (stats.f_bavail as u64) * (stats.f_frsize as u64) < 64 * 1024
}

/// Whether a regular file of `size` bytes (or more) is under `folder`, on its file system
/// (not in the program's folders bound inside `/tmp`), links not followed; the first few
/// thousand entries are looked at.
fn has_file_of(folder: &Path, size: u64) -> bool {
    use std::os::unix::fs::MetadataExt;
    let Ok(device) = std::fs::metadata(folder).map(|m| m.dev()) else { return false };
    let mut folders = vec![folder.to_path_buf()];
    let mut seen = 0;
    while let Some(next) = folders.pop() {
        let Ok(entries) = std::fs::read_dir(&next) else { continue };
        for entry in entries.flatten() {
            seen += 1;
            if seen > 10_000 {
                return false;
            }
            match entry.metadata() {
                Ok(m) if m.dev() != device => {}
                Ok(m) if m.is_file() && m.len() >= size => return true,
                Ok(m) if m.is_dir() => folders.push(entry.path()),
                _ => {}
            }
        }
    }
    false
}

/// Copies the output `name` of the working folder into the outbox as `as_name`.
fn copy_out(name: &Path, outbox: &OwnedFd, as_name: &str, max: u64) -> Result<(), String> {
    let file = untrusted::open_beneath(Path::new("."), name)?;
    let size = file.metadata().map_err(|e| e.to_string())?.len();
    if size > max {
        return Err(format!("{}: larger than {max} bytes", name.display()));
    }
    let mut target = create_in(outbox, as_name)?;
    std::io::copy(&mut std::io::Read::take(file, max), &mut target).map_err(|e| format!("{}: {e}", name.display()))?;
    Ok(())
}

/// A new file `name` in the folder open on `folder`.
fn create_in(folder: &OwnedFd, name: &str) -> Result<std::fs::File, String> {
    let c_name = std::ffi::CString::new(name).map_err(|_| "a NUL in a name".to_string())?;
    let flags = libc::O_WRONLY | libc::O_CREAT | libc::O_EXCL | libc::O_NOFOLLOW | libc::O_CLOEXEC;
    // SAFETY: a valid descriptor and a NUL-terminated name; the result is checked.
    let fd = unsafe { libc::openat(folder.as_raw_fd(), c_name.as_ptr(), flags, 0o600 as libc::c_uint) };
    if fd < 0 {
        return Err(format!("outbox {name}: {}", std::io::Error::last_os_error()));
    }
    // SAFETY: a descriptor just opened, owned by nothing else.
    Ok(std::fs::File::from(unsafe { OwnedFd::from_raw_fd(fd) }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_limits_word_round_trips() {
        let limits = Limits { wall: 1.5, cpu: 2, memory: 3 << 20, processes: 4, file: 5, folder: 6 };
        assert_eq!(limits_word(&limits), "1500:2:3145728:4:5:6");
        assert_eq!(parse_limits(&limits_word(&limits)), Some(limits));
        assert_eq!(parse_limits("1:2:3"), None);
    }
}
