// uses: host, params, stats, ray, triangle, closest
// Screen-space bins (gpu::binning): the BIN_COLUMNS × BIN_ROWS pixels of a bin walk one list
// of candidates, nearest first, the same for every invocation, in packets of PACKET rays.

// The bin of pixel column i in image row `row` (from the top), in the band of bin rows
// bound for this dispatch (gpu::binning::Bins::band).
fn bin_of(i: u32, row: u32) -> u32 {
    return (row / BIN_ROWS - P.first_bin_row) * P.bin_columns + i / BIN_COLUMNS;
}

// The packet's rays and closest hits so far. Code over them is written out for each of the
// PACKET rays (a function called with rows 0 … 3), never a loop: lavapipe lowers a loop's
// indexing of these arrays before it unrolls the loop, and that made the pipeline of
// `main_bins` take 29 ms longer to create (docs/lavapipe.md); a loop would also count
// against its 65535 iterations per invocation.
var<private> packet_rays: array<Ray, PACKET>;
var<private> packet_hits: array<Closest, PACKET>;
const_assert PACKET == 4u;

// Whether a packet of pixels in column x and rows y0 … y1 of a bin (all relative to the
// bin's corner) lies outside an item's pixel rectangle (BinItem.pixels): then none of its
// rays can meet the item, and the item is not even loaded.
fn packet_misses(pixels: u32, x: u32, y0: u32, y1: u32) -> bool {
    let c0 = pixels & 0xffu;
    let r0 = (pixels >> 8u) & 0xffu;
    let c1 = (pixels >> 16u) & 0xffu;
    let r1 = pixels >> 24u;
    return x < c0 || x > c1 || y1 < r0 || y0 > r1;
}

// Row r of the packet against a triangle from the bins (the watertight test's primary-ray
// form), or against any primitive by reference.
fn test_eye(r: u32, tri: EyeTriangle, reference: u32, tmin: f32) {
    count(COUNT_TESTS);
    packet_hits[r] = nearer(packet_hits[r], eye_triangle_t(tri, packet_rays[r], tmin), KIND_TRIANGLE, reference);
}

fn test_ref(r: u32, reference: u32, shear: Shear, tmin: f32) {
    packet_hits[r] = try_ref(reference, packet_rays[r], shear, tmin, packet_hits[r], true);
}

// The farthest of the packet's closest hits so far: no item nearer than it can change one.
fn packet_farthest() -> f32 {
    return max(max(packet_hits[0].t, packet_hits[1].t), max(packet_hits[2].t, packet_hits[3].t));
}

// The closest hits of the packet (pixels of column `column`, image rows `first_row` …
// `last_row`, all in one bin) among the primitives listed in its bin, nearest first. Each
// item is loaded once and tested against the PACKET rays (on lavapipe a load costs a gather
// per lane group even when every lane reads one address: docs/lavapipe.md), unless none of
// the packet's pixels is in its rectangle; the walk stops once every ray's closest hit is
// nearer than the next item can be.
fn walk_bin_packet(column: u32, first_row: u32, last_row: u32, tmin: f32) {
    let range = bin_ranges[bin_of(column, first_row)];
    let x = column % BIN_COLUMNS;
    let y0 = first_row % BIN_ROWS;
    let y1 = last_row % BIN_ROWS;
    // Triangles alone, with the watertight test: every item takes test_eye.
    let eye_only = !HAS_SPHERES && !HAS_ELLIPSOIDS && TRIANGLE_TEST == TRIANGLE_WATERTIGHT;
    var shears: array<Shear, PACKET>;
    if (!eye_only) {
        shears = array<Shear, PACKET>(
            shear_for(packet_rays[0].direction),
            shear_for(packet_rays[1].direction),
            shear_for(packet_rays[2].direction),
            shear_for(packet_rays[3].direction),
        );
    }
    for (var k = range.x; k < range.x + range.y; k++) {
        let item = bin_items[k];
        if (bitcast<f32>(item.words[ITEM_NEAR]) > packet_farthest()) {
            break;
        }
        if (packet_misses(item.words[ITEM_PIXELS], x, y0, y1)) {
            continue;
        }
        let reference = item.words[ITEM_REFERENCE];
        if (eye_only) {
            let tri = eye_triangles[reference];
            test_eye(0u, tri, reference, tmin);
            test_eye(1u, tri, reference, tmin);
            test_eye(2u, tri, reference, tmin);
            test_eye(3u, tri, reference, tmin);
            continue;
        }
        test_ref(0u, reference, shears[0], tmin);
        test_ref(1u, reference, shears[1], tmin);
        test_ref(2u, reference, shears[2], tmin);
        test_ref(3u, reference, shears[3], tmin);
    }
}

// The walk of main_bins_shared, where the subgroup is exactly one row of a bin's packets
// (BIN_COLUMNS lanes, lane j in column j: the host chooses it only on such adapters,
// gpu::GpuRenderer::shares_bin_loads). Every lane walks the same list, and lavapipe loads a
// storage buffer lane by lane even where the address is the same for all (docs/lavapipe.md):
// so each lane loads one word of the item and two of its triangle, and broadcasts hand
// every word to every lane (a register move), 3 loads where `walk_bin_packet` makes 19. The
// lanes stay in step: the walk stops when every lane's packet is done (subgroupMax), and a
// lane outside the image walks with the others (`inside` false: it never holds the walk).
fn walk_bin_shared(column: u32, first_row: u32, lane: u32, inside: bool, tmin: f32) {
    let range = bin_ranges[bin_of(column, first_row)];
    for (var k = range.x; k < range.x + range.y; k++) {
        // Lane 0 loads the reference, the others the near bound.
        let word = bin_items[k].words[min(lane, ITEM_NEAR)];
        let near = bitcast<f32>(subgroupBroadcast(word, ITEM_NEAR));
        let farthest = select(0.0, packet_farthest(), inside);
        if (near > subgroupMax(farthest)) {
            break;
        }
        let reference = subgroupBroadcast(word, ITEM_REFERENCE);
        let low = eye_triangles[reference].rows[lane / 4u][lane % 4u];
        let high = eye_triangles[reference].rows[2u + lane / 4u][lane % 4u];
        let tri = EyeTriangle(array<vec4<f32>, 4>(
            vec4<f32>(subgroupBroadcast(low, 0u), subgroupBroadcast(low, 1u), subgroupBroadcast(low, 2u), subgroupBroadcast(low, 3u)),
            vec4<f32>(subgroupBroadcast(low, 4u), subgroupBroadcast(low, 5u), subgroupBroadcast(low, 6u), subgroupBroadcast(low, 7u)),
            vec4<f32>(subgroupBroadcast(high, 0u), subgroupBroadcast(high, 1u), subgroupBroadcast(high, 2u), subgroupBroadcast(high, 3u)),
            vec4<f32>(subgroupBroadcast(high, 4u), subgroupBroadcast(high, 5u), subgroupBroadcast(high, 6u), subgroupBroadcast(high, 7u)),
        ));
        test_eye(0u, tri, reference, tmin);
        test_eye(1u, tri, reference, tmin);
        test_eye(2u, tri, reference, tmin);
        test_eye(3u, tri, reference, tmin);
    }
}
