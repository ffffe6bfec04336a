//! The GPU backend: a WGSL compute kernel driven through wgpu, headless.
//!
//! A [`GpuRenderer`] owns the device (created once per process, reused for any number of
//! scenes) and a cache of kernels specialised by `override` constants.
//! [`GpuRenderer::prepare`] flattens a scene ([`flatten`], into the structs of [`layout`]),
//! uploads it and binds it once; the [`PreparedScene`] then dispatches the kernel
//! ([`shader`]; an invocation per pixel, or per packet of pixels with bins) in tiles of rows
//! (so memory is bounded by the tile, not the frame), reading tile k back while the device
//! renders tile k + 1.

mod bindings;
pub mod binning;
pub mod finite;
pub mod flatten;
pub mod fuse;
mod handoff;
pub mod layout;
pub mod precision;
mod precision_error;
mod prepared;
pub mod shader;
mod specialise;
pub mod support;
pub mod texture_range;
pub mod tree;
pub mod voxels;

#[cfg(not(target_arch = "wasm32"))]
use crate::render::Frame;
use crate::render::{Output, RenderOptions, SphereTest, TriangleTest};
use crate::scene::Scene;
use flatten::SceneBuffers;
use layout::PixelLayout;
pub use prepared::{PreparedScene, ReadTile};
use std::collections::HashMap;
use std::sync::Mutex;

/// Workgroup edge: the kernel's `@workgroup_size(WORKGROUP, WORKGROUP)`, and a bin's side.
pub const WORKGROUP: u32 = 8;

/// The packet of a kernel walking bins (see [`KernelConfig::packet`]).
pub const BIN_PACKET: u32 = 4;

// A packet never straddles two bins (the kernel's `main_bins` relies on it).
const _: () = assert!(binning::BIN_ROWS.is_multiple_of(BIN_PACKET));

/// The output tile of one dispatch. Small tiles stay in the CPU's caches on lavapipe:
/// bunny_40k at 2048² ran at 7.4 Mrays/s with 64 MiB tiles, 9.3 with 16 MiB, 9.8 with 8 MiB,
/// 10.3 with 2 MiB and 10.2 with 1 MiB (`raycaster bench --only bunny_40k`, kernel time from
/// timestamps, float output of 8 words a pixel); below that the dispatches multiply. It
/// also bounds host memory.
pub const MAX_TILE_BYTES: u64 = 2 << 20;

/// The output tile on a CPU adapter (lavapipe), where a tile's bins and pixels share the
/// CPU's caches with the kernel: bunny_40k at 1024² (8-bit output, one word a pixel) took
/// 98.2 ms of wall time with 1 MiB tiles against 104.8 ms with 2 MiB (kernel 10.5 against
/// 15.4 ms; medians of 15 interleaved runs), and 99.0 and 103.0 ms with 512 and 256 KiB;
/// 2048² and 4096² were as fast or faster, and 512² is one tile either way. Real GPUs,
/// unmeasured, keep [`MAX_TILE_BYTES`].
const CPU_TILE_BYTES: u64 = 1 << 20;

/// How a [`GpuRenderer`] renders; [`Default`] is what the command line uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuOptions {
    /// Caps the output buffer of one dispatch (or less if the adapter's limits are lower;
    /// at least one row); taller images render in several tiles.
    pub max_tile_bytes: u64,
    /// Scenes with at least this many finite primitives get a hierarchy; `usize::MAX` turns
    /// it off, 1 forces it on.
    pub bvh_min_primitives: usize,
    /// How rays find their candidates.
    pub acceleration: Acceleration,
    /// Let the lanes of a bin's row share its loads (`main_bins_shared`) where the device
    /// allows it ([`GpuRenderer::shares_bin_loads`]); false keeps one load per lane
    /// (`main_bins`), as on every other adapter, for tests to compare the two.
    pub shared_bin_loads: bool,
    /// Let the host map the buffers the kernel binds where the device allows it
    /// ([`GpuRenderer::maps_kernel_buffers`]); false copies through staging and readback
    /// buffers, as on a discrete GPU, for tests to compare the two.
    pub mapped_buffers: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            max_tile_bytes: MAX_TILE_BYTES,
            bvh_min_primitives: flatten::BVH_MIN_PRIMITIVES,
            acceleration: Acceleration::Auto,
            shared_bin_loads: true,
            mapped_buffers: true,
        }
    }
}

