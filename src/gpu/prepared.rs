//! A scene uploaded and bound once, then rendered tile by tile with the same buffers, bind
//! groups and pipeline (as wgpu's `repeated_compute` example keeps its own).
//!
//! Two sets of per-tile buffers take turns: a thread of ours submits tile k + 1 and waits for
//! it while the caller's thread decodes and writes tile k, so the host's share of the work
//! (decoding, quantising, writing files) overlaps the device's instead of following it.
//! In a browser, which has neither the thread nor a blocking wait, [`PreparedScene::render_async`]
//! renders the tiles one after another and awaits each.

use super::bindings::BindingSet;
use super::binning::{Band, Bins, BIN_ROWS};
use super::flatten::{GridChoice, SceneBuffers};
use super::layout::{
    BinItem, GpuSampling, GpuTexture, Handover, Params, PixelLayout, PACKED_MISS, PERLIN_PERMUTATION, SAMPLE_WORDS,
    STATS_SLOTS, STATS_WORDS,
};
use super::{
    GpuError, GpuRenderer, KernelConfig, RenderStats, Stage, Timer, BINDINGS, BIN_ITEMS_BINDING, BIN_RANGES_BINDING,
    COUNTERS_BINDING, MAX_SAMPLE_BYTES, OUTPUT_BINDING, SAMPLES_BINDING, SAMPLING_BINDING, WORKGROUP,
};
use crate::cpu::Reference;
use crate::render::{row_tiles, Frame, Output, RayStats, RenderOptions};
use crate::sampling::Sampling;
use crate::scene::Scene;
use wgpu::util::DeviceExt;

/// A scene ready on the device for one image size and set of outputs.
pub struct PreparedScene<'a> {
    gpu: &'a GpuRenderer,
    /// The kernel of a render without sampling (`sampled` holds the others).
    pipeline: Option<wgpu::ComputePipeline>,
    /// Pixels per invocation ([`KernelConfig::packet`]).
    packet: u32,
    layout: PixelLayout,
    params: Params,
    options: RenderOptions,
    tile_rows: u32,
    slots: Vec<Slot>,
    stats: RenderStats,
    /// The scene, kept where the kernel may hand pixels over (its driver cut them short,
    /// [`KernelConfig::loop_canary`], or a texture was beyond its reach there,
    /// [`super::texture_range`]), to render those with the reference.
    fallback: Option<Scene>,
    /// The kernel's `-stats` counts, shared by every tile (bound to every slot).
    counters: Counters,
    /// With sampling: the passes that trace the samples and filter them.
    sampled: Option<Sampled>,
    /// The frame's screen-space bins, whose lists each tile fills for its own band of rows
    /// ([`Bins::band`]) into its slot's buffers.
    bins: Option<Bins>,
}

/// The `counters` binding: [`STATS_SLOTS`] slots of [`STATS_WORDS`] words, with a buffer to
/// read them back, where the render counts (`-stats`); else one word no kernel touches.
struct Counters {
    buffer: wgpu::Buffer,
    readback: Option<wgpu::Buffer>,
}

/// The two passes of a render with several samples per pixel (docs/SPEC.md §8).
struct Sampled {
    sampling: Sampling,
    samples: wgpu::ComputePipeline,
    filter: wgpu::ComputePipeline,
}

/// The buffers one tile in flight uses, and their bindings.
struct Slot {
    buffers: SlotBuffers,
    bind_group: wgpu::BindGroup,
}

/// The buffers of a [`Slot`], made before the kernel's bindings are known (while it
/// compiles).
struct SlotBuffers {
    params: wgpu::Buffer,
    /// The tile's samples and their parameters (a word each without sampling).
    sampling: wgpu::Buffer,
    samples: wgpu::Buffer,
    output: wgpu::Buffer,
    /// The buffer the output is copied into for the host to read, or `None` where the
    /// host maps the output itself ([`GpuRenderer::maps_kernel_buffers`]).
    readback: Option<wgpu::Buffer>,
    /// The lists of the bins the tile's rays walk, where the frame has bins.
    bins: Option<BandBuffers>,
    timer: Option<Timer>,
}

/// The `bin_ranges` and `bin_items` of a slot: room for the lists of the largest band of
/// bin rows a tile traces.
struct BandBuffers {
    ranges: wgpu::Buffer,
    items: wgpu::Buffer,
    /// The band (its first bin row and bin rows) whose lists the buffers hold: slot 0's
    /// are the whole image's first tile's, written while the kernel compiles.
    holds: std::sync::Mutex<Option<(u32, u32)>>,
}

/// One tile as the kernel wrote it and the host read it back, floats or packed 8-bit words
/// (its [`PixelLayout`]): `rows` full image rows from `first_row` (from the top).
pub struct ReadTile<'a> {
    pub first_row: u32,
    pub rows: u32,
    width: u32,
    layout: PixelLayout,
    options: &'a RenderOptions,
    words: &'a [u32],
}

