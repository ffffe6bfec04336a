//! Which of the kernel's bindings a prepared scene binds. The kernel declares eighteen
//! storage buffers ([`BINDINGS`]). Native adapters offer far more per shader stage, and
//! there every pipeline shares one layout of all of them. WebGPU in a browser offers 8 to
//! 10 (Chromium, SwiftShader included: 10), so on such an adapter a scene's layout holds
//! only the bindings its kernels still reference once [`super::specialise`] has cut what
//! the scene does not use (a sphere scene binds no triangles, no hierarchy, no bins).

use super::{Binding, BINDINGS};

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
