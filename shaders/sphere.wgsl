// uses: params, exact
// Ray/sphere: the nearest root t > tmin of |f + t·d| = r, where f = origin − centre and d
// need not be unit length (an ellipsoid hands over its object-space ray).

fn sphere_t(f: vec3<f32>, d: vec3<f32>, radius: f32, tmin: f32) -> f32 {
    if (SPHERE_TEST == SPHERE_NAIVE) {
        return sphere_t_textbook(f, d, radius, tmin);
    }
    return sphere_t_precise(f, d, radius, tmin);
}

// The nearer root above tmin of two roots in either order.
fn nearest_root(r0: f32, r1: f32, tmin: f32) -> f32 {
    let near = min(r0, r1);
    let far = max(r0, r1);
    if (near > tmin) {
        return near;
    }
    if (far > tmin) {
        return far;
    }
    return NO_HIT;
}

// a t² + b t + c = 0 as in any textbook: b² − 4ac cancels when the ray starts far from the
// sphere, and −b ± √Δ cancels for one of the roots. Kept to measure what the precise form buys
// (--sphere-test naive; scenes/hard/far_sphere.txt loses the whole sphere).
fn sphere_t_textbook(f: vec3<f32>, d: vec3<f32>, radius: f32, tmin: f32) -> f32 {
    let a = dot3(d, d);
    let b = 2.0 * dot3(f, d);
    let c = dot3(f, f) - rounded(radius * radius);
    let discriminant = difference_of_products(b, b, 4.0 * a, c);
    if (discriminant < 0.0) {
        return NO_HIT;
    }
    let root = sqrt(discriminant);
    return nearest_root((-b - root) / (2.0 * a), (-b + root) / (2.0 * a), tmin);
}

// Haines, Günther, Akenine-Möller, "Precision Improvements for Ray/Sphere Intersection",
// Ray Tracing Gems ch. 7 (b here is −f·d, half the textbook's and negated): the
// discriminant from the squared distance of the centre to the line, r² − |f + (b/a) d|²,
// so nothing cancels when the ray starts far away (b² − 4ac does); then
// q = b + sign(b)·√(a·Δ) and the roots c/q and q/a, so neither root is a difference of
// nearly equal numbers (the textbook's −b ± √Δ is, for one of the two).
fn sphere_t_precise(f: vec3<f32>, d: vec3<f32>, radius: f32, tmin: f32) -> f32 {
    let a = dot3(d, d);
    let b = -dot3(f, d);
    let perpendicular = along(f, b / a, d);
    let discriminant = rounded(radius * radius) - dot3(perpendicular, perpendicular);
    if (discriminant < 0.0) {
        return NO_HIT;
    }
    let c = dot3(f, f) - rounded(radius * radius);
    let q = b + rounded(select(-1.0, 1.0, b >= 0.0) * sqrt(a * discriminant));
    // q = 0 only for a ray that starts on the sphere and touches it there (b = 0, Δ = 0):
    // its one root is 0, and c / q would be 0 / 0.
    let near = select(c / q, q / a, q == 0.0);
    return nearest_root(near, q / a, tmin);
}
