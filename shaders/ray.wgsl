// uses: params
// A ray, the interval of t it accepts, and its per-ray set-up for the watertight triangle
// test (shaders/triangle.wgsl), which each search computes once per ray and hands to every
// triangle it tests.

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// Rays of an orthographic camera start at infinity (negative t is visible, docs/SPEC.md
// §3); perspective rays start at the eye.
fn t_min() -> f32 {
    if (orthographic()) {
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

// Per-ray set-up of the watertight test: the axis permutation that makes the ray's largest
// component z, and the shear that makes the ray +z.
struct Shear {
    axes: vec3<u32>,
    s: vec3<f32>,
}

fn shear_for(d: vec3<f32>) -> Shear {
    let a = abs(d);
    var kz = 2u;
    if (a.x > a.y && a.x > a.z) {
        kz = 0u;
    } else if (a.y > a.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    // Keep the winding: swap the other two axes when the ray points down its main axis.
    if (d[kz] < 0.0) {
        let k = kx;
        kx = ky;
        ky = k;
    }
    return Shear(vec3<u32>(kx, ky, kz), vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]));
}

fn permute(v: vec3<f32>, k: vec3<u32>) -> vec3<f32> {
    return vec3<f32>(v[k.x], v[k.y], v[k.z]);
}
