// A ray and the interval of t it accepts.

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// Rays of an orthographic camera start at infinity (negative t is visible, docs/SPEC.md
// §3); perspective rays start at the eye.
fn t_min() -> f32 {
    if (ORTHOGRAPHIC) {
        return -F32_MAX;
    }
    return 0.0;
}

fn t_if_above(t: f32, tmin: f32) -> f32 {
    if (t > tmin) {
        return t;
    }
    return NO_HIT;
}
