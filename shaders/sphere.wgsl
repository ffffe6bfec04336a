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
    let a = dot(d, d);
    let b = 2.0 * dot(f, d);
    let c = dot(f, f) - radius * radius;
    let discriminant = b * b - 4.0 * a * c;
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
    let a = dot(d, d);
    let b = -dot(f, d);
    let perpendicular = f + (b / a) * d;
    let discriminant = radius * radius - dot(perpendicular, perpendicular);
    if (discriminant < 0.0) {
        return NO_HIT;
    }
    let c = dot(f, f) - radius * radius;
    let q = b + select(-1.0, 1.0, b >= 0.0) * sqrt(a * discriminant);
    return nearest_root(c / q, q / a, tmin);
}
