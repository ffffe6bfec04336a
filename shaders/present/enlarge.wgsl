// uses: host (gpu::present's constants, prepended)
// The live window's frame, on the device (src/gpu/present.rs): one tile of a render's
// packed words (gpu::layout::PixelLayout, packed) enlarged into the texels of the
// surface's rows, each pixel a `scale` × `scale` block, then copied onto the surface as
// bytes.
// Integer work only: the texels are the bytes an image file holds, and no float-to-unorm
// conversion (whose rounding a driver chooses) comes between; a depth's grey level is
// found by comparing its bits with bounds the host computed in f64. Not part of the kernel
// (src/gpu/shader.rs composes that from shaders/*.wgsl alone).

struct Enlarge {
    // Pixels per row of the rendered image.
    width: u32,
    // The tile's first image row, and its rows.
    first_row: u32,
    rows: u32,
    // Words per pixel; the first (colour, else normals, else the depth) is shown.
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
// For a depth: depth_bounds[k] is the largest ordered key (below) whose grey level is at
// least k (gpu::present::depth_bounds); [0] holds every key.
@group(0) @binding(4) var<storage, read> depth_bounds: array<u32, 256>;
// The ordered keys of the frame's nearest and farthest hit (`depth_bits`).
@group(0) @binding(5) var<storage, read_write> hit_range: array<atomic<u32>, 2>;

// A float's bits as a key that orders floats as unsigned integers: the sign bit flipped for
// positive numbers, every bit for negative ones (gpu::ordered::ordered_key).
fn ordered_key(bits: u32) -> u32 {
    return select(bits | 0x80000000u, ~bits, (bits >> 31u) == 1u);
}

// The grey level of the depth word `bits`, as image_io::depth_level gives it: the largest k
// whose bound the key does not pass (a binary search over the non-increasing bounds);
// black where nothing was hit.
fn depth_rgb(bits: u32) -> u32 {
    if (bits == 0xffffffffu) {
        return 0u;
    }
    let key = ordered_key(bits);
    var level = 0u;
    for (var step = 128u; step > 0u; step >>= 1u) {
        if (key <= depth_bounds[level + step]) {
            level += step;
        }
    }
    return level | (level << 8u) | (level << 16u);
}

// A packed colour or |N| (r | g << 8 | b << 16) as the texel's four bytes, opaque.
fn texel_of(rgb: u32) -> u32 {
    var bytes = rgb;
    if (E.bgra != 0u) {
        bytes = ((rgb & 0xffu) << 16u) | (rgb & 0xff00u) | ((rgb >> 16u) & 0xffu);
    }
    return bytes | 0xff000000u;
}

// The block of rendered pixel (x, image row y) in the target, cut at its edges.
fn fill_block(x: u32, y: u32, texel: u32) {
    let x0 = x * E.scale;
    let y0 = y * E.scale;
    let x1 = min(x0 + E.scale, E.target_width);
    let y1 = min(y0 + E.scale, E.target_height);
    for (var row = y0; row < y1; row++) {
        for (var column = x0; column < x1; column++) {
            texels[row * E.row_texels + column] = texel;
        }
    }
}

// Each view has its own entry point, which binds only what it uses: a CPU driver (llvmpipe)
// runs both sides of a branch under a mask, so a pass that chose the view by a branch paid
// for the depth's search and atomics on every colour pixel (docs/performance.md, "Frames
// drawn on the device"). One invocation per pixel of the tile, writing its block: no division,
// which a CPU driver's vector units do lane by lane (a pass with an invocation per texel,
// dividing its coordinates by the scale, took lavapipe twice as long at a scale of 3).

// Colour or |N|: each pixel's packed bytes as its block's texels.
@compute @workgroup_size(16, 16)
fn rgb(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= E.width || id.y >= E.rows) {
        return;
    }
    let first = pixels[(id.y * E.width + id.x) * E.stride];
    note_handed_over(first);
    fill_block(id.x, E.first_row + id.y, texel_of(first));
}

// The depth over a `-depth` range: each hit's t (its bits; all ones where nothing was hit)
// as its grey level, black where nothing was hit.
@compute @workgroup_size(16, 16)
fn depth_grey(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= E.width || id.y >= E.rows) {
        return;
    }
    let first = pixels[(id.y * E.width + id.x) * E.stride];
    note_handed_over(first);
    fill_block(id.x, E.first_row + id.y, texel_of(depth_rgb(first)));
}

// The depth over the frame's own hits (no `-depth` range): each depth kept as its bits
// while the nearest and farthest hit are gathered into `hit_range`, for `grey` to show
// once the host has the range.
@compute @workgroup_size(16, 16)
fn depth_bits(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= E.width || id.y >= E.rows) {
        return;
    }
    let first = pixels[(id.y * E.width + id.x) * E.stride];
    if (!note_handed_over(first) && first != 0xffffffffu) {
        let key = ordered_key(first);
        atomicMin(&hit_range[0], key);
        atomicMax(&hit_range[1], key);
    }
    fill_block(id.x, E.first_row + id.y, first);
}

// Whether the pixel whose first word is `first` was handed over to the reference, noted
// for the whole frame in `handed_over`.
fn note_handed_over(first: u32) -> bool {
    let handed = first == CUT_SHORT_WORD || first == BEYOND_REACH_WORD;
    if (handed) {
        atomicOr(&handed_over, 1u);
    }
    return handed;
}

// The depths kept by `depth_bits` turned grey once the host has written the bounds of
// the frame's range: one invocation per rendered pixel (`width` × `rows` of them, from
// the top), reading its block's first texel and writing the block.
@compute @workgroup_size(16, 16)
fn grey(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= E.width || id.y >= E.rows || id.x * E.scale >= E.target_width) {
        return;
    }
    let bits = texels[id.y * E.scale * E.row_texels + id.x * E.scale];
    fill_block(id.x, id.y, texel_of(depth_rgb(bits)));
}
