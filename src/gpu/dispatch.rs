//! Dispatching one tile: its parameters, its band of the bins' lists, the kernel's passes
//! and the copy the host reads.

use super::binning::Bins;
use super::layout::{GpuSampling, Params, PixelLayout};
use super::renderer::{GpuRenderer, Sampled};
use super::tiles::{TileBuffers, TileSlot};
use super::workgroup::WORKGROUP;
use crate::render::RenderOptions;
#[cfg(not(target_arch = "wasm32"))]
use {super::error::GpuError, super::readback::map_and_wait};

/// What renders a prepared scene's tiles: its kernels, the slots of per-tile buffers that
/// take turns, and the frame's bins, on `gpu`: a renderer (`&GpuRenderer`), or while the
/// scene is set apart from it the device they belong to (`gpu::aim::DetachedScene`).
pub(super) struct Dispatch<G> {
    pub gpu: G,
    /// The kernel of a render without sampling (`sampled` holds the others).
    pub pipeline: Option<wgpu::ComputePipeline>,
    /// With sampling: the passes that trace the samples and filter them.
    pub sampled: Option<Sampled>,
    /// Pixels per invocation ([`KernelConfig::packet`](super::KernelConfig::packet)).
    pub packet: u32,
    pub layout: PixelLayout,
    /// The parameters every tile shares (each sets its own rows).
    pub params: Params,
    pub options: RenderOptions,
    pub tile_rows: u32,
    pub slots: Vec<TileSlot>,
    /// The frame's screen-space bins, whose lists each tile fills for its own band of rows
    /// ([`Bins::band`]) into its slot's buffers.
    pub bins: Option<Bins>,
    /// Nanoseconds spent filling slots' lists from the bins, over every tile so far
    /// (`RenderStats::lists_ms`: a render reads the difference).
    pub lists_ns: std::sync::atomic::AtomicU64,
}

impl<G> Dispatch<G> {
    /// The same tiles on `gpu` instead.
    pub fn on<H>(self, gpu: H) -> Dispatch<H> {
        Dispatch {
            gpu,
            pipeline: self.pipeline,
            sampled: self.sampled,
            packet: self.packet,
            layout: self.layout,
            params: self.params,
            options: self.options,
            tile_rows: self.tile_rows,
            slots: self.slots,
            bins: self.bins,
            lists_ns: self.lists_ns,
        }
    }
}

impl Dispatch<&GpuRenderer> {
    pub fn tile_bytes(&self, rows: u32) -> u64 {
        self.options.width as u64 * rows as u64 * self.layout.words() as u64 * 4
    }

