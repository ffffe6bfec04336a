//! Screen-space bins for primary rays: every primitive is listed, nearest first, in the bins
//! of 8 × 4 pixels that hold a pixel whose rays may meet it, so the invocations of one bin (a
//! row of a workgroup, a packet of 4 rows each) walk one short list that is the same for all
//! of them. On lavapipe, where every branch of a divergent loop is paid for by all lanes
//! (docs/lavapipe.md), a uniform list beats a per-ray hierarchy walk; on a real GPU it is
//! the coherent access pattern they favour too.
//!
//! Which pixels hit what does not change: each invocation still intersects its own ray with
//! every candidate exactly, and a candidate is left out of a tile only when its bounds
//! provably miss every ray of the tile. Lists are sorted by a lower bound of the distance at
//! which a ray can meet the primitive, so a ray stops once its closest hit is nearer than the
//! next candidate could be.
//!
//! Triangles are tested against the rays' shared origin (perspective) or direction
//! (orthographic) with edge planes computed once per frame ([`EyeTriangle`]).

use super::layout::{BinItem, EyeTriangle, GpuTriangle, PrimitiveKind};
use super::ordered::ordered_key;
use crate::bvh::Aabb;
use crate::camera::PrimaryRays;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Pixel columns of a bin: the kernel's workgroup is as wide, so that the lanes of a subgroup
/// on lavapipe (8 neighbouring invocations of a workgroup row) walk one list.
pub const BIN_COLUMNS: u32 = super::workgroup::WORKGROUP;
/// Pixel rows of a bin: a packet's, so that its list holds only what the packet's rays may
/// meet. With bins of 8 rows a packet walked the other half's items too, skipping them one
/// by one, and the kernel was slower (docs/performance.md).
pub const BIN_ROWS: u32 = super::workgroup::BIN_PACKET;

/// The kernel's rounding error, in pixels, per unit of the scene's resolution R
/// ([`PrimaryRays::resolution`]), padded for the bins. A primary ray's direction (or
/// orthographic origin), a triangle's edge planes and the dot products between them each
/// round to f32 a few times, about ten units of 2⁻²⁴ in all, so the kernel may take a ray
/// for inside an edge up to about 10·2⁻²⁴ of the distance beyond it: 10·2⁻²⁴·R pixels on
/// the screen (the precision module's account of f32's error). 2⁻¹⁶ is 25 times that.
/// (bunny_40k at 512², R ≈ 955: 0.015 pixel; at the triangle bound R = 2¹⁷: 2.)
const PAD_PER_RESOLUTION: f64 = 1.0 / 65_536.0;

/// The bins of one frame, built band by band: the frame keeps, per primitive, its place
/// (which bins it is listed in, and where in their lists), and [`Bins::band`] fills the
/// lists of a band of bin rows when a tile needs them, so that memory for the lists is
/// bounded by the tile, not the frame (docs/SPEC.md §6: bunny_40k at 16384² with `-output`
/// peaked at 328 MB resident with the whole frame's lists, at 114 MB with a band's).
#[derive(Clone, Debug, Default)]
pub struct Bins {
    /// Bin columns (tiles per image row).
    pub columns: u32,
    /// Bin rows of the frame.
    pub rows: u32,
    /// Every primitive some ray may meet, nearest first once [`Bins::finish`] has sorted
    /// them: the order of every bin's list.
    placed: Vec<Placed>,
    /// Items listed in each bin row: what a band's buffers must hold.
    row_items: Vec<u64>,
    /// Per triangle, its edge planes and plane (same index as the triangle), from
    /// [`Bins::finish`].
    pub eye_triangles: Vec<EyeTriangle>,
    /// The camera's kind and unit viewing direction, for the edge planes.
    orthographic: bool,
    direction: DVec3,
    /// Whether [`Bins::finish`] has run: lists are filled only then.
    finished: bool,
    pub build_ms: f64,
}

/// A primitive's entry in the bins holding the inclusive rectangle `[col0, row0, col1,
/// row1]` of pixels whose rays may meet it.
#[derive(Clone, Copy, Debug)]
struct Placed {
    item: BinItem,
    pixels: [u32; 4],
}