/// How the kernel finds the primitives a ray may hit (planes are always tested directly).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Acceleration {
    /// Screen-space bins where their lists are short, else the hierarchy from
    /// [`GpuOptions::bvh_min_primitives`] on, else flat loops.
    #[default]
    Auto,
    /// Screen-space bins ([`binning`]).
    Bins,
    /// The bounding volume hierarchy ([`crate::bvh`]).
    Hierarchy,
    /// Every primitive for every ray.
    Flat,
    /// The uniform grid `-grid` asks for (docs/SPEC.md §7); never chosen otherwise.
    Grid,
}

impl Acceleration {
    pub fn name(self) -> &'static str {
        match self {
            Acceleration::Auto => "auto",
            Acceleration::Bins => "bins",
            Acceleration::Hierarchy => "hierarchy",
            Acceleration::Flat => "flat",
            Acceleration::Grid => "grid",
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found ({0}); on a machine without a GPU install Mesa's lavapipe (apt-get install mesa-vulkan-drivers) or use --backend cpu")]
    NoAdapter(String),
    #[error("could not open the GPU device: {0}")]
    Device(String),
    #[error("the scene is too large for this GPU: {0}")]
    TooLarge(String),
    #[error("writing to the GPU's memory failed: {0}")]
    Upload(String),
    #[error("reading the image back from the GPU failed: {0}")]
    Readback(String),
    #[error("{0}; render it with --backend cpu")]
    Precision(precision::PrecisionError),
    #[error("{0}; render it with --backend cpu")]
    Unsupported(support::UnsupportedError),
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

/// The `override` constants a kernel is compiled with: only what the scene and the requested
/// outputs need is compiled in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KernelConfig {
    pub has_spheres: bool,
    pub has_ellipsoids: bool,
    pub has_planes: bool,
    pub has_triangles: bool,
    pub orthographic: bool,
    pub pixel_layout: PixelLayout,
    pub num_lights: u32,
    /// The scene has one material (loaded once per invocation).
    pub one_material: bool,
    pub shade_back: bool,
    /// Some material has a specular colour.
    pub specular: bool,
    pub specular_fix: bool,
    /// Some light is a point light.
    pub point_lights: bool,
    /// Shadow rays (`-shadows` in a scene with lights).
    pub shadows: bool,
    /// The ray tree's depth ([`tree::TreeShape::depth`]).
    pub bounces: u32,
    /// Check every pixel for loops the driver cut short ([`GpuRenderer::loop_limit`]).
    pub loop_canary: bool,
    pub triangle_test: TriangleTest,
    pub sphere_test: SphereTest,
    pub use_bvh: bool,
    pub use_bins: bool,
    /// With bins, the subgroup's lanes share each item's loads (`main_bins_shared`).
    pub shared_bin_loads: bool,
    pub use_grid: bool,
    /// Some material is a solid texture (`shaders/texture.wgsl`).
    pub textures: bool,
    /// `-stats`: count rays, tests and cells (`shaders/stats.wgsl`).
    pub stats: bool,
    /// `-visualize_grid`: draw the grid's occupied cells (`shaders/voxels.wgsl`).
    pub voxels: bool,
    /// Which of the kernel's passes this pipeline runs.
    pub stage: Stage,
}

/// The kernel's passes: one pass for a pixel's centre sample, or, with sampling
/// (docs/SPEC.md §8), a pass tracing every sample and a pass filtering them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Stage {
    /// `main` or `main_bins`: one sample per pixel, at its centre.
    #[default]
    Pixels,
    /// `main_samples`: one invocation per sample; `main_samples_bins`, with bins: a packet of
    /// a pixel's samples per invocation, walking its bin.
    Samples,
    /// `main_filter`: one invocation per output pixel, reading the samples.
    Filter,
}

