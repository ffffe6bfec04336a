//! `grade --run COMMAND`: the student's program run on each command line, as the course
//! runs it (inside the assignment's folder, the line's words after the program), in a fresh
//! working folder holding only the line's scene and meshes, within limits. On Linux it runs
//! in a [`Sandbox`]; elsewhere, or with `--no-sandbox`, with the teacher's rights. Whatever
//! the program does (crash, hang, write nothing, cheat) becomes an outcome of the line,
//! never an error of the grader.

use crate::app::args::{LimitKind, Limits, RunArgs};
use crate::app::grade::course::{self, CourseLine};
#[cfg(target_os = "linux")]
use crate::app::grade::sandbox::Sandbox;
use crate::app::grade::untrusted;
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

/// A line's run: how it ended, the end of what it printed on stderr, the limits it hit,
/// and where each of its outputs can be read (a folder and a name under it), or why not.
pub struct Run {
    pub ending: Ending,
    pub stderr_tail: String,
    pub hits: Vec<LimitKind>,
    pub outputs: Vec<Result<(PathBuf, PathBuf), String>>,
    /// The line's own folder (outbox or working folder), removed with the run.
    _folder: LineFolder,
}

/// A folder of one line's, removed when the line has been judged.
struct LineFolder(PathBuf);

impl Drop for LineFolder {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The teacher's folders a program must not see, even inside its own folders.
// Only Linux's sandbox reads them; elsewhere there is none to hide them from.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
pub struct Hidden {
    /// Also never holding the program: the assignment's folder, grade's private folder.
    pub forbidden: Vec<PathBuf>,
    /// Hidden where a folder of the program's holds them; the program may be inside.
    pub masked: Vec<PathBuf>,
}

/// How the program is run.
enum Isolation {
    #[cfg(target_os = "linux")]
    Sandboxed(Sandbox),
    /// `--no-sandbox`: with the teacher's rights, in a folder of its own, within the limits
    /// a process can set on itself (no process count, no folder size).
    Trusted,
}

/// The student's program, ready to run lines.
pub struct Student {
    /// The program and its own arguments, paths made absolute.
    words: Vec<String>,
    isolation: Isolation,
    limits: Limits,
    /// `--env`'s variables, `NAME=VALUE`.
    env: Vec<String>,
    assignment: PathBuf,
    /// grade's private folder, where each line's folder is made.
    scratch: PathBuf,
}

impl Student {
    /// The program `run` names, for the lines of `assignment`; `hidden` are the folders it
    /// must not see. `Err`: no sandbox can be made (and `--no-sandbox` was not given), or the
    /// program's folder cannot be given to it.
    pub fn new(assignment: &Path, run: &RunArgs, scratch: &Path, hidden: &Hidden) -> Result<Student, String> {
        let words = absolute_words(&run.command);
        let isolation = if run.trusted { Isolation::Trusted } else { sandboxed(run, &words, hidden, scratch)? };
        Ok(Student {
            words,
            isolation,
            limits: run.limits,
            env: run.env.clone(),
            assignment: assignment.to_path_buf(),
            scratch: scratch.to_path_buf(),
        })
    }

