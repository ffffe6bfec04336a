//! Reading back what the kernel wrote: mapping a buffer once its submission is done (by
//! blocking natively, by awaiting in a browser), a tile's words and their decoding, the
//! kernel's timestamps and its `-stats` counters.

use super::error::GpuError;
use super::layout::{sum_counters, PixelLayout, PACKED_MISS, STATS_SLOTS, STATS_WORDS};
use super::oneshot::OneShot;
use super::renderer::GpuRenderer;
use crate::image_io::{PackedRgb, RgbRows};
use crate::render::{Frame, Output, RayStats, RenderOptions};

/// One tile as the kernel wrote it and the host read it back, floats or packed 8-bit words
/// (its [`PixelLayout`]): `rows` full image rows from `first_row` (from the top).
pub struct ReadTile<'a> {
    pub first_row: u32,
    pub rows: u32,
    pub(super) width: u32,
    pub(super) layout: PixelLayout,
    pub(super) options: &'a RenderOptions,
    pub(super) words: &'a [u32],
}

impl ReadTile<'_> {
    /// The tile as float buffers (a render prepared with `packed = false`).
    pub fn to_frame(&self) -> Frame {
        assert!(!self.layout.packed, "a packed tile holds 8-bit images, not floats");
        self.layout.decode(self.options, self.rows, self.words)
    }

    /// The tile decoded straight into its rows of `frame`, a whole image's float buffers
    /// (a render prepared with `packed = false`): what [`ReadTile::to_frame`] and
    /// [`Frame::paste`] do, without the tile's own frame.
    pub fn decode_into(&self, frame: &mut Frame) {
        assert!(!self.layout.packed, "a packed tile holds 8-bit images, not floats");
        assert_eq!(frame.width, self.width, "tiles are full rows");
        self.layout.decode_into(self.words, frame, self.first_row as usize * self.width as usize);
    }

    /// The word of output `slot` (0 = the first output asked for) of each pixel.
    fn output_words(&self, slot: usize) -> impl ExactSizeIterator<Item = u32> + '_ {
        assert!(self.layout.packed, "a float tile holds no 8-bit images");
        let stride = self.layout.words() as usize;
        self.words.iter().skip(slot).step_by(stride).copied().take(self.pixels())
    }

    /// Output `slot`'s pixels as the kernel packed them, for a writer to reorder.
    fn output_rows(&self, slot: usize) -> RgbRows<'_> {
        assert!(self.layout.packed, "a float tile holds no 8-bit images");
        RgbRows::Packed(PackedRgb::new(&self.words[slot..], self.layout.words() as usize, self.pixels()))
    }

    fn pixels(&self) -> usize {
        self.width as usize * self.rows as usize
    }

    /// The diffuse-shaded image's rows, quantised by the kernel, as it packed them.
    pub fn color_rows(&self) -> RgbRows<'_> {
        assert!(self.layout.outputs.contains(Output::Color), "the tile holds no colour");
        self.output_rows(0)
    }

    /// 8-bit RGB rows of the diffuse-shaded image, quantised by the kernel.
    pub fn color_rgb(&self) -> Vec<u8> {
        self.color_rows().to_vec()
    }

    /// [`ReadTile::color_rgb`] written straight into its rows of `rgb`, a whole image's
    /// 8-bit RGB (rows top first): a frame a loop keeps, with no tile of its own to make.
    ///
    /// # Panics
    /// If the tile holds no colour, or its rows run past the end of `rgb`.
    pub fn color_rgb_into(&self, rgb: &mut [u8]) {
        let start = self.first_row as usize * self.width as usize * 3;
        self.color_rows().rgb_into(0, &mut rgb[start..start + 3 * self.pixels()]);
    }

    /// The rows of the normal visualisation `|N|`, quantised by the kernel, as it packed them.
    pub fn normals_rows(&self) -> RgbRows<'_> {
        assert!(self.layout.outputs.contains(Output::Normals), "the tile holds no normals");
        self.output_rows(self.layout.outputs.contains(Output::Color) as usize)
    }

    /// 8-bit RGB rows of the normal visualisation `|N|`, quantised by the kernel.
    pub fn normals_rgb(&self) -> Vec<u8> {
        self.normals_rows().to_vec()
    }

    /// The words of the depth output: the distance `t`'s bits, [`PACKED_MISS`] where
    /// nothing was hit.
    fn depth_words(&self) -> impl ExactSizeIterator<Item = u32> + '_ {
        assert!(self.layout.outputs.contains(Output::Depth), "the tile holds no depth");
        let slot = self.layout.outputs.contains(Output::Color) as usize
            + self.layout.outputs.contains(Output::Normals) as usize;
        self.output_words(slot)
    }

    /// The hit distances `t` the kernel handed over, as [`crate::image_io::depth_values`]
    /// gives them from floats: +∞ where nothing was hit (`-depth` as EXR).
    pub fn depth_values(&self) -> Vec<f32> {
        self.depth_words().map(|word| if word == PACKED_MISS { f32::INFINITY } else { f32::from_bits(word) }).collect()
    }

    /// 8-bit RGB rows of the depth visualisation; the kernel hands over the distance `t`
    /// and the host quantises it in f64, exactly as [`crate::image_io::depth_image`] does.
    pub fn depth_rgb(&self, min: f32, max: f32) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.pixels() * 3);
        for word in self.depth_words() {
            let grey =
                if word == PACKED_MISS { 0 } else { crate::image_io::depth_level(f32::from_bits(word), min, max) };
            out.extend_from_slice(&[grey; 3]);
        }
        out
    }
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
    let mapped = OneShot::default();
    let sender = mapped.clone();
    slice.map_async(wgpu::MapMode::Read, move |result| sender.send(result));
    device
        .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    mapped.await.map_err(|e| GpuError::Readback(e.to_string()))
}