impl KernelConfig {
    /// The kernel for `buffers`, flattened from a scene whose ray tree is `tree`, that finds
    /// candidates by `acceleration` (never `Auto`: what the buffers hold, or will), on a
    /// driver with (`loop_limit`) or without a loop limit, whose subgroups can share a bin's
    /// loads (`shared_loads`, [`GpuRenderer::shares_bin_loads`]) or not.
    pub fn new(
        buffers: &SceneBuffers,
        acceleration: Acceleration,
        pixel_layout: PixelLayout,
        options: &RenderOptions,
        tree: &tree::TreeShape,
        loop_limit: bool,
        shared_loads: bool,
    ) -> KernelConfig {
        let shading = &options.shading;
        let specular = buffers.materials.iter().any(|m| m.specular != [0.0; 3]);
        let mut config = KernelConfig {
            has_spheres: !buffers.spheres.is_empty(),
            has_ellipsoids: !buffers.ellipsoids.is_empty(),
            has_planes: !buffers.planes.is_empty(),
            has_triangles: !buffers.triangles.is_empty(),
            orthographic: buffers.orthographic,
            pixel_layout,
            num_lights: buffers.lights.len() as u32,
            one_material: buffers.materials.len() == 1,
            shade_back: shading.shade_back,
            specular,
            specular_fix: specular && shading.specular_fix,
            point_lights: buffers.lights.iter().any(|l| l.is_point != 0),
            shadows: shading.shadows && !options.visualize_grid && !buffers.lights.is_empty(),
            bounces: tree.depth,
            loop_canary: false,
            triangle_test: options.triangle_test,
            sphere_test: options.sphere_test,
            use_bvh: acceleration == Acceleration::Hierarchy,
            use_bins: acceleration == Acceleration::Bins,
            shared_bin_loads: false,
            use_grid: acceleration == Acceleration::Grid,
            textures: !buffers.textures.is_empty(),
            stats: options.stats,
            voxels: options.visualize_grid,
            stage: Stage::Pixels,
        };
        // Every pixel, whatever it casts: a hierarchy that cannot cull (slivers across the
        // view), a crowded bin, a flat loop or a texture's blend passes the limit.
        config.loop_canary = loop_limit;
        // The shared walk tests triangles alone, with the watertight test's primary-ray form.
        let eye_only =
            !config.has_spheres && !config.has_ellipsoids && config.triangle_test == TriangleTest::Watertight;
        config.shared_bin_loads = shared_loads && config.use_bins && eye_only;
        config
    }

    /// Pixels each invocation renders, stacked in a column (the kernel's `PACKET` in
    /// `main_bins`): 4 rays share each load from a bin; `main` renders one pixel.
    pub fn packet(&self) -> u32 {
        if self.use_bins {
            BIN_PACKET
        } else {
            1
        }
    }

