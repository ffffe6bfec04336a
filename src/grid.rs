//! The uniform grid of the course's assignments 5 and 6 (`-grid nx ny nz`, docs/SPEC.md §7),
//! in f64: cells over the scene's bounds, the items that may touch each cell, and the
//! 3D-DDA that walks a ray through the cells in order (Amanatides and Woo, "A Fast Voxel
//! Traversal Algorithm for Ray Tracing", Eurographics 1987).
//!
//! The grid knows nothing of primitives: its user hands it one [`Footprint`] per item and
//! gets back, per cell, the indices of the items whose footprint touches the cell, in
//! increasing order. The CPU reference ([`crate::cpu`]) builds one over the scene's bounded
//! primitives (planes stay outside, always tested), and the GPU's host one over its f32
//! primitives (`gpu::flatten::GpuGrid`), which the kernel walks with its own f32 march
//! (shaders/grid.wgsl); this march is the reference's only.
//!
//! **Conservative by a margin.** A ray that hits an item at `t` must meet, at `t`, a cell
//! that lists the item, or a grid-accelerated search would miss the hit. The hit point is
//! computed, and so rounded; each footprint is therefore widened by [`MARGIN`] times the
//! grid's largest extent before its cells are found, far above the rounding of any hit point
//! and far below a cell.

use crate::scene::Bounds;
use glam::DVec3;

/// The number of cells along x, y and z (`-grid nx ny nz`), each ≥ 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GridSize {
    pub nx: u32,
    pub ny: u32,
    pub nz: u32,
}

impl GridSize {
    /// The most cells a grid may have (2²⁴): its index takes 4 bytes a cell, 64 MiB here.
    pub const MAX_CELLS: u64 = 1 << 24;

    pub fn cells(&self) -> u64 {
        u64::from(self.nx) * u64::from(self.ny) * u64::from(self.nz)
    }

    fn as_array(&self) -> [usize; 3] {
        [self.nx as usize, self.ny as usize, self.nz as usize]
    }
}

/// Footprints are widened by this share of the grid's largest extent (see the module's
/// documentation): hit points are rounded at about 2⁻⁵² of the scene's size times the few
/// hundred operations of the deepest intersection path, about 10⁻¹³.
pub const MARGIN: f64 = 1e-9;

/// Where an item may lie, as the course's assignment 5 marks cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Footprint {
    /// Every cell the box overlaps (the course's rule for everything but spheres: a
    /// transformed primitive by its transformed bounds).
    Box(Bounds),
    /// The handout's sphere rule: every cell whose centre lies within `radius` plus half the
    /// cell's diagonal of `center`. Conservative: a point of the sphere inside a cell lies
    /// within half the diagonal of the cell's centre.
    Sphere { center: DVec3, radius: f64 },
}

impl Footprint {
    /// The box the footprint covers.
    pub fn bounds(&self) -> Bounds {
        match *self {
            Footprint::Box(b) => b,
            Footprint::Sphere { center, radius } => Bounds::sphere(center, radius),
        }
    }
}

/// A uniform grid over a box, with the items of each cell.
#[derive(Clone, Debug)]
pub struct Grid {
    /// The box the cells divide; [`Bounds::EMPTY`] when there was nothing to hold.
    pub bounds: Bounds,
    size: [usize; 3],
    /// The extent of one cell along each axis.
    cell: DVec3,
    /// Cell `c`'s items are `items[starts[c] .. starts[c + 1]]` (one list for all cells, so
    /// that an empty cell costs 4 bytes).
    starts: Vec<u32>,
    items: Vec<u32>,
}

/// One cell a ray passes through, with the part of the ray inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellVisit {
    /// The cell's indices along x, y, z.
    pub cell: [usize; 3],
    /// Where the ray enters the cell (or starts, if it starts inside it).
    pub t_enter: f64,
    /// Where it leaves the cell (or ends, if it ends inside it).
    pub t_exit: f64,
    /// The outward unit normal of the face the ray came in through: the face of the grid's
    /// box for the first cell, `None` if the ray starts inside the box.
    pub entered_through: Option<DVec3>,
}

