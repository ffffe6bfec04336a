//! A scene uploaded and bound once, then rendered tile by tile with the same buffers, bind
//! groups and pipeline (as wgpu's `repeated_compute` example keeps its own).
//!
//! Sets of per-tile buffers (slots, two unless `GpuOptions::tile_slots` says otherwise) take
//! turns: a thread of ours submits the next tiles and waits for them while the caller's
//! thread decodes and writes the one before, so the host's share of the work (decoding,
//! quantising, writing files) overlaps the device's instead of following it.
//! In a browser, which has neither the thread nor a blocking wait, [`PreparedScene::render_async`]
//! renders the tiles one after another and awaits each.

use super::binning::Bins;
use super::dispatch::Dispatch;
use super::error::GpuError;
use super::flatten::{self, GpuBvh, GridChoice, SceneBuffers};
use super::kernel::{KernelConfig, KernelKey};
use super::layout::{GpuTexture, Params, PixelLayout, SWITCH_ORTHOGRAPHIC, SWITCH_SHADE_BACK, SWITCH_TRIANGLES_ALONE};
use super::parallel::in_parallel;
use super::readback::Counters;
use super::renderer::{Compiled, GpuRenderer};
use super::tiles::{SlotSizes, TileBuffers, TileSlot, Tiling};
use super::upload::{upload_inputs, Inputs};
use super::{precision, texture_range, unsupported, voxels};
use crate::render::RenderOptions;
use crate::render::RenderStats;
use crate::scene::Scene;

/// A scene ready on the device for one image size and set of outputs.
pub struct PreparedScene<'a> {
    /// The kernels, the per-tile buffers and the frame's bins, which render the tiles.
    pub(super) dispatch: Dispatch<&'a GpuRenderer>,
    pub(super) stats: RenderStats,
    /// The scene, kept where the kernel may hand pixels over
    /// ([`KernelConfig::may_hand_over`]), to render those with the reference
    /// ([`super::handover`]).
    pub(super) fallback: Option<Scene>,
    /// The kernel's `-stats` counts, shared by every tile (bound to every slot).
    pub(super) counters: Counters,
    /// The kernel the tiles dispatch first (`gpu::ahead`, which a browser does without).
    #[cfg_attr(target_arch = "wasm32", allow(dead_code))]
    pub(super) first_kernel: KernelKey,
    /// What another camera may keep ([`PreparedScene::aim`]).
    pub(super) kept: Kept,
}

/// How much room the slots' buffers give the bins' lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ListsRoom {
    /// What this camera's lists need: a render of one image.
    Exact,
    /// Twice that (within the adapter's binding limit), for the lists of the cameras to
    /// come: a scene prepared again because a moved camera's lists outgrew its slots
    /// ([`PreparedScene::aim`]).
    Doubled,
}

/// What a prepared scene keeps for [`PreparedScene::aim`]: its kernel's configuration, the
/// scene's buffers and the sizes of the slots', and the hierarchy's shape.
pub(super) struct Kept {
    pub config: KernelConfig,
    pub inputs: Inputs,
    pub sizes: SlotSizes,
    pub shape: Option<GpuBvh>,
}

impl GpuRenderer {
    /// Compiles the kernel [`GpuRenderer::prepare`] would compile first for this render,
    /// and nothing else (no buffer, no upload): a batch compiles the next line's kernel
    /// while it renders this one, and the next line's `prepare` finds it compiled, or
    /// waits for it. Refuses what `prepare` refuses.
    pub fn precompile(&self, scene: &Scene, options: &RenderOptions, packed: bool) -> Result<(), GpuError> {
        self.precompile_first(scene, options, packed).map(drop)
    }

    /// [`GpuRenderer::precompile`], naming the kernel a render dispatches first
    /// (`gpu::ahead`).
    pub(super) fn precompile_first(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        packed: bool,
    ) -> Result<KernelKey, GpuError> {
        let planned = Planned::new(self, scene, options, PixelLayout::new(options, packed))?;
        Compiled::new(self, planned.config, options, &scene.path).map(|compiled| compiled.first)
    }

    /// Flattens, uploads and binds `scene` for the outputs `options` asks for, once; the
    /// result renders the image tile by tile. `packed` asks for the outputs as 8-bit images
    /// (one word per pixel and output, quantised by the kernel), else as floats.
    pub fn prepare(&self, scene: &Scene, options: &RenderOptions, packed: bool) -> Result<PreparedScene<'_>, GpuError> {
        PreparedScene::new(self, scene, options, PixelLayout::new(options, packed), ListsRoom::Exact)
    }
}