impl Placed {
    /// The inclusive rectangle of bins that list it.
    fn bins(&self) -> [u32; 4] {
        let [c0, r0, c1, r1] = self.pixels;
        [c0 / BIN_COLUMNS, r0 / BIN_ROWS, c1 / BIN_COLUMNS, r1 / BIN_ROWS]
    }
}

/// The lists of a band of bin rows, as the kernel reads them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Band {
    /// Per bin, `[first, count]` into `items`; bins are numbered row by row from the band's
    /// first row.
    pub ranges: Vec<[u32; 2]>,
    pub items: Vec<BinItem>,
}

/// A finite primitive to bin: its reference ([`PrimitiveKind::reference`]) and its bounds.
pub struct Candidate {
    pub reference: u32,
    pub bounds: Aabb,
    /// Exact corners to project instead of the box's (a triangle's vertices).
    pub points: Option<[Vec3; 3]>,
}

impl Bins {
    /// Bins `candidates` for the image `rays` describes, whose pixels cast their rays up to
    /// `reach` pixels from their centres (0 for one ray through each centre, ½ for samples
    /// anywhere in the pixel), or `None` when `worth_it` turns down the lists' lengths,
    /// which are known before any list is filled (so a scene that goes to the hierarchy
    /// pays only for the projection and the count). The lists' order and the edge planes
    /// come later, from [`Bins::finish`], so that the kernel can be compiled meanwhile: the
    /// choice of kernel needs only the lengths.
    pub fn build(
        rays: &PrimaryRays,
        candidates: &[Candidate],
        reach: f64,
        worth_it: impl FnOnce(&ListLengths) -> bool,
    ) -> Option<Bins> {
        let start = crate::clock::Instant::now();
        let farthest =
            candidates.iter().map(|c| c.bounds.min.abs().max(c.bounds.max.abs()).max_element()).fold(0.0, f32::max);
        let rounding = rays.resolution(f64::from(farthest)) * PAD_PER_RESOLUTION;
        let projector = Projector::new(rays, reach + rounding);
        let columns = rays.width.div_ceil(BIN_COLUMNS);
        let rows = rays.height.div_ceil(BIN_ROWS);
        // Projected on every core, kept in the candidates' order.
        let placed: Vec<Placed> = candidates
            .par_iter()
            .filter_map(|c| {
                let rect = match &c.points {
                    Some(points) => projector.pixel_rect(points),
                    None => projector.pixel_rect(&box_corners(&c.bounds)),
                }?;
                let item = BinItem { reference: c.reference, near: projector.near_bound(&c.bounds), pixels: 0 };
                Some(Placed { item, pixels: rect })
            })
            .collect();
        let (lengths, row_items) = list_lengths(&placed, columns, rows);
        if !worth_it(&lengths) {
            return None;
        }
        Some(Bins {
            columns,
            rows,
            placed,
            row_items,
            eye_triangles: Vec::new(),
            orthographic: rays.orthographic,
            direction: projector.direction,
            finished: false,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Orders the lists, nearest first, and builds the edge planes of `triangles` (the
    /// triangles [`Bins::build`] was given); counted in `build_ms`.
    pub fn finish(&mut self, triangles: &[GpuTriangle]) {
        let start = crate::clock::Instant::now();
        // Stable, so that equally near primitives keep their order in every band's lists.
        self.placed = sorted_by_near(std::mem::take(&mut self.placed));
        let (orthographic, direction) = (self.orthographic, self.direction);
        self.eye_triangles = triangles.par_iter().map(|t| EyeTriangle::new(t, orthographic, direction)).collect();
        self.finished = true;
        self.build_ms += start.elapsed().as_secs_f64() * 1e3;
    }

    /// The bin rows `first .. first + count` that hold image rows `first_row .. first_row +
    /// rows` (rows from the top).
    pub fn rows_holding(first_row: u32, rows: u32) -> (u32, u32) {
        let first = first_row / BIN_ROWS;
        (first, (first_row + rows.max(1) - 1) / BIN_ROWS + 1 - first)
    }

    /// The most items any `count` consecutive bin rows list: what a buffer for a band of
    /// that many rows must hold.
    pub fn most_items(&self, count: u32) -> u64 {
        let count = (count as usize).clamp(1, self.row_items.len().max(1));
        self.row_items.windows(count).map(|w| w.iter().sum()).max().unwrap_or(0)
    }

    /// The lists of bin rows `first .. first + count`, each nearest first, exactly as the
    /// frame's own lists would hold them.
    pub fn band(&self, first: u32, count: u32) -> Band {
        assert!(self.finished, "Bins::finish orders the lists before a band is filled");
        let count = count.min(self.rows - first);
        let last = first + count - 1;
        // Every primitive is looked at for every band: O(primitives) a tile (bunny_40k: a
        // fraction of a millisecond), and no memory beyond the frame's placements and the
        // band's own.
        let in_band: Vec<(&Placed, [u32; 4])> = self
            .placed
            .iter()
            .filter_map(|p| {
                let [c0, r0, c1, r1] = p.bins();
                (r0 <= last && r1 >= first).then_some((p, [c0, r0.max(first) - first, c1, r1.min(last) - first]))
            })
            .collect();
        let mut counts = vec![0u32; (count * self.columns) as usize];
        for &(_, [c0, r0, c1, r1]) in &in_band {
            for row in r0..=r1 {
                for col in c0..=c1 {
                    counts[(row * self.columns + col) as usize] += 1;
                }
            }
        }
        let mut ranges = Vec::with_capacity(counts.len());
        let mut total = 0u32;
        for &n in &counts {
            ranges.push([total, n]);
            total += n;
        }
        // Counting sort: each bin keeps the placement order, nearest first.
        let mut items = vec![BinItem::default(); total as usize];
        let mut fill = counts;
        for (slot, range) in fill.iter_mut().zip(&ranges) {
            *slot = range[0];
        }
        for &(placed, [c0, r0, c1, r1]) in &in_band {
            for row in r0..=r1 {
                for col in c0..=c1 {
                    let slot = &mut fill[(row * self.columns + col) as usize];
                    let pixels = pixels_in_bin(placed.pixels, col, first + row);
                    items[*slot as usize] = BinItem { pixels, ..placed.item };
                    *slot += 1;
                }
            }
        }
        Band { ranges, items }
    }
}

/// The part of the pixel rectangle `[col0, row0, col1, row1]` inside bin (`column`, `row`),
/// relative to the bin's corner, a byte each from the lowest: the kernel skips an item for a
/// packet whose pixels are all outside it (`packet_misses` in shaders/bins.wgsl). The
/// rectangle is the one the bins were chosen by, so no ray that may meet the primitive is
/// skipped.
fn pixels_in_bin([c0, r0, c1, r1]: [u32; 4], column: u32, row: u32) -> u32 {
    let (x, y) = (column * BIN_COLUMNS, row * BIN_ROWS);
    let inside = |v: u32, corner: u32, side: u32| v.clamp(corner, corner + side - 1) - corner;
    inside(c0, x, BIN_COLUMNS)
        | inside(r0, y, BIN_ROWS) << 8
        | inside(c1, x, BIN_COLUMNS) << 16
        | inside(r1, y, BIN_ROWS) << 24
}

/// The lengths of the frame's lists, and the items of each bin row, counted row by row
/// (a row of counts at a time, never the frame's).
fn list_lengths(placed: &[Placed], columns: u32, rows: u32) -> (ListLengths, Vec<u64>) {
    let by_first_row = sorted_by_key(placed.iter().collect(), |p| p.bins()[1]);
    let mut next = by_first_row.iter().peekable();
    let mut active: Vec<&Placed> = Vec::new();
    // Differences between neighbouring columns' counts.
    let mut steps = vec![0i64; columns as usize + 1];
    let (mut total, mut max) = (0u64, 0u32);
    let mut row_items = Vec::with_capacity(rows as usize);
    for row in 0..rows {
        active.retain(|p| p.bins()[3] >= row);
        while let Some(p) = next.next_if(|p| p.bins()[1] == row) {
            active.push(p);
        }
        steps.fill(0);
        let mut items = 0u64;
        for p in &active {
            let [c0, _, c1, _] = p.bins();
            steps[c0 as usize] += 1;
            steps[c1 as usize + 1] -= 1;
            items += u64::from(c1 - c0 + 1);
        }
        let mut count = 0i64;
        for step in &steps[..columns as usize] {
            count += step;
            max = max.max(count as u32);
        }
        total += items;
        row_items.push(items);
    }
    let bins = (columns as u64 * rows as u64).max(1);
    (ListLengths { mean: total as f64 / bins as f64, max }, row_items)
}

/// `placed` sorted by the lower bound of their distance, as `f32::total_cmp` orders it,
/// equal bounds in their order: [`sorted_by_key`] on the bits that order floats as
/// unsigned integers ([`ordered_key`]).
fn sorted_by_near(placed: Vec<Placed>) -> Vec<Placed> {
    sorted_by_key(placed, |p| ordered_key(p.item.near))
}

/// `items` sorted by `key`, stably: a least-significant-digit radix sort, one pass per byte
/// of the key that is not the same for every item (bunny_40k's 40 000 triangles at 1024²:
/// see `Bins::build`'s time in the README's table of measurements).
fn sorted_by_key<T: Copy>(mut items: Vec<T>, key: impl Fn(&T) -> u32) -> Vec<T> {
    let keys: Vec<u32> = items.iter().map(&key).collect();
    let (mut from, mut to) = ((0..items.len() as u32).collect::<Vec<u32>>(), vec![0u32; items.len()]);
    for shift in [0, 8, 16, 24] {
        let digit = |k: u32| (keys[k as usize] >> shift & 0xff) as usize;
        let mut starts = [0usize; 257];
        for &k in &from {
            starts[digit(k) + 1] += 1;
        }
        if starts.contains(&items.len()) {
            continue; // every key has this byte: the pass would change nothing
        }
        for d in 0..256 {
            starts[d + 1] += starts[d];
        }
        for &k in &from {
            let d = digit(k);
            to[starts[d]] = k;
            starts[d] += 1;
        }
        std::mem::swap(&mut from, &mut to);
    }
    let original = items.clone();
    for (item, &k) in items.iter_mut().zip(&from) {
        *item = original[k as usize];
    }
    items
}

/// How long the bins' lists are: the cost model's inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ListLengths {
    /// Items per bin on average: candidates an invocation tests at worst, on average.
    pub mean: f64,
    /// The longest list: every invocation of that bin walks it in one loop.
    pub max: u32,
}

/// The finite primitives of a flattened scene, for [`Bins::build`].
pub fn candidates(triangles: &[GpuTriangle], sphere_bounds: &[Aabb], ellipsoid_bounds: &[Aabb]) -> Vec<Candidate> {
    let mut out = Vec::with_capacity(triangles.len() + sphere_bounds.len() + ellipsoid_bounds.len());
    out.par_extend(triangles.par_iter().enumerate().map(|(k, t)| {
        let points = [Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2)];
        Candidate {
            reference: PrimitiveKind::Triangle.reference(k),
            bounds: Aabb::of_points(&points),
            points: Some(points),
        }
    }));
    for (k, b) in sphere_bounds.iter().enumerate() {
        out.push(Candidate { reference: PrimitiveKind::Sphere.reference(k), bounds: *b, points: None });
    }
    for (k, b) in ellipsoid_bounds.iter().enumerate() {
        out.push(Candidate { reference: PrimitiveKind::Ellipsoid.reference(k), bounds: *b, points: None });
    }
    out
}

fn box_corners(b: &Aabb) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

/// From camera-relative points to pixel coordinates, in f64.
struct Projector {
    orthographic: bool,
    /// Unit viewing direction.
    direction: DVec3,
    /// The camera's scaled axes (docs/SPEC.md §3): the ray through screen point (x, y) is
    /// `direction·D + x·horizontal + y·up` (perspective) or starts at `x·horizontal + y·up`.
    forward: DVec3,
    horizontal: DVec3,
    up: DVec3,
    width: u32,
    height: u32,
    /// How far from its centre a pixel's ray may pass, in pixels: its samples' reach and the
    /// kernel's rounding.
    pad: f64,
}

impl Projector {
    fn new(rays: &PrimaryRays, pad: f64) -> Projector {
        Projector {
            pad,
            orthographic: rays.orthographic,
            direction: rays.direction.normalize(),
            forward: rays.direction,
            horizontal: rays.horizontal,
            up: rays.up,
            width: rays.width,
            height: rays.height,
        }
    }

    /// The screen point (x, y) a camera-relative point is seen at, or `None` at or behind the
    /// eye plane (perspective).
    fn screen(&self, p: DVec3) -> Option<(f64, f64)> {
        let h = p.dot(self.horizontal) / self.horizontal.length_squared();
        let u = p.dot(self.up) / self.up.length_squared();
        if self.orthographic {
            return Some((h, u));
        }
        // p = s·(forward + x·horizontal + y·up) with the three axes orthogonal.
        let s = p.dot(self.forward) / self.forward.length_squared();
        if s <= 0.0 {
            return None;
        }
        Some((h / s, u / s))
    }

    /// The inclusive pixel rectangle `[col0, row0, col1, row1]` (rows from the top) that
    /// holds every pixel whose ray may meet the convex hull of `points`, or `None` when no
    /// pixel's can: those whose centres lie within the pad of the hull's screen bounds.
    /// Perspective projection maps the hull of points in front of the eye onto the hull of
    /// their images, so their extremes bound it; a hull reaching the eye plane may be seen
    /// anywhere.
    fn pixel_rect(&self, points: &[Vec3]) -> Option<[u32; 4]> {
        let full = [0, 0, self.width - 1, self.height - 1];
        let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for p in points {
            let p = p.as_dvec3();
            if !p.is_finite() {
                return Some(full);
            }
            match self.screen(p) {
                Some((x, y)) => {
                    x0 = x0.min(x);
                    x1 = x1.max(x);
                    y0 = y0.min(y);
                    y1 = y1.max(y);
                }
                // In front of the eye only partly (or not at all: then no ray meets it,
                // but listing it everywhere is still correct).
                None => return Some(full),
            }
        }
        // Pixel i's centre sits at x = (i + ½ − W/2)/longer (docs/SPEC.md §3).
        let longer = self.width.max(self.height) as f64;
        let to_column = |x: f64| x * longer + self.width as f64 / 2.0 - 0.5;
        let to_j = |y: f64| y * longer + self.height as f64 / 2.0 - 0.5;
        let (i0, i1) = ((to_column(x0) - self.pad).ceil(), (to_column(x1) + self.pad).floor());
        let (j0, j1) = ((to_j(y0) - self.pad).ceil(), (to_j(y1) + self.pad).floor());
        // A primitive between pixel centres (or off the image) is seen by no pixel.
        if i0 > i1 || j0 > j1 || i1 < 0.0 || j1 < 0.0 || i0 > (self.width - 1) as f64 || j0 > (self.height - 1) as f64 {
            return None;
        }
        let clamp = |v: f64, hi: u32| v.clamp(0.0, hi as f64) as u32;
        let (c0, c1) = (clamp(i0, self.width - 1), clamp(i1, self.width - 1));
        // j counts from the bottom, image rows from the top.
        let (r0, r1) = (self.height - 1 - clamp(j1, self.height - 1), self.height - 1 - clamp(j0, self.height - 1));
        Some([c0, r0, c1, r1])
    }

    /// A lower bound of the `t` at which any primary ray meets something inside `bounds`:
    /// perspective rays are unit and start at the eye, so `t` is the distance to the eye,
    /// at least the box's; orthographic `t` is the depth along the unit direction, at least
    /// the smallest corner's. Rounded down (and widened by 2⁻²⁰ of its size, far more
    /// than the kernel's own rounding of `t`) so the kernel's early stop never skips a
    /// candidate it could have hit first.
    fn near_bound(&self, bounds: &Aabb) -> f32 {
        let (min, max) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
        let near = if self.orthographic {
            box_corners(bounds).iter().map(|c| c.as_dvec3().dot(self.direction)).fold(f64::MAX, f64::min)
        } else {
            DVec3::ZERO.clamp(min, max).length()
        };
        let widened = near - near.abs() * (1.0 / (1 << 20) as f64);
        let rounded = widened as f32;
        if (rounded as f64) > widened {
            rounded.next_down()
        } else {
            rounded
        }
    }
}

impl EyeTriangle {
    /// Edge planes through the rays' common origin (perspective: the eye at the origin) or
    /// containing their common direction (orthographic), and the triangle's plane, in f64
    /// from the f32 vertices, then rounded.
    ///
    /// Watertight for the same reason as Woop, Benthin and Wald's test (JCGT 2013): an edge
    /// shared by two triangles gets the same plane with the opposite sign in both, bit for
    /// bit (a cross product and a dot product of reversed arguments negate exactly, and the
    /// offset is taken from the edge's lexicographically smaller end whichever way it is
    /// walked), so the kernel's edge functions for a ray are exact negations of each other
    /// and no ray slips between the two.
    pub fn new(t: &GpuTriangle, orthographic: bool, direction: DVec3) -> EyeTriangle {
        let [a, b, c] = [t.v0, t.v1, t.v2].map(|v| Vec3::from(v).as_dvec3());
        let edge = |p: DVec3, q: DVec3| -> [f32; 4] {
            if orthographic {
                let n = (q - p).cross(direction);
                let anchor = if (p.x, p.y, p.z) < (q.x, q.y, q.z) { p } else { q };
                [n.x as f32, n.y as f32, n.z as f32, n.dot(anchor) as f32]
            } else {
                let n = p.cross(q);
                [n.x as f32, n.y as f32, n.z as f32, 0.0]
            }
        };
        let normal = (b - a).cross(c - a);
        let plane = [normal.x as f32, normal.y as f32, normal.z as f32, normal.dot(a) as f32];
        EyeTriangle { edges: [edge(b, c), edge(c, a), edge(a, b)], plane }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn placed(reference: u32, near: f32) -> Placed {
        Placed { item: BinItem { reference, near, pixels: 0 }, pixels: [0; 4] }
    }

    /// The radix sort against the standard library's stable sort by `f32::total_cmp`: signs,
    /// both zeros, infinities, equal keys (whose order must be kept, told apart by
    /// `reference`), and keys that differ only in their low or high bytes.
    #[test]
    fn sorted_by_near_is_the_stable_total_order() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let special = [0.0, -0.0, 1.0, -1.0, f32::INFINITY, f32::NEG_INFINITY, 1e-40, -1e-40, 3.5, 3.5];
        let mut items: Vec<Placed> = special.iter().enumerate().map(|(k, &near)| placed(k as u32, near)).collect();
        for k in 0..5000u32 {
            let r = next();
            let near = match r % 4 {
                0 => (r >> 8) as u32 as f32 / 1e6,                          // positive, many distinct
                1 => -((r >> 8) as u16 as f32),                             // negative, many equal
                2 => f32::from_bits(0x4000_0000 | (r >> 40) as u32 & 0xff), // low byte only
                _ => special[(r >> 8) as usize % special.len()],            // repeats
            };
            items.push(placed(1000 + k, near));
        }
        let mut expected = items.clone();
        expected.sort_by(|a, b| a.item.near.total_cmp(&b.item.near));
        let got = sorted_by_near(items);
        let order = |v: &[Placed]| v.iter().map(|p| p.item.reference).collect::<Vec<_>>();
        assert_eq!(order(&got), order(&expected));
        assert!(sorted_by_near(Vec::new()).is_empty());
    }
}
