//! How the command ends. Every error reaches `main` as a [`Failure`], which carries its exit
//! status, and is reported there in one place; the interrupt handler reports through the same
//! function. Writing to a closed stdout or stderr (`raycaster --help | head -1`) is not an
//! error: the text is dropped and the command goes on to its own verdict.

use crate::app::args::UsageError;
use crate::app::interrupt::Interrupt;
use crate::app::job;
use raycaster::gpu::GpuError;
use std::io::Write;

/// Why the command failed, with the exit status each reason gets.
#[derive(Debug, thiserror::Error)]
pub enum Failure {
    /// A bad command line: status 2, and nothing was rendered.
    #[error(transparent)]
    Usage(#[from] UsageError),
    /// A scene, GPU or image file error: status 1.
    #[error(transparent)]
    Job(#[from] job::Error),
    /// A teacher's input that cannot be used as it is (an assignment's `commands.txt`
    /// naming a file outside its folder, a program no sandbox can run): status 2, like a bad
    /// command line, and nothing was run.
    #[error("{0}")]
    BadInput(String),
    /// Anything else that failed (compare's verdict, lines of a batch, the bench): status 1.
    #[error("{0}")]
    Failed(String),
    /// Interrupted (Ctrl-C, SIGTERM, a closed console...): 130, 143 or 129, the shells'
    /// convention.
    #[error("interrupted by {}", .0.name())]
    Interrupted(Interrupt),
}

impl From<GpuError> for Failure {
    fn from(e: GpuError) -> Self {
        Failure::Job(e.into())
    }
}

impl Failure {
    pub fn status(&self) -> u8 {
        match self {
            Failure::Usage(_) | Failure::BadInput(_) => 2,
            Failure::Job(_) | Failure::Failed(_) => 1,
            Failure::Interrupted(interrupt) => interrupt.status(),
        }
    }
}

/// Prints `raycaster: FAILURE` on stderr and returns the exit status.
pub fn report(failure: &Failure) -> u8 {
    say(&failure.to_string());
    failure.status()
}

/// One line on stderr, `raycaster: ` first: the one way the command tells the user
/// something besides its output (errors, warnings, notes, `-v`'s lines, progress of
/// `bench`). A closed stderr is ignored: there is no one left to tell.
pub fn say(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "raycaster: {line}");
}

/// Text on stdout. A reader that has gone away (a closed pipe) drops the rest quietly; any
/// other write error (a full disk) is a failure.
pub fn print(text: &str) -> Result<(), Failure> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::Failed(format!("stdout: {e}"))),
        _ => Ok(()),
    }
}
