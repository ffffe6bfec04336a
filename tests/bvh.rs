//! The BVH: structure invariants of the builder, the robust slab test, and agreement of the
//! traversal (the kernel's algorithm, run on the CPU) with brute force on random triangles,
//! degenerate inputs and the bunny. Run with `--nocapture` to see build statistics.

mod common;

use glam::{DVec3, Vec3};
use raycaster::bvh::{ray_box_entry, Aabb, Bvh, BvhNode, MAX_LEAF_SIZE, STACK_SIZE};
use std::time::Instant;

/// SplitMix64 (Steele, Lea & Flood 2014): deterministic and good enough for test inputs.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        common::splitmix64(&mut self.0)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn point_in(&mut self, b: &Aabb) -> Vec3 {
        Vec3::new(self.range(b.min.x, b.max.x), self.range(b.min.y, b.max.y), self.range(b.min.z, b.max.z))
    }
    fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

type Triangle = [Vec3; 3];

/// Plain f32 Möller–Trumbore: the same function serves brute force and the BVH, so that
/// their t values can be compared exactly.
fn intersect(tri: &Triangle, origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = direction.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = origin - tri[0];
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = direction.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    (t_min < t && t < t_max).then_some(t)
}

fn triangle_bounds(tris: &[Triangle]) -> Vec<Aabb> {
    tris.iter().map(|t| Aabb::of_points(t)).collect()
}

#[derive(Clone, Copy, Debug)]
struct Ray {
    origin: Vec3,
    direction: Vec3,
    t_min: f32,
    t_max: f32,
}

fn brute_force(tris: &[Triangle], ray: &Ray) -> Option<(u32, f32)> {
    let mut best = None;
    let mut closest = ray.t_max;
    for (i, tri) in tris.iter().enumerate() {
        if let Some(t) = intersect(tri, ray.origin, ray.direction, ray.t_min, closest) {
            closest = t;
            best = Some((i as u32, t));
        }
    }
    best
}

/// The BVH's closest hit, and how many primitives it tested.
fn bvh_hit(bvh: &Bvh, tris: &[Triangle], ray: &Ray) -> (Option<(u32, f32)>, usize) {
    let mut tests = 0;
    let hit = bvh.closest_hit(ray.origin, ray.direction, ray.t_min, ray.t_max, |prim, t_min, t_max| {
        tests += 1;
        intersect(&tris[prim as usize], ray.origin, ray.direction, t_min, t_max)
    });
    (hit, tests)
}

/// Compares every ray; returns (rays that hit, mean primitive tests per ray).
fn assert_agrees_with_brute_force(bvh: &Bvh, tris: &[Triangle], rays: &[Ray]) -> (usize, f64) {
    let mut hits = 0;
    let mut tests = 0;
    for (i, ray) in rays.iter().enumerate() {
        let expected = brute_force(tris, ray);
        let (got, n) = bvh_hit(bvh, tris, ray);
        tests += n;
        match (expected, got) {
            (None, None) => {}
            (Some((ep, et)), Some((gp, gt))) => {
                assert_eq!(et, gt, "ray {i} {ray:?}: t (brute force prim {ep}, bvh prim {gp})");
                if ep != gp {
                    // An exact tie: the other primitive must give the very same t.
                    let t = intersect(&tris[gp as usize], ray.origin, ray.direction, ray.t_min, ray.t_max);
                    assert_eq!(t, Some(et), "ray {i} {ray:?}: prim {gp} instead of {ep}");
                }
                hits += 1;
            }
            _ => panic!("ray {i} {ray:?}: brute force {expected:?}, bvh {got:?}"),
        }
    }
    (hits, tests as f64 / rays.len().max(1) as f64)
}

fn bounds_of(boxes: &[Aabb]) -> Aabb {
    boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b))
}

fn contains(outer: &Aabb, inner: &Aabb) -> bool {
    outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
}

fn node_box(node: &BvhNode) -> Aabb {
    Aabb { min: Vec3::from_array(node.min), max: Vec3::from_array(node.max) }
}

