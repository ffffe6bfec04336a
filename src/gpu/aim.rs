//! A prepared scene pointed at another camera: what the live view does between frames, and
//! `bench`'s moving frames, instead of preparing the scene again (docs/SPEC.md §6, "A
//! camera moved").
//!
//! The kernel's values are camera-relative (docs/SPEC.md §6), so a moved camera moves every
//! primitive, every box and every bin: the scene is checked (the precision contract is the
//! new camera's), flattened and its bins built again, and written into the buffers it
//! already has. What stays is the rest of preparing: the kernel (compiled or looked up),
//! the buffers and their bindings, the tile slots, and the hierarchy's shape, whose boxes
//! are refitted ([`crate::bvh::Bvh::refit`]) instead of built again. A camera that changes
//! more (another kernel, lists longer than the slots hold, a larger buffer) prepares the
//! scene again, so an aimed scene renders what a scene prepared for that camera renders:
//! the same hits, but where two primitives meet a ray at exactly one distance and the kept
//! hierarchy visits the other first.

use super::dispatch::Dispatch;
use super::error::GpuError;
use super::prepared::{built, frame_params, frame_stats, kernel_config, ListsRoom, Planned, PreparedScene};
use super::upload::rewrite_inputs;
use crate::render::RenderStats;
use crate::scene::Scene;

/// How [`PreparedScene::aim`] met the new camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aimed {
    /// The scene's buffers written in place: no kernel, buffer or binding made.
    InPlace,
    /// Prepared again, as [`super::GpuRenderer::prepare`] prepares: the camera changed the
    /// kernel, or outgrew a buffer.
    Prepared,
}

impl<'a> PreparedScene<'a> {
    /// Points the scene at `scene`'s camera: `scene` is the scene this was prepared for,
    /// its camera moved, rendered with the same options. Refuses what
    /// [`super::GpuRenderer::prepare`] refuses for that camera (a sphere too far from it,
    /// `gpu::precision`), and then leaves the scene as it was.
    pub fn aim(&mut self, scene: &Scene) -> Result<Aimed, GpuError> {
        let start = crate::clock::Instant::now();
        let gpu: &'a super::GpuRenderer = self.dispatch.gpu;
        let (options, layout) = (self.dispatch.options, self.dispatch.layout);
        let Planned { traced, mut plan, mut buffers, .. } = Planned::new(gpu, scene, &options, layout)?;
        let tiling = built(gpu, scene, &options, layout, &mut buffers, &mut plan, self.kept.shape.as_ref())?;
        let config = kernel_config(gpu, &buffers, buffers.acceleration(), layout, &options, &traced);
        let same_kernel_and_slots = config == self.kept.config && tiling.fits(self.dispatch.tile_rows, self.kept.sizes);
        if !same_kernel_and_slots || !rewrite_inputs(gpu, &self.kept.inputs, &buffers)? {
            // A camera that moves on is likely to outgrow lists again: where the scene has
            // bins, the slots made again give its lists room to grow.
            *self = PreparedScene::new(gpu, scene, &options, layout, ListsRoom::Doubled)?;
            return Ok(Aimed::Prepared);
        }
        self.stats = RenderStats {
            scene_bytes: self.stats.scene_bytes,
            prepare_ms: start.elapsed().as_secs_f64() * 1e3,
            ..frame_stats(gpu, &buffers, &plan, &options)
        };
        self.dispatch.params = frame_params(&buffers, &options, &traced);
        self.dispatch.bins = buffers.bins.take();
        // Every slot's lists are the old camera's.
        for band in self.dispatch.slots.iter().filter_map(|slot| slot.buffers.bins.as_ref()) {
            *band.holds.lock().unwrap_or_else(|e| e.into_inner()) = None;
        }
        self.fallback = config.may_hand_over().then(|| scene.clone());
        self.kept.shape = buffers.bvh.take();
        Ok(Aimed::InPlace)
    }
}

/// A prepared scene set apart from the renderer it was prepared on, for a caller that keeps
/// it between frames but cannot keep the borrow (the live view, whose window owns its
/// renderer): [`PreparedScene::detach`], then [`DetachedScene::attach`] to render or aim it.
pub struct DetachedScene {
    /// The tiles' kernels, buffers and bins, on the device that made them.
    dispatch: Dispatch<wgpu::Device>,
    stats: RenderStats,
    fallback: Option<Scene>,
    counters: super::readback::Counters,
    first_kernel: super::kernel::KernelKey,
    kept: super::prepared::Kept,
}

impl PreparedScene<'_> {
    /// The scene apart from its renderer, its buffers and kernel kept.
    pub fn detach(self) -> DetachedScene {
        let PreparedScene { dispatch, stats, fallback, counters, first_kernel, kept } = self;
        let device = dispatch.gpu.device.clone();
        DetachedScene { dispatch: dispatch.on(device), stats, fallback, counters, first_kernel, kept }
    }
}

impl DetachedScene {
    /// The outputs and size the scene was prepared for.
    pub fn options(&self) -> &crate::render::RenderOptions {
        &self.dispatch.options
    }

    /// The scene on `gpu` again, or `None` where `gpu` renders on another device than the
    /// one it was prepared on, whose buffers and kernel it cannot use.
    pub fn attach(self, gpu: &super::GpuRenderer) -> Option<PreparedScene<'_>> {
        if gpu.device != self.dispatch.gpu {
            return None;
        }
        let DetachedScene { dispatch, stats, fallback, counters, first_kernel, kept } = self;
        Some(PreparedScene { dispatch: dispatch.on(gpu), stats, fallback, counters, first_kernel, kept })
    }
}
