// uses: host, params, stats, ray, camera, closest, bins, nearest, shading, tree, voxels, output, sampling, filter
// The entry points. `main` renders one pixel per invocation; `main_bins` a packet of
// PACKET pixels stacked in a column, so that every primitive loaded from a bin is tested
// against PACKET rays; `main_bins_shared` the same, its subgroup's lanes sharing the
// loads; with sampling (docs/SPEC.md §8), `main_samples` one sample per invocation
// (`main_samples_bins` a packet of them, with bins) and `main_filter` one output pixel from
// the samples. All in this file, so that what a dispatch runs is found from its name
// (gpu::KernelConfig::entry_point). Without bins an invocation stays at one pixel: lavapipe
// stops an invocation's loops after 65535 iterations in all (docs/lavapipe.md), which
// PACKET flat walks over many primitives would reach. Separate entry points, not an
// override: wgpu compiles only what the chosen one reaches, and lavapipe would otherwise
// compile the others' code before dropping it. (The host's gpu::KernelConfig::packet and
// entry_point.)

// Whether the driver's loop limit was reached (docs/lavapipe.md): lavapipe counts the
// iterations of all of an invocation's loops together and, past its limit, lets each loop
// run one pass and no more. A loop of LOOP_CANARY_TRIPS = 2 passes (a count the compiler
// cannot see) then runs once.
fn loops_were_cut() -> bool {
    var passes = 0u;
    for (var k = 0u; k < P.loop_canary_trips; k++) {
        passes += 1u;
    }
    return passes != P.loop_canary_trips;
}

// Writes tile-local row `row` of column i, when it belongs to this tile; handed over to the
// host's reference when the invocation's loops were cut short (`cut`) or a texture was
// beyond its reach.
fn write_row(i: u32, row: i32, shaded: Shaded, cut: bool) {
    if (row < 0 || row >= i32(P.tile_rows)) {
        return;
    }
    var handover = HANDOVER_NONE;
    if (cut) {
        handover = HANDOVER_LOOPS;
    } else if (shaded.beyond_reach) {
        handover = HANDOVER_REACH;
    }
    write_pixel(u32(row) * P.width + i, shaded.hit, shaded.color, shaded.normal, shaded.t, handover);
}

// What a primary ray (a pixel's or a sample's) shows: the scene shaded, or with
// -visualize_grid the grid's occupied cells (voxels.wgsl).
fn primary_ray_sees(ray: Ray) -> Shaded {
    if (VOXELS) {
        return voxel_pixel(ray);
    }
    return shade_pixel(ray, closest_hit(ray, t_min()));
}

@compute @workgroup_size(WORKGROUP, WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let row = id.y;
    if (i >= P.width || row >= P.tile_rows) {
        return;
    }
    let ray = ray_of_row(i, P.first_row + row);
    load_shading_data();
    let shaded = primary_ray_sees(ray);
    let cut = LOOP_CANARY && loops_were_cut();
    write_row(i, i32(row), shaded, cut);
    // A pixel cut short is rendered again, and counted, by the reference.
    if (!cut) {
        flush_counts(stats_slot(id));
    }
}

// Row r of a packet starting at image row `base` (tile-relative `first`): its ray and its
// nearest plane. A row outside the tile is traced with its packet but not a pixel of it:
// its ray is not counted (its tests are: the kernel ran them).
fn start_row(r: u32, i: u32, base: u32, first: i32, tmin: f32) {
    packet_rays[r] = ray_of_row(i, base + r);
    if (u32(first + i32(r)) < P.tile_rows) {
        count(COUNT_RAYS);
    }
    packet_hits[r] = closest_plane(packet_rays[r], tmin);
}

// Image rows base + PACKET·y … + PACKET − 1, where base is the tile's first row rounded
// down to a multiple of PACKET, so that a packet never straddles two bins (BIN_ROWS rows, a
// multiple of PACKET) whatever the tile.
@compute @workgroup_size(WORKGROUP, WORKGROUP)
fn main_bins(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let base = P.first_row - P.first_row % PACKET + id.y * PACKET;
    let first = i32(base) - i32(P.first_row);
    if (i >= P.width || first >= i32(P.tile_rows)) {
        return;
    }
    let tmin = t_min();
    start_row(0u, i, base, first, tmin);
    start_row(1u, i, base, first, tmin);
    start_row(2u, i, base, first, tmin);
    start_row(3u, i, base, first, tmin);
    walk_bin_packet(i, base, base + PACKET - 1u, tmin);
    finish_packet(i, first, stats_slot(id), false);
}

