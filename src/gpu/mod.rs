//! The GPU backend: a WGSL compute kernel driven through wgpu, headless.
//!
//! A [`GpuRenderer`] owns the device (created once per process, reused for any number of
//! scenes) and a cache of kernels specialised by `override` constants ([`KernelConfig`]).
//! [`GpuRenderer::prepare`] flattens a scene ([`flatten`], into the structs of [`layout`]),
//! uploads it and binds it once; the [`PreparedScene`] then dispatches the kernel
//! ([`shader`]; an invocation per pixel, or per packet of pixels with bins) in tiles of rows
//! (so memory is bounded by the tile, not the frame), reading tile k back while the device
//! renders tile k + 1, and hands the pixels the kernel marks over to the reference.
//!
//! This file is the façade: each room below holds one concern, from the bottom up:
//! `options`, `error` and `stats` (what a caller passes and gets back); `bindings` (the
//! kernel's bindings, by name); `kernel` (its configuration); `renderer` (the device and
//! its compiled kernels); `upload`, `tiles`, `dispatch` and `readback` (a scene's buffers,
//! its tiles in flight, a tile's dispatch, what the host reads back); `handover` (pixels
//! given to the reference); `prepared` (a scene made ready), `aim` (the same scene pointed
//! at a moved camera without preparing it again) and `tile_loop` (its tiles rendered, on a
//! thread of ours or awaited in a browser); `present` (its tiles drawn onto
//! a texture on the device, for the live window); `first_dispatch` and `ahead` (a batch's
//! next kernels compiled ahead, on lavapipe on twin devices).

mod ahead;
mod aim;
mod bindings;
pub mod binning;
mod dispatch;
mod error;
pub mod finite;
mod first_dispatch;
pub mod flatten;
pub mod fuse;
mod handover;
mod kernel;
pub mod layout;
mod oneshot;
mod options;
mod ordered;
mod parallel;
pub mod pipeline_cache;
pub mod precision;
mod precision_error;
mod prepared;
#[cfg(not(target_arch = "wasm32"))]
mod present;
pub mod ray_tree;
mod readback;
mod renderer;
pub mod shader;
mod specialise;
mod stats;
pub mod texture_range;
mod tile_loop;
mod tiles;
pub mod unsupported;
mod upload;
pub mod voxels;
mod workgroup;

pub use ahead::Ahead;
pub use aim::{Aimed, DetachedScene};
pub use bindings::Binding;
pub use error::GpuError;
pub use kernel::{KernelConfig, Stage, SHARED_KERNEL_MAX_SAMPLES};
pub use options::{Acceleration, GpuOptions, MAX_TILE_BYTES, TILE_MIB_VARIABLE, TILE_SLOTS, TILE_SLOTS_VARIABLE};
pub use prepared::PreparedScene;
#[cfg(not(target_arch = "wasm32"))]
pub use present::{Presented, Presenter};
pub use readback::ReadTile;
pub use renderer::GpuRenderer;
pub use tiles::MAX_SAMPLE_BYTES;
pub use workgroup::{BIN_PACKET, WORKGROUP};
