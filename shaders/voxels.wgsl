// uses: params, stats, exact, ray, grid, shading, tree
// The voxel picture (-visualize_grid; VOXELS; docs/SPEC.md §7, as cpu::Reference::
// voxel_pixel draws it): a primary ray shows the first occupied cell the 3D-DDA of
// shaders/grid.wgsl finds, as an opaque box. The host's grid for it is the reference's
// occupancy (gpu::voxels): bin_ranges holds each cell's (0, number of items).

// The outward normal of the face a ray along `d` enters a cell through, moving along
// `axis`: against the direction's component there.
fn face_towards(d: vec3<f32>, axis: u32) -> vec3<f32> {
    var n = vec3<f32>(0.0);
    n[axis] = -sign(d[axis]);
    return n;
}

// The axis of the largest of three values, the first of equal ones (the reference's
// min_by/max_position order).
fn largest_axis(v: vec3<f32>) -> u32 {
    if (v.x >= v.y && v.x >= v.z) {
        return 0u;
    }
    return select(2u, 1u, v.y >= v.z);
}

// The axis whose boundary the march crosses next (march_step's choice).
fn stepping_axis(t_next: vec3<f32>) -> u32 {
    if (t_next.x <= t_next.y && t_next.x <= t_next.z) {
        return 0u;
    }
    return select(2u, 1u, t_next.y <= t_next.z);
}

// The face a ray enters the grid's box through: the slab it enters last, when it enters
// at or after tmin; a ray starting inside the box sees the face against its largest
// direction component.
fn entry_face(ray: Ray, tmin: f32) -> vec3<f32> {
    let lo = P.grid_min;
    let hi = P.grid_min + rounded3(P.grid_cell * vec3<f32>(f32(P.grid_nx), f32(P.grid_ny), f32(P.grid_nz)));
    let still = ray.direction == vec3<f32>(0.0);
    let d = select(ray.direction, vec3<f32>(1.0), still);
    let near = select(min((lo - ray.origin) / d, (hi - ray.origin) / d), vec3<f32>(-F32_MAX), still);
    let t_in = max(near.x, max(near.y, near.z));
    if (t_in >= tmin) {
        return face_towards(ray.direction, largest_axis(near));
    }
    return face_towards(ray.direction, largest_axis(abs(ray.direction)));
}

// docs/SPEC.md §7: a cell's colour by how many items it holds, in bands that double:
// 1–2 magenta, 3–4 blue, 5–8 cyan, 9–16 green, 17–32 yellow, more red (cpu::voxel_color).
fn voxel_color(count: u32) -> vec3<f32> {
    var bands = array<vec3<f32>, 6>(
        vec3<f32>(1.0, 0.0, 1.0),
        vec3<f32>(0.0, 0.0, 1.0),
        vec3<f32>(0.0, 1.0, 1.0),
        vec3<f32>(0.0, 1.0, 0.0),
        vec3<f32>(1.0, 1.0, 0.0),
        vec3<f32>(1.0, 0.0, 0.0),
    );
    // ⌈log₂ count⌉ − 1, at least 0: 1 and 2 → 0, 3 and 4 → 1, 5…8 → 2, …
    let band = u32(firstLeadingBit(max(count, 2u) - 1u));
    return bands[min(band, 5u)];
}

// The cell's colour times the ambient light plus each light's diffuse term at the point
// where the ray enters it (no specular term, no shadow, no secondary ray).
fn voxel_shade(count: u32, point: vec3<f32>, n: vec3<f32>, ray: Ray) -> vec3<f32> {
    let diffuse = voxel_color(count);
    let material = Material(diffuse, 0.0, vec3<f32>(0.0), 1.0, vec3<f32>(0.0), 0u, vec3<f32>(0.0), 0u);
    var color = P.ambient * diffuse;
    for (var k = 0u; k < light_count(); k++) {
        color += local(material, n, incoming(light_at(k), point), -ray.direction);
    }
    return color;
}

// What a primary ray shows of the grid: the first occupied cell, or the background.
fn voxel_pixel(ray: Ray) -> Shaded {
    count(COUNT_RAYS);
    let tmin = t_min();
    let span = grid_span(ray, tmin, F32_MAX);
    if (span.x > span.y) {
        return Shaded(false, P.background, vec3<f32>(0.0), 0.0, false);
    }
    var m = march_start(ray, span.x);
    var t_enter = span.x;
    var n = entry_face(ray, tmin);
    loop {
        let range = march_cell(ray, &m, span.y);
        if (range.y > 0u) {
            var color = vec3<f32>(0.0);
            if (WANT_COLOR) {
                color = voxel_shade(range.y, along(ray.origin, t_enter, ray.direction), n, ray);
            }
            return Shaded(true, color, n, t_enter, false);
        }
        n = face_towards(ray.direction, stepping_axis(m.t_next));
        t_enter = m.t_exit;
        if (!march_step(&m, span.y)) {
            break;
        }
    }
    return Shaded(false, P.background, vec3<f32>(0.0), 0.0, false);
}