impl<'a> PreparedScene<'a> {
    pub(super) fn new(
        gpu: &'a GpuRenderer,
        scene: &Scene,
        options: &RenderOptions,
        layout: PixelLayout,
    ) -> Result<PreparedScene<'a>, GpuError> {
        let start = crate::clock::Instant::now();
        // Refused before any tile is handed out: `auto` then renders with the reference.
        let tree = super::support::check(scene, options).map_err(GpuError::Unsupported)?;
        super::precision::check(scene, options).map_err(GpuError::Precision)?;
        let rays = crate::camera::PrimaryRays::for_camera(&scene.camera, options.width, options.height);
        let secondary_rays =
            tree.depth > 0 || (options.shading.shadows && !options.visualize_grid && !scene.lights.is_empty());
        let grid = options.grid.map(|size| match options.visualize_grid {
            true => GridChoice::Given(super::voxels::voxel_grid(scene, size, rays.center)),
            false => GridChoice::Walk(size),
        });
        let sampled_rays = options.sampling.is_some();
        let mut buffers = SceneBuffers::flattened(scene, &rays);
        if let Some(sampling) = options.sampling {
            let samples = super::texture_range::checker_samples_per_pixel(&sampling) as f32;
            for texture in buffers.textures.iter_mut().filter(|t| t.kind == GpuTexture::CHECKERBOARD) {
                texture.reach /= samples;
            }
        }
        let config_for = |buffers: &SceneBuffers, acceleration| {
            let (loop_limit, shared_loads) = (gpu.loop_limit().is_some(), gpu.shares_bin_loads());
            KernelConfig::new(buffers, acceleration, layout, options, &tree, loop_limit, shared_loads)
        };
        // The kernel is compiled (on lavapipe about 18 ms for bunny_40k's, even from the
        // shader cache, while the machine's other core waited) while this thread builds the
        // bins or the hierarchy, uploads the scene and fills the first tile's lists. It is
        // the kernel of the planned way of finding candidates: exact but for bins, whose
        // lists may turn out too long; then the hierarchy's kernel is compiled here.
        let planned = buffers.planned_acceleration(&rays, &gpu.options, secondary_rays, sampled_rays, grid.is_some());
        let planned_config = config_for(&buffers, planned);
        let prepare = || {
            buffers.build_acceleration(&rays, &gpu.options, secondary_rays, sampled_rays, grid);
            let flat = buffers.bins.is_none() && buffers.bvh.is_none() && buffers.grid.is_none();
            let primitives =
                buffers.spheres.len() + buffers.ellipsoids.len() + buffers.planes.len() + buffers.triangles.len();
            if flat && primitives > super::flatten::LOOP_LIMIT as usize / 2 {
                return Err(GpuError::TooLarge(format!(
                    "{primitives} primitives in flat loops (at most {} without bins or a hierarchy)",
                    super::flatten::LOOP_LIMIT / 2
                )));
            }
            let tiling = Tiling::new(gpu, scene, options, &layout, buffers.bins.as_ref())?;
            if let Some(bins) = &mut buffers.bins {
                bins.finish(&buffers.triangles);
            }
            let inputs = upload_inputs(gpu, &buffers)?;
            // The first tile's lists go straight into slot 0's buffers, and every slot's
            // buffers are made (and where the host maps them, their pages touched) here
            // rather than on the way to the first tile.
            let first_band = buffers.bins.as_ref().map(|bins| {
                let (first, count) = Bins::rows_holding(0, tiling.first_traced_rows(options));
                (first, count, bins.band(first, count))
            });
            let tile_bytes = options.width as u64 * tiling.tile_rows as u64 * layout.words() as u64 * 4;
            let sizes = SlotSizes { tile_bytes, sample_bytes: tiling.sample_bytes, band_bytes: tiling.band_bytes };
            let slots = options.height.div_ceil(tiling.tile_rows).min(2);
            let slot_buffers: Vec<SlotBuffers> = (0..slots)
                .map(|k| SlotBuffers::new(gpu, sizes, first_band.as_ref().filter(|_| k == 0)))
                .collect::<Result<_, _>>()?;
            // The plan failed (the bins' lists were too long): the kernel that is needed,
            // compiled here at once, not after the other.
            let config = config_for(&buffers, buffers.acceleration());
            let unplanned = (config != planned_config).then(|| Compiled::new(gpu, config, options, &scene.path));
            Ok((config, unplanned, tiling, inputs, slot_buffers))
        };
        let (planned, prepared) = in_parallel(|| Compiled::new(gpu, planned_config, options, &scene.path), prepare);
        let (config, unplanned, tiling, inputs, slot_buffers) = prepared?;
        let Compiled { bindings, pipeline, sampled } = unplanned.unwrap_or(planned)?;
        let Tiling { tile_rows, band_bytes, .. } = tiling;
        let counters = Counters::new(gpu, options.stats);
        let acceleration = buffers.acceleration();
        let bins = buffers.bins.take();
        let slots: Vec<Slot> =
            slot_buffers.into_iter().map(|b| Slot::new(gpu, b, &bindings, &inputs, &counters.buffer)).collect();
        let band_buffer_bytes: u64 = band_bytes.map_or(0, |(r, i)| r + i) * slots.len() as u64;
        let scene_bytes = inputs.iter().flatten().map(|b| b.size()).sum::<u64>() + band_buffer_bytes;
        Ok(PreparedScene {
            gpu,
            pipeline,
            packet: config.packet(),
            layout,
            params: Params { weight: options.shading.weight as f32, ..buffers.params },
            options: *options,
            tile_rows,
            slots,
            stats: RenderStats {
                kernel_ns: gpu.timestamps.then_some(0),
                tiles: 0,
                acceleration_build_ms: buffers
                    .bvh
                    .as_ref()
                    .map(|b| b.build_ms)
                    .or(bins.as_ref().map(|b| b.build_ms))
                    .or(buffers.grid.as_ref().map(|g| g.build_ms)),
                prepare_ms: start.elapsed().as_secs_f64() * 1e3,
                scene_bytes,
                acceleration,
                pixels_cut_short: 0,
                pixels_beyond_reach: 0,
                counted: None,
                grid_bounds: options.stats.then(|| buffers.grid_world_bounds(rays.center)).flatten(),
            },
            fallback: (config.loop_canary || config.textures).then(|| scene.clone()),
            counters,
            sampled,
            bins,
        })
    }

    /// Renders every tile, top first, handing each to `on_tile` on the calling thread.
    /// (Not in a browser, which has neither threads nor blocking waits: there
    /// [`PreparedScene::render_async`].)
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render<E: From<GpuError>>(&self, on_tile: impl FnMut(&ReadTile) -> Result<(), E>) -> Result<RenderStats, E> {
        self.render_band(0, self.options.height, on_tile)
    }

    /// As [`PreparedScene::render`], for image rows `first .. first + rows` only (a band of
    /// a render split across machines); tiles still carry image row numbers.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_band<E: From<GpuError>>(
        &self,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(&ReadTile) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        assert!(first + rows <= self.options.height, "the band lies inside the image");
        let tiles: Vec<(u32, u32)> = row_tiles(rows, self.tile_rows).map(|(offset, n)| (first + offset, n)).collect();
        let mut stats = self.stats;
        let counted = self.counters.zero(self.gpu);
        let again = RenderAgain::default();
        std::thread::scope(|scope| {
            use std::sync::mpsc::sync_channel;
            let (ready_tx, ready_rx) = sync_channel(self.slots.len());
            let (free_tx, free_rx) = sync_channel::<usize>(self.slots.len());
            for k in 0..self.slots.len() {
                free_tx.send(k).expect("the receiver is alive");
            }
            let submitter = tiles.clone();
            scope.spawn(move || {
                for (first_row, rows) in submitter {
                    // The caller stopped (an error, or all tiles done): nothing more to submit.
                    let Ok(slot) = free_rx.recv() else { return };
                    let result = self.run_tile(slot, first_row, rows);
                    let failed = result.is_err();
                    if ready_tx.send(result.map(|ns| (slot, first_row, rows, ns))).is_err() || failed {
                        return;
                    }
                }
            });
            for _ in &tiles {
                let (slot, first_row, rows, kernel_ns) =
                    ready_rx.recv().map_err(|e| GpuError::Readback(e.to_string()))??;
                let handed = self.hand_over(slot, first_row, rows, &again, &mut on_tile)?;
                stats.add_tile(handed, kernel_ns);
                // The submitter may already have finished; then nobody needs the slot back.
                let _ = free_tx.send(slot);
            }
            Ok::<(), E>(())
        })?;
        if let Some(counted) = counted {
            stats.counted = Some(again.add_counts(counted, self.counters.read(self.gpu)?));
        }
        Ok(stats)
    }

    /// As [`PreparedScene::render`], the tiles one after another on the calling task, each
    /// read back by awaiting its map: the path for a browser, where a map resolves only once
    /// control returns to the page's event loop and no thread can wait for it. The pixels
    /// the kernel hands over are rendered again by the reference, as in
    /// [`PreparedScene::render_band`].
    pub async fn render_async<E: From<GpuError>>(
        &self,
        mut on_tile: impl FnMut(&ReadTile) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let mut stats = self.stats;
        let counted = self.counters.zero(self.gpu);
        let again = RenderAgain::default();
        for (first_row, rows) in row_tiles(self.options.height, self.tile_rows) {
            let submission = self.submit_tile(0, first_row, rows);
            let slot = &self.slots[0].buffers;
            map_async(&self.gpu.device, &slot.readable().slice(..self.tile_bytes(rows)), submission.clone()).await?;
            let kernel_ns = match &slot.timer {
                Some(timer) => Some(timer.elapsed_ns_async(self.gpu, submission).await?),
                None => None,
            };
            let handed = self.hand_over(0, first_row, rows, &again, &mut on_tile)?;
            stats.add_tile(handed, kernel_ns);
        }
        if let Some(counted) = counted {
            stats.counted = Some(again.add_counts(counted, self.counters.read_async(self.gpu).await?));
        }
        Ok(stats)
    }

    /// Shows the caller the mapped tile, its pixels handed over rendered again by the
    /// reference, then gives the buffer back to the device; returns how many were, by why.
    fn hand_over<'s, E: From<GpuError>>(
        &'s self,
        slot: usize,
        first_row: u32,
        rows: u32,
        again: &RenderAgain<'s>,
        on_tile: &mut impl FnMut(&ReadTile) -> Result<(), E>,
    ) -> Result<HandedOver, E> {
        let readback = self.slots[slot].buffers.readable();
        let range = readback.slice(..self.tile_bytes(rows));
        let mut handed = HandedOver::default();
        let result = {
            let view = range.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?;
            let mapped: &[u32] = bytemuck::cast_slice(&view);
            let patched =
                self.fallback.as_ref().and_then(|scene| self.rerender_handed_over(scene, again, first_row, mapped));
            if let Some((_, counts)) = &patched {
                handed = *counts;
            }
            let words = patched.as_ref().map_or(mapped, |(words, _)| &words[..]);
            on_tile(&ReadTile {
                first_row,
                rows,
                width: self.options.width,
                layout: self.layout,
                options: &self.options,
                words,
            })
        };
        readback.unmap();
        result.map(|()| handed)
    }

    /// The tile's words with every pixel the kernel handed over replaced by the
    /// reference's, and how many those were, by why; `None` when none was.
    fn rerender_handed_over<'s>(
        &self,
        scene: &'s Scene,
        again: &RenderAgain<'s>,
        first_row: u32,
        words: &[u32],
    ) -> Option<(Vec<u32>, HandedOver)> {
        if !self.layout.hands_over_any(words) {
            return None;
        }
        let stride = self.layout.words() as usize;
        let width = self.options.width as usize;
        let (mut cut, mut beyond) = (Vec::new(), Vec::new());
        for k in 0..words.len() / stride {
            match self.layout.handover(&words[k * stride..]) {
                Some(Handover::LoopsCut) => cut.push(k),
                Some(Handover::BeyondReach) => beyond.push(k),
                None => {}
            }
        }
        if cut.is_empty() && beyond.is_empty() {
            return None;
        }
        let mut out = words.to_vec();
        let mut render_again = |reference: &std::cell::OnceCell<Reference<'s>>, marked: &[usize]| {
            if marked.is_empty() {
                return;
            }
            let pixels: Vec<(u32, u32)> =
                marked.iter().map(|&k| ((k % width) as u32, first_row + (k / width) as u32)).collect();
            let rendered = reference.get_or_init(|| Reference::new(scene, &self.options)).pixels(&pixels);
            for (n, &k) in marked.iter().enumerate() {
                self.layout.encode(&rendered.pixel(n), &mut out[k * stride..(k + 1) * stride]);
            }
        };
        render_again(&again.cut_short, &cut);
        render_again(&again.beyond_reach, &beyond);
        Some((out, HandedOver { loops_cut: cut.len() as u64, beyond_reach: beyond.len() as u64 }))
    }

    fn tile_bytes(&self, rows: u32) -> u64 {
        self.options.width as u64 * rows as u64 * self.layout.words() as u64 * 4
    }

    /// Dispatches one tile into `slot` and waits until the host can read it (mapped);
    /// returns the kernel time where the adapter measures it.
    #[cfg(not(target_arch = "wasm32"))]
    fn run_tile(&self, slot: usize, first_row: u32, rows: u32) -> Result<Option<u64>, GpuError> {
        let submission = self.submit_tile(slot, first_row, rows);
        let s = &self.slots[slot].buffers;
        map_and_wait(&self.gpu.device, &s.readable().slice(..self.tile_bytes(rows)), submission)?;
        match &s.timer {
            Some(timer) => Ok(Some(timer.elapsed_ns(&self.gpu.device, self.gpu.queue.get_timestamp_period())?)),
            None => Ok(None),
        }
    }

    /// The image rows whose rays a tile of `rows` rows from `first_row` traces: its own, and
    /// with sampling those the filter reads around them (docs/SPEC.md §8).
    fn traced_rows(&self, first_row: u32, rows: u32) -> (u32, u32) {
        let Some(sampled) = &self.sampled else { return (first_row, rows) };
        let radius = sampled.sampling.radius();
        let first = first_row.saturating_sub(radius);
        (first, (first_row + rows).saturating_add(radius).min(self.options.height) - first)
    }

    /// Fills slot `slot`'s bin buffers with the lists of the bins that hold image rows
    /// `first_row .. first_row + rows`, where the frame has bins, unless they hold them
    /// already; returns the band's first bin row (the kernel's `first_bin_row`).
    fn upload_band(&self, slot: usize, first_row: u32, rows: u32) -> u32 {
        let (Some(bins), Some(buffers)) = (&self.bins, &self.slots[slot].buffers.bins) else { return 0 };
        let (first, count) = Bins::rows_holding(first_row, rows);
        let mut holds = buffers.holds.lock().unwrap_or_else(|e| e.into_inner());
        if *holds != Some((first, count)) {
            let band = bins.band(first, count);
            let queue = &self.gpu.queue;
            queue.write_buffer(&buffers.ranges, 0, bytemuck::cast_slice(&band.ranges));
            if !band.items.is_empty() {
                queue.write_buffer(&buffers.items, 0, bytemuck::cast_slice(&band.items));
            }
            *holds = Some((first, count));
        }
        first
    }

    /// Dispatches one tile into `slot`, and copies it to the slot's readback buffer where
    /// it has one.
    fn submit_tile(&self, slot: usize, first_row: u32, rows: u32) -> wgpu::SubmissionIndex {
        let gpu = self.gpu;
        let (traced_first, traced_rows) = self.traced_rows(first_row, rows);
        let first_bin_row = self.upload_band(slot, traced_first, traced_rows);
        let (s, bind_group) = (&self.slots[slot].buffers, &self.slots[slot].bind_group);
        let params = Params { first_row, tile_rows: rows, first_bin_row, ..self.params };
        gpu.queue.write_buffer(&s.params, 0, bytemuck::bytes_of(&params));
        let size = self.tile_bytes(rows);
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("raycast") });
        {
            let timestamp_writes = s.timer.as_ref().map(|t| wgpu::ComputePassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("raycast"), timestamp_writes });
            pass.set_bind_group(0, bind_group, &[]);
            let columns = self.options.width.div_ceil(WORKGROUP);
            match &self.sampled {
                None => {
                    pass.set_pipeline(self.pipeline.as_ref().expect("a render without sampling has its pixels kernel"));
                    // Packets start at the tile's first row rounded down to a multiple of PACKET.
                    let packets = (first_row % self.packet + rows).div_ceil(self.packet);
                    pass.dispatch_workgroups(columns, packets.div_ceil(WORKGROUP), 1);
                }
                Some(sampled) => {
                    // Every sample of the tile's rows and of the rows the filter reads around
                    // them, then each pixel from them (the two dispatches are ordered: wgpu
                    // puts a barrier between a pass's dispatches that write and read a buffer).
                    let sampling = &sampled.sampling;
                    let (sample_first, sample_rows) = (traced_first, traced_rows);
                    let radius = sampling.radius();
                    let header = GpuSampling {
                        count: sampling.count(),
                        side: sampling.sampler.side(),
                        seed: sampling.seed,
                        kind: sampling.sampler.kind(),
                        filter_kind: sampling.filter.kind(),
                        radius,
                        parameter: sampling.filter.parameter() as f32,
                        first_row: sample_first,
                        rows: sample_rows,
                        _pad: [0; 3],
                    };
                    gpu.queue.write_buffer(&s.sampling, 0, bytemuck::bytes_of(&header));
                    pass.set_pipeline(&sampled.samples);
                    // With bins, an invocation traces a packet: a pixel's samples, or for fewer
                    // samples than a packet, those of a stack of rows starting at a multiple of
                    // their count (the kernel's `packet_rows`).
                    let packets = sampling.count().div_ceil(self.packet);
                    let stack = (self.packet / sampling.count()).max(1);
                    let stacks = (sample_first % stack + sample_rows).div_ceil(stack);
                    pass.dispatch_workgroups(columns, stacks.div_ceil(WORKGROUP), packets);
                    pass.set_pipeline(&sampled.filter);
                    pass.dispatch_workgroups(columns, rows.div_ceil(WORKGROUP), 1);
                }
            }
        }
        if let Some(readback) = &s.readback {
            encoder.copy_buffer_to_buffer(&s.output, 0, readback, 0, size);
        }
        if let Some(timer) = &s.timer {
            timer.resolve(&mut encoder);
        }
        gpu.queue.submit([encoder.finish()])
    }
}

