//! A one-shot future: a value sent once from a callback to the task that awaits it. wgpu
//! reports a buffer map through a callback, which a browser runs from its event loop, so
//! the renderer awaits it there rather than block ([`super::PreparedScene::render_async`]).
//! A future of our own, a dozen lines, rather than an executor crate's channel.

use std::future::Future;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};

/// The receiving end; a clone is the sending end, which [`OneShot::send`] consumes.
pub(super) struct OneShot<T>(Arc<Mutex<State<T>>>);

/// The value once sent, and the task to wake then.
struct State<T> {
    value: Option<T>,
    waker: Option<Waker>,
}

impl<T> Default for OneShot<T> {
    fn default() -> Self {
        OneShot(Arc::new(Mutex::new(State { value: None, waker: None })))
    }
}

impl<T> Clone for OneShot<T> {
    fn clone(&self) -> Self {
        OneShot(Arc::clone(&self.0))
    }
}

impl<T> OneShot<T> {
    pub fn send(self, value: T) {
        let waker = {
            let mut state = self.0.lock().unwrap_or_else(|e| e.into_inner());
            state.value = Some(value);
            state.waker.take()
        };
        if let Some(waker) = waker {
            waker.wake();
        }
    }
}

impl<T> Future for OneShot<T> {
    type Output = T;

    fn poll(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<T> {
        let mut state = self.0.lock().unwrap_or_else(|e| e.into_inner());
        match state.value.take() {
            Some(value) => Poll::Ready(value),
            None => {
                state.waker = Some(cx.waker().clone());
                Poll::Pending
            }
        }
    }
}
