// uses: params, exact, ray
// Primary rays: the camera maths of docs/SPEC.md §3, as camera::PrimaryRays on the host.

// Pixel (i from the left, j from the bottom), sampled at its centre; the longer image side
// spans the camera's extent and the shorter one is cropped (docs/SPEC.md §3).
fn primary_ray(i: u32, j: u32) -> Ray {
    let longer = f32(max(P.width, P.height));
    let x = (f32(i) + 0.5 - rounded(0.5 * f32(P.width))) / longer;
    let y = (f32(j) + 0.5 - rounded(0.5 * f32(P.height))) / longer;
    return ray_through(x, y);
}

// The ray through screen coordinates (x, y). Products rounded (shaders/exact.wgsl): a
// pixel mirrored across the image's centre gets the mirrored ray on every driver, so a ray
// exactly on a symmetric edge stays exactly on it.
fn ray_through(x: f32, y: f32) -> Ray {
    let offset = rounded3(x * P.horizontal) + rounded3(y * P.up);
    if (orthographic()) {
        return Ray(offset, P.direction);
    }
    return Ray(vec3<f32>(0.0), normalize(P.direction + offset));
}

// The ray of image row `image_row` (from the top), clamped into the image so that a packet
// reaching past its last row still casts a valid ray (whose pixel is not written).
fn ray_of_row(i: u32, image_row: u32) -> Ray {
    let clamped = min(image_row, P.height - 1u);
    // Image rows count from the top, the camera's j from the bottom.
    return primary_ray(i, P.height - 1u - clamped);
}
