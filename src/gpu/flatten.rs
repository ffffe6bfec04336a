//! The walk over the scene tree that fills the kernel's buffers ([`super::layout`]).
//!
//! Transforms are baked on the CPU wherever that is exact: triangles and planes go to world
//! space, spheres under a similarity become world spheres; only a sphere under a
//! non-uniform scale keeps a matrix (an [`Ellipsoid`](super::layout::GpuEllipsoid)).
//! Everything is moved so that the camera sits at the origin, in f64, before it is rounded
//! to f32.

use super::binning::{self, Bins};
use super::layout::*;
use super::options::{Acceleration, GpuOptions};
use crate::bvh::{Aabb, Bvh, BvhNode};
use crate::camera::PrimaryRays;
use crate::clock::Instant;
use crate::grid::{Footprint, Grid, GridSize};
use crate::scene::{ellipsoid_extent, for_each_leaf, Bounds, Mesh, Object, Scene, Shape};
use glam::{DMat3, DMat4, DVec3, Vec3};
use rayon::prelude::*;

/// Everything the kernel reads, ready to upload.
#[derive(Clone, Debug, Default)]
pub struct SceneBuffers {
    /// `Params` without the per-image and per-tile fields (width, height, tile).
    pub params: Params,
    pub orthographic: bool,
    pub spheres: Vec<GpuSphere>,
    pub ellipsoids: Vec<GpuEllipsoid>,
    pub planes: Vec<GpuPlane>,
    pub triangles: Vec<GpuTriangle>,
    pub materials: Vec<GpuMaterial>,
    /// One per material when the scene has solid textures; empty otherwise.
    pub textures: Vec<GpuTexture>,
    pub lights: Vec<GpuLight>,
    /// The hierarchy over spheres, ellipsoids and triangles, when the scene has enough of
    /// them to profit ([`super::options::BVH_MIN_PRIMITIVES`]).
    pub bvh: Option<GpuBvh>,
    /// Screen-space bins of the finite primitives, when the frame walks those instead.
    pub bins: Option<Bins>,
    /// The `-grid`'s cells, when the render asks for one (then neither bins nor a hierarchy).
    pub grid: Option<GpuGrid>,
    /// Bounds of each sphere and ellipsoid (f32, slightly padded), for the hierarchy.
    sphere_bounds: Vec<Aabb>,
    ellipsoid_bounds: Vec<Aabb>,
}

/// Below this many pixels `auto` walks samples (`-random_samples` and the like) through the
/// hierarchy: there the bins' packets of samples lost to it, while at 512² they win
/// (docs/performance.md).
/// One ray a pixel takes bins at every size.
pub const SAMPLED_BINS_MIN_PIXELS: u64 = 1 << 18;

/// Bins are used while a bin lists at most this many primitives on average (see
/// [`binning::ListLengths`]); longer lists, as sub-pixel triangles make, go to the
/// hierarchy.
pub const BINS_MAX_MEAN_LIST: f64 = 64.0;

/// The most primitives a hierarchy is built for: a reference keeps its index in the bits
/// below [`REF_KIND_SHIFT`].
const BVH_MAX_PRIMITIVES: usize = 1 << REF_KIND_SHIFT;

/// lavapipe ends an invocation's loops after this many iterations in all (a guard of its
/// compiler against endless loops; docs/lavapipe.md), so no loop of ours may come near it:
/// bins whose longest list does go to the hierarchy, and flat loops over more primitives
/// are refused.
pub const LOOP_LIMIT: u32 = 65535;

/// The hierarchy as the kernel reads it.
#[derive(Clone, Debug, Default)]
pub struct GpuBvh {
    pub nodes: Vec<BvhNode>,
    /// A reference ([`PrimitiveKind::reference`]) per leaf slot; empty when the
    /// hierarchy holds triangles alone, which are then stored in leaf order instead.
    pub prim_refs: Vec<u32>,
    /// Leaf slot → primitive (the builder's order).
    pub order: Vec<u32>,
    pub build_ms: f64,
}

