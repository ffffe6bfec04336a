//! Bounding volume hierarchy: a binned-SAH builder, a flat 32-byte node layout that the WGSL
//! kernel reads as it is, and, on the CPU, the exact traversal the kernel runs.
//!
//! **Layout.** `nodes[0]` is the root. An interior node has `count == 0` and its two children at
//! `nodes[first]` and `nodes[first + 1]`; a leaf has `count >= 1` and holds the primitives
//! `order[first .. first + count]`. Node boxes are the exact (f32) union of their primitives'
//! boxes. An empty hierarchy (no primitives) is one node with [`Aabb::EMPTY`] bounds and
//! `count == 0`; no ray hits that box, so traversal never reads its (nonexistent) children.
//!
//! **Depth.** `depth()` counts the nodes on the longest root-to-leaf path (a lone root leaf has
//! depth 1). The traversal's stack never holds more than `depth()` entries (see
//! [`Bvh::closest_hit`]) and the builder keeps `depth() <= STACK_SIZE`, so a stack of
//! `STACK_SIZE` entries cannot overflow. An entry is a node index and the entry distance of its
//! box (in WGSL, e.g. `array<u32, STACK_SIZE>` and `array<f32, STACK_SIZE>` side by side).
//!
//! Sources: Wald, "On fast Construction of SAH-based Bounding Volume Hierarchies", IEEE
//! Symposium on Interactive Ray Tracing 2007 (binning); MacDonald & Booth, "Heuristics for ray
//! tracing using space subdivision", The Visual Computer 6(3) 1990 (the surface area
//! heuristic); Ize, "Robust BVH Ray Traversal", JCGT 2(2) 2013 (the slab test's error bound).

use glam::Vec3;

/// Axis-aligned box in f32 (GPU precision); the f64 twin of the scene model is
/// [`crate::scene::Bounds`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// The box that contains nothing (`min > max`), the identity of [`Aabb::union`]. Finite
    /// (±`f32::MAX`, not ±∞) so that it can go into a GPU buffer unchanged.
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::MAX), max: Vec3::splat(-f32::MAX) };

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Halves before adding, so that boxes near ±`f32::MAX` do not overflow.
    pub fn centroid(&self) -> Vec3 {
        self.min * 0.5 + self.max * 0.5
    }

    /// 0 for an empty box; flat boxes have the area of their two faces, lines and points 0.
    pub fn surface_area(&self) -> f32 {
        let d = self.max - self.min;
        if d.min_element() < 0.0 {
            return 0.0;
        }
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    pub fn of_points(points: &[Vec3]) -> Aabb {
        let mut b = Aabb::EMPTY;
        points.iter().for_each(|&p| b.grow(p));
        b
    }
}

/// 32 bytes, mirrored in WGSL as
/// `struct BvhNode { min: vec3<f32>, first: u32, max: vec3<f32>, count: u32 }`.
/// Interior node: `count == 0`, children are nodes `first` and `first + 1` (adjacent).
/// Leaf: primitives `order[first .. first + count]`, `count >= 1`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub first: u32,
    pub max: [f32; 3],
    pub count: u32,
}

impl BvhNode {
    fn new(bounds: &Aabb, first: u32, count: u32) -> BvhNode {
        BvhNode { min: bounds.min.to_array(), first, max: bounds.max.to_array(), count }
    }

    fn bounds(&self) -> Aabb {
        Aabb { min: Vec3::from_array(self.min), max: Vec3::from_array(self.max) }
    }

    fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// Primitive indices in leaf order.
    pub order: Vec<u32>,
}

/// Most primitives in a leaf; the builder never exceeds it (coincident centroids are split by
/// index), so the kernel's leaf loop runs at most this many times. Measured on bunny_40k
/// (20 000 rays from outside at points in its box, this traversal): with the SAH costs at 1:1
/// the leaves average 1.0 / 1.6 / 1.75 / 1.75 primitives for limits 1 / 2 / 4 / 8, with
/// 23.0 / 21.4 / 21.2 / 21.2 nodes popped and 1.9 / 2.6 / 2.7 / 2.7 primitives tested per ray;
/// beyond 4 nothing changes. (A traversal cost of 4 instead of 1 grows the leaves to ~3 and
/// saves 6% of the pops for 70% more primitive tests.)
pub const MAX_LEAF_SIZE: usize = 4;