// The packet of column i, tile-relative rows first … first + 3, shaded (after the lights
// are loaded once for them all) and written, or handed over to the host's reference where
// the driver cut its loops short or `untrusted`; its counts added into `slot`.
fn finish_packet(i: u32, first: i32, slot: u32, untrusted: bool) {
    load_shading_data();
    let s0 = shade_pixel(packet_rays[0], packet_hits[0]);
    let s1 = shade_pixel(packet_rays[1], packet_hits[1]);
    let s2 = shade_pixel(packet_rays[2], packet_hits[2]);
    let s3 = shade_pixel(packet_rays[3], packet_hits[3]);
    // One canary for the invocation, after all of its loops: past the limit only the first
    // canary runs short, a second one runs in full (tests/loop_limit.rs found the packet's
    // last three rows wrong and unmarked with one canary per row).
    let cut = (LOOP_CANARY && loops_were_cut()) || untrusted;
    write_row(i, first, s0, cut);
    write_row(i, first + 1, s1, cut);
    write_row(i, first + 2, s2, cut);
    write_row(i, first + 3, s3, cut);
    if (!cut) {
        flush_counts(slot);
    }
}

// As main_bins, on adapters whose subgroups are exactly BIN_COLUMNS lanes (lavapipe): the
// subgroup is one row of a bin's packets, lane j in column j (so the pixels are chosen from
// the subgroup's own numbering, whatever order the driver gives its invocations), and the
// lanes share each item's loads (walk_bin_shared). Triangles only, with the watertight
// test: the host chooses it only then (gpu::KernelConfig::entry_point). The workgroups are
// main_bins' (WORKGROUP columns by WORKGROUP packet rows, dispatched alike) laid out in one
// dimension, which subgroup builtins require.
const_assert WORKGROUP == BIN_COLUMNS;
@compute @workgroup_size(WORKGROUP * WORKGROUP)
fn main_bins_shared(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(subgroup_id) subgroup: u32,
    @builtin(subgroup_invocation_id) lane: u32,
    @builtin(subgroup_size) lanes: u32,
) {
    P = params;
    let i = group.x * BIN_COLUMNS + lane;
    let packet_row = group.y * WORKGROUP + subgroup;
    let base = P.first_row - P.first_row % PACKET + packet_row * PACKET;
    let first = i32(base) - i32(P.first_row);
    // The whole subgroup or none of it: its lanes share a packet row.
    if (first >= i32(P.tile_rows)) {
        return;
    }
    // A lane beyond the image's last column walks with the others and writes nothing.
    let inside = i < P.width;
    let tmin = t_min();
    start_row(0u, i, base, first, tmin);
    start_row(1u, i, base, first, tmin);
    start_row(2u, i, base, first, tmin);
    start_row(3u, i, base, first, tmin);
    walk_bin_shared(i, base, lane, inside, tmin);
    if (!inside) {
        return;
    }
    // The host chose this kernel for subgroups of BIN_COLUMNS lanes; should the driver
    // run others, the lanes did not walk one bin together: the reference renders the pixels.
    finish_packet(i, first, stats_slot(vec3<u32>(i, packet_row, 0u)), lanes != BIN_COLUMNS);
}

// One sample per invocation: x the column, y the row of samples, z the sample's index.
// Neighbouring invocations trace the same sample of neighbouring pixels, rays a pixel apart.
@compute @workgroup_size(WORKGROUP, WORKGROUP)
fn main_samples(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let r = id.y;
    let k = id.z;
    if (i >= P.width || r >= sampling.rows || k >= sampling.count) {
        return;
    }
    let j = P.height - 1u - (sampling.first_row + r);
    let ray = sample_ray(i, j, k);
    load_shading_data();
    let shaded = primary_ray_sees(ray);
    let cut = LOOP_CANARY && loops_were_cut();
    write_sample(i, r, k, shaded, cut);
    flush_sample_counts(id, r, cut);
}

