//! Choosing and calling a renderer: the GPU kernel or the f64 CPU reference.

use crate::app::cli::BackendChoice;
use crate::app::output::Kind;
use raycaster::cpu::Reference;
use raycaster::gpu::{GpuError, GpuRenderer, RenderStats};
use raycaster::image_io;
use raycaster::render::{row_tiles, Frame, RenderOptions};
use raycaster::scene::Scene;

/// About how many pixels the CPU reference renders per tile: enough rows to keep every core
/// busy, few enough to bound memory and to move a progress bar every second or so.
const CPU_TILE_PIXELS: u32 = 1 << 18;

/// A ready renderer.
pub enum Backend {
    Gpu(Box<GpuRenderer>),
    Cpu,
}

impl Backend {
    /// Opens the backend `choice` asks for. With `Auto`, a missing GPU falls back to the CPU
    /// reference and the returned notice says so (for stderr).
    pub fn open(choice: BackendChoice) -> Result<(Backend, Option<String>), GpuError> {
        match choice {
            BackendChoice::Cpu => Ok((Backend::Cpu, None)),
            BackendChoice::Gpu => Ok((Backend::Gpu(Box::new(GpuRenderer::new()?)), None)),
            BackendChoice::Auto => match GpuRenderer::new() {
                Ok(gpu) => Ok((Backend::Gpu(Box::new(gpu)), None)),
                Err(e) => Ok((Backend::Cpu, Some(format!("{e}; rendering with the CPU reference instead")))),
            },
        }
    }

    /// What renders, in words: the adapter, or the reference and its threads.
    pub fn describe(&self) -> String {
        match self {
            Backend::Gpu(gpu) => {
                let info = gpu.adapter_info();
                format!("gpu, {} ({:?}, {:?})", info.name, info.backend, info.device_type)
            }
            Backend::Cpu => match rayon::current_num_threads() {
                1 => "cpu, the f64 reference on 1 thread".to_string(),
                n => format!("cpu, the f64 reference on {n} threads"),
            },
        }
    }

    /// Renders image rows `first .. first + rows` (the whole image, or one band of a split
    /// render) in tiles of full rows, top first, handing each tile and its first image row
    /// to `on_tile`; see [`GpuRenderer::render_band`].
    pub fn render_band<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        match self {
            Backend::Gpu(gpu) => gpu.render_band(scene, options, first, rows, on_tile),
            Backend::Cpu => {
                let reference = Reference::new(scene, options);
                let mut stats = RenderStats::default();
                for (offset, rows) in row_tiles(rows, CPU_TILE_PIXELS / options.width) {
                    let first_row = first + offset;
                    on_tile(first_row, reference.rows(first_row, rows))?;
                    stats.tiles += 1;
                }
                Ok(stats)
            }
        }
    }

    /// Renders the 8-bit images `options` asks for (the depth visualisation over
    /// `depth_range`) for image rows `first .. first + rows` (the whole image, or one band of
    /// a split render), in tiles of full rows, top first. On the GPU the kernel quantises,
    /// so only the bytes of the images cross from the device.
    pub fn render_images<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        depth_range: (f32, f32),
        (first, rows): (u32, u32),
        mut on_tile: impl FnMut(u32, ImageRows) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let (min, max) = depth_range;
        match self {
            Backend::Gpu(gpu) => gpu.prepare(scene, options, true)?.render_band(first, rows, |tile| {
                let rows = ImageRows {
                    rows: tile.rows,
                    color: options.color.then(|| tile.color_rgb()),
                    normals: options.normals.then(|| tile.normals_rgb()),
                    depth: options.depth.then(|| tile.depth_rgb(min, max)),
                };
                on_tile(tile.first_row, rows)
            }),
            Backend::Cpu => self.render_band(scene, options, first, rows, |first_row, frame| {
                let rows = ImageRows {
                    rows: frame.height,
                    color: options.color.then(|| image_io::color_image(&frame).into_raw()),
                    normals: options.normals.then(|| image_io::normals_image(&frame).into_raw()),
                    depth: options.depth.then(|| image_io::depth_image(&frame, min, max).into_raw()),
                };
                on_tile(first_row, rows)
            }),
        }
    }
}

/// One tile's rows of each 8-bit image asked for, RGB, top row first.
pub struct ImageRows {
    /// How many rows the tile has.
    pub rows: u32,
    pub color: Option<Vec<u8>>,
    pub normals: Option<Vec<u8>>,
    pub depth: Option<Vec<u8>>,
}

impl ImageRows {
    /// The rows of the image of `kind`, once (each kind is asked for at most once).
    pub fn take(&mut self, kind: Kind) -> Vec<u8> {
        let rows = match kind {
            Kind::Color => &mut self.color,
            Kind::Normals => &mut self.normals,
            Kind::Depth { .. } => &mut self.depth,
        };
        rows.take().expect("the render computed every output asked for")
    }
}