impl<'a> PreparedScene<'a> {
    pub(super) fn new(
        gpu: &'a GpuRenderer,
        scene: &Scene,
        options: &RenderOptions,
        layout: PixelLayout,
        room: ListsRoom,
    ) -> Result<PreparedScene<'a>, GpuError> {
        let start = crate::clock::Instant::now();
        let Planned { traced, mut plan, mut buffers, config: planned } = Planned::new(gpu, scene, options, layout)?;
        let config_for =
            |buffers: &SceneBuffers, acceleration| kernel_config(gpu, buffers, acceleration, layout, options, &traced);
        // The kernel is compiled (on lavapipe a cost worth hiding even from the shader cache,
        // docs/performance.md) while this thread builds the bins or the hierarchy, uploads the
        // scene and fills the first tile's lists. It is the kernel of the planned way of
        // finding candidates: exact but for bins, whose lists may turn out too long; then the
        // hierarchy's kernel is compiled by `upload` at once, not after the other.
        let (compiled, uploaded) = in_parallel(
            || {
                let compiling = crate::clock::Instant::now();
                Compiled::new(gpu, planned, options, &scene.path).map(|c| (c, compiling.elapsed().as_secs_f64() * 1e3))
            },
            || {
                let uploaded = Uploaded::new(gpu, scene, options, (layout, room), &mut buffers, &mut plan)?;
                let config = config_for(&buffers, buffers.acceleration());
                let unplanned = (config != planned).then(|| Compiled::new(gpu, config, options, &scene.path));
                Ok::<_, GpuError>((config, unplanned, uploaded))
            },
        );
        let (config, unplanned, uploaded) = uploaded?;
        let (compile_ms, specialise_ms) = compiled.as_ref().map_or((0.0, 0.0), |(c, ms)| (*ms, c.specialise_ms));
        let compiled = match unplanned {
            Some(instead) => instead?,
            None => compiled?.0,
        };
        let first_kernel = compiled.first;
        // Where the driver compiles at the first dispatch, a kernel a batch's twin device is
        // compiling is waited for: Mesa's cache then hands it over (gpu::ahead).
        if let Some(first_dispatches) = &gpu.first_dispatches {
            first_dispatches.wait_or_claim(first_kernel);
        }
        let counters = Counters::new(gpu, options.stats);
        let stats = RenderStats {
            compile_ms,
            specialise_ms,
            scene_bytes: uploaded.scene_bytes(),
            ..frame_stats(gpu, &buffers, &plan, options)
        };
        let params = frame_params(&buffers, options, &traced);
        let (dispatch, inputs, sizes) =
            uploaded.dispatch(gpu, compiled, &counters, &mut buffers, (config, params), options, layout);
        Ok(PreparedScene {
            dispatch,
            stats: RenderStats { prepare_ms: start.elapsed().as_secs_f64() * 1e3, ..stats },
            fallback: config.may_hand_over().then(|| scene.clone()),
            counters,
            first_kernel,
            kept: Kept { config, inputs, sizes, shape: buffers.bvh.take() },
        })
    }
}

/// The parameters every tile of a frame of `buffers` shares.
pub(super) fn frame_params(
    buffers: &SceneBuffers,
    options: &RenderOptions,
    traced: &super::ray_tree::RenderRays,
) -> Params {
    Params {
        weight: options.shading.weight as f32,
        bounces: traced.tree.depth,
        switches: switches(buffers, options.shading.shade_back),
        ..buffers.params
    }
}

/// `Params::switches`: what a shared kernel reads instead of compiling it in.
fn switches(buffers: &SceneBuffers, shade_back: bool) -> u32 {
    let bit = |on: bool, bit: u32| if on { bit } else { 0 };
    bit(buffers.orthographic, SWITCH_ORTHOGRAPHIC)
        | bit(shade_back, SWITCH_SHADE_BACK)
        | bit(buffers.triangles_alone(), SWITCH_TRIANGLES_ALONE)
}

/// A render checked, planned and flattened, and the kernel of its plan: what
/// [`GpuRenderer::precompile`] compiles and [`PreparedScene::new`] starts from.
pub(super) struct Planned {
    pub traced: super::ray_tree::RenderRays,
    pub plan: Plan,
    pub buffers: SceneBuffers,
    pub config: KernelConfig,
}

impl Planned {
    pub fn new(
        gpu: &GpuRenderer,
        scene: &Scene,
        options: &RenderOptions,
        layout: PixelLayout,
    ) -> Result<Planned, GpuError> {
        // Refused before any tile is handed out: `auto` then renders with the reference.
        let traced = unsupported::check(scene, options).map_err(GpuError::Unsupported)?;
        precision::check(scene, options).map_err(GpuError::Precision)?;
        let plan = Plan::new(scene, options, traced.secondary());
        let buffers = flattened(scene, options, &plan.rays);
        let acceleration = plan.acceleration(&buffers, &gpu.options);
        let config = kernel_config(gpu, &buffers, acceleration, layout, options, &traced);
        Ok(Planned { traced, plan, buffers, config })
    }
}