/// Length of the traversal stack; the builder guarantees `depth() <= STACK_SIZE`.
pub const STACK_SIZE: usize = 32;

/// Wald 2007 finds 16 bins within a few percent of a full SAH sweep.
const BIN_COUNT: usize = 16;

/// SAH cost of visiting an interior node (testing its two children's boxes) relative to
/// testing one primitive. Both are about the same amount of arithmetic in the kernel.
const TRAVERSAL_COST: f32 = 1.0;
const INTERSECTION_COST: f32 = 1.0;

impl Bvh {
    /// Binned SAH build along the longest centroid axis (Wald 2007), root at `nodes[0]`.
    ///
    /// A node becomes a leaf when it has one primitive, or at most [`MAX_LEAF_SIZE`] and the
    /// SAH prefers a leaf or has no split to offer. Otherwise it is split at the best of
    /// `BIN_COUNT` bins' planes; it falls back to a median split (half the primitives each
    /// side, ordered along the longest centroid axis, any order when the centroids coincide)
    /// when the centroids have no extent, the box has no area, or the SAH split could make a
    /// branch deeper than [`STACK_SIZE`].
    /// O(n log n); the subtrees of the top two levels are built in parallel (rayon).
    /// Panics only beyond `u32::MAX` primitives.
    pub fn build(bounds: &[Aabb]) -> Bvh {
        let count = u32::try_from(bounds.len()).expect("at most u32::MAX primitives");
        if count == 0 {
            return Bvh { nodes: vec![BvhNode::new(&Aabb::EMPTY, 0, 0)], order: Vec::new() };
        }
        assert!(fits_in_stack(1, bounds.len()), "too many primitives for a {STACK_SIZE}-entry stack");
        let mut prims: Vec<Prim> =
            bounds.iter().zip(0..count).map(|(b, index)| Prim { bounds: *b, centroid: b.centroid(), index }).collect();
        let boxes = range_boxes(&prims);
        let nodes = subtree(&mut prims, 0, 1, boxes);
        Bvh { nodes, order: prims.iter().map(|p| p.index).collect() }
    }

    /// The same tree over primitives that moved: every node's box made again from `bounds`
    /// (indexed as [`Bvh::build`]'s were), a leaf's from its primitives and an interior
    /// node's from its two children, which come after it. Which primitives share a leaf
    /// stays as built, so the tree stays valid (every box holds what is below it) for any
    /// `bounds`, and only its cost can change: the refitting of Wald, Boulos and Shirley,
    /// "Ray Tracing Deformable Scenes using Dynamic Bounding Volume Hierarchies" (ACM TOG
    /// 2007). For a translated scene (the GPU's camera-relative boxes of a moved camera)
    /// the cost does not change but for rounding. Boxes are unions, exact in f32, so
    /// refitting with the build's own boxes gives its nodes back bit for bit.
    pub fn refit(&mut self, bounds: &[Aabb]) {
        assert_eq!(bounds.len(), self.order.len(), "a refit takes the built primitives' boxes");
        if self.order.is_empty() {
            return;
        }
        for k in (0..self.nodes.len()).rev() {
            let node = self.nodes[k];
            let (first, count) = (node.first as usize, node.count as usize);
            let boxed = if node.is_leaf() {
                self.order[first..first + count].iter().fold(Aabb::EMPTY, |b, &p| b.union(&bounds[p as usize]))
            } else {
                self.nodes[first].bounds().union(&self.nodes[first + 1].bounds())
            };
            self.nodes[k] = BvhNode::new(&boxed, node.first, node.count);
        }
    }

    /// Expected cost of a random ray through the root box (MacDonald & Booth): the sum over
    /// nodes of P(ray hits node | hits root) = area / root area, times `TRAVERSAL_COST` for an
    /// interior node or `INTERSECTION_COST` × count for a leaf. 0 when the root box has no
    /// area (empty, or all primitives are points or segments).
    pub fn sah_cost(&self) -> f32 {
        let root_area = self.nodes[0].bounds().surface_area();
        if self.order.is_empty() || root_area == 0.0 {
            return 0.0;
        }
        let node_cost = |n: &BvhNode| {
            let weight = if n.is_leaf() { INTERSECTION_COST * n.count as f32 } else { TRAVERSAL_COST };
            f64::from(weight * n.bounds().surface_area())
        };
        (self.nodes.iter().map(node_cost).sum::<f64>() / f64::from(root_area)) as f32
    }

