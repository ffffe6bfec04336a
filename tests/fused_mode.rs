//! The fused test mode (src/gpu/fuse.rs) fuses for real on the drivers we test on, which
//! do not fuse on their own: a difference of equal products, `a·b − b·a`, is exactly 0
//! computed as written and the rounding error of one product once fused; the kernel's
//! `rounded()` products (shaders/exact.wgsl) stay 0 in both. Run on the machine's driver
//! (lavapipe in CI) through wgpu, with the pass applied as the renderer applies it.

mod common;

use raycaster::gpu::fuse;
use wgpu::util::DeviceExt;

const N: usize = 256;

const KERNEL: &str = "
struct P { zero_bits: u32 }
@group(0) @binding(0) var<storage, read> input: array<vec2<f32>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> params: P;
fn rounded(x: f32) -> f32 { return bitcast<f32>(bitcast<u32>(x) | params.zero_bits); }
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let a = input[id.x].x;
    let b = input[id.x].y;
    out[id.x] = vec4<f32>(a * b - b * a, rounded(a * b) - rounded(b * a), fma(a, b, -(b * a)), 0.0);
}";

/// Per input: `a·b − b·a` as written, with rounded products, and as an explicit `fma`.
fn run(device: &wgpu::Device, queue: &wgpu::Queue, fused: bool) -> Vec<[f32; 4]> {
    let mut module = naga::front::wgsl::parse_str(&format!("{}{KERNEL}", fuse::prelude())).unwrap();
    if fused {
        assert_eq!(fuse::fuse(&mut module).len(), 2, "the difference and the fma are fused");
    }
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: None,
        module: &shader,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    // Products with many significant bits, whose rounding errors are not 0.
    let mut state = 837_u64;
    let inputs: Vec<[f32; 2]> = (0..N)
        .map(|_| {
            let (x, y) = (common::splitmix64(&mut state), common::splitmix64(&mut state));
            [1.0 + (x >> 41) as f32 / (1u64 << 23) as f32, 0.1 + (y >> 41) as f32 / (1u64 << 22) as f32]
        })
        .collect();
    let storage = |contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: None, contents, usage })
    };
    let input = storage(bytemuck::cast_slice(&inputs), wgpu::BufferUsages::STORAGE);
    let params = storage(&[0u8; 16], wgpu::BufferUsages::STORAGE);
    let size = (N * 16) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: params.as_entire_binding() },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((N / 64) as u32, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&out, 0, &read, 0, size);
    queue.submit([encoder.finish()]);
    read.slice(..).map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let bytes = read.slice(..).get_mapped_range().unwrap().to_vec();
    bytemuck::cast_slice::<u8, [f32; 4]>(&bytes).to_vec()
}

#[test]
fn the_fused_mode_fuses_what_the_driver_does_not_and_rounded_products_stay_exact() {
    let Some(gpu) = common::gpu() else { return };
    let adapter_info = gpu.adapter_info().clone();
    let instance = raycaster::gpu::GpuRenderer::instance();
    let adapter = pollster::block_on(instance.request_adapter(&Default::default())).unwrap();
    if !adapter.features().contains(wgpu::Features::SHADER_F64) {
        eprintln!("SKIPPED: {} offers no f64, which the fused mode needs", adapter_info.name);
        return;
    }
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: wgpu::Features::SHADER_F64,
        ..Default::default()
    }))
    .unwrap();
    let plain = run(&device, &queue, false);
    let fused = run(&device, &queue, true);
    let nonzero = |values: &[[f32; 4]], k: usize| values.iter().filter(|v| v[k] != 0.0).count();
    println!(
        "{}: a·b − b·a nonzero in {} of {N} as compiled, {} fused; with rounded products {} and {}; \
         fma(a, b, −b·a) nonzero in {} (0: the driver computes an explicit fma unfused)",
        adapter.get_info().name,
        nonzero(&plain, 0),
        nonzero(&fused, 0),
        nonzero(&plain, 1),
        nonzero(&fused, 1),
        nonzero(&plain, 2),
    );
    assert!(nonzero(&fused, 0) > N / 2, "fused, a·b − b·a is one product's rounding error");
    assert_eq!(nonzero(&fused, 2), nonzero(&fused, 0), "an explicit fma is fused the same way");
    assert_eq!(nonzero(&plain, 1) + nonzero(&fused, 1), 0, "rounded products are exact whatever is fused");
}
