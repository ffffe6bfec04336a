// One invocation per pixel: cast the primary ray, keep the closest hit, then write colour,
// normal and depth (docs/SPEC.md §3–§5).
//
// Coordinates are camera-relative: the host moved the scene so that the camera centre is
// the origin (in f64, before rounding to f32), so precision does not depend on where the
// scene sits in the world.
//
// Feature switches are `override` constants, not run-time flags: on lavapipe every branch
// runs whether taken or not (docs/lavapipe.md), while an override set to false removes its code.

override HAS_SPHERES: bool = true;
override HAS_ELLIPSOIDS: bool = true;
override HAS_PLANES: bool = true;
override HAS_TRIANGLES: bool = true;
override ORTHOGRAPHIC: bool = false;
override WANT_COLOR: bool = true;
override WANT_NORMAL: bool = true;
override WANT_DEPTH: bool = true;
// Words each pixel takes in `pixels` (the host's gpu::layout::PixelLayout). As floats: the
// hit flag, then 3 for colour, 3 for the normal and 1 for the depth, each only when asked
// for. Packed (PACKED_8BIT, for 8-bit images): one word per output asked for.
override PIXEL_WORDS: u32 = 8u;
override PACKED_8BIT: bool = false;
// A loop bound fixed at compile time: no light code for a scene without lights, and the
// loop unrolled for the rest.
override NUM_LIGHTS: u32 = 0u;
override SHADE_BACK: bool = false;
// Which intersection algorithms to compile (the course asks for methods compared), one of
// the TRIANGLE_* and SPHERE_* values below (the host's render::TriangleTest, SphereTest).
override TRIANGLE_TEST: u32 = 2u;
override SPHERE_TEST: u32 = 1u;
// Cramer's rule (seed notes), Möller–Trumbore, Woop–Benthin–Wald.
const TRIANGLE_CRAMER: u32 = 0u;
const TRIANGLE_MOLLER: u32 = 1u;
const TRIANGLE_WATERTIGHT: u32 = 2u;
// The textbook quadratic; the precise form of Ray Tracing Gems ch. 7.
const SPHERE_NAIVE: u32 = 0u;
const SPHERE_PRECISE: u32 = 1u;
// Finite primitives through the bounding volume hierarchy, or through screen-space bins
// (gpu::binning); else flat loops over each kind.
override USE_BVH: bool = false;
override USE_BINS: bool = false;
// With bins (entry point main_bins) each invocation renders PACKET pixels stacked in a
// column (image rows PACKET·m …), so that every primitive loaded from a bin is tested
// against four rays: on lavapipe a load whose address is the same for every lane still
// costs a gather per lane group, and the packet pays it once for four pixels. Without bins
// (entry point main) an invocation renders one pixel: lavapipe stops any invocation's loops
// after 65535 iterations in all (docs/lavapipe.md), which four flat walks over many
// primitives would reach. Two entry points, not an override: wgpu compiles only what the
// chosen one reaches, and lavapipe would otherwise compile the other's code before dropping
// it. (The host's gpu::KernelConfig::packet.)
const PACKET: u32 = 4u;

const F32_MAX: f32 = 3.40282347e38;
// The "no hit" distance: never less than any closest-so-far.
const NO_HIT: f32 = F32_MAX;

const KIND_NONE: u32 = 0u;
const KIND_SPHERE: u32 = 1u;
const KIND_ELLIPSOID: u32 = 2u;
const KIND_PLANE: u32 = 3u;
const KIND_TRIANGLE: u32 = 4u;

struct Params {
    // The camera (docs/SPEC.md §3), its extent folded into `horizontal` and `up`; for a
    // perspective camera `direction` is scaled by D = 1/tan(angle/2).
    direction: vec3<f32>,
    width: u32,
    horizontal: vec3<f32>,
    height: u32,
    up: vec3<f32>,
    // First image row (from the top) of the tile this dispatch renders.
    first_row: u32,
    background: vec3<f32>,
    tile_rows: u32,
    ambient: vec3<f32>,
    // Bins per image row (USE_BINS).
    bin_columns: u32,
    num_spheres: u32,
    num_ellipsoids: u32,
    num_planes: u32,
    num_triangles: u32,
}

