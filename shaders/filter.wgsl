// uses: host, exact, sampling
// Filters (docs/SPEC.md §8): each output pixel the weighted average of the samples of the
// pixels within the support radius, cropped at the image's border, as
// raycaster::cpu::Reference does it. Reached only from `main_filter` (shaders/entry.wgsl).

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
