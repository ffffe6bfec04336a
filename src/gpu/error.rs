//! Why the GPU did not render a scene.

use super::precision::PrecisionError;
use super::unsupported::UnsupportedError;

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found ({0}); on a machine without a GPU install Mesa's lavapipe (apt-get install mesa-vulkan-drivers) or use --backend cpu")]
    NoAdapter(String),
    #[error("could not open the GPU device: {0}")]
    Device(String),
    /// A setting of ours the renderer refuses (an environment variable's value), which
    /// `auto` does not hide by falling back to the reference.
    #[error("{0}")]
    Setting(String),
    #[error("the scene is too large for this GPU: {0}")]
    TooLarge(String),
    #[error("writing to the GPU's memory failed: {0}")]
    Upload(String),
    #[error("reading the image back from the GPU failed: {0}")]
    Readback(String),
    #[error("{0}; render it with --backend cpu")]
    Precision(PrecisionError),
    #[error("{0}; render it with --backend cpu")]
    Unsupported(UnsupportedError),
    /// A NaN or an infinity in what the host would upload (gpu::finite).
    #[error("{0}; render it with --backend cpu")]
    NonFinite(String),
}

impl GpuError {
    /// Whether the GPU refused the scene itself (out of its f32 range, or shading it does
    /// not implement), which the f64 reference renders: `auto` falls back on these.
    pub fn reference_renders_it(&self) -> bool {
        matches!(self, GpuError::Precision(_) | GpuError::Unsupported(_) | GpuError::NonFinite(_))
    }
}