// With bins: a packet of PACKET samples per invocation, which walk one bin together. A bin
// lists what any ray through its pixels can meet, anywhere in them
// (gpu::binning::Bins::build, its `reach`). With PACKET samples or more a pixel, a packet holds samples
// PACKET·z … of one pixel (one past the last repeats it, traced but not written); with
// fewer (1 or 2), every sample of PACKET / count rows of one column, as `main_bins` stacks
// rows, the rows starting at a multiple of that count so that a packet never straddles two
// bins (BIN_ROWS rows, a multiple of PACKET).
@compute @workgroup_size(WORKGROUP, WORKGROUP)
fn main_samples_bins(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let per_row = min(sampling.count, PACKET);
    let rows = packet_rows();
    let base = sampling.first_row - sampling.first_row % rows + id.y * rows;
    let first = id.z * PACKET;
    if (i >= P.width || base >= sampling.first_row + sampling.rows || first >= sampling.count) {
        return;
    }
    let tmin = t_min();
    // Each slot written out, as in main_bins (no loop indexes the packet's arrays).
    let at0 = start_sample(0u, i, base, first, per_row, rows, tmin);
    let at1 = start_sample(1u, i, base, first, per_row, rows, tmin);
    let at2 = start_sample(2u, i, base, first, per_row, rows, tmin);
    let at3 = start_sample(3u, i, base, first, per_row, rows, tmin);
    walk_bin_packet(i, base, base + rows - 1u, tmin);
    load_shading_data();
    let s0 = shade_pixel(packet_rays[0], packet_hits[0]);
    let s1 = shade_pixel(packet_rays[1], packet_hits[1]);
    let s2 = shade_pixel(packet_rays[2], packet_hits[2]);
    let s3 = shade_pixel(packet_rays[3], packet_hits[3]);
    // One canary after all of the invocation's loops, as in main_bins.
    let cut = LOOP_CANARY && loops_were_cut();
    finish_sample(i, at0, s0, cut);
    finish_sample(i, at1, s1, cut);
    finish_sample(i, at2, s2, cut);
    finish_sample(i, at3, s3, cut);
    // The packet's rows that are the tile's (not the filter's overlap) count its tests.
    if (!cut && base < P.first_row + P.tile_rows && base + rows > P.first_row) {
        flush_counts(stats_slot(id));
    }
}

// One output pixel per invocation, tile-local row y.
@compute @workgroup_size(WORKGROUP, WORKGROUP)
fn main_filter(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let row = id.y;
    if (i >= P.width || row >= P.tile_rows) {
        return;
    }
    let image_row = i32(P.first_row + row);
    let radius = i32(sampling.radius);
    let n = sampling.count;
    var sum = FilterSum(0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, 0u);
    for (var dr = -radius; dr <= radius; dr++) {
        let row2 = image_row + dr;
        if (row2 < 0 || row2 >= i32(P.height)) {
            continue;
        }
        let j2 = P.height - 1u - u32(row2);
        for (var di = -radius; di <= radius; di++) {
            let i2 = i32(i) + di;
            if (i2 < 0 || i2 >= i32(P.width)) {
                continue;
            }
            let first = ((u32(row2) - sampling.first_row) * P.width + u32(i2)) * n;
            for (var k = 0u; k < n; k++) {
                // Rows run down the image; a sample's y runs up.
                let p = sample_position(u32(i2), j2, k);
                let w = filter_weight(f32(di) + p.x - 0.5, f32(-dr) + p.y - 0.5);
                add_sample(&sum, w, first + k);
            }
        }
    }
    if (sum.weight == 0.0) {
        // No sample weighs: the plain average of the pixel's own.
        sum = FilterSum(0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, sum.handover);
        let first = ((u32(image_row) - sampling.first_row) * P.width + i) * n;
        for (var k = 0u; k < n; k++) {
            add_sample(&sum, 1.0, first + k);
        }
    }
    let hit = sum.hit_weight > 0.0 && 2.0 * sum.hit_weight >= sum.weight;
    let per_hit = select(0.0, 1.0 / sum.hit_weight, sum.hit_weight > 0.0);
    let normal = select(vec3<f32>(0.0), sum.normal * per_hit, hit);
    let t = select(0.0, sum.depth * per_hit, hit);
    // A sample the kernel could not finish makes the pixel the reference's.
    var handover = HANDOVER_NONE;
    if ((sum.handover & 2u) != 0u || (LOOP_CANARY && loops_were_cut())) {
        handover = HANDOVER_LOOPS;
    } else if ((sum.handover & 4u) != 0u) {
        handover = HANDOVER_REACH;
    }
    write_pixel(row * P.width + i, hit, sum.color / sum.weight, normal, t, handover);
}
