//! The scene as the reference traces it: the parsed tree with what does not depend on the
//! ray worked out once — each Transform's `M⁻¹` and `(M⁻¹)ᵀ`, each plane's unit normal,
//! each mesh's bounding box — and the three queries the renderer is built from:
//!
//! - [`ReferenceScene::closest_hit`]: the nearest `t` and which primitive it belongs to;
//! - [`ReferenceScene::surface_at`]: what the shading needs at that hit, built once for the
//!   nearest hit only (pbrt-v4's split of `Intersect` and `SurfaceInteraction`: the normals
//!   of the hits a nearer one replaces are never computed);
//! - [`ReferenceScene::occluded`]: whether anything lies on a ray at all (pbrt-v4's
//!   `IntersectP`), for shadow rays, which may stop at the first hit they find.
//!
//! The tree is still walked for every ray and the ray carried through each Transform in
//! turn, exactly as docs/SPEC.md §4 says. With `-grid` ([`ReferenceScene::with_grid`]) the
//! two searches walk the grid's cells instead (docs/SPEC.md §7): the same primitives, the
//! same rays carried the same way into them, only fewer of them tested; ties between equal
//! `t`s go to the primitive the tree walk would have kept, so both give the same hit. Composing the matrices of nested Transforms into
//! one would be faster, but would round differently from the spec's arithmetic, and this
//! renderer is the spec's arithmetic.

use super::intersect::{
    intersect_plane, intersect_sphere, intersect_triangle, ray_meets_box, sphere_normal, triangle_normal,
};
use crate::camera::Ray;
use crate::grid::{Footprint, Grid, GridSize};
use crate::render::RayStats;
use crate::scene::{Bounds, Material, Mesh, Object, Scene, Shape};
use glam::{DMat4, DVec3};

/// A scene prepared for the reference (see the module documentation).
pub struct ReferenceScene<'a> {
    /// The parsed scene it was prepared from (its lights, background and materials are
    /// used as they are).
    pub scene: &'a Scene,
    /// The top-level `Group`'s objects, as in [`Scene::root`].
    root: Vec<Node>,
    transforms: Vec<Transform>,
    primitives: Vec<Primitive<'a>>,
    /// `-grid`'s cells over the bounded primitives, when asked for.
    grid: Option<SceneGrid>,
}

/// The grid over a scene's primitives (docs/SPEC.md §7).
pub struct SceneGrid {
    pub grid: Grid,
    /// What each of the grid's items is: a primitive, and for a mesh one of its triangles
    /// (each triangle is an item of its own, placed by its own transformed box).
    items: Vec<Item>,
    /// The primitives no grid can hold (planes), tested by every ray.
    unbounded: Vec<usize>,
}

#[derive(Clone, Copy, Debug)]
struct Item {
    primitive: usize,
    triangle: Option<usize>,
}

/// A node of [`Scene::root`]'s tree, its leaves and Transforms moved into the scene's lists.
enum Node {
    Group(Vec<Node>),
    Transform { transform: usize, child: Box<Node> },
    Primitive(usize),
}

/// One Transform node of the tree.
struct Transform {
    /// `M⁻¹`, which carries a ray from the parent's space into the child's.
    inverse: DMat4,
    /// `(M⁻¹)ᵀ`, which carries a normal back from the child's space (the normal transforms
    /// by the inverse transpose so that it stays perpendicular to transformed tangents:
    /// pbrt-v4 §3.10.3).
    inverse_transpose: DMat4,
    /// The nearest Transform enclosing this one: with [`Primitive::transform`], the path
    /// from a primitive out to the world, which [`ReferenceScene::surface_at`] retraces.
    parent: Option<usize>,
    /// `M₁·M₂⋯M`, from this Transform's child space to the world: only where the grid
    /// places primitives, never on a ray's path.
    to_world: DMat4,
}

/// One leaf of the tree (a mesh is one leaf; a hit says which of its triangles).
struct Primitive<'a> {
    geometry: Geometry<'a>,
    material: u32,
    /// The nearest enclosing Transform, `None` at the top level.
    transform: Option<usize>,
}

enum Geometry<'a> {
    Sphere { center: DVec3, radius: f64 },
    Plane { unit_normal: DVec3, offset: f64 },
    Triangle([DVec3; 3]),
    Mesh { mesh: &'a Mesh, bounds: Bounds },
}

