//! What a walk of the object tree measures: how far each object and the whole scene reach
//! ([`Object::bounds`], [`Scene::bounds`]) and how many primitives of each kind a scene
//! holds ([`Scene::primitive_counts`]). It sits above [`super::model`] (the types) and
//! [`super::walk`] (the visit, which reads those types), so that the three import in one
//! direction only.

use super::model::{Bounds, Extent, Object, PrimitiveCounts, Scene, Shape};
use super::walk::for_each_leaf;
use glam::{DMat4, DVec3};

impl Object {
    /// How far the object reaches in the coordinates of the object holding it: exact for
    /// every finite shape, [`Extent::Unbounded`] for a plane and for anything that contains
    /// one. A group with no objects is [`Bounds::EMPTY`].
    pub fn bounds(&self) -> Extent {
        extent_of(std::slice::from_ref(self))
    }
}

/// The union of the leaves' extents ([`leaf_extent`]) under `objects`.
fn extent_of(objects: &[Object]) -> Extent {
    let mut all = Extent::Bounded(Bounds::EMPTY);
    for_each_leaf(objects, &DMat4::IDENTITY, &mut |leaf| {
        let to_world = leaf.transform.is_some().then_some(&leaf.to_world);
        all = all.union(&leaf_extent(leaf.shape(), to_world));
    });
    all
}

/// The extent of a primitive after `to_world` (`None`: the identity) maps its points.
/// Exact: spheres become ellipsoids with their own box, triangles and meshes the box of
/// their mapped vertices (an affine map keeps convex hulls).
fn leaf_extent(shape: &Shape, to_world: Option<&DMat4>) -> Extent {
    let map = |p: DVec3| to_world.map_or(p, |m| m.transform_point3(p));
    Extent::Bounded(match shape {
        Shape::Plane { .. } => return Extent::Unbounded,
        Shape::Sphere { center, radius, .. } => match to_world {
            None => Bounds::sphere(*center, *radius),
            // The unit sphere carried by to_world · T(center) · S(radius).
            Some(m) => {
                Bounds::ellipsoid(&(*m * DMat4::from_translation(*center) * DMat4::from_scale(DVec3::splat(*radius))))
            }
        },
        Shape::Triangle { vertices, .. } => Bounds::of_points(vertices.map(map)),
        Shape::Mesh { mesh, .. } => Bounds::of_points(mesh.positions.iter().map(|&p| map(p))),
        Shape::Group(_) | Shape::Transform { .. } => unreachable!("the walk visits leaves only"),
    })
}

impl Scene {
    /// How far the scene reaches in world space: the union of its objects' extents
    /// ([`Object::bounds`]); unbounded as soon as it has a plane.
    pub fn bounds(&self) -> Extent {
        extent_of(&self.root)
    }

    pub fn primitive_counts(&self) -> PrimitiveCounts {
        let mut counts = PrimitiveCounts::default();
        for_each_leaf(&self.root, &DMat4::IDENTITY, &mut |leaf| match leaf.shape() {
            Shape::Sphere { .. } => counts.spheres += 1,
            Shape::Plane { .. } => counts.planes += 1,
            Shape::Triangle { .. } => counts.triangles += 1,
            Shape::Mesh { mesh, .. } => counts.triangles += mesh.triangles.len(),
            Shape::Group(_) | Shape::Transform { .. } => {}
        });
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Location, Mesh};
    use std::path::PathBuf;
    use std::sync::Arc;

    fn object(shape: Shape) -> Object {
        Object { shape, location: Location::default(), fields: Default::default() }
    }

    fn transform(matrix: DMat4, shape: Shape) -> Shape {
        Shape::Transform { matrix, child: Box::new(object(shape)) }
    }

    fn sphere(center: DVec3, radius: f64) -> Shape {
        Shape::Sphere { center, radius, material: 0 }
    }

    fn bounded(extent: Extent) -> Bounds {
        extent.bounds().expect("bounded")
    }

    fn assert_close(actual: Bounds, expected: Bounds) {
        let error = (actual.min - expected.min).abs().max((actual.max - expected.max).abs()).max_element();
        assert!(error <= 1e-12, "{actual:?} vs {expected:?}");
    }

    #[test]
    fn sphere_bounds() {
        let bounds = bounded(object(sphere(DVec3::new(1.0, 2.0, 3.0), 2.0)).bounds());
        assert_eq!(bounds, Bounds { min: DVec3::new(-1.0, 0.0, 1.0), max: DVec3::new(3.0, 4.0, 5.0) });
    }

    /// The sphere of centre (1, 0, 0) and radius 1 under `ZRotate 45` then `Scale 2 1 3`
    /// (M = R·S): S makes the ellipsoid of centre (2, 0, 0) and semi-axes 2, 1, 3; R turns it
    /// by 45° about z, so its centre goes to (√2, √2, 0) and its half-extent along x (and y)
    /// is √(2²·cos²45° + 1²·sin²45°) = √2.5; along z it stays 3.
    #[test]
    fn sphere_under_rotation_and_non_uniform_scale() {
        let matrix = DMat4::from_rotation_z(45f64.to_radians()) * DMat4::from_scale(DVec3::new(2.0, 1.0, 3.0));
        let shape = transform(matrix, sphere(DVec3::X, 1.0));
        let (c, h) = (2f64.sqrt(), 2.5f64.sqrt());
        let expected = Bounds { min: DVec3::new(c - h, c - h, -3.0), max: DVec3::new(c + h, c + h, 3.0) };
        assert_close(bounded(object(shape).bounds()), expected);
        // Tight: points of the surface reach each face of the box, and none leaves it.
        let mut reached = Bounds::EMPTY;
        for i in 0..=200 {
            for j in 0..=400 {
                let (theta, phi) = (std::f64::consts::PI * i as f64 / 200.0, std::f64::consts::TAU * j as f64 / 400.0);
                let u = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                reached = reached.union(&Bounds::of_points([matrix.transform_point3(DVec3::X + u)]));
            }
        }
        assert!(reached.min.cmpge(expected.min - 1e-12).all() && reached.max.cmple(expected.max + 1e-12).all());
        assert!((reached.min - expected.min).abs().max((reached.max - expected.max).abs()).max_element() < 1e-3);
    }

