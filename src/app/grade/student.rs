//! `grade --run COMMAND`: the student's program run on each command line, as the course
//! runs it (inside the assignment's folder, the line's words after the program), in a copy
//! of the folder so that nothing of the teacher's is touched, with a time limit. Whatever
//! the program does (crash, hang, write nothing) becomes an outcome of the line, never an
//! error of the grader.

use crate::app::grade::course::CourseLine;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// How a line's run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Ending {
    /// Exit status 0.
    Finished,
    /// A non-zero status, or killed by a signal: what the shell would say.
    Failed(String),
    /// Still running at the time limit: it was killed.
    TimedOut(f64),
    /// The program could not be started at all.
    NotStarted(String),
}

impl Ending {
    /// Why the line's images may be missing, in words; `None` after a normal exit.
    pub fn trouble(&self) -> Option<String> {
        match self {
            Ending::Finished => None,
            Ending::Failed(how) => Some(format!("the program {how}")),
            Ending::TimedOut(limit) => Some(format!("the program ran past the time limit ({limit} s) and was killed")),
            Ending::NotStarted(why) => Some(format!("the program did not start: {why}")),
        }
    }
}

/// A line's run: how it ended and the end of what it printed on stderr.
#[derive(Clone, Debug)]
pub struct Run {
    pub ending: Ending,
    pub stderr_tail: String,
}

/// The folder the student's program runs in: a copy of the assignment's folder.
pub struct Workspace {
    dir: tempfile::TempDir,
    program: Vec<String>,
    time_limit: Duration,
}

impl Workspace {
    /// Copies `folder` into a temporary folder for `command` (the program and its own
    /// arguments, split at spaces) to run in.
    pub fn new(folder: &Path, command: &str, time_limit: f64) -> Result<Workspace, String> {
        let dir = tempfile::Builder::new().prefix("raycaster-grade-").tempdir().map_err(|e| e.to_string())?;
        copy_folder(folder, dir.path())?;
        let mut program: Vec<String> = command.split_whitespace().map(str::to_string).collect();
        // A program named by a path relative to where the teacher is (`./raytracer`) must
        // not be looked up in the copy, where the line runs.
        if let Some(first) = program.first_mut().filter(|p| p.contains(std::path::is_separator)) {
            if let Ok(absolute) = Path::new(first.as_str()).canonicalize() {
                *first = absolute.to_string_lossy().into_owned();
            }
        }
        Ok(Workspace { dir, program, time_limit: Duration::from_secs_f64(time_limit) })
    }

    /// Where the line's images are, once run.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// Runs the program on `line` in the copy, after removing the images the line should
    /// write (an earlier line may have written the same file).
    pub fn run(&self, line: &CourseLine) -> Run {
        for image in &line.images {
            let _ = std::fs::remove_file(self.path().join(image));
        }
        let stderr_path = self.path().join(format!(".raycaster-grade-stderr-{}", line.number));
        let ending = match self.start(line, &stderr_path) {
            Ok(child) => self.wait(child),
            Err(why) => Ending::NotStarted(why),
        };
        let stderr_tail = std::fs::read(&stderr_path).map(|bytes| tail(&bytes)).unwrap_or_default();
        let _ = std::fs::remove_file(&stderr_path);
        Run { ending, stderr_tail }
    }

    fn start(&self, line: &CourseLine, stderr_path: &Path) -> Result<Child, String> {
        let stderr = std::fs::File::create(stderr_path).map_err(|e| e.to_string())?;
        let (program, own_args) = self.program.split_first().ok_or("--run names no program")?;
        let mut command = Command::new(program);
        command.args(own_args).args(line.words()).current_dir(self.path());
        command.stdin(Stdio::null()).stdout(Stdio::null()).stderr(stderr);
        own_process_group(&mut command);
        command.spawn().map_err(|e| format!("{program}: {e}"))
    }

    /// Waits for `child` until the time limit, then kills it (and what it started).
    fn wait(&self, mut child: Child) -> Ending {
        let start = Instant::now();
        loop {
            match child.try_wait() {
                Ok(Some(status)) => return ended(status),
                Ok(None) if start.elapsed() >= self.time_limit => {
                    kill(&mut child);
                    return Ending::TimedOut(self.time_limit.as_secs_f64());
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(10)),
                Err(e) => {
                    kill(&mut child);
                    return Ending::Failed(format!("could not be waited for: {e}"));
                }
            }
        }
    }
}

fn ended(status: ExitStatus) -> Ending {
    if status.success() {
        return Ending::Finished;
    }
    match status.code() {
        Some(code) => Ending::Failed(format!("exited with status {code}")),
        None => Ending::Failed(killed_by(status)),
    }
}

#[cfg(unix)]
fn killed_by(status: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match status.signal() {
        Some(signal) => format!("was killed by signal {signal}"),
        None => format!("ended with {status}"),
    }
}

#[cfg(not(unix))]
fn killed_by(status: ExitStatus) -> String {
    format!("ended with {status}")
}

/// The program leads a process group of its own, so that a time-out also ends the
/// processes it started (a shell script's children would otherwise run on).
#[cfg(unix)]
fn own_process_group(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    command.process_group(0);
}

#[cfg(not(unix))]
fn own_process_group(_: &mut Command) {}

#[cfg(unix)]
fn kill(child: &mut Child) {
    // The group's id is the child's: `own_process_group` made it its leader.
    if let Ok(group) = libc::pid_t::try_from(child.id()) {
        // SAFETY: kill takes plain integers; a group that has already gone gives ESRCH.
        unsafe { libc::kill(-group, libc::SIGKILL) };
    }
    let _ = child.kill();
    let _ = child.wait();
}

#[cfg(not(unix))]
fn kill(child: &mut Child) {
    let _ = child.kill();
    let _ = child.wait();
}

/// The last lines of what the program printed: enough to say why it failed.
fn tail(bytes: &[u8]) -> String {
    const KEEP: usize = 1500;
    let text = String::from_utf8_lossy(bytes);
    let text = text.trim_end();
    let start = text.char_indices().rev().nth(KEEP).map_or(0, |(k, _)| k);
    text[start..].to_string()
}

/// Copies `from` into `to`, folders and all.
fn copy_folder(from: &Path, to: &Path) -> Result<(), String> {
    let entries = std::fs::read_dir(from).map_err(|e| format!("{}: {e}", from.display()))?;
    for entry in entries {
        let path: PathBuf = entry.map_err(|e| format!("{}: {e}", from.display()))?.path();
        let target = to.join(path.file_name().expect("a folder's entry has a name"));
        if path.is_dir() {
            std::fs::create_dir_all(&target).map_err(|e| format!("{}: {e}", target.display()))?;
            copy_folder(&path, &target)?;
        } else {
            std::fs::copy(&path, &target).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    Ok(())
}