// A sphere in world space (a similarity transform was baked into it).
struct Sphere {
    center: vec3<f32>,
    radius: f32,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// A sphere under a transform that is not a similarity: the rows of the affine map W from
// world space to the space where it is the unit sphere at the origin.
struct Ellipsoid {
    row0: vec4<f32>,
    row1: vec4<f32>,
    row2: vec4<f32>,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// n̂ · p = offset, in world space.
struct Plane {
    normal: vec3<f32>,
    offset: f32,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Vertices in world space, ordered so that (v1 − v0) × (v2 − v0) is the normal of docs/SPEC.md §4.
struct Triangle {
    v0: vec3<f32>,
    material: u32,
    v1: vec3<f32>,
    _pad0: u32,
    v2: vec3<f32>,
    _pad1: u32,
}

// A triangle for primary rays (gpu::binning::EyeTriangle): three edge planes n · q − w, with
// q the ray's direction (perspective, all rays from the eye at the origin) or its origin
// (orthographic, all rays along one direction), and the triangle's plane n · p = w.
struct EyeTriangle {
    e0: vec4<f32>,
    e1: vec4<f32>,
    e2: vec4<f32>,
    plane: vec4<f32>,
}

// A primitive listed in a bin (kind << 30 | index, as prim_refs) and a lower bound of the t
// at which a primary ray can meet it; a bin's items are sorted by it.
struct BinItem {
    reference: u32,
    near: f32,
}

struct Light {
    // −normalise(direction): from the surface toward the light.
    to_light: vec3<f32>,
    _pad0: u32,
    color: vec3<f32>,
    _pad1: u32,
}

// A node of the hierarchy (src/bvh.rs): interior when count == 0, with children at first and
// first + 1; a leaf holds prim_refs[first .. first + count].
struct BvhNode {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    count: u32,
}


@group(0) @binding(0) var<storage, read> params: Params;
// The parameters, loaded once per invocation: lavapipe does not know that an address is the
// same for every lane, so each read of the storage buffer would be a gather of its own.
var<private> P: Params;
@group(0) @binding(1) var<storage, read> spheres: array<Sphere>;
@group(0) @binding(2) var<storage, read> ellipsoids: array<Ellipsoid>;
@group(0) @binding(3) var<storage, read> planes: array<Plane>;
@group(0) @binding(4) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(5) var<storage, read> materials: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> lights: array<Light>;
// PIXEL_WORDS words per pixel of the tile, f32 values as their bits.
@group(0) @binding(7) var<storage, read_write> pixels: array<u32>;
@group(0) @binding(8) var<storage, read> nodes: array<BvhNode>;
// kind << 30 | index into that kind's array.
@group(0) @binding(9) var<storage, read> prim_refs: array<u32>;
@group(0) @binding(10) var<storage, read> eye_triangles: array<EyeTriangle>;
// Per bin (8×8 pixels, row by row from the top): first item and count.
@group(0) @binding(11) var<storage, read> bin_ranges: array<vec2<u32>>;
@group(0) @binding(12) var<storage, read> bin_items: array<BinItem>;

const REF_TRIANGLE: u32 = 0u;
const REF_SPHERE: u32 = 1u;
const REF_ELLIPSOID: u32 = 2u;
const REF_INDEX_MASK: u32 = 0x3fffffffu;
// The hierarchy's depth bound (bvh::STACK_SIZE): the traversal stack cannot overflow.
const STACK_SIZE: u32 = 32u;
// 2·gamma(3) with gamma(n) = n·u/(1 − n·u), u = 2⁻²⁴ (bvh::SLAB_MARGIN).
const SLAB_MARGIN: f32 = 3.5762793e-7;

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// Pixel (i from the left, j from the bottom), sampled at its centre; the longer image side
// spans the camera's extent and the shorter one is cropped (docs/SPEC.md §3).
fn primary_ray(i: u32, j: u32) -> Ray {
    let longer = f32(max(P.width, P.height));
    let x = (f32(i) + 0.5 - 0.5 * f32(P.width)) / longer;
    let y = (f32(j) + 0.5 - 0.5 * f32(P.height)) / longer;
    let offset = x * P.horizontal + y * P.up;
    if (ORTHOGRAPHIC) {
        return Ray(offset, P.direction);
    }
    return Ray(vec3<f32>(0.0), normalize(P.direction + offset));
}

// Rays of an orthographic camera start at infinity (negative t is visible); perspective
// rays start at the eye.
fn t_min() -> f32 {
    if (ORTHOGRAPHIC) {
        return -F32_MAX;
    }
    return 0.0;
}

// The nearest root t > t_min of |f + t·d| = r, where f = origin − centre; d need not be
// unit length. Haines, Günther, Akenine-Möller, "Precision Improvements for Ray/Sphere
// Intersection", Ray Tracing Gems ch. 7: the discriminant from the squared distance of the
// centre to the line (no b² − 4ac cancellation when the ray starts far away), and the
// smaller root from c/q (no −b + √Δ cancellation).
fn sphere_t(f: vec3<f32>, d: vec3<f32>, radius: f32, tmin: f32) -> f32 {
    if (SPHERE_TEST == SPHERE_NAIVE) {
        return sphere_t_textbook(f, d, radius, tmin);
    }
    return sphere_t_precise(f, d, radius, tmin);
}

// The nearer root above tmin of two roots in either order.
fn nearest_root(r0: f32, r1: f32, tmin: f32) -> f32 {
    let near = min(r0, r1);
    let far = max(r0, r1);
    if (near > tmin) {
        return near;
    }
    if (far > tmin) {
        return far;
    }
    return NO_HIT;
}

// a t² + b t + c = 0 as in any textbook: b² − 4ac cancels when the ray starts far from the
// sphere, and −b + √Δ cancels for the far root. Kept to measure what the precise form buys.
fn sphere_t_textbook(f: vec3<f32>, d: vec3<f32>, radius: f32, tmin: f32) -> f32 {
    let a = dot(d, d);
    let b = 2.0 * dot(f, d);
    let c = dot(f, f) - radius * radius;
    let discriminant = b * b - 4.0 * a * c;
    if (discriminant < 0.0) {
        return NO_HIT;
    }
    let root = sqrt(discriminant);
    return nearest_root((-b - root) / (2.0 * a), (-b + root) / (2.0 * a), tmin);
}

fn sphere_t_precise(f: vec3<f32>, d: vec3<f32>, radius: f32, tmin: f32) -> f32 {
    let a = dot(d, d);
    let b = -dot(f, d);
    let perpendicular = f + (b / a) * d;
    let discriminant = radius * radius - dot(perpendicular, perpendicular);
    if (discriminant < 0.0) {
        return NO_HIT;
    }
    let c = dot(f, f) - radius * radius;
    let q = b + select(-1.0, 1.0, b >= 0.0) * sqrt(a * discriminant);
    return nearest_root(c / q, q / a, tmin);
}

fn to_unit_sphere_point(e: Ellipsoid, p: vec3<f32>) -> vec3<f32> {
    let h = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(e.row0, h), dot(e.row1, h), dot(e.row2, h));
}

fn to_unit_sphere_vector(e: Ellipsoid, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(e.row0.xyz, v), dot(e.row1.xyz, v), dot(e.row2.xyz, v));
}

// docs/SPEC.md §4: the ray goes into object space without renormalising, so t is the world t.
fn ellipsoid_t(e: Ellipsoid, ray: Ray, tmin: f32) -> f32 {
    return sphere_t(to_unit_sphere_point(e, ray.origin), to_unit_sphere_vector(e, ray.direction), 1.0, tmin);
}

// The world normal is normalise(Wᵀ · n) with n the unit sphere's normal at the hit
// (the inverse transpose of the object-to-world map, whose inverse W we hold).
fn ellipsoid_normal(e: Ellipsoid, world_point: vec3<f32>) -> vec3<f32> {
    let n = to_unit_sphere_point(e, world_point);
    return normalize(e.row0.xyz * n.x + e.row1.xyz * n.y + e.row2.xyz * n.z);
}

fn plane_t(p: Plane, ray: Ray, tmin: f32) -> f32 {
    let denominator = dot(p.normal, ray.direction);
    if (denominator == 0.0) {
        return NO_HIT;
    }
    return t_if_above((p.offset - dot(p.normal, ray.origin)) / denominator, tmin);
}

// Per-ray set-up of the watertight test: the axis permutation that makes the ray's largest
// component z, and the shear that makes the ray +z.
struct Shear {
    axes: vec3<u32>,
    s: vec3<f32>,
}

fn shear_for(d: vec3<f32>) -> Shear {
    let a = abs(d);
    var kz = 2u;
    if (a.x > a.y && a.x > a.z) {
        kz = 0u;
    } else if (a.y > a.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    // Keep the winding: swap the other two axes when the ray points down its main axis.
    if (d[kz] < 0.0) {
        let k = kx;
        kx = ky;
        ky = k;
    }
    return Shear(vec3<u32>(kx, ky, kz), vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]));
}

