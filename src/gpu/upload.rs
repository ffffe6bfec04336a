//! Uploading a scene's buffers: the kernel's read-only inputs, checked finite and within the
//! adapter's limits, written in place where the host maps them, and written again into the
//! same buffers for a moved camera (`gpu::aim`).

use super::bindings::{Binding, PerBinding};
use super::error::GpuError;
use super::finite;
use super::flatten::SceneBuffers;
use super::layout::{BinItem, PERLIN_PERMUTATION};
use super::renderer::GpuRenderer;
use wgpu::util::DeviceExt;

/// The scene's buffers: one per input binding, `None` for those each tile slot owns
/// ([`contents`]).
pub(super) type Inputs = PerBinding<Option<wgpu::Buffer>>;

/// The scene's read-only buffers, uploaded.
pub(super) fn upload_inputs(gpu: &GpuRenderer, buffers: &SceneBuffers) -> Result<Inputs, GpuError> {
    // Written in place where the host maps the kernel's buffers: else through a staging
    // buffer, which the device copies before the first tile. Either way a moved camera may
    // write them again (`rewrite_inputs`).
    let usage = match gpu.maps_kernel_buffers() {
        true => wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_WRITE,
        false => wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    };
    let mut out = PerBinding(Default::default());
    for (binding, bytes) in checked_contents(gpu, buffers)? {
        out.0[binding as usize] = Some(gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(binding.name()),
            contents: bytes,
            usage,
        }));
    }
    Ok(out)
}

/// Writes `buffers` into the scene's buffers `inputs`, uploaded before for the same
/// bindings, where each fits in its buffer; else writes nothing and returns false, for the
/// caller to upload them afresh. (The kernel reads only as many elements as `Params`
/// counts, so a buffer larger than its contents is fine.)
pub(super) fn rewrite_inputs(gpu: &GpuRenderer, inputs: &Inputs, buffers: &SceneBuffers) -> Result<bool, GpuError> {
    let contents = checked_contents(gpu, buffers)?;
    let fits =
        |&(binding, bytes): &(Binding, &[u8])| inputs[binding].as_ref().is_some_and(|b| bytes.len() as u64 <= b.size());
    let uploaded = inputs.0.iter().filter(|b| b.is_some()).count();
    if contents.len() != uploaded || !contents.iter().all(fits) {
        return Ok(false);
    }
    for (binding, bytes) in contents {
        let buffer = inputs[binding].as_ref().expect("checked above");
        gpu.queue.write_buffer(buffer, 0, bytes);
    }
    Ok(true)
}

/// Each input binding's bytes ([`contents`]), checked finite and within the adapter's
/// storage binding limit.
fn checked_contents<'b>(gpu: &GpuRenderer, buffers: &'b SceneBuffers) -> Result<Vec<(Binding, &'b [u8])>, GpuError> {
    let limit = gpu.limits.max_storage_buffer_binding_size;
    let mut out = Vec::new();
    for binding in Binding::ALL {
        let Some(bytes) = contents(buffers, binding) else { continue };
        let name = binding.name();
        if let Some((element, at, value)) = finite::first_non_finite(binding, bytes) {
            return Err(GpuError::NonFinite(format!(
                "{name}[{element}] holds {value} at byte {at}: the kernel takes finite values only"
            )));
        }
        if bytes.len() as u64 > limit {
            return Err(GpuError::TooLarge(format!(
                "{name}: {} bytes exceed the adapter's storage binding limit of {limit} bytes",
                bytes.len()
            )));
        }
        out.push((binding, bytes));
    }
    Ok(out)
}

/// The bytes the scene uploads to `binding`, or `None` where a tile slot binds a buffer of
/// its own ([`super::tiles::TileSlot`]): the parameters, the output, the samples and the
/// counters, and where the frame has bins their lists, filled tile by tile.
fn contents(buffers: &SceneBuffers, binding: Binding) -> Option<&[u8]> {
    let bvh = buffers.bvh.as_ref();
    let bins = buffers.bins.as_ref();
    let grid = buffers.grid.as_ref();
    // A grid has no hierarchy nor bins, and takes two of their bindings for its cells: its
    // references in `prim_refs`, each cell's (first, count) in `bin_ranges`.
    let refs = grid.map_or(bvh.map_or(&[][..], |b| &b.prim_refs), |g| &g.refs);
    let ranges = grid.map_or(&[][..], |g| &g.ranges);
    match binding {
        Binding::Spheres => Some(non_empty(&buffers.spheres)),
        Binding::Ellipsoids => Some(non_empty(&buffers.ellipsoids)),
        Binding::Planes => Some(non_empty(&buffers.planes)),
        Binding::Triangles => Some(non_empty(&buffers.triangles)),
        Binding::Materials => Some(non_empty(&buffers.materials)),
        Binding::Lights => Some(non_empty(&buffers.lights)),
        Binding::Nodes => Some(non_empty(bvh.map_or(&[][..], |b| &b.nodes))),
        Binding::PrimRefs => Some(non_empty(refs)),
        Binding::EyeTriangles => Some(non_empty(bins.map_or(&[][..], |b| &b.eye_triangles))),
        Binding::BinRanges => bins.is_none().then(|| non_empty(ranges)),
        Binding::BinItems => bins.is_none().then(|| non_empty::<BinItem>(&[])),
        Binding::Textures => Some(non_empty(&buffers.textures)),
        Binding::Permutation => {
            Some(non_empty(if buffers.textures.is_empty() { &[][..] } else { &PERLIN_PERMUTATION[..] }))
        }
        Binding::Params | Binding::Pixels | Binding::Counters | Binding::Samples | Binding::Sampling => None,
    }
}

/// A zero-sized buffer cannot be bound, so an empty list is uploaded as one zeroed element
/// (the kernel reads only as many as `Params` counts).
fn non_empty<T: bytemuck::Pod>(items: &[T]) -> &[u8] {
    const ZEROS: [u8; 128] = [0; 128];
    if items.is_empty() {
        &ZEROS[..std::mem::size_of::<T>()]
    } else {
        bytemuck::cast_slice(items)
    }
}
