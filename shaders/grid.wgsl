// uses: host, params, stats, exact, ray, closest
// The -grid (USE_GRID; docs/SPEC.md §7): finite primitives listed per cell of a uniform
// grid (gpu::flatten::GpuGrid), walked in order along the ray by the 3D-DDA of Amanatides
// and Woo (1987). Cell (x, y, z)'s list is prim_refs[first .. first + count] for
// bin_ranges[x + nx·(y + ny·z)] = (first, count): the grid takes the bins' bindings, which
// a grid render does not use.

// The ray's part inside the grid's box within (tmin, tmax), by the slab test (Kay and
// Kajiya 1986): (t_in, t_out), with t_in > t_out where it misses. A direction component of
// zero leaves its slab unbounded when the origin lies between the planes. A grid over
// nothing (planes alone) has cells of extent 0 and no box: every ray misses it, as the
// reference's march enters no cell.
fn grid_span(ray: Ray, tmin: f32, tmax: f32) -> vec2<f32> {
    if (P.grid_cell.x == 0.0) {
        return vec2<f32>(1.0, 0.0);
    }
    let lo = P.grid_min;
    let hi = P.grid_min + rounded3(P.grid_cell * vec3<f32>(f32(P.grid_nx), f32(P.grid_ny), f32(P.grid_nz)));
    let parallel = ray.direction == vec3<f32>(0.0);
    let d = select(ray.direction, vec3<f32>(1.0), parallel);
    let t0 = (lo - ray.origin) / d;
    let t1 = (hi - ray.origin) / d;
    let near = select(min(t0, t1), vec3<f32>(-F32_MAX), parallel);
    let far = select(max(t0, t1), vec3<f32>(F32_MAX), parallel);
    let outside = parallel & ((ray.origin < lo) | (ray.origin > hi));
    let t_in = max(max(near.x, near.y), max(near.z, tmin));
    let t_out = min(min(far.x, far.y), min(far.z, tmax));
    return select(vec2<f32>(t_in, t_out), vec2<f32>(1.0, 0.0), any(outside));
}

// Where the march stands: the cell, the step along each axis (−1, 0 or 1), and where the
// ray crosses the cell's next boundary along each axis and leaves the cell (march_cell).
struct March {
    cell: vec3<i32>,
    step: vec3<i32>,
    t_next: vec3<f32>,
    t_exit: f32,
}

// The first cell: the one holding the ray's point at t_in, clamped into the grid (rounding
// may put a point on the box's face just outside).
fn march_start(ray: Ray, t_in: f32) -> March {
    let n = vec3<i32>(i32(P.grid_nx), i32(P.grid_ny), i32(P.grid_nz));
    let p = along(ray.origin, t_in, ray.direction);
    let cell = clamp(vec3<i32>(floor((p - P.grid_min) / P.grid_cell)), vec3<i32>(0), n - 1);
    return March(cell, vec3<i32>(sign(ray.direction)), vec3<f32>(F32_MAX), F32_MAX);
}

// Enters the current cell: where the ray crosses its boundaries (F32_MAX along an axis it
// does not move along; recomputed from the cell index at each step rather than
// incremented as in the paper, so that the error does not grow with the steps taken) and
// leaves it (at most t_out); returns the cell's (first, count) in prim_refs. Counted as a
// cell traversed (-stats).
fn march_cell(ray: Ray, m: ptr<function, March>, t_out: f32) -> vec2<u32> {
    count(COUNT_CELLS);
    let boundary = (*m).cell + select(vec3<i32>(0), vec3<i32>(1), (*m).step > vec3<i32>(0));
    let plane = P.grid_min + rounded3(vec3<f32>(boundary) * P.grid_cell);
    let still = (*m).step == vec3<i32>(0);
    let d = select(ray.direction, vec3<f32>(1.0), still);
    let t_next = select((plane - ray.origin) / d, vec3<f32>(F32_MAX), still);
    (*m).t_next = t_next;
    (*m).t_exit = min(min(t_next.x, t_next.y), min(t_next.z, t_out));
    let c = vec3<u32>((*m).cell);
    return bin_ranges[c.x + P.grid_nx * (c.y + P.grid_ny * c.z)];
}

// One step to the neighbour across the nearest boundary; false once the ray's part in the
// grid ends in this cell or the march leaves the grid.
fn march_step(m: ptr<function, March>, t_out: f32) -> bool {
    let t_next = (*m).t_next;
    if ((*m).t_exit >= t_out) {
        return false;
    }
    if (t_next.x <= t_next.y && t_next.x <= t_next.z) {
        (*m).cell.x += (*m).step.x;
    } else if (t_next.y <= t_next.z) {
        (*m).cell.y += (*m).step.y;
    } else {
        (*m).cell.z += (*m).step.z;
    }
    let n = vec3<i32>(i32(P.grid_nx), i32(P.grid_ny), i32(P.grid_nz));
    return all((*m).cell >= vec3<i32>(0)) && all((*m).cell < n);
}

// The nearest hit through the grid, starting from `start` (the planes' nearest). A hit
// beyond the current cell is kept but does not end the march: a nearer one may lie in a
// later cell; once the nearest so far lies within the cells walked, none can.
fn grid_closest(ray: Ray, shear: Shear, tmin: f32, start: Closest) -> Closest {
    var best = start;
    let span = grid_span(ray, tmin, best.t);
    if (span.x > span.y) {
        return best;
    }
    var m = march_start(ray, span.x);
    loop {
        let range = march_cell(ray, &m, span.y);
        for (var k = range.x; k < range.x + range.y; k++) {
            best = try_ref(prim_refs[k], ray, shear, tmin, best, false);
        }
        if (best.t <= m.t_exit || !march_step(&m, span.y)) {
            break;
        }
    }
    return best;
}

// Whether any listed primitive is hit in (tmin, tmax), stopping at the first found.
fn grid_any(ray: Ray, shear: Shear, tmin: f32, tmax: f32) -> bool {
    let bound = Closest(tmax, KIND_TRIANGLE, 0u);
    let span = grid_span(ray, tmin, tmax);
    if (span.x > span.y) {
        return false;
    }
    var m = march_start(ray, span.x);
    loop {
        let range = march_cell(ray, &m, span.y);
        for (var k = range.x; k < range.x + range.y; k++) {
            if (try_ref(prim_refs[k], ray, shear, tmin, bound, false).t < tmax) {
                return true;
            }
        }
        if (!march_step(&m, span.y)) {
            break;
        }
    }
    return false;
}
