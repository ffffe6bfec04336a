//! Which of the kernel's bindings a prepared scene binds. The kernel declares eighteen
//! storage buffers ([`BINDINGS`]). Native adapters offer far more per shader stage, and
//! there every pipeline shares one layout of all of them. WebGPU in a browser offers 8 to
//! 10 (Chromium, SwiftShader included: 10), so on such an adapter a scene's layout holds
//! only the bindings its kernels still reference once [`super::specialise`] has cut what
//! the scene does not use (a sphere scene binds no triangles, no hierarchy, no bins).

use super::layout;

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

/// The `@binding` of the output (`pixels`).
pub(super) const OUTPUT_BINDING: usize = 7;

/// The `@binding`s of the bins' lists (per slot where the frame has bins: each tile's band).
pub(super) const BIN_RANGES_BINDING: usize = 11;
pub(super) const BIN_ITEMS_BINDING: usize = 12;

/// The `@binding` of the `-stats` counters (`counters`).
pub(super) const COUNTERS_BINDING: usize = 15;

/// The `@binding`s of the samples of a tile and of their parameters (per slot, like the
/// output).
pub(super) const SAMPLES_BINDING: usize = 16;
pub(super) const SAMPLING_BINDING: usize = 17;

/// A set of the kernel's bindings (bit k: `@binding(k)`) and its layouts.
#[derive(Clone)]
pub(super) struct BindingSet {
    pub mask: u32,
    pub group: wgpu::BindGroupLayout,
    pub pipeline: wgpu::PipelineLayout,
}

impl BindingSet {
    pub const ALL: u32 = (1 << BINDINGS.len()) - 1;

    pub fn new(device: &wgpu::Device, mask: u32) -> BindingSet {
        let entries: Vec<_> =
            BINDINGS.iter().enumerate().filter(|&(k, _)| mask & 1 << k != 0).map(|(k, b)| entry(k as u32, b)).collect();
        let group = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("raycast bindings"),
            entries: &entries,
        });
        let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("raycast layout"),
            bind_group_layouts: &[Some(&group)],
            immediate_size: 0,
        });
        BindingSet { mask, group, pipeline }
    }

    pub fn contains(&self, binding: usize) -> bool {
        self.mask & 1 << binding != 0
    }
}

/// The bindings `module` (a specialised kernel) still references.
pub(super) fn referenced(module: &naga::Module) -> u32 {
    module.global_variables.iter().filter_map(|(_, g)| g.binding.as_ref()).fold(0, |mask, b| mask | 1 << b.binding)
}

fn entry(index: u32, binding: &Binding) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding: index,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: !binding.writable },
            has_dynamic_offset: false,
            min_binding_size: std::num::NonZeroU64::new(binding.element_bytes),
        },
        count: None,
    }
}
