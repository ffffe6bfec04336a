//! The `raycaster` command: parses the command line and hands it to the library. What the
//! command does is `app::command::run`, which the Python package compiles too; this file is
//! what only a process of its own does: Mesa's settings, the interrupt handlers, the exit status.

mod app;

use app::exit::{self, Failure};
use std::process::ExitCode;

/// The one place an error ends the command: it is printed once, as `raycaster: ERROR`, and
/// its kind sets the exit status (2 usage, 1 failure; the interrupt handler reports 130/143 the
/// same way).
fn main() -> ExitCode {
    // Inside a sandbox of `grade --run`, as its first process: nothing else of ours runs.
    #[cfg(target_os = "linux")]
    if let Some(status) = app::grade::keeper::main_if_asked() {
        return ExitCode::from(status);
    }
    app::command::give_mesa_a_runtime_dir();
    app::command::split_lavapipe_dispatches_finer();
    let handled =
        app::signals::clean_up_on_interrupt().map_err(|e| Failure::Failed(format!("cannot handle interrupts: {e}")));
    match handled.and_then(|()| app::command::run(std::env::args_os().skip(1))) {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => ExitCode::from(exit::report(&failure)),
    }
}
