//! Choosing and calling a renderer: the GPU kernel or the f64 CPU reference.

use crate::cli::BackendChoice;
use crate::gpu::{GpuError, GpuRenderer, RenderStats};
use crate::render::{Frame, RenderOptions};
use crate::scene::Scene;

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

    pub fn render(&self, scene: &Scene, options: &RenderOptions) -> Result<Frame, GpuError> {
        match self {
            Backend::Gpu(gpu) => gpu.render(scene, options),
            Backend::Cpu => Ok(crate::cpu::render(scene, options)),
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
                let rows_per_tile = (CPU_TILE_PIXELS / options.width).max(1);
                let mut stats = RenderStats::default();
                let mut first_row = 0;
                while first_row < options.height {
                    let rows = rows_per_tile.min(options.height - first_row);
                    on_tile(first_row, crate::cpu::render_rows(scene, options, first_row, rows))?;
                    first_row += rows;
                    stats.tiles += 1;
                }
                Ok(stats)
            }
        }
    }

    /// A short name for messages: the adapter's name, or "cpu reference".
    pub fn name(&self) -> String {
        match self {
            Backend::Gpu(gpu) => format!("gpu ({})", gpu.adapter_info().name),
            Backend::Cpu => "cpu reference".to_string(),
        }
    }
}
