//! The kernel's bindings, by name: [`Binding`] is the one table from which the WGSL
//! declarations ([`wgsl_declarations`], composed before `shaders/` by
//! [`super::shader::source`]), the bind-group layouts and every bind group come.
//!
//! Which of them a prepared scene binds: native adapters offer far more storage buffers
//! per shader stage than the kernel declares, and there every pipeline shares one layout
//! of all of them. WebGPU in a browser offers 8 to 10 (Chromium, SwiftShader included: 10),
//! so on such an adapter a scene's layout holds only the bindings its kernels still
//! reference once [`super::specialise`] has cut what the scene does not use (a sphere
//! scene binds no triangles, no hierarchy, no bins): a [`BindingSet`].

use super::layout;
use std::fmt::Write;
use std::ops::Index;

/// One of the kernel's storage buffers, all in `@group(0)`; its position in [`Binding::ALL`]
/// is its `@binding`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Binding {
    /// A dispatch's parameters (each tile's own), loaded once per invocation.
    Params,
    Spheres,
    Ellipsoids,
    Planes,
    Triangles,
    Materials,
    Lights,
    /// The tile's output: `PIXEL_WORDS` words per pixel, f32 values as their bits.
    Pixels,
    /// The hierarchy's nodes.
    Nodes,
    /// References (kind << REF_KIND_SHIFT | index into that kind's array), in the
    /// hierarchy's leaf order; with `-grid`, which has no hierarchy, in its cells' order.
    PrimRefs,
    /// The bins' triangles as primary rays see them.
    EyeTriangles,
    /// Per bin (BIN_COLUMNS × BIN_ROWS pixels, row by row from `first_bin_row`, the band of
    /// bin rows the dispatch traces): first item and count; with `-grid`, which has no bins,
    /// each cell's first reference in `prim_refs` and count.
    BinRanges,
    /// The bins' lists.
    BinItems,
    /// One per material where the scene has solid textures (a single zero entry otherwise).
    Textures,
    /// Perlin's permutation (256 entries) where the scene has solid textures (a single zero
    /// otherwise).
    Permutation,
    /// The `-stats` counts (shaders/stats.wgsl), where the render counts; never touched
    /// otherwise.
    Counters,
    /// A tile's samples, SAMPLE_WORDS words each (shaders/sampling.wgsl), where the render
    /// samples (docs/SPEC.md §8); a single zero otherwise.
    Samples,
    /// The parameters of a tile's samples.
    Sampling,
}

/// What the table says of one binding.
struct Spec {
    /// The WGSL variable.
    name: &'static str,
    /// Its WGSL type.
    wgsl_type: &'static str,
    /// Whether the kernel writes it.
    writable: bool,
    /// The size of one element on the host (the least a binding holds).
    element_bytes: usize,
}

const fn read<T>(name: &'static str, wgsl_type: &'static str) -> Spec {
    Spec { name, wgsl_type, writable: false, element_bytes: std::mem::size_of::<T>() }
}

const fn written<T>(name: &'static str, wgsl_type: &'static str) -> Spec {
    Spec { name, wgsl_type, writable: true, element_bytes: std::mem::size_of::<T>() }
}

impl Binding {
    /// Every binding, in `@binding` order.
    pub const ALL: [Binding; 18] = [
        Binding::Params,
        Binding::Spheres,
        Binding::Ellipsoids,
        Binding::Planes,
        Binding::Triangles,
        Binding::Materials,
        Binding::Lights,
        Binding::Pixels,
        Binding::Nodes,
        Binding::PrimRefs,
        Binding::EyeTriangles,
        Binding::BinRanges,
        Binding::BinItems,
        Binding::Textures,
        Binding::Permutation,
        Binding::Counters,
        Binding::Samples,
        Binding::Sampling,
    ];