/// A kernel's bindings and pipelines: the pixels kernel of a render without sampling, the
/// samples and filter kernels of one with it.
struct Compiled {
    bindings: BindingSet,
    pipeline: Option<wgpu::ComputePipeline>,
    sampled: Option<Sampled>,
}

impl Compiled {
    fn new(
        gpu: &GpuRenderer,
        config: KernelConfig,
        options: &RenderOptions,
        file: &std::path::Path,
    ) -> Result<Compiled, GpuError> {
        let stages = match options.sampling {
            None => vec![config],
            Some(_) => {
                [Stage::Pixels, Stage::Samples, Stage::Filter].map(|stage| KernelConfig { stage, ..config }).to_vec()
            }
        };
        let bindings = gpu.bindings_for(&stages, file)?;
        // A sampled render dispatches its samples and filter kernels only.
        let (pipeline, sampled) = match options.sampling {
            None => (Some(gpu.pipeline(config, &bindings)), None),
            Some(sampling) => {
                let stage = |stage| gpu.pipeline(KernelConfig { stage, ..config }, &bindings);
                (None, Some(Sampled { sampling, samples: stage(Stage::Samples), filter: stage(Stage::Filter) }))
            }
        };
        Ok(Compiled { bindings, pipeline, sampled })
    }
}

