//! The scene flattened into GPU-ready buffers: the host twins of the structs in
//! `shaders/raycast.wgsl` (same size and field offsets, checked by a test against naga's
//! reflection), and the walk over the scene tree that fills them.
//!
//! Transforms are baked on the CPU wherever that is exact: triangles and planes go to world
//! space, spheres under a similarity become world spheres; only a sphere under a
//! non-uniform scale keeps a matrix (an [`Ellipsoid`]). Everything is moved so that the
//! camera sits at the origin, in f64, before it is rounded to f32.

use crate::bvh::{Aabb, Bvh, BvhNode};
use crate::camera::PrimaryRays;
use crate::render::{Frame, RenderOptions};
use crate::scene::{Object, Scene, Shape};
use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3, Vec3};
use std::time::Instant;

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
    pub _pad0: u32,
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

/// WGSL `Light`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub to_light: [f32; 3],
    pub _pad0: u32,
    pub color: [f32; 3],
    pub _pad1: u32,
}

/// What the kernel writes per pixel (WGSL `write_pixel`): a hit flag word, then three words
/// of colour, three of normal and one of depth, each only when that output is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PixelLayout {
    pub color: bool,
    pub normal: bool,
    pub depth: bool,
}

impl PixelLayout {
    pub fn new(options: &RenderOptions) -> PixelLayout {
        PixelLayout { color: options.color, normal: options.normals, depth: options.depth }
    }

    /// 32-bit words per pixel (the kernel's `PIXEL_WORDS`).
    pub fn words(&self) -> u32 {
        1 + 3 * self.color as u32 + 3 * self.normal as u32 + self.depth as u32
    }

    /// The frame of `rows` full rows that `words` (one tile, as read back) encode.
    pub fn decode(&self, options: &RenderOptions, rows: u32, words: &[u32]) -> Frame {
        let mut frame = Frame::new(&RenderOptions { height: rows, ..*options });
        let f = |w: &[u32]| [f32::from_bits(w[0]), f32::from_bits(w[1]), f32::from_bits(w[2])];
        for (k, pixel) in words.chunks_exact(self.words() as usize).enumerate() {
            frame.hit[k] = pixel[0] != 0;
            let mut w = 1;
            if self.color {
                frame.color[k] = f(&pixel[w..]);
                w += 3;
            }
            if self.normal {
                frame.normal[k] = f(&pixel[w..]);
                w += 3;
            }
            if self.depth {
                frame.depth[k] = f32::from_bits(pixel[w]);
            }
        }
        frame
    }
}

/// Everything the kernel reads, ready to upload.
#[derive(Clone, Debug, Default)]
pub struct SceneBuffers {
    /// `Params` without the per-image and per-tile fields (width, height, tile).
    pub params: Params,
    pub orthographic: bool,
    pub spheres: Vec<GpuSphere>,
    pub ellipsoids: Vec<GpuEllipsoid>,
    pub planes: Vec<GpuPlane>,
    pub triangles: Vec<GpuTriangle>,
    /// Diffuse colours, xyz used.
    pub materials: Vec<[f32; 4]>,
    pub lights: Vec<GpuLight>,
    /// The hierarchy over spheres, ellipsoids and triangles, when the scene has enough of
    /// them to profit ([`BVH_MIN_PRIMITIVES`]).
    pub bvh: Option<GpuBvh>,
    /// Bounds of each sphere and ellipsoid (f32, slightly padded), for the hierarchy.
    sphere_bounds: Vec<Aabb>,
    ellipsoid_bounds: Vec<Aabb>,
}

/// Below this many finite primitives the flat loops beat the hierarchy. Kernel ms at 200²
/// on lavapipe, hierarchy against flat (`raycaster bench --only scene2` with the threshold
/// at 1 and at ∞): 1 sphere 2.5 / 0.56, 6 primitives 2.8 / 1.2, 12 (the cube) 1.65 / 2.05,
/// 24: 2.4 / 3.6, 48: 2.8 / 6.6, bunny_1k 4.1 / 127.
pub const BVH_MIN_PRIMITIVES: usize = 8;

