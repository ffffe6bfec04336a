// uses: host, params, stats, ray, plane, closest, bvh, grid
// The any-hit query, for shadow rays: whether anything lies between a point and a light.
// A kernel without SHADOWS never calls it, so its pipeline does not compile it.

// Whether the ray meets anything at some t in (tmin, tmax), returning at the first hit
// found. Each primitive is tested as the closest-hit search tests it, with tmax as the
// closest hit so far. Without the hierarchy (flat loops, or bins, which hold primary rays
// only) every primitive is a candidate.
fn occluded(ray: Ray, tmin: f32, tmax: f32) -> bool {
    count(COUNT_SHADOW_RAYS);
    let bound = Closest(tmax, KIND_TRIANGLE, 0u);
    if (HAS_PLANES) {
        for (var k = 0u; k < P.num_planes; k++) {
            count(COUNT_TESTS);
            if (plane_t(planes[k], ray, tmin) < tmax) {
                return true;
            }
        }
    }
    let shear = shear_for(ray.direction);
    if (USE_GRID) {
        return grid_any(ray, shear, tmin, tmax);
    }
    if (USE_BVH) {
        return traverse_any(ray, shear, tmin, tmax);
    }
    if (HAS_SPHERES) {
        for (var k = 0u; k < P.num_spheres; k++) {
            if (try_sphere(k, ray, tmin, bound).t < tmax) {
                return true;
            }
        }
    }
    if (HAS_ELLIPSOIDS) {
        for (var k = 0u; k < P.num_ellipsoids; k++) {
            if (try_ellipsoid(k, ray, tmin, bound).t < tmax) {
                return true;
            }
        }
    }
    if (HAS_TRIANGLES) {
        for (var k = 0u; k < P.num_triangles; k++) {
            if (try_triangle(k, ray, shear, tmin, bound).t < tmax) {
                return true;
            }
        }
    }
    return false;
}
