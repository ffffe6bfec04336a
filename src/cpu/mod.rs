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
pub mod texture;

pub use intersect::{intersect_plane, intersect_sphere, intersect_triangle, sphere_normal, triangle_normal};
pub use prepared::{Hit, ReferenceScene, SceneGrid, Surface};
// `refract` and `spawn_origin` are defined below and public for the tests.

use crate::camera::{PrimaryRays, Ray};
use crate::render::{Frame, Output, Pixel, RayStats, RenderOptions};
use crate::sampling::{Sampler, Sampling};
use crate::scene::{Light, Material, Scene};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::Mutex;

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
    /// What the renders so far counted (rays, tests, cells), summed once per pixel.
    stats: Mutex<RayStats>,
}

impl<'a> Reference<'a> {
    pub fn new(scene: &'a Scene, options: &RenderOptions) -> Reference<'a> {
        let rays = PrimaryRays::for_camera(&scene.camera, options.width, options.height);
        let prepared = match options.grid {
            Some(size) => ReferenceScene::with_grid(scene, size),
            None => ReferenceScene::new(scene),
        };
        Reference { prepared, rays, options: *options, stats: Mutex::new(RayStats::default()) }
    }

    /// How many rays the renders so far traced: one per pixel, plus every reflected,
    /// refracted and shadow ray (`bench` counts rays per second by it).
    pub fn rays_traced(&self) -> u64 {
        let stats = self.stats();
        stats.non_shadow_rays + stats.shadow_rays
    }

    /// What the renders so far counted: the course's statistics (`-stats`).
    pub fn stats(&self) -> RayStats {
        *self.stats.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The grid's cells, when the render has a grid.
    pub fn grid(&self) -> Option<&SceneGrid> {
        self.prepared.grid()
    }

    /// Image rows `first_row .. first_row + rows` (from the top) as a frame of full rows.
    /// With sampling, each pixel filters the samples of the pixels within the filter's
    /// support (docs/SPEC.md §8), rows outside the band included: a band is the same
    /// whichever tiles or bands the image is cut into.
    pub fn rows(&self, first_row: u32, rows: u32) -> Frame {
        if let Some(sampling) = self.options.sampling {
            return self.filtered_rows(&sampling, first_row, rows);
        }
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

    /// The listed pixels' results, in that order, rendered in parallel. With sampling, each
    /// pixel filters its own and its neighbours' samples (traced for it alone).
    fn render_pixels(&self, pixels: &[(u32, u32)]) -> Vec<Pixel> {
        if let Some(sampling) = self.options.sampling {
            // Every pixel whose samples a listed pixel's filter reads, traced once.
            let (r, width, height) = (sampling.radius(), self.options.width, self.options.height);
            let mut needed: Vec<(u32, u32)> = pixels
                .iter()
                .flat_map(|&(i, row)| {
                    let rows = row.saturating_sub(r)..(row + 1).saturating_add(r).min(height);
                    rows.flat_map(move |row2| {
                        (i.saturating_sub(r)..(i + 1).saturating_add(r).min(width)).map(move |i2| (i2, row2))
                    })
                })
                .collect();
            needed.sort_unstable();
            needed.dedup();
            let traced: Vec<Vec<((f64, f64), Pixel)>> = needed
                .par_iter()
                .map(|&(i2, row2)| self.samples(&sampling, i2, height - 1 - row2, &mut RayStats::default()))
                .collect();
            let at = |i2: u32, row2: u32| {
                let k = needed.binary_search(&(i2, row2)).expect("every neighbour was traced");
                &traced[k][..]
            };
            return pixels.par_iter().map(|&(i, row)| self.filtered_pixel(&sampling, i, row, at)).collect();
        }
        pixels
            .par_iter()
            .map(|&(i, row)| {
                let mut stats = RayStats::default();
                // Image rows run from the top; the camera's j runs from the bottom (§3).
                let pixel = self.pixel(i, self.options.height - 1 - row, &mut stats);
                self.stats.lock().unwrap_or_else(|e| e.into_inner()).add(&stats);
                pixel
            })
            .collect()
    }

    /// The samples of pixel (i from the left, j from the bottom), in their order
    /// (docs/SPEC.md §8), each with its pixel-local position.
    pub fn samples(&self, sampling: &Sampling, i: u32, j: u32, stats: &mut RayStats) -> Vec<((f64, f64), Pixel)> {
        (0..sampling.count())
            .map(|k| {
                let position = sampling.position(i, j, k);
                let ray = match sampling.sampler {
                    Sampler::Uniform(_) => self.rays.grid_ray(i, j, k, sampling.sampler.side()),
                    _ => self.rays.ray_at(i, j, position),
                };
                (position, self.pixel_at(ray, stats))
            })
            .collect()
    }

    /// docs/SPEC.md §8: rows `first_row .. first_row + rows` (from the top), each pixel the
    /// filtered samples of the pixels within the support radius, cropped at the image's
    /// border. Statistics count the samples of the band's own pixels only.
    fn filtered_rows(&self, sampling: &Sampling, first_row: u32, rows: u32) -> Frame {
        let (width, height) = (self.options.width, self.options.height);
        let radius = sampling.radius();
        let top = first_row.saturating_sub(radius);
        let bottom = (first_row + rows).saturating_add(radius).min(height);
        let band = first_row..first_row + rows;
        let pixels: Vec<(u32, u32)> = (top..bottom).flat_map(|row| (0..width).map(move |i| (i, row))).collect();
        let samples: Vec<Vec<((f64, f64), Pixel)>> = pixels
            .par_iter()
            .map(|&(i, row)| {
                let mut stats = RayStats::default();
                let samples = self.samples(sampling, i, height - 1 - row, &mut stats);
                if band.contains(&row) {
                    self.stats.lock().unwrap_or_else(|e| e.into_inner()).add(&stats);
                }
                samples
            })
            .collect();
        let at = |i: u32, row: u32| &samples[(row - top) as usize * width as usize + i as usize];
        let out: Vec<(u32, u32)> = band.clone().flat_map(|row| (0..width).map(move |i| (i, row))).collect();
        let filtered: Vec<Pixel> = out
            .par_iter()
            .map(|&(i, row)| self.filtered_pixel(sampling, i, row, |i2, row2| &at(i2, row2)[..]))
            .collect();
        Frame::from_pixels(&RenderOptions { height: rows, ..self.options }, filtered)
    }

    /// docs/SPEC.md §8: pixel (i, row from the top) from the samples `at(i2, row2)` of the
    /// pixels within the support radius, cropped at the image's border.
    fn filtered_pixel<'s>(
        &self,
        sampling: &Sampling,
        i: u32,
        row: u32,
        at: impl Fn(u32, u32) -> &'s [((f64, f64), Pixel)],
    ) -> Pixel {
        let (width, height) = (self.options.width as i64, self.options.height as i64);
        let r = sampling.radius() as i64;
        let mut sum = FilterSum::default();
        for dr in -r..=r {
            let row2 = row as i64 + dr;
            if row2 < 0 || row2 >= height {
                continue;
            }
            for di in -r..=r {
                let i2 = i as i64 + di;
                if i2 < 0 || i2 >= width {
                    continue;
                }
                // Rows run down the image; the sample's y runs up.
                for &((sx, sy), sample) in at(i2 as u32, row2 as u32) {
                    let (dx, dy) = (di as f64 + sx - 0.5, -dr as f64 + sy - 0.5);
                    sum.add(sampling.filter.weight(dx, dy), &sample);
                }
            }
        }
        if sum.weight == 0.0 {
            // No sample weighs (a filter narrower than the gaps between samples): the plain
            // average of the pixel's own.
            sum = FilterSum::default();
            at(i, row).iter().for_each(|(_, sample)| sum.add(1.0, sample));
        }
        sum.pixel()
    }

    /// Pixel (i from the left, j from the bottom): the kernel's stages, in its order.
    fn pixel(&self, i: u32, j: u32, stats: &mut RayStats) -> Pixel {
        self.pixel_at(self.primary_ray(i, j), stats)
    }

    /// What the primary ray `ray` sees: the kernel's stages, in its order.
    fn pixel_at(&self, ray: Ray, stats: &mut RayStats) -> Pixel {
        stats.non_shadow_rays += 1;
        if let Some(grid) = self.prepared.grid().filter(|_| self.options.visualize_grid) {
            return self.voxel_pixel(grid, &ray, stats); // §7
        }
        let hit = self.prepared.closest_hit_counted(&ray, stats); // §4
        let surface = hit.map(|hit| self.prepared.surface_at(&hit, &ray)); // §4
        let color = match (&surface, self.options.outputs.contains(Output::Color)) {
            (_, false) => DVec3::ZERO,
            (None, true) => self.prepared.scene.background.color, // §5: a miss
            (Some(surface), true) => self.shade(surface, &ray, Path::PRIMARY, stats), // §5
        };
        write_pixel(surface.as_ref(), color) // §5
    }

    /// docs/SPEC.md §7, `-visualize_grid`: the first cell the 3D-DDA finds occupied, seen as
    /// an opaque box: its depth where the ray enters it, the normal of the face it enters
    /// through, and [`voxel_color`] shaded by the scene's lights (ambient and diffuse, no
    /// shadow).
    fn voxel_pixel(&self, grid: &SceneGrid, ray: &Ray, stats: &mut RayStats) -> Pixel {
        let scene = self.prepared.scene;
        for visit in grid.grid.march(ray.origin, ray.direction, ray.t_min, ray.t_max) {
            stats.cells_traversed += 1;
            let count = grid.grid.items(visit.cell).len();
            if count == 0 {
                continue;
            }
            // A ray that starts inside an occupied cell sees the face behind its start.
            let normal = visit.entered_through.unwrap_or_else(|| facing_face(ray.direction));
            let point = ray.at(visit.t_enter);
            let material = Material::diffuse(voxel_color(count));
            let mut color = scene.background.ambient * material.diffuse;
            for light in &scene.lights {
                let (to_light, light_color) = light_from(light, point);
                color += local(&material, normal, to_light, light_color, -ray.direction, false);
            }
            let surface = Surface { t: visit.t_enter, point, normal, object_point: point, material: 0 };
            return write_pixel(Some(&surface), color);
        }
        write_pixel(None, scene.background.color)
    }

    /// docs/SPEC.md §3: the ray through the pixel's centre, with the camera's interval.
    fn primary_ray(&self, i: u32, j: u32) -> Ray {
        self.rays.ray(i, j)
    }

    /// The colour seen along a secondary ray: what it hits, shaded, or the background.
    fn trace(&self, ray: &Ray, path: Path, stats: &mut RayStats) -> DVec3 {
        stats.non_shadow_rays += 1;
        match self.prepared.closest_hit_counted(ray, stats) {
            None => self.prepared.scene.background.color,
            Some(hit) => self.shade(&self.prepared.surface_at(&hit, ray), ray, path, stats),
        }
    }

    /// docs/SPEC.md §5: a back-facing hit is black unless `shade_back`, which shades it
    /// with the normal turned towards the viewer; otherwise the hit's material, shaded.
    fn shade(&self, surface: &Surface, ray: &Ray, path: Path, stats: &mut RayStats) -> DVec3 {
        let facing = ray.direction.dot(surface.normal);
        let mut normal = surface.normal;
        if facing > 0.0 {
            if !self.options.shading.shade_back {
                return DVec3::ZERO;
            }
            normal = -normal;
        }
        let hit = Shaded { surface, normal, entering: facing < 0.0 };
        self.shade_material(surface.material, &hit, ray, path, stats)
    }

    /// docs/SPEC.md §5: material `index` at the hit. A solid texture blends its two
    /// materials' shaded colours (each with its own ambient, lights, reflection and
    /// refraction, as the handout's update of 11/2 says) by its weight at the hit's world
    /// point carried into texture space; a material with no weight there is not shaded.
    fn shade_material(&self, index: u32, hit: &Shaded, ray: &Ray, path: Path, stats: &mut RayStats) -> DVec3 {
        let Some(texture) = self.prepared.scene.texture(index) else {
            return self.shade_phong(self.prepared.material(index), hit, ray, path, stats);
        };
        let weight = texture::first_material_weight(texture, texture.to_texture.transform_point3(hit.surface.point));
        let [first, second] = texture.materials;
        let mut color = DVec3::ZERO;
        if weight > 0.0 {
            color += weight * self.shade_material(first, hit, ray, path, stats);
        }
        if weight < 1.0 {
            color += (1.0 - weight) * self.shade_material(second, hit, ray, path, stats);
        }
        color
    }

    /// docs/SPEC.md §5: ambient times diffuse, plus for each light in file order (that no
    /// shadow ray finds blocked, with `-shadows`) Lambert's cosine law and the
    /// Blinn–Torrance specular lobe, plus the reflected and refracted rays' colours while
    /// `path` may go deeper.
    fn shade_phong(&self, material: &Material, hit: &Shaded, ray: &Ray, path: Path, stats: &mut RayStats) -> DVec3 {
        let Shaded { surface, normal, entering } = *hit;
        let scene = self.prepared.scene;
        let mut color = scene.background.ambient * material.diffuse;
        for light in &scene.lights {
            let (to_light, light_color) = light_from(light, surface.point);
            // A light behind the surface adds nothing (§5), so it needs no shadow ray.
            if self.options.shading.shadows && to_light.dot(normal) > 0.0 {
                let origin = spawn_origin(surface.point, normal, to_light);
                let mut shadow = Ray::new(origin, to_light, 0.0);
                if let Light::Point(light) = light {
                    shadow.t_max = (light.position - origin).length();
                }
                stats.shadow_rays += 1;
                if self.prepared.occluded_counted(&shadow, stats) {
                    continue;
                }
            }
            color += local(material, normal, to_light, light_color, -ray.direction, self.options.shading.specular_fix);
        }
        if path.bounces >= self.options.shading.bounces {
            return color;
        }
        let mut spawn = |direction: DVec3, side: DVec3, weight: DVec3, index: f64| -> DVec3 {
            let path = Path { bounces: path.bounces + 1, weight: path.weight * weight.length(), index };
            if weight == DVec3::ZERO || path.weight < self.options.shading.weight {
                return DVec3::ZERO;
            }
            let origin = spawn_origin(surface.point, side, direction);
            weight * self.trace(&Ray::new(origin, direction, 0.0), path, stats)
        };
        // Mirror reflection, on the viewer's side of the surface.
        let d = ray.direction;
        color += spawn(d - 2.0 * d.dot(normal) * normal, normal, material.reflective, path.index);
        // Refraction (GRAMMAR.md A4): objects sit in vacuum, so a ray entering a surface goes
        // from index 1 into the material's, and one leaving it back to 1.
        let into = if entering { material.index_of_refraction } else { 1.0 };
        if let Some(refracted) = refract(d, normal, path.index, into) {
            color += spawn(refracted, -normal, material.transparent, into);
        }
        color
    }
}

/// The unit direction towards `light` from `point` and the light's colour arriving there
/// (docs/SPEC.md §5: a point light attenuated by `a0 + a1·d + a2·d²`).
fn light_from(light: &Light, point: DVec3) -> (DVec3, DVec3) {
    match light {
        Light::Directional(light) => (-light.direction.normalize(), light.color),
        Light::Point(light) => {
            let offset = light.position - point;
            let d = offset.length();
            let [a0, a1, a2] = light.attenuation.to_array();
            // The parser makes the coefficients ≥ 0 and not all 0: the divisor is
            // positive for d > 0; at the light itself it is kept from reaching 0.
            let divisor = (a0 + a1 * d + a2 * d * d).max(f64::MIN_POSITIVE);
            (offset / d, light.color / divisor)
        }
    }
}

/// The outward normal of the cell face a ray moving along `direction` looks at head-on:
/// against the direction's largest component.
fn facing_face(direction: DVec3) -> DVec3 {
    let axis = direction.abs().max_position();
    let mut n = DVec3::ZERO;
    n[axis] = -direction[axis].signum();
    n
}

/// docs/SPEC.md §7: the colour of a cell holding `count` items, by bands of counts that
/// double: 1–2 magenta, 3–4 blue, 5–8 cyan, 9–16 green, 17–32 yellow, more red. The hue
/// steps 60° for each doubling, so a picture's density reads as a rainbow.
pub fn voxel_color(count: usize) -> DVec3 {
    const BANDS: [DVec3; 6] = [
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
    ];
    // ⌈log₂ count⌉ − 1, at least 0: 1 and 2 → 0, 3 and 4 → 1, 5…8 → 2, …
    let band = (count.max(2) - 1).ilog2() as usize;
    BANDS[band.min(BANDS.len() - 1)]
}

/// A filtered pixel being summed (docs/SPEC.md §8): Σw·colour over every sample, and
/// Σw·normal and Σw·t over the samples that hit, in f64.
#[derive(Default)]
struct FilterSum {
    weight: f64,
    color: DVec3,
    hit_weight: f64,
    normal: DVec3,
    depth: f64,
}

impl FilterSum {
    fn add(&mut self, w: f64, sample: &Pixel) {
        let v = |a: [f32; 3]| DVec3::from(a.map(f64::from));
        self.weight += w;
        self.color += w * v(sample.color);
        if sample.hit {
            self.hit_weight += w;
            self.normal += w * v(sample.normal);
            self.depth += w * sample.depth as f64;
        }
    }

    /// The weighted averages; the pixel is a hit where the samples that hit carry at least
    /// half of the weight, and then shows their filtered normal and t.
    fn pixel(&self) -> Pixel {
        let hit = self.hit_weight > 0.0 && 2.0 * self.hit_weight >= self.weight;
        let per_hit = if self.hit_weight > 0.0 { 1.0 / self.hit_weight } else { 0.0 };
        Pixel {
            hit,
            color: (self.color / self.weight).as_vec3().to_array(),
            normal: if hit { (self.normal * per_hit).as_vec3().to_array() } else { [0.0; 3] },
            depth: if hit { (self.depth * per_hit) as f32 } else { 0.0 },
        }
    }
}

/// A hit about to be shaded: its surface, the normal turned towards the viewer, and
/// whether the ray enters the surface (hits its front).
struct Shaded<'s> {
    surface: &'s Surface,
    normal: DVec3,
    entering: bool,
}

/// Where a secondary ray is in the recursion of docs/SPEC.md §5.
#[derive(Clone, Copy, Debug)]
struct Path {
    /// Reflections and refractions so far.
    bounces: u32,
    /// The product of the lengths of the reflective and transparent colours so far.
    weight: f64,
    /// The index of refraction of the medium the ray travels in.
    index: f64,
}

impl Path {
    /// A camera ray: no bounce yet, full weight, in vacuum.
    const PRIMARY: Path = Path { bounces: 0, weight: 1.0, index: 1.0 };
}

/// The direction of a unit ray `d` refracted at a surface with unit normal `n` facing it,
/// from index `from` into index `into` (Snell's law); `None` at total internal reflection.
pub fn refract(d: DVec3, n: DVec3, from: f64, into: f64) -> Option<DVec3> {
    let eta = from / into;
    let cos_in = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_in * cos_in);
    (k >= 0.0).then(|| (eta * d + (eta * cos_in - k.sqrt()) * n).normalize())
}