/// The nearest hit of a ray: only where (`t`) and what; [`ReferenceScene::surface_at`]
/// makes the rest of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The world t (a ray carried into a Transform keeps the scale of its direction).
    pub t: f64,
    primitive: usize,
    /// Which triangle of a mesh; 0 for the other primitives.
    triangle: usize,
}

impl Hit {
    /// Whether `other` is on the same primitive (for a mesh, the same triangle): a test asks
    /// whether a secondary ray met the surface it left or another one.
    pub fn same_primitive(&self, other: &Hit) -> bool {
        (self.primitive, self.triangle) == (other.primitive, other.triangle)
    }
}

/// The surface at a hit: what shading, and the secondary rays to come, need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// The hit's world t.
    pub t: f64,
    /// The hit point in world space, `o + t·d` of the world ray.
    pub point: DVec3,
    /// The unit world normal as the primitive defines it (outward for spheres, `n̂` for
    /// planes, counter-clockwise for triangles), not flipped toward the viewer.
    pub normal: DVec3,
    /// The hit point in the primitive's own coordinates (inside every enclosing
    /// Transform), where a solid texture is evaluated so that it moves with its object.
    pub object_point: DVec3,
    /// Index into [`Scene::materials`].
    pub material: u32,
}

/// Whether a query wants the nearest hit or is satisfied by any.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Want {
    Nearest,
    Any,
}

impl<'a> ReferenceScene<'a> {
    pub fn new(scene: &'a Scene) -> ReferenceScene<'a> {
        let mut prepared =
            ReferenceScene { scene, root: Vec::new(), transforms: Vec::new(), primitives: Vec::new(), grid: None };
        prepared.root = scene.root.iter().map(|object| prepared.prepare(object, None)).collect();
        prepared
    }

    /// The scene with a grid of `size` cells over its bounded primitives, through which
    /// [`Self::closest_hit`] and [`Self::occluded`] then search.
    pub fn with_grid(scene: &'a Scene, size: GridSize) -> ReferenceScene<'a> {
        let mut prepared = ReferenceScene::new(scene);
        prepared.grid = Some(prepared.build_grid(size));
        prepared
    }

    /// The grid, when the scene was prepared with one.
    pub fn grid(&self) -> Option<&SceneGrid> {
        self.grid.as_ref()
    }

    /// The grid over the scene's bounds, planes left out (the course's assignment 5): each
    /// sphere, triangle and mesh triangle an item, placed by its world footprint.
    fn build_grid(&self, size: GridSize) -> SceneGrid {
        let (mut items, mut footprints, mut unbounded) = (Vec::new(), Vec::new(), Vec::new());
        for (primitive, p) in self.primitives.iter().enumerate() {
            let (count, is_mesh) = match &p.geometry {
                Geometry::Plane { .. } => {
                    unbounded.push(primitive);
                    continue;
                }
                Geometry::Mesh { mesh, .. } => (mesh.triangles.len(), true),
                Geometry::Sphere { .. } | Geometry::Triangle(_) => (1, false),
            };
            for k in 0..count {
                items.push(Item { primitive, triangle: is_mesh.then_some(k) });
                footprints.push(self.footprint(primitive, k).expect("a bounded primitive"));
            }
        }
        let bounds = footprints.iter().fold(Bounds::EMPTY, |all, f| all.union(&f.bounds()));
        SceneGrid { grid: Grid::new(bounds, size, &footprints), items, unbounded }
    }

    /// Where triangle `triangle` of primitive `primitive` (0 for a primitive that is not a
    /// mesh) lies in the world; `None` for a plane.
    fn footprint(&self, primitive: usize, triangle: usize) -> Option<Footprint> {
        let p = &self.primitives[primitive];
        let to_world = p.transform.map(|k| self.transforms[k].to_world);
        let box_of = |vertices: [DVec3; 3]| {
            let map = |v: DVec3| to_world.map_or(v, |m| m.transform_point3(v));
            Footprint::Box(Bounds::of_points(vertices.map(map)))
        };
        Some(match &p.geometry {
            Geometry::Plane { .. } => return None,
            &Geometry::Sphere { center, radius } => match to_world {
                None => Footprint::Sphere { center, radius },
                // The box of the ellipsoid the transformed sphere is.
                Some(m) => Footprint::Box(Bounds::ellipsoid(
                    &(m * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius))),
                )),
            },
            // The handout's "special case" for transformed triangles: the box of the
            // transformed vertices, not the transformed box.
            Geometry::Triangle(vertices) => box_of(*vertices),
            Geometry::Mesh { mesh, .. } => box_of(mesh.triangle(triangle)),
        })
    }