/// The `counters` binding: [`STATS_SLOTS`] slots of [`STATS_WORDS`] words, with a buffer to
/// read them back, where the render counts (`-stats`); else one word no kernel touches.
pub(super) struct Counters {
    pub buffer: wgpu::Buffer,
    readback: Option<wgpu::Buffer>,
}

impl Counters {
    const WORDS: u64 = STATS_SLOTS as u64 * STATS_WORDS as u64;

    pub fn new(gpu: &GpuRenderer, stats: bool) -> Counters {
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
    pub fn zero(&self, gpu: &GpuRenderer) -> Option<RayStats> {
        self.readback.as_ref()?;
        gpu.queue.write_buffer(&self.buffer, 0, &[0; Self::WORDS as usize * 4]);
        Some(RayStats::default())
    }

    /// What the kernel counted since [`Counters::zero`], once its tiles are done.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn read(&self, gpu: &GpuRenderer) -> Result<RayStats, GpuError> {
        let (readback, submission) = self.copy_to_readback(gpu);
        map_and_wait(&gpu.device, &readback.slice(..), submission)?;
        Self::sum_mapped(readback)
    }

    /// As [`Counters::read`], awaiting the map ([`PreparedScene::render_async`]).
    pub async fn read_async(&self, gpu: &GpuRenderer) -> Result<RayStats, GpuError> {
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
            sum_counters(bytemuck::cast_slice(&view))
        };
        readback.unmap();
        Ok(counted)
    }
}

/// Two timestamps around the compute pass, resolved into a buffer we can map.
pub(super) struct Timer {
    pub queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl Timer {
    pub fn new(device: &wgpu::Device) -> Timer {
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        Timer {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel time"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolved: buffer("timestamps", wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
            readback: buffer("timestamps readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST),
        }
    }

    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolved, 0);
        encoder.copy_buffer_to_buffer(&self.resolved, 0, &self.readback, 0, 16);
    }

    #[cfg(not(target_arch = "wasm32"))]
    pub fn elapsed_ns(&self, device: &wgpu::Device, period_ns: f32) -> Result<u64, GpuError> {
        let bytes = read_back(device, &self.readback)?;
        Ok(Self::span_ns(&bytes, period_ns))
    }

    /// As [`Timer::elapsed_ns`], awaiting the map ([`PreparedScene::render_async`]).
    pub async fn elapsed_ns_async(
        &self,
        gpu: &GpuRenderer,
        submission: wgpu::SubmissionIndex,
    ) -> Result<u64, GpuError> {
        let slice = self.readback.slice(..);
        map_async(&gpu.device, &slice, submission).await?;
        let bytes = slice.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
        self.readback.unmap();
        Ok(Self::span_ns(&bytes, gpu.queue.get_timestamp_period()))
    }

    fn span_ns(bytes: &[u8], period_ns: f32) -> u64 {
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(bytes);
        (ticks[1].saturating_sub(ticks[0]) as f64 * period_ns as f64) as u64
    }
}

#[cfg(not(target_arch = "wasm32"))]
fn read_back(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
    receiver.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
    let bytes = slice.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
    buffer.unmap();
    Ok(bytes)
}
