//! What can interrupt the command, whichever way the platform delivers it (a Unix signal, a
//! Windows console event), and the exit status each one ends with. Plain numbers in, so that
//! the mapping of both platforms is tested wherever the tests run; [`signals`] receives the
//! interrupts and checks these numbers against the platform's own constants.
//!
//! [`signals`]: crate::app::signals

/// An interrupt as the platform delivered it.
// A build sees only its own platform's kind, the tests both.
#[cfg_attr(not(test), allow(dead_code))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interrupt {
    Sigint,
    Sigterm,
    Sighup,
    CtrlC,
    CtrlBreak,
    ConsoleClosed,
    Logoff,
    Shutdown,
}

#[cfg_attr(not(test), allow(dead_code))]
impl Interrupt {
    /// The signals handled on Unix. POSIX fixes these three numbers (`kill -1`, `-2`, `-15`),
    /// so they are the same on Linux and macOS.
    pub fn from_signal(number: i32) -> Option<Interrupt> {
        match number {
            1 => Some(Interrupt::Sighup),
            2 => Some(Interrupt::Sigint),
            15 => Some(Interrupt::Sigterm),
            _ => None,
        }
    }

    /// The console events handled on Windows, by their `CTRL_*_EVENT` numbers (wincon.h).
    pub fn from_console_event(event: u32) -> Option<Interrupt> {
        match event {
            0 => Some(Interrupt::CtrlC),
            1 => Some(Interrupt::CtrlBreak),
            2 => Some(Interrupt::ConsoleClosed),
            5 => Some(Interrupt::Logoff),
            6 => Some(Interrupt::Shutdown),
            _ => None,
        }
    }

    /// 128 + the number of the Unix signal it stands for: the shells' convention (130 for
    /// Ctrl-C), kept on Windows too so that a script tells an interrupted render from a failed
    /// one (status 1) the same way everywhere.
    pub fn status(self) -> u8 {
        128 + self.unix_counterpart()
    }

    /// The signal a Unix system sends for the same act: a key that interrupts, a terminal (or
    /// session) that goes away, a system that asks programs to end before it stops.
    fn unix_counterpart(self) -> u8 {
        const SIGHUP: u8 = 1;
        const SIGINT: u8 = 2;
        const SIGTERM: u8 = 15;
        match self {
            Interrupt::Sigint | Interrupt::CtrlC | Interrupt::CtrlBreak => SIGINT,
            Interrupt::Sighup | Interrupt::ConsoleClosed | Interrupt::Logoff => SIGHUP,
            Interrupt::Sigterm | Interrupt::Shutdown => SIGTERM,
        }
    }

    /// What the message names: "interrupted by NAME".
    pub fn name(self) -> &'static str {
        match self {
            Interrupt::Sigint => "SIGINT",
            Interrupt::Sigterm => "SIGTERM",
            Interrupt::Sighup => "SIGHUP",
            Interrupt::CtrlC => "Ctrl-C",
            Interrupt::CtrlBreak => "Ctrl-Break",
            Interrupt::ConsoleClosed => "closing the console",
            Interrupt::Logoff => "logging off",
            Interrupt::Shutdown => "the system shutting down",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ends(interrupt: Option<Interrupt>) -> Option<(u8, &'static str)> {
        interrupt.map(|i| (i.status(), i.name()))
    }

    #[test]
    fn unix_signals_end_with_128_plus_their_number() {
        assert_eq!(ends(Interrupt::from_signal(2)), Some((130, "SIGINT")));
        assert_eq!(ends(Interrupt::from_signal(15)), Some((143, "SIGTERM")));
        assert_eq!(ends(Interrupt::from_signal(1)), Some((129, "SIGHUP")));
        assert_eq!(Interrupt::from_signal(9), None);
    }

    /// Each console event ends as its Unix counterpart does: Ctrl-C with 130.
    #[test]
    fn windows_console_events_end_like_their_unix_counterparts() {
        assert_eq!(ends(Interrupt::from_console_event(0)), Some((130, "Ctrl-C")));
        assert_eq!(ends(Interrupt::from_console_event(1)), Some((130, "Ctrl-Break")));
        assert_eq!(ends(Interrupt::from_console_event(2)), Some((129, "closing the console")));
        assert_eq!(ends(Interrupt::from_console_event(5)), Some((129, "logging off")));
        assert_eq!(ends(Interrupt::from_console_event(6)), Some((143, "the system shutting down")));
        // 3 and 4 are not defined; a future event is left to the next handler.
        for unknown in [3, 4, 7] {
            assert_eq!(Interrupt::from_console_event(unknown), None, "{unknown}");
        }
    }
}