fn permute(v: vec3<f32>, k: vec3<u32>) -> vec3<f32> {
    return vec3<f32>(v[k.x], v[k.y], v[k.z]);
}

// Watertight ray/triangle test: Woop, Benthin, Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2(1), 2013. Edge functions are computed in a frame where the ray is
// the +z axis, so an edge shared by two triangles gives both the same value with opposite
// signs: no ray slips between them. Edges count as inside; both sides of the triangle hit.
fn triangle_t(tri: Triangle, ray: Ray, shear: Shear, tmin: f32) -> f32 {
    if (TRIANGLE_TEST == TRIANGLE_CRAMER) {
        return triangle_t_cramer(tri, ray, tmin);
    }
    if (TRIANGLE_TEST == TRIANGLE_MOLLER) {
        return triangle_t_moller(tri, ray, tmin);
    }
    return triangle_t_watertight(tri, ray, shear, tmin);
}

fn t_if_above(t: f32, tmin: f32) -> f32 {
    if (t > tmin) {
        return t;
    }
    return NO_HIT;
}

// Cramer's rule on α·(a − c) + β·(b − c) + c = o + t·d, as the seed notes derive it.
fn triangle_t_cramer(tri: Triangle, ray: Ray, tmin: f32) -> f32 {
    let e1 = tri.v0 - tri.v2;
    let e2 = tri.v1 - tri.v2;
    let oc = ray.origin - tri.v2;
    let n = cross(e1, e2);
    let det = -dot(ray.direction, n);
    if (det == 0.0) {
        return NO_HIT;
    }
    let alpha = -dot(ray.direction, cross(oc, e2)) / det;
    let beta = -dot(ray.direction, cross(e1, oc)) / det;
    if (alpha < 0.0 || beta < 0.0 || alpha + beta > 1.0) {
        return NO_HIT;
    }
    return t_if_above(dot(oc, n) / det, tmin);
}