    #[test]
    fn triangle_bounds_plain_and_transformed() {
        let vertices = [DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 2.0, -1.0)];
        let triangle = Shape::Triangle { vertices, material: 0 };
        assert_eq!(
            bounded(object(triangle.clone()).bounds()),
            Bounds { min: DVec3::new(0.0, 0.0, -1.0), max: DVec3::new(1.0, 2.0, 0.0) }
        );
        // x ↦ 2x + 1 on every axis, then a quarter turn about z: (x, y, z) ↦ (−y, x, z).
        let matrix = DMat4::from_rotation_z(90f64.to_radians())
            * DMat4::from_translation(DVec3::ONE)
            * DMat4::from_scale(DVec3::splat(2.0));
        // Mapped vertices: (−1, 1, 1), (−1, 3, 1), (−5, 1, −1).
        let expected = Bounds { min: DVec3::new(-5.0, 1.0, -1.0), max: DVec3::new(-1.0, 3.0, 1.0) };
        assert_close(bounded(object(transform(matrix, triangle)).bounds()), expected);
    }

    #[test]
    fn mesh_bounds() {
        let positions =
            vec![DVec3::new(1.0, -2.0, 0.5), DVec3::new(-3.0, 4.0, 0.0), DVec3::new(0.0, 0.0, 7.0), DVec3::ZERO];
        let mesh = Arc::new(Mesh {
            path: PathBuf::new(),
            positions,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            vertex_locations: Vec::new(),
        });
        let expected = Bounds { min: DVec3::new(-3.0, -2.0, 0.0), max: DVec3::new(1.0, 4.0, 7.0) };
        assert_eq!(mesh.bounds(), expected);
        assert_eq!(bounded(object(Shape::Mesh { mesh: mesh.clone(), material: 0 }).bounds()), expected);
        let moved = transform(DMat4::from_translation(DVec3::new(10.0, 0.0, 0.0)), Shape::Mesh { mesh, material: 0 });
        assert_eq!(
            bounded(object(moved).bounds()),
            Bounds { min: expected.min + DVec3::X * 10.0, max: expected.max + DVec3::X * 10.0 }
        );
        let empty = Mesh::default().bounds();
        assert!(empty.is_empty() && empty == Bounds::EMPTY);
    }

    #[test]
    fn planes_are_unbounded_and_groups_fold() {
        let plane = Shape::Plane { normal: DVec3::Y, offset: -1.0, material: 0 };
        assert_eq!(object(plane.clone()).bounds(), Extent::Unbounded);
        let rotated = transform(DMat4::from_rotation_x(0.3), plane.clone());
        assert_eq!(object(rotated).bounds(), Extent::Unbounded);
        assert_eq!(object(Shape::Group(Vec::new())).bounds(), Extent::Bounded(Bounds::EMPTY));
        let a = sphere(DVec3::ZERO, 1.0);
        let b = transform(DMat4::from_translation(DVec3::new(5.0, 0.0, 0.0)), sphere(DVec3::ZERO, 2.0));
        let group = Shape::Group(vec![object(a.clone()), object(b.clone())]);
        let union = Bounds { min: DVec3::new(-1.0, -2.0, -2.0), max: DVec3::new(7.0, 2.0, 2.0) };
        assert_close(bounded(object(group).bounds()), union);
        assert_eq!(object(Shape::Group(vec![object(a), object(b), object(plane)])).bounds(), Extent::Unbounded);
    }

    #[test]
    fn nested_transforms_compose() {
        // Outer translation of the inner scale: the unit sphere becomes radius 2 around (10, 0, 0).
        let inner = transform(DMat4::from_scale(DVec3::splat(2.0)), sphere(DVec3::ZERO, 1.0));
        let outer = transform(DMat4::from_translation(DVec3::new(10.0, 0.0, 0.0)), inner);
        let expected = Bounds { min: DVec3::new(8.0, -2.0, -2.0), max: DVec3::new(12.0, 2.0, 2.0) };
        assert_close(bounded(object(outer).bounds()), expected);
    }

    #[test]
    fn scene_bounds_fold_the_root() {
        let camera = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }";
        let materials = "Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }";
        let objects = "Sphere { center 0 0 0 radius 1 }
            Transform { Translate 0 3 0 Scale 1 2 1 Sphere { center 0 0 0 radius 1 } }
            Triangle { vertex0 -4 0 0 vertex1 0 0 0 vertex2 0 0 -6 }";
        let parse = |objects: &str, count: u32| {
            let text = format!("{camera} {materials} Group {{ numObjects {count} MaterialIndex 0 {objects} }}");
            crate::scene::parse_scene(&text, std::path::Path::new("bounds.txt")).unwrap()
        };
        let expected = Bounds { min: DVec3::new(-4.0, -1.0, -6.0), max: DVec3::new(1.0, 5.0, 1.0) };
        assert_close(bounded(parse(objects, 3).bounds()), expected);
        let with_plane = format!("{objects} Plane {{ normal 0 1 0 offset -1 }}");
        assert_eq!(parse(&with_plane, 4).bounds(), Extent::Unbounded);
    }
}
