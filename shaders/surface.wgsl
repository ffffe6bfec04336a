// uses: host, params, exact, ray, ellipsoid, triangle, closest
// The surface at the nearest hit, built once per ray after the search (pbrt-v4's split of
// intersection and surface interaction): the search compares t alone.

struct Surface {
    // Camera-relative world point.
    point: vec3<f32>,
    // Unit world normal as the primitive defines it (docs/SPEC.md §4), not yet turned to
    // face the ray.
    normal: vec3<f32>,
    material: u32,
    // The largest magnitude the point was computed from (ray origin, point, the primitive's
    // coordinates): its rounding error is a few ulps of this (see spawn_origin). An
    // ellipsoid's point is bounded by the point and the origin alone: its unit-sphere
    // coordinates are within a few units.
    scale: f32,
    // The primitive hit: a sphere's or an ellipsoid's solid is closed (solid_exit_t).
    kind: u32,
    index: u32,
}

fn max_norm(v: vec3<f32>) -> f32 {
    let a = abs(v);
    return max(max(a.x, a.y), a.z);
}

// `hit` must be a hit (hit.t < NO_HIT).
fn surface_at(hit: Closest, ray: Ray) -> Surface {
    let p = along(ray.origin, hit.t, ray.direction);
    let scale = max(max_norm(ray.origin), max_norm(p));
    if (HAS_SPHERES && hit.kind == KIND_SPHERE) {
        let s = spheres[hit.index];
        return Surface(p, (p - s.center) / s.radius, s.material, max(scale, max_norm(s.center) + s.radius), hit.kind, hit.index);
    }
    if (HAS_ELLIPSOIDS && hit.kind == KIND_ELLIPSOID) {
        let e = ellipsoids[hit.index];
        return Surface(p, ellipsoid_normal(e, p), e.material, scale, hit.kind, hit.index);
    }
    if (HAS_PLANES && hit.kind == KIND_PLANE) {
        let pl = planes[hit.index];
        return Surface(p, pl.normal, pl.material, max(scale, abs(pl.offset)), hit.kind, hit.index);
    }
    if (HAS_TRIANGLES && hit.kind == KIND_TRIANGLE) {
        let tri = triangles[hit.index];
        let extent = max(max(max_norm(tri.v0), max_norm(tri.v1)), max_norm(tri.v2));
        return Surface(p, triangle_normal(tri), tri.material, max(scale, extent), hit.kind, hit.index);
    }
    return Surface(p, vec3<f32>(0.0), 0u, scale, hit.kind, hit.index);
}

// 2⁵ ulps of a magnitude: 2⁵ · 2⁻²⁴.
const SPAWN_OFFSET: f32 = 1.9073486328125e-6;

// Where a ray leaving the surface in direction d (unit, on the side of the unit normal
// `side`) starts (docs/SPEC.md §5; cpu::spawn_origin is the same rule in f64): moved along
// d itself until it is SPAWN_OFFSET · scale off the surface, so that it cannot find the
// surface it leaves, and its line stays the exact reflected, refracted or shadow ray.
//
// The bound: the hit point's error along the normal is the error of t times d·n plus the
// rounding of o + t·d, a few ulps of the magnitudes the point was computed from (the
// ray's origin, the point, the primitive's coordinates: `scale`), and the host's rounding
// of the primitive to f32 adds one more; 2⁵ ulps is twice the 16 that a test of some
// tens of operations can reach. Relative, so a scene scaled or moved renders the same.
// Wächter and Binder ("A Fast and Robust Method for Avoiding Self-Intersection", Ray
// Tracing Gems ch. 6) offset along the normal, by 2⁸ ulps per coordinate; an offset along
// the normal moves the ray's line sideways, which grazing rays inside a transparent sphere
// turned into 170 of 40 000 pixels off the reference in the course's scene4_07 (2⁸ ulps)
// or 11 (2⁴), against 2 moved along d (2⁵). A ray leaving at less than SPAWN_MIN_COSINE to
// the surface moves 1024 times the offset along itself, which no longer clears the
// point's error: a reflected or refracted ray leaving that way hands its pixel over
// (Leaving::grazing).
fn spawn_origin(surface: Surface, side: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return start_along(surface, d, dot3(d, side));
}

// spawn_origin for a ray leaving at `cosine` (d·side) to the surface.
fn start_along(surface: Surface, d: vec3<f32>, cosine: f32) -> vec3<f32> {
    return along(surface.point, SPAWN_OFFSET * surface.scale / max(cosine, SPAWN_MIN_COSINE), d);
}

// The cosine to the surface below which spawn_origin's move stops growing.
const SPAWN_MIN_COSINE: f32 = 0.0009765625; // 1/1024

// A reflected or refracted ray leaving the surface, started as spawn_origin starts it, and
// whether it leaves at less than SPAWN_MIN_COSINE: its start may then lie within the
// point's error of the surface, and find it again.
struct Leaving {
    ray: Ray,
    grazing: bool,
}

// The ray leaving the surface in direction d (unit, on the side of the unit normal `side`).
fn leaving(surface: Surface, side: vec3<f32>, d: vec3<f32>) -> Leaving {
    let cosine = dot3(d, side);
    return Leaving(Ray(start_along(surface, d, cosine), d), cosine < SPAWN_MIN_COSINE);
}

// How far a ray from the surface's point along the unit direction d goes inside the closed
// solid the surface bounds (a sphere or an ellipsoid) before it leaves it again: the chord,
// 0 or less where d points out of the solid, NO_HIT on an open surface (a plane, a
// triangle). spawn_origin moves a ray that leaves at a grazing angle c = |N·d| a distance
// SPAWN_OFFSET · scale / c along itself, and the chord into a sphere of radius r is only
// 2·r·c long: below c² ≈ SPAWN_OFFSET · scale / (2r) the moved ray starts beyond the chord
// and never meets the solid it stands in (a shadow ray lit a point the sphere itself hides;
// a random scene found it, docs/SPEC.md §5). The chord's length needs no search: from a
// point p on the sphere, |p + t·d − c| = r has the roots 0 and −2 (p − c)·d = −2r N·d, whose
// error is the normal's, not the point's.
fn solid_exit_t(surface: Surface, d: vec3<f32>) -> f32 {
    if (HAS_SPHERES && surface.kind == KIND_SPHERE) {
        return -2.0 * spheres[surface.index].radius * dot3(surface.normal, d);
    }
    if (HAS_ELLIPSOIDS && surface.kind == KIND_ELLIPSOID) {
        // The same chord in the unit sphere's space, where t is the world t (ellipsoid_t).
        let e = ellipsoids[surface.index];
        let q = to_unit_sphere_point(e, surface.point);
        let v = to_unit_sphere_vector(e, d);
        return -2.0 * dot3(q, v) / dot3(v, v);
    }
    return NO_HIT;
}