    /// The table: each binding's variable, type, access and host element.
    const fn spec(self) -> Spec {
        use layout::*;
        match self {
            Binding::Params => read::<Params>("params", "Params"),
            Binding::Spheres => read::<GpuSphere>("spheres", "array<Sphere>"),
            Binding::Ellipsoids => read::<GpuEllipsoid>("ellipsoids", "array<Ellipsoid>"),
            Binding::Planes => read::<GpuPlane>("planes", "array<Plane>"),
            Binding::Triangles => read::<GpuTriangle>("triangles", "array<Triangle>"),
            Binding::Materials => read::<GpuMaterial>("materials", "array<Material>"),
            Binding::Lights => read::<GpuLight>("lights", "array<Light>"),
            Binding::Pixels => written::<u32>("pixels", "array<u32>"),
            Binding::Nodes => read::<crate::bvh::BvhNode>("nodes", "array<BvhNode>"),
            Binding::PrimRefs => read::<u32>("prim_refs", "array<u32>"),
            Binding::EyeTriangles => read::<EyeTriangle>("eye_triangles", "array<EyeTriangle>"),
            Binding::BinRanges => read::<[u32; 2]>("bin_ranges", "array<vec2<u32>>"),
            Binding::BinItems => read::<BinItem>("bin_items", "array<BinItem>"),
            Binding::Textures => read::<GpuTexture>("textures", "array<Texture>"),
            Binding::Permutation => read::<u32>("permutation", "array<u32>"),
            Binding::Counters => written::<u32>("counters", "array<atomic<u32>>"),
            Binding::Samples => written::<u32>("samples", "array<u32>"),
            Binding::Sampling => read::<GpuSampling>("sampling", "Sampling"),
        }
    }

    /// Its `@binding`.
    pub const fn index(self) -> u32 {
        self as u32
    }

    /// The name of its WGSL variable.
    pub const fn name(self) -> &'static str {
        self.spec().name
    }

    /// Whether the kernel writes it.
    pub const fn writable(self) -> bool {
        self.spec().writable
    }

    /// The bytes of one element as the host uploads it (a struct's size, or an array's
    /// element's): the least the binding holds.
    pub const fn element_bytes(self) -> u64 {
        self.spec().element_bytes as u64
    }

    /// Its WGSL declaration.
    pub fn declaration(self) -> String {
        let spec = self.spec();
        let access = if spec.writable { "read_write" } else { "read" };
        format!("@group(0) @binding({}) var<storage, {access}> {}: {};", self.index(), spec.name, spec.wgsl_type)
    }

    /// This binding's bit in a mask of bindings.
    const fn bit(self) -> u32 {
        1 << self.index()
    }
}

// A binding's place in `ALL` is its discriminant, which is its `@binding`.
const _: () = {
    let mut k = 0;
    while k < Binding::ALL.len() {
        assert!(Binding::ALL[k] as usize == k);
        k += 1;
    }
};

/// The kernel's binding declarations, for the composed source: generated here so that the
/// host's table and the shader cannot disagree on a name, a number or an access.
pub fn wgsl_declarations() -> String {
    let mut out =
        String::from("// Generated by gpu::bindings from its table (gpu::Binding, whose docs say what each holds).\n");
    for binding in Binding::ALL {
        let _ = writeln!(out, "{}", binding.declaration());
    }
    out
}

/// One value per binding, looked up by name.
pub(super) struct PerBinding<T>(pub [T; Binding::ALL.len()]);

impl<T> Index<Binding> for PerBinding<T> {
    type Output = T;

    fn index(&self, binding: Binding) -> &T {
        &self.0[binding as usize]
    }
}

/// A set of the kernel's bindings (bit k: `@binding(k)`) and its layouts.
#[derive(Clone)]
pub(super) struct BindingSet {
    pub mask: u32,
    pub group: wgpu::BindGroupLayout,
    pub pipeline: wgpu::PipelineLayout,
}

impl BindingSet {
    pub const ALL: u32 = (1 << Binding::ALL.len()) - 1;

    pub fn new(device: &wgpu::Device, mask: u32) -> BindingSet {
        let entries: Vec<_> = Binding::ALL.into_iter().filter(|b| mask & b.bit() != 0).map(entry).collect();
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

    pub fn contains(&self, binding: Binding) -> bool {
        self.mask & binding.bit() != 0
    }

    /// The bindings of the set, in `@binding` order.
    pub fn bindings(&self) -> impl Iterator<Item = Binding> + '_ {
        Binding::ALL.into_iter().filter(|&b| self.contains(b))
    }
}

/// The bindings `module` (a specialised kernel) still references.
pub(super) fn referenced(module: &naga::Module) -> u32 {
    module.global_variables.iter().filter_map(|(_, g)| g.binding.as_ref()).fold(0, |mask, b| mask | 1 << b.binding)
}

fn entry(binding: Binding) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding: binding.index(),
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: !binding.writable() },
            has_dynamic_offset: false,
            min_binding_size: std::num::NonZeroU64::new(binding.element_bytes()),
        },
        count: None,
    }
}