/// The hierarchy as the kernel reads it.
#[derive(Clone, Debug, Default)]
pub struct GpuBvh {
    pub nodes: Vec<BvhNode>,
    /// `kind << 30 | index` per leaf slot (kinds as in the kernel's `REF_*`); empty when the
    /// hierarchy holds triangles alone, which are then stored in leaf order instead.
    pub prim_refs: Vec<u32>,
    /// Leaf slot → primitive (the builder's order).
    pub order: Vec<u32>,
    pub build_ms: f64,
}

/// Primitive kinds in a `prim_refs` entry (the kernel's `REF_*` constants).
pub const REF_TRIANGLE: u32 = 0;
pub const REF_SPHERE: u32 = 1;
pub const REF_ELLIPSOID: u32 = 2;

impl SceneBuffers {
    /// Flattens `scene` for the image `rays` describes, with a hierarchy when it has at
    /// least `bvh_min_primitives` spheres, ellipsoids and triangles.
    pub fn new(scene: &Scene, rays: &PrimaryRays, bvh_min_primitives: usize) -> SceneBuffers {
        let mut buffers = SceneBuffers { orthographic: rays.orthographic, ..Default::default() };
        let to_camera = DMat4::from_translation(-rays.center);
        buffers.flatten(&scene.root, &to_camera);
        buffers.bvh = buffers.build_bvh(bvh_min_primitives);
        if let Some(bvh) = buffers.bvh.as_ref().filter(|b| b.prim_refs.is_empty()) {
            buffers.triangles = bvh.order.iter().map(|&p| buffers.triangles[p as usize]).collect();
        }
        buffers.materials = scene.materials.iter().map(|m| m.diffuse.as_vec3().extend(0.0).to_array()).collect();
        buffers.lights = scene
            .lights
            .iter()
            .map(|l| GpuLight {
                to_light: f32x3(-l.direction.normalize()),
                color: f32x3(l.color),
                ..Default::default()
            })
            .collect();
        buffers.params = Params {
            direction: f32x3(rays.direction),
            horizontal: f32x3(rays.horizontal),
            up: f32x3(rays.up),
            width: rays.width,
            height: rays.height,
            background: f32x3(scene.background.color),
            ambient: f32x3(scene.background.ambient),
            num_spheres: buffers.spheres.len() as u32,
            num_ellipsoids: buffers.ellipsoids.len() as u32,
            num_planes: buffers.planes.len() as u32,
            num_triangles: buffers.triangles.len() as u32,
            ..Default::default()
        };
        buffers
    }

