//! The one walk of the object tree: every primitive (sphere, plane, triangle, mesh) with the
//! transform that the Groups and Transforms above it add up to.
//!
//! Each stage that needs the scene's primitives in world space (the GPU's flattening, its
//! precision check, the scene's bounds and counts (`measure`), a split render's scene hash) visits them
//! through here, so the order of the matrix products, and so every rounding, is the same for
//! all of them. (The CPU reference keeps its own walk on purpose: it carries the ray through
//! each Transform in turn, as docs/SPEC.md §4 says, and must stay independent.)

use super::model::{Location, Object, Shape};
use glam::DMat4;

/// A primitive of the tree as the walk reaches it.
#[derive(Clone, Copy, Debug)]
pub struct Leaf<'a> {
    /// The primitive's node: its shape is a Sphere, Plane, Triangle or Mesh, never a Group
    /// or a Transform. Its `location` and `fields` say where it was written.
    pub object: &'a Object,
    /// Maps the primitive's own coordinates to those of the walk's start: `start · M₁ · M₂ ⋯`
    /// for the Transforms from the outermost in, each product taken as the walk descends.
    pub to_world: DMat4,
    /// Where the innermost Transform around the primitive was written, if there is one.
    pub transform: Option<Location>,
}

impl<'a> Leaf<'a> {
    pub fn shape(&self) -> &'a Shape {
        &self.object.shape
    }
}

/// Calls `visit` for every primitive under `objects`, in file order, starting from `start`
/// (the identity, or a map such as "move the camera to the origin"), and stops at the first
/// error. The depth is bounded by the parser's nesting limit ([`super::MAX_NESTING`]).
pub fn try_for_each_leaf<'a, E>(
    objects: &'a [Object],
    start: &DMat4,
    visit: &mut impl FnMut(&Leaf<'a>) -> Result<(), E>,
) -> Result<(), E> {
    walk(objects, start, None, visit)
}

/// [`try_for_each_leaf`] for a visit that cannot fail.
pub fn for_each_leaf<'a>(objects: &'a [Object], start: &DMat4, visit: &mut impl FnMut(&Leaf<'a>)) {
    let _ = walk::<std::convert::Infallible>(objects, start, None, &mut |leaf| {
        visit(leaf);
        Ok(())
    });
}

fn walk<'a, E>(
    objects: &'a [Object],
    to_world: &DMat4,
    transform: Option<Location>,
    visit: &mut impl FnMut(&Leaf<'a>) -> Result<(), E>,
) -> Result<(), E> {
    for object in objects {
        match &object.shape {
            Shape::Group(children) => walk(children, to_world, transform, visit)?,
            Shape::Transform { matrix, child } => {
                walk(std::slice::from_ref(&**child), &(*to_world * *matrix), Some(object.location), visit)?
            }
            _ => visit(&Leaf { object, to_world: *to_world, transform })?,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn parse(objects: &str, count: u32) -> crate::scene::Scene {
        let text = format!(
            "OrthographicCamera {{ center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }}
             Materials {{ numMaterials 1 Material {{ }} }}
             Group {{ numObjects {count} MaterialIndex 0 {objects} }}"
        );
        crate::scene::parse_scene(&text, std::path::Path::new("walk.txt")).unwrap()
    }

    /// Leaves come in file order, each with the product of the Transforms above it (outer
    /// first) and the place of the innermost one.
    #[test]
    fn leaves_in_file_order_with_their_transforms() {
        let scene = parse(
            "Sphere { center 0 0 0 radius 1 }
             Transform { Translate 1 0 0
               Group { numObjects 2
                 Plane { normal 0 1 0 offset 0 }
                 Transform { Scale 2 2 2 Triangle { vertex0 0 0 0 vertex1 1 0 0 vertex2 0 1 0 } } } }",
            2,
        );
        let mut seen = Vec::new();
        for_each_leaf(&scene.root, &DMat4::IDENTITY, &mut |leaf| {
            seen.push((leaf.to_world.transform_point3(DVec3::ONE), leaf.transform.map(|l| l.line)))
        });
        assert_eq!(
            seen,
            vec![
                (DVec3::ONE, None),
                (DVec3::new(2.0, 1.0, 1.0), Some(4)),
                // Translate(1, 0, 0) · Scale(2): (1, 1, 1) ↦ (2, 2, 2) ↦ (3, 2, 2).
                (DVec3::new(3.0, 2.0, 2.0), Some(7)),
            ]
        );
    }

    #[test]
    fn the_first_error_stops_the_walk() {
        let scene = parse(
            "Sphere { center 0 0 0 radius 1 } Sphere { center 0 0 0 radius 2 } Sphere { center 0 0 0 radius 3 }",
            3,
        );
        let mut visited = 0;
        let result = try_for_each_leaf(&scene.root, &DMat4::IDENTITY, &mut |leaf| {
            visited += 1;
            match leaf.shape() {
                Shape::Sphere { radius, .. } if *radius == 2.0 => Err("second"),
                _ => Ok(()),
            }
        });
        assert_eq!((result, visited), (Err("second"), 2));
    }
}