/// How a render is cut into tiles: rows per tile, the bytes of a tile's samples and of its
/// bins' lists.
struct Tiling {
    tile_rows: u32,
    sample_bytes: u64,
    band_bytes: Option<(u64, u64)>,
}

impl Tiling {
    fn new(
        gpu: &GpuRenderer,
        scene: &Scene,
        options: &RenderOptions,
        layout: &PixelLayout,
        bins: Option<&Bins>,
    ) -> Result<Tiling, GpuError> {
        let mut tile_rows = gpu.tile_rows(options.width, layout)?;
        let limit = gpu.limits.max_storage_buffer_binding_size;
        if let Some(bins) = bins {
            // Where primitives crowd every bin, fewer rows a tile keep its band's lists within
            // a binding (scenes/hard/closed_mesh_inside.txt, a mesh around the camera whose
            // triangles all reach the eye plane, bins forced: 151 MiB for all 200 rows).
            let radius = options.sampling.map_or(0, |s| s.radius());
            let fits = |rows: u32| band_bytes(bins, (rows + 2 * radius).min(options.height), limit).is_ok();
            while tile_rows > 1 && !fits(tile_rows) {
                tile_rows /= 2;
            }
        }
        let mut sample_bytes = 4;
        if let Some(sampling) = options.sampling {
            // A tile's samples: its rows and the filter's overlap above and below.
            let row_bytes = options.width as u64 * sampling.count() as u64 * SAMPLE_WORDS as u64 * 4;
            let overlap = 2 * sampling.radius() as u64;
            let budget = gpu.limits.max_storage_buffer_binding_size.min(gpu.limits.max_buffer_size);
            if row_bytes * (1 + overlap) > budget {
                return Err(GpuError::Unsupported(super::support::UnsupportedError {
                    file: scene.path.clone(),
                    location: None,
                    what: format!(
                        "{} {} at {} pixels across: one row of samples and the filter's {overlap} rows around it exceed the adapter's storage binding limit of {budget} bytes",
                        sampling.sampler.flag(),
                        sampling.count(),
                        options.width
                    ),
                }));
            }
            let rows = (MAX_SAMPLE_BYTES.min(budget) / row_bytes).saturating_sub(overlap).max(1);
            tile_rows = tile_rows.min(rows as u32);
            sample_bytes = row_bytes * (tile_rows as u64 + overlap).min(options.height as u64);
        }
        let traced_rows = match options.sampling {
            Some(sampling) => (tile_rows + 2 * sampling.radius()).min(options.height),
            None => tile_rows,
        };
        let band_bytes = bins.map(|b| band_bytes(b, traced_rows, limit)).transpose()?;
        Ok(Tiling { tile_rows, sample_bytes, band_bytes })
    }

