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
//! rather than compiled twice ([`FirstDispatches`]); one the renderer reached first is left
//! to it. The kernels dispatched are listed in the cache folder ([`Kept`]), so that a later
//! batch opens no twin device for them.
//!
//! A browser's page renders one scene at a time and compiles nothing ahead.
#![cfg_attr(target_arch = "wasm32", allow(dead_code, unused_imports))]

use super::error::GpuError;
use super::renderer::{GpuRenderer, KernelKey};
use crate::render::RenderOptions;
use crate::scene::Scene;
use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::io::Write;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

/// The kernels dispatched once (or being so) by a renderer or one of its twins, on a driver
/// that compiles at the first dispatch: the first to reach a kernel dispatches it, and a
/// renderer that reaches it while a twin is dispatching it waits. Those that earlier
/// processes dispatched are [`Kept`]: no twin compiles them again.
pub(super) struct FirstDispatches {
    slots: Mutex<HashMap<KernelKey, Arc<OnceLock<()>>>>,
    kept: Kept,
}

impl FirstDispatches {
    /// For a renderer on `info`'s adapter, with the kernels kept in the cache folder.
    pub(super) fn open(info: &wgpu::AdapterInfo) -> FirstDispatches {
        let file = super::pipeline_cache::folder().map(|folder| folder.join(KEPT_FILE));
        FirstDispatches::with_file(file, driver_identity(info))
    }

    fn with_file(file: Option<PathBuf>, driver: u64) -> FirstDispatches {
        FirstDispatches { slots: Default::default(), kept: Kept::read(file, driver) }
    }

    /// Runs `dispatch` unless `key`'s kernel was dispatched already; waits while another
    /// thread is running its own. Kept for later processes where `dispatch` says the
    /// driver's cache has the kernel now.
    fn first(&self, key: KernelKey, dispatch: impl FnOnce() -> bool) {
        let slot = self.slots.lock().unwrap_or_else(PoisonError::into_inner).entry(key).or_default().clone();
        let mut cached = false;
        slot.get_or_init(|| cached = dispatch());
        if cached {
            self.kept.add(&key);
        }
    }

    /// Whether `key`'s kernel was dispatched by this process or an earlier one, is being so,
    /// or was taken on by the renderer.
    fn known(&self, key: &KernelKey) -> bool {
        self.kept.has(key) || self.slots.lock().unwrap_or_else(PoisonError::into_inner).contains_key(key)
    }

    /// The renderer is about to dispatch `key`'s kernel: waits while a twin compiles it
    /// (then the driver's cache has it), else takes it on (no twin compiles it after, and
    /// its dispatch puts it in the driver's cache).
    pub(super) fn wait_or_claim(&self, key: KernelKey) {
        self.first(key, || true);
    }
}

/// The file in the cache folder ([`super::pipeline_cache::folder`]) that keeps the kernels
/// dispatched by earlier processes.
const KEPT_FILE: &str = "first-dispatches.txt";

/// The kernels earlier processes dispatched, a hash per line: Mesa's disk cache has their
/// machine code, unless it dropped it (then the renderer compiles it at its first dispatch,
/// as with no twin). A kernel's hash covers the driver, its version and Mesa's cache folder
/// (what Mesa's own key covers, as far as the host sees it) and this program's version.
struct Kept {
    file: Option<PathBuf>,
    driver: u64,
    hashes: Mutex<HashSet<u64>>,
}

impl Kept {
    /// What `file` holds; a file that cannot be read holds nothing, a line that does not
    /// parse is skipped.
    fn read(file: Option<PathBuf>, driver: u64) -> Kept {
        let text = file.as_ref().and_then(|f| std::fs::read_to_string(f).ok()).unwrap_or_default();
        let hashes = text.lines().filter_map(|line| u64::from_str_radix(line.trim(), 16).ok()).collect();
        Kept { file, driver, hashes: Mutex::new(hashes) }
    }

    fn hash(&self, key: &KernelKey) -> u64 {
        let mut hasher = std::hash::DefaultHasher::new();
        (self.driver, key).hash(&mut hasher);
        hasher.finish()
    }

    fn has(&self, key: &KernelKey) -> bool {
        self.hashes.lock().unwrap_or_else(PoisonError::into_inner).contains(&self.hash(key))
    }

    /// Adds `key`, appending a line to the file: an append this short is written whole, so
    /// two processes adding at once each add their line. A file that cannot be written costs
    /// only a later process's parallel compile: the failure is not an error.
    fn add(&self, key: &KernelKey) {
        let hash = self.hash(key);
        if !self.hashes.lock().unwrap_or_else(PoisonError::into_inner).insert(hash) {
            return;
        }
        let Some(file) = &self.file else { return };
        if let Some(folder) = file.parent() {
            let _ = std::fs::create_dir_all(folder);
        }
        let appended = std::fs::OpenOptions::new().create(true).append(true).open(file);
        let _ = appended.and_then(|mut f| f.write_all(format!("{hash:016x}\n").as_bytes()));
    }
}

/// What a kept kernel's hash covers besides the kernel ([`Kept`]).
fn driver_identity(info: &wgpu::AdapterInfo) -> u64 {
    let mut hasher = std::hash::DefaultHasher::new();
    let mesa_cache = std::env::var_os("MESA_SHADER_CACHE_DIR");
    (&info.name, &info.driver, &info.driver_info, mesa_cache, env!("CARGO_PKG_VERSION")).hash(&mut hasher);
    hasher.finish()
}

