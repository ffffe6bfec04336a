//! Which lines of a batch have their kernels compiled ahead: while line k renders, threads
//! compile the kernels of lines k + 1 ..= k + `ahead`, each line taken once and in order, so
//! that a driver that compiles slowly (lavapipe: a second or more a kernel) does so on every
//! core instead of on one while the rest wait (docs/SPEC.md §6, docs/performance.md).

use std::sync::{Condvar, Mutex, PoisonError};

/// The lines a batch's compiling threads may take, shared between them and the batch.
pub struct Lookahead {
    state: Mutex<State>,
    changed: Condvar,
    /// Lines in the batch.
    lines: usize,
    /// How far past the line rendering a thread may compile.
    ahead: usize,
}

struct State {
    /// The line rendering now (its own render compiles what it needs).
    rendering: usize,
    /// The next line no thread has taken.
    next: usize,
    /// The batch is over: threads take nothing more.
    over: bool,
}

impl Lookahead {
    /// Before the first line starts: nothing may be taken yet.
    pub fn new(lines: usize, ahead: usize) -> Lookahead {
        let state = State { rendering: 0, next: 1, over: false };
        Lookahead { state: Mutex::new(state), changed: Condvar::new(), lines, ahead }
    }

    /// Line `k` starts rendering: lines up to `k + ahead` may be taken, and those up to `k`
    /// no longer need to be.
    pub fn starting(&self, k: usize) {
        let mut state = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        state.rendering = k;
        state.next = state.next.max(k + 1);
        self.changed.notify_all();
    }

    /// The batch is over: threads waiting for a line stop.
    pub fn finish(&self) {
        self.state.lock().unwrap_or_else(PoisonError::into_inner).over = true;
        self.changed.notify_all();
    }

    /// The next line to compile, once one is within reach; `None` when there is none left or
    /// the batch is over.
    pub fn take(&self) -> Option<usize> {
        let state = self.state.lock().unwrap_or_else(PoisonError::into_inner);
        let reachable = |s: &mut State| s.over || s.next >= self.lines || s.next <= s.rendering + self.ahead;
        let mut state = self.changed.wait_while(state, |s| !reachable(s)).unwrap_or_else(PoisonError::into_inner);
        if state.over || state.next >= self.lines {
            return None;
        }
        state.next += 1;
        Some(state.next - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_taken_in_order_within_reach_and_never_twice() {
        let lookahead = Lookahead::new(6, 2);
        lookahead.starting(0);
        assert_eq!((lookahead.take(), lookahead.take()), (Some(1), Some(2)));
        // Line 3 is out of reach until line 1 starts; line 2 starting skips nothing taken.
        lookahead.starting(1);
        assert_eq!(lookahead.take(), Some(3));
        // A line that starts before its turn is not compiled ahead: its render does it.
        lookahead.starting(5);
        assert_eq!(lookahead.take(), None);
    }

    #[test]
    fn a_waiting_thread_stops_when_the_batch_ends() {
        let lookahead = Lookahead::new(10, 1);
        lookahead.starting(0);
        assert_eq!(lookahead.take(), Some(1));
        std::thread::scope(|scope| {
            let waiting = scope.spawn(|| lookahead.take());
            lookahead.finish();
            assert_eq!(waiting.join().unwrap(), None);
        });
    }
}
