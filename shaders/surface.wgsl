// The surface at the nearest hit, built once per ray after the search (pbrt-v4's split of
// intersection and surface interaction): the search compares t alone.

struct Surface {
    // Camera-relative world point.
    point: vec3<f32>,
    // Unit world normal as the primitive defines it (docs/SPEC.md §4), not yet turned to
    // face the ray.
    normal: vec3<f32>,
    material: u32,
}

// `hit` must be a hit (hit.t < NO_HIT).
fn surface_at(hit: Closest, ray: Ray) -> Surface {
    let p = ray.origin + hit.t * ray.direction;
    if (HAS_SPHERES && hit.kind == KIND_SPHERE) {
        let s = spheres[hit.index];
        return Surface(p, (p - s.center) / s.radius, s.material);
    }
    if (HAS_ELLIPSOIDS && hit.kind == KIND_ELLIPSOID) {
        let e = ellipsoids[hit.index];
        return Surface(p, ellipsoid_normal(e, p), e.material);
    }
    if (HAS_PLANES && hit.kind == KIND_PLANE) {
        let pl = planes[hit.index];
        return Surface(p, pl.normal, pl.material);
    }
    if (HAS_TRIANGLES && hit.kind == KIND_TRIANGLE) {
        let tri = triangles[hit.index];
        return Surface(p, triangle_normal(tri), tri.material);
    }
    return Surface(p, vec3<f32>(0.0), 0u);
}