/// Whether a device on this adapter compiles a kernel at its first dispatch, into a cache
/// shared by the devices of the process: lavapipe, with Mesa's disk cache on (it is unless
/// `MESA_SHADER_CACHE_DISABLE`, or where that is unset the older `MESA_GLSL_CACHE_DISABLE`,
/// says otherwise, as Mesa reads them).
pub(super) fn compiles_at_first_dispatch(info: &wgpu::AdapterInfo) -> bool {
    let var = |name| std::env::var(name).ok();
    let switch = var("MESA_SHADER_CACHE_DISABLE").or_else(|| var("MESA_GLSL_CACHE_DISABLE"));
    super::renderer::is_lavapipe(info) && !mesa_cache_disabled(switch.as_deref())
}

/// Whether `MESA_SHADER_CACHE_DISABLE`'s value turns Mesa's disk cache off, as Mesa's
/// `env_var_as_boolean` reads it.
fn mesa_cache_disabled(value: Option<&str>) -> bool {
    value.is_some_and(|v| matches!(v.to_ascii_lowercase().as_str(), "1" | "true" | "y" | "yes"))
}

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
    use crate::gpu::flatten::SceneBuffers;
    use crate::gpu::kernel::KernelConfig;
    use crate::gpu::layout::PixelLayout;
    use crate::gpu::options::Acceleration;
    use std::sync::atomic::{AtomicBool, Ordering};

    /// A kernel of a small scene, from the host's own steps, as a render would have it.
    fn key(mask: u32) -> KernelKey {
        let text = "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 4 }
            Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
            Background { color 0 0 0 ambientLight 0.1 0.1 0.1 }
            Materials { numMaterials 1 PhongMaterial { diffuseColor 0.5 0.5 0.5 } }
            Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }";
        let scene = crate::scene::parse_scene(text, std::path::Path::new("ahead.txt")).unwrap();
        let options = RenderOptions::all(16, 16);
        let rays = crate::camera::PrimaryRays::for_camera(&scene.camera, 16, 16);
        let buffers = SceneBuffers::flattened(&scene, &rays);
        let traced = super::super::unsupported::check(&scene, &options).unwrap();
        let layout = PixelLayout::new(&options, true);
        let config = KernelConfig::new(&buffers, Acceleration::Flat, layout, &options, &traced, true, false);
        (config, mask)
    }

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

    #[test]
    fn the_renderer_waits_for_a_twins_dispatch() {
        let first = FirstDispatches::with_file(None, 0);
        let dispatched = AtomicBool::new(false);
        let (started, has_started) = std::sync::mpsc::channel();
        std::thread::scope(|scope| {
            scope.spawn(|| {
                first.first(key(1), || {
                    started.send(()).unwrap();
                    std::thread::sleep(std::time::Duration::from_millis(50));
                    dispatched.store(true, Ordering::SeqCst);
                    true
                })
            });
            has_started.recv().unwrap();
            first.wait_or_claim(key(1));
            assert!(dispatched.load(Ordering::SeqCst), "the renderer went on while a twin compiled its kernel");
        });
    }

    #[test]
    fn no_twin_dispatches_a_kernel_the_renderer_took_on() {
        let first = FirstDispatches::with_file(None, 0);
        assert!(!first.known(&key(2)));
        first.wait_or_claim(key(2));
        assert!(first.known(&key(2)));
        assert!(!first.known(&key(3)), "another binding mask is another kernel");
        first.first(key(2), || panic!("a twin dispatched a kernel the renderer took on"));
        first.first(key(3), || false);
        assert!(first.known(&key(3)) && !first.kept.has(&key(3)), "a failed dispatch is known here, kept for none");
    }

    #[test]
    fn later_processes_know_the_kernels_kept_for_the_same_driver_only() {
        let folder = std::env::temp_dir().join(format!("raycaster-ahead-{}", std::process::id()));
        let file = folder.join(KEPT_FILE);
        let _ = std::fs::remove_dir_all(&folder);
        FirstDispatches::with_file(Some(file.clone()), 7).first(key(4), || true);
        // Another process's line, half written or not ours, is skipped.
        std::fs::OpenOptions::new().append(true).open(&file).unwrap().write_all(b"not a hash\n").unwrap();
        FirstDispatches::with_file(Some(file.clone()), 7).wait_or_claim(key(5));
        let later = FirstDispatches::with_file(Some(file.clone()), 7);
        assert!(later.known(&key(4)) && later.known(&key(5)));
        assert!(!later.known(&key(6)));
        assert!(!FirstDispatches::with_file(Some(file.clone()), 8).known(&key(4)), "another driver's kernel");
        assert_eq!(std::fs::read_to_string(&file).unwrap().lines().count(), 3);
        let _ = std::fs::remove_dir_all(&folder);
    }

    #[test]
    fn mesas_disk_cache_switch_is_read_as_mesa_reads_it() {
        for (value, disabled) in [(None, false), (Some("1"), true), (Some("TRUE"), true), (Some("yes"), true)] {
            assert_eq!(mesa_cache_disabled(value), disabled, "{value:?}");
        }
        for value in ["0", "false", "no", ""] {
            assert!(!mesa_cache_disabled(Some(value)), "{value}");
        }
    }
}