    /// Runs the program on `line`.
    pub fn run(&self, line: &CourseLine) -> Run {
        let folder = LineFolder(self.scratch.join(format!("line-{}", line.number)));
        let _ = std::fs::remove_dir_all(&folder.0);
        let mut words = self.words.clone();
        words.extend(line.student_words());
        let inputs = course::inputs_of(line, &self.assignment);
        let (ending, stderr_tail, hits, outputs) = match &self.isolation {
            #[cfg(target_os = "linux")]
            Isolation::Sandboxed(sandbox) => in_sandbox(sandbox, line, &inputs, &words, &folder.0, self.limits),
            Isolation::Trusted => trusted(&inputs, &line.images, &words, &folder.0, &self.limits, &self.env),
        };
        Run { ending, stderr_tail, hits, outputs, _folder: folder }
    }
}

type Outcome = (Ending, String, Vec<LimitKind>, Vec<Result<(PathBuf, PathBuf), String>>);

#[cfg(target_os = "linux")]
fn sandboxed(run: &RunArgs, words: &[String], hidden: &Hidden, scratch: &Path) -> Result<Isolation, String> {
    Sandbox::new(run, words, hidden, scratch).map(Isolation::Sandboxed)
}

#[cfg(not(target_os = "linux"))]
fn sandboxed(_: &RunArgs, _: &[String], _: &Hidden, _: &Path) -> Result<Isolation, String> {
    Err(format!(
        "no sandbox on {}: grade's sandbox is Linux's namespaces (bubblewrap); run it on Linux, in a Linux \
         virtual machine or WSL 2",
        std::env::consts::OS
    ))
}

/// The line in a fresh sandbox, its outputs read from the outbox the keeper filled.
#[cfg(target_os = "linux")]
fn in_sandbox(
    sandbox: &Sandbox,
    line: &CourseLine,
    inputs: &[(PathBuf, PathBuf)],
    words: &[String],
    outbox: &Path,
    limits: Limits,
) -> Outcome {
    let run = sandbox.run(inputs, &line.images, words, outbox, &mut crate::app::scratch::set_running_group);
    let (status, stderr) = match run {
        Ok((finished, stderr)) => (finished.status, stderr),
        Err(why) => (Err(why), String::new()),
    };
    let status = match status {
        Ok(status) => status,
        Err(why) => {
            let missing = line.images.iter().map(|_| Err("no file written".to_string())).collect();
            return (Ending::Failed(format!("ran in a sandbox that failed: {why}")), stderr, Vec::new(), missing);
        }
    };
    let mut ending = Ending::Failed("ended without saying how".into());
    let mut hits = Vec::new();
    let mut outputs: Vec<Result<(PathBuf, PathBuf), String>> =
        line.images.iter().map(|_| Err("no file written".to_string())).collect();
    for text in status.lines() {
        let (key, rest) = text.split_once(' ').unwrap_or((text, ""));
        match key {
            "ended" => ending = keeper_ending(rest, limits.wall),
            "hit" => hits.extend(LimitKind::named(rest)),
            "output" => {
                let (k, outcome) = rest.split_once(' ').unwrap_or((rest, ""));
                if let Some(slot) = k.parse::<usize>().ok().and_then(|k| outputs.get_mut(k)) {
                    *slot = match outcome {
                        "copied" => Ok((outbox.to_path_buf(), PathBuf::from(k))),
                        why if why.starts_with("no file") => Err("no file written".into()),
                        why => Err(why.to_string()),
                    };
                }
            }
            _ => {}
        }
    }
    (ending, stderr, hits, outputs)
}

/// The keeper's `ended …` line as an [`Ending`].
#[cfg(target_os = "linux")]
fn keeper_ending(text: &str, wall: f64) -> Ending {
    let (how, rest) = text.split_once(' ').unwrap_or((text, ""));
    match how {
        "exited" if rest == "0" => Ending::Finished,
        "exited" => Ending::Failed(format!("exited with status {rest}")),
        "signal" => Ending::Failed(format!("was killed by signal {rest}")),
        "killed" => Ending::TimedOut(wall),
        "not-started" => Ending::NotStarted(rest.to_string()),
        _ => Ending::Failed(format!("ended oddly: {text}")),
    }
}

/// The line run with the teacher's rights, in `folder`.
fn trusted(
    inputs: &[(PathBuf, PathBuf)],
    images: &[PathBuf],
    words: &[String],
    folder: &Path,
    limits: &Limits,
    env: &[String],
) -> Outcome {
    let missing = || images.iter().map(|_| Err("no file written".to_string())).collect();
    if let Err(why) = copy_inputs(inputs, folder) {
        return (Ending::NotStarted(why), String::new(), Vec::new(), missing());
    }
    let work = folder.join("work");
    let _ = std::fs::create_dir_all(&work);
    let (ending, stderr, hits) = match start(words, &work, limits, env) {
        Ok((child, tail)) => {
            crate::app::scratch::set_running_group(Some(child.id()));
            let (ending, hits) = wait(child, limits);
            crate::app::scratch::set_running_group(None);
            (ending, tail.finish(), hits)
        }
        Err(why) => (Ending::NotStarted(why), String::new(), Vec::new()),
    };
    let outputs = images.iter().map(|name| Ok((work.clone(), name.clone()))).collect();
    (ending, stderr, hits, outputs)
}

fn copy_inputs(inputs: &[(PathBuf, PathBuf)], folder: &Path) -> Result<(), String> {
    std::fs::create_dir_all(folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    // The line runs in `folder/work`, so that a scene named `../scene.txt` has a place.
    for (host, relative) in inputs {
        let Some(target) = untrusted::lexically_beneath(folder, &Path::new("work").join(relative)) else { continue };
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
        }
        std::fs::copy(host, &target).map_err(|e| format!("{}: {e}", host.display()))?;
    }
    Ok(())
}

fn start(
    words: &[String],
    folder: &Path,
    limits: &Limits,
    env: &[String],
) -> Result<(Child, super::stderr::Tail), String> {
    let (program, args) = words.split_first().ok_or("--run names no program")?;
    let (stderr, tail) = super::stderr::capture().map_err(|e| format!("a pipe for stderr: {e}"))?;
    let mut command = Command::new(program);
    command.args(args).current_dir(folder);
    command.envs(env.iter().map(|var| var.split_once('=').unwrap_or((var, ""))));
    command.stdin(Stdio::null()).stdout(Stdio::null()).stderr(stderr);
    own_limits(&mut command, limits);
    let child = command.spawn().map_err(|e| format!("{program}: {e}"))?;
    Ok((child, tail))
}

/// Waits for `child` until the wall time, then kills it; kills what it left behind in its
/// process group either way.
fn wait(mut child: Child, limits: &Limits) -> (Ending, Vec<LimitKind>) {
    let start = Instant::now();
    let wall = Duration::from_secs_f64(limits.wall);
    loop {
        match child.try_wait() {
            Ok(Some(status)) => {
                kill_group(&mut child);
                return (ended(status), signal_hits(status));
            }
            Ok(None) if start.elapsed() >= wall => {
                kill_group(&mut child);
                return (Ending::TimedOut(limits.wall), vec![LimitKind::Wall]);
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(2)),
            Err(e) => {
                kill_group(&mut child);
                return (Ending::Failed(format!("could not be waited for: {e}")), Vec::new());
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

#[cfg(unix)]
fn signal_hits(status: ExitStatus) -> Vec<LimitKind> {
    use std::os::unix::process::ExitStatusExt;
    match status.signal() {
        Some(libc::SIGXCPU) => vec![LimitKind::Cpu],
        Some(libc::SIGXFSZ) => vec![LimitKind::File],
        _ => Vec::new(),
    }
}

#[cfg(not(unix))]
fn signal_hits(_: ExitStatus) -> Vec<LimitKind> {
    Vec::new()
}

/// The program leads a process group of its own (so that the processes it started go
/// with it), with the limits a process can set on itself.
#[cfg(unix)]
fn own_limits(command: &mut Command, limits: &Limits) {
    use std::os::unix::process::CommandExt;
    command.process_group(0);
    let limits = *limits;
    // SAFETY: only setrlimit, which is async-signal-safe, between fork and exec.
    unsafe {
        command.pre_exec(move || {
            for (resource, value) in [
                (libc::RLIMIT_CPU, limits.cpu),
                (libc::RLIMIT_AS, limits.memory),
                (libc::RLIMIT_FSIZE, limits.file),
                (libc::RLIMIT_CORE, 0),
            ] {
                let limit = libc::rlimit { rlim_cur: value as libc::rlim_t, rlim_max: value as libc::rlim_t };
                if libc::setrlimit(resource, &limit) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
            }
            Ok(())
        });
    }
}

#[cfg(not(unix))]
fn own_limits(_: &mut Command, _: &Limits) {}

#[cfg(unix)]
pub fn kill_group(child: &mut Child) {
    // The group's id is the child's: it was made its leader.
    if let Ok(group) = libc::pid_t::try_from(child.id()) {
        // SAFETY: kill takes plain integers; a group that has already gone gives ESRCH.
        unsafe { libc::kill(-group, libc::SIGKILL) };
    }
    let _ = child.kill();
    let _ = child.wait();
}

#[cfg(not(unix))]
pub fn kill_group(child: &mut Child) {
    let _ = child.kill();
    let _ = child.wait();
}

/// `command` split at spaces, each word naming an existing path with a separator in it
/// (`./raytracer`, `student/rt.py`) made absolute: the line runs elsewhere. A bare name
/// (`python3`) is looked up where the program runs (in the sandbox: the system's `PATH`).
fn absolute_words(command: &str) -> Vec<String> {
    let mut words: Vec<String> = command.split_whitespace().map(str::to_string).collect();
    for word in &mut words {
        if word.contains(std::path::is_separator) {
            if let Ok(absolute) = Path::new(word.as_str()).canonicalize() {
                *word = absolute.to_string_lossy().into_owned();
            }
        }
    }
    words
}
