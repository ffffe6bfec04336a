//! The host twins of the structs in `shaders/raycast.wgsl`: `#[repr(C)]`, `Pod`, padding
//! spelled out, with the same size and field offsets as naga reports for the WGSL side
//! (checked by `tests/layout.rs`), and the per-pixel word layout of the kernel's output.

use crate::render::{Frame, Output, Outputs, Pixel, RenderOptions};
use bytemuck::{Pod, Zeroable};
/// WGSL `Params`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Params {
    pub direction: [f32; 3],
    pub width: u32,
    pub horizontal: [f32; 3],
    pub height: u32,
    pub up: [f32; 3],
    pub first_row: u32,
    pub background: [f32; 3],
    pub tile_rows: u32,
    pub ambient: [f32; 3],
    /// Bins per image row, when the kernel walks screen-space bins.
    pub bin_columns: u32,
    pub num_spheres: u32,
    pub num_ellipsoids: u32,
    pub num_planes: u32,
    pub num_triangles: u32,
}

/// WGSL `Sphere`: a sphere in (camera-relative) world space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSphere {
    pub center: [f32; 3],
    pub radius: f32,
    pub material: u32,
    pub _pad: [u32; 3],
}

/// WGSL `Ellipsoid`: rows of the affine map from world space to the unit sphere's space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEllipsoid {
    pub rows: [[f32; 4]; 3],
    pub material: u32,
    pub _pad: [u32; 3],
}

/// WGSL `Plane`: `normal · p = offset`, normal of unit length.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPlane {
    pub normal: [f32; 3],
    pub offset: f32,
    pub material: u32,
    pub _pad: [u32; 3],
}

/// WGSL `Triangle`: world-space vertices, wound so that `(v1 − v0) × (v2 − v0)` is the normal.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub material: u32,
    pub v1: [f32; 3],
    pub _pad0: u32,
    pub v2: [f32; 3],
    pub _pad1: u32,
}

/// WGSL `EyeTriangle`: a triangle's three edge planes through the rays' common origin or
/// along their common direction (`n · q − w`, with q the ray's direction or origin), and its
/// own plane `normal · p = w` (see `gpu::binning`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EyeTriangle {
    pub edges: [[f32; 4]; 3],
    pub plane: [f32; 4],
}

/// WGSL `BinItem`: a primitive listed in a screen bin (`kind << 30 | index`), and a lower
/// bound of the distance at which a primary ray can meet it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BinItem {
    pub reference: u32,
    pub near: f32,
}

/// WGSL `Light`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub to_light: [f32; 3],
    pub _pad0: u32,
    pub color: [f32; 3],
    pub _pad1: u32,
}

/// What the kernel writes per pixel (WGSL `write_pixel`). As floats: a hit flag word, then
/// three words of colour, three of normal and one of depth, each only when that output is
/// asked for. Packed (`PACKED_8BIT`), for 8-bit images: one word per output asked for, the
/// colour and `|N|` quantised by the kernel (`r | g << 8 | b << 16`), the depth as the f32
/// bits of `t` (all ones where nothing was hit), which the host quantises in f64.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PixelLayout {
    pub outputs: Outputs,
    pub packed: bool,
}

impl PixelLayout {
    pub fn new(options: &RenderOptions, packed: bool) -> PixelLayout {
        PixelLayout { outputs: options.outputs, packed }
    }

    /// 32-bit words per pixel (the kernel's `PIXEL_WORDS`).
    pub fn words(&self) -> u32 {
        if self.packed {
            (self.outputs.len() as u32).max(1)
        } else {
            let wants = |output| self.outputs.contains(output) as u32;
            1 + 3 * wants(Output::Color) + 3 * wants(Output::Normals) + wants(Output::Depth)
        }
    }

    /// The frame of `rows` full rows that `words` (one tile, as read back) encode.
    pub fn decode(&self, options: &RenderOptions, rows: u32, words: &[u32]) -> Frame {
        let f = |w: &[u32]| [f32::from_bits(w[0]), f32::from_bits(w[1]), f32::from_bits(w[2])];
        let pixels = words.chunks_exact(self.words() as usize).map(|words| {
            let mut pixel = Pixel { hit: words[0] != 0, ..Pixel::default() };
            let mut w = 1;
            if self.outputs.contains(Output::Color) {
                pixel.color = f(&words[w..]);
                w += 3;
            }
            if self.outputs.contains(Output::Normals) {
                pixel.normal = f(&words[w..]);
                w += 3;
            }
            if self.outputs.contains(Output::Depth) {
                pixel.depth = f32::from_bits(words[w]);
            }
            pixel
        });
        Frame::from_pixels(&RenderOptions { height: rows, ..*options }, pixels)
    }
}

/// Primitive kinds in a `prim_refs` entry (the kernel's `REF_*` constants).
pub const REF_TRIANGLE: u32 = 0;
pub const REF_SPHERE: u32 = 1;
pub const REF_ELLIPSOID: u32 = 2;