    fn build_bvh(&self, min_primitives: usize) -> Option<GpuBvh> {
        let finite = self.triangles.len() + self.spheres.len() + self.ellipsoids.len();
        if finite < min_primitives.max(1) || finite > (1 << 30) {
            return None;
        }
        let start = Instant::now();
        let mut bounds = Vec::with_capacity(finite);
        let mut refs = Vec::with_capacity(finite);
        for (k, t) in self.triangles.iter().enumerate() {
            bounds.push(Aabb::of_points(&[Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2)]));
            refs.push(REF_TRIANGLE << 30 | k as u32);
        }
        for (k, b) in self.sphere_bounds.iter().enumerate() {
            bounds.push(*b);
            refs.push(REF_SPHERE << 30 | k as u32);
        }
        for (k, b) in self.ellipsoid_bounds.iter().enumerate() {
            bounds.push(*b);
            refs.push(REF_ELLIPSOID << 30 | k as u32);
        }
        let bvh = Bvh::build(&bounds);
        let prim_refs = if self.spheres.is_empty() && self.ellipsoids.is_empty() {
            // Triangles alone: the kernel reads them in leaf order directly (see `leaf_slot`).
            Vec::new()
        } else {
            bvh.order.iter().map(|&p| refs[p as usize]).collect()
        };
        Some(GpuBvh { nodes: bvh.nodes, prim_refs, order: bvh.order, build_ms: start.elapsed().as_secs_f64() * 1e3 })
    }

    /// Walks the tree with `matrix` mapping the current object space to camera-relative world
    /// space. The tree depth is bounded by the parser's nesting limit.
    fn flatten(&mut self, objects: &[Object], matrix: &DMat4) {
        for object in objects {
            match &object.shape {
                Shape::Group(children) => self.flatten(children, matrix),
                Shape::Transform { matrix: m, child } => self.flatten(std::slice::from_ref(child), &(*matrix * *m)),
                Shape::Sphere { center, radius, material } => self.push_sphere(matrix, *center, *radius, *material),
                Shape::Plane { normal, offset, material } => self.push_plane(matrix, *normal, *offset, *material),
                Shape::Triangle { vertices, material } => self.push_triangle(matrix, vertices, *material),
                Shape::Mesh { mesh, material } => {
                    self.triangles.reserve(mesh.triangles.len());
                    for k in 0..mesh.triangles.len() {
                        self.push_triangle(matrix, &mesh.triangle(k), *material);
                    }
                }
            }
        }
    }

    fn push_sphere(&mut self, matrix: &DMat4, center: DVec3, radius: f64, material: u32) {
        let linear = DMat3::from_mat4(*matrix);
        if let Some(scale) = similarity_scale(&linear) {
            let (world_center, world_radius) = (matrix.transform_point3(center), radius * scale);
            self.sphere_bounds.push(padded_box(world_center, DVec3::splat(world_radius)));
            self.spheres.push(GpuSphere {
                center: f32x3(world_center),
                radius: world_radius as f32,
                material,
                ..Default::default()
            });
            return;
        }
        // The unit sphere at the origin, carried to the world by matrix · T(c) · S(r);
        // the kernel needs the inverse of that.
        let to_world = *matrix * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
        let to_unit = to_world.inverse();
        // The image of the unit sphere under A reaches |row i of A's linear part| along axis i.
        let half = DVec3::from_array([0, 1, 2].map(|r| to_world.row(r).truncate().length()));
        self.ellipsoid_bounds.push(padded_box(to_world.w_axis.truncate(), half));
        let rows = [0, 1, 2].map(|r| to_unit.row(r).as_vec4().to_array());
        self.ellipsoids.push(GpuEllipsoid { rows, material, ..Default::default() });
    }

    /// The plane's world normal is `normalise(M⁻ᵀ·n̂)`; a point on it, `offset·n̂`, maps by M.
    fn push_plane(&mut self, matrix: &DMat4, normal: DVec3, offset: f64, material: u32) {
        let n = normal.normalize();
        let world_normal = DMat3::from_mat4(*matrix).inverse().transpose().mul_vec3(n).normalize();
        let world_point = matrix.transform_point3(offset * n);
        self.planes.push(GpuPlane {
            normal: f32x3(world_normal),
            offset: world_normal.dot(world_point) as f32,
            material,
            ..Default::default()
        });
    }

    /// A mirroring transform (det < 0) reverses the winding of mapped vertices, while the
    /// SPEC's normal `normalise(M⁻ᵀ·n)` does not flip; swapping two vertices keeps them equal.
    fn push_triangle(&mut self, matrix: &DMat4, vertices: &[DVec3; 3], material: u32) {
        let [a, mut b, mut c] = vertices.map(|v| f32x3(matrix.transform_point3(v)));
        if DMat3::from_mat4(*matrix).determinant() < 0.0 {
            std::mem::swap(&mut b, &mut c);
        }
        self.triangles.push(GpuTriangle { v0: a, material, v1: b, v2: c, ..Default::default() });
    }
}

/// The f32 box around `center ± half`, padded by a relative 1e-6 so that rounding to f32
/// can never leave part of the curved surface outside it.
fn padded_box(center: DVec3, half: DVec3) -> Aabb {
    let pad = half + DVec3::splat(1e-6 * (center.abs().max_element() + half.max_element()));
    Aabb { min: (center - pad).as_vec3(), max: (center + pad).as_vec3() }
}

/// `Some(s)` when `linear` is `s` times a rotation or reflection (columns orthogonal and of
/// equal length, to f64 rounding), so a sphere stays a sphere of radius `s·r`.
pub(crate) fn similarity_scale(linear: &DMat3) -> Option<f64> {
    let cols = [linear.x_axis, linear.y_axis, linear.z_axis];
    let lengths = cols.map(|c| c.length());
    let scale = lengths[0];
    let tolerance = 1e-12 * scale;
    let equal = lengths.iter().all(|l| (l - scale).abs() <= tolerance);
    let orthogonal = (cols[0].dot(cols[1]).abs() <= tolerance * scale)
        && (cols[0].dot(cols[2]).abs() <= tolerance * scale)
        && (cols[1].dot(cols[2]).abs() <= tolerance * scale);
    (equal && orthogonal && scale > 0.0).then_some(scale)
}

fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}