    /// The rows the first tile of a whole image traces (a band of a split render may start
    /// lower): those `PreparedScene::traced_rows` gives it.
    fn first_traced_rows(&self, options: &RenderOptions) -> u32 {
        let rows = self.tile_rows.min(options.height);
        options.sampling.map_or(rows, |sampling| (rows + sampling.radius()).min(options.height))
    }
}

impl SlotBuffers {
    /// A slot's buffers of `sizes`, those of the bins holding the lists of `band` (its
    /// first bin row, bin rows and lists) where given.
    /// Where the host maps the kernel's buffers, the output is mapped once here, which
    /// zeroes it: wgpu would otherwise clear it before the first tile, and lavapipe touch
    /// its fresh pages then.
    fn new(gpu: &GpuRenderer, sizes: SlotSizes, band: Option<&(u32, u32, Band)>) -> Result<SlotBuffers, GpuError> {
        use wgpu::BufferUsages as U;
        let maps = gpu.maps_kernel_buffers();
        let buffer = |label, size, usage, mapped_at_creation| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation })
        };
        let params = buffer("params", std::mem::size_of::<Params>() as u64, U::STORAGE | U::COPY_DST, false);
        let (output, readback) = if maps {
            let output = buffer("pixels", sizes.tile_bytes, U::STORAGE | U::MAP_READ | U::MAP_WRITE, true);
            output.unmap();
            (output, None)
        } else {
            let output = buffer("pixels", sizes.tile_bytes, U::STORAGE | U::COPY_SRC, false);
            (output, Some(buffer("readback", sizes.tile_bytes, U::MAP_READ | U::COPY_DST, false)))
        };
        let samples = buffer("samples", sizes.sample_bytes, U::STORAGE, false);
        let band_usage = if maps { U::STORAGE | U::COPY_DST | U::MAP_WRITE } else { U::STORAGE | U::COPY_DST };
        let bins = sizes.band_bytes.map(|(ranges, items)| {
            let written = |label, size, bytes: Option<&[u8]>| -> Result<wgpu::Buffer, GpuError> {
                let b = buffer(label, size, band_usage, bytes.is_some());
                if let Some(bytes) = bytes {
                    let mut view = b.slice(..bytes.len() as u64).get_mapped_range_mut();
                    view.as_mut().map_err(|e| GpuError::Upload(format!("{label}: {e}")))?.copy_from_slice(bytes);
                    drop(view);
                    b.unmap();
                }
                Ok(b)
            };
            let lists = band.map(|(_, _, lists)| lists);
            let list_items = lists.filter(|b| !b.items.is_empty()).map(|b| bytemuck::cast_slice(&b.items));
            Ok::<_, GpuError>(BandBuffers {
                ranges: written("bin_ranges", ranges, lists.map(|b| bytemuck::cast_slice(&b.ranges)))?,
                items: written("bin_items", items, list_items)?,
                holds: std::sync::Mutex::new(band.map(|&(first, count, _)| (first, count))),
            })
        });
        let bins = bins.transpose()?;
        let sampling = buffer("sampling", std::mem::size_of::<GpuSampling>() as u64, U::STORAGE | U::COPY_DST, false);
        let timer = gpu.timestamps.then(|| Timer::new(&gpu.device));
        Ok(SlotBuffers { params, sampling, samples, output, readback, bins, timer })
    }

    /// The buffer the host maps to read a tile.
    fn readable(&self) -> &wgpu::Buffer {
        self.readback.as_ref().unwrap_or(&self.output)
    }
}

