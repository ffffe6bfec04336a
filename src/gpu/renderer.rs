//! The renderer: a wgpu device opened as the kernel needs it, what the adapter allows, and
//! the kernels compiled on it (cached by their configuration and bindings).

use super::bindings::{self, Binding, BindingSet};
use super::error::GpuError;
use super::first_dispatch::{self, FirstDispatches};
use super::kernel::{KernelConfig, KernelKey, Stage};
use super::options::GpuOptions;
use super::pipeline_cache::PipelineCache;
use super::unsupported::UnsupportedError;
use super::{binning, flatten, fuse, specialise};
use crate::render::RenderOptions;
use crate::sampling::Sampling;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// Kernels a renderer keeps compiled (see [`GpuRenderer::pipeline`]).
const MAX_CACHED_PIPELINES: usize = 32;

/// A wgpu device with the ray-casting kernel, ready to render scenes.
pub struct GpuRenderer {
    pub(super) device: wgpu::Device,
    pub(super) queue: wgpu::Queue,
    pub(super) adapter_info: wgpu::AdapterInfo,
    pub(super) limits: wgpu::Limits,
    /// Every binding: the layout of every kernel on an adapter that offers them all. `None`
    /// on one that offers fewer storage buffers per shader stage than the kernel declares,
    /// which would refuse it: there each scene binds only those its kernels use
    /// ([`bindings`]).
    all_bindings: Option<BindingSet>,
    /// Each kernel compiled or being compiled, by its configuration and bindings: a thread
    /// that asks for one another thread is compiling waits for it rather than compile it too
    /// (a batch compiles the next line's kernel while it renders this one).
    pipelines: Mutex<HashMap<KernelKey, Arc<OnceLock<wgpu::ComputePipeline>>>>,
    /// Kernels this renderer compiled ([`GpuRenderer::kernels_compiled`]).
    compiled: std::sync::atomic::AtomicUsize,
    /// The kernels compiled by earlier processes, where the adapter keeps them
    /// ([`super::pipeline_cache`]); shared by the renderers on one device.
    pipeline_cache: Option<Arc<PipelineCache>>,
    pub(super) options: GpuOptions,
    pub(super) timestamps: bool,
    /// The adapter the device was opened on, where this renderer opened it: a twin device
    /// (`gpu::ahead`) opens on it too.
    pub(super) adapter: Option<wgpu::Adapter>,
    /// Where the driver compiles a kernel at its first dispatch: the kernels dispatched
    /// once, here or on a twin device (`gpu::ahead`); shared with the renderers on this
    /// device. `None` elsewhere, and on a twin itself.
    pub(super) first_dispatches: Option<Arc<FirstDispatches>>,
}