    /// The world box of what `hit` is on (a sphere, a triangle, a mesh's triangle); `None`
    /// for a plane.
    pub fn world_bounds(&self, hit: &Hit) -> Option<Bounds> {
        self.footprint(hit.primitive, hit.triangle).map(|f| f.bounds())
    }

    fn prepare(&mut self, object: &'a Object, transform: Option<usize>) -> Node {
        let (geometry, material) = match &object.shape {
            Shape::Group(children) => {
                return Node::Group(children.iter().map(|child| self.prepare(child, transform)).collect())
            }
            Shape::Transform { matrix, child } => {
                let inverse = matrix.inverse();
                let to_world = transform.map_or(*matrix, |k| self.transforms[k].to_world * *matrix);
                self.transforms.push(Transform {
                    inverse,
                    inverse_transpose: inverse.transpose(),
                    parent: transform,
                    to_world,
                });
                let index = self.transforms.len() - 1;
                return Node::Transform { transform: index, child: Box::new(self.prepare(child, Some(index))) };
            }
            &Shape::Sphere { center, radius, material } => (Geometry::Sphere { center, radius }, material),
            &Shape::Plane { normal, offset, material } => {
                (Geometry::Plane { unit_normal: normal.normalize(), offset }, material)
            }
            &Shape::Triangle { vertices, material } => (Geometry::Triangle(vertices), material),
            Shape::Mesh { mesh, material } => (Geometry::Mesh { mesh, bounds: mesh.bounds() }, *material),
        };
        self.primitives.push(Primitive { geometry, material, transform });
        Node::Primitive(self.primitives.len() - 1)
    }

    /// The material a [`Surface`] names.
    pub fn material(&self, index: u32) -> &Material {
        &self.scene.materials[index as usize]
    }