impl Slot {
    fn new(
        gpu: &GpuRenderer,
        buffers: SlotBuffers,
        bindings: &BindingSet,
        inputs: &[Option<wgpu::Buffer>; BINDINGS.len()],
        counters: &wgpu::Buffer,
    ) -> Slot {
        let b = &buffers;
        let entries: Vec<_> = (0..BINDINGS.len())
            .filter(|&k| bindings.contains(k))
            .map(|k| {
                let resource = match k {
                    0 => &b.params,
                    OUTPUT_BINDING => &b.output,
                    COUNTERS_BINDING => counters,
                    SAMPLES_BINDING => &b.samples,
                    SAMPLING_BINDING => &b.sampling,
                    BIN_RANGES_BINDING if b.bins.is_some() => &b.bins.as_ref().expect("checked").ranges,
                    BIN_ITEMS_BINDING if b.bins.is_some() => &b.bins.as_ref().expect("checked").items,
                    _ => inputs[k].as_ref().expect("every input binding is uploaded"),
                };
                wgpu::BindGroupEntry { binding: k as u32, resource: resource.as_entire_binding() }
            })
            .collect();
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raycast"),
            layout: &bindings.group,
            entries: &entries,
        });
        Slot { buffers, bind_group }
    }
}

/// The sizes of a slot's buffers: the output tile, the samples, and where the frame has
/// bins those of the bin ranges and items of a band.
#[derive(Clone, Copy)]
struct SlotSizes {
    tile_bytes: u64,
    sample_bytes: u64,
    band_bytes: Option<(u64, u64)>,
}

/// The bytes of `bin_ranges` and `bin_items` that hold the lists of any band of bin rows a
/// tile tracing `traced_rows` image rows walks, refused where either exceeds the adapter's
/// storage binding limit. (A band spans at most one bin row more than the rows' height
/// when it does not start on a bin's edge.)
fn band_bytes(bins: &Bins, traced_rows: u32, limit: u64) -> Result<(u64, u64), GpuError> {
    let band_rows = ((traced_rows.max(1) - 1) / BIN_ROWS + 2).min(bins.rows);
    let ranges = band_rows as u64 * bins.columns as u64 * std::mem::size_of::<[u32; 2]>() as u64;
    let items = bins.most_items(band_rows).max(1) * std::mem::size_of::<BinItem>() as u64;
    if items > limit {
        return Err(GpuError::TooLarge(format!(
            "bin_items: {items} bytes for a tile's bins exceed the adapter's storage binding limit of {limit} bytes"
        )));
    }
    Ok((ranges, items))
}