impl Grid {
    /// A grid of `size` cells over `bounds`, cell `c` listing the index of every footprint
    /// that touches it. An axis along which `bounds` is flat (a scene of one triangle) is
    /// widened to [`MARGIN`] of the largest extent on either side, so that every cell has a
    /// volume and the march a finite step.
    pub fn new(bounds: Bounds, size: GridSize, footprints: &[Footprint]) -> Grid {
        let size = size.as_array();
        let cells = size.iter().product::<usize>();
        if bounds.is_empty() {
            let starts = vec![0; cells + 1];
            return Grid { bounds: Bounds::EMPTY, size, cell: DVec3::ZERO, starts, items: Vec::new() };
        }
        let bounds = widened_where_flat(bounds);
        let cell = (bounds.max - bounds.min) / DVec3::new(size[0] as f64, size[1] as f64, size[2] as f64);
        let mut grid = Grid { bounds, size, cell, starts: Vec::new(), items: Vec::new() };
        let per_cell = grid.items_per_cell(footprints);
        grid.starts.reserve(cells + 1);
        grid.starts.push(0);
        for list in per_cell {
            grid.items.extend(list);
            grid.starts.push(u32::try_from(grid.items.len()).expect("at most 2³² item–cell pairs"));
        }
        grid
    }

    /// For each cell, the footprints that touch it, in increasing order.
    fn items_per_cell(&self, footprints: &[Footprint]) -> Vec<Vec<u32>> {
        let mut per_cell = vec![Vec::new(); self.cell_count()];
        let margin = self.margin();
        for (index, footprint) in footprints.iter().enumerate() {
            let index = u32::try_from(index).expect("at most 2³² items");
            let (lo, hi) = match footprint {
                Footprint::Box(b) => (b.min - margin, b.max + margin),
                Footprint::Sphere { center, radius } => (*center - (*radius + margin), *center + (*radius + margin)),
            };
            let Some((first, last)) = self.cell_range(lo, hi) else { continue };
            for k in first[2]..=last[2] {
                for j in first[1]..=last[1] {
                    for i in first[0]..=last[0] {
                        if self.touches(footprint, [i, j, k]) {
                            per_cell[self.flat([i, j, k])].push(index);
                        }
                    }
                }
            }
        }
        per_cell
    }

    /// Whether `footprint` marks cell `c`: always for a box (whose cell range was already
    /// taken), by the handout's centre-distance rule for a sphere.
    fn touches(&self, footprint: &Footprint, c: [usize; 3]) -> bool {
        match footprint {
            Footprint::Box(_) => true,
            Footprint::Sphere { center, radius } => {
                let reach = radius + self.cell.length() / 2.0 + self.margin();
                self.cell_center(c).distance_squared(*center) <= reach * reach
            }
        }
    }

    /// The first and last cell (inclusive) of the cells a box `lo ..= hi` overlaps; `None`
    /// if it lies outside the grid.
    fn cell_range(&self, lo: DVec3, hi: DVec3) -> Option<([usize; 3], [usize; 3])> {
        if lo.cmpgt(self.bounds.max).any() || hi.cmplt(self.bounds.min).any() {
            return None;
        }
        Some((self.clamped_cell(lo), self.clamped_cell(hi)))
    }

    /// The cell holding `p`, clamped into the grid.
    fn clamped_cell(&self, p: DVec3) -> [usize; 3] {
        let r = (p - self.bounds.min) / self.cell;
        [0, 1, 2].map(|a| (r[a].floor().max(0.0) as usize).min(self.size[a] - 1))
    }

    /// The grid's absolute margin ([`MARGIN`] of its largest extent).
    fn margin(&self) -> f64 {
        MARGIN * (self.bounds.max - self.bounds.min).max_element()
    }

    pub fn size(&self) -> [usize; 3] {
        self.size
    }

    pub fn cell_count(&self) -> usize {
        self.size.iter().product()
    }

    fn flat(&self, [i, j, k]: [usize; 3]) -> usize {
        (k * self.size[1] + j) * self.size[0] + i
    }

    /// The indices of the items that touch cell `c`, in increasing order.
    pub fn items(&self, c: [usize; 3]) -> &[u32] {
        let f = self.flat(c);
        &self.items[self.starts[f] as usize..self.starts[f + 1] as usize]
    }

    /// The centre of cell `c`.
    pub fn cell_center(&self, c: [usize; 3]) -> DVec3 {
        self.bounds.min + (DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) + 0.5) * self.cell
    }

    /// The extent of one cell along each axis.
    pub fn cell_extent(&self) -> DVec3 {
        self.cell
    }

    /// The cells the ray `origin + t·direction` passes through for `t_min ≤ t ≤ t_max`, in
    /// order along it (see [`March`]). Either limit may be infinite.
    pub fn march(&self, origin: DVec3, direction: DVec3, t_min: f64, t_max: f64) -> March<'_> {
        March::start(self, origin, direction, t_min, t_max)
    }
}