    /// The hit with the smallest t in the ray's interval, if any (docs/SPEC.md §4: "the
    /// nearest hit with t > tmin is the one shown").
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        self.closest_hit_counted(ray, &mut RayStats::default())
    }

    /// [`Self::closest_hit`], adding the ray–primitive tests and grid cells it took to
    /// `stats`.
    pub fn closest_hit_counted(&self, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        if let Some(grid) = &self.grid {
            return self.closest_in_grid(grid, ray, stats);
        }
        let mut closest = None;
        for node in &self.root {
            self.closest_in(node, ray, &mut closest, stats);
        }
        closest
    }

    /// Replaces `closest` with any hit under `node` nearer than it.
    fn closest_in(&self, node: &Node, ray: &Ray, closest: &mut Option<Hit>, stats: &mut RayStats) {
        match node {
            Node::Group(children) => {
                for child in children {
                    self.closest_in(child, ray, closest, stats);
                }
            }
            Node::Transform { transform, child } => {
                self.closest_in(child, &self.transforms[*transform].ray_in_child(ray), closest, stats)
            }
            &Node::Primitive(primitive) => {
                // Only a hit nearer than the nearest so far can replace it.
                let ray = Ray { t_max: closest.map_or(ray.t_max, |hit| hit.t), ..*ray };
                if let Some((t, triangle)) = self.primitives[primitive].intersect(&ray, Want::Nearest, stats) {
                    *closest = Some(Hit { t, primitive, triangle });
                }
            }
        }
    }

    /// Whether any primitive is hit within the ray's interval. Stops at the first hit found,
    /// which need not be the nearest; true exactly when [`Self::closest_hit`] finds a hit.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_counted(ray, &mut RayStats::default())
    }

    /// [`Self::occluded`], adding the tests and grid cells it took to `stats`.
    pub fn occluded_counted(&self, ray: &Ray, stats: &mut RayStats) -> bool {
        match &self.grid {
            Some(grid) => self.occluded_in_grid(grid, ray, stats),
            None => self.root.iter().any(|node| self.occluded_in(node, ray, stats)),
        }
    }

    fn occluded_in(&self, node: &Node, ray: &Ray, stats: &mut RayStats) -> bool {
        match node {
            Node::Group(children) => children.iter().any(|child| self.occluded_in(child, ray, stats)),
            Node::Transform { transform, child } => {
                self.occluded_in(child, &self.transforms[*transform].ray_in_child(ray), stats)
            }
            &Node::Primitive(primitive) => self.primitives[primitive].intersect(ray, Want::Any, stats).is_some(),
        }
    }

    /// [`Self::closest_hit`] through the grid: the planes, then the items of each cell the
    /// ray enters, in order, until the nearest hit so far lies within the cells already
    /// searched (a hit beyond the current cell may be beaten by one in a later cell, so it
    /// is kept, not returned: the handout's "intersections outside the cell"). Every hit at
    /// or before a cell's exit lies in a cell searched, because an item is listed in every
    /// cell its (widened) footprint touches.
    fn closest_in_grid(&self, grid: &SceneGrid, ray: &Ray, stats: &mut RayStats) -> Option<Hit> {
        let mut rays = ObjectRays::new(self, ray);
        let mut best = None;
        for &primitive in &grid.unbounded {
            self.offer(Item { primitive, triangle: None }, &mut rays, &mut best, stats);
        }
        for visit in grid.grid.march(ray.origin, ray.direction, ray.t_min, ray.t_max) {
            if best.is_some_and(|hit: Hit| hit.t < visit.t_enter) {
                break;
            }
            stats.cells_traversed += 1;
            for &item in grid.grid.items(visit.cell) {
                self.offer(grid.items[item as usize], &mut rays, &mut best, stats);
            }
            if best.is_some_and(|hit| hit.t <= visit.t_exit) {
                break;
            }
        }
        best
    }

    /// Tests `item` and keeps its hit in `best` when it comes first in the tree walk's order:
    /// the smaller t, and at equal t the earlier primitive, then the earlier triangle (the
    /// walk keeps the first of equal hits, and a cell may offer a later one first).
    fn offer(&self, item: Item, rays: &mut ObjectRays, best: &mut Option<Hit>, stats: &mut RayStats) {
        let primitive = &self.primitives[item.primitive];
        let world_t_max = rays.world.t_max;
        let mut ray = rays.in_space_of(primitive.transform);
        // Up to and including the best t, so that an equal t can still win on order.
        ray.t_max = best.map_or(world_t_max, |hit| hit.t.next_up());
        let Some((t, triangle)) = (match (item.triangle, &primitive.geometry) {
            (Some(k), Geometry::Mesh { mesh, .. }) => {
                stats.intersections += 1;
                intersect_triangle(&mesh.triangle(k), &ray).map(|t| (t, k))
            }
            _ => primitive.intersect(&ray, Want::Nearest, stats),
        }) else {
            return;
        };
        let candidate = Hit { t, primitive: item.primitive, triangle };
        let first = |a: &Hit| (a.t, a.primitive, a.triangle);
        if t < world_t_max && best.is_none_or(|b| first(&candidate) < first(&b)) {
            *best = Some(candidate);
        }
    }

    /// [`Self::occluded`] through the grid: any hit in the ray's interval, in any cell.
    fn occluded_in_grid(&self, grid: &SceneGrid, ray: &Ray, stats: &mut RayStats) -> bool {
        let mut rays = ObjectRays::new(self, ray);
        let mut blocks = |item: Item, stats: &mut RayStats| {
            let primitive = &self.primitives[item.primitive];
            let ray = rays.in_space_of(primitive.transform);
            match (item.triangle, &primitive.geometry) {
                (Some(k), Geometry::Mesh { mesh, .. }) => {
                    stats.intersections += 1;
                    intersect_triangle(&mesh.triangle(k), &ray).is_some()
                }
                _ => primitive.intersect(&ray, Want::Any, stats).is_some(),
            }
        };
        if grid.unbounded.iter().any(|&primitive| blocks(Item { primitive, triangle: None }, stats)) {
            return true;
        }
        for visit in grid.grid.march(ray.origin, ray.direction, ray.t_min, ray.t_max) {
            stats.cells_traversed += 1;
            if grid.grid.items(visit.cell).iter().any(|&item| blocks(grid.items[item as usize], stats)) {
                return true;
            }
        }
        false
    }

    /// The surface at `hit`, which [`Self::closest_hit`] found on `ray`.
    ///
    /// docs/SPEC.md §4: the ray is carried into the primitive's space again, through the
    /// same Transforms with the same arithmetic as during the search, so the object-space
    /// point is the one the primitive's test saw; the primitive's normal there is carried
    /// back out as `normalise((M⁻¹)ᵀ·n)`, innermost Transform first, normalised at each one.
    pub fn surface_at(&self, hit: &Hit, ray: &Ray) -> Surface {
        let primitive = &self.primitives[hit.primitive];
        let object_point = self.ray_in_object_space(primitive.transform, ray).at(hit.t);
        let mut normal = primitive.normal(hit.triangle, object_point);
        let mut enclosing = primitive.transform;
        while let Some(k) = enclosing {
            let transform = &self.transforms[k];
            normal = transform.inverse_transpose.transform_vector3(normal).normalize();
            enclosing = transform.parent;
        }
        Surface { t: hit.t, point: ray.at(hit.t), normal, object_point, material: primitive.material }
    }

    /// `ray` carried through the Transforms from the outermost one in to `transform`.
    fn ray_in_object_space(&self, transform: Option<usize>, ray: &Ray) -> Ray {
        match transform {
            None => *ray,
            Some(k) => {
                let parent = self.ray_in_object_space(self.transforms[k].parent, ray);
                self.transforms[k].ray_in_child(&parent)
            }
        }
    }
}

