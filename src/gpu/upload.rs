//! Uploading a scene's buffers: the kernel's read-only inputs, checked finite and within the
//! adapter's limits, written in place where the host maps them.

use super::bindings::BINDINGS;
use super::error::GpuError;
use super::finite;
use super::flatten::SceneBuffers;
use super::layout::{BinItem, PERLIN_PERMUTATION};
use super::renderer::GpuRenderer;
use wgpu::util::DeviceExt;

/// The scene's read-only buffers, at their `@binding` (params and the output are per slot).
pub(super) fn upload_inputs(
    gpu: &GpuRenderer,
    buffers: &SceneBuffers,
) -> Result<[Option<wgpu::Buffer>; BINDINGS.len()], GpuError> {
    let limit = gpu.limits.max_storage_buffer_binding_size;
    // Written in place where the host maps the kernel's buffers: else through a staging
    // buffer, which the device copies before the first tile.
    let maps = gpu.maps_kernel_buffers();
    let bvh = buffers.bvh.as_ref();
    let bins = buffers.bins.as_ref();
    let grid = buffers.grid.as_ref();
    // A grid has no hierarchy nor bins, and takes their bindings for its cells. The bins'
    // lists are each slot's, filled tile by tile.
    let refs = grid.map_or(bvh.map_or(&[][..], |b| &b.prim_refs), |g| &g.refs);
    let ranges = grid.map_or(&[][..], |g| &g.ranges);
    let contents: [Option<&[u8]>; BINDINGS.len()] = [
        None,
        Some(non_empty(&buffers.spheres)),
        Some(non_empty(&buffers.ellipsoids)),
        Some(non_empty(&buffers.planes)),
        Some(non_empty(&buffers.triangles)),
        Some(non_empty(&buffers.materials)),
        Some(non_empty(&buffers.lights)),
        None,
        Some(non_empty(bvh.map_or(&[][..], |b| &b.nodes))),
        Some(non_empty(refs)),
        Some(non_empty(bins.map_or(&[][..], |b| &b.eye_triangles))),
        bins.is_none().then(|| non_empty(ranges)),
        bins.is_none().then(|| non_empty::<BinItem>(&[])),
        Some(non_empty(&buffers.textures)),
        Some(non_empty(if buffers.textures.is_empty() { &[][..] } else { &PERLIN_PERMUTATION[..] })),
        None,
        None,
        None,
    ];
    let mut out: [Option<wgpu::Buffer>; BINDINGS.len()] = Default::default();
    for (k, bytes) in contents.iter().enumerate() {
        let Some(bytes) = bytes else { continue };
        let name = BINDINGS[k].name;
        if let Some((element, at, value)) = finite::first_non_finite(k as u32, bytes) {
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
        out[k] = Some(gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(name),
            contents: bytes,
            usage: if maps {
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::MAP_WRITE
            } else {
                wgpu::BufferUsages::STORAGE
            },
        }));
    }
    Ok(out)
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
