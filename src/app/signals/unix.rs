//! Unix: SIGINT (Ctrl-C), SIGTERM and SIGHUP. A signal the process was started with ignored
//! stays ignored, as `nohup` and the background jobs of shell scripts expect.

use crate::app::interrupt::Interrupt;
use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

// The interrupts' statuses are computed from POSIX's numbers; these are the platform's.
const _: () = assert!(SIGHUP == 1 && SIGINT == 2 && SIGTERM == 15);

/// Starts a thread that waits for the signals and handles the first one. It ends the
/// process from that thread at once, whatever the main thread is doing (rendering a tile
/// for seconds, or waiting on the GPU), rather than asking the main thread to stop.
pub fn clean_up_on_interrupt() -> std::io::Result<()> {
    let mut signals = Signals::new([SIGINT, SIGTERM, SIGHUP].into_iter().filter(|&s| !ignored(s)))?;
    std::thread::Builder::new().name("signals".into()).spawn(move || {
        if let Some(interrupt) = signals.forever().find_map(Interrupt::from_signal) {
            let status = super::clean_up(interrupt);
            // `_exit`: no atexit handlers, which could run Mesa's teardown under the feet of
            // its own worker threads.
            signal_hook::low_level::exit(status.into());
        }
    })?;
    Ok(())
}

/// Whether `signal` is ignored (`SIG_IGN`): a handler installed over that would undo the
/// choice of whoever started us.
fn ignored(signal: i32) -> bool {
    // SAFETY: a zeroed `sigaction` is a valid value (integers, a pointer-sized handler, a
    // signal set), and with a null new action the call only reads the current one into it.
    unsafe {
        let mut current: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal, std::ptr::null(), &mut current) == 0 && current.sa_sigaction == libc::SIG_IGN
    }
}