impl Counters {
    const WORDS: u64 = STATS_SLOTS as u64 * STATS_WORDS as u64;

    fn new(gpu: &GpuRenderer, stats: bool) -> Counters {
        use wgpu::BufferUsages as U;
        let size = if stats { Self::WORDS * 4 } else { 4 };
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters"),
            size,
            usage: U::STORAGE | U::COPY_SRC | U::COPY_DST,
            mapped_at_creation: false,
        });
        let readback = stats.then(|| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("counters readback"),
                size,
                usage: U::MAP_READ | U::COPY_DST,
                mapped_at_creation: false,
            })
        });
        Counters { buffer, readback }
    }

    /// Zeroes the counts before a render that counts (ordered before its tiles, which are
    /// submitted after); `None` for a render that does not.
    fn zero(&self, gpu: &GpuRenderer) -> Option<RayStats> {
        self.readback.as_ref()?;
        gpu.queue.write_buffer(&self.buffer, 0, &[0; Self::WORDS as usize * 4]);
        Some(RayStats::default())
    }

    /// What the kernel counted since [`Counters::zero`], once its tiles are done.
    #[cfg(not(target_arch = "wasm32"))]
    fn read(&self, gpu: &GpuRenderer) -> Result<RayStats, GpuError> {
        let (readback, submission) = self.copy_to_readback(gpu);
        map_and_wait(&gpu.device, &readback.slice(..), submission)?;
        Self::sum_mapped(readback)
    }

    /// As [`Counters::read`], awaiting the map ([`PreparedScene::render_async`]).
    async fn read_async(&self, gpu: &GpuRenderer) -> Result<RayStats, GpuError> {
        let (readback, submission) = self.copy_to_readback(gpu);
        map_async(&gpu.device, &readback.slice(..), submission).await?;
        Self::sum_mapped(readback)
    }

    fn copy_to_readback(&self, gpu: &GpuRenderer) -> (&wgpu::Buffer, wgpu::SubmissionIndex) {
        let readback = self.readback.as_ref().expect("read only where counted");
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("counters") });
        encoder.copy_buffer_to_buffer(&self.buffer, 0, readback, 0, Self::WORDS * 4);
        (readback, gpu.queue.submit([encoder.finish()]))
    }

    fn sum_mapped(readback: &wgpu::Buffer) -> Result<RayStats, GpuError> {
        let counted = {
            let view = readback.slice(..).get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?;
            super::layout::sum_counters(bytemuck::cast_slice(&view))
        };
        readback.unmap();
        Ok(counted)
    }
}

/// The scene's read-only buffers, at their `@binding` (params and the output are per slot).
fn upload_inputs(
    gpu: &GpuRenderer,
    buffers: &SceneBuffers,
) -> Result<[Option<wgpu::Buffer>; BINDINGS.len()], GpuError> {
    let limit = gpu.limits.max_storage_buffer_binding_size;
    // Written in place where the host maps the kernel's buffers: else through a staging
    // buffer, which the device copies before the first tile.
    let maps = gpu.maps_kernel_buffers();
    let bvh = buffers.bvh.as_ref();
    let bins = buffers.bins.as_ref();
    let grid = buffers.grid.as_ref();
    // A grid has no hierarchy nor bins, and takes their bindings for its cells. The bins'
    // lists are each slot's, filled tile by tile.
    let refs = grid.map_or(bvh.map_or(&[][..], |b| &b.prim_refs), |g| &g.refs);
    let ranges = grid.map_or(&[][..], |g| &g.ranges);
    let contents: [Option<&[u8]>; BINDINGS.len()] = [
        None,
        Some(non_empty(&buffers.spheres)),
        Some(non_empty(&buffers.ellipsoids)),
        Some(non_empty(&buffers.planes)),
        Some(non_empty(&buffers.triangles)),
        Some(non_empty(&buffers.materials)),
        Some(non_empty(&buffers.lights)),
        None,
        Some(non_empty(bvh.map_or(&[][..], |b| &b.nodes))),
        Some(non_empty(refs)),
        Some(non_empty(bins.map_or(&[][..], |b| &b.eye_triangles))),
        bins.is_none().then(|| non_empty(ranges)),
        bins.is_none().then(|| non_empty::<BinItem>(&[])),
        Some(non_empty(&buffers.textures)),
        Some(non_empty(if buffers.textures.is_empty() { &[][..] } else { &PERLIN_PERMUTATION[..] })),
        None,
        None,
        None,
    ];
    let mut out: [Option<wgpu::Buffer>; BINDINGS.len()] = Default::default();
    for (k, bytes) in contents.iter().enumerate() {
        let Some(bytes) = bytes else { continue };
        let name = BINDINGS[k].name;
        if let Some((element, at, value)) = super::finite::first_non_finite(k as u32, bytes) {
            return Err(GpuError::NonFinite(format!(
                "{name}[{element}] holds {value} at byte {at}: the kernel takes finite values only"
            )));
        }
        if bytes.len() as u64 > limit {
            return Err(GpuError::TooLarge(format!(
                "{name}: {} bytes exceed the adapter's storage binding limit of {limit} bytes",
                bytes.len()
            )));
        }
        out[k] = Some(gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(name),
            contents: bytes,
            usage: if maps {
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::MAP_WRITE
            } else {
                wgpu::BufferUsages::STORAGE
            },
        }));
    }
    Ok(out)
}

