// Filters (docs/SPEC.md §8): each output pixel the weighted average of the samples of the
// pixels within the support radius, cropped at the image's border, as
// raycaster::cpu::Reference does it. Reached only from `main_filter`.

// raycaster::sampling::Filter::weight, at (dx, dy) pixels from the output pixel's centre.
fn filter_weight(dx: f32, dy: f32) -> f32 {
    let r = sampling.parameter;
    if (sampling.filter_kind == 0u) {
        return select(0.0, 1.0, abs(dx) <= r && abs(dy) <= r);
    }
    let d2 = rounded(dx * dx) + rounded(dy * dy);
    if (sampling.filter_kind == 1u) {
        return max(0.0, 1.0 - sqrt(d2) / r);
    }
    return exp(-d2 / (2.0 * r * r));
}

// A pixel being summed: Σw·colour over every sample; Σw·normal and Σw·t over the hits.
struct FilterSum {
    weight: f32,
    color: vec3<f32>,
    hit_weight: f32,
    normal: vec3<f32>,
    depth: f32,
    // The samples' handover flags, or-ed (2 loops cut short, 4 beyond a texture's reach).
    handover: u32,
}

fn add_sample(sum: ptr<function, FilterSum>, w: f32, index: u32) {
    let s = index * SAMPLE_WORDS;
    let flags = samples[s];
    let color = vec3<f32>(bitcast<f32>(samples[s + 1u]), bitcast<f32>(samples[s + 2u]), bitcast<f32>(samples[s + 3u]));
    (*sum).weight += w;
    (*sum).color += w * color;
    (*sum).handover |= flags & 6u;
    if ((flags & 1u) != 0u) {
        let normal =
            vec3<f32>(bitcast<f32>(samples[s + 4u]), bitcast<f32>(samples[s + 5u]), bitcast<f32>(samples[s + 6u]));
        (*sum).hit_weight += w;
        (*sum).normal += w * normal;
        (*sum).depth += w * bitcast<f32>(samples[s + 7u]);
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
