//! Pixels the f32 kernel cannot resolve by its spawn rule (docs/SPEC.md §5): a secondary ray
//! starts `ε / max(D·N, 1/1024)` along itself, ε being 2⁵ ulps of the magnitudes its hit
//! point was computed from, so it does not see another surface closer than that to the
//! point it leaves. The reference's ε is 2²⁷ times smaller and sees it. Two surfaces that
//! close (a mesh folded onto itself, two sheets a hair apart) are a difference of the two
//! renderers' documented resolutions, not an error of either, and a random scene makes such
//! a pair now and then (a soup mesh folded at half a degree: its two faces 5.42·10⁻⁵ apart
//! along a refracted ray, under the kernel's 5.45·10⁻⁵, in a scene 7 units across).
//!
//! [`within_spawn_gap`] tells whether one pixel's colour depends on such a pair: it walks the
//! pixel's ray tree with the reference's own geometry (every ray the reference may cast:
//! shadow rays to the lights that face each hit, and the reflected and refracted rays of
//! each material there while the bounces allow, `-weight`'s pruning left out) and looks for a secondary ray whose nearest
//! hit is on another primitive than the one it leaves, closer than twice the kernel's
//! offset. Twice: the kernel's point is itself off by up to half its offset (the offset is
//! twice the bound of that error). The offset's scale is the kernel's, or a bound of it:
//! the largest camera-relative coordinate of the ray's origin, the point, and the world box
//! of the primitive it leaves (for a plane, the farthest plane's). The same primitive never
//! excuses a pixel: a ray leaving a triangle or a plane cannot meet it again, and a sphere's chord
//! the kernel resolves exactly (`solid_exit_t`).

use glam::DVec3;
use raycaster::camera::{PrimaryRays, Ray};
use raycaster::cpu::{refract, spawn_origin, Hit, ReferenceScene};
use raycaster::render::Shading;
use raycaster::scene::{for_each_leaf, Light, Scene, Shape};

/// The kernel's ε relative to its scale: 2⁵ ulps, 2⁵ · 2⁻²⁴ (`SPAWN_OFFSET` in
/// shaders/surface.wgsl).
const KERNEL_SPAWN_OFFSET: f64 = 1.9073486328125e-6;

/// One scene's ray trees, as the reference would cast them.
pub struct SpawnGaps<'a> {
    scene: &'a Scene,
    prepared: ReferenceScene<'a>,
    shading: Shading,
    /// A bound of the kernel's scale on any plane: the largest camera-relative distance of
    /// a plane.
    plane_scale: f64,
}