    /// Nodes on the longest root-to-leaf path; 0 for an empty hierarchy.
    pub fn depth(&self) -> usize {
        if self.order.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut pending = vec![(0usize, 1usize)];
        while let Some((index, depth)) = pending.pop() {
            let node = self.nodes[index];
            if node.is_leaf() {
                deepest = deepest.max(depth);
            } else {
                pending.push((node.first as usize, depth + 1));
                pending.push((node.first as usize + 1, depth + 1));
            }
        }
        deepest
    }

    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.is_leaf()).count()
    }

    /// The kernel's traversal, on the CPU. One loop pops one node per iteration; a stack entry
    /// is a node and the entry distance of its box, computed when it was pushed.
    /// - A popped node whose entry distance is `>=` the closest hit so far is skipped (a closer
    ///   hit was found after it was pushed).
    /// - A leaf tests its primitives with `hit(prim, t_min, closest)`, which returns the hit's
    ///   t if `t_min < t < closest`.
    /// - An interior node tests both children's boxes against `[t_min, closest]` and pushes
    ///   the farther one first, so that the nearer one is visited next.
    ///
    /// The stack never holds more than `depth()` entries: when a node at depth L is popped, the
    /// entries below it are at distinct depths 2..=L, so pushing its two children makes at
    /// most L + 1 ≤ `depth()`.
    pub fn closest_hit(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_min: f32,
        t_max: f32,
        mut hit: impl FnMut(u32, f32, f32) -> Option<f32>,
    ) -> Option<(u32, f32)> {
        let inv_dir = direction.recip();
        let mut closest = t_max;
        let mut best = None;
        let mut stack = [StackEntry { node: 0, entry: 0.0 }; STACK_SIZE];
        let mut len = 0;
        if let Some(entry) = ray_box_entry(&self.nodes[0].bounds(), origin, inv_dir, t_min, closest) {
            stack[0] = StackEntry { node: 0, entry };
            len = 1;
        }
        while len > 0 {
            len -= 1;
            let StackEntry { node, entry } = stack[len];
            if entry >= closest {
                continue;
            }
            let node = self.nodes[node as usize];
            if node.is_leaf() {
                for &prim in &self.order[node.first as usize..(node.first + node.count) as usize] {
                    if let Some(t) = hit(prim, t_min, closest) {
                        closest = t;
                        best = Some((prim, t));
                    }
                }
            } else {
                let child = |index: u32| {
                    let entry = ray_box_entry(&self.nodes[index as usize].bounds(), origin, inv_dir, t_min, closest);
                    entry.map(|entry| StackEntry { node: index, entry })
                };
                let (left, right) = (child(node.first), child(node.first + 1));
                let right_is_nearer = matches!((left, right), (Some(l), Some(r)) if r.entry < l.entry);
                let (near, far) = if right_is_nearer { (right, left) } else { (left, right) };
                // The farther one first, so that the nearer one is popped next.
                for child in [far, near].into_iter().flatten() {
                    stack[len] = child;
                    len += 1;
                }
            }
        }
        best
    }
}

#[derive(Clone, Copy)]
struct StackEntry {
    node: u32,
    /// Entry distance of the node's box.
    entry: f32,
}

/// gamma(n) = n·u / (1 − n·u), u = `f32::EPSILON / 2`: the relative error bound of n
/// successive f32 roundings (Higham; Pharr, Jakob & Humphreys, PBRT 3rd ed., §3.9).
const fn gamma(n: f32) -> f32 {
    let u = f32::EPSILON / 2.0;
    n * u / (1.0 - n * u)
}

/// A slab distance `(bound − origin) · inv_dir` is three roundings away from the exact one
/// (the subtraction, the reciprocal, the product), so within a relative gamma(3). Ize widens
/// by 2·gamma(3) to cover the error of both ends and the widening's own rounding.
pub const SLAB_MARGIN: f32 = 2.0 * gamma(3.0);