/// The kernel for `buffers` on `gpu`, finding candidates by `acceleration`.
pub(super) fn kernel_config(
    gpu: &GpuRenderer,
    buffers: &SceneBuffers,
    acceleration: super::Acceleration,
    layout: PixelLayout,
    options: &RenderOptions,
    traced: &super::ray_tree::RenderRays,
) -> KernelConfig {
    let (loop_limit, shared_loads) = (gpu.loop_limit().is_some(), gpu.shares_bin_loads());
    let config = KernelConfig::new(buffers, acceleration, layout, options, traced, loop_limit, shared_loads);
    if gpu.options.share_small_kernels && options.sample_count() <= super::kernel::SHARED_KERNEL_MAX_SAMPLES {
        config.shared(gpu.binds_every_buffer())
    } else {
        config
    }
}

/// What a scene's render casts, and where it finds its candidates.
pub(super) struct Plan {
    rays: crate::camera::PrimaryRays,
    secondary_rays: bool,
    sampled_rays: bool,
    grid: Option<GridChoice>,
}

impl Plan {
    fn new(scene: &Scene, options: &RenderOptions, secondary_rays: bool) -> Plan {
        let rays = crate::camera::PrimaryRays::for_camera(&scene.camera, options.width, options.height);
        let grid = options.grid.map(|size| match options.visualize_grid {
            true => GridChoice::Given(voxels::voxel_grid(scene, size, rays.center)),
            false => GridChoice::Walk(size),
        });
        Plan { rays, secondary_rays, sampled_rays: options.sampling.is_some(), grid }
    }

    /// The way of finding candidates [`Plan::build`] will take (see
    /// [`SceneBuffers::planned_acceleration`]).
    fn acceleration(&self, buffers: &SceneBuffers, options: &super::GpuOptions) -> super::Acceleration {
        buffers.planned_acceleration(&self.rays, options, self.secondary_rays, self.sampled_rays, self.grid.is_some())
    }

    /// Builds the grid (handed over: built once), the bins or the hierarchy into `buffers`;
    /// a hierarchy in the shape of `shape` where given ([`SceneBuffers::build_acceleration`]).
    fn build(&mut self, buffers: &mut SceneBuffers, options: &super::GpuOptions, shape: Option<&GpuBvh>) {
        let grid = self.grid.take();
        buffers.build_acceleration(&self.rays, options, self.secondary_rays, self.sampled_rays, grid, shape);
    }
}

/// The scene as the kernel's buffers, with each checkerboard's reach shared among the
/// samples of a pixel ([`texture_range::checker_samples_per_pixel`]).
fn flattened(scene: &Scene, options: &RenderOptions, rays: &crate::camera::PrimaryRays) -> SceneBuffers {
    let mut buffers = SceneBuffers::flattened(scene, rays);
    if let Some(sampling) = options.sampling {
        let samples = texture_range::checker_samples_per_pixel(&sampling) as f32;
        for texture in buffers.textures.iter_mut().filter(|t| t.kind == GpuTexture::CHECKERBOARD) {
            texture.reach /= samples;
        }
    }
    buffers
}

/// Refuses flat loops (no bins, hierarchy or grid) over more primitives than a loop may
/// run on a driver that ends long loops.
fn check_flat_loops(buffers: &SceneBuffers) -> Result<(), GpuError> {
    let flat = buffers.bins.is_none() && buffers.bvh.is_none() && buffers.grid.is_none();
    let primitives = buffers.spheres.len() + buffers.ellipsoids.len() + buffers.planes.len() + buffers.triangles.len();
    if flat && primitives > flatten::LOOP_LIMIT as usize / 2 {
        return Err(GpuError::TooLarge(format!(
            "{primitives} primitives in flat loops (at most {} without bins or a hierarchy)",
            flatten::LOOP_LIMIT / 2
        )));
    }
    Ok(())
}

/// Builds `plan`'s way of finding candidates into `buffers` (a hierarchy in the shape of
/// `shape` where given), checks its flat loops, cuts the render into tiles and finishes the
/// bins: what a render needs before its buffers are written, whether the scene is prepared
/// or aimed at a moved camera ([`PreparedScene::aim`]).
pub(super) fn built(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
    layout: PixelLayout,
    buffers: &mut SceneBuffers,
    plan: &mut Plan,
    shape: Option<&GpuBvh>,
) -> Result<Tiling, GpuError> {
    plan.build(buffers, &gpu.options, shape);
    check_flat_loops(buffers)?;
    let tiling = Tiling::new(gpu, scene, options, &layout, buffers.bins.as_ref())?;
    if let Some(bins) = &mut buffers.bins {
        bins.finish(&buffers.triangles);
    }
    Ok(tiling)
}

