//! The CPU reference renderer: f64, textbook, and independent of the GPU path's data
//! preparation. It walks the parsed scene tree for every ray, carrying the ray into each
//! Transform's object space as docs/SPEC.md §4 says, so what it computes can be checked
//! against the spec line by line. It is the ground truth of the tests; clarity comes before
//! speed (pixels run in parallel, and a mesh is skipped when the ray misses its bounding box).

mod intersect;

pub use intersect::{intersect_plane, intersect_sphere, intersect_triangle, Hit};

use crate::camera::{PrimaryRays, Ray};
use crate::render::{Frame, Output, Pixel, RenderOptions};
use crate::scene::{Bounds, Material, Mesh, Object, Scene, Shape};
use glam::{DMat4, DVec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Renders `scene` with the f64 reference.
pub fn render(scene: &Scene, options: &RenderOptions) -> Frame {
    render_rows(scene, options, 0, options.height)
}

/// Renders image rows `first_row .. first_row + rows` (counted from the top) as a frame of
/// that many full-width rows.
pub fn render_rows(scene: &Scene, options: &RenderOptions, first_row: u32, rows: u32) -> Frame {
    Reference::new(scene, options).rows(first_row, rows)
}

/// The reference prepared for one scene and image size, able to render any set of pixels
/// on their own (the benchmark measures error on a subsample this way).
pub struct Reference<'a> {
    tracer: Tracer<'a>,
    rays: PrimaryRays,
    options: RenderOptions,
}

impl<'a> Reference<'a> {
    pub fn new(scene: &'a Scene, options: &RenderOptions) -> Reference<'a> {
        let rays = PrimaryRays::for_camera(&scene.camera, options.width, options.height);
        Reference { tracer: Tracer::new(scene), rays, options: *options }
    }

    /// Image rows `first_row .. first_row + rows` (from the top) as a frame of full rows.
    pub fn rows(&self, first_row: u32, rows: u32) -> Frame {
        let width = self.options.width;
        let pixels: Vec<(u32, u32)> =
            (first_row..first_row + rows).flat_map(|row| (0..width).map(move |i| (i, row))).collect();
        Frame::from_pixels(&RenderOptions { height: rows, ..self.options }, self.render_pixels(&pixels))
    }

    /// The listed pixels (column from the left, row from the top) as a one-row frame, in
    /// that order, rendered in parallel.
    pub fn pixels(&self, pixels: &[(u32, u32)]) -> Frame {
        let one_row = RenderOptions { width: pixels.len() as u32, height: 1, ..self.options };
        Frame::from_pixels(&one_row, self.render_pixels(pixels))
    }

    /// The listed pixels' results, in that order, rendered in parallel.
    fn render_pixels(&self, pixels: &[(u32, u32)]) -> Vec<Pixel> {
        pixels
            .par_iter()
            .map(|&(i, row)| {
                // Image rows run from the top; the camera's j runs from the bottom.
                let j = self.options.height - 1 - row;
                self.tracer.pixel(&self.rays.ray(i, j), self.rays.t_min(), &self.options)
            })
            .collect()
    }
}

/// The closest hit of one world-space ray with the whole scene, `t > t_min`.
pub fn trace(scene: &Scene, ray: &Ray, t_min: f64) -> Option<Hit> {
    Tracer::new(scene).closest_hit(ray, t_min)
}

/// The scene plus the few things worth computing once rather than per ray.
struct Tracer<'a> {
    scene: &'a Scene,
    /// Bounding boxes of meshes, keyed by the mesh's address (meshes are shared by `Arc`).
    mesh_bounds: HashMap<usize, Bounds>,
}

impl<'a> Tracer<'a> {
    fn new(scene: &'a Scene) -> Self {
        let mut mesh_bounds = HashMap::new();
        collect_mesh_bounds(&scene.root, &mut mesh_bounds);
        Tracer { scene, mesh_bounds }
    }

    /// The pixel whose primary ray is `ray`: normal and depth zero where nothing is hit,
    /// colour zero unless `options` asks for it.
    fn pixel(&self, ray: &Ray, t_min: f64, options: &RenderOptions) -> Pixel {
        let hit = self.closest_hit(ray, t_min);
        let color = match (&hit, options.outputs.contains(Output::Color)) {
            (_, false) => DVec3::ZERO,
            (None, true) => self.scene.background.color,
            (Some(hit), true) => self.shade(hit, ray, options.shade_back),
        };
        Pixel {
            hit: hit.is_some(),
            color: color.as_vec3().to_array(),
            normal: hit.map_or([0.0; 3], |hit| hit.normal.as_vec3().to_array()),
            depth: hit.map_or(0.0, |hit| hit.t as f32),
        }
    }

    fn closest_hit(&self, ray: &Ray, t_min: f64) -> Option<Hit> {
        let mut closest = None;
        for object in &self.scene.root {
            self.intersect_object(object, ray, t_min, &mut closest);
        }
        closest
    }

