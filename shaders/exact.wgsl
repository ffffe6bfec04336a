// uses: params
// Arithmetic whose rounding no driver chooses (docs/SPEC.md §6, "What the kernel assumes of
// the driver"). WGSL lets a compiler fuse a multiply into the add or subtraction that uses
// it (one rounding instead of two) and compute dot and cross in any fused order; NVIDIA's
// compiler does, the CPU drivers do not. A sign that decides a hit must not hang on that:
// fused, the edge function a·b − a·b of a zero-area triangle is the rounding error of one
// product instead of 0, and a point covered the whole image (src/gpu/fuse.rs reproduces
// it). So where a sign or a comparison decides a hit, an inside test, a bin, a cell or a
// shadow, each product goes through `rounded`: its bits or-ed with P.zero_bits, a zero the
// compiler cannot know, so that the product is rounded on its own on every driver and the
// sums follow in the order written. Products are then exact where the arithmetic is
// (a·b − a·b is 0 everywhere), and a driver that fuses the rest changes no decision.
// uses: params (P.zero_bits)

fn rounded(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) | P.zero_bits);
}

fn rounded3(v: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(v) | vec3<u32>(P.zero_bits));
}

fn rounded4(v: vec4<f32>) -> vec4<f32> {
    return bitcast<vec4<f32>>(bitcast<vec4<u32>>(v) | vec4<u32>(P.zero_bits));
}

// a·b − c·d with both products rounded: exactly 0 whenever a·b = c·d, on every driver.
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    return rounded(a * b) - rounded(c * d);
}

// dot(a, b) summed x, y, z in that order, each product rounded.
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let p = rounded3(a * b);
    return (p.x + p.y) + p.z;
}

fn dot4(a: vec4<f32>, b: vec4<f32>) -> f32 {
    let p = rounded4(a * b);
    return ((p.x + p.y) + p.z) + p.w;
}

// cross(a, b), each component a difference of rounded products.
fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return rounded3(a.yzx * b.zxy) - rounded3(a.zxy * b.yzx);
}

// o + t·d, the product rounded: a point along a ray.
fn along(o: vec3<f32>, t: f32, d: vec3<f32>) -> vec3<f32> {
    return o + rounded3(t * d);
}