impl SceneBuffers {
    /// Flattens `scene` for the image `rays` describes, with a hierarchy when it has at
    /// least `bvh_min_primitives` spheres, ellipsoids and triangles. With `no_bins` (shadow,
    /// reflected or refracted rays, which bins do not hold) every ray walks the hierarchy.
    /// `sampled`: whether pixels cast rays anywhere in them (docs/SPEC.md §8), not only
    /// through their centres, which the bins must hold.
    pub fn new(
        scene: &Scene,
        rays: &PrimaryRays,
        options: &GpuOptions,
        no_bins: bool,
        sampled: bool,
        grid: Option<GridChoice>,
    ) -> SceneBuffers {
        let mut buffers = SceneBuffers::flattened(scene, rays);
        buffers.build_acceleration(rays, options, no_bins, sampled, grid, None);
        buffers
    }

    /// [`SceneBuffers::new`] without its way of finding candidates (no bins, hierarchy or
    /// grid yet: [`SceneBuffers::build_acceleration`]).
    pub fn flattened(scene: &Scene, rays: &PrimaryRays) -> SceneBuffers {
        let mut buffers = SceneBuffers { orthographic: rays.orthographic, ..Default::default() };
        let to_camera = DMat4::from_translation(-rays.center);
        buffers.flatten(&scene.root, &to_camera);
        buffers.materials = scene.materials.iter().map(GpuMaterial::new).collect();
        if scene.has_textures() {
            buffers.textures = (0..scene.materials.len() as u32)
                .map(|k| GpuTexture::new(scene.texture(k), rays.center, super::ray_tree::branching(scene, k) > 0))
                .collect();
        }
        buffers.lights = scene.lights.iter().map(|light| GpuLight::new(light, rays.center)).collect();
        buffers.params = Params {
            direction: f32x3(rays.direction),
            horizontal: f32x3(rays.horizontal),
            up: f32x3(rays.up),
            width: rays.width,
            height: rays.height,
            background: f32x3(scene.background.color),
            ambient: f32x3(scene.background.ambient),
            num_spheres: buffers.spheres.len() as u32,
            num_ellipsoids: buffers.ellipsoids.len() as u32,
            num_planes: buffers.planes.len() as u32,
            num_triangles: buffers.triangles.len() as u32,
            loop_canary_trips: LOOP_CANARY_TRIPS,
            num_lights: buffers.lights.len() as u32,
            ..Default::default()
        };
        buffers
    }

    /// What [`SceneBuffers::build_acceleration`] will build, without building it: exact,
    /// but for [`Acceleration::Bins`], which the bins' list lengths may still turn down for
    /// the hierarchy. (So the kernel for it can be compiled while they are built.)
    pub fn planned_acceleration(
        &self,
        rays: &PrimaryRays,
        options: &GpuOptions,
        no_bins: bool,
        sampled: bool,
        grid: bool,
    ) -> Acceleration {
        if grid {
            return Acceleration::Grid;
        }
        let Some(bins_asked) = self.bins_asked(rays, options, sampled) else { return Acceleration::Flat };
        if bins_asked && !no_bins {
            return Acceleration::Bins;
        }
        match self.holds_a_hierarchy(self.bvh_min_primitives(options)) {
            true => Acceleration::Hierarchy,
            false => Acceleration::Flat,
        }
    }

    /// Builds the grid (`grid`: `-grid`), or else bins, a hierarchy or nothing (flat
    /// loops), as [`SceneBuffers::new`] says. A hierarchy takes the shape of `shape`, a
    /// hierarchy of these primitives seen from another camera, refitted
    /// ([`crate::bvh::Bvh::refit`]) rather than built again, where it has as many.
    pub fn build_acceleration(
        &mut self,
        rays: &PrimaryRays,
        options: &GpuOptions,
        no_bins: bool,
        sampled: bool,
        grid: Option<GridChoice>,
        shape: Option<&GpuBvh>,
    ) {
        match grid {
            // An explicit grid means the grid (docs/SPEC.md §7).
            Some(GridChoice::Walk(size)) => self.grid = Some(GpuGrid::build(self, size)),
            Some(GridChoice::Given(grid)) => self.grid = Some(grid),
            None => self.choose_acceleration(rays, options, no_bins, sampled, shape),
        }
        if let Some(bvh) = self.bvh.as_ref().filter(|b| b.prim_refs.is_empty()) {
            self.triangles = bvh.order.iter().map(|&p| self.triangles[p as usize]).collect();
        }
        self.params.bin_columns = self.bins.as_ref().map_or(0, |b| b.columns);
        if let Some(grid) = &self.grid {
            [self.params.grid_nx, self.params.grid_ny, self.params.grid_nz] = grid.size;
            (self.params.grid_min, self.params.grid_cell) = (grid.min, grid.cell);
        }
    }