/// A zero-sized buffer cannot be bound, so an empty list is uploaded as one zeroed element
/// (the kernel reads only as many as `Params` counts).
fn non_empty<T: bytemuck::Pod>(items: &[T]) -> &[u8] {
    const ZEROS: [u8; 128] = [0; 128];
    if items.is_empty() {
        &ZEROS[..std::mem::size_of::<T>()]
    } else {
        bytemuck::cast_slice(items)
    }
}

/// `a` and `b` at once, `a` on a thread of its own, where there are threads; in a browser,
/// or where the system refuses a thread, one after the other.
#[cfg(not(target_arch = "wasm32"))]
fn in_parallel<A: Send, B>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B) -> (A, B) {
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
fn in_parallel<A, B>(a: impl FnOnce() -> A, b: impl FnOnce() -> B) -> (A, B) {
    (a(), b())
}

/// Maps `slice` for reading once `submission` is done, blocking until it is.
#[cfg(not(target_arch = "wasm32"))]
pub(super) fn map_and_wait(
    device: &wgpu::Device,
    slice: &wgpu::BufferSlice,
    submission: wgpu::SubmissionIndex,
) -> Result<(), GpuError> {
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    device
        .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    receiver.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))
}

/// Maps `slice` for reading once `submission` is done, without blocking. Natively the poll
/// waits for the device and the map is resolved when it returns; in a browser polling does
/// nothing, and the map resolves once control returns to the page's event loop, which
/// awaiting gives it.
pub(super) async fn map_async(
    device: &wgpu::Device,
    slice: &wgpu::BufferSlice<'_>,
    submission: wgpu::SubmissionIndex,
) -> Result<(), GpuError> {
    let mapped = super::handoff::Handoff::default();
    let sender = mapped.clone();
    slice.map_async(wgpu::MapMode::Read, move |result| sender.send(result));
    device
        .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    mapped.await.map_err(|e| GpuError::Readback(e.to_string()))
}

impl ReadTile<'_> {
    /// The tile as float buffers (a render prepared with `packed = false`).
    pub fn to_frame(&self) -> Frame {
        assert!(!self.layout.packed, "a packed tile holds 8-bit images, not floats");
        self.layout.decode(self.options, self.rows, self.words)
    }

    /// The word of output `slot` (0 = the first output asked for) of each pixel.
    fn output_words(&self, slot: usize) -> impl ExactSizeIterator<Item = u32> + '_ {
        assert!(self.layout.packed, "a float tile holds no 8-bit images");
        let stride = self.layout.words() as usize;
        self.words.iter().skip(slot).step_by(stride).copied().take(self.width as usize * self.rows as usize)
    }

    /// 8-bit RGB rows of the diffuse-shaded image, quantised by the kernel.
    pub fn color_rgb(&self) -> Vec<u8> {
        rgb_of(self.output_words(0))
    }

    /// 8-bit RGB rows of the normal visualisation `|N|`, quantised by the kernel.
    pub fn normals_rgb(&self) -> Vec<u8> {
        rgb_of(self.output_words(self.layout.outputs.contains(Output::Color) as usize))
    }

    /// 8-bit RGB rows of the depth visualisation; the kernel hands over the distance `t`
    /// and the host quantises it in f64, exactly as [`crate::image_io::depth_image`] does.
    pub fn depth_rgb(&self, min: f32, max: f32) -> Vec<u8> {
        let slot = self.layout.outputs.contains(Output::Color) as usize
            + self.layout.outputs.contains(Output::Normals) as usize;
        let mut out = Vec::with_capacity(self.width as usize * self.rows as usize * 3);
        for word in self.output_words(slot) {
            let grey =
                if word == PACKED_MISS { 0 } else { crate::image_io::depth_level(f32::from_bits(word), min, max) };
            out.extend_from_slice(&[grey; 3]);
        }
        out
    }
}

/// Bytes r, g, b of words `r | g << 8 | b << 16`.
fn rgb_of(words: impl ExactSizeIterator<Item = u32>) -> Vec<u8> {
    let mut out = vec![0; 3 * words.len()];
    for (rgb, w) in out.chunks_exact_mut(3).zip(words) {
        rgb.copy_from_slice(&w.to_le_bytes()[..3]);
    }
    out
}

/// Pixels of a tile the reference rendered for the kernel, by why ([`Handover`]).
#[derive(Clone, Copy, Debug, Default)]
struct HandedOver {
    loops_cut: u64,
    beyond_reach: u64,
}

impl RenderStats {
    /// Counts one tile read back: its pixels handed over, by why, and its kernel time.
    fn add_tile(&mut self, handed: HandedOver, kernel_ns: Option<u64>) {
        self.pixels_cut_short += handed.loops_cut;
        self.pixels_beyond_reach += handed.beyond_reach;
        self.kernel_ns = self.kernel_ns.zip(kernel_ns).map(|(a, b)| a + b);
        self.tiles += 1;
    }
}

impl RenderAgain<'_> {
    /// `-stats` of a whole render: what the kernel counted, and the reference's counts
    /// for the pixels cut short. The kernel counted the pixels beyond a texture's reach
    /// itself, having traced them to the end, and not those cut short.
    fn add_counts(&self, mut counted: RayStats, kernel: RayStats) -> RayStats {
        counted.add(&kernel);
        if let Some(reference) = self.cut_short.get() {
            counted.add(&reference.stats());
        }
        counted
    }
}

/// The references that render handed-over pixels again, each built once per band, when
/// its first pixel comes (with `-grid`, building one builds the grid): one for the pixels
/// cut short, whose counts `-stats` adds, one for those beyond a texture's reach.
#[derive(Default)]
struct RenderAgain<'s> {
    cut_short: std::cell::OnceCell<Reference<'s>>,
    beyond_reach: std::cell::OnceCell<Reference<'s>>,
}