    /// Dispatches one tile into `slot` and waits until the host can read it (mapped);
    /// returns the kernel time where the adapter measures it.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn run_tile(&self, slot: usize, first_row: u32, rows: u32) -> Result<Option<u64>, GpuError> {
        self.wait_tile(slot, rows, self.submit_tile(slot, first_row, rows))
    }

    /// Waits until the host can read (mapped) the tile of `rows` rows that `submission`
    /// renders into `slot` ([`Dispatch::submit_tile`]); returns the kernel time where the
    /// adapter measures it.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn wait_tile(
        &self,
        slot: usize,
        rows: u32,
        submission: wgpu::SubmissionIndex,
    ) -> Result<Option<u64>, GpuError> {
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
            let filling = crate::clock::Instant::now();
            let band = bins.band(first, count);
            let queue = &self.gpu.queue;
            queue.write_buffer(&buffers.ranges, 0, bytemuck::cast_slice(&band.ranges));
            if !band.items.is_empty() {
                queue.write_buffer(&buffers.items, 0, bytemuck::cast_slice(&band.items));
            }
            *holds = Some((first, count));
            let ns = filling.elapsed().as_nanos() as u64;
            self.lists_ns.fetch_add(ns, std::sync::atomic::Ordering::Relaxed);
        }
        first
    }

    /// Dispatches one tile into `slot`, and copies it to the slot's readback buffer where
    /// it has one.
    pub fn submit_tile(&self, slot: usize, first_row: u32, rows: u32) -> wgpu::SubmissionIndex {
        let size = self.tile_bytes(rows);
        self.submit_tile_then(slot, first_row, rows, |encoder, s| {
            if let Some(readback) = &s.readback {
                encoder.copy_buffer_to_buffer(&s.output, 0, readback, 0, size);
            }
        })
    }

    /// Dispatches one tile into `slot`, then what `then` records on the slot's buffers (a
    /// copy for the host, or the pass that draws the tile onto a texture, `gpu::present`),
    /// in one submission.
    pub fn submit_tile_then(
        &self,
        slot: usize,
        first_row: u32,
        rows: u32,
        then: impl FnOnce(&mut wgpu::CommandEncoder, &TileBuffers),
    ) -> wgpu::SubmissionIndex {
        let gpu = self.gpu;
        let (traced_first, traced_rows) = self.traced_rows(first_row, rows);
        let first_bin_row = self.upload_band(slot, traced_first, traced_rows);
        let (s, bind_group) = (&self.slots[slot].buffers, &self.slots[slot].bind_group);
        let params = Params { first_row, tile_rows: rows, first_bin_row, ..self.params };
        gpu.queue.write_buffer(&s.params, 0, bytemuck::bytes_of(&params));
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
            match &self.sampled {
                None => self.dispatch_pixels(&mut pass, first_row, rows),
                Some(sampled) => {
                    self.dispatch_samples(&mut pass, sampled, &s.sampling, (traced_first, traced_rows), rows)
                }
            }
        }
        then(&mut encoder, s);
        if let Some(timer) = &s.timer {
            timer.resolve(&mut encoder);
        }
        gpu.queue.submit([encoder.finish()])
    }

    /// The pixels kernel over the tile's rows: an invocation per pixel, or per packet.
    fn dispatch_pixels(&self, pass: &mut wgpu::ComputePass<'_>, first_row: u32, rows: u32) {
        pass.set_pipeline(self.pipeline.as_ref().expect("a render without sampling has its pixels kernel"));
        // Packets start at the tile's first row rounded down to a multiple of PACKET.
        let packets = (first_row % self.packet + rows).div_ceil(self.packet);
        pass.dispatch_workgroups(self.options.width.div_ceil(WORKGROUP), packets.div_ceil(WORKGROUP), 1);
    }

    /// Every sample of the tile's rows and of the rows the filter reads around them
    /// (`traced`), then each of the tile's `rows` of pixels from them (the two dispatches are
    /// ordered: wgpu puts a barrier between a pass's dispatches that write and read a buffer).
    fn dispatch_samples(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        sampled: &Sampled,
        header_buffer: &wgpu::Buffer,
        (sample_first, sample_rows): (u32, u32),
        rows: u32,
    ) {
        let sampling = &sampled.sampling;
        let header = GpuSampling {
            count: sampling.count(),
            side: sampling.sampler.side(),
            seed: sampling.seed,
            kind: sampling.sampler.kind(),
            filter_kind: sampling.filter.kind(),
            radius: sampling.radius(),
            parameter: sampling.filter.parameter() as f32,
            first_row: sample_first,
            rows: sample_rows,
            _pad: [0; 3],
        };
        self.gpu.queue.write_buffer(header_buffer, 0, bytemuck::bytes_of(&header));
        let columns = self.options.width.div_ceil(WORKGROUP);
        pass.set_pipeline(&sampled.samples);
        // With bins, an invocation traces a packet: a pixel's samples, or for fewer samples
        // than a packet, those of a stack of rows starting at a multiple of their count (the
        // kernel's `packet_rows`).
        let packets = sampling.count().div_ceil(self.packet);
        let stack = (self.packet / sampling.count()).max(1);
        let stacks = (sample_first % stack + sample_rows).div_ceil(stack);
        pass.dispatch_workgroups(columns, stacks.div_ceil(WORKGROUP), packets);
        pass.set_pipeline(&sampled.filter);
        pass.dispatch_workgroups(columns, rows.div_ceil(WORKGROUP), 1);
    }
}