    /// The box the `-grid`'s cells divide, in world space (the camera's centre added back),
    /// where there is a grid with something in it: what `-stats` prints.
    pub fn grid_world_bounds(&self, camera_center: DVec3) -> Option<Bounds> {
        let bounds = self.grid.as_ref()?.bounds;
        (!bounds.is_empty()).then(|| Bounds { min: bounds.min + camera_center, max: bounds.max + camera_center })
    }

    /// What the kernel walks to find candidates.
    pub fn acceleration(&self) -> Acceleration {
        if self.grid.is_some() {
            Acceleration::Grid
        } else if self.bins.is_some() {
            Acceleration::Bins
        } else if self.bvh.is_some() {
            Acceleration::Hierarchy
        } else {
            Acceleration::Flat
        }
    }

    /// Bins, a hierarchy or flat loops: what `options` asks for, or with
    /// [`Acceleration::Auto`] the cost model's choice; with `no_bins`, the hierarchy
    /// where bins were asked for.
    fn choose_acceleration(
        &mut self,
        rays: &PrimaryRays,
        options: &GpuOptions,
        no_bins: bool,
        sampled: bool,
        shape: Option<&GpuBvh>,
    ) {
        let Some(bins_asked) = self.bins_asked(rays, options, sampled) else { return };
        if bins_asked && !no_bins {
            let candidates = binning::candidates(&self.triangles, &self.sphere_bounds, &self.ellipsoid_bounds);
            let forced = options.acceleration == Acceleration::Bins;
            // A sample lies within half a pixel of its pixel's centre (docs/SPEC.md §8).
            let reach = if sampled { 0.5 } else { 0.0 };
            self.bins = Bins::build(rays, &candidates, reach, |lengths| {
                forced || (lengths.mean <= BINS_MAX_MEAN_LIST && lengths.max <= LOOP_LIMIT / 2)
            });
            if self.bins.is_some() {
                return;
            }
        }
        self.bvh = self.build_bvh(self.bvh_min_primitives(options), shape);
    }

    /// Whether the finite primitives are triangles alone: then the hierarchy's leaves hold
    /// the triangles themselves, in leaf order, and no references (`build_bvh`).
    pub fn triangles_alone(&self) -> bool {
        self.spheres.is_empty() && self.ellipsoids.is_empty()
    }

    /// Spheres, ellipsoids and triangles: what bins and the hierarchy hold.
    fn finite(&self) -> usize {
        self.triangles.len() + self.spheres.len() + self.ellipsoids.len()
    }

    /// The fewest primitives a hierarchy is built for: `auto`'s threshold, else one.
    fn bvh_min_primitives(&self, options: &GpuOptions) -> usize {
        if options.acceleration == Acceleration::Auto {
            options.bvh_min_primitives
        } else {
            1
        }
    }

    /// Whether bins are asked for; `None` where flat loops are, with nothing else tried.
    fn bins_asked(&self, rays: &PrimaryRays, options: &GpuOptions, sampled: bool) -> Option<bool> {
        let finite = self.finite();
        let auto = options.acceleration == Acceleration::Auto;
        if finite == 0 || options.acceleration == Acceleration::Flat || (auto && finite < options.bvh_min_primitives) {
            return None;
        }
        // `auto` tries bins at every size for one ray a pixel: their kernel, without loops
        // over its rays, compiles faster than the hierarchy's, and building bins costs less
        // than building the hierarchy, so even a 16² image is quicker with them
        // (docs/performance.md). Samples take bins from SAMPLED_BINS_MIN_PIXELS on. Long
        // lists still go to the hierarchy (choose_acceleration).
        let pixels = rays.width as u64 * rays.height as u64;
        Some(options.acceleration == Acceleration::Bins || (auto && (!sampled || pixels >= SAMPLED_BINS_MIN_PIXELS)))
    }

