// uses: host, params, ray, closest
// The bounding volume hierarchy (src/bvh.rs): a box test and two walks, nearest hit and
// any hit.

// The hierarchy's depth bound (bvh::STACK_SIZE): the traversal stack cannot overflow.
const STACK_SIZE: u32 = 32u;
// 2·gamma(3) with gamma(n) = n·u/(1 − n·u), u = 2⁻²⁴ (bvh::SLAB_MARGIN).
const SLAB_MARGIN: f32 = 3.5762793e-7;

// Entry distance of the ray into a node's box within [tmin, tmax], or NO_HIT. Robust slab
// test: Ize, "Robust BVH Ray Traversal", JCGT 2(2) 2013 — both ends widened by 2·gamma(3)
// so that rounding never culls a box the exact ray meets (as bvh::ray_box_entry, which the
// tests check against brute force). Axes the ray is parallel to are decided by whether the
// origin lies within the slab, never by 0·∞.
fn box_entry(node: BvhNode, ray: Ray, inv: vec3<f32>, parallel: vec3<bool>, tmin: f32, tmax: f32) -> f32 {
    let towards = inv >= vec3<f32>(0.0);
    var near = (select(node.max, node.min, towards) - ray.origin) * inv;
    var far = (select(node.min, node.max, towards) - ray.origin) * inv;
    let inside = node.min <= ray.origin & ray.origin <= node.max;
    near = select(near, select(vec3<f32>(F32_MAX), vec3<f32>(-F32_MAX), inside), parallel);
    far = select(far, select(vec3<f32>(-F32_MAX), vec3<f32>(F32_MAX), inside), parallel);
    let n = max(max(near.x, near.y), near.z);
    let f = min(min(far.x, far.y), far.z);
    let entry = max(tmin, n * select(1.0 + SLAB_MARGIN, 1.0 - SLAB_MARGIN, n > 0.0));
    let exit = min(tmax, f * select(1.0 - SLAB_MARGIN, 1.0 + SLAB_MARGIN, f > 0.0));
    return select(NO_HIT, entry, entry <= exit);
}

// What leaf slot k holds: a prim_refs entry, or with triangles alone (reordered into leaf
// order by the host) the triangle index itself, one load fewer.
fn leaf_slot(k: u32) -> u32 {
    if (triangles_alone()) {
        return k;
    }
    return prim_refs[k];
}

// Closest hit through the hierarchy: a short fixed stack of (node, entry distance), the
// nearer child visited first, a popped node skipped when a closer hit was found after it
// was pushed (the traversal of bvh::Bvh::closest_hit).
fn traverse(ray: Ray, shear: Shear, tmin: f32, start: Closest) -> Closest {
    var best = start;
    let parallel = ray.direction == vec3<f32>(0.0);
    let inv = 1.0 / select(ray.direction, vec3<f32>(1.0), parallel);
    var stack_node: array<u32, STACK_SIZE>;
    var stack_entry: array<f32, STACK_SIZE>;
    var len = 0u;
    let root_entry = box_entry(nodes[0], ray, inv, parallel, tmin, best.t);
    if (root_entry < best.t) {
        stack_node[0] = 0u;
        stack_entry[0] = root_entry;
        len = 1u;
    }
    while (len > 0u) {
        len -= 1u;
        if (stack_entry[len] >= best.t) {
            continue;
        }
        let node = nodes[stack_node[len]];
        if (node.count > 0u) {
            for (var k = node.first; k < node.first + node.count; k++) {
                best = try_ref(leaf_slot(k), ray, shear, tmin, best, false);
            }
            continue;
        }
        let left = box_entry(nodes[node.first], ray, inv, parallel, tmin, best.t);
        let right = box_entry(nodes[node.first + 1u], ray, inv, parallel, tmin, best.t);
        let right_first = right < left;
        let near_node = select(node.first, node.first + 1u, right_first);
        let far_node = select(node.first + 1u, node.first, right_first);
        let near_entry = min(left, right);
        let far_entry = max(left, right);
        // The farther one first, so that the nearer one is popped next.
        if (far_entry < best.t) {
            stack_node[len] = far_node;
            stack_entry[len] = far_entry;
            len += 1u;
        }
        if (near_entry < best.t) {
            stack_node[len] = near_node;
            stack_entry[len] = near_entry;
            len += 1u;
        }
    }
    return best;
}

// Whether anything lies in (tmin, tmax) along the ray: a walk that stops at the first hit
// found, in no particular order, so it keeps no entry distances (a shadow ray needs no
// nearest hit). A primitive is tested as by the closest-hit walk, with tmax as the closest
// hit so far.
fn traverse_any(ray: Ray, shear: Shear, tmin: f32, tmax: f32) -> bool {
    let bound = Closest(tmax, KIND_TRIANGLE, 0u);
    let parallel = ray.direction == vec3<f32>(0.0);
    let inv = 1.0 / select(ray.direction, vec3<f32>(1.0), parallel);
    var stack: array<u32, STACK_SIZE>;
    var len = 0u;
    if (box_entry(nodes[0], ray, inv, parallel, tmin, tmax) < tmax) {
        stack[0] = 0u;
        len = 1u;
    }
    while (len > 0u) {
        len -= 1u;
        let node = nodes[stack[len]];
        if (node.count > 0u) {
            for (var k = node.first; k < node.first + node.count; k++) {
                if (try_ref(leaf_slot(k), ray, shear, tmin, bound, false).t < tmax) {
                    return true;
                }
            }
            continue;
        }
        // Both children at most once per level, as in the closest-hit walk: the stack holds
        // the deepest tree the builder makes.
        for (var child = node.first; child < node.first + 2u; child++) {
            if (box_entry(nodes[child], ray, inv, parallel, tmin, tmax) < tmax) {
                stack[len] = child;
                len += 1u;
            }
        }
    }
    return false;
}