impl<'a> SpawnGaps<'a> {
    pub fn new(scene: &'a Scene, shading: Shading) -> SpawnGaps<'a> {
        SpawnGaps { scene, prepared: ReferenceScene::new(scene), shading, plane_scale: farthest_plane(scene) }
    }

    /// Whether the colour of pixel `(i, row)` (row from the top, as images count it) of a
    /// `width × height` image depends on a surface within the kernel's spawn gap; the
    /// description of the first such ray, if so.
    pub fn within_spawn_gap(&self, width: u32, height: u32, i: u32, row: u32) -> Option<String> {
        // PrimaryRays counts rows from the bottom.
        let ray = PrimaryRays::for_camera(&self.scene.camera, width, height).ray(i, height - 1 - row);
        self.walk(&ray, None, 0, 1.0)
    }

    /// The tree below `ray`, which left the primitive of `from` (none for a camera ray) after
    /// `bounces` reflections and refractions, travelling in a medium of index `index`.
    fn walk(&self, ray: &Ray, from: Option<(&Hit, f64)>, bounces: u32, index: f64) -> Option<String> {
        let hit = self.prepared.closest_hit(ray)?;
        if let Some(gap) = from.and_then(|(parent, reach)| self.gap(parent, &hit, reach, "reflected or refracted")) {
            return Some(gap);
        }
        let surface = self.prepared.surface_at(&hit, ray);
        let facing = ray.direction.dot(surface.normal);
        if facing > 0.0 && !self.shading.shade_back {
            return None; // black: no shadow ray, no child
        }
        let normal = if facing > 0.0 { -surface.normal } else { surface.normal };
        let scale = self.kernel_scale(ray, surface.point, &hit);
        let spawn = |direction: DVec3, side: DVec3| {
            // The reference's own start, and the kernel's reach beyond the point (its
            // offset along the ray grows over the cosine as the reference's does).
            let cosine = direction.dot(side).max(1.0 / 1024.0);
            let reach = 2.0 * KERNEL_SPAWN_OFFSET * scale / cosine;
            (Ray::new(spawn_origin(surface.point, side, direction), direction, 0.0), reach)
        };
        if self.shading.shadows {
            for light in &self.scene.lights {
                let (to_light, distance) = towards(light, surface.point);
                if to_light.dot(normal) <= 0.0 {
                    continue;
                }
                let (mut shadow, reach) = spawn(to_light, normal);
                shadow.t_max = distance;
                if let Some(blocker) = self.prepared.closest_hit(&shadow) {
                    if let Some(gap) = self.gap(&hit, &blocker, reach, "shadow") {
                        return Some(gap);
                    }
                }
            }
        }
        if bounces >= self.shading.bounces {
            return None;
        }
        for material in self.materials_at(surface.material) {
            let material = self.prepared.material(material);
            let d = ray.direction;
            if material.reflective != DVec3::ZERO {
                let (reflected, reach) = spawn(d - 2.0 * d.dot(normal) * normal, normal);
                if let Some(gap) = self.walk(&reflected, Some((&hit, reach)), bounces + 1, index) {
                    return Some(gap);
                }
            }
            let into = if facing < 0.0 { material.index_of_refraction } else { 1.0 };
            if material.transparent != DVec3::ZERO {
                if let Some(direction) = refract(d, normal, index, into) {
                    let (refracted, reach) = spawn(direction, -normal);
                    if let Some(gap) = self.walk(&refracted, Some((&hit, reach)), bounces + 1, into) {
                        return Some(gap);
                    }
                }
            }
        }
        None
    }

    /// The description of `hit`, met by a secondary ray that left `parent`'s primitive, if it
    /// lies on another primitive within `reach` of the start.
    fn gap(&self, parent: &Hit, hit: &Hit, reach: f64, kind: &str) -> Option<String> {
        (!hit.same_primitive(parent) && hit.t < reach).then(|| {
            format!("a {kind} ray meets another surface {:.3e} from its start, within the kernel's {reach:.3e}", hit.t)
        })
    }

    /// A bound of the scale of the kernel's offset at `point`, where `ray` hit `hit`
    /// (`surface_at` in shaders/surface.wgsl): camera-relative, the largest coordinate of
    /// the ray's origin, the point and the primitive.
    fn kernel_scale(&self, ray: &Ray, point: DVec3, hit: &Hit) -> f64 {
        let camera = self.scene.camera.center;
        let largest = |p: DVec3| (p - camera).abs().max_element();
        let primitive = match self.prepared.world_bounds(hit) {
            // The box's farthest corner, axis by axis.
            Some(b) => (b.min - camera).abs().max((b.max - camera).abs()).max_element(),
            None => self.plane_scale,
        };
        // An orthographic ray's origin is far behind the camera; the kernel starts it on
        // the image plane.
        let origin = if ray.t_min.is_finite() { largest(ray.origin) } else { 0.0 };
        origin.max(largest(point)).max(primitive)
    }

    /// Every Phong material a material index blends (itself, or a texture's leaves).
    fn materials_at(&self, index: u32) -> Vec<u32> {
        match self.scene.texture(index) {
            None => vec![index],
            Some(texture) => texture.materials.iter().flat_map(|&m| self.materials_at(m)).collect(),
        }
    }
}

/// The unit direction towards `light` from `point`, and how far the light is.
fn towards(light: &Light, point: DVec3) -> (DVec3, f64) {
    match light {
        Light::Directional(light) => (-light.direction.normalize(), f64::INFINITY),
        Light::Point(light) => {
            let offset = light.position - point;
            (offset / offset.length(), offset.length())
        }
    }
}

/// The largest camera-relative distance of a plane: that of the point of it nearest the
/// origin carried to the world (no nearer to the camera than the plane itself, whose
/// camera-relative offset the kernel takes).
fn farthest_plane(scene: &Scene) -> f64 {
    let camera = scene.camera.center;
    let mut farthest: f64 = 0.0;
    for_each_leaf(&scene.root, &glam::DMat4::IDENTITY, &mut |leaf| {
        if let Shape::Plane { normal, offset, .. } = leaf.shape() {
            let foot = leaf.to_world.transform_point3(*normal * (*offset / normal.length_squared()));
            farthest = farthest.max((foot - camera).length());
        }
    });
    farthest
}