/// What a frame of `buffers` reports of its preparation: how candidates are found and what
/// building them cost, the grid's box for `-stats`, and room for the kernel's time.
pub(super) fn frame_stats(
    gpu: &GpuRenderer,
    buffers: &SceneBuffers,
    plan: &Plan,
    options: &RenderOptions,
) -> RenderStats {
    let acceleration_build_ms = buffers
        .bvh
        .as_ref()
        .map(|b| b.build_ms)
        .or(buffers.bins.as_ref().map(|b| b.build_ms))
        .or(buffers.grid.as_ref().map(|g| g.build_ms));
    RenderStats {
        kernel_ns: gpu.timestamps.then_some(0),
        grid_bounds: options.stats.then(|| buffers.grid_world_bounds(plan.rays.center)).flatten(),
        acceleration_build_ms,
        acceleration: buffers.acceleration(),
        ..RenderStats::default()
    }
}

/// A scene's buffers on the device: the inputs, and the buffers of each tile slot.
struct Uploaded {
    tiling: Tiling,
    inputs: Inputs,
    sizes: SlotSizes,
    slot_buffers: Vec<TileBuffers>,
}

impl Uploaded {
    /// Builds the acceleration `plan` asks for, checks the flat loops' size, and uploads.
    fn new(
        gpu: &GpuRenderer,
        scene: &Scene,
        options: &RenderOptions,
        (layout, room): (PixelLayout, ListsRoom),
        buffers: &mut SceneBuffers,
        plan: &mut Plan,
    ) -> Result<Uploaded, GpuError> {
        let tiling = built(gpu, scene, options, layout, buffers, plan, None)?;
        let inputs = upload_inputs(gpu, buffers)?;
        // The first tile's lists go straight into slot 0's buffers, and every slot's buffers
        // are made (and where the host maps them, their pages touched) here rather than on
        // the way to the first tile.
        let first_band = buffers.bins.as_ref().map(|bins| {
            let (first, count) = Bins::rows_holding(0, tiling.first_traced_rows(options));
            (first, count, bins.band(first, count))
        });
        let tile_bytes = options.width as u64 * tiling.tile_rows as u64 * layout.words() as u64 * 4;
        let limit = gpu.limits.max_storage_buffer_binding_size;
        let band_bytes = tiling.band_bytes.map(|(ranges, items)| match room {
            ListsRoom::Exact => (ranges, items),
            ListsRoom::Doubled => (ranges, (2 * items).min(limit)),
        });
        let sizes = SlotSizes { tile_bytes, sample_bytes: tiling.sample_bytes, band_bytes };
        let slots = options.height.div_ceil(tiling.tile_rows).min(gpu.options.tile_slots.max(1) as u32);
        let slot_buffers = (0..slots)
            .map(|k| TileBuffers::new(gpu, sizes, first_band.as_ref().filter(|_| k == 0)))
            .collect::<Result<_, _>>()?;
        Ok(Uploaded { tiling, inputs, sizes, slot_buffers })
    }

    /// The bytes of the scene's buffers and of every slot's lists on the device.
    fn scene_bytes(&self) -> u64 {
        let band_buffer_bytes = self.sizes.band_bytes.map_or(0, |(r, i)| r + i) * self.slot_buffers.len() as u64;
        self.inputs.0.iter().flatten().map(|b| b.size()).sum::<u64>() + band_buffer_bytes
    }

    /// The tiles' dispatch: each slot bound to the kernel `compiled` (of `config`, with
    /// `params`), the inputs and the counters; the frame's bins taken from `buffers`. The
    /// inputs and the slots' sizes come back beside it, for a moved camera to reuse.
    #[allow(clippy::too_many_arguments)]
    fn dispatch<'a>(
        self,
        gpu: &'a GpuRenderer,
        compiled: Compiled,
        counters: &Counters,
        buffers: &mut SceneBuffers,
        (config, params): (KernelConfig, Params),
        options: &RenderOptions,
        layout: PixelLayout,
    ) -> (Dispatch<&'a GpuRenderer>, Inputs, SlotSizes) {
        let Compiled { bindings, pipeline, sampled, .. } = compiled;
        let slots = self
            .slot_buffers
            .into_iter()
            .map(|b| TileSlot::new(gpu, b, &bindings, &self.inputs, &counters.buffer))
            .collect();
        let dispatch = Dispatch {
            gpu,
            pipeline,
            sampled,
            packet: config.packet(),
            layout,
            params,
            options: *options,
            tile_rows: self.tiling.tile_rows,
            slots,
            bins: buffers.bins.take(),
            lists_ns: Default::default(),
        };
        (dispatch, self.inputs, self.sizes)
    }
}
