//! Ray–primitive intersections in f64, the textbook way. Each returns the nearest
//! `(t, unit normal)` with `t_min < t < t_max`, in the coordinates of the ray it was given.

use crate::camera::Ray;
use glam::DVec3;

/// A hit. `t` is the world t (a ray carried into a Transform keeps the scale of its
/// direction); `normal` is in the coordinates of the ray that found the hit until each
/// enclosing Transform maps it back, so the hits the reference returns are in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f64,
    /// Unit normal as the primitive defines it (outward for spheres, `n̂` for planes,
    /// counter-clockwise for triangles); not flipped toward the viewer.
    pub normal: DVec3,
    pub material: u32,
}

/// `|p − c| = r` with `p = o + t·d`: the quadratic `a t² + b t + c = 0`. The direction need
/// not be unit length (inside a Transform it is not).
pub fn intersect_sphere(center: DVec3, radius: f64, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
    let oc = ray.origin - center;
    let a = ray.direction.length_squared();
    let b = 2.0 * ray.direction.dot(oc);
    let c = oc.length_squared() - radius * radius;
    let discriminant = b * b - 4.0 * a * c;
    if discriminant < 0.0 || a == 0.0 {
        return None;
    }
    let root = discriminant.sqrt();
    let near = (-b - root) / (2.0 * a);
    let far = (-b + root) / (2.0 * a);
    let t = [near, far].into_iter().find(|&t| t > t_min && t < t_max)?;
    Some((t, (ray.origin + t * ray.direction - center) / radius))
}

/// `n̂ · p = offset`: `t = (offset − n̂·o) / (n̂·d)`; a ray parallel to the plane never hits.
pub fn intersect_plane(normal: DVec3, offset: f64, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
    let n = normal.normalize();
    let denominator = n.dot(ray.direction);
    if denominator == 0.0 {
        return None;
    }
    let t = (offset - n.dot(ray.origin)) / denominator;
    (t > t_min && t < t_max).then_some((t, n))
}

/// Cramer's rule on `α·(a−c) + β·(b−c) + c = o + t·d` (the seed notes' derivation).
/// Hits inside or on an edge count; a degenerate triangle never hits.
pub fn intersect_triangle(vertices: &[DVec3; 3], ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
    let [a, b, c] = *vertices;
    let (e1, e2) = (a - c, b - c);
    let oc = ray.origin - c;
    let e1xe2 = e1.cross(e2);
    let det = -ray.direction.dot(e1xe2);
    if det == 0.0 {
        return None;
    }
    let t = oc.dot(e1xe2) / det;
    let alpha = -ray.direction.dot(oc.cross(e2)) / det;
    let beta = -ray.direction.dot(e1.cross(oc)) / det;
    let inside = alpha >= 0.0 && beta >= 0.0 && alpha + beta <= 1.0;
    if !(inside && t > t_min && t < t_max) {
        return None;
    }
    let normal = (b - a).cross(c - a).try_normalize()?;
    Some((t, normal))
}
