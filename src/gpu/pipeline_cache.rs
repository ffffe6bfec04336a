//! The compiled kernels kept between processes: wgpu's pipeline cache (a Vulkan
//! `VkPipelineCache`), read when the device opens and written to the user's cache folder
//! each time a kernel variant is compiled, so that a second process (the next line of a
//! batch, the next command line of an assignment) does not compile it again. Where the
//! adapter offers no pipeline cache (Metal, Direct3D 12, WebGPU) the drivers keep their own.
//!
//! The file is named by wgpu's key for the adapter (vendor and device), and wgpu checks its
//! header against the driver before handing it over: data of another driver or version is
//! ignored, and the kernels are compiled as without it. It is written to a temporary file
//! and renamed, so a reader never sees half of one.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The variable that names the cache folder; set to an empty string, no cache is kept.
pub const VARIABLE: &str = "RAYCASTER_CACHE_DIR";

/// A pipeline cache and the file that keeps it.
pub struct PipelineCache {
    pub(super) cache: wgpu::PipelineCache,
    file: PathBuf,
    /// Bytes read from the file when the device opened (0: none yet).
    read: u64,
    /// Bytes last written.
    written: AtomicU64,
}

impl PipelineCache {
    /// The cache of `device`'s adapter, with what earlier processes compiled; `None` where
    /// the device was opened without `PIPELINE_CACHE`, wgpu has no key for its backend, or
    /// there is no cache folder.
    pub fn open(device: &wgpu::Device, adapter: &wgpu::AdapterInfo) -> Option<PipelineCache> {
        if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
            return None;
        }
        let file = folder()?.join(wgpu::util::pipeline_cache_key(adapter)?);
        let data = std::fs::read(&file).ok();
        // SAFETY: the data is what `get_data` returned on an adapter of the same key (the
        // file is named by it and only ever written whole, by `save`); wgpu validates its
        // header against this driver and, with `fallback`, starts empty where it does not
        // match.
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                label: Some("raycaster"),
                data: data.as_deref(),
                fallback: true,
            })
        };
        let read = data.map_or(0, |d| d.len() as u64);
        Some(PipelineCache { cache, file, read, written: AtomicU64::new(0) })
    }

    /// Writes what the cache holds now (after a kernel was compiled). A cache that cannot
    /// be written costs only the next process's compile: the failure is not an error.
    pub fn save(&self) {
        let Some(data) = self.cache.get_data() else { return };
        if let Some(folder) = self.file.parent() {
            let _ = std::fs::create_dir_all(folder);
        }
        // Named by process and write: two threads may compile, and save, at once.
        static WRITES: AtomicU64 = AtomicU64::new(0);
        let write = WRITES.fetch_add(1, Ordering::Relaxed);
        let temp = self.file.with_extension(format!("{}-{write}.tmp", std::process::id()));
        if std::fs::write(&temp, &data).and_then(|()| std::fs::rename(&temp, &self.file)).is_ok() {
            self.written.store(data.len() as u64, Ordering::Relaxed);
        } else {
            let _ = std::fs::remove_file(&temp);
        }
    }

    /// The file, the bytes read from it when the device opened and the bytes last written
    /// (for `--verbose`).
    pub fn describe(&self) -> (&Path, u64, u64) {
        (&self.file, self.read, self.written.load(Ordering::Relaxed))
    }
}

/// The cache folder: `$RAYCASTER_CACHE_DIR`, else `raycaster` in the platform's
/// (`$XDG_CACHE_HOME` or `~/.cache` on Linux, `~/Library/Caches` on macOS, `%LOCALAPPDATA%`
/// on Windows); `None` when the variable is set empty or no folder is known.
pub fn folder() -> Option<PathBuf> {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(chosen) = std::env::var_os(VARIABLE) {
        return (!chosen.is_empty()).then(|| PathBuf::from(chosen));
    }
    let base = if cfg!(target_os = "windows") {
        var("LOCALAPPDATA")
    } else if cfg!(target_os = "macos") {
        var("HOME").map(|home| home.join("Library/Caches"))
    } else {
        var("XDG_CACHE_HOME").or_else(|| var("HOME").map(|home| home.join(".cache")))
    };
    base.map(|base| base.join("raycaster"))
}