impl GpuRenderer {
    /// Opens the first adapter wgpu offers (real GPUs come before CPU ones such as lavapipe;
    /// `WGPU_BACKEND` and the other wgpu environment variables are honoured), rendering as
    /// [`GpuOptions::from_env`] says.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new() -> Result<GpuRenderer, GpuError> {
        Self::with_options(GpuOptions::from_env().map_err(GpuError::Setting)?)
    }

    /// As [`GpuRenderer::new`], rendering as `options` say.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn with_options(options: GpuOptions) -> Result<GpuRenderer, GpuError> {
        // The kernel's WGSL is parsed (once a process) while the driver opens the device,
        // instead of on the way to the first render; a render that needs it first waits.
        let _ = std::thread::Builder::new().name("parse-kernel".into()).spawn(|| match fuse::requested() {
            true => drop(super::shader::fused_module()),
            false => drop(super::shader::module()),
        });
        pollster::block_on(Self::open(options))
    }

    /// As [`GpuRenderer::with_options`], awaiting the adapter and the device rather than
    /// blocking on them: the way to open one in a browser, which cannot block.
    pub async fn open(options: GpuOptions) -> Result<GpuRenderer, GpuError> {
        let adapter = Self::instance()
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        Self::on_adapter(&adapter, options).await
    }

    /// The wgpu instance renderers find their adapters in: the primary backends (Vulkan,
    /// Metal, DX12), or those `WGPU_BACKEND` names.
    pub fn instance() -> wgpu::Instance {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        wgpu::Instance::new(descriptor)
    }

    /// Opens `adapter`'s device as the kernel needs it, and a renderer on it (for a caller
    /// that chose the adapter, such as one that presents to a window).
    pub async fn on_adapter(adapter: &wgpu::Adapter, options: GpuOptions) -> Result<GpuRenderer, GpuError> {
        let mut gpu = Self::open_device(adapter, options).await?;
        // lavapipe compiles a kernel at its first dispatch, into Mesa's cache, which the
        // process's devices share where it is on (gpu::ahead's twin devices).
        if is_lavapipe(&gpu.adapter_info) && first_dispatch::mesa_disk_cache_on() {
            gpu.first_dispatches = Some(Arc::new(FirstDispatches::open(&gpu.adapter_info)));
        }
        Ok(gpu)
    }

    /// [`GpuRenderer::on_adapter`], without first dispatches.
    async fn open_device(adapter: &wgpu::Adapter, options: GpuOptions) -> Result<GpuRenderer, GpuError> {
        // The defaults are below what lavapipe and real GPUs offer (docs/lavapipe.md); ask for all.
        let limits = adapter.limits();
        // Kernel time from the GPU's own clock where the adapter offers it (lavapipe does).
        // Subgroups where offered: on lavapipe a bin's lanes share their loads with them
        // (GpuRenderer::shares_bin_loads). Buffers the kernel binds that the host also maps,
        // where the device's memory is the host's (a CPU adapter): no staging copies
        // (GpuRenderer::maps_kernel_buffers).
        // Compiled kernels kept between processes where the adapter offers it (Vulkan).
        let mut wanted = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SUBGROUP | wgpu::Features::PIPELINE_CACHE;
        if adapter.get_info().device_type == wgpu::DeviceType::Cpu {
            wanted |= wgpu::Features::MAPPABLE_PRIMARY_BUFFERS;
        }
        if fuse::requested() {
            // The fused mode computes each fused operation in f64 (gpu::fuse).
            if !adapter.features().contains(wgpu::Features::SHADER_F64) {
                return Err(GpuError::Device(format!(
                    "{}=1 needs f64 in shaders, which this adapter does not offer",
                    fuse::VARIABLE
                )));
            }
            wanted |= wgpu::Features::SHADER_F64;
        }
        let features = adapter.features() & wanted;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("raycaster"),
                required_features: features,
                required_limits: limits,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let gpu = Self::with_device(adapter.get_info(), device, queue, options);
        Ok(GpuRenderer { adapter: Some(adapter.clone()), ..gpu })
    }

    /// A second device on this renderer's adapter, opened as this one was, for compiling
    /// kernels ahead (`gpu::ahead`): it keeps no pipeline cache file of its own and
    /// shares no first dispatches. `None` where this renderer did not open its device.
    #[cfg(not(target_arch = "wasm32"))]
    pub(super) fn twin(&self) -> Option<Result<GpuRenderer, GpuError>> {
        let adapter = self.adapter.as_ref()?;
        Some(pollster::block_on(Self::open_device(adapter, self.options)).map(|twin| {
            // Its compiles are kept in the driver's cache; the renderer's file is its own.
            GpuRenderer { pipeline_cache: None, ..twin }
        }))
    }

    /// Renders on a device the caller opened (as wgpu's examples hand theirs to `init`).
    /// The renderer uses the device's limits and, where the device was opened with
    /// `TIMESTAMP_QUERY`, times the kernel.
    pub fn with_device(
        adapter_info: wgpu::AdapterInfo,
        device: wgpu::Device,
        queue: wgpu::Queue,
        options: GpuOptions,
    ) -> GpuRenderer {
        let cache = PipelineCache::open(&device, &adapter_info).map(Arc::new);
        Self::sharing_cache(adapter_info, device, queue, options, cache)
    }

    fn sharing_cache(
        adapter_info: wgpu::AdapterInfo,
        device: wgpu::Device,
        queue: wgpu::Queue,
        options: GpuOptions,
        pipeline_cache: Option<Arc<PipelineCache>>,
    ) -> GpuRenderer {
        let all = device.limits().max_storage_buffers_per_shader_stage >= Binding::ALL.len() as u32;
        let all_bindings = all.then(|| BindingSet::new(&device, BindingSet::ALL));
        GpuRenderer {
            limits: device.limits(),
            timestamps: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
            device,
            queue,
            adapter_info,
            all_bindings,
            pipelines: Mutex::new(HashMap::new()),
            compiled: Default::default(),
            pipeline_cache,
            options,
            adapter: None,
            first_dispatches: None,
        }
    }

    /// Another renderer on this one's device and queue, rendering as `options` say (opens
    /// no second device).
    pub fn on_same_device(&self, options: GpuOptions) -> GpuRenderer {
        let (info, device, queue) = (self.adapter_info.clone(), self.device.clone(), self.queue.clone());
        GpuRenderer {
            adapter: self.adapter.clone(),
            first_dispatches: self.first_dispatches.clone(),
            ..Self::sharing_cache(info, device, queue, options, self.pipeline_cache.clone())
        }
    }

    /// How many kernels this renderer has compiled (found in none of its own caches; the
    /// driver's and [`GpuRenderer::pipeline_cache`] may still have spared the work).
    pub fn kernels_compiled(&self) -> usize {
        self.compiled.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The pipeline cache kept between processes, where the adapter offers one.
    pub fn pipeline_cache(&self) -> Option<&PipelineCache> {
        self.pipeline_cache.as_deref()
    }

    /// The device and queue, for a caller that shows what it renders (the live view of
    /// `-gui`, which presents on the same device) or catches its errors in error scopes (a
    /// browser, where they are not raised where they happen).
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Which adapter this renderer runs on (name, backend, device type).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.adapter_info
    }

    /// How this renderer renders.
    pub fn options(&self) -> &GpuOptions {
        &self.options
    }

    /// How many loop iterations this adapter's driver lets one invocation run in all:
    /// lavapipe's compiler ends loops after [`flatten::LOOP_LIMIT`] (docs/lavapipe.md);
    /// other drivers have no such limit.
    pub fn loop_limit(&self) -> Option<u32> {
        is_lavapipe(&self.adapter_info).then_some(flatten::LOOP_LIMIT)
    }

    /// Whether the host maps the buffers the kernel binds (its tiles' pixels, the bins'
    /// lists, the scene) instead of copying through staging buffers: where the device was
    /// opened with `MAPPABLE_PRIMARY_BUFFERS`, which [`GpuRenderer::on_adapter`] asks of CPU
    /// adapters only, and the options allow it. A CPU adapter's memory is the host's, so
    /// the copies were pure cost (lavapipe: docs/lavapipe.md, "Buffers the host maps"); a
    /// discrete GPU would read such a buffer across its bus.
    pub fn maps_kernel_buffers(&self) -> bool {
        self.options.mapped_buffers && self.device.features().contains(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS)
    }

    /// Whether the lanes of a bin's row can share their loads (`main_bins_shared`): the
    /// device was opened with subgroups, every subgroup has exactly
    /// [`binning::BIN_COLUMNS`] lanes (lavapipe's 8, one row of a bin's packets), and the
    /// options allow it. Where a GPU loads one address for a whole subgroup at once, as real
    /// GPUs do, the subgroups are wider and `main_bins` runs.
    pub fn shares_bin_loads(&self) -> bool {
        let info = &self.adapter_info;
        self.options.shared_bin_loads
            && self.device.features().contains(wgpu::Features::SUBGROUP)
            && info.subgroup_min_size == binning::BIN_COLUMNS
            && info.subgroup_max_size == binning::BIN_COLUMNS
    }

    /// Whether every kernel binds all its buffers here: the adapter's limit takes every
    /// [`Binding`], as lavapipe's and desktop GPUs' do (SwiftShader's 10 and WebGPU's default
    /// 8 do not).
    pub(super) fn binds_every_buffer(&self) -> bool {
        self.all_bindings.is_some()
    }

    /// The bindings the kernels `stages` of a scene in `file` use: all of them, or where
    /// the adapter offers fewer ([`bindings`]) those the kernels reference, refused when
    /// they are still too many.
    pub(super) fn bindings_for(&self, stages: &[KernelConfig], file: &std::path::Path) -> Result<BindingSet, GpuError> {
        if let Some(all) = &self.all_bindings {
            return Ok(all.clone());
        }
        let mask = stages.iter().fold(0, |mask, &config| mask | bindings::referenced(&config.module()));
        let (count, limit) = (mask.count_ones(), self.limits.max_storage_buffers_per_shader_stage);
        if count > limit {
            return Err(GpuError::Unsupported(UnsupportedError {
                file: file.to_path_buf(),
                location: None,
                what: format!("its kernel binds {count} storage buffers, more than the {limit} per shader stage this adapter offers"),
            }));
        }
        Ok(BindingSet::new(&self.device, mask))
    }

    /// The pipeline of `config`, compiled where no thread has yet; the time this call spent
    /// specialising the kernel's module is added to `specialising`.
    pub(super) fn pipeline(
        &self,
        config: KernelConfig,
        bindings: &BindingSet,
        specialising: &mut std::time::Duration,
    ) -> wgpu::ComputePipeline {
        let key = (config, bindings.mask);
        let slot = {
            let mut cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
            // A compiled kernel holds megabytes on lavapipe; a process that renders many
            // kinds of scene (the random-scene test: hundreds) starts over rather than keep
            // them all.
            if cache.len() >= MAX_CACHED_PIPELINES && !cache.contains_key(&key) {
                cache.clear();
            }
            cache.entry(key).or_default().clone()
        };
        // Compiled without the map's lock, so that two threads compile two kernels at once
        // (PreparedScene::new: a planned kernel and the one needed instead).
        slot.get_or_init(|| self.compile(config, bindings, specialising)).clone()
    }

    fn compile(
        &self,
        config: KernelConfig,
        bindings: &BindingSet,
        specialising: &mut std::time::Duration,
    ) -> wgpu::ComputePipeline {
        self.compiled.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let start = crate::clock::Instant::now();
        let source = specialise::shader_source(config.module());
        *specialising += start.elapsed();
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("raycast"), source });
        let pipeline = self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("raycast"),
            layout: Some(&bindings.pipeline),
            module: &module,
            entry_point: Some(config.entry_point()),
            compilation_options: wgpu::PipelineCompilationOptions {
                // Fixed already, by specialise.
                constants: &[],
                zero_initialize_workgroup_memory: false,
            },
            cache: self.pipeline_cache.as_ref().map(|c| &c.cache),
        });
        if let Some(kept) = &self.pipeline_cache {
            kept.save();
        }
        pipeline
    }
}