impl Transform {
    /// docs/SPEC.md §4: `(M⁻¹·o, M⁻¹·d)`, the direction not renormalised, so that the
    /// child's t is the world t and the interval carries over as it is.
    fn ray_in_child(&self, ray: &Ray) -> Ray {
        Ray {
            origin: self.inverse.transform_point3(ray.origin),
            direction: self.inverse.transform_vector3(ray.direction),
            ..*ray
        }
    }
}

impl Primitive<'_> {
    /// A hit in the ray's interval, in the primitive's coordinates: its t and, for a mesh,
    /// which triangle. With [`Want::Nearest`] the nearest such hit.
    fn intersect(&self, ray: &Ray, want: Want, stats: &mut RayStats) -> Option<(f64, usize)> {
        if !matches!(self.geometry, Geometry::Mesh { .. }) {
            stats.intersections += 1;
        }
        match &self.geometry {
            &Geometry::Sphere { center, radius } => intersect_sphere(center, radius, ray).map(|t| (t, 0)),
            &Geometry::Plane { unit_normal, offset } => intersect_plane(unit_normal, offset, ray).map(|t| (t, 0)),
            Geometry::Triangle(vertices) => intersect_triangle(vertices, ray).map(|t| (t, 0)),
            Geometry::Mesh { mesh, bounds } => intersect_mesh(mesh, bounds, ray, want, stats),
        }
    }

    /// The unit normal at `point` (for a mesh, on triangle `triangle`), in the primitive's
    /// coordinates (docs/SPEC.md §4).
    fn normal(&self, triangle: usize, point: DVec3) -> DVec3 {
        let vertices = match &self.geometry {
            &Geometry::Sphere { center, radius } => return sphere_normal(center, radius, point),
            &Geometry::Plane { unit_normal, .. } => return unit_normal,
            Geometry::Triangle(vertices) => *vertices,
            Geometry::Mesh { mesh, .. } => mesh.triangle(triangle),
        };
        triangle_normal(&vertices).expect("intersect_triangle hits only triangles with a normal")
    }
}

/// The mesh's triangles one after the other, skipped all at once when the ray misses the
/// mesh's box.
fn intersect_mesh(mesh: &Mesh, bounds: &Bounds, ray: &Ray, want: Want, stats: &mut RayStats) -> Option<(f64, usize)> {
    if !ray_meets_box(ray, bounds) {
        return None;
    }
    let mut ray = *ray;
    let mut nearest = None;
    for k in 0..mesh.triangles.len() {
        stats.intersections += 1;
        if let Some(t) = intersect_triangle(&mesh.triangle(k), &ray) {
            nearest = Some((t, k));
            if want == Want::Any {
                break;
            }
            ray.t_max = t;
        }
    }
    nearest
}

/// One world ray carried into the space of each Transform it is needed in, each at most
/// once, by [`Transform::ray_in_child`] from the outermost Transform in: the same
/// arithmetic as the tree walk, so a primitive sees the same ray either way.
struct ObjectRays<'s, 'a> {
    scene: &'s ReferenceScene<'a>,
    world: Ray,
    carried: Vec<Option<Ray>>,
}

impl<'s, 'a> ObjectRays<'s, 'a> {
    fn new(scene: &'s ReferenceScene<'a>, world: &Ray) -> Self {
        ObjectRays { scene, world: *world, carried: vec![None; scene.transforms.len()] }
    }

    fn in_space_of(&mut self, transform: Option<usize>) -> Ray {
        let Some(k) = transform else { return self.world };
        if let Some(ray) = self.carried[k] {
            return ray;
        }
        let parent = self.in_space_of(self.scene.transforms[k].parent);
        let ray = self.scene.transforms[k].ray_in_child(&parent);
        self.carried[k] = Some(ray);
        ray
    }
}