/// Robust slab test (Ize, "Robust BVH Ray Traversal", JCGT 2(2) 2013): the ray
/// `origin + t · direction` with `inv_dir = 1 / direction` against box `b` over `[t_min, t_max]`.
/// Returns the entry distance (the larger of `t_min` and the slabs' entries) or `None`.
///
/// Rounding never culls a box that the exact ray meets within `[t_min, t_max]`: the slabs'
/// exit is raised and their entry lowered by the relative margin 2·gamma(3). Ize multiplies the
/// exit by 1 + 2·gamma(3); scaling by 1 ± margin according to the sign of t is the same for
/// t > 0 and also conservative for negative t (orthographic rays run from `t_min = -f32::MAX`).
/// Lowering the entry too keeps the comparison with `t_max` (the closest hit so far)
/// conservative, which Ize's exit-only widening does not cover. Denormal results are outside
/// this bound (their error is absolute, at most 2⁻¹⁵⁰).
///
/// A zero direction component (`inv_dir` ±∞) is handled explicitly: the ray is parallel to that
/// slab and is inside it for all t (origin within the bounds, boundary included) or for none.
/// This avoids 0·∞ = NaN when the origin lies on the bound.
pub fn ray_box_entry(b: &Aabb, origin: Vec3, inv_dir: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let (near_x, far_x) = slab(b.min.x, b.max.x, origin.x, inv_dir.x);
    let (near_y, far_y) = slab(b.min.y, b.max.y, origin.y, inv_dir.y);
    let (near_z, far_z) = slab(b.min.z, b.max.z, origin.z, inv_dir.z);
    let near = near_x.max(near_y).max(near_z);
    let far = far_x.min(far_y).min(far_z);
    let entry = t_min.max(lowered(near));
    let exit = t_max.min(raised(far));
    (entry <= exit).then_some(entry)
}

/// `t` moved down by the relative margin. Scaling (not adding `|t| · margin`) keeps ±∞ from
/// overflowed slab distances as they are instead of turning ∞ − ∞ into NaN.
fn lowered(t: f32) -> f32 {
    t * if t > 0.0 { 1.0 - SLAB_MARGIN } else { 1.0 + SLAB_MARGIN }
}

/// `t` moved up by the relative margin; see [`lowered`].
fn raised(t: f32) -> f32 {
    t * if t > 0.0 { 1.0 + SLAB_MARGIN } else { 1.0 - SLAB_MARGIN }
}

/// The t interval (near, far) in which the ray is inside `lo <= x <= hi` along one axis.
fn slab(lo: f32, hi: f32, origin: f32, inv_dir: f32) -> (f32, f32) {
    if inv_dir.abs() > f32::MAX {
        // Parallel to the slab. ±f32::MAX rather than ±∞ keeps the values finite.
        let inside = lo <= origin && origin <= hi;
        return if inside { (-f32::MAX, f32::MAX) } else { (f32::MAX, -f32::MAX) };
    }
    // Choosing the bounds by the direction's sign (rather than min/max of the two distances)
    // keeps an empty box (lo > hi) empty.
    let (near, far) = if inv_dir >= 0.0 { (lo, hi) } else { (hi, lo) };
    ((near - origin) * inv_dir, (far - origin) * inv_dir)
}

/// Levels of the tree whose two subtrees are built in parallel (rayon): up to 4 subtrees at
/// once, chosen for 2 cores (the only machine measured: bunny_40k 15.9 → 10.2 ms). Each
/// level copies its subtrees' nodes once more, into their parent's array.
const PARALLEL_LEVELS: usize = 2;

/// Below this many primitives a node's subtrees are built on the caller's thread.
const PARALLEL_MIN: usize = 4096;

/// A primitive as the builder moves it: its box, the box's centroid and its index. The
/// builder partitions these records themselves, so that every pass reads them in order.
#[derive(Clone, Copy)]
struct Prim {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

/// The union of a range's boxes and the box of its centroids.
#[derive(Clone, Copy)]
struct Boxes {
    bounds: Aabb,
    centroids: Aabb,
}

fn range_boxes(prims: &[Prim]) -> Boxes {
    let mut boxes = Boxes { bounds: Aabb::EMPTY, centroids: Aabb::EMPTY };
    for p in prims {
        boxes.bounds = boxes.bounds.union(&p.bounds);
        boxes.centroids.grow(p.centroid);
    }
    boxes
}

/// Primitives and box of one SAH bin.
#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: usize,
}

