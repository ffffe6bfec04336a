//! Interrupts: Ctrl-C, and whatever else the platform sends a program it wants ended (SIGTERM
//! and SIGHUP on Unix; a closed console, logoff and shutdown on Windows), remove the
//! temporary files of every image being written, render or batch alike, and grade's private
//! folders (killing the student's program first), and end the process
//! with the status [`Interrupt::status`] gives it (130 for Ctrl-C). Each platform's module
//! only receives them; what happens then is [`clean_up`], the same everywhere.

use crate::app::exit::{self, Failure};
use crate::app::interrupt::Interrupt;

#[cfg(unix)]
mod unix;
#[cfg(unix)]
pub use unix::clean_up_on_interrupt;

#[cfg(windows)]
mod windows;
#[cfg(windows)]
pub use windows::clean_up_on_interrupt;

/// Removes the temporary file of every image being written, says on stderr what interrupted
/// the command, and returns the exit status. The caller ends the process with it at once:
/// no image can be written any more (see `remove_temporary_files_for_exit`).
fn clean_up(interrupt: Interrupt) -> u8 {
    raycaster::image_io::remove_temporary_files_for_exit();
    crate::app::scratch::remove_for_exit();
    exit::report(&Failure::Interrupted(interrupt))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;

    /// Where [`interrupted_child`] renders, set only when a test starts it.
    const CHILD_DIR: &str = "RAYCASTER_TEST_INTERRUPTED_CHILD_DIR";

    /// The Windows path, run here: what the console handler does on Ctrl-C. The clean-up
    /// leaves no image writable in its process, so it runs in a child, this test binary
    /// running [`interrupted_child`] only.
    #[test]
    fn ctrl_c_from_the_console_removes_the_temporary_files_and_ends_with_130() {
        let dir = tempfile::tempdir().unwrap();
        let test_path = module_path!().split_once("::").map_or(module_path!(), |(_crate, path)| path);
        let child = Command::new(std::env::current_exe().unwrap())
            .args(["--exact", &format!("{test_path}::interrupted_child"), "--ignored", "--nocapture"])
            .env(CHILD_DIR, dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&child.stderr);
        let what = format!("stdout: {}\nstderr: {stderr}", String::from_utf8_lossy(&child.stdout));
        assert_eq!(child.status.code(), Some(130), "{what}");
        assert!(stderr.contains("raycaster: interrupted by Ctrl-C\n"), "{what}");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert!(left.is_empty(), "left behind {left:?}");
    }

    /// An image's temporary file, then Ctrl-C as the console delivers it.
    #[test]
    #[ignore = "the child of the test above"]
    fn interrupted_child() {
        let Some(dir) = std::env::var_os(CHILD_DIR).map(std::path::PathBuf::from) else { return };
        let (_temp, _file) = raycaster::image_io::temp_beside(&dir.join("o.png")).unwrap();
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "the temporary file exists");
        let status = clean_up(Interrupt::from_console_event(0).unwrap());
        // Before the temporary file's own drop could remove it.
        std::process::exit(status.into());
    }
}
