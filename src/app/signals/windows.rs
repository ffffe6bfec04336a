//! Windows: the console's events, Ctrl-C and Ctrl-Break, the console window closed, logoff
//! and shutdown. A process started with Ctrl-C ignored (`SetConsoleCtrlHandler(NULL, TRUE)`,
//! inherited) keeps ignoring it: the system then calls no handler for it.
//!
//! Not the `ctrlc` crate: its handler returns at once and does the work on another thread,
//! but for a closed console the system ends the process as soon as a handler returns, so
//! the clean-up would race the end. Here it runs in the handler itself.

use crate::app::interrupt::Interrupt;
use windows_sys::core::BOOL;
use windows_sys::Win32::System::Console::{
    SetConsoleCtrlHandler, CTRL_BREAK_EVENT, CTRL_CLOSE_EVENT, CTRL_C_EVENT, CTRL_LOGOFF_EVENT, CTRL_SHUTDOWN_EVENT,
};
use windows_sys::Win32::System::Threading::{GetCurrentProcess, TerminateProcess};

// `Interrupt::from_console_event` reads wincon.h's numbers; these are the platform's.
const _: () = assert!(
    CTRL_C_EVENT == 0
        && CTRL_BREAK_EVENT == 1
        && CTRL_CLOSE_EVENT == 2
        && CTRL_LOGOFF_EVENT == 5
        && CTRL_SHUTDOWN_EVENT == 6
);

const TRUE: BOOL = 1;
const FALSE: BOOL = 0;

pub fn clean_up_on_interrupt() -> std::io::Result<()> {
    // SAFETY: the handler is a function of the program, valid for as long as it runs.
    if unsafe { SetConsoleCtrlHandler(Some(on_console_event), TRUE) } == FALSE {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// Called on a thread the system starts for the event, so it may lock and write files like
/// any thread. It ends the process itself; a second event meanwhile waits on the clean-up.
unsafe extern "system" fn on_console_event(event: u32) -> BOOL {
    let Some(interrupt) = Interrupt::from_console_event(event) else {
        return FALSE; // not ours: the next handler's (in the end, the system's default)
    };
    let status = super::clean_up(interrupt);
    // TerminateProcess rather than ExitProcess, as `_exit` on Unix: no DLL detach runs the
    // GPU driver's teardown under the feet of its own worker threads.
    // SAFETY: ends this process; GetCurrentProcess's pseudo-handle needs no closing.
    unsafe { TerminateProcess(GetCurrentProcess(), status.into()) };
    TRUE
}