impl Bin {
    const EMPTY: Bin = Bin { bounds: Aabb::EMPTY, count: 0 };

    fn union(&self, o: &Bin) -> Bin {
        Bin { bounds: self.bounds.union(&o.bounds), count: self.count + o.count }
    }
}

/// A split plane between bins `plane - 1` and `plane` along `axis`, with its SAH cost and
/// the two sides' boxes and counts.
struct SahSplit {
    axis: usize,
    plane: usize,
    left: Bin,
    right: Bin,
    cost: f32,
}

/// The subtree of `prims` (`offset` is the first one's place in the final order), its root at
/// index 0 of the nodes returned and at `depth` in the whole tree.
fn subtree(prims: &mut [Prim], offset: usize, depth: usize, boxes: Boxes) -> Vec<BvhNode> {
    // A binary tree with at most one primitive per leaf has at most 2n − 1 nodes.
    let mut nodes = Vec::with_capacity(2 * prims.len() - 1);
    nodes.push(BvhNode::default());
    build_node(&mut nodes, 0, prims, offset, depth, boxes);
    nodes
}

/// Fills `nodes[node]` (already allocated) with the subtree of `prims`.
fn build_node(nodes: &mut Vec<BvhNode>, node: usize, prims: &mut [Prim], offset: usize, depth: usize, boxes: Boxes) {
    let Some((mid, left, right)) = split(prims, depth, &boxes) else {
        nodes[node] = BvhNode::new(&boxes.bounds, offset as u32, prims.len() as u32);
        return;
    };
    // Both children are allocated together, so that they are adjacent.
    let first = nodes.len();
    nodes[node] = BvhNode::new(&boxes.bounds, first as u32, 0);
    let count = prims.len();
    let (left_prims, right_prims) = prims.split_at_mut(mid);
    if depth <= PARALLEL_LEVELS && count >= PARALLEL_MIN {
        let (left_nodes, right_nodes) = rayon::join(
            || subtree(left_prims, offset, depth + 1, left),
            || subtree(right_prims, offset + mid, depth + 1, right),
        );
        append_subtrees(nodes, first, &left_nodes, &right_nodes);
        return;
    }
    nodes.extend([BvhNode::default(); 2]);
    build_node(nodes, first, left_prims, offset, depth + 1, left);
    build_node(nodes, first + 1, right_prims, offset + mid, depth + 1, right);
}

/// Appends two subtrees built apart as the children of the node whose `first` is `first`
/// (`nodes.len()`): their roots side by side, then the left one's other nodes, then the
/// right one's, each interior node's `first` moved by where its subtree landed.
fn append_subtrees(nodes: &mut Vec<BvhNode>, first: usize, left: &[BvhNode], right: &[BvhNode]) {
    debug_assert_eq!(nodes.len(), first);
    // Node i > 0 of the left subtree lands at first + 1 + i, of the right at first + L + i.
    let moved = |n: &BvhNode, by: usize| match n.is_leaf() {
        true => *n,
        false => BvhNode { first: n.first + by as u32, ..*n },
    };
    let (left_by, right_by) = (first + 1, first + left.len());
    nodes.push(moved(&left[0], left_by));
    nodes.push(moved(&right[0], right_by));
    nodes.extend(left[1..].iter().map(|n| moved(n, left_by)));
    nodes.extend(right[1..].iter().map(|n| moved(n, right_by)));
}

/// Partitions `prims` and returns where the right child starts, with both children's
/// boxes, or `None` for a leaf.
fn split(prims: &mut [Prim], depth: usize, boxes: &Boxes) -> Option<(usize, Boxes, Boxes)> {
    let count = prims.len();
    if count == 1 {
        return None;
    }
    // An SAH split is only taken when both children can still be finished within the stack.
    let sah = best_binned_split(prims, boxes)
        .filter(|s| fits_in_stack(depth + 1, s.left.count) && fits_in_stack(depth + 1, s.right.count));
    let leaf_cost = INTERSECTION_COST * count as f32;
    if count <= MAX_LEAF_SIZE && sah.as_ref().is_none_or(|s| leaf_cost <= s.cost) {
        return None;
    }
    Some(match sah {
        Some(s) => partition_at_plane(prims, &boxes.centroids, &s),
        None => {
            let mid = partition_at_median(prims, (boxes.centroids.max - boxes.centroids.min).max_position());
            (mid, range_boxes(&prims[..mid]), range_boxes(&prims[mid..]))
        }
    })
}

