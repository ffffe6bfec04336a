//! Compression the writers hand to a pool of threads and take back in the order they handed
//! it: PNG strips and EXR blocks are compressed on every core and written one after another.

use std::collections::VecDeque;
use std::sync::mpsc::{sync_channel, Receiver};

/// Jobs started on the writers' pool, their results taken in the order they started. A few
/// per thread wait at most, so memory stays bounded however large the image.
pub(super) struct InOrder<T> {
    /// The jobs not yet taken, oldest first.
    pending: VecDeque<Receiver<T>>,
}

impl<T: Send + 'static> InOrder<T> {
    pub(super) fn new() -> InOrder<T> {
        InOrder { pending: VecDeque::new() }
    }

    /// Starts `job` on the pool (where there is none, runs it here), then hands `done` the
    /// oldest results, in order, while more than two per thread are pending.
    pub(super) fn start<E: From<std::io::Error>>(
        &mut self,
        job: impl FnOnce() -> T + Send + 'static,
        mut done: impl FnMut(T) -> Result<(), E>,
    ) -> Result<(), E> {
        let Some(pool) = writer_pool() else { return done(job()) };
        let (send, receive) = sync_channel(1);
        pool.spawn(move || drop(send.send(job())));
        self.pending.push_back(receive);
        while self.pending.len() > pool.current_num_threads() + 2 {
            done(self.oldest()?)?;
        }
        Ok(())
    }

    /// Hands `done` every result still pending, in order.
    pub(super) fn finish<E: From<std::io::Error>>(
        &mut self,
        mut done: impl FnMut(T) -> Result<(), E>,
    ) -> Result<(), E> {
        while !self.pending.is_empty() {
            done(self.oldest()?)?;
        }
        Ok(())
    }

    fn oldest(&mut self) -> std::io::Result<T> {
        let oldest = self.pending.pop_front().expect("a job is pending");
        oldest.recv().map_err(|_| std::io::Error::other("a compressing thread stopped"))
    }
}

/// The threads that compress, one per core, made on first use; none where threads cannot be
/// made (wasm), and the caller then compresses. Their own pool, not rayon's global one, whose
/// threads may be the very caller waiting for a result.
fn writer_pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    POOL.get_or_init(|| rayon::ThreadPoolBuilder::new().thread_name(|k| format!("image-compress-{k}")).build().ok())
        .as_ref()
}