/// `bounds` with each flat axis widened by [`MARGIN`] of the largest extent (or by
/// [`MARGIN`] itself when the box is a point) on both sides.
fn widened_where_flat(bounds: Bounds) -> Bounds {
    let extent = (bounds.max - bounds.min).max_element();
    let pad = MARGIN * if extent > 0.0 { extent } else { 1.0 };
    let flat = (bounds.max - bounds.min).cmple(DVec3::ZERO);
    let pad = DVec3::select(flat, DVec3::splat(pad), DVec3::ZERO);
    Bounds { min: bounds.min - pad, max: bounds.max + pad }
}

/// The 3D-DDA of Amanatides and Woo (1987) as an iterator of [`CellVisit`]s: the ray is
/// clipped to the grid's box, the first cell is the one holding the clipped start, and each
/// step moves one cell along the axis whose next cell boundary is nearest (`t_next`).
///
/// Unlike the paper's incremental `tMax += tDelta`, `t_next` is recomputed from the
/// boundary's index at each step, so that the error does not grow with the number of steps
/// (a 40-cell march would otherwise drift by 40 roundings).
pub struct March<'a> {
    grid: &'a Grid,
    origin: DVec3,
    direction: DVec3,
    /// Where the current cell starts; `> t_end` once the march is over.
    t: f64,
    t_end: f64,
    cell: [i64; 3],
    step: [i64; 3],
    entered_through: Option<DVec3>,
    done: bool,
}

impl<'a> March<'a> {
    fn start(grid: &'a Grid, origin: DVec3, direction: DVec3, t_min: f64, t_max: f64) -> March<'a> {
        let step = [0, 1, 2].map(|a| (direction[a] > 0.0) as i64 - (direction[a] < 0.0) as i64);
        let mut march = March {
            grid,
            origin,
            direction,
            t: t_min,
            t_end: t_max,
            cell: [0; 3],
            step,
            entered_through: None,
            done: true,
        };
        if grid.bounds.is_empty() || direction == DVec3::ZERO {
            return march;
        }
        let Some((t_in, t_out, axis_in)) = march.box_interval() else { return march };
        let (t0, t1) = (t_in.max(t_min), t_out.min(t_max));
        if t0 > t1 {
            return march;
        }
        if t_in >= t_min {
            march.entered_through = axis_in.map(|a| march.face_normal(a));
        }
        let start = origin + t0 * direction;
        march.cell = grid.clamped_cell(start).map(|i| i as i64);
        (march.t, march.t_end, march.done) = (t0, t1, false);
        march
    }

    /// The slab test against the grid's box (Kay and Kajiya 1986), widened by the grid's
    /// margin so that a ray grazing the box still meets the cells at its edge: the
    /// interval of the line inside it, and the axis of the slab it enters last (the face
    /// it comes in through; `None` when no slab bounds the entry, which cannot happen for
    /// a non-zero direction).
    fn box_interval(&self) -> Option<(f64, f64, Option<usize>)> {
        let margin = self.grid.margin();
        let (lo, hi) = (self.grid.bounds.min - margin, self.grid.bounds.max + margin);
        let (mut near, mut far, mut axis_in) = (f64::NEG_INFINITY, f64::INFINITY, None);
        for a in 0..3 {
            let (o, d) = (self.origin[a], self.direction[a]);
            if d == 0.0 {
                if o < lo[a] || o > hi[a] {
                    return None;
                }
                continue;
            }
            let (t0, t1) = ((lo[a] - o) / d, (hi[a] - o) / d);
            let (t0, t1) = (t0.min(t1), t0.max(t1));
            if t0 > near {
                (near, axis_in) = (t0, Some(a));
            }
            far = far.min(t1);
        }
        (near <= far).then_some((near, far, axis_in))
    }

    /// The outward normal of the face a ray moving along `axis` enters a cell through.
    fn face_normal(&self, axis: usize) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[axis] = -(self.step[axis] as f64);
        n
    }

    /// Where the ray crosses the next cell boundary along `axis` (+∞ if it never moves
    /// along it).
    fn t_next(&self, axis: usize) -> f64 {
        if self.step[axis] == 0 {
            return f64::INFINITY;
        }
        let boundary = self.cell[axis] + (self.step[axis] > 0) as i64;
        let plane = self.grid.bounds.min[axis] + boundary as f64 * self.grid.cell[axis];
        (plane - self.origin[axis]) / self.direction[axis]
    }
}

