// uses: host, params, stats, ray, sphere, ellipsoid, plane, triangle
// The closest hit: the nearest t and what was hit, nothing more (the surface is built once,
// for the nearest hit only, by surface_at; pbrt-v4 splits intersection the same way).

// While nothing is hit, t is NO_HIT and kind and index mean nothing.
struct Closest {
    t: f32,
    kind: u32,
    index: u32,
}

fn no_hit() -> Closest {
    return Closest(NO_HIT, KIND_TRIANGLE, 0u);
}

// The closer of the hit so far and a hit at t on primitive `index` of `kind` (ties keep the
// earlier one).
fn nearer(best: Closest, t: f32, kind: u32, index: u32) -> Closest {
    if (t < best.t) {
        return Closest(t, kind, index);
    }
    return best;
}

fn try_sphere(k: u32, ray: Ray, tmin: f32, best: Closest) -> Closest {
    count(COUNT_TESTS);
    let s = spheres[k];
    let t = sphere_t(ray.origin - s.center, ray.direction, s.radius, tmin);
    return nearer(best, t, KIND_SPHERE, k);
}

fn try_ellipsoid(k: u32, ray: Ray, tmin: f32, best: Closest) -> Closest {
    count(COUNT_TESTS);
    let t = ellipsoid_t(ellipsoids[k], ray, tmin);
    return nearer(best, t, KIND_ELLIPSOID, k);
}

fn try_triangle(k: u32, ray: Ray, shear: Shear, tmin: f32, best: Closest) -> Closest {
    count(COUNT_TESTS);
    let t = triangle_t(triangles[k], ray, shear, tmin);
    return nearer(best, t, KIND_TRIANGLE, k);
}

fn try_eye_triangle(k: u32, ray: Ray, tmin: f32, best: Closest) -> Closest {
    count(COUNT_TESTS);
    let t = eye_triangle_t(eye_triangles[k], ray, tmin);
    return nearer(best, t, KIND_TRIANGLE, k);
}

// With bins, the watertight test takes its primary-ray form (the same guarantee, from
// planes computed once per frame); the other tests stay as they are, to be compared.
fn try_binned_triangle(k: u32, ray: Ray, shear: Shear, tmin: f32, best: Closest) -> Closest {
    if (TRIANGLE_TEST == TRIANGLE_WATERTIGHT) {
        return try_eye_triangle(k, ray, tmin, best);
    }
    return try_triangle(k, ray, shear, tmin, best);
}

// Tests the primitive a reference names (kind << REF_KIND_SHIFT | index; with triangles
// alone, the triangle index itself, since KIND_TRIANGLE is 0). `binned` selects the
// triangle test of a bin (try_binned_triangle) over the hierarchy's; every caller passes a
// constant, so the choice is folded away.
fn try_ref(r: u32, ray: Ray, shear: Shear, tmin: f32, best: Closest, binned: bool) -> Closest {
    let kind = select(r >> REF_KIND_SHIFT, KIND_TRIANGLE, !HAS_SPHERES && !HAS_ELLIPSOIDS);
    let index = select(r & ((1u << REF_KIND_SHIFT) - 1u), r, !HAS_SPHERES && !HAS_ELLIPSOIDS);
    var out = best;
    if (HAS_TRIANGLES && kind == KIND_TRIANGLE) {
        if (binned) {
            out = try_binned_triangle(index, ray, shear, tmin, out);
        } else {
            out = try_triangle(index, ray, shear, tmin, out);
        }
    }
    if (HAS_SPHERES && kind == KIND_SPHERE) {
        out = try_sphere(index, ray, tmin, out);
    }
    if (HAS_ELLIPSOIDS && kind == KIND_ELLIPSOID) {
        out = try_ellipsoid(index, ray, tmin, out);
    }
    return out;
}

// The nearest plane hit (planes are infinite and stay outside bins and the hierarchy; a
// near plane hit prunes them).
fn closest_plane(ray: Ray, tmin: f32) -> Closest {
    var best = no_hit();
    if (HAS_PLANES) {
        for (var k = 0u; k < P.num_planes; k++) {
            count(COUNT_TESTS);
            best = nearer(best, plane_t(planes[k], ray, tmin), KIND_PLANE, k);
        }
    }
    return best;
}