/// Checks every structural invariant; returns the largest leaf.
fn check_invariants(bvh: &Bvh, bounds: &[Aabb]) -> usize {
    let n = bounds.len();
    let mut in_order = vec![0u32; n];
    for &prim in &bvh.order {
        in_order[prim as usize] += 1;
    }
    assert!(in_order.iter().all(|&c| c == 1), "every primitive appears exactly once in order");
    assert_eq!(bvh.order.len(), n);
    if n == 0 {
        assert_eq!(bvh.nodes.len(), 1);
        assert_eq!(bvh.nodes[0].count, 0);
        assert_eq!(node_box(&bvh.nodes[0]), Aabb::EMPTY);
        assert_eq!((bvh.depth(), bvh.leaf_count()), (0, 0));
        return 0;
    }

    let mut parents = vec![0u32; bvh.nodes.len()];
    parents[0] = 1; // the root counts as referenced
    let mut covered = vec![0u32; n];
    let (mut depth, mut leaves, mut largest_leaf) = (0, 0, 0);
    let mut pending = vec![(0usize, 1usize)];
    while let Some((index, level)) = pending.pop() {
        let node = &bvh.nodes[index];
        let b = node_box(node);
        depth = depth.max(level);
        if node.count > 0 {
            let range = node.first as usize..(node.first + node.count) as usize;
            assert!(range.end <= n, "leaf {index} range {range:?} within order");
            let prims: Vec<Aabb> = bvh.order[range.clone()].iter().map(|&p| bounds[p as usize]).collect();
            assert!(prims.iter().all(|p| contains(&b, p)), "leaf {index} contains its primitives");
            assert_eq!(b, bounds_of(&prims), "leaf {index} box is tight");
            range.for_each(|i| covered[i] += 1);
            leaves += 1;
            largest_leaf = largest_leaf.max(node.count as usize);
        } else {
            let (l, r) = (node.first as usize, node.first as usize + 1);
            assert!(l > index && r < bvh.nodes.len(), "node {index}: children {l}, {r} after it and in range");
            let (lb, rb) = (node_box(&bvh.nodes[l]), node_box(&bvh.nodes[r]));
            assert!(contains(&b, &lb) && contains(&b, &rb), "node {index} contains its children");
            assert_eq!(b, lb.union(&rb), "node {index} box is tight");
            parents[l] += 1;
            parents[r] += 1;
            pending.push((l, level + 1));
            pending.push((r, level + 1));
        }
    }
    assert!(parents.iter().all(|&p| p == 1), "every node is reachable exactly once");
    assert!(covered.iter().all(|&c| c == 1), "leaf ranges partition order");
    assert_eq!(bvh.nodes.len(), 2 * leaves - 1, "a binary tree");
    assert_eq!((bvh.depth(), bvh.leaf_count()), (depth, leaves));
    assert!(depth <= STACK_SIZE, "depth {depth} > STACK_SIZE");
    assert!(largest_leaf <= MAX_LEAF_SIZE, "leaf of {largest_leaf} > MAX_LEAF_SIZE");
    assert!(bvh.sah_cost() >= 0.0 && bvh.sah_cost().is_finite());
    largest_leaf
}

fn random_boxes(rng: &mut Rng, n: usize) -> Vec<Aabb> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.range(-10.0, 10.0), rng.range(-10.0, 10.0), rng.range(-10.0, 10.0));
            let h = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * rng.range(0.0, 2.0);
            Aabb { min: c - h, max: c + h }
        })
        .collect()
}

fn random_triangles(rng: &mut Rng, n: usize, spread: f32, size: f32) -> Vec<Triangle> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.range(-spread, spread), rng.range(-spread, spread), rng.range(-spread, spread));
            [c + rng.unit_vector() * size, c + rng.unit_vector() * size, c + rng.unit_vector() * size]
        })
        .collect()
}

/// A ray mix: perspective-like rays from outside the scene box at points in it; rays from
/// inside; axis-aligned rays (two zero direction components) and rays with one zero component,
/// some lying exactly in a primitive's box face; orthographic rays (t_min = -f32::MAX) through
/// the scene; and rays whose t_max cuts the scene.
fn ray_mix(rng: &mut Rng, tris: &[Triangle], count: usize) -> Vec<Ray> {
    let scene = bounds_of(&triangle_bounds(tris));
    let center = scene.centroid();
    let radius = (scene.max - scene.min).length().max(1.0);
    (0..count)
        .map(|i| {
            let target = rng.point_in(&scene);
            let outside = center + rng.unit_vector() * 2.0 * radius;
            let vertex = tris[rng.below(tris.len())][rng.below(3)];
            match i % 6 {
                0 => Ray { origin: outside, direction: target - outside, t_min: 0.0, t_max: f32::INFINITY },
                1 => Ray { origin: target, direction: rng.unit_vector(), t_min: 1e-4, t_max: f32::MAX },
                2 => {
                    // Along one axis, the other two coordinates taken from a vertex (a box face).
                    let axis = rng.below(3);
                    let mut origin = vertex;
                    origin[axis] = outside[axis];
                    let mut direction = Vec3::ZERO;
                    direction[axis] = if rng.unit() < 0.5 { -1.0 } else { 1.0 };
                    Ray { origin, direction, t_min: -f32::MAX * (rng.below(2) as f32), t_max: f32::MAX }
                }
                3 => {
                    let axis = rng.below(3);
                    let mut direction = target - outside;
                    direction[axis] = 0.0;
                    let mut origin = outside;
                    origin[axis] = if rng.unit() < 0.5 { vertex[axis] } else { target[axis] };
                    Ray { origin, direction, t_min: 0.0, t_max: f32::INFINITY }
                }
                4 => Ray { origin: target, direction: rng.unit_vector(), t_min: -f32::MAX, t_max: f32::MAX },
                _ => {
                    let direction = (target - outside).normalize();
                    Ray { origin: outside, direction, t_min: 0.0, t_max: rng.range(0.5, 3.0) * radius }
                }
            }
        })
        .collect()
}