impl Iterator for March<'_> {
    type Item = CellVisit;

    fn next(&mut self) -> Option<CellVisit> {
        if self.done {
            return None;
        }
        let t_next = [0, 1, 2].map(|a| self.t_next(a));
        let axis = (0..3).min_by(|&a, &b| t_next[a].total_cmp(&t_next[b])).expect("three axes");
        // Rounding may put the boundary a hair before the cell's start: never go back.
        let t_exit = t_next[axis].max(self.t).min(self.t_end);
        let visit = CellVisit {
            cell: self.cell.map(|i| i as usize),
            t_enter: self.t,
            t_exit,
            entered_through: self.entered_through,
        };
        self.cell[axis] += self.step[axis];
        let outside = self.cell[axis] < 0 || self.cell[axis] >= self.grid.size[axis] as i64;
        self.done = outside || t_next[axis] >= self.t_end;
        (self.t, self.entered_through) = (t_exit, Some(self.face_normal(axis)));
        Some(visit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_grid(n: u32) -> Grid {
        let bounds = Bounds { min: DVec3::ZERO, max: DVec3::ONE };
        Grid::new(bounds, GridSize { nx: n, ny: n, nz: n }, &[])
    }

    /// An axis-aligned ray through a 4³ grid visits the four cells of its row, each over
    /// a quarter of the box, entering the first through the box's −x face.
    #[test]
    fn axis_ray_visits_its_row() {
        let grid = unit_grid(4);
        let visits: Vec<_> = grid.march(DVec3::new(-1.0, 0.3, 0.6), DVec3::X, 0.0, f64::INFINITY).collect();
        assert_eq!(visits.iter().map(|v| v.cell).collect::<Vec<_>>(), [[0, 1, 2], [1, 1, 2], [2, 1, 2], [3, 1, 2]]);
        assert_eq!(visits[0].entered_through, Some(-DVec3::X));
        assert!((visits[0].t_enter - 1.0).abs() < 1e-8 && (visits[3].t_exit - 2.0).abs() < 1e-8);
        assert_eq!(visits[1].t_enter, 1.25);
    }

    /// A ray starting inside the box starts in its own cell, through no face; one that
    /// ends inside stops there.
    #[test]
    fn starts_and_ends_inside() {
        let grid = unit_grid(4);
        let visits: Vec<_> = grid.march(DVec3::new(0.1, 0.1, 0.1), -DVec3::Y, 0.0, 0.05).collect();
        assert_eq!(visits.len(), 1);
        assert_eq!(visits[0].cell, [0, 0, 0]);
        assert_eq!(visits[0].entered_through, None);
        assert_eq!((visits[0].t_enter, visits[0].t_exit), (0.0, 0.05));
    }

    #[test]
    fn a_ray_that_misses_visits_nothing() {
        let grid = unit_grid(3);
        assert_eq!(grid.march(DVec3::new(-1.0, 2.0, 0.5), DVec3::X, 0.0, f64::INFINITY).count(), 0);
        assert_eq!(grid.march(DVec3::new(2.0, 0.5, 0.5), DVec3::X, 0.0, f64::INFINITY).count(), 0);
    }

    /// The handout's sphere rule on a 5³ grid over [0, 5]³ (cells of side 1): a sphere of
    /// radius 0.5 at the centre of cell (2, 2, 2) reaches the centres within 0.5 + √3/2 ≈
    /// 1.37 of it: the cell and its 6 face neighbours (distance 1), not the 12 edge
    /// neighbours (√2 ≈ 1.41).
    #[test]
    fn sphere_rule_marks_centres_within_reach() {
        let bounds = Bounds { min: DVec3::ZERO, max: DVec3::splat(5.0) };
        let sphere = Footprint::Sphere { center: DVec3::splat(2.5), radius: 0.5 };
        let grid = Grid::new(bounds, GridSize { nx: 5, ny: 5, nz: 5 }, &[sphere]);
        let mut marked = 0;
        for k in 0..5 {
            for j in 0..5 {
                for i in 0..5 {
                    let far = [i, j, k].iter().map(|&c| (c as i32 - 2).abs()).sum::<i32>();
                    assert_eq!(grid.items([i, j, k]).len(), usize::from(far <= 1), "{:?}", [i, j, k]);
                    marked += grid.items([i, j, k]).len();
                }
            }
        }
        assert_eq!(marked, 7);
    }

    /// A flat scene (one triangle in z = 0) still gets cells with a volume.
    #[test]
    fn flat_bounds_are_widened() {
        let bounds = Bounds { min: DVec3::ZERO, max: DVec3::new(1.0, 1.0, 0.0) };
        let grid = Grid::new(bounds, GridSize { nx: 2, ny: 2, nz: 3 }, &[Footprint::Box(bounds)]);
        assert!(grid.cell_extent().z > 0.0);
        let visits: Vec<_> = grid.march(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z, 0.0, f64::INFINITY).collect();
        assert_eq!(visits.len(), 3);
        assert!(visits.iter().all(|v| grid.items(v.cell) == [0]));
    }
}