// Möller, Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection", JGT 2(1), 1997.
fn triangle_t_moller(tri: Triangle, ray: Ray, tmin: f32) -> f32 {
    let e1 = tri.v1 - tri.v0;
    let e2 = tri.v2 - tri.v0;
    let p = cross(ray.direction, e2);
    let det = dot(e1, p);
    if (det == 0.0) {
        return NO_HIT;
    }
    let inv = 1.0 / det;
    let s = ray.origin - tri.v0;
    let u = dot(s, p) * inv;
    let q = cross(s, e1);
    let v = dot(ray.direction, q) * inv;
    if (u < 0.0 || v < 0.0 || u + v > 1.0) {
        return NO_HIT;
    }
    return t_if_above(dot(e2, q) * inv, tmin);
}

fn triangle_t_watertight(tri: Triangle, ray: Ray, shear: Shear, tmin: f32) -> f32 {
    let a = permute(tri.v0 - ray.origin, shear.axes);
    let b = permute(tri.v1 - ray.origin, shear.axes);
    let c = permute(tri.v2 - ray.origin, shear.axes);
    let ax = a.x - shear.s.x * a.z;
    let ay = a.y - shear.s.y * a.z;
    let bx = b.x - shear.s.x * b.z;
    let by = b.y - shear.s.y * b.z;
    let cx = c.x - shear.s.x * c.z;
    let cy = c.y - shear.s.y * c.z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return NO_HIT;
    }
    let det = u + v + w;
    if (det == 0.0) {
        return NO_HIT;
    }
    return t_if_above((u * a.z + v * b.z + w * c.z) * shear.s.z / det, tmin);
}

fn triangle_normal(tri: Triangle) -> vec3<f32> {
    return normalize(cross(tri.v1 - tri.v0, tri.v2 - tri.v0));
}

struct Closest {
    t: f32,
    kind: u32,
    index: u32,
}

// The nearest plane hit (planes are infinite and stay outside bins and the hierarchy; a
// near plane hit prunes them).
fn closest_plane(ray: Ray, tmin: f32) -> Closest {
    var best = Closest(NO_HIT, KIND_NONE, 0u);
    if (HAS_PLANES) {
        for (var k = 0u; k < P.num_planes; k++) {
            best = nearer(best, plane_t(planes[k], ray, tmin), KIND_PLANE, k);
        }
    }
    return best;
}

