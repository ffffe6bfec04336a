// uses: params, exact, ray
// Ray/triangle, three ways, so that the course's comparison of methods is a measurement
// (--triangle-test; README "Accuracy"), and the watertight one's primary-ray form, for the
// screen-space bins (shaders/bins.wgsl). Edges count as inside; both sides hit.

fn triangle_t(tri: Triangle, ray: Ray, shear: Shear, tmin: f32) -> f32 {
    if (TRIANGLE_TEST == TRIANGLE_CRAMER) {
        return triangle_t_cramer(tri, ray, tmin);
    }
    if (TRIANGLE_TEST == TRIANGLE_MOLLER) {
        return triangle_t_moller(tri, ray, tmin);
    }
    return triangle_t_watertight(tri, ray, shear, tmin);
}

// Cramer's rule on α·(a − c) + β·(b − c) + c = o + t·d, as the seed notes derive it.
fn triangle_t_cramer(tri: Triangle, ray: Ray, tmin: f32) -> f32 {
    let e1 = tri.v0 - tri.v2;
    let e2 = tri.v1 - tri.v2;
    let oc = ray.origin - tri.v2;
    let n = cross3(e1, e2);
    let det = -dot3(ray.direction, n);
    if (det == 0.0) {
        return NO_HIT;
    }
    let alpha = -dot3(ray.direction, cross3(oc, e2)) / det;
    let beta = -dot3(ray.direction, cross3(e1, oc)) / det;
    if (alpha < 0.0 || beta < 0.0 || alpha + beta > 1.0) {
        return NO_HIT;
    }
    return t_if_above(dot3(oc, n) / det, tmin);
}

// Möller, Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection", JGT 2(1), 1997.
fn triangle_t_moller(tri: Triangle, ray: Ray, tmin: f32) -> f32 {
    let e1 = tri.v1 - tri.v0;
    let e2 = tri.v2 - tri.v0;
    let p = cross3(ray.direction, e2);
    let det = dot3(e1, p);
    if (det == 0.0) {
        return NO_HIT;
    }
    let inv = 1.0 / det;
    let s = ray.origin - tri.v0;
    let u = rounded(dot3(s, p) * inv);
    let q = cross3(s, e1);
    let v = rounded(dot3(ray.direction, q) * inv);
    if (u < 0.0 || v < 0.0 || u + v > 1.0) {
        return NO_HIT;
    }
    return t_if_above(dot3(e2, q) * inv, tmin);
}

// Woop, Benthin, Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013. Edge
// functions are computed in a frame where the ray is the +z axis, so an edge shared by two
// triangles gives both the same value with opposite signs: no ray slips between them.
// The paper recomputes an edge function that is exactly 0 in double precision; here 0
// counts as inside (as the reference's α ≥ 0), so a ray on a shared edge is taken by both
// triangles, never by neither. Every product is rounded on its own (shaders/exact.wgsl): the
// edge functions of a zero-area triangle are then exactly 0 on every driver, and so is
// their sum, the determinant, whatever the compiler fuses elsewhere.
fn triangle_t_watertight(tri: Triangle, ray: Ray, shear: Shear, tmin: f32) -> f32 {
    let a = permute(tri.v0 - ray.origin, shear.axes);
    let b = permute(tri.v1 - ray.origin, shear.axes);
    let c = permute(tri.v2 - ray.origin, shear.axes);
    let ax = a.x - rounded(shear.s.x * a.z);
    let ay = a.y - rounded(shear.s.y * a.z);
    let bx = b.x - rounded(shear.s.x * b.z);
    let by = b.y - rounded(shear.s.y * b.z);
    let cx = c.x - rounded(shear.s.x * c.z);
    let cy = c.y - rounded(shear.s.y * c.z);
    let u = difference_of_products(cx, by, cy, bx);
    let v = difference_of_products(ax, cy, ay, cx);
    let w = difference_of_products(bx, ay, by, ax);
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return NO_HIT;
    }
    let det = u + v + w;
    if (det == 0.0) {
        return NO_HIT;
    }
    let scaled = (rounded(u * a.z) + rounded(v * b.z)) + rounded(w * c.z);
    return t_if_above(rounded(scaled * shear.s.z) / det, tmin);
}

// The edge functions of a primary ray against a triangle's edge planes: all of one sign
// (or zero) when the ray's line meets the triangle, edges included. Watertight (see
// gpu::binning::EyeTriangle): a shared edge's plane is negated bit for bit in its two
// triangles, and each product is rounded on its own (shaders/exact.wgsl), so that the
// negation holds on every driver. Then t from the triangle's plane; a ray in that plane
// never hits. The non-short-circuit & and | keep it free of branches.
fn eye_triangle_t(tri: EyeTriangle, ray: Ray, tmin: f32) -> f32 {
    var q = ray.direction;
    if (orthographic()) {
        q = ray.origin;
    }
    let e0 = dot3(tri.rows[0].xyz, q) - tri.rows[0].w;
    let e1 = dot3(tri.rows[1].xyz, q) - tri.rows[1].w;
    let e2 = dot3(tri.rows[2].xyz, q) - tri.rows[2].w;
    let inside = ((e0 >= 0.0) & (e1 >= 0.0) & (e2 >= 0.0)) | ((e0 <= 0.0) & (e1 <= 0.0) & (e2 <= 0.0));
    let plane = tri.rows[3];
    let denominator = dot3(plane.xyz, ray.direction);
    var numerator = plane.w;
    if (orthographic()) {
        numerator -= dot3(plane.xyz, ray.origin);
    }
    let t = numerator / select(1.0, denominator, denominator != 0.0);
    return select(NO_HIT, t_if_above(t, tmin), inside & (denominator != 0.0));
}

// The host computed the normal from the f64 vertices: a cross product of the f32 ones would
// lose 2⁻²⁴ of their distance from the camera over an edge's length.
fn triangle_normal(tri: Triangle) -> vec3<f32> {
    return octahedral_decode(vec2<f32>(tri.normal_u, tri.normal_v));
}

// Inverse of gpu::layout::octahedral (Cigolle et al. 2014, §3.1): the upper half as is, the
// lower half unfolded, then normalised.
fn octahedral_decode(e: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - abs(e.x) - abs(e.y);
    var xy = e;
    if (z < 0.0) {
        xy = (1.0 - abs(e.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), e >= vec2<f32>(0.0));
    }
    return normalize(vec3<f32>(xy, z));
}
