//! The CPU reference renderer: f64, textbook, and independent of the GPU path's data
//! preparation. It walks the parsed scene tree for every ray, carrying the ray into each
//! Transform's object space as docs/SPEC.md §4 says, so what it computes can be checked
//! against the spec line by line. It is the ground truth of the tests; clarity comes before
//! speed (pixels run in parallel, what does not depend on the ray is computed once per
//! scene, and a mesh is skipped when the ray misses its bounding box).
//!
//! A pixel goes through the kernel's stages, under the kernel's names, so that the two can
//! be read side by side: `primary_ray` (docs/SPEC.md §3), `closest_hit` and `surface_at`
//! (§4, in [`ReferenceScene`]), `shade` and `write_pixel` (§5).

mod intersect;
mod prepared;

pub use intersect::{intersect_plane, intersect_sphere, intersect_triangle, sphere_normal, triangle_normal};
pub use prepared::{Hit, ReferenceScene, Surface};

use crate::camera::{PrimaryRays, Ray};
use crate::render::{Frame, Output, Pixel, RenderOptions};
use crate::scene::{Light, Material, Scene};
use glam::DVec3;
use rayon::prelude::*;

/// Renders `scene` with the f64 reference.
pub fn render(scene: &Scene, options: &RenderOptions) -> Frame {
    render_rows(scene, options, 0, options.height)
}

/// Renders image rows `first_row .. first_row + rows` (counted from the top) as a frame of
/// that many full-width rows.
pub fn render_rows(scene: &Scene, options: &RenderOptions, first_row: u32, rows: u32) -> Frame {
    Reference::new(scene, options).rows(first_row, rows)
}

/// The surface at the nearest hit of one world-space ray within its interval. Prepares the
/// scene for this one ray: to trace many, use a [`ReferenceScene`].
pub fn trace(scene: &Scene, ray: &Ray) -> Option<Surface> {
    let prepared = ReferenceScene::new(scene);
    prepared.closest_hit(ray).map(|hit| prepared.surface_at(&hit, ray))
}

/// The reference prepared for one scene and image size, able to render any set of pixels
/// on their own (the benchmark measures error on a subsample this way).
pub struct Reference<'a> {
    prepared: ReferenceScene<'a>,
    rays: PrimaryRays,
    options: RenderOptions,
}

impl<'a> Reference<'a> {
    pub fn new(scene: &'a Scene, options: &RenderOptions) -> Reference<'a> {
        let rays = PrimaryRays::for_camera(&scene.camera, options.width, options.height);
        Reference { prepared: ReferenceScene::new(scene), rays, options: *options }
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
                // Image rows run from the top; the camera's j runs from the bottom (§3).
                self.pixel(i, self.options.height - 1 - row)
            })
            .collect()
    }

    /// Pixel (i from the left, j from the bottom): the kernel's stages, in its order.
    fn pixel(&self, i: u32, j: u32) -> Pixel {
        let ray = self.primary_ray(i, j); // §3
        let hit = self.prepared.closest_hit(&ray); // §4
        let surface = hit.map(|hit| self.prepared.surface_at(&hit, &ray)); // §4
        let color = match (&surface, self.options.outputs.contains(Output::Color)) {
            (_, false) => DVec3::ZERO,
            (None, true) => self.prepared.scene.background.color, // §5: a miss
            (Some(surface), true) => self.shade(surface, &ray),   // §5
        };
        write_pixel(surface.as_ref(), color) // §5
    }

    /// docs/SPEC.md §3: the ray through the pixel's centre, with the camera's interval.
    fn primary_ray(&self, i: u32, j: u32) -> Ray {
        self.rays.ray(i, j)
    }

    /// docs/SPEC.md §5: ambient times diffuse, plus for each light in file order Lambert's
    /// cosine law and the Blinn–Torrance specular lobe; a back-facing hit is black unless
    /// `shade_back`, which shades it with the normal turned towards the viewer.
    fn shade(&self, surface: &Surface, ray: &Ray) -> DVec3 {
        let mut normal = surface.normal;
        if ray.direction.dot(normal) > 0.0 {
            if !self.options.shade_back {
                return DVec3::ZERO;
            }
            normal = -normal;
        }
        let scene = self.prepared.scene;
        let material = self.prepared.material(surface.material);
        let mut color = scene.background.ambient * material.diffuse;
        for light in &scene.lights {
            let (to_light, light_color) = match light {
                Light::Directional(light) => (-light.direction.normalize(), light.color),
                Light::Point(light) => {
                    let offset = light.position - surface.point;
                    let d = offset.length();
                    let [a0, a1, a2] = light.attenuation.to_array();
                    // The parser makes the coefficients ≥ 0 and not all 0: the divisor is
                    // positive for d > 0; at the light itself it is kept from reaching 0.
                    let divisor = (a0 + a1 * d + a2 * d * d).max(f64::MIN_POSITIVE);
                    (offset / d, light.color / divisor)
                }
            };
            color += local(material, normal, to_light, light_color, -ray.direction, self.options.specular_fix);
        }
        color
    }
}

/// docs/SPEC.md §5: what a surface with unit normal `normal` reflects towards `to_viewer`
/// (unit) of the light `light_color` arriving from `to_light` (unit): the diffuse term
/// `max(N·L, 0)·light·diffuse` plus the Blinn–Torrance term `max(N·H, 0)^exponent·light·specular` with
/// the half vector `H = normalise(L + V)`. The specular term is cut to zero where N·L ≤ 0
/// (the light is behind the surface), or with `specular_fix` multiplied by `max(N·L, 0)`,
/// the handout's optional fix for the sharp edge that cut leaves on wide lobes.
pub fn local(
    material: &Material,
    normal: DVec3,
    to_light: DVec3,
    light_color: DVec3,
    to_viewer: DVec3,
    specular_fix: bool,
) -> DVec3 {
    let cos_light = to_light.dot(normal);
    // Multiplied in this order since A2: directional, specular-free scenes stay bit for bit.
    let diffuse = cos_light.max(0.0) * light_color * material.diffuse;
    if material.specular == DVec3::ZERO || cos_light <= 0.0 {
        return diffuse;
    }
    // L + V is zero only when the viewer looks straight at the light from behind the
    // surface's tangent plane, which N·L > 0 leaves out but for a grazing view.
    let Some(half) = (to_light + to_viewer).try_normalize() else { return diffuse };
    let mut lobe = normal.dot(half).max(0.0).powf(material.exponent);
    if specular_fix {
        lobe *= cos_light;
    }
    diffuse + lobe * light_color * material.specular
}

/// docs/SPEC.md §5: what the three images need of a pixel, before quantisation: normal and
/// depth zero where nothing is hit; `color` as [`Reference::pixel`] computed it.
fn write_pixel(surface: Option<&Surface>, color: DVec3) -> Pixel {
    Pixel {
        hit: surface.is_some(),
        color: color.as_vec3().to_array(),
        normal: surface.map_or([0.0; 3], |surface| surface.normal.as_vec3().to_array()),
        depth: surface.map_or(0.0, |surface| surface.t as f32),
    }
}