    /// The kernel's entry point: `main_bins` renders packets from bins (`main_bins_shared`
    /// sharing their loads), `main` one pixel.
    pub fn entry_point(&self) -> &'static str {
        match self.stage {
            Stage::Samples if self.use_bins => return "main_samples_bins",
            Stage::Samples => return "main_samples",
            Stage::Filter => return "main_filter",
            Stage::Pixels => {}
        }
        match (self.use_bins, self.shared_bin_loads) {
            (true, true) => "main_bins_shared",
            (true, false) => "main_bins",
            (false, _) => "main",
        }
    }

    /// Whether rays other than primary ones are traced (shadow, reflected, refracted).
    pub fn secondary_rays(&self) -> bool {
        self.shadows || self.bounces > 0
    }

    /// The values for `PipelineCompilationOptions::constants`.
    pub fn constants(&self) -> [(&'static str, f64); 27] {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        [
            ("HAS_SPHERES", b(self.has_spheres)),
            ("HAS_ELLIPSOIDS", b(self.has_ellipsoids)),
            ("HAS_PLANES", b(self.has_planes)),
            ("HAS_TRIANGLES", b(self.has_triangles)),
            ("ORTHOGRAPHIC", b(self.orthographic)),
            ("WANT_COLOR", b(self.pixel_layout.outputs.contains(Output::Color))),
            ("WANT_NORMAL", b(self.pixel_layout.outputs.contains(Output::Normals))),
            ("WANT_DEPTH", b(self.pixel_layout.outputs.contains(Output::Depth))),
            ("PIXEL_WORDS", self.pixel_layout.words() as f64),
            ("PACKED_8BIT", b(self.pixel_layout.packed)),
            ("NUM_LIGHTS", self.num_lights as f64),
            ("ONE_MATERIAL", b(self.one_material)),
            ("SHADE_BACK", b(self.shade_back)),
            ("SPECULAR", b(self.specular)),
            ("SPECULAR_FIX", b(self.specular_fix)),
            ("POINT_LIGHTS", b(self.point_lights)),
            ("SHADOWS", b(self.shadows)),
            ("BOUNCES", self.bounces as f64),
            ("LOOP_CANARY", b(self.loop_canary)),
            ("TRIANGLE_TEST", self.triangle_test as u32 as f64),
            ("SPHERE_TEST", self.sphere_test as u32 as f64),
            ("USE_BVH", b(self.use_bvh)),
            ("USE_BINS", b(self.use_bins)),
            ("USE_GRID", b(self.use_grid)),
            ("TEXTURES", b(self.textures)),
            ("STATS", b(self.stats)),
            ("VOXELS", b(self.voxels)),
        ]
    }
}

/// One of the kernel's bindings, in `@binding` order: the name of its WGSL variable,
/// whether the kernel writes it, and the size of one element (the least a binding holds).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub name: &'static str,
    pub writable: bool,
    pub element_bytes: u64,
}

const fn binding<T>(name: &'static str, writable: bool) -> Binding {
    Binding { name, writable, element_bytes: std::mem::size_of::<T>() as u64 }
}

/// Every binding of the kernel (`shaders/params.wgsl`), index = `@binding`. The bind-group layout and
/// every bind group are built from this table, and `tests/layout.rs` checks it against the
/// shader's own declarations (names, order, access, element sizes).
pub const BINDINGS: [Binding; 18] = [
    binding::<layout::Params>("params", false),
    binding::<layout::GpuSphere>("spheres", false),
    binding::<layout::GpuEllipsoid>("ellipsoids", false),
    binding::<layout::GpuPlane>("planes", false),
    binding::<layout::GpuTriangle>("triangles", false),
    binding::<layout::GpuMaterial>("materials", false),
    binding::<layout::GpuLight>("lights", false),
    binding::<u32>("pixels", true),
    binding::<crate::bvh::BvhNode>("nodes", false),
    binding::<u32>("prim_refs", false),
    binding::<layout::EyeTriangle>("eye_triangles", false),
    binding::<[u32; 2]>("bin_ranges", false),
    binding::<layout::BinItem>("bin_items", false),
    binding::<layout::GpuTexture>("textures", false),
    binding::<u32>("permutation", false),
    binding::<u32>("counters", true),
    binding::<u32>("samples", true),
    binding::<layout::GpuSampling>("sampling", false),
];

/// Kernels a renderer keeps compiled (see [`GpuRenderer::pipeline`]).
const MAX_CACHED_PIPELINES: usize = 32;

/// The `@binding` of the output (`pixels`).
const OUTPUT_BINDING: usize = 7;

