//! The kernels a renderer and its twin devices have dispatched once, where the driver
//! compiles a kernel's machine code at its first dispatch into a cache the process's devices
//! share (lavapipe, with Mesa's disk cache on): the bookkeeping of `gpu::ahead`, which
//! compiles a batch's next kernels on twin devices, and of the renderer, which waits for a
//! kernel a twin is compiling. Those dispatched are kept in the cache folder for later
//! processes ([`Kept`]).

use super::kernel::KernelKey;
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

    pub(super) fn with_file(file: Option<PathBuf>, driver: u64) -> FirstDispatches {
        FirstDispatches { slots: Default::default(), kept: Kept::read(file, driver) }
    }

    /// Runs `dispatch` unless `key`'s kernel was dispatched already; waits while another
    /// thread is running its own. Kept for later processes where `dispatch` says the
    /// driver's cache has the kernel now.
    pub(super) fn first(&self, key: KernelKey, dispatch: impl FnOnce() -> bool) {
        let slot = self.slots.lock().unwrap_or_else(PoisonError::into_inner).entry(key).or_default().clone();
        let mut cached = false;
        slot.get_or_init(|| cached = dispatch());
        if cached {
            self.kept.add(&key);
        }
    }

    /// Whether `key`'s kernel was dispatched by this process or an earlier one, is being so,
    /// or was taken on by the renderer. (A browser compiles nothing ahead and never asks.)
    #[cfg_attr(target_arch = "wasm32", allow(dead_code))]
    pub(super) fn known(&self, key: &KernelKey) -> bool {
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

    #[cfg_attr(target_arch = "wasm32", allow(dead_code))]
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

/// Whether Mesa's disk cache is on, which lets the devices of a process share compiled
/// kernels: it is unless `MESA_SHADER_CACHE_DISABLE`, or where that is unset the older
/// `MESA_GLSL_CACHE_DISABLE`, says otherwise, as Mesa reads them.
pub(super) fn mesa_disk_cache_on() -> bool {
    let var = |name| std::env::var(name).ok();
    let switch = var("MESA_SHADER_CACHE_DISABLE").or_else(|| var("MESA_GLSL_CACHE_DISABLE"));
    !mesa_cache_disabled(switch.as_deref())
}

/// Whether `MESA_SHADER_CACHE_DISABLE`'s value turns Mesa's disk cache off, as Mesa's
/// `env_var_as_boolean` reads it.
fn mesa_cache_disabled(value: Option<&str>) -> bool {
    value.is_some_and(|v| matches!(v.to_ascii_lowercase().as_str(), "1" | "true" | "y" | "yes"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::flatten::SceneBuffers;
    use crate::gpu::kernel::KernelConfig;
    use crate::gpu::layout::PixelLayout;
    use crate::gpu::options::Acceleration;
    use crate::render::RenderOptions;
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
