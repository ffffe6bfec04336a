//! Choosing and calling a renderer: the GPU kernel or the f64 CPU reference.

use crate::app::cli::BackendChoice;
use raycaster::cpu::Reference;
use raycaster::gpu::{GpuError, GpuRenderer, RenderStats};
use raycaster::render::{row_tiles, Frame, RenderOptions};
use raycaster::scene::Scene;

/// About how many pixels the CPU reference renders per tile (enough rows to keep both cores
/// busy, few enough to bound memory).
const CPU_TILE_PIXELS: u32 = 1 << 20;

/// A ready renderer.
pub enum Backend {
    Gpu(Box<GpuRenderer>),
    Cpu,
    /// The GPU, except for scenes its f32 kernel cannot render faithfully
    /// ([`raycaster::gpu::precision`]), which the CPU reference renders.
    Auto(Box<GpuRenderer>),
}

impl Backend {
    /// Opens the backend `choice` asks for. With `Auto`, a missing GPU falls back to the CPU
    /// reference and the returned notice says so (for stderr).
    pub fn open(choice: BackendChoice) -> Result<(Backend, Option<String>), GpuError> {
        match choice {
            BackendChoice::Cpu => Ok((Backend::Cpu, None)),
            BackendChoice::Gpu => Ok((Backend::Gpu(Box::new(GpuRenderer::new()?)), None)),
            BackendChoice::Auto => match GpuRenderer::new() {
                Ok(gpu) => Ok((Backend::Auto(Box::new(gpu)), None)),
                Err(e) => Ok((Backend::Cpu, Some(format!("{e}; rendering with the CPU reference instead")))),
            },
        }
    }

    /// Renders in tiles of full rows, top first, handing each tile and its first row to
    /// `on_tile`; see [`GpuRenderer::render_tiles`]. With `Auto`, a scene outside the f32
    /// kernel's range is rendered by the CPU reference, and the notice says which value.
    pub fn render_tiles<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<(RenderStats, Option<String>), E> {
        match self {
            Backend::Gpu(gpu) => Ok((gpu.render_tiles(scene, options, on_tile)?, None)),
            Backend::Cpu => Ok((cpu_tiles(scene, options, on_tile)?, None)),
            Backend::Auto(gpu) => {
                // The GPU refuses before its first tile, so a refused scene has handed
                // nothing to `on_tile` yet and the reference can start from the top.
                match gpu.render_tiles(scene, options, |row, tile| on_tile(row, tile).map_err(Attempt::Tile)) {
                    Ok(stats) => Ok((stats, None)),
                    Err(Attempt::Tile(e)) => Err(e),
                    Err(Attempt::Gpu(GpuError::Precision(e))) => {
                        let notice = format!("{e}; rendering with the f64 CPU reference instead");
                        Ok((cpu_tiles(scene, options, on_tile)?, Some(notice)))
                    }
                    Err(Attempt::Gpu(e)) => Err(e.into()),
                }
            }
        }
    }
}

/// A GPU render's failure, told apart from the caller's own.
enum Attempt<E> {
    Gpu(GpuError),
    Tile(E),
}

impl<E> From<GpuError> for Attempt<E> {
    fn from(e: GpuError) -> Self {
        Attempt::Gpu(e)
    }
}

fn cpu_tiles<E>(
    scene: &Scene,
    options: &RenderOptions,
    mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
) -> Result<RenderStats, E> {
    let reference = Reference::new(scene, options);
    let mut stats = RenderStats::default();
    for (first_row, rows) in row_tiles(options.height, CPU_TILE_PIXELS / options.width) {
        on_tile(first_row, reference.rows(first_row, rows))?;
        stats.tiles += 1;
    }
    Ok(stats)
}