    /// Whether a hierarchy is built for these primitives, from `min_primitives` on.
    fn holds_a_hierarchy(&self, min_primitives: usize) -> bool {
        (min_primitives.max(1)..=BVH_MAX_PRIMITIVES).contains(&self.finite())
    }

    fn build_bvh(&self, min_primitives: usize, shape: Option<&GpuBvh>) -> Option<GpuBvh> {
        if !self.holds_a_hierarchy(min_primitives) {
            return None;
        }
        let finite = self.finite();
        let start = Instant::now();
        let mut bounds = Vec::with_capacity(finite);
        let mut refs = Vec::with_capacity(finite);
        for (k, t) in self.triangles.iter().enumerate() {
            bounds.push(Aabb::of_points(&[Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2)]));
            refs.push(PrimitiveKind::Triangle.reference(k));
        }
        for (k, b) in self.sphere_bounds.iter().enumerate() {
            bounds.push(*b);
            refs.push(PrimitiveKind::Sphere.reference(k));
        }
        for (k, b) in self.ellipsoid_bounds.iter().enumerate() {
            bounds.push(*b);
            refs.push(PrimitiveKind::Ellipsoid.reference(k));
        }
        let bvh = match shape.filter(|s| s.order.len() == finite) {
            Some(shape) => {
                let mut kept = Bvh { nodes: shape.nodes.clone(), order: shape.order.clone() };
                kept.refit(&bounds);
                kept
            }
            None => Bvh::build(&bounds),
        };
        let prim_refs = if self.triangles_alone() {
            // Triangles alone: the kernel reads them in leaf order directly (see `leaf_slot`).
            Vec::new()
        } else {
            bvh.order.iter().map(|&p| refs[p as usize]).collect()
        };
        Some(GpuBvh { nodes: bvh.nodes, prim_refs, order: bvh.order, build_ms: start.elapsed().as_secs_f64() * 1e3 })
    }

    /// Every primitive of the tree, with `leaf.to_world` mapping its object space to
    /// camera-relative world space.
    fn flatten(&mut self, objects: &[Object], to_camera: &DMat4) {
        for_each_leaf(objects, to_camera, &mut |leaf| {
            let matrix = &leaf.to_world;
            match leaf.shape() {
                Shape::Sphere { center, radius, material } => self.push_sphere(matrix, *center, *radius, *material),
                Shape::Plane { normal, offset, material } => self.push_plane(matrix, *normal, *offset, *material),
                Shape::Triangle { vertices, material } => {
                    let world = vertices.map(|v| matrix.transform_point3(v));
                    self.triangles.push(gpu_triangle(world, mirrors(matrix), *material));
                }
                Shape::Mesh { mesh, material } => self.push_mesh(matrix, mesh, *material),
                Shape::Group(_) | Shape::Transform { .. } => {}
            }
        });
    }

    fn push_sphere(&mut self, matrix: &DMat4, center: DVec3, radius: f64, material: u32) {
        let linear = DMat3::from_mat4(*matrix);
        if let Some(scale) = similarity_scale(&linear) {
            let (world_center, world_radius) = (matrix.transform_point3(center), radius * scale);
            self.sphere_bounds.push(padded_box(world_center, DVec3::splat(world_radius)));
            self.spheres.push(GpuSphere {
                center: f32x3(world_center),
                radius: world_radius as f32,
                material,
                ..Default::default()
            });
            return;
        }
        // The unit sphere at the origin, carried to the world by matrix · T(c) · S(r);
        // the kernel needs the inverse of that.
        let to_world = *matrix * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
        let to_unit = to_world.inverse();
        let (center, half) = ellipsoid_extent(&to_world);
        self.ellipsoid_bounds.push(padded_box(center, half));
        let rows = [0, 1, 2].map(|r| to_unit.row(r).as_vec4().to_array());
        self.ellipsoids.push(GpuEllipsoid { rows, material, ..Default::default() });
    }

    /// The plane's world normal is `normalise(M⁻ᵀ·n̂)`; a point on it, `offset·n̂`, maps by M.
    fn push_plane(&mut self, matrix: &DMat4, normal: DVec3, offset: f64, material: u32) {
        let n = normal.normalize();
        let world_normal = DMat3::from_mat4(*matrix).inverse().transpose().mul_vec3(n).normalize();
        let world_point = matrix.transform_point3(offset * n);
        self.planes.push(GpuPlane {
            normal: f32x3(world_normal),
            offset: world_normal.dot(world_point) as f32,
            material,
            ..Default::default()
        });
    }

    /// Each position of the mesh carried to the world once, then its triangles flattened
    /// on every core, in order.
    fn push_mesh(&mut self, matrix: &DMat4, mesh: &Mesh, material: u32) {
        let world: Vec<DVec3> = mesh.positions.par_iter().map(|&p| matrix.transform_point3(p)).collect();
        let mirrored = mirrors(matrix);
        self.triangles.par_extend(
            mesh.triangles.par_iter().map(|t| gpu_triangle(t.map(|v| world[v as usize]), mirrored, material)),
        );
    }
}

