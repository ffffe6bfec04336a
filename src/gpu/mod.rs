//! The GPU backend: a WGSL compute kernel driven through wgpu, headless.
//!
//! A [`GpuRenderer`] owns the device (created once per process, reused for any number of
//! scenes) and a cache of kernels specialised by `override` constants. [`GpuRenderer::render`]
//! flattens the scene ([`buffers`]), dispatches one invocation per pixel in tiles of rows
//! (so memory is bounded by the tile, not the frame), and reads the float results back
//! into a [`Frame`].

pub mod buffers;
pub mod precision;

use crate::camera::PrimaryRays;
use crate::render::{row_tiles, Frame, RenderOptions, SphereTest, TriangleTest};
use crate::scene::Scene;
use buffers::{PixelLayout, SceneBuffers};
use std::collections::HashMap;
use std::sync::Mutex;
use wgpu::util::DeviceExt;

/// The kernel's source, compiled into the binary.
pub const SHADER_SOURCE: &str = include_str!("../../shaders/raycast.wgsl");

/// Workgroup edge, as in `@workgroup_size(8, 8)`.
const WORKGROUP: u32 = 8;

/// The output tile of one dispatch. Small tiles stay in the CPU's caches on lavapipe:
/// bunny_40k at 2048² ran at 7.4 Mrays/s with 64 MiB tiles, 9.3 with 16 MiB, 9.8 with 8 MiB,
/// 10.3 with 2 MiB and 10.2 with 1 MiB (`raycaster bench --only bunny_40k`, kernel time from
/// timestamps); below that the dispatches multiply. It also bounds host memory.
const MAX_TILE_BYTES: u64 = 2 << 20;

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found ({0}); on a machine without a GPU install Mesa's lavapipe (apt-get install mesa-vulkan-drivers) or use --backend cpu")]
    NoAdapter(String),
    #[error("could not open the GPU device: {0}")]
    Device(String),
    #[error("the scene is too large for this GPU: {0}")]
    TooLarge(String),
    #[error("reading the image back from the GPU failed: {0}")]
    Readback(String),
    #[error("{0}; render it with --backend cpu")]
    Precision(precision::PrecisionError),
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
    pub shade_back: bool,
    pub triangle_test: TriangleTest,
    pub sphere_test: SphereTest,
    pub use_bvh: bool,
}

impl KernelConfig {
    pub fn new(buffers: &SceneBuffers, options: &RenderOptions) -> KernelConfig {
        KernelConfig {
            has_spheres: !buffers.spheres.is_empty(),
            has_ellipsoids: !buffers.ellipsoids.is_empty(),
            has_planes: !buffers.planes.is_empty(),
            has_triangles: !buffers.triangles.is_empty(),
            orthographic: buffers.orthographic,
            pixel_layout: PixelLayout::new(options),
            num_lights: buffers.lights.len() as u32,
            shade_back: options.shade_back,
            triangle_test: options.triangle_test,
            sphere_test: options.sphere_test,
            use_bvh: buffers.bvh.is_some(),
        }
    }

    /// The values for `PipelineCompilationOptions::constants`.
    pub fn constants(&self) -> [(&'static str, f64); 14] {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        [
            ("HAS_SPHERES", b(self.has_spheres)),
            ("HAS_ELLIPSOIDS", b(self.has_ellipsoids)),
            ("HAS_PLANES", b(self.has_planes)),
            ("HAS_TRIANGLES", b(self.has_triangles)),
            ("ORTHOGRAPHIC", b(self.orthographic)),
            ("WANT_COLOR", b(self.pixel_layout.color)),
            ("WANT_NORMAL", b(self.pixel_layout.normal)),
            ("WANT_DEPTH", b(self.pixel_layout.depth)),
            ("PIXEL_WORDS", self.pixel_layout.words() as f64),
            ("NUM_LIGHTS", self.num_lights as f64),
            ("SHADE_BACK", b(self.shade_back)),
            ("TRIANGLE_TEST", self.triangle_test as u32 as f64),
            ("SPHERE_TEST", self.sphere_test as u32 as f64),
            ("USE_BVH", b(self.use_bvh)),
        ]
    }
}

/// A wgpu device with the ray-casting kernel, ready to render scenes.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    bind_group_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    pipelines: Mutex<HashMap<KernelConfig, wgpu::ComputePipeline>>,
    max_tile_bytes: u64,
    timestamps: bool,
    bvh_min_primitives: usize,
}

/// What a render cost, as far as the GPU can tell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Time spent in the kernel, summed over tiles, from GPU timestamp queries; `None`
    /// where the adapter has none (then only wall time can be measured).
    pub kernel_ns: Option<u64>,
    /// Dispatches the image took.
    pub tiles: u32,
    /// Time to build the hierarchy on the CPU, when the scene got one.
    pub bvh_build_ms: Option<f64>,
    /// Time to flatten the scene into buffers (BVH build included) and upload them.
    pub prepare_ms: f64,
    /// Bytes of scene data uploaded (primitives, materials, lights, hierarchy).
    pub scene_bytes: u64,
}