/// The `@binding`s of the bins' lists (per slot where the frame has bins: each tile's band).
const BIN_RANGES_BINDING: usize = 11;
const BIN_ITEMS_BINDING: usize = 12;

/// The `@binding` of the `-stats` counters (`counters`).
const COUNTERS_BINDING: usize = 15;

/// The `@binding`s of the samples of a tile and of their parameters (per slot, like the
/// output).
const SAMPLES_BINDING: usize = 16;
const SAMPLING_BINDING: usize = 17;

/// The most bytes of samples one tile holds (the overlap rows of the filter included).
pub const MAX_SAMPLE_BYTES: u64 = 64 << 20;

/// A wgpu device with the ray-casting kernel, ready to render scenes.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    /// Every binding: the layout of every kernel on an adapter that offers them all. `None`
    /// on one that offers fewer storage buffers per shader stage than the kernel declares,
    /// which would refuse it: there each scene binds only those its kernels use
    /// ([`bindings`]).
    all_bindings: Option<bindings::BindingSet>,
    pipelines: Mutex<HashMap<(KernelConfig, u32), wgpu::ComputePipeline>>,
    options: GpuOptions,
    timestamps: bool,
}

/// What a render cost, as far as the GPU can tell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Time spent in the kernel, summed over tiles, from GPU timestamp queries; `None`
    /// where the adapter has none (then only wall time can be measured).
    pub kernel_ns: Option<u64>,
    /// Dispatches the image took.
    pub tiles: u32,
    /// Time to build the hierarchy or the bins on the CPU, when the scene got one.
    pub acceleration_build_ms: Option<f64>,
    /// Pixels whose loops the driver cut short ([`GpuRenderer::loop_limit`]), which the
    /// reference rendered instead.
    pub pixels_cut_short: u64,
    /// Pixels where a solid texture was blended beyond its reach
    /// ([`texture_range`]), which the reference rendered instead.
    pub pixels_beyond_reach: u64,
    /// Time to flatten the scene into buffers (BVH build included) and upload them.
    pub prepare_ms: f64,
    /// Bytes of scene data on the device (primitives, materials, lights, hierarchy, and
    /// the bins: their edge planes and the buffers of the lists of each tile in flight).
    pub scene_bytes: u64,
    /// How the kernel found candidates (never `Auto`: what the cost model chose).
    pub acceleration: Acceleration,
    /// The course's statistics (`-stats`), where the render was asked to count them
    /// (docs/SPEC.md §7).
    pub counted: Option<crate::render::RayStats>,
    /// The box the `-grid` cells divide, where there was a grid.
    pub grid_bounds: Option<crate::scene::Bounds>,
}