/// Whether `matrix` mirrors (det < 0), which reverses the winding of mapped vertices.
fn mirrors(matrix: &DMat4) -> bool {
    DMat3::from_mat4(*matrix).determinant() < 0.0
}

/// A triangle of world (camera-relative) vertices. A mirroring transform reverses the winding
/// of mapped vertices, while the normal of docs/SPEC.md §4, `normalise(M⁻ᵀ·n)`, does not
/// flip; swapping two vertices keeps them equal.
fn gpu_triangle([a, mut b, mut c]: [DVec3; 3], mirrored: bool, material: u32) -> GpuTriangle {
    if mirrored {
        std::mem::swap(&mut b, &mut c);
    }
    // A triangle f64 cannot give a normal is never hit (cpu::intersect_triangle): it
    // reaches the kernel as a point, whose edge functions and determinant are exactly 0
    // on every driver (shaders/exact.wgsl), so it is tested (and counted) but never hit,
    // and its normal is a unit vector, not the NaN of a zero vector normalised.
    let Some(normal) = (b - a).cross(c - a).try_normalize() else {
        let point = f32x3(a);
        let [normal_u, normal_v] = super::layout::octahedral(DVec3::Z);
        return GpuTriangle { v0: point, material, v1: point, normal_u, v2: point, normal_v };
    };
    let [normal_u, normal_v] = super::layout::octahedral(normal);
    GpuTriangle { v0: f32x3(a), material, v1: f32x3(b), normal_u, v2: f32x3(c), normal_v }
}

/// The f32 box around `center ± half`, padded by a relative 1e-6 so that rounding to f32
/// can never leave part of the curved surface outside it.
/// Which grid a render with `-grid` gets.
pub enum GridChoice {
    /// The kernel's own over its f32 primitives, for finding hits ([`GpuGrid`]).
    Walk(GridSize),
    /// One the caller built (the `-visualize_grid` occupancy of `gpu::voxels`).
    Given(GpuGrid),
}

/// The `-grid` as the kernel walks it (shaders/grid.wgsl): cell `x + nx·(y + ny·z)` lists
/// `refs[first .. first + count]` for its `ranges` entry `[first, count]`.
#[derive(Clone, Debug)]
pub struct GpuGrid {
    pub size: [u32; 3],
    /// The box the cells divide, camera-relative, in f64 ([`Bounds::EMPTY`] when nothing
    /// finite was there).
    pub bounds: Bounds,
    pub min: [f32; 3],
    pub cell: [f32; 3],
    pub ranges: Vec<[u32; 2]>,
    pub refs: Vec<u32>,
    pub build_ms: f64,
}

/// Each footprint is widened by this share of the largest of the grid's extent and its
/// coordinates' magnitude before it is placed: the kernel computes cell boundaries and hit
/// points in f32 (relative error about 6·10⁻⁸ per operation, a few tens of them), so a hit
/// point is never outside the cells that list its primitive.
const GRID_MARGIN_F32: f64 = 1e-5;