/// The cheapest of the planes between [`BIN_COUNT`] equal bins of the centroids' extent
/// along its longest axis, or `None` when the centroids coincide or the box has no area
/// (then the SAH cannot tell splits apart). The cost is in the units of a leaf's
/// `INTERSECTION_COST · count`: TRAVERSAL_COST + INTERSECTION_COST · Σ (area · count) / area.
fn best_binned_split(prims: &[Prim], boxes: &Boxes) -> Option<SahSplit> {
    let (bounds, centroids) = (&boxes.bounds, &boxes.centroids);
    let area = bounds.surface_area();
    let axis = (centroids.max - centroids.min).max_position();
    let extent = centroids.max[axis] - centroids.min[axis];
    if !(extent > 0.0 && area > 0.0) {
        return None;
    }
    let mut bins = [Bin::EMPTY; BIN_COUNT];
    for p in prims {
        let bin = &mut bins[bin_index(p.centroid[axis], centroids.min[axis], extent)];
        bin.bounds = bin.bounds.union(&p.bounds);
        bin.count += 1;
    }
    // right[p]: the bins p.. together, for each plane p.
    let mut right = [Bin::EMPTY; BIN_COUNT];
    let mut acc = Bin::EMPTY;
    for plane in (1..BIN_COUNT).rev() {
        acc = acc.union(&bins[plane]);
        right[plane] = acc;
    }
    let mut left = Bin::EMPTY;
    let mut best: Option<SahSplit> = None;
    for plane in 1..BIN_COUNT {
        left = left.union(&bins[plane - 1]);
        if left.count == 0 || right[plane].count == 0 {
            continue;
        }
        let weighted = left.bounds.surface_area() * left.count as f32
            + right[plane].bounds.surface_area() * right[plane].count as f32;
        let cost = TRAVERSAL_COST + INTERSECTION_COST * weighted / area;
        if best.as_ref().is_none_or(|b| cost < b.cost) {
            best = Some(SahSplit { axis, plane, left, right: right[plane], cost });
        }
    }
    best
}

/// Partitions `prims` at the split's plane; returns where the right side starts and both
/// sides' boxes (their bounds from the split's bins, their centroids' boxes gathered here).
fn partition_at_plane(prims: &mut [Prim], centroids: &Aabb, split: &SahSplit) -> (usize, Boxes, Boxes) {
    let (axis, min, extent) =
        (split.axis, centroids.min[split.axis], centroids.max[split.axis] - centroids.min[split.axis]);
    let (mut left_centroids, mut right_centroids) = (Aabb::EMPTY, Aabb::EMPTY);
    let mut left = 0;
    for i in 0..prims.len() {
        let centroid = prims[i].centroid;
        if bin_index(centroid[axis], min, extent) < split.plane {
            left_centroids.grow(centroid);
            prims.swap(left, i);
            left += 1;
        } else {
            right_centroids.grow(centroid);
        }
    }
    debug_assert_eq!(left, split.left.count);
    (
        left,
        Boxes { bounds: split.left.bounds, centroids: left_centroids },
        Boxes { bounds: split.right.bounds, centroids: right_centroids },
    )
}

