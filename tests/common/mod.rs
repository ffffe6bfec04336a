//! Shared test support: where the course corpus lives, the GPU (opened once per test binary,
//! failing loudly when absent), and pixel comparisons.
#![allow(dead_code)]

pub mod hard;

use raycaster::gpu::GpuRenderer;
use std::path::PathBuf;
use std::sync::OnceLock;

/// `../shared/mit6837` beside the project.
pub fn corpus() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/mit6837")
}

/// The project's own scenes.
pub fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// The GPU renderer, or `None` when `RAYCASTER_SKIP_GPU=1` is set on purpose and no adapter
/// exists. Without that variable a missing adapter fails the test: a skipped GPU test must
/// never pass for a run one.
pub fn gpu() -> Option<&'static GpuRenderer> {
    static GPU: OnceLock<Result<GpuRenderer, String>> = OnceLock::new();
    match GPU.get_or_init(|| GpuRenderer::new().map_err(|e| e.to_string())) {
        Ok(gpu) => Some(gpu),
        Err(e) if std::env::var("RAYCASTER_SKIP_GPU").as_deref() == Ok("1") => {
            eprintln!("SKIPPED (RAYCASTER_SKIP_GPU=1): {e}");
            None
        }
        Err(e) => panic!("GPU test without a GPU adapter: {e}\nInstall lavapipe (apt-get install mesa-vulkan-drivers), or set RAYCASTER_SKIP_GPU=1 to skip on purpose."),
    }
}
