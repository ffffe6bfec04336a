//! Kernels compiled ahead of the render that needs them: a batch compiles its next lines'
//! kernels while it renders this one (docs/SPEC.md §6).
//!
//! Most drivers (NVIDIA's, AMD's, Intel's, SwiftShader) compile a kernel's machine code when
//! its pipeline is created, and creating it on the renderer's own device is enough: the
//! render finds it in [`GpuRenderer::pipeline`]'s cache, or waits for it there. lavapipe
//! compiles it at the kernel's first dispatch instead, on the device's one queue thread, so
//! pipelines created ahead still leave every compile to that thread, one after another
//! (docs/performance.md, "Compiles"). There each compiling thread also opens a twin device on
//! the same adapter, whose queue thread is its own, and dispatches the kernel once on it
//! (one row of the image). Mesa keeps the machine code in its shader cache on disk, where
//! the renderer's own first dispatch finds it. A kernel a twin is compiling is waited for
//! rather than compiled twice (`first_dispatch::FirstDispatches`); one the renderer reached
//! first is left to it. The kernels dispatched are listed in the cache folder, so that a
//! later batch opens no twin device for them.
//!
//! A browser's page renders one scene at a time and compiles nothing ahead.
#![cfg_attr(target_arch = "wasm32", allow(dead_code, unused_imports))]
use super::error::GpuError;
use super::first_dispatch::FirstDispatches;
use super::renderer::GpuRenderer;
use crate::render::RenderOptions;
use crate::scene::Scene;
use std::sync::{Arc, OnceLock};

/// What one thread compiles ahead with ([`GpuRenderer::ahead`]).
pub struct Ahead<'a> {
    gpu: &'a GpuRenderer,
    /// Where the driver compiles at the first dispatch: the kernels dispatched once, and
    /// the thread's twin device, opened when a kernel first needs it (`None` inside: it
    /// did not open, and the renderer's own device compiles).
    twin: Option<(Arc<FirstDispatches>, OnceLock<Option<GpuRenderer>>)>,
}

impl GpuRenderer {
    /// How a thread of a batch compiles kernels ahead for this renderer ([`super::ahead`]).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn ahead(&self) -> Ahead<'_> {
        let twin = self.first_dispatches.clone().map(|first| (first, OnceLock::new()));
        Ahead { gpu: self, twin }
    }
}

impl Ahead<'_> {
    /// Compiles the kernel `gpu.prepare(scene, options, packed)` would render with, where
    /// the render will find it compiled. Refuses what `prepare` refuses.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn precompile(&self, scene: &Scene, options: &RenderOptions, packed: bool) -> Result<(), GpuError> {
        // The pipeline on the renderer's own device, as on every driver: on lavapipe too its
        // creation (SPIR-V to Mesa's own form) would take a render tens of milliseconds.
        let first = self.gpu.precompile_first(scene, options, packed)?;
        let Some((first_dispatches, twin)) = &self.twin else { return Ok(()) };
        // A kernel dispatched, being so or taken on: the thread goes on to the next line.
        if first_dispatches.known(&first) {
            return Ok(());
        }
        let Some(twin) = twin.get_or_init(|| self.gpu.twin().and_then(Result::ok)) else { return Ok(()) };
        let prepared = twin.prepare(scene, options, packed)?;
        let mut dispatched = Ok(());
        first_dispatches.first(prepared.first_kernel, || {
            dispatched = prepared.dispatch.run_tile(0, 0, 1).map(drop);
            dispatched.is_ok()
        });
        dispatched
    }

    /// Whether this thread compiles new kernels by dispatching them on a twin device
    /// ([`super::ahead`]), the renderer's own device creating their pipelines.
    pub fn on_twin(&self) -> bool {
        self.twin.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A renderer on the first adapter, or `None` where `RAYCASTER_SKIP_GPU=1` says to skip
    /// without one (as the integration tests' `common::gpu`).
    fn gpu() -> Option<GpuRenderer> {
        match GpuRenderer::new() {
            Ok(gpu) => Some(gpu),
            Err(e) if std::env::var("RAYCASTER_SKIP_GPU").as_deref() == Ok("1") => {
                eprintln!("SKIPPED (RAYCASTER_SKIP_GPU=1): {e}");
                None
            }
            Err(e) => panic!("GPU test without a GPU adapter: {e}"),
        }
    }

    /// On any adapter, with first dispatches of its own (no file): a kernel compiled ahead
    /// is dispatched on a twin device once, known after, and the renderer then renders the
    /// image a renderer without twins renders.
    #[test]
    fn a_twin_dispatches_a_kernel_once_and_the_render_is_the_same() {
        let Some(plain) = gpu() else { return };
        let first = Arc::new(FirstDispatches::with_file(None, 0));
        let mut gpu = plain.on_same_device(plain.options);
        gpu.first_dispatches = Some(first.clone());
        let ahead = gpu.ahead();
        assert!(ahead.on_twin());
        let text = "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }
            Lights { numLights 1 PointLight { position 2 3 4 color 1 1 1 } }
            Background { color 0.2 0.2 0.2 ambientLight 0.1 0.1 0.1 }
            Materials { numMaterials 1 PhongMaterial { diffuseColor 0.8 0.3 0.3 } }
            Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }";
        let scene = crate::scene::parse_scene(text, std::path::Path::new("twin.txt")).unwrap();
        let options = RenderOptions::all(23, 17);
        ahead.precompile(&scene, &options, false).unwrap();
        let twin = ahead.twin.as_ref().and_then(|(_, twin)| twin.get());
        assert!(matches!(twin, Some(Some(_))), "the twin device opened");
        let key = gpu.precompile_first(&scene, &options, false).unwrap();
        assert!(first.known(&key));
        first.first(key, || panic!("a kernel dispatched on a twin was dispatched again"));
        assert_eq!(gpu.render(&scene, &options).unwrap(), plain.render(&scene, &options).unwrap());
    }
}
