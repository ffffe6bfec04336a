//! `--backend auto`'s rules for giving the reference a job the GPU could render: where the
//! reference is quicker. The measurements behind the thresholds are in docs/performance.md.

use crate::gpu::ray_tree::RenderRays;
use crate::gpu::GpuRenderer;
use crate::render::RenderOptions;
use crate::scene::Scene;

/// Ray/primitive pairs up to which `auto` renders with the f64 reference instead of opening
/// the GPU: about what the reference tests in the time opening a CPU Vulkan device and
/// compiling a kernel takes (docs/performance.md, "Measurements behind `auto`'s rules").
pub const REFERENCE_QUICKER_BELOW: u64 = 2_000_000;

/// Whether `auto` should render `scene` with the reference without opening the GPU: a job
/// so small that the device's start-up would dominate. Counts every primitive for every
/// pixel, an upper bound of the reference's work; through an explicit `-grid nx ny nz`, at
/// most `nx + ny + nz` of them, the cells a ray can cross, which the course sizes to hold a
/// primitive or so each.
pub fn reference_is_quicker(scene: &Scene, options: &RenderOptions) -> bool {
    let primitives = scene.primitive_counts().total() as u64;
    let per_ray = options.grid.map_or(primitives, |g| primitives.min(g.nx as u64 + g.ny as u64 + g.nz as u64));
    options.sample_count() * per_ray <= REFERENCE_QUICKER_BELOW
}

/// Whether `auto` opens the GPU for a render as `options` say whatever its scene, but for
/// a scene with nothing in it: its samples alone exceed [`REFERENCE_QUICKER_BELOW`], so the
/// device can open while the scene is read.
pub fn samples_alone_open_the_gpu(options: &RenderOptions) -> bool {
    options.sample_count() > REFERENCE_QUICKER_BELOW
}

/// Primitives (each triangle of a mesh counted) up to which `auto` traces a scene that needs
/// secondary rays with the reference rather than with a CPU Vulkan device (lavapipe; WARP):
/// there the kernel's ray trees run no faster than the reference, which tests every
/// primitive, on scenes this small, and compiling a tree kernel costs more than the render
/// (docs/performance.md, "Measurements behind `auto`'s rules"). A real GPU always gets the
/// scene.
pub const CPU_DEVICE_TREE_PRIMITIVES: usize = 128;

/// Why the reference traces `scene` quicker than `gpu`, if it does: on a CPU device, a
/// scene with secondary rays and few primitives (see [`CPU_DEVICE_TREE_PRIMITIVES`]), or
/// walked through an explicit `-grid`, which the reference then walks too (every line of
/// assignment 6 that casts secondary rays through a grid was quicker on it: docs/performance.md).
pub fn reference_traces_quicker(gpu: &GpuRenderer, scene: &Scene, options: &RenderOptions) -> Option<&'static str> {
    let cpu_device = gpu.adapter_info().device_type == wgpu::DeviceType::Cpu;
    if !cpu_device || !RenderRays::new(scene, options).secondary() {
        None
    } else if scene.primitive_counts().total() <= CPU_DEVICE_TREE_PRIMITIVES {
        Some("auto: ray trees of a scene this small are quicker here than on a CPU Vulkan device")
    } else if options.grid.is_some() {
        Some("auto: ray trees through a -grid are quicker here on the reference than on a CPU Vulkan device")
    } else {
        None
    }
}
