//! Two pieces of work at once where there are threads (the kernel compiles while the scene
//! uploads, [`super::PreparedScene`]); one after the other in a browser.

/// `a` and `b` at once, `a` on a thread of its own, where there are threads; in a browser,
/// or where the system refuses a thread, one after the other.
#[cfg(not(target_arch = "wasm32"))]
pub(super) fn in_parallel<A: Send, B>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B) -> (A, B) {
    // Taken by whichever thread runs it: a thread that is refused never does.
    fn run<A, F: FnOnce() -> A>(f: &std::sync::Mutex<Option<F>>) -> Option<A> {
        f.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take().map(|f| f())
    }
    let a = std::sync::Mutex::new(Some(a));
    std::thread::scope(|scope| {
        let thread = std::thread::Builder::new().name("compile".into()).spawn_scoped(scope, || run(&a));
        let b = b();
        let ran = match thread {
            Ok(thread) => thread.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            Err(_) => None,
        };
        (ran.or_else(|| run(&a)).expect("`a` runs on one thread or the other"), b)
    })
}

#[cfg(target_arch = "wasm32")]
pub(super) fn in_parallel<A, B>(a: impl FnOnce() -> A, b: impl FnOnce() -> B) -> (A, B) {
    (a(), b())
}