    /// docs/SPEC.md §5: diffuse with ambient; a back-facing hit is black unless `shade_back`.
    fn shade(&self, hit: &Hit, ray: &Ray, shade_back: bool) -> DVec3 {
        let mut normal = hit.normal;
        if ray.direction.dot(normal) > 0.0 {
            if !shade_back {
                return DVec3::ZERO;
            }
            normal = -normal;
        }
        let diffuse = self.material(hit.material).diffuse;
        let mut color = self.scene.background.ambient * diffuse;
        for light in &self.scene.lights {
            let to_light = -light.direction.normalize();
            color += to_light.dot(normal).max(0.0) * light.color * diffuse;
        }
        color
    }

    fn material(&self, index: u32) -> Material {
        self.scene.materials[index as usize]
    }

    /// Updates `closest` if `object` has a hit nearer than it (and beyond `t_min`).
    fn intersect_object(&self, object: &Object, ray: &Ray, t_min: f64, closest: &mut Option<Hit>) {
        let t_max = closest.map_or(f64::INFINITY, |h| h.t);
        let candidate = match &object.shape {
            Shape::Group(children) => {
                for child in children {
                    self.intersect_object(child, ray, t_min, closest);
                }
                return;
            }
            Shape::Transform { matrix, child } => {
                self.intersect_transformed(matrix, child, ray, t_min, closest);
                return;
            }
            Shape::Sphere { center, radius, material } => {
                intersect_sphere(*center, *radius, ray, t_min, t_max).map(|(t, n)| (t, n, *material))
            }
            Shape::Plane { normal, offset, material } => {
                intersect_plane(*normal, *offset, ray, t_min, t_max).map(|(t, n)| (t, n, *material))
            }
            Shape::Triangle { vertices, material } => {
                intersect_triangle(vertices, ray, t_min, t_max).map(|(t, n)| (t, n, *material))
            }
            Shape::Mesh { mesh, material } => {
                self.intersect_mesh(mesh, ray, t_min, t_max).map(|(t, n)| (t, n, *material))
            }
        };
        if let Some((t, normal, material)) = candidate {
            *closest = Some(Hit { t, normal, material });
        }
    }

    /// docs/SPEC.md §4: intersect the child with `(M⁻¹·o, M⁻¹·d)`, the direction not
    /// renormalised so that the child's t is the world t; the normal comes back as
    /// `normalise((M⁻¹)ᵀ·n)`.
    fn intersect_transformed(&self, matrix: &DMat4, child: &Object, ray: &Ray, t_min: f64, closest: &mut Option<Hit>) {
        let inverse = matrix.inverse();
        let local =
            Ray { origin: inverse.transform_point3(ray.origin), direction: inverse.transform_vector3(ray.direction) };
        let before = *closest;
        self.intersect_object(child, &local, t_min, closest);
        if let Some(hit) = closest.as_mut() {
            if Some(*hit) != before {
                hit.normal = inverse.transpose().transform_vector3(hit.normal).normalize();
            }
        }
    }

    fn intersect_mesh(&self, mesh: &Mesh, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        if !ray_meets_box(ray, &self.mesh_bounds[&mesh_key(mesh)], t_min, t_max) {
            return None;
        }
        let mut best: Option<(f64, DVec3)> = None;
        for k in 0..mesh.triangles.len() {
            let t_max = best.map_or(t_max, |(t, _)| t);
            if let Some(hit) = intersect_triangle(&mesh.triangle(k), ray, t_min, t_max) {
                best = Some(hit);
            }
        }
        best
    }
}

/// A mesh's identity for the bounds map: its address (only compared, never dereferenced).
fn mesh_key(mesh: &Mesh) -> usize {
    mesh as *const Mesh as usize
}

/// Each mesh's own box ([`Mesh::bounds`], in the mesh's coordinates), once per mesh.
fn collect_mesh_bounds(objects: &[Object], bounds: &mut HashMap<usize, Bounds>) {
    for object in objects {
        match &object.shape {
            Shape::Group(children) => collect_mesh_bounds(children, bounds),
            Shape::Transform { child, .. } => collect_mesh_bounds(std::slice::from_ref(child), bounds),
            Shape::Mesh { mesh, .. } => {
                bounds.entry(mesh_key(mesh)).or_insert_with(|| mesh.bounds());
            }
            _ => {}
        }
    }
}

/// Slab test, conservative: the box is widened by a margin of 1e-9 times its largest extent
/// (at least 1e-9) so that rounding can never make the reference skip a mesh that a
/// triangle test would hit.
fn ray_meets_box(ray: &Ray, bounds: &Bounds, t_min: f64, t_max: f64) -> bool {
    let (lo, hi) = (bounds.min, bounds.max);
    let margin = (hi - lo).max_element().max(1.0) * 1e-9;
    let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
    let (mut near, mut far) = (t_min, t_max);
    for axis in 0..3 {
        let (o, d) = (ray.origin[axis], ray.direction[axis]);
        if d == 0.0 {
            if o < lo[axis] || o > hi[axis] {
                return false;
            }
            continue;
        }
        let (t0, t1) = ((lo[axis] - o) / d, (hi[axis] - o) / d);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    near <= far
}