#[test]
fn aabb_basics() {
    let a = Aabb { min: Vec3::new(0.0, 0.0, 0.0), max: Vec3::new(1.0, 2.0, 3.0) };
    let b = Aabb { min: Vec3::new(-1.0, 1.0, 1.0), max: Vec3::new(0.5, 4.0, 2.0) };
    assert_eq!(a.union(&b), Aabb { min: Vec3::new(-1.0, 0.0, 0.0), max: Vec3::new(1.0, 4.0, 3.0) });
    assert_eq!(a.union(&Aabb::EMPTY), a);
    assert_eq!(Aabb::EMPTY.union(&a), a);
    assert_eq!(a.centroid(), Vec3::new(0.5, 1.0, 1.5));
    assert_eq!(a.surface_area(), 2.0 * (2.0 + 6.0 + 3.0));
    assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    let flat = Aabb { min: Vec3::ZERO, max: Vec3::new(2.0, 3.0, 0.0) };
    assert_eq!(flat.surface_area(), 12.0);
    let mut g = Aabb::EMPTY;
    g.grow(Vec3::new(1.0, -2.0, 3.0));
    assert_eq!(g, Aabb { min: Vec3::new(1.0, -2.0, 3.0), max: Vec3::new(1.0, -2.0, 3.0) });
    assert_eq!(g.surface_area(), 0.0);
    assert_eq!(
        Aabb::of_points(&[Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 5.0, 0.0)]).max,
        Vec3::new(1.0, 5.0, 3.0)
    );
    assert_eq!(Aabb::of_points(&[]), Aabb::EMPTY);
    assert!(Aabb::EMPTY.min.is_finite() && Aabb::EMPTY.max.is_finite(), "uploadable to a GPU buffer");
}

