//! Ray–primitive intersections in f64, the textbook way. Each returns only the nearest `t`
//! with `ray.t_min < t < ray.t_max`, in the coordinates of the ray it was given: as in
//! pbrt-v4, intersection finds where, and the surface there (normal, point) is built
//! afterwards, once, for the nearest hit only ([`super::Surface`]). The normal expressions
//! live here too, beside the tests they belong to, so that both steps see one definition.

use crate::camera::Ray;
use crate::scene::Bounds;
use glam::DVec3;

/// `|p − c| = r` with `p = o + t·d`: the quadratic `a t² + b t + c = 0`. The direction need
/// not be unit length (inside a Transform it is not). The nearer root in the interval, else
/// the farther one (from inside the sphere the near root lies behind the ray).
pub fn intersect_sphere(center: DVec3, radius: f64, ray: &Ray) -> Option<f64> {
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
    [near, far].into_iter().find(|&t| within(t, ray))
}

/// docs/SPEC.md §4: the outward normal `(p − c)/r` at a point `p` of the sphere, in the
/// sphere's coordinates.
pub fn sphere_normal(center: DVec3, radius: f64, point: DVec3) -> DVec3 {
    (point - center) / radius
}

/// `n̂ · p = offset`: `t = (offset − n̂·o) / (n̂·d)`; a ray parallel to the plane never hits.
/// `unit_normal` is the plane's normal already normalised (docs/SPEC.md §4), which is also
/// the plane's normal everywhere.
pub fn intersect_plane(unit_normal: DVec3, offset: f64, ray: &Ray) -> Option<f64> {
    let denominator = unit_normal.dot(ray.direction);
    if denominator == 0.0 {
        return None;
    }
    let t = (offset - unit_normal.dot(ray.origin)) / denominator;
    within(t, ray).then_some(t)
}

/// Cramer's rule on `α·(a−c) + β·(b−c) + c = o + t·d` (the seed notes' derivation).
/// Hits inside or on an edge count; a degenerate triangle never hits, and neither does one
/// whose [`triangle_normal`] f64 cannot normalise (an area that underflows or overflows even
/// where the determinant does not), so that every hit has a normal.
pub fn intersect_triangle(vertices: &[DVec3; 3], ray: &Ray) -> Option<f64> {
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
    if !(inside && within(t, ray)) {
        return None;
    }
    triangle_normal(vertices).map(|_| t)
}

/// docs/SPEC.md §4: `normalise((v1 − v0) × (v2 − v0))`, counter-clockwise in front; `None`
/// when f64 cannot normalise it.
pub fn triangle_normal(vertices: &[DVec3; 3]) -> Option<DVec3> {
    let [a, b, c] = *vertices;
    (b - a).cross(c - a).try_normalize()
}

/// Whether the ray can meet anything inside `bounds` within its interval: the slab test
/// (Kay and Kajiya 1986; pbrt-v4 §6.1.2), conservative: the box is widened by a margin of
/// 1e-9 times its largest extent (at least 1e-9) so that rounding can never make the
/// reference skip a mesh that a triangle test would hit.
pub fn ray_meets_box(ray: &Ray, bounds: &Bounds) -> bool {
    let (lo, hi) = (bounds.min, bounds.max);
    let margin = (hi - lo).max_element().max(1.0) * 1e-9;
    let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
    let (mut near, mut far) = (ray.t_min, ray.t_max);
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

/// The ray's interval is open at both ends: a hit at exactly `t_min` (a shadow ray's own
/// surface) or `t_max` (the hit already found, or the light) does not count.
fn within(t: f64, ray: &Ray) -> bool {
    t > ray.t_min && t < ray.t_max
}