impl GpuRenderer {
    /// Opens the first adapter wgpu offers (real GPUs come before CPU ones such as lavapipe;
    /// `WGPU_BACKEND` and the other wgpu environment variables are honoured).
    pub fn new() -> Result<GpuRenderer, GpuError> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<GpuRenderer, GpuError> {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(descriptor);
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        // The defaults are below what lavapipe and real GPUs offer (MEASURED.md); ask for all.
        let limits = adapter.limits();
        // Kernel time from the GPU's own clock where the adapter offers it (lavapipe does).
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("raycaster"),
                required_features: features,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("raycast.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADER_SOURCE.into()),
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raycast bindings"),
            entries: &(0..10).map(storage_entry).collect::<Vec<_>>(),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("raycast layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        Ok(GpuRenderer {
            device,
            queue,
            adapter_info: adapter.get_info(),
            limits,
            bind_group_layout,
            pipeline_layout,
            module,
            pipelines: Mutex::new(HashMap::new()),
            max_tile_bytes: MAX_TILE_BYTES,
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
            bvh_min_primitives: buffers::BVH_MIN_PRIMITIVES,
        })
    }

    /// Caps the output buffer of one dispatch (default 2 MiB, or less if the adapter's
    /// limits are lower; at least one row); taller images render in several tiles.
    pub fn set_max_tile_bytes(&mut self, bytes: u64) {
        self.max_tile_bytes = bytes;
    }

    /// Scenes with at least this many finite primitives get a hierarchy (default
    /// [`buffers::BVH_MIN_PRIMITIVES`]); `usize::MAX` turns it off, 1 forces it on.
    pub fn set_bvh_min_primitives(&mut self, count: usize) {
        self.bvh_min_primitives = count;
    }

