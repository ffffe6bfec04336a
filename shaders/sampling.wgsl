// uses: host, params, stats, exact, ray, camera, closest, bins, tree
// Supersampling (docs/SPEC.md §8): where a pixel's samples lie, the same positions as
// raycaster::sampling on the host, their rays, and the words a traced sample leaves in
// `samples`. Reached only from `main_samples`, `main_samples_bins` and `main_filter`
// (shaders/entry.wgsl): a render without sampling compiles none of it.

// gpu::layout::GpuSampling: the sampler, the filter and the rows of samples a tile holds.
struct Sampling {
    // Samples per pixel, the side of the regular patterns' grid, the seed, and the pattern
    // (raycaster::sampling::Sampler::kind: 0 uniform, 1 random, 2 jittered).
    count: u32,
    side: u32,
    seed: u32,
    kind: u32,
    // raycaster::sampling::Filter::kind (0 box, 1 tent, 2 gaussian), its support radius in
    // pixels and its radius or sigma.
    filter_kind: u32,
    radius: u32,
    parameter: f32,
    // The first image row (from the top) of the samples in `samples`, and how many rows.
    first_row: u32,
    rows: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Words of one sample in `samples`: flags (1 hit, 2 its loops cut short, 4 a texture
// blended beyond its reach: the host renders the pixels it reaches again), colour, normal, t.
const SAMPLE_WORDS: u32 = 8u;

// The bindings `samples` and `sampling` are in params.wgsl, with the others.

// PCG's output hash (Jarzynski & Olano 2020), raycaster::sampling::pcg.
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A hashed word as a number in [0, 1): its top 24 bits times 2^-24, exact in f32.
fn unit(u: u32) -> f32 {
    return f32(u >> 8u) * (1.0 / 16777216.0);
}

// Sample k of pixel (i from the left, j from the bottom), pixel-local in [0, 1)², y up:
// raycaster::sampling::Sampler::position.
fn sample_position(i: u32, j: u32, k: u32) -> vec2<f32> {
    let m = sampling.side;
    let cell = vec2<f32>(f32(k % m), f32(k / m));
    if (sampling.kind == 0u) {
        return (cell + 0.5) / f32(m);
    }
    let h = pcg(pcg(pcg(pcg(sampling.seed) + i) + j) + k);
    let offset = vec2<f32>(unit(h), unit(pcg(h)));
    if (sampling.kind == 1u) {
        return offset;
    }
    return (cell + offset) / f32(m);
}

// The ray through the point p (pixel-local, y up) of pixel (i, j): camera::PrimaryRays::ray_at.
fn primary_ray_at(i: u32, j: u32, p: vec2<f32>) -> Ray {
    let longer = f32(max(P.width, P.height));
    let x = (f32(i) + p.x - rounded(0.5 * f32(P.width))) / longer;
    let y = (f32(j) + p.y - rounded(0.5 * f32(P.height))) / longer;
    return ray_through(x, y);
}

// The ray of sample k of pixel (i, j). A uniform sample's screen coordinates come from whole
// numbers, x = ((2i − W)·m + 2a + 1) / (2·m·longer) for column a of the m × m grid, exact
// but for the one division: mirrored samples get exactly mirrored rays, and a sample on a
// symmetric edge stays on it (camera::PrimaryRays::grid_ray in f64; docs/SPEC.md §8).
fn sample_ray(i: u32, j: u32, k: u32) -> Ray {
    if (sampling.kind != 0u) {
        return primary_ray_at(i, j, sample_position(i, j, k));
    }
    let m = sampling.side;
    let nx = i32(2u * i * m + 2u * (k % m) + 1u) - i32(P.width * m);
    let ny = i32(2u * j * m + 2u * (k / m) + 1u) - i32(P.height * m);
    let scale = f32(2u * m * max(P.width, P.height));
    return ray_through(f32(nx) / scale, f32(ny) / scale);
}

// Slot q of a packet of `main_samples_bins` (see there): its ray and nearest plane; returns
// its image row and sample.
fn start_sample(q: u32, i: u32, base: u32, first: u32, per_row: u32, rows: u32, tmin: f32) -> vec2<u32> {
    let row = min(q / per_row, rows - 1u);
    let image_row = base + row;
    let sample = first + q - row * per_row;
    let j = P.height - 1u - image_row;
    let k = min(sample, sampling.count - 1u);
    packet_rays[q] = sample_ray(i, j, k);
    if (sample_is_written(image_row, sample) && row_is_in_tile(image_row)) {
        count(COUNT_RAYS);
    }
    packet_hits[q] = closest_plane(packet_rays[q], tmin);
    return vec2<u32>(image_row, sample);
}

// Writes a slot's sample (image row and sample `at`) where the tile holds it.
fn finish_sample(i: u32, at: vec2<u32>, shaded: Shaded, cut: bool) {
    if (sample_is_written(at.x, at.y)) {
        write_sample(i, at.x - sampling.first_row, at.y, shaded, cut);
    }
}

// Rows of one column a packet of `main_samples_bins` holds: PACKET / count for 1 or 2
// samples a pixel, 1 otherwise (3 samples: three and a repeat).
fn packet_rows() -> u32 {
    return max(1u, PACKET / sampling.count);
}

// Whether image row `row`'s sample k is one of the samples the tile holds.
fn sample_is_written(row: u32, k: u32) -> bool {
    return row >= sampling.first_row && row < sampling.first_row + sampling.rows && k < sampling.count;
}

// Whether image row `row` is one of the tile's own rows, not of the filter's overlap.
fn row_is_in_tile(row: u32) -> bool {
    return row >= P.first_row && row < P.first_row + P.tile_rows;
}

fn write_sample(i: u32, r: u32, k: u32, shaded: Shaded, cut: bool) {
    let w = ((r * P.width + i) * sampling.count + k) * SAMPLE_WORDS;
    samples[w] = select(0u, 1u, shaded.hit) | select(0u, 2u, cut) | select(0u, 4u, shaded.beyond_reach);
    samples[w + 1u] = bitcast<u32>(shaded.color.x);
    samples[w + 2u] = bitcast<u32>(shaded.color.y);
    samples[w + 3u] = bitcast<u32>(shaded.color.z);
    samples[w + 4u] = bitcast<u32>(shaded.normal.x);
    samples[w + 5u] = bitcast<u32>(shaded.normal.y);
    samples[w + 6u] = bitcast<u32>(shaded.normal.z);
    samples[w + 7u] = bitcast<u32>(shaded.t);
}

// -stats: a row of the filter's overlap is traced again as a row of its own tile, and
// counted there; a sample cut short, by the reference that renders its pixels again.
fn flush_sample_counts(id: vec3<u32>, r: u32, cut: bool) {
    if (!cut && row_is_in_tile(sampling.first_row + r)) {
        flush_counts(stats_slot(id));
    }
}