/// Half the primitives each side (the left one has the smaller centroids along `axis`).
fn partition_at_median(prims: &mut [Prim], axis: usize) -> usize {
    let half = prims.len() / 2;
    prims.select_nth_unstable_by(half, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    half
}

/// The bin of a centroid coordinate; binning and partitioning must agree, so both use this.
fn bin_index(c: f32, min: f32, extent: f32) -> usize {
    // `as usize` saturates (negative and NaN give 0), `min` clamps the maximum to the last bin.
    (((c - min) / extent * BIN_COUNT as f32) as usize).min(BIN_COUNT - 1)
}

/// Whether a node at `depth` with `count` primitives can always be finished within
/// [`STACK_SIZE`] levels: median splits halve the count per level, so they reach leaves of
/// [`MAX_LEAF_SIZE`] after ⌈log₂ ⌈count / MAX_LEAF_SIZE⌉⌉ more levels. If a node fits, so do the
/// children of its median split, hence SAH splits are taken only when both children fit.
fn fits_in_stack(depth: usize, count: usize) -> bool {
    let levels_below = count.div_ceil(MAX_LEAF_SIZE).next_power_of_two().trailing_zeros() as usize;
    depth + levels_below <= STACK_SIZE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_budget() {
        assert!(fits_in_stack(1, u32::MAX as usize), "any u32 count fits at the root");
        assert!(fits_in_stack(STACK_SIZE, MAX_LEAF_SIZE));
        assert!(!fits_in_stack(STACK_SIZE, MAX_LEAF_SIZE + 1));
        assert!(fits_in_stack(STACK_SIZE - 1, 2 * MAX_LEAF_SIZE));
        assert!(!fits_in_stack(STACK_SIZE - 1, 2 * MAX_LEAF_SIZE + 1));
    }

    #[test]
    fn bins_cover_the_extent() {
        assert_eq!(bin_index(2.0, 2.0, 3.0), 0);
        assert_eq!(bin_index(5.0, 2.0, 3.0), BIN_COUNT - 1, "the maximum goes into the last bin");
        assert_eq!(bin_index(3.5, 2.0, 3.0), BIN_COUNT / 2);
        assert_eq!(bin_index(1.0, 2.0, 3.0), 0, "below the minimum saturates");
    }

    /// Boxes scattered by a fixed linear congruential generator, some of them flat or points.
    fn scattered_boxes(count: usize) -> Vec<Aabb> {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..count)
            .map(|k| {
                let corner = Vec3::new(next(), next(), next()) * 100.0 - 50.0;
                let size = if k % 7 == 0 { Vec3::ZERO } else { Vec3::new(next(), next(), 0.0) * 3.0 };
                Aabb { min: corner, max: corner + size }
            })
            .collect()
    }

    #[test]
    fn a_refit_with_the_builds_own_boxes_gives_its_nodes_back() {
        // Enough primitives for the parallel top levels (`append_subtrees`) to take part.
        for count in [1, 2, 5, 300, 20_000] {
            let bounds = scattered_boxes(count);
            let built = Bvh::build(&bounds);
            let mut refitted = Bvh { nodes: built.nodes.clone(), order: built.order.clone() };
            refitted.refit(&bounds);
            assert_eq!(refitted.nodes, built.nodes, "{count} primitives");
        }
    }

    #[test]
    fn a_refit_over_moved_boxes_keeps_the_shape_and_holds_every_primitive() {
        let bounds = scattered_boxes(3_000);
        let mut bvh = Bvh::build(&bounds);
        let shape: Vec<_> = bvh.nodes.iter().map(|n| (n.first, n.count)).collect();
        let moved: Vec<Aabb> = bounds
            .iter()
            .map(|b| Aabb { min: b.min - Vec3::new(1e3, -7.5, 0.1), max: b.max - Vec3::new(1e3, -7.5, 0.1) })
            .collect();
        bvh.refit(&moved);
        assert_eq!(bvh.nodes.iter().map(|n| (n.first, n.count)).collect::<Vec<_>>(), shape);
        let all = moved.iter().fold(Aabb::EMPTY, |b, m| b.union(m));
        assert_eq!(bvh.nodes[0].bounds(), all, "the root is the union of every moved box");
        let holds = |outer: &Aabb, inner: &Aabb| outer.min.cmple(inner.min).all() && inner.max.cmple(outer.max).all();
        for node in &bvh.nodes {
            let (first, count) = (node.first as usize, node.count as usize);
            if node.is_leaf() {
                for &p in &bvh.order[first..first + count] {
                    assert!(holds(&node.bounds(), &moved[p as usize]));
                }
            } else {
                assert!(holds(&node.bounds(), &bvh.nodes[first].bounds()));
                assert!(holds(&node.bounds(), &bvh.nodes[first + 1].bounds()));
            }
        }
    }

    #[test]
    fn slab_margin_is_two_gamma_three() {
        let u = f64::from(f32::EPSILON) / 2.0;
        assert!((f64::from(SLAB_MARGIN) - 2.0 * 3.0 * u / (1.0 - 3.0 * u)).abs() < 1e-12);
    }
}