    /// Which adapter this renderer runs on (name, backend, device type).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.adapter_info
    }

    /// Renders `scene` into float buffers; see [`crate::image_io`] for images.
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
    pub fn render_tiles<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let start = std::time::Instant::now();
        let rays = PrimaryRays::new(&scene.camera, options.width, options.height)
            .expect("the parser rejects cameras whose up is parallel to their direction");
        // Refused before any tile is handed out: `auto` then renders with the reference.
        precision::check(scene, options).map_err(GpuError::Precision)?;
        let buffers = SceneBuffers::new(scene, &rays, self.bvh_min_primitives);
        let pipeline = self.pipeline(KernelConfig::new(&buffers, options));
        let inputs = self.upload(&buffers)?;
        let layout = PixelLayout::new(options);
        let tile_rows = self.tile_rows(options.width, &layout)?;
        let mut stats = RenderStats {
            kernel_ns: self.timestamps.then_some(0),
            tiles: 0,
            bvh_build_ms: buffers.bvh.as_ref().map(|b| b.build_ms),
            prepare_ms: start.elapsed().as_secs_f64() * 1e3,
            scene_bytes: inputs.bytes(),
        };
        for (first_row, rows) in row_tiles(options.height, tile_rows) {
            let (words, kernel_ns) = self.render_tile(&pipeline, &inputs, buffers.params, &layout, first_row, rows)?;
            stats.kernel_ns = stats.kernel_ns.zip(kernel_ns).map(|(a, b)| a + b);
            stats.tiles += 1;
            on_tile(first_row, layout.decode(options, rows, &words))?;
        }
        Ok(stats)
    }

    fn pipeline(&self, config: KernelConfig) -> wgpu::ComputePipeline {
        let mut cache = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(config)
            .or_insert_with(|| {
                self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("raycast"),
                    layout: Some(&self.pipeline_layout),
                    module: &self.module,
                    entry_point: Some("main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &config.constants(),
                        zero_initialize_workgroup_memory: false,
                    },
                    cache: None,
                })
            })
            .clone()
    }

    /// How many image rows one dispatch renders: as many as fit the adapter's storage
    /// binding limit and our own cap, and the dispatch size limit.
    fn tile_rows(&self, width: u32, layout: &PixelLayout) -> Result<u32, GpuError> {
        let row_bytes = width as u64 * layout.words() as u64 * 4;
        let adapter_budget = self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size);
        let max_groups = self.limits.max_compute_workgroups_per_dimension as u64;
        if row_bytes > adapter_budget || (width as u64).div_ceil(WORKGROUP as u64) > max_groups {
            return Err(GpuError::TooLarge(format!("an image {width} pixels wide exceeds the adapter's limits")));
        }
        let rows = (self.max_tile_bytes.min(adapter_budget) / row_bytes).max(1);
        // Whole workgroup rows where possible, so no dispatch ends in a half-empty workgroup.
        let rows = if rows >= WORKGROUP as u64 { rows - rows % WORKGROUP as u64 } else { rows };
        Ok(rows.min(max_groups * WORKGROUP as u64) as u32)
    }

    fn upload(&self, buffers: &SceneBuffers) -> Result<SceneInputs, GpuError> {
        let limit = self.limits.max_storage_buffer_binding_size;
        let storage = |label: &str, bytes: &[u8]| -> Result<wgpu::Buffer, GpuError> {
            if bytes.len() as u64 > limit {
                return Err(GpuError::TooLarge(format!(
                    "{label}: {} bytes exceed the adapter's storage binding limit of {limit} bytes",
                    bytes.len()
                )));
            }
            Ok(self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            }))
        };
        Ok(SceneInputs {
            spheres: storage("spheres", non_empty(&buffers.spheres))?,
            ellipsoids: storage("ellipsoids", non_empty(&buffers.ellipsoids))?,
            planes: storage("planes", non_empty(&buffers.planes))?,
            triangles: storage("triangles", non_empty(&buffers.triangles))?,
            materials: storage("materials", non_empty(&buffers.materials))?,
            lights: storage("lights", non_empty(&buffers.lights))?,
            nodes: storage("bvh nodes", non_empty(buffers.bvh.as_ref().map_or(&[][..], |b| &b.nodes)))?,
            prim_refs: storage("bvh primitives", non_empty(buffers.bvh.as_ref().map_or(&[][..], |b| &b.prim_refs)))?,
        })
    }

    fn render_tile(
        &self,
        pipeline: &wgpu::ComputePipeline,
        inputs: &SceneInputs,
        mut params: buffers::Params,
        layout: &PixelLayout,
        first_row: u32,
        rows: u32,
    ) -> Result<(Vec<u32>, Option<u64>), GpuError> {
        params.first_row = first_row;
        params.tile_rows = rows;
        let params_buffer = self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = params.width as u64 * rows as u64 * layout.words() as u64 * 4;
        let output = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pixels"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bindings = [
            &params_buffer,
            &inputs.spheres,
            &inputs.ellipsoids,
            &inputs.planes,
            &inputs.triangles,
            &inputs.materials,
            &inputs.lights,
            &output,
            &inputs.nodes,
            &inputs.prim_refs,
        ];
        let entries: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() })
            .collect();
        let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raycast"),
            layout: &self.bind_group_layout,
            entries: &entries,
        });
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("raycast") });
        // Per render, not per renderer: renders from several threads must not share them.
        let timer = self.timestamps.then(|| Timer::new(&self.device));
        {
            let timestamp_writes = timer.as_ref().map(|t| wgpu::ComputePassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("raycast"), timestamp_writes });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(params.width.div_ceil(WORKGROUP), rows.div_ceil(WORKGROUP), 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, size);
        if let Some(timer) = &timer {
            timer.resolve(&mut encoder);
        }
        self.queue.submit([encoder.finish()]);
        let pixels: Vec<u32> = bytemuck::pod_collect_to_vec(&read_back(&self.device, &readback)?);
        let kernel_ns = match &timer {
            Some(timer) => Some(timer.elapsed_ns(&self.device, self.queue.get_timestamp_period())?),
            None => None,
        };
        Ok((pixels, kernel_ns))
    }
}

/// The scene's read-only buffers on the device.
struct SceneInputs {
    spheres: wgpu::Buffer,
    ellipsoids: wgpu::Buffer,
    planes: wgpu::Buffer,
    triangles: wgpu::Buffer,
    materials: wgpu::Buffer,
    lights: wgpu::Buffer,
    nodes: wgpu::Buffer,
    prim_refs: wgpu::Buffer,
}

impl SceneInputs {
    fn bytes(&self) -> u64 {
        [
            &self.spheres,
            &self.ellipsoids,
            &self.planes,
            &self.triangles,
            &self.materials,
            &self.lights,
            &self.nodes,
            &self.prim_refs,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            // The last binding is the output.
            ty: wgpu::BufferBindingType::Storage { read_only: binding != 7 },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A zero-sized buffer cannot be bound, so an empty list is uploaded as one zeroed element
/// (the kernel reads only as many as `Params` counts).
fn non_empty<T: bytemuck::Pod>(items: &[T]) -> &[u8] {
    const ZEROS: [u8; 64] = [0; 64];
    if items.is_empty() {
        &ZEROS[..std::mem::size_of::<T>()]
    } else {
        bytemuck::cast_slice(items)
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

    fn elapsed_ns(&self, device: &wgpu::Device, period_ns: f32) -> Result<u64, GpuError> {
        let bytes = read_back(device, &self.readback)?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes);
        Ok((ticks[1].saturating_sub(ticks[0]) as f64 * period_ns as f64) as u64)
    }
}

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