impl GpuRenderer {
    /// Opens the first adapter wgpu offers (real GPUs come before CPU ones such as lavapipe;
    /// `WGPU_BACKEND` and the other wgpu environment variables are honoured).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn new() -> Result<GpuRenderer, GpuError> {
        Self::with_options(GpuOptions::default())
    }

    /// As [`GpuRenderer::new`], rendering as `options` say.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn with_options(options: GpuOptions) -> Result<GpuRenderer, GpuError> {
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
        // The defaults are below what lavapipe and real GPUs offer (docs/lavapipe.md); ask for all.
        let limits = adapter.limits();
        // Kernel time from the GPU's own clock where the adapter offers it (lavapipe does).
        // Subgroups where offered: on lavapipe a bin's lanes share their loads with them
        // (GpuRenderer::shares_bin_loads). Buffers the kernel binds that the host also maps,
        // where the device's memory is the host's (a CPU adapter): no staging copies
        // (GpuRenderer::maps_kernel_buffers).
        let mut wanted = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SUBGROUP;
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
        Ok(Self::with_device(adapter.get_info(), device, queue, options))
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
        let all = device.limits().max_storage_buffers_per_shader_stage >= BINDINGS.len() as u32;
        let all_bindings = all.then(|| bindings::BindingSet::new(&device, bindings::BindingSet::ALL));
        GpuRenderer {
            limits: device.limits(),
            timestamps: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
            device,
            queue,
            adapter_info,
            all_bindings,
            pipelines: Mutex::new(HashMap::new()),
            options,
        }
    }

    /// Another renderer on this one's device and queue, rendering as `options` say (opens
    /// no second device).
    pub fn on_same_device(&self, options: GpuOptions) -> GpuRenderer {
        Self::with_device(self.adapter_info.clone(), self.device.clone(), self.queue.clone(), options)
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

    /// Flattens, uploads and binds `scene` for the outputs `options` asks for, once; the
    /// result renders the image tile by tile. `packed` asks for the outputs as 8-bit images
    /// (one word per pixel and output, quantised by the kernel), else as floats.
    pub fn prepare(&self, scene: &Scene, options: &RenderOptions, packed: bool) -> Result<PreparedScene<'_>, GpuError> {
        PreparedScene::new(self, scene, options, PixelLayout::new(options, packed))
    }

    /// Renders `scene` into float buffers; see [`crate::image_io`] for images.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render(&self, scene: &Scene, options: &RenderOptions) -> Result<Frame, GpuError> {
        let mut frame = Frame::new(options);
        self.render_tiles(scene, options, |first_row, tile| {
            frame.paste(first_row, &tile);
            Ok::<(), GpuError>(())
        })?;
        Ok(frame)
    }

    /// Renders `scene` in tiles of full rows, top first, handing each to `on_tile` with its
    /// first image row as soon as it is read back: memory is bounded by the tile.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_tiles<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        self.render_band(scene, options, 0, options.height, on_tile)
    }

    /// As [`GpuRenderer::render_tiles`], for image rows `first .. first + rows` only (a band
    /// of a render split across machines); tiles still carry image row numbers.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_band<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let prepared = self.prepare(scene, options, false)?;
        prepared.render_band(first, rows, |tile| on_tile(tile.first_row, tile.to_frame()))
    }

    /// How many loop iterations this adapter's driver lets one invocation run in all:
    /// lavapipe's compiler ends loops after [`flatten::LOOP_LIMIT`] (docs/lavapipe.md);
    /// other drivers have no such limit.
    pub fn loop_limit(&self) -> Option<u32> {
        let info = &self.adapter_info;
        let lavapipe = info.driver.contains("llvmpipe") || info.name.contains("llvmpipe");
        lavapipe.then_some(flatten::LOOP_LIMIT)
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

    /// The bindings the kernels `stages` of a scene in `file` use: all of them, or where
    /// the adapter offers fewer ([`bindings`]) those the kernels reference, refused when
    /// they are still too many.
    fn bindings_for(&self, stages: &[KernelConfig], file: &std::path::Path) -> Result<bindings::BindingSet, GpuError> {
        if let Some(all) = &self.all_bindings {
            return Ok(all.clone());
        }
        let mask = stages.iter().fold(0, |mask, &config| mask | bindings::referenced(&Self::kernel(config)));
        let (count, limit) = (mask.count_ones(), self.limits.max_storage_buffers_per_shader_stage);
        if count > limit {
            return Err(GpuError::Unsupported(support::UnsupportedError {
                file: file.to_path_buf(),
                location: None,
                what: format!("its kernel binds {count} storage buffers, more than the {limit} per shader stage this adapter offers"),
            }));
        }
        Ok(bindings::BindingSet::new(&self.device, mask))
    }

    fn kernel(config: KernelConfig) -> naga::Module {
        if fuse::requested() {
            return specialise::specialise(&shader::fused_module().0, &config.constants(), config.entry_point());
        }
        specialise::specialise(shader::module(), &config.constants(), config.entry_point())
    }

    fn pipeline(&self, config: KernelConfig, bindings: &bindings::BindingSet) -> wgpu::ComputePipeline {
        let key = (config, bindings.mask);
        let cache = || self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(pipeline) = cache().get(&key) {
            return pipeline.clone();
        }
        // Compiled without the cache's lock, so that two threads compile two kernels at once
        // (PreparedScene::new: a planned kernel and the one needed instead).
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("raycast"),
            source: specialise::shader_source(Self::kernel(config)),
        });
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
            cache: None,
        });
        let mut cache = cache();
        // A compiled kernel holds megabytes on lavapipe; a process that renders many kinds
        // of scene (the random-scene test: hundreds) starts over rather than keep them all.
        if cache.len() >= MAX_CACHED_PIPELINES && !cache.contains_key(&key) {
            cache.clear();
        }
        cache.entry(key).or_insert(pipeline).clone()
    }

    /// How many image rows one dispatch renders: as many as fit the adapter's storage
    /// binding limit and our own cap (lower on a CPU adapter), and the dispatch size limit.
    fn tile_rows(&self, width: u32, layout: &PixelLayout) -> Result<u32, GpuError> {
        let row_bytes = width as u64 * layout.words() as u64 * 4;
        let adapter_budget = self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size);
        let max_groups = self.limits.max_compute_workgroups_per_dimension as u64;
        if row_bytes > adapter_budget || (width as u64).div_ceil(WORKGROUP as u64) > max_groups {
            return Err(GpuError::TooLarge(format!("an image {width} pixels wide exceeds the adapter's limits")));
        }
        let cap = match self.adapter_info.device_type {
            wgpu::DeviceType::Cpu => self.options.max_tile_bytes.min(CPU_TILE_BYTES),
            _ => self.options.max_tile_bytes,
        };
        let rows = (cap.min(adapter_budget) / row_bytes).max(1);
        // Whole workgroup rows where possible, so no dispatch ends in a half-empty workgroup.
        // Whole workgroups of the largest packet, whichever kernel runs.
        let group_rows = (WORKGROUP * BIN_PACKET) as u64;
        let rows = if rows >= group_rows { rows - rows % group_rows } else { rows };
        Ok(rows.min((max_groups - 1) * group_rows) as u32)
    }
}

