//! How a render is cut into tiles of rows, and the buffers of a tile in flight: its
//! parameters, output, samples and band of the bins' lists, bound with the scene's inputs.

use super::bindings::{Binding, BindingSet};
use super::binning::{Band, Bins, BIN_ROWS};
use super::error::GpuError;
use super::layout::{BinItem, GpuSampling, Params, PixelLayout, SAMPLE_WORDS};
use super::readback::Timer;
use super::renderer::GpuRenderer;
use super::unsupported::UnsupportedError;
use super::upload::Inputs;
use super::workgroup::{BIN_PACKET, WORKGROUP};
use crate::render::RenderOptions;
use crate::scene::Scene;

/// The most bytes of samples one tile holds (the overlap rows of the filter included).
pub const MAX_SAMPLE_BYTES: u64 = 64 << 20;

/// The output tile of one dispatch on each kind of adapter, at most. On a CPU adapter
/// (lavapipe) a tile's bins and pixels share the CPU's caches with the kernel, and 1 MiB was
/// measured best. On a GPU 2 MiB: on an NVIDIA H200, bunny_40k's render (8-bit output) took
/// less time in 2 MiB tiles than in tiles of up to 32 MiB at 2048², 4096² and 8192². A
/// large tile's buffers cost more to make than its submissions save, and a few large tiles
/// leave little readback to overlap with the next tile's work (docs/performance.md, "On a
/// real GPU"). Small tiles also keep each submission far below an operating system's
/// watchdog (docs/SPEC.md §6).
fn adapter_tile_bytes(device_type: wgpu::DeviceType) -> u64 {
    match device_type {
        wgpu::DeviceType::Cpu => 1 << 20,
        _ => 2 << 20,
    }
}

/// How a render is cut into tiles: rows per tile, the bytes of a tile's samples and of its
/// bins' lists.
pub(super) struct Tiling {
    pub tile_rows: u32,
    pub sample_bytes: u64,
    pub band_bytes: Option<(u64, u64)>,
}

