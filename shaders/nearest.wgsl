// uses: params, stats, ray, closest, bvh, grid
// The nearest-hit query, for every ray but the primary rays of a kernel with bins, which
// walk their bin (shaders/bins.wgsl). A file of its own, after the searches it chooses
// among, as the any-hit query is (shaders/occluded.wgsl).

// The closest hit above tmin without bins: through the hierarchy, or flat loops over each
// kind.
fn closest_hit(ray: Ray, tmin: f32) -> Closest {
    count(COUNT_RAYS);
    var best = closest_plane(ray, tmin);
    // Only the watertight test reads the shear; otherwise the compiler drops it.
    let shear = shear_for(ray.direction);
    if (USE_GRID) {
        return grid_closest(ray, shear, tmin, best);
    }
    if (USE_BVH) {
        return traverse(ray, shear, tmin, best);
    }
    if (HAS_SPHERES) {
        for (var k = 0u; k < P.num_spheres; k++) {
            best = try_sphere(k, ray, tmin, best);
        }
    }
    if (HAS_ELLIPSOIDS) {
        for (var k = 0u; k < P.num_ellipsoids; k++) {
            best = try_ellipsoid(k, ray, tmin, best);
        }
    }
    if (HAS_TRIANGLES) {
        for (var k = 0u; k < P.num_triangles; k++) {
            best = try_triangle(k, ray, shear, tmin, best);
        }
    }
    return best;
}
