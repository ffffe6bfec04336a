//! Choosing and calling a renderer: the GPU kernel or the f64 CPU reference.

use crate::app::cli::BackendChoice;
use raycaster::cpu::Reference;
use raycaster::gpu::{GpuError, GpuRenderer, RenderStats};
use raycaster::image_io;
use raycaster::render::{row_tiles, Frame, RenderOptions};
use raycaster::scene::Scene;

/// About how many pixels the CPU reference renders per tile (enough rows to keep both cores
/// busy, few enough to bound memory).
const CPU_TILE_PIXELS: u32 = 1 << 20;

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

    /// Renders in tiles of full rows, top first, handing each tile and its first row to
    /// `on_tile`; see [`GpuRenderer::render_tiles`].
    pub fn render_tiles<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        match self {
            Backend::Gpu(gpu) => gpu.render_tiles(scene, options, on_tile),
            Backend::Cpu => {
                let reference = Reference::new(scene, options);
                let mut stats = RenderStats::default();
                for (first_row, rows) in row_tiles(options.height, CPU_TILE_PIXELS / options.width) {
                    on_tile(first_row, reference.rows(first_row, rows))?;
                    stats.tiles += 1;
                }
                Ok(stats)
            }
        }
    }

    /// Renders the 8-bit images `options` asks for (the depth visualisation over
    /// `depth_range`), in tiles of full rows, top first. On the GPU the kernel quantises,
    /// so only the bytes of the images cross from the device.
    pub fn render_images<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        depth_range: (f32, f32),
        mut on_tile: impl FnMut(u32, ImageRows) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let (min, max) = depth_range;
        match self {
            Backend::Gpu(gpu) => gpu.prepare(scene, options, true)?.render(|tile| {
                let rows = ImageRows {
                    color: options.color.then(|| tile.color_rgb()),
                    normals: options.normals.then(|| tile.normals_rgb()),
                    depth: options.depth.then(|| tile.depth_rgb(min, max)),
                };
                on_tile(tile.first_row, rows)
            }),
            Backend::Cpu => self.render_tiles(scene, options, |first_row, frame| {
                let rows = ImageRows {
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
    pub color: Option<Vec<u8>>,
    pub normals: Option<Vec<u8>>,
    pub depth: Option<Vec<u8>>,
}
