// uses: params, exact, ray
// Ray/plane. Planes are infinite: they stay outside the bins and the hierarchy and are
// tested by every ray.

// A ray parallel to the plane never hits it, even when it lies in it.
fn plane_t(p: Plane, ray: Ray, tmin: f32) -> f32 {
    let denominator = dot3(p.normal, ray.direction);
    if (denominator == 0.0) {
        return NO_HIT;
    }
    return t_if_above((p.offset - dot3(p.normal, ray.origin)) / denominator, tmin);
}
