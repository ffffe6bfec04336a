//! Choosing and calling a renderer: the GPU kernel or the f64 CPU reference.

use crate::cli::BackendChoice;
use crate::gpu::{GpuError, GpuRenderer};
use crate::render::{Frame, RenderOptions};
use crate::scene::Scene;

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

    /// A short name for messages: the adapter's name, or "cpu reference".
    pub fn name(&self) -> String {
        match self {
            Backend::Gpu(gpu) => format!("gpu ({})", gpu.adapter_info().name),
            Backend::Cpu => "cpu reference".to_string(),
        }
    }
}
