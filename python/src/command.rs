//! `raycaster.run`: a command line run by the binary's own code (src/app/command.rs), in
//! this process, without the binary's interrupt handlers.

use crate::app;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::{Mutex, PoisonError};

pyo3::create_exception!(
    raycaster,
    CommandError,
    PyRuntimeError,
    "A command line that failed: `str(e)` is the binary's message (without its `raycaster: `), \
     `status` its exit status (2: a bad command line; 1: a scene, GPU or file error)."
);

/// One command line with a working folder of its own at a time: the working folder is the
/// process's.
static IN_FOLDER: Mutex<()> = Mutex::new(());

#[pyfunction]
#[pyo3(signature = (args, cwd = None))]
pub fn run(py: Python<'_>, args: Vec<OsString>, cwd: Option<PathBuf>) -> PyResult<()> {
    let outcome = py.detach(|| {
        let _one = IN_FOLDER.lock().unwrap_or_else(PoisonError::into_inner);
        let back = match &cwd {
            Some(dir) => {
                let here = std::env::current_dir().map_err(|e| format!("the working folder: {e}"))?;
                std::env::set_current_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
                Some(here)
            }
            None => None,
        };
        let outcome = app::command::run(args).map_err(|failure| (failure.to_string(), failure.status()));
        if let Some(here) = back {
            std::env::set_current_dir(&here).map_err(|e| format!("{}: {e}", here.display()))?;
        }
        Ok::<_, String>(outcome)
    });
    match outcome {
        Ok(Ok(())) => Ok(()),
        Ok(Err((message, status))) => Err(command_error(py, message, status)),
        Err(message) => Err(command_error(py, message, 1)),
    }
}

fn command_error(py: Python<'_>, message: String, status: u8) -> PyErr {
    let err = CommandError::new_err(message);
    match err.value(py).setattr("status", status) {
        Ok(()) => err,
        Err(failed) => failed,
    }
}
