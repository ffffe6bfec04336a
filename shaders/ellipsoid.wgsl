// uses: params, exact, ray, sphere
// A sphere under a transform that is not a similarity: the ray goes into the unit sphere's
// space by the affine map W the host inverted in f64 (docs/SPEC.md §4).

fn to_unit_sphere_point(e: Ellipsoid, p: vec3<f32>) -> vec3<f32> {
    let h = vec4<f32>(p, 1.0);
    return vec3<f32>(dot4(e.row0, h), dot4(e.row1, h), dot4(e.row2, h));
}

fn to_unit_sphere_vector(e: Ellipsoid, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot3(e.row0.xyz, v), dot3(e.row1.xyz, v), dot3(e.row2.xyz, v));
}

// The direction is not renormalised in the unit sphere's space, so the root t found there
// is the world t (docs/SPEC.md §4).
fn ellipsoid_t(e: Ellipsoid, ray: Ray, tmin: f32) -> f32 {
    return sphere_t(to_unit_sphere_point(e, ray.origin), to_unit_sphere_vector(e, ray.direction), 1.0, tmin);
}

// The world normal is normalise(Wᵀ · n) with n the unit sphere's normal at the hit
// (the inverse transpose of the object-to-world map, whose inverse W we hold).
fn ellipsoid_normal(e: Ellipsoid, world_point: vec3<f32>) -> vec3<f32> {
    let n = to_unit_sphere_point(e, world_point);
    return normalize(rounded3(e.row0.xyz * n.x) + rounded3(e.row1.xyz * n.y) + rounded3(e.row2.xyz * n.z));
}