/// Where a secondary ray leaving the hit point `p` in direction `d` (unit, on the side of
/// the unit normal `side`) starts (docs/SPEC.md §5): moved along `d` itself until it is
/// `2⁻³² · max(1, |p|∞)` off the surface, so that it cannot hit the surface it leaves,
/// while its line stays the exact reflected, refracted or shadow ray (an offset along the
/// normal would shift the line sideways, by up to the offset, and grazing rays would then
/// find other hits). The GPU kernel's rule is the same with its own bound
/// (`spawn_origin` in shaders/surface.wgsl).
///
/// The bound: the reference computes `p` in f64 from the ray and the primitive, and the
/// error of `p` along the normal is a sum of rounding errors of the magnitudes involved,
/// `|p|`, the ray origin and the primitive's coordinates, each ≤ 2⁻⁵³ relative, times the
/// operation count of the intersection path (a few tens for a primitive, about ten more
/// per enclosing Transform, up to the parser's 1000 levels: below 2¹⁴ in all). The offset
/// is 2⁻³² · max(1, |p|∞), over 2⁷ times that bound for any scene whose coordinates are
/// within 2¹⁴ of the hit point's magnitude, and still 2⁻³² relative: no visible gap. A ray
/// leaving at less than 1/1024 to the surface moves 1024 times the offset along itself.
pub fn spawn_origin(p: DVec3, side: DVec3, d: DVec3) -> DVec3 {
    const RELATIVE: f64 = 1.0 / 4_294_967_296.0; // 2⁻³²
    let away = d.dot(side).max(1.0 / 1024.0);
    p + d * (RELATIVE * p.abs().max_element().max(1.0) / away)
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