impl GpuGrid {
    /// The grid of `size` cells over the buffers' finite primitives, each placed by its box,
    /// but a sphere by the handout's rule as the reference places an untransformed one
    /// (docs/SPEC.md §7), so that both test the same items where both run the 3D-DDA
    /// (`-stats` counts them): each widened by the margin.
    fn build(buffers: &SceneBuffers, size: GridSize) -> GpuGrid {
        let start = Instant::now();
        let mut boxes: Vec<(u32, Aabb)> = Vec::new();
        for (k, t) in buffers.triangles.iter().enumerate() {
            let bounds = Aabb::of_points(&[Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2)]);
            boxes.push((PrimitiveKind::Triangle.reference(k), bounds));
        }
        let kinds =
            [(PrimitiveKind::Sphere, &buffers.sphere_bounds), (PrimitiveKind::Ellipsoid, &buffers.ellipsoid_bounds)];
        for (kind, bounds) in kinds {
            boxes.extend(bounds.iter().enumerate().map(|(k, b)| (kind.reference(k), *b)));
        }
        let to_bounds = |b: &Aabb| Bounds { min: b.min.as_dvec3(), max: b.max.as_dvec3() };
        let all = boxes.iter().fold(Bounds::EMPTY, |all, (_, b)| all.union(&to_bounds(b)));
        let margin = GRID_MARGIN_F32 * reach_of(&all);
        let footprints: Vec<Footprint> = boxes
            .iter()
            .map(|&(reference, b)| match PrimitiveKind::of_reference(reference) {
                (PrimitiveKind::Sphere, k) => {
                    let sphere = &buffers.spheres[k];
                    let center = Vec3::from(sphere.center).as_dvec3();
                    Footprint::Sphere { center, radius: f64::from(sphere.radius) + margin }
                }
                _ => {
                    let b = to_bounds(&b);
                    Footprint::Box(Bounds { min: b.min - margin, max: b.max + margin })
                }
            })
            .collect();
        let grid = Grid::new(all, size, &footprints);
        let [nx, ny, nz] = grid.size();
        let (mut ranges, mut refs) = (Vec::with_capacity(grid.cell_count()), Vec::new());
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let items = grid.items([x, y, z]);
                    ranges.push([refs.len() as u32, items.len() as u32]);
                    refs.extend(items.iter().map(|&item| boxes[item as usize].0));
                }
            }
        }
        // With nothing finite the box is empty; every cell's list is, and no ray enters.
        let min = if all.is_empty() { DVec3::ZERO } else { grid.bounds.min };
        GpuGrid {
            size: [size.nx, size.ny, size.nz],
            bounds: grid.bounds,
            min: f32x3(min),
            cell: f32x3(grid.cell_extent()),
            ranges,
            refs,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }
}

impl GpuGrid {
    /// A bound of the loop iterations of one ray's march: a ray crosses at most
    /// `nx + ny + nz` cells, each with at most the longest list.
    pub fn most_iterations_per_ray(&self) -> u64 {
        let crossed: u64 = self.size.iter().map(|&n| u64::from(n)).sum();
        let longest = self.ranges.iter().map(|r| u64::from(r[1])).max().unwrap_or(0);
        crossed * (longest + 1)
    }
}

/// The larger of a box's extent and its coordinates' magnitude (0 for an empty box).
fn reach_of(b: &Bounds) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    (b.max - b.min).max_element().max(b.min.abs().max(b.max.abs()).max_element())
}

fn padded_box(center: DVec3, half: DVec3) -> Aabb {
    let pad = half + DVec3::splat(1e-6 * (center.abs().max_element() + half.max_element()));
    Aabb { min: (center - pad).as_vec3(), max: (center + pad).as_vec3() }
}

/// `Some(s)` when `linear` is `s` times a rotation or reflection (columns orthogonal and of
/// equal length, to f64 rounding), so a sphere stays a sphere of radius `s·r`.
pub(crate) fn similarity_scale(linear: &DMat3) -> Option<f64> {
    let cols = [linear.x_axis, linear.y_axis, linear.z_axis];
    let lengths = cols.map(|c| c.length());
    let scale = lengths[0];
    let tolerance = 1e-12 * scale;
    let equal = lengths.iter().all(|l| (l - scale).abs() <= tolerance);
    let orthogonal = (cols[0].dot(cols[1]).abs() <= tolerance * scale)
        && (cols[0].dot(cols[2]).abs() <= tolerance * scale)
        && (cols[1].dot(cols[2]).abs() <= tolerance * scale);
    (equal && orthogonal && scale > 0.0).then_some(scale)
}

fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}