/// Two timestamps around the compute pass, resolved into a buffer we can map.
struct Timer {
    queries: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl Timer {
    fn new(device: &wgpu::Device) -> Timer {
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage,
                mapped_at_creation: false,
            })
        };
        Timer {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel time"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolved: buffer("timestamps", wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC),
            readback: buffer("timestamps readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST),
        }
    }

    fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolved, 0);
        encoder.copy_buffer_to_buffer(&self.resolved, 0, &self.readback, 0, 16);
    }

    #[cfg(not(target_arch = "wasm32"))]
    fn elapsed_ns(&self, device: &wgpu::Device, period_ns: f32) -> Result<u64, GpuError> {
        let bytes = read_back(device, &self.readback)?;
        Ok(Self::span_ns(&bytes, period_ns))
    }

    /// As [`Timer::elapsed_ns`], awaiting the map ([`PreparedScene::render_async`]).
    async fn elapsed_ns_async(&self, gpu: &GpuRenderer, submission: wgpu::SubmissionIndex) -> Result<u64, GpuError> {
        let slice = self.readback.slice(..);
        prepared::map_async(&gpu.device, &slice, submission).await?;
        let bytes = slice.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
        self.readback.unmap();
        Ok(Self::span_ns(&bytes, gpu.queue.get_timestamp_period()))
    }

    fn span_ns(bytes: &[u8], period_ns: f32) -> u64 {
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(bytes);
        (ticks[1].saturating_sub(ticks[0]) as f64 * period_ns as f64) as u64
    }
}

#[cfg(not(target_arch = "wasm32"))]
fn read_back(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
    receiver.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
    let bytes = slice.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
    buffer.unmap();
    Ok(bytes)
}
