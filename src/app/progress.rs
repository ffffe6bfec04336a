//! The progress bar of long work (rows of a render, lines of a batch): on stderr, only when
//! stderr is a terminal, and only once the work has run for about a second, so that short
//! renders, scripts and the course's command lines print nothing.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

/// How long work runs before its bar appears. The length of a render is not known in
/// advance (the first tile may wait for the kernel's compilation), so the bar waits.
const SHOW_AFTER: Duration = Duration::from_secs(1);

/// A progress bar that is drawn only if the work outlasts [`SHOW_AFTER`]; cleared when
/// dropped.
pub struct Progress {
    bar: ProgressBar,
    /// Dropped when the work ends, which tells `shower` not to show the bar.
    done: Option<mpsc::Sender<()>>,
    shower: Option<JoinHandle<()>>,
}

impl Progress {
    /// A bar over `total` `unit`s (for example "rows"), drawn on stderr when `wanted` and
    /// stderr is a terminal.
    pub fn new(wanted: bool, total: u64, unit: &str) -> Progress {
        if !wanted || !std::io::stderr().is_terminal() {
            return Progress::off();
        }
        Progress::delayed(total, unit, SHOW_AFTER, ProgressDrawTarget::stderr)
    }

    /// No bar at all.
    pub fn off() -> Progress {
        Progress { bar: ProgressBar::hidden(), done: None, shower: None }
    }

    fn delayed(
        total: u64,
        unit: &str,
        after: Duration,
        target: impl FnOnce() -> ProgressDrawTarget + Send + 'static,
    ) -> Progress {
        let template = format!("{{elapsed:>4}} [{{wide_bar}}] {{pos}}/{{len}} {unit}, {{per_sec:0}}, {{eta}} left");
        let style = ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar());
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden()).with_style(style);
        let (done, wait) = mpsc::channel::<()>();
        let shown = bar.clone();
        let shower = std::thread::spawn(move || {
            if wait.recv_timeout(after) == Err(mpsc::RecvTimeoutError::Timeout) {
                shown.set_draw_target(target());
                // Ticks keep the elapsed time moving while one long tile renders.
                shown.enable_steady_tick(Duration::from_millis(200));
            }
        });
        Progress { bar, done: Some(done), shower: Some(shower) }
    }

    /// `n` more units done.
    pub fn advance(&self, n: u64) {
        self.bar.inc(n);
    }

    /// Runs `f` (which prints on stderr) with the bar cleared, then draws it again.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        drop(self.done.take());
        if let Some(shower) = self.shower.take() {
            let _ = shower.join();
        }
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use indicatif::TermLike;
    use std::sync::{Arc, Mutex};

    /// A terminal that records what is written to it.
    #[derive(Debug, Clone, Default)]
    struct Recorder(Arc<Mutex<String>>);

    impl TermLike for Recorder {
        fn width(&self) -> u16 {
            100
        }
        fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn write_line(&self, s: &str) -> std::io::Result<()> {
            self.write_str(&format!("{s}\n"))
        }
        fn write_str(&self, s: &str) -> std::io::Result<()> {
            self.0.lock().unwrap().push_str(s);
            Ok(())
        }
        fn clear_line(&self) -> std::io::Result<()> {
            Ok(())
        }
        fn flush(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn recorded(after: Duration, work: Duration) -> String {
        let term = Recorder::default();
        let target = term.clone();
        let progress = Progress::delayed(40, "rows", after, move || ProgressDrawTarget::term_like(Box::new(target)));
        progress.advance(10);
        std::thread::sleep(work);
        progress.advance(10);
        std::thread::sleep(Duration::from_millis(300));
        drop(progress);
        let text = term.0.lock().unwrap().clone();
        text
    }

    #[test]
    fn long_work_shows_rows_rate_and_time_left() {
        let text = recorded(Duration::from_millis(50), Duration::from_millis(200));
        assert!(text.contains("20/40 rows"), "{text:?}");
        assert!(text.contains("/s") && text.contains("left"), "{text:?}");
    }

    #[test]
    fn short_work_shows_nothing() {
        let term = Recorder::default();
        let target = term.clone();
        let progress = Progress::delayed(40, "rows", Duration::from_secs(5), move || {
            ProgressDrawTarget::term_like(Box::new(target))
        });
        progress.advance(40);
        drop(progress);
        assert_eq!(term.0.lock().unwrap().as_str(), "");
    }
}
