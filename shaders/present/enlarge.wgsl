// uses: host (gpu::present's constants, prepended)
// The live window's frame, on the device (src/gpu/present.rs): one tile of a render's
// packed 8-bit words (gpu::layout::PixelLayout, packed) enlarged into the texels of the
// surface's rows, each pixel a `scale` × `scale` block, then copied onto the surface as
// bytes.
// Integer work only: the texels are the bytes an image file holds, and no float-to-unorm
// conversion (whose rounding a driver chooses) comes between. Not part of the kernel
// (src/gpu/shader.rs composes that from shaders/*.wgsl alone).

struct Enlarge {
    // Pixels per row of the rendered image.
    width: u32,
    // The tile's first image row, and its rows.
    first_row: u32,
    rows: u32,
    // Words per pixel; the first, colour or else normals, is shown.
    stride: u32,
    // Texels per rendered pixel, along each side.
    scale: u32,
    // The target's size in texels, and the texels per row of `texels` (rows padded to
    // wgpu's COPY_BYTES_PER_ROW_ALIGNMENT).
    target_width: u32,
    target_height: u32,
    row_texels: u32,
    // 1 where the target's bytes are blue, green, red, alpha; 0 for red, green, blue, alpha.
    bgra: u32,
}

@group(0) @binding(0) var<storage, read> pixels: array<u32>;
@group(0) @binding(1) var<storage, read_write> texels: array<u32>;
// Set where a pixel of the frame was handed over to the reference (its first word
// CUT_SHORT_WORD or BEYOND_REACH_WORD): the host then draws this frame from the reference.
@group(0) @binding(2) var<storage, read_write> handed_over: atomic<u32>;
@group(0) @binding(3) var<uniform> E: Enlarge;

// A packed colour or |N| (r | g << 8 | b << 16) as the texel's four bytes, opaque.
fn texel_of(rgb: u32) -> u32 {
    var bytes = rgb;
    if (E.bgra != 0u) {
        bytes = ((rgb & 0xffu) << 16u) | (rgb & 0xff00u) | ((rgb >> 16u) & 0xffu);
    }
    return bytes | 0xff000000u;
}

// One invocation per pixel of the tile, writing its block: no division, which a CPU
// driver's vector units do lane by lane (a pass with an invocation per texel, dividing
// its coordinates by the scale, took lavapipe twice as long at a scale of 3).
@compute @workgroup_size(16, 16)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= E.width || id.y >= E.rows) {
        return;
    }
    let pixel = (id.y * E.width + id.x) * E.stride;
    let first = pixels[pixel];
    if (first == CUT_SHORT_WORD || first == BEYOND_REACH_WORD) {
        atomicOr(&handed_over, 1u);
    }
    let texel = texel_of(first);
    let x0 = id.x * E.scale;
    let y0 = (E.first_row + id.y) * E.scale;
    let x1 = min(x0 + E.scale, E.target_width);
    let y1 = min(y0 + E.scale, E.target_height);
    for (var y = y0; y < y1; y++) {
        for (var x = x0; x < x1; x++) {
            texels[y * E.row_texels + x] = texel;
        }
    }
}