/// Whether `info` is lavapipe's (Mesa's llvmpipe under Vulkan).
pub(super) fn is_lavapipe(info: &wgpu::AdapterInfo) -> bool {
    info.driver.contains("llvmpipe") || info.name.contains("llvmpipe")
}

/// The two passes of a render with several samples per pixel (docs/SPEC.md §8).
pub(super) struct Sampled {
    pub sampling: Sampling,
    pub samples: wgpu::ComputePipeline,
    pub filter: wgpu::ComputePipeline,
}

/// A kernel's bindings and pipelines: the pixels kernel of a render without sampling, the
/// samples and filter kernels of one with it.
pub(super) struct Compiled {
    /// The kernel a render dispatches first (its pixels kernel, or its samples kernel) and
    /// its bindings: what `gpu::ahead` compiles by dispatching it.
    pub first: KernelKey,
    pub bindings: BindingSet,
    pub pipeline: Option<wgpu::ComputePipeline>,
    pub sampled: Option<Sampled>,
    /// Of the time these kernels took to compile, milliseconds spent specialising their
    /// modules (`specialise`), not in wgpu and the driver; 0 where all were compiled before.
    pub specialise_ms: f64,
}

impl Compiled {
    /// Compiles (or finds in the cache) the kernels of `config` for a render as `options`
    /// say, of a scene in `file`.
    pub fn new(
        gpu: &GpuRenderer,
        config: KernelConfig,
        options: &RenderOptions,
        file: &std::path::Path,
    ) -> Result<Compiled, GpuError> {
        let stages = Self::stages(config, options);
        let bindings = gpu.bindings_for(&stages, file)?;
        let first = Self::first(config, options, &bindings);
        // A sampled render dispatches its samples and filter kernels only.
        let mut specialising = std::time::Duration::ZERO;
        let (pipeline, sampled) = match options.sampling {
            None => (Some(gpu.pipeline(config, &bindings, &mut specialising)), None),
            Some(sampling) => {
                let mut stage = |stage| gpu.pipeline(KernelConfig { stage, ..config }, &bindings, &mut specialising);
                let samples = stage(Stage::Samples);
                (None, Some(Sampled { sampling, samples, filter: stage(Stage::Filter) }))
            }
        };
        let specialise_ms = specialising.as_secs_f64() * 1e3;
        Ok(Compiled { first, bindings, pipeline, sampled, specialise_ms })
    }

    /// The kernels of `config` a render as `options` say binds.
    fn stages(config: KernelConfig, options: &RenderOptions) -> Vec<KernelConfig> {
        match options.sampling {
            None => vec![config],
            Some(_) => {
                [Stage::Pixels, Stage::Samples, Stage::Filter].map(|stage| KernelConfig { stage, ..config }).to_vec()
            }
        }
    }

    /// The kernel of `config` a render as `options` say dispatches first, and its bindings.
    fn first(config: KernelConfig, options: &RenderOptions, bindings: &BindingSet) -> KernelKey {
        let stage = if options.sampling.is_some() { Stage::Samples } else { config.stage };
        (KernelConfig { stage, ..config }, bindings.mask)
    }
}