/// The node's Rust layout equals what naga lays out for the WGSL declaration in the docs.
#[test]
fn ray_box_entry_cases() {
    let unit = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
    let inv = |d: Vec3| d.recip();
    let x = Vec3::X;
    // Straight in through the x = 0 face, 1 away; the entry is lowered by a few ulps at most.
    let entry = ray_box_entry(&unit, Vec3::new(-1.0, 0.5, 0.5), inv(x), 0.0, f32::INFINITY).unwrap();
    assert!(entry <= 1.0 && entry > 1.0 - 1e-6, "{entry}");
    // t_max short of the box, box behind the ray, ray beside the box.
    assert_eq!(ray_box_entry(&unit, Vec3::new(-1.0, 0.5, 0.5), inv(x), 0.0, 0.9), None);
    assert_eq!(ray_box_entry(&unit, Vec3::new(2.0, 0.5, 0.5), inv(x), 0.0, f32::INFINITY), None);
    assert_eq!(ray_box_entry(&unit, Vec3::new(-1.0, 1.5, 0.5), inv(x), 0.0, f32::INFINITY), None);
    // From inside: the entry is t_min.
    assert_eq!(ray_box_entry(&unit, Vec3::splat(0.5), inv(x), 0.0, f32::INFINITY), Some(0.0));
    // Orthographic: the box behind the origin is hit at a negative t.
    let behind = ray_box_entry(&unit, Vec3::new(3.0, 0.5, 0.5), inv(x), -f32::MAX, f32::MAX).unwrap();
    assert!((-3.00001..=-3.0).contains(&behind), "{behind}");
    assert_eq!(ray_box_entry(&unit, Vec3::new(3.0, 0.5, 0.5), inv(x), -f32::MAX, -3.5), None);
    // Zero direction components with the origin exactly on a bound: (bound − origin) · ∞ would
    // be NaN. The boundary counts as inside.
    for (y, z) in [(0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.0)] {
        for dx in [1.0f32, -1.0] {
            let origin = Vec3::new(0.5 - 2.5 * dx, y, z);
            let entry = ray_box_entry(&unit, origin, inv(Vec3::new(dx, 0.0, 0.0)), 0.0, f32::INFINITY);
            assert!(entry.is_some_and(|e| (1.99999..=2.0).contains(&e)), "({y}, {z}) {dx}: {entry:?}");
            let neg_zero = inv(Vec3::new(dx, -0.0, -0.0));
            assert!(ray_box_entry(&unit, origin, neg_zero, -f32::MAX, f32::MAX).is_some());
        }
    }
    assert_eq!(ray_box_entry(&unit, Vec3::new(-2.0, 1.0 + 1e-7, 0.5), inv(x), 0.0, f32::INFINITY), None);
    // A flat box, hit across and along its plane.
    let flat = Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 1.0, 0.0) };
    let down = ray_box_entry(&flat, Vec3::new(0.5, 0.5, 2.0), inv(-Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!((1.99999..=2.0).contains(&down), "{down}");
    assert!(ray_box_entry(&flat, Vec3::new(-1.0, 0.5, 0.0), inv(x), 0.0, f32::INFINITY).is_some());
    // A zero direction is parallel to every slab: inside or not at all.
    assert!(ray_box_entry(&unit, Vec3::splat(0.5), inv(Vec3::ZERO), 0.0, 1.0).is_some());
    assert!(ray_box_entry(&unit, Vec3::splat(1.5), inv(Vec3::ZERO), 0.0, 1.0).is_none());
}

#[test]
fn empty_box_is_never_hit() {
    let mut rng = Rng(7);
    for _ in 0..10_000 {
        let origin = Vec3::new(rng.range(-1e3, 1e3), rng.range(-1e3, 1e3), rng.range(-1e3, 1e3));
        let mut direction = rng.unit_vector();
        direction[rng.below(3)] = 0.0;
        if rng.unit() < 0.3 {
            direction[rng.below(3)] = 0.0;
        }
        let hit = ray_box_entry(&Aabb::EMPTY, origin, direction.recip(), -f32::MAX, f32::INFINITY);
        assert_eq!(hit, None, "{origin} {direction}");
    }
    for corner in [Vec3::splat(f32::MAX), Vec3::splat(-f32::MAX), Vec3::ZERO] {
        assert_eq!(ray_box_entry(&Aabb::EMPTY, corner, Vec3::ONE, -f32::MAX, f32::MAX), None);
    }
}

/// Exact-ish reference: the f32 inputs in f64, where (bound − origin) is exact and the
/// division rounds once. Returns the clamped (entry, exit) interval, or `None` when the ray is
/// parallel to a slab and outside it; the ray meets the box iff entry <= exit.
fn ray_box_interval_f64(b: &Aabb, origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Option<(f64, f64)> {
    let (mut near, mut far) = (f64::from(t_min), f64::from(t_max));
    for axis in 0..3 {
        let (lo, hi, o, d) =
            (f64::from(b.min[axis]), f64::from(b.max[axis]), f64::from(origin[axis]), f64::from(direction[axis]));
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((lo - o) / d, (hi - o) / d);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    Some((near, far))
}

fn ray_box_entry_f64(b: &Aabb, origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Option<f64> {
    ray_box_interval_f64(b, origin, direction, t_min, t_max).filter(|(near, far)| near <= far).map(|(near, _)| near)
}

/// Rounding never culls a box the exact ray meets, never reports an entry later than the exact
/// one, and accepts only near misses. Rays are aimed at the boxes' faces, edges and corners to
/// graze them, and t_max is put at the exact entry.
#[test]
fn ray_box_entry_is_conservative() {
    let mut rng = Rng(11);
    let (mut exact_hits, mut near_misses) = (0, 0);
    for i in 0..200_000 {
        let scale = [1e-3, 1.0, 1e3][i % 3];
        let c = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale;
        let h = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * scale;
        let b = Aabb { min: c - h, max: c + h };
        // A point on the boundary: snap some coordinates to a bound.
        let mut q = rng.point_in(&b);
        for axis in 0..3 {
            if rng.unit() < 0.6 {
                q[axis] = if rng.unit() < 0.5 { b.min[axis] } else { b.max[axis] };
            }
        }
        let mut origin = c + rng.unit_vector() * scale * rng.range(1.5, 20.0);
        let mut direction = q - origin;
        if rng.unit() < 0.2 {
            let axis = rng.below(3);
            direction[axis] = 0.0;
            origin[axis] = q[axis];
        }
        let (t_min, t_max) = match i % 4 {
            0 => (0.0, f32::INFINITY),
            1 => (-f32::MAX, f32::MAX),
            // t_max at (or next to) the exact entry: the comparison with the closest hit so far.
            _ => {
                let exact = ray_box_entry_f64(&b, origin, direction, 0.0, f32::MAX).unwrap_or(1.0) as f32;
                (0.0, if i % 4 == 2 { exact } else { exact.next_up() })
            }
        };
        let got = ray_box_entry(&b, origin, direction.recip(), t_min, t_max);
        let context = format!("box {b:?} origin {origin} dir {direction} [{t_min}, {t_max}]: {got:?}");
        match ray_box_interval_f64(&b, origin, direction, t_min, t_max) {
            Some((near, far)) if near <= far => {
                exact_hits += 1;
                let entry = got.unwrap_or_else(|| panic!("culled: {context}"));
                assert!(f64::from(entry) <= near, "entry later than exact {near}: {context}");
            }
            Some((near, far)) if got.is_some() => {
                near_misses += 1;
                let tolerance = 1e-6 * (near.abs() + far.abs());
                assert!(near <= far + tolerance, "accepted a clear miss ({near} > {far}): {context}");
            }
            _ => assert!(got.is_none(), "accepted a miss: {context}"),
        }
    }
    println!("slab test: {exact_hits} exact hits kept, {near_misses} near misses accepted");
    assert!(exact_hits > 100_000);
}

#[test]
fn empty_bvh() {
    let bvh = Bvh::build(&[]);
    check_invariants(&bvh, &[]);
    assert_eq!(bvh.sah_cost(), 0.0);
    let mut rng = Rng(3);
    for _ in 0..1000 {
        let origin = Vec3::new(rng.range(-10.0, 10.0), rng.range(-10.0, 10.0), rng.range(-10.0, 10.0));
        let hit = bvh.closest_hit(origin, rng.unit_vector(), -f32::MAX, f32::MAX, |_, _, _| panic!("no primitive"));
        assert_eq!(hit, None);
    }
}

#[test]
fn one_and_two_primitives() {
    let tri: Triangle = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let one = vec![tri];
    let bvh = Bvh::build(&triangle_bounds(&one));
    check_invariants(&bvh, &triangle_bounds(&one));
    assert_eq!((bvh.nodes.len(), bvh.depth(), bvh.leaf_count()), (1, 1, 1));
    let ray = Ray { origin: Vec3::new(0.25, 0.25, 1.0), direction: -Vec3::Z, t_min: 0.0, t_max: f32::INFINITY };
    assert_eq!(bvh_hit(&bvh, &one, &ray).0, Some((0, 1.0)));
    let away = Ray { direction: Vec3::Z, ..ray };
    assert_eq!(bvh_hit(&bvh, &one, &away).0, None);
    let ortho = Ray { t_min: -f32::MAX, t_max: f32::MAX, ..away };
    assert_eq!(bvh_hit(&bvh, &one, &ortho).0, Some((0, -1.0)));

    // Two triangles one behind the other: the nearer wins from either side.
    let two = vec![tri, tri.map(|v| v - Vec3::Z)];
    let bounds = triangle_bounds(&two);
    let bvh = Bvh::build(&bounds);
    check_invariants(&bvh, &bounds);
    assert_eq!(bvh_hit(&bvh, &two, &ray).0, Some((0, 1.0)));
    let from_below = Ray { origin: Vec3::new(0.25, 0.25, -3.0), direction: Vec3::Z, ..ray };
    assert_eq!(bvh_hit(&bvh, &two, &from_below).0, Some((1, 2.0)));
    let mut rng = Rng(5);
    let rays = ray_mix(&mut rng, &two, 600);
    assert_agrees_with_brute_force(&bvh, &two, &rays);
}

#[test]
fn invariants_on_random_boxes() {
    let mut rng = Rng(1);
    for n in [2, 3, 4, 5, 7, 16, 17, 100, 1000, 10_000, 100_000] {
        let boxes = random_boxes(&mut rng, n);
        let bvh = Bvh::build(&boxes);
        check_invariants(&bvh, &boxes);
        if n >= 1000 {
            // Sanity of the SAH: far better than one leaf of n (cost n).
            assert!(bvh.sah_cost() < n as f32 / 10.0, "n {n}: SAH cost {}", bvh.sah_cost());
        }
    }
}

#[test]
fn identical_boxes_terminate_and_split_by_index() {
    let tri: Triangle = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let tris = vec![tri; 1000];
    let bounds = triangle_bounds(&tris);
    let bvh = Bvh::build(&bounds);
    check_invariants(&bvh, &bounds);
    assert_eq!(bvh.depth(), 1 + 1000usize.div_ceil(MAX_LEAF_SIZE).next_power_of_two().trailing_zeros() as usize);
    // Every ray that hits hits all of them at the same t: any primitive is right.
    let mut rng = Rng(9);
    let rays = ray_mix(&mut rng, &tris, 300);
    let (hits, _) = assert_agrees_with_brute_force(&bvh, &tris, &rays);
    assert!(hits > 10);
}

#[test]
fn points_and_segments() {
    // Zero-area boxes: the SAH has nothing to compare, splits fall back to medians.
    let mut rng = Rng(2);
    let points: Vec<Aabb> = (0..5000)
        .map(|i| {
            let p = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            let q = if i % 2 == 0 { p } else { p + Vec3::X * rng.unit() };
            Aabb::of_points(&[p, q])
        })
        .collect();
    let bvh = Bvh::build(&points);
    check_invariants(&bvh, &points);
    let on_a_line: Vec<Aabb> = (0..5000)
        .map(|i| Aabb::of_points(&[Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32 + 0.5, 0.0, 0.0)]))
        .collect();
    let bvh = Bvh::build(&on_a_line);
    check_invariants(&bvh, &on_a_line);
    assert_eq!(bvh.sah_cost(), 0.0, "no area");
}

#[test]
fn flat_scene_in_one_plane() {
    let mut rng = Rng(4);
    let tris: Vec<Triangle> =
        random_triangles(&mut rng, 3000, 10.0, 0.5).into_iter().map(|t| t.map(|v| Vec3::new(v.x, v.y, 0.0))).collect();
    let bounds = triangle_bounds(&tris);
    assert!(bounds.iter().all(|b| b.min.z == 0.0 && b.max.z == 0.0));
    let bvh = Bvh::build(&bounds);
    check_invariants(&bvh, &bounds);
    let mut rays = ray_mix(&mut rng, &tris, 3000);
    // Straight down and up (two zero components, as an axis-aligned orthographic camera).
    for i in 0..1000 {
        let origin = Vec3::new(rng.range(-10.0, 10.0), rng.range(-10.0, 10.0), 5.0);
        let dz = if i % 2 == 0 { -1.0 } else { 1.0 };
        rays.push(Ray { origin, direction: Vec3::new(0.0, 0.0, dz), t_min: -f32::MAX, t_max: f32::MAX });
    }
    let (hits, _) = assert_agrees_with_brute_force(&bvh, &tris, &rays);
    assert!(hits > 500, "{hits}");
}

/// Triangles spanning the cubes [s, 2s]³ for s = 0.99^i: each SAH split peels off a few of
/// the largest, so without the depth guard the tree is 46 deep (measured with the guard
/// disabled); with it, within STACK_SIZE. The traversal's fixed stack is exercised too.
#[test]
fn depth_is_bounded_on_a_pathological_distribution() {
    let tris: Vec<Triangle> = (0..8700)
        .map(|i| {
            let s = 0.99f32.powi(i);
            [Vec3::splat(s), Vec3::new(2.0 * s, s, 2.0 * s), Vec3::new(s, 2.0 * s, s)]
        })
        .collect();
    let bounds = triangle_bounds(&tris);
    let bvh = Bvh::build(&bounds);
    check_invariants(&bvh, &bounds);
    println!("geometric boxes: depth {}", bvh.depth());
    assert!(bvh.depth() >= STACK_SIZE - 4, "still deep: the guard was needed here");
    let mut rng = Rng(6);
    let mut rays = ray_mix(&mut rng, &tris, 1500);
    // Rays at the small triangles near the origin, where the tree is deepest. Their origins
    // are near, on the triangles' scale: from afar, f32 Möller–Trumbore reports hits on such
    // tiny triangles (4e-6 seen from 4 away) at t outside their boxes, which no box test can
    // agree with.
    for _ in 0..500 {
        let s = 0.99f32.powi(rng.below(tris.len()) as i32);
        let target = Vec3::splat(s) + Vec3::new(rng.unit(), rng.unit(), rng.unit()) * s;
        let origin = target + rng.unit_vector() * 3.0 * s;
        rays.push(Ray { origin, direction: target - origin, t_min: 0.0, t_max: f32::INFINITY });
    }
    let (hits, _) = assert_agrees_with_brute_force(&bvh, &tris, &rays);
    assert!(hits > 100, "{hits}");
}

#[test]
fn closest_hit_matches_brute_force_on_random_triangles() {
    let mut rng = Rng(8);
    for (n, size) in [(100, 2.0), (2000, 0.8), (20_000, 0.3)] {
        let tris = random_triangles(&mut rng, n, 10.0, size);
        let bounds = triangle_bounds(&tris);
        let bvh = Bvh::build(&bounds);
        check_invariants(&bvh, &bounds);
        let rays = ray_mix(&mut rng, &tris, 3000);
        let (hits, tests) = assert_agrees_with_brute_force(&bvh, &tris, &rays);
        println!("{n} random triangles: {hits}/{} rays hit, {tests:.1} primitive tests per ray", rays.len());
        assert!(hits > rays.len() / 10, "{hits}");
    }
}

fn mesh_triangles(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<Triangle> {
    triangles.iter().map(|t| t.map(|i| positions[i as usize].as_vec3())).collect()
}

fn print_stats(name: &str, bvh: &Bvh, seconds: f64) {
    println!(
        "{name}: {} primitives, build {:.1} ms, SAH cost {:.2}, depth {}, {} nodes, {} leaves ({:.2} primitives per leaf)",
        bvh.order.len(),
        seconds * 1e3,
        bvh.sah_cost(),
        bvh.depth(),
        bvh.nodes.len(),
        bvh.leaf_count(),
        bvh.order.len() as f64 / bvh.leaf_count() as f64
    );
}

#[test]
fn bunny_40k() {
    let Some(corpus) = common::corpus() else { return };
    let path = corpus.join("meshes/bunny_40k.obj");
    let mesh = raycaster::scene::load_obj(&path).expect("bunny_40k.obj loads");
    let tris = mesh_triangles(&mesh.positions, &mesh.triangles);
    let bounds = triangle_bounds(&tris);
    let start = Instant::now();
    let bvh = Bvh::build(&bounds);
    let seconds = start.elapsed().as_secs_f64();
    check_invariants(&bvh, &bounds);
    print_stats("bunny_40k", &bvh, seconds);

    // Rays from a sphere around the bunny at points in its box, plus the mix.
    let mut rng = Rng(10);
    let scene = bounds_of(&bounds);
    let radius = (scene.max - scene.min).length();
    let mut rays: Vec<Ray> = (0..1500)
        .map(|_| {
            let origin = scene.centroid() + rng.unit_vector() * 2.0 * radius;
            Ray { origin, direction: rng.point_in(&scene) - origin, t_min: 0.0, t_max: f32::INFINITY }
        })
        .collect();
    rays.extend(ray_mix(&mut rng, &tris, 600));
    let (hits, tests) = assert_agrees_with_brute_force(&bvh, &tris, &rays);
    println!("bunny_40k: {hits}/{} rays hit, {tests:.1} primitive tests per ray", rays.len());
    assert!(hits > rays.len() / 3, "{hits}");
    // The culling works: a small fraction of the 40k triangles is tested per ray.
    assert!(tests < 200.0, "{tests} primitive tests per ray");
}

/// A UV sphere of about 1.3M triangles (the poles' triangles are degenerate).
fn uv_sphere(rings: usize, segments: usize) -> Vec<Triangle> {
    let point = |r: usize, s: usize| {
        let theta = std::f64::consts::PI * r as f64 / rings as f64;
        let phi = std::f64::consts::TAU * s as f64 / segments as f64;
        DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()).as_vec3()
    };
    let mut tris = Vec::with_capacity(2 * rings * segments);
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (point(r, s), point(r, s + 1), point(r + 1, s), point(r + 1, s + 1));
            tris.push([a, c, b]);
            tris.push([b, c, d]);
        }
    }
    tris
}

#[test]
fn one_point_three_million_triangles() {
    let tris = uv_sphere(570, 1140);
    let bounds = triangle_bounds(&tris);
    let start = Instant::now();
    let bvh = Bvh::build(&bounds);
    let seconds = start.elapsed().as_secs_f64();
    check_invariants(&bvh, &bounds);
    print_stats("UV sphere", &bvh, seconds);
    let mut rng = Rng(12);
    let rays = ray_mix(&mut rng, &tris, 60);
    let (hits, tests) = assert_agrees_with_brute_force(&bvh, &tris, &rays);
    println!("UV sphere: {hits}/{} rays hit, {tests:.1} primitive tests per ray", rays.len());
    assert!(hits > 20, "{hits}");
}

/// On the GPU: the kernel through the hierarchy against the same kernel's flat loops, for
/// every pixel of a few scenes (meshes seen from outside and inside, a mixed scene with
/// spheres, ellipsoids and triangles in one hierarchy): the same hits at the same distance,
/// the same normals. Ties (two primitives at exactly the same t) may pick either.
#[test]
fn gpu_hierarchy_matches_flat_loops() {
    use raycaster::gpu::{Acceleration, GpuOptions};
    use raycaster::render::RenderOptions;
    if common::gpu().is_none() {
        return;
    }
    let gpu = common::gpu().unwrap();
    let with = |acceleration| gpu.on_same_device(GpuOptions { acceleration, ..GpuOptions::default() });
    // Asked for by name: `auto` would take bins for these primary rays.
    let (flat, forced) = (with(Acceleration::Flat), with(Acceleration::Hierarchy));
    let mut scenes: Vec<(String, raycaster::scene::Scene, Option<tempfile::TempDir>)> = vec![
        {
            let (dir, scene) = common::hard::load_hard_ok("closed_mesh_inside.txt");
            ("closed_mesh_inside".into(), scene, dir)
        },
        ("offset_base".into(), common::hard::load_hard_ok("offset_base.txt").1, None),
        (
            "ellipsoids".into(),
            raycaster::scene::load_scene(&common::scenes_dir().join("ellipsoids.txt")).unwrap(),
            None,
        ),
    ];
    // Without the course's files, our own scenes above still run.
    if let Some(corpus) = common::corpus() {
        for name in ["scene2_10_bunny_1k", "scene2_15_crazy_transforms", "scene2_07_sphere_triangles"] {
            let path = corpus.join(format!("a2/{name}.txt"));
            scenes.push((name.into(), raycaster::scene::load_scene(&path).unwrap(), None));
        }
    }
    for (name, scene, _dir) in &scenes {
        let options = RenderOptions::all(96, 80);
        let a = flat.render(scene, &options).unwrap();
        let b = forced.render(scene, &options).unwrap();
        let mut differing = 0;
        for k in 0..a.hit.len() {
            if a.hit[k] != b.hit[k] || (a.hit[k] && (a.depth[k] != b.depth[k] || a.normal[k] != b.normal[k])) {
                differing += 1;
            }
        }
        assert!(b.hit.iter().any(|&h| h), "{name}: nothing hit");
        assert_eq!(differing, 0, "{name}: {differing} pixels differ between the hierarchy and the flat loops");
    }
}

/// lavapipe ends an invocation's loops after 65535 iterations in all (docs/lavapipe.md), so
/// the walk of a bin may spend one iteration per item and no more: the loops over the
/// packet's rays inside it must be unrolled. Here one bin lists 20 000 slivers that no
/// pixel's ray meets (diagonals across the bin, between its pixels' centres), nearer than a
/// wall behind them, which every ray hits: it is the last item of the list, so a walk cut
/// short by the limit leaves pixels empty.
#[test]
fn gpu_bins_walk_long_lists_to_the_end() {
    use raycaster::gpu::binning::BIN_COLUMNS;
    use raycaster::gpu::Acceleration;
    use raycaster::render::RenderOptions;
    let Some(shared) = common::gpu_with(Acceleration::Bins) else { return };
    // Subgroups of exactly one row of a bin (lavapipe's 8 lanes, with 256-bit vectors)
    // share their loads; others keep one load per lane.
    let info = shared.adapter_info();
    let one_row = info.subgroup_min_size == BIN_COLUMNS && info.subgroup_max_size == BIN_COLUMNS;
    assert_eq!(shared.shares_bin_loads(), one_row, "{info:?}");
    const SLIVERS: usize = 20_000;
    // Angle 90°: the ray through column i and row j (from the bottom) of 8 has slopes
    // ((i − 3.5)/4, (j − 3.5)/4), whose difference is a multiple of ¼. The slivers lie
    // where that difference is between 0.115 and 0.135, so no ray meets them, while their
    // bounds hold the centres of columns 1 to 7 and of every row.
    let mut text = String::from(
        "PerspectiveCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 angle 90 }
         Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
         Background { color 0 0 0 ambientLight 0 0 0 }
         Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n",
    );
    text.push_str(&format!("Group {{ numObjects {} MaterialIndex 0\n", SLIVERS + 1));
    for k in 0..SLIVERS {
        let d = 1.0 + k as f64 * 4e-4;
        let [a, b, c] =
            [(-0.95 + 0.115, -0.95), (0.95 + 0.115, 0.95), (0.95 + 0.135, 0.95)].map(|(x, y)| (x * d, y * d));
        text.push_str(&format!(
            "Triangle {{ vertex0 {} {} {} vertex1 {} {} {} vertex2 {} {} {} }}\n",
            a.0, a.1, -d, b.0, b.1, -d, c.0, c.1, -d
        ));
    }
    text.push_str("Triangle { vertex0 -1000 -1000 -100 vertex1 1000 -1000 -100 vertex2 0 1000 -100 } }\n");
    let scene = raycaster::scene::parse_scene(&text, "slivers.txt".as_ref()).unwrap();
    let options = RenderOptions { stats: true, ..RenderOptions::all(8, 8) };
    for bins in [shared, common::gpu_with_own_bin_loads()] {
        walks_long_lists_to_the_end(&bins, &scene, &options, SLIVERS);
    }
}

fn walks_long_lists_to_the_end(
    bins: &raycaster::gpu::GpuRenderer,
    scene: &raycaster::scene::Scene,
    options: &raycaster::render::RenderOptions,
    slivers: usize,
) {
    use raycaster::gpu::Acceleration;
    let mut frame = raycaster::render::Frame::new(options);
    let stats = bins
        .render_tiles(scene, options, |first_row, tile| {
            frame.paste(first_row, &tile);
            Ok::<(), raycaster::gpu::GpuError>(())
        })
        .unwrap();
    assert_eq!(stats.acceleration, Acceleration::Bins);
    // Every pixel walked the whole list (a walk cut short would be handed to the reference).
    assert_eq!(stats.pixels_cut_short, 0, "walks cut short by the loop limit");
    let tests = stats.counted.unwrap().intersections;
    // Column 0's rays skip them (outside their rectangle) in main_bins; the 56 others
    // test each (main_bins_shared tests all 64).
    assert!(tests >= (56 * slivers) as u64, "{tests} ray/triangle tests: the slivers are not in the bin's list");
    let missed = frame.hit.iter().filter(|&&h| !h).count();
    assert_eq!(missed, 0, "{missed} of 64 pixels missed the wall at the end of the bin's list");
    for (k, depth) in frame.depth.iter().enumerate() {
        assert!((100.0..=100.0 * 3f32.sqrt()).contains(depth), "pixel {k}: t = {depth}, not the wall's");
    }
}
