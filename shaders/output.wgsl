// uses: host, params
// The words a pixel leaves in `pixels` (gpu::layout::PixelLayout decodes them).

// floor(255·clamp(v, 0, 1)) per channel, as image_io::quantize (NaN → 0; docs/SPEC.md §5),
// packed r | g << 8 | b << 16.
fn pack_rgb8(c: vec3<f32>) -> u32 {
    let q = vec3<u32>(floor(255.0 * clamp(select(c, vec3<f32>(0.0), c != c), vec3<f32>(0.0), vec3<f32>(1.0))));
    return q.x | (q.y << 8u) | (q.z << 16u);
}

// Why the host must render a pixel again with the reference, if it must: the driver cut
// the invocation's loops short, or a solid texture was blended beyond its reach.
const HANDOVER_NONE: u32 = 0u;
const HANDOVER_LOOPS: u32 = 1u;
const HANDOVER_REACH: u32 = 2u;

// The 8-bit images, one word each: colour, |N| (black on a miss), and t as bits for the
// host to quantise in f64 as the reference does (all ones on a miss). A pixel handed over
// is CUT_SHORT_WORD or BEYOND_REACH_WORD in its first word, which no output writes.
fn write_packed_pixel(index: u32, hit: bool, color: vec3<f32>, normal: vec3<f32>, t: f32, handover: u32) {
    var w = index * PIXEL_WORDS;
    if (handover != HANDOVER_NONE) {
        pixels[w] = select(BEYOND_REACH_WORD, CUT_SHORT_WORD, handover == HANDOVER_LOOPS);
        return;
    }
    if (WANT_COLOR) {
        pixels[w] = pack_rgb8(color);
        w += 1u;
    }
    if (WANT_NORMAL) {
        pixels[w] = select(0u, pack_rgb8(abs(normal)), hit);
        w += 1u;
    }
    if (WANT_DEPTH) {
        pixels[w] = select(0xffffffffu, bitcast<u32>(t), hit);
    }
}

// Writes one pixel: the hit flag (CUT_SHORT_HIT or BEYOND_REACH_HIT for a pixel handed
// over), then only the outputs asked for.
fn write_pixel(index: u32, hit: bool, color: vec3<f32>, normal: vec3<f32>, t: f32, handover: u32) {
    if (PACKED_8BIT) {
        write_packed_pixel(index, hit, color, normal, t, handover);
        return;
    }
    var w = index * PIXEL_WORDS;
    var flag = select(0u, 1u, hit);
    if (handover != HANDOVER_NONE) {
        flag = select(BEYOND_REACH_HIT, CUT_SHORT_HIT, handover == HANDOVER_LOOPS);
    }
    pixels[w] = flag;
    w += 1u;
    if (WANT_COLOR) {
        pixels[w] = bitcast<u32>(color.x);
        pixels[w + 1u] = bitcast<u32>(color.y);
        pixels[w + 2u] = bitcast<u32>(color.z);
        w += 3u;
    }
    if (WANT_NORMAL) {
        pixels[w] = bitcast<u32>(normal.x);
        pixels[w + 1u] = bitcast<u32>(normal.y);
        pixels[w + 2u] = bitcast<u32>(normal.z);
        w += 3u;
    }
    if (WANT_DEPTH) {
        pixels[w] = bitcast<u32>(t);
    }
}
