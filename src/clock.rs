//! The clock the library times its stages with. `std::time::Instant` panics in a browser
//! (wasm32-unknown-unknown has no clock of its own); there `web-time`'s reads the page's
//! `performance.now()`. Natively it is the standard one.

#[cfg(not(target_arch = "wasm32"))]
pub use std::time::Instant;
#[cfg(target_arch = "wasm32")]
pub use web_time::Instant;