// The closest hit without bins: through the hierarchy, or flat loops over each kind.
fn closest_hit(ray: Ray) -> Closest {
    let tmin = t_min();
    var best = closest_plane(ray, tmin);
    // Only the watertight test reads the shear; otherwise the compiler drops it.
    let shear = shear_for(ray.direction);
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

// The closer of the hit so far and a hit at t on primitive `index` of `kind` (ties keep the
// earlier one).
fn nearer(best: Closest, t: f32, kind: u32, index: u32) -> Closest {
    if (t < best.t) {
        return Closest(t, kind, index);
    }
    return best;
}

fn try_sphere(k: u32, ray: Ray, tmin: f32, best: Closest) -> Closest {
    let s = spheres[k];
    let t = sphere_t(ray.origin - s.center, ray.direction, s.radius, tmin);
    return nearer(best, t, KIND_SPHERE, k);
}

fn try_ellipsoid(k: u32, ray: Ray, tmin: f32, best: Closest) -> Closest {
    let t = ellipsoid_t(ellipsoids[k], ray, tmin);
    return nearer(best, t, KIND_ELLIPSOID, k);
}

fn try_triangle(k: u32, ray: Ray, shear: Shear, tmin: f32, best: Closest) -> Closest {
    let t = triangle_t(triangles[k], ray, shear, tmin);
    return nearer(best, t, KIND_TRIANGLE, k);
}

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

// Tests the primitive a reference names (kind << 30 | index; with triangles alone, the
// triangle index itself: REF_TRIANGLE is 0). `binned` selects the triangle test of a bin
// (try_binned_triangle) over the hierarchy's; every caller passes a constant, so the
// choice is folded away.
fn try_ref(r: u32, ray: Ray, shear: Shear, tmin: f32, best: Closest, binned: bool) -> Closest {
    let kind = select(r >> 30u, REF_TRIANGLE, !HAS_SPHERES && !HAS_ELLIPSOIDS);
    let index = select(r & REF_INDEX_MASK, r, !HAS_SPHERES && !HAS_ELLIPSOIDS);
    var out = best;
    if (HAS_TRIANGLES && kind == REF_TRIANGLE) {
        if (binned) {
            out = try_binned_triangle(index, ray, shear, tmin, out);
        } else {
            out = try_triangle(index, ray, shear, tmin, out);
        }
    }
    if (HAS_SPHERES && kind == REF_SPHERE) {
        out = try_sphere(index, ray, tmin, out);
    }
    if (HAS_ELLIPSOIDS && kind == REF_ELLIPSOID) {
        out = try_ellipsoid(index, ray, tmin, out);
    }
    return out;
}

// What leaf slot k holds: a prim_refs entry, or with triangles alone (reordered into leaf
// order by the host) the triangle index itself, one load fewer.
fn leaf_slot(k: u32) -> u32 {
    if (!HAS_SPHERES && !HAS_ELLIPSOIDS) {
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

// The edge functions of a primary ray against a triangle's edge planes: all of one sign
// (or zero) when the ray's line meets the triangle, edges included. Watertight (see
// gpu::binning::EyeTriangle): a shared edge's plane is negated bit for bit in its two
// triangles. Then t from the triangle's plane; a ray in that plane never hits. The
// non-short-circuit & and | keep it free of branches.
fn eye_triangle_t(tri: EyeTriangle, ray: Ray, tmin: f32) -> f32 {
    var q = ray.direction;
    if (ORTHOGRAPHIC) {
        q = ray.origin;
    }
    let e0 = dot(tri.e0.xyz, q) - tri.e0.w;
    let e1 = dot(tri.e1.xyz, q) - tri.e1.w;
    let e2 = dot(tri.e2.xyz, q) - tri.e2.w;
    let inside = ((e0 >= 0.0) & (e1 >= 0.0) & (e2 >= 0.0)) | ((e0 <= 0.0) & (e1 <= 0.0) & (e2 <= 0.0));
    let denominator = dot(tri.plane.xyz, ray.direction);
    var numerator = tri.plane.w;
    if (ORTHOGRAPHIC) {
        numerator -= dot(tri.plane.xyz, ray.origin);
    }
    let t = numerator / select(1.0, denominator, denominator != 0.0);
    return select(NO_HIT, t_if_above(t, tmin), inside & (denominator != 0.0));
}

fn try_eye_triangle(k: u32, ray: Ray, tmin: f32, best: Closest) -> Closest {
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


// The packet's rays and closest hits so far (private: registers once the calls are inlined).
var<private> R0: Ray;
var<private> R1: Ray;
var<private> R2: Ray;
var<private> R3: Ray;
var<private> H0: Closest;
var<private> H1: Closest;
var<private> H2: Closest;
var<private> H3: Closest;

// The closest hits of the packet among the primitives listed in its bin, nearest first. The
// list, and so the loop, is the same for every invocation of the workgroup. Each item is loaded once and tested against the four rays; the
// walk stops once every ray's closest hit is nearer than the next item can be.
fn walk_bin_packet(bin: u32, tmin: f32) {
    let range = bin_ranges[bin];
    let s0 = shear_for(R0.direction);
    let s1 = shear_for(R1.direction);
    let s2 = shear_for(R2.direction);
    let s3 = shear_for(R3.direction);
    for (var k = range.x; k < range.x + range.y; k++) {
        let item = bin_items[k];
        if (item.near > max(max(H0.t, H1.t), max(H2.t, H3.t))) {
            break;
        }
        let r = item.reference;
        if (!HAS_SPHERES && !HAS_ELLIPSOIDS && TRIANGLE_TEST == TRIANGLE_WATERTIGHT) {
            let tri = eye_triangles[r];
            H0 = nearer(H0, eye_triangle_t(tri, R0, tmin), KIND_TRIANGLE, r);
            H1 = nearer(H1, eye_triangle_t(tri, R1, tmin), KIND_TRIANGLE, r);
            H2 = nearer(H2, eye_triangle_t(tri, R2, tmin), KIND_TRIANGLE, r);
            H3 = nearer(H3, eye_triangle_t(tri, R3, tmin), KIND_TRIANGLE, r);
            continue;
        }
        H0 = try_ref(r, R0, s0, tmin, H0, true);
        H1 = try_ref(r, R1, s1, tmin, H1, true);
        H2 = try_ref(r, R2, s2, tmin, H2, true);
        H3 = try_ref(r, R3, s3, tmin, H3, true);
    }
}

struct Surface {
    normal: vec3<f32>,
    material: u32,
}

fn surface_at(hit: Closest, ray: Ray) -> Surface {
    let p = ray.origin + hit.t * ray.direction;
    if (HAS_SPHERES && hit.kind == KIND_SPHERE) {
        let s = spheres[hit.index];
        return Surface((p - s.center) / s.radius, s.material);
    }
    if (HAS_ELLIPSOIDS && hit.kind == KIND_ELLIPSOID) {
        let e = ellipsoids[hit.index];
        return Surface(ellipsoid_normal(e, p), e.material);
    }
    if (HAS_PLANES && hit.kind == KIND_PLANE) {
        let pl = planes[hit.index];
        return Surface(pl.normal, pl.material);
    }
    if (HAS_TRIANGLES && hit.kind == KIND_TRIANGLE) {
        let tri = triangles[hit.index];
        return Surface(triangle_normal(tri), tri.material);
    }
    return Surface(vec3<f32>(0.0), 0u);
}

// docs/SPEC.md §5: ambient plus Lambert per light; a back-facing hit is black unless SHADE_BACK,
// which shades it with the flipped normal.
fn shade(surface: Surface, ray: Ray) -> vec3<f32> {
    var n = surface.normal;
    if (dot(ray.direction, n) > 0.0) {
        if (!SHADE_BACK) {
            return vec3<f32>(0.0);
        }
        n = -n;
    }
    let diffuse = materials[surface.material].xyz;
    var color = P.ambient * diffuse;
    for (var k = 0u; k < NUM_LIGHTS; k++) {
        let light = lights[k];
        color += max(dot(light.to_light, n), 0.0) * light.color * diffuse;
    }
    return color;
}

// docs/SPEC.md §5: floor(255·clamp(v, 0, 1)) per channel, as image_io::quantize (NaN → 0),
// packed r | g << 8 | b << 16.
fn pack_rgb8(c: vec3<f32>) -> u32 {
    let q = vec3<u32>(floor(255.0 * clamp(select(c, vec3<f32>(0.0), c != c), vec3<f32>(0.0), vec3<f32>(1.0))));
    return q.x | (q.y << 8u) | (q.z << 16u);
}

// The 8-bit images, one word each: colour, |N| (black on a miss), and t as bits for the
// host to quantise in f64 (all ones on a miss).
fn write_packed_pixel(index: u32, hit: bool, color: vec3<f32>, normal: vec3<f32>, t: f32) {
    var w = index * PIXEL_WORDS;
    if (WANT_COLOR) {
        pixels[w] = pack_rgb8(color);
        w += 1u;
    }
    if (WANT_NORMAL) {
        pixels[w] = select(0u, pack_rgb8(abs(normal)), hit);
        w += 1u;
    }
    if (WANT_DEPTH) {
        pixels[w] = select(0xffffffffu, bitcast<u32>(t), hit);
    }
}

// Writes one pixel: the hit flag, then only the outputs asked for.
fn write_pixel(index: u32, hit: bool, color: vec3<f32>, normal: vec3<f32>, t: f32) {
    if (PACKED_8BIT) {
        write_packed_pixel(index, hit, color, normal, t);
        return;
    }
    var w = index * PIXEL_WORDS;
    pixels[w] = select(0u, 1u, hit);
    w += 1u;
    if (WANT_COLOR) {
        pixels[w] = bitcast<u32>(color.x);
        pixels[w + 1u] = bitcast<u32>(color.y);
        pixels[w + 2u] = bitcast<u32>(color.z);
        w += 3u;
    }
    if (WANT_NORMAL) {
        pixels[w] = bitcast<u32>(normal.x);
        pixels[w + 1u] = bitcast<u32>(normal.y);
        pixels[w + 2u] = bitcast<u32>(normal.z);
        w += 3u;
    }
    if (WANT_DEPTH) {
        pixels[w] = bitcast<u32>(t);
    }
}

// Shades and writes tile-local row `row` of column i, when it belongs to this tile.
fn finish_pixel(i: u32, row: i32, ray: Ray, hit: Closest) {
    if (row < 0 || row >= i32(P.tile_rows)) {
        return;
    }
    let index = u32(row) * P.width + i;
    if (hit.kind == KIND_NONE) {
        write_pixel(index, false, P.background, vec3<f32>(0.0), 0.0);
        return;
    }
    let surface = surface_at(hit, ray);
    var color = vec3<f32>(0.0);
    if (WANT_COLOR) {
        color = shade(surface, ray);
    }
    write_pixel(index, true, color, surface.normal, hit.t);
}

// The ray of image row `image_row` (from the top), clamped into the image so that a packet
// reaching past its last row still casts a valid ray (whose pixel is not written).
fn ray_of_row(i: u32, image_row: u32) -> Ray {
    let clamped = min(image_row, P.height - 1u);
    // Image rows count from the top, the camera's j from the bottom.
    return primary_ray(i, P.height - 1u - clamped);
}

// One invocation per pixel, without bins.
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let row = id.y;
    if (i >= P.width || row >= P.tile_rows) {
        return;
    }
    let ray = ray_of_row(i, P.first_row + row);
    finish_pixel(i, i32(row), ray, closest_hit(ray));
}

// One invocation per column and packet: image rows base + PACKET·y … + PACKET − 1, where base
// is the tile's first row rounded down to a multiple of PACKET, so that a packet never
// straddles two bins (8 rows, a multiple of PACKET) whatever the tile.
@compute @workgroup_size(8, 8)
fn main_bins(@builtin(global_invocation_id) id: vec3<u32>) {
    P = params;
    let i = id.x;
    let base = P.first_row - P.first_row % PACKET + id.y * PACKET;
    let first = i32(base) - i32(P.first_row);
    if (i >= P.width || first >= i32(P.tile_rows)) {
        return;
    }
    R0 = ray_of_row(i, base);
    R1 = ray_of_row(i, base + 1u);
    R2 = ray_of_row(i, base + 2u);
    R3 = ray_of_row(i, base + 3u);
    let tmin = t_min();
    H0 = closest_plane(R0, tmin);
    H1 = closest_plane(R1, tmin);
    H2 = closest_plane(R2, tmin);
    H3 = closest_plane(R3, tmin);
    walk_bin_packet((base / 8u) * P.bin_columns + i / 8u, tmin);
    finish_pixel(i, first, R0, H0);
    finish_pixel(i, first + 1, R1, H1);
    finish_pixel(i, first + 2, R2, H2);
    finish_pixel(i, first + 3, R3, H3);
}