impl Tiling {
    pub fn new(
        gpu: &GpuRenderer,
        scene: &Scene,
        options: &RenderOptions,
        layout: &PixelLayout,
        bins: Option<&Bins>,
    ) -> Result<Tiling, GpuError> {
        let mut tile_rows = tile_rows(gpu, options.width, layout)?;
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
                return Err(GpuError::Unsupported(UnsupportedError {
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

    /// Whether tiles cut this way fit the slots of a render cut into `tile_rows` rows with
    /// buffers of `sizes`: the same rows, no more samples nor longer lists.
    pub fn fits(&self, tile_rows: u32, sizes: SlotSizes) -> bool {
        let lists_fit = match (self.band_bytes, sizes.band_bytes) {
            (Some((ranges, items)), Some((room_ranges, room_items))) => ranges <= room_ranges && items <= room_items,
            (None, None) => true,
            _ => false,
        };
        self.tile_rows == tile_rows && self.sample_bytes <= sizes.sample_bytes && lists_fit
    }

    /// The rows the first tile of a whole image traces (a band of a split render may start
    /// lower): those `Dispatch::traced_rows` gives it.
    pub fn first_traced_rows(&self, options: &RenderOptions) -> u32 {
        let rows = self.tile_rows.min(options.height);
        options.sampling.map_or(rows, |sampling| (rows + sampling.radius()).min(options.height))
    }
}

/// How many image rows one dispatch renders: as many as fit the adapter's storage
/// binding limit, the tile of its kind of adapter ([`adapter_tile_bytes`]) or the one the
/// caller aims for, the caller's cap, and the dispatch size limit.
fn tile_rows(gpu: &GpuRenderer, width: u32, layout: &PixelLayout) -> Result<u32, GpuError> {
    let aim = gpu.options.tile_bytes.unwrap_or_else(|| adapter_tile_bytes(gpu.adapter_info.device_type));
    let cap = gpu.options.max_tile_bytes.min(aim);
    rows_within(&gpu.limits, cap, width, layout.words())
}

/// [`tile_rows`] for `width` pixels of `words` words each, at most `cap` bytes a tile.
fn rows_within(limits: &wgpu::Limits, cap: u64, width: u32, words: u32) -> Result<u32, GpuError> {
    let row_bytes = width as u64 * words as u64 * 4;
    let adapter_budget = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
    let max_groups = limits.max_compute_workgroups_per_dimension as u64;
    if row_bytes > adapter_budget || (width as u64).div_ceil(WORKGROUP as u64) > max_groups {
        return Err(GpuError::TooLarge(format!("an image {width} pixels wide exceeds the adapter's limits")));
    }
    let rows = (cap.min(adapter_budget) / row_bytes).max(1);
    // Whole workgroup rows where possible, so no dispatch ends in a half-empty workgroup.
    // Whole workgroups of the largest packet, whichever kernel runs.
    let group_rows = (WORKGROUP * BIN_PACKET) as u64;
    let rows = if rows >= group_rows { rows - rows % group_rows } else { rows };
    Ok(rows.min((max_groups - 1) * group_rows) as u32)
}

/// The buffers one tile in flight uses, and their bindings: one of the two that take turns.
pub(super) struct TileSlot {
    pub buffers: TileBuffers,
    pub bind_group: wgpu::BindGroup,
}

/// The buffers of a [`TileSlot`], made before the kernel's bindings are known (while it
/// compiles).
pub(super) struct TileBuffers {
    pub params: wgpu::Buffer,
    /// The tile's samples and their parameters (a word each without sampling).
    pub sampling: wgpu::Buffer,
    pub samples: wgpu::Buffer,
    pub output: wgpu::Buffer,
    /// The buffer the output is copied into for the host to read, or `None` where the
    /// host maps the output itself ([`GpuRenderer::maps_kernel_buffers`]).
    pub readback: Option<wgpu::Buffer>,
    /// The lists of the bins the tile's rays walk, where the frame has bins.
    pub bins: Option<BandBuffers>,
    pub timer: Option<Timer>,
}

/// The `bin_ranges` and `bin_items` of a slot: room for the lists of the largest band of
/// bin rows a tile traces.
pub(super) struct BandBuffers {
    pub ranges: wgpu::Buffer,
    pub items: wgpu::Buffer,
    /// The band (its first bin row and bin rows) whose lists the buffers hold: slot 0's
    /// are the whole image's first tile's, written while the kernel compiles.
    pub holds: std::sync::Mutex<Option<(u32, u32)>>,
}

impl TileBuffers {
    /// A slot's buffers of `sizes`, those of the bins holding the lists of `band` (its
    /// first bin row, bin rows and lists) where given.
    /// Where the host maps the kernel's buffers, the output is mapped once here, which
    /// zeroes it: wgpu would otherwise clear it before the first tile, and lavapipe touch
    /// its fresh pages then.
    pub fn new(gpu: &GpuRenderer, sizes: SlotSizes, band: Option<&(u32, u32, Band)>) -> Result<TileBuffers, GpuError> {
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
        Ok(TileBuffers { params, sampling, samples, output, readback, bins, timer })
    }

    /// The buffer the host maps to read a tile.
    pub fn readable(&self) -> &wgpu::Buffer {
        self.readback.as_ref().unwrap_or(&self.output)
    }
}

impl TileSlot {
    pub fn new(
        gpu: &GpuRenderer,
        buffers: TileBuffers,
        bindings: &BindingSet,
        inputs: &Inputs,
        counters: &wgpu::Buffer,
    ) -> TileSlot {
        let b = &buffers;
        let entries: Vec<_> = bindings
            .bindings()
            .map(|binding| {
                let resource = match (binding, &b.bins) {
                    (Binding::Params, _) => &b.params,
                    (Binding::Pixels, _) => &b.output,
                    (Binding::Counters, _) => counters,
                    (Binding::Samples, _) => &b.samples,
                    (Binding::Sampling, _) => &b.sampling,
                    (Binding::BinRanges, Some(band)) => &band.ranges,
                    (Binding::BinItems, Some(band)) => &band.items,
                    _ => inputs[binding].as_ref().expect("every input binding is uploaded"),
                };
                wgpu::BindGroupEntry { binding: binding.index(), resource: resource.as_entire_binding() }
            })
            .collect();
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raycast"),
            layout: &bindings.group,
            entries: &entries,
        });
        TileSlot { buffers, bind_group }
    }
}

/// The sizes of a slot's buffers: the output tile, the samples, and where the frame has
/// bins those of the bin ranges and items of a band.
#[derive(Clone, Copy)]
pub(super) struct SlotSizes {
    pub tile_bytes: u64,
    pub sample_bytes: u64,
    pub band_bytes: Option<(u64, u64)>,
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

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::DeviceType;

    /// Tiles of a `side`² image of `words` words a pixel on `device_type` with `limits`, the
    /// caller's cap left at its default.
    fn tiles(device_type: DeviceType, limits: &wgpu::Limits, side: u32, words: u32) -> u32 {
        let cap = super::super::GpuOptions::default().max_tile_bytes.min(adapter_tile_bytes(device_type));
        side.div_ceil(rows_within(limits, cap, side, words).unwrap())
    }

    #[test]
    fn a_gpu_renders_in_tiles_of_2_mib_and_lavapipe_in_tiles_of_1_mib() {
        // wgpu's default limits (a 128 MiB binding), which every adapter offers at least.
        let limits = wgpu::Limits::default();
        // 8192² with the colour as 8-bit words (what `-output` reads back): 256 MiB.
        for gpu in [DeviceType::DiscreteGpu, DeviceType::IntegratedGpu, DeviceType::Other] {
            assert_eq!(tiles(gpu, &limits, 8192, 1), 128, "{gpu:?}");
        }
        assert_eq!(tiles(DeviceType::Cpu, &limits, 8192, 1), 256);
    }

    #[test]
    fn a_tile_stays_within_the_adapters_binding_limit() {
        let limits = wgpu::Limits { max_storage_buffer_binding_size: 4 << 20, ..wgpu::Limits::default() };
        let rows = rows_within(&limits, 32 << 20, 8192, 8).unwrap();
        assert!(rows as u64 * 8192 * 8 * 4 <= 4 << 20, "{rows} rows");
        assert!(rows >= 1);
        // A row wider than the binding is refused by name, not cut.
        let refused = rows_within(&limits, 32 << 20, 1 << 16, 32).unwrap_err();
        assert!(refused.to_string().contains("65536 pixels wide exceeds the adapter's limits"), "{refused}");
    }
}
