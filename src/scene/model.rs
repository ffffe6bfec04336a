//! The parsed scene: a typed tree that mirrors the scene file (SPEC §2), in f64.
//!
//! Both backends start from this model: the CPU reference walks it as it is, the GPU
//! backend flattens it into buffers. Nodes keep the place in the file they came from, so
//! later stages can still point at the source when they reject something.

use glam::{DMat4, DVec3};
use std::path::PathBuf;
use std::sync::Arc;

/// A position in a source file (1-based line and column, columns counted in characters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Location {
    pub line: u32,
    pub col: u32,
}

/// The whole scene file.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file the scene was read from (for messages and for resolving `obj_file`).
    pub path: PathBuf,
    pub camera: Camera,
    pub lights: Vec<DirectionalLight>,
    pub background: Background,
    pub materials: Vec<Material>,
    /// The top-level `Group`.
    pub root: Vec<Object>,
    /// Non-fatal remarks made while reading (no lights, PhongMaterial terms ignored, ...).
    pub warnings: Vec<String>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// `size`: the width of the view (world units) across the longer image side.
    Orthographic { size: f64 },
    /// `angle`: the full field of view across the longer image side, in radians.
    Perspective { angle: f64 },
}

/// A camera as written in the file. `direction` and `up` are stored as given; the
/// normalisation and Gram–Schmidt of SPEC §3 happen in [`Camera::basis`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub projection: Projection,
    pub center: DVec3,
    pub direction: DVec3,
    pub up: DVec3,
    pub location: Location,
}

/// The orthonormal frame of a camera (SPEC §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    pub direction: DVec3,
    pub up: DVec3,
    pub horizontal: DVec3,
}

impl Camera {
    /// `direction` normalised, `up` made orthogonal to it and normalised,
    /// `horizontal = direction × up`. `None` when `up` is parallel to `direction`
    /// (or either is zero); the parser rejects such cameras.
    pub fn basis(&self) -> Option<CameraBasis> {
        let direction = self.direction.try_normalize()?;
        let up = (self.up - self.up.dot(direction) * direction).try_normalize()?;
        // A tiny residue of up after Gram–Schmidt means up ∥ direction.
        if self.up.length() == 0.0 || self.up.cross(direction).length() <= 1e-12 * self.up.length() {
            return None;
        }
        Some(CameraBasis { direction, up, horizontal: direction.cross(up) })
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// The direction light travels in (as written; not normalised).
    pub direction: DVec3,
    pub color: DVec3,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Background {
    pub color: DVec3,
    pub ambient: DVec3,
}

impl Default for Background {
    fn default() -> Self {
        Background { color: DVec3::splat(0.5), ambient: DVec3::ZERO }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub diffuse: DVec3,
}

/// One node of the object tree with the place it was written.
#[derive(Clone, Debug)]
pub struct Object {
    pub shape: Shape,
    pub location: Location,
    /// Where a leaf's fields were written (their names), for later stages that reject a
    /// value the parser accepted: `center`, `radius` of a Sphere; `normal`, `offset` of a
    /// Plane; `vertex0`…`vertex2` of a Triangle. `Location::default()` (line 0) elsewhere.
    pub fields: [Location; 3],
}

/// What a node is. Leaves carry the index of the material that was current when they
/// were read (SPEC §2: `MaterialIndex` scopes by file order, not by hierarchy).
#[derive(Clone, Debug)]
pub enum Shape {
    Group(Vec<Object>),
    Sphere {
        center: DVec3,
        radius: f64,
        material: u32,
    },
    /// `normal` as written (not normalised; the parser rejects a zero normal).
    Plane {
        normal: DVec3,
        offset: f64,
        material: u32,
    },
    Triangle {
        vertices: [DVec3; 3],
        material: u32,
    },
    Mesh {
        mesh: Arc<Mesh>,
        material: u32,
    },
    /// `matrix` maps the child's points to the parent's: `p_parent = matrix · p_child`.
    /// Always invertible (the parser rejects singular transforms).
    Transform {
        matrix: DMat4,
        child: Box<Object>,
    },
}

/// A triangle mesh read from an OBJ file.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub path: PathBuf,
    pub positions: Vec<DVec3>,
    /// Triangles as indices into `positions` (fans already triangulated).
    pub triangles: Vec<[u32; 3]>,
    /// Where each position was read in `path` (its `v`), so that later stages can point at
    /// a vertex they reject; empty for generated meshes.
    pub vertex_locations: Vec<Location>,
}

impl Mesh {
    pub fn triangle(&self, i: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }
}

/// How many primitives of each kind a scene holds (mesh triangles counted one by one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrimitiveCounts {
    pub spheres: usize,
    pub planes: usize,
    pub triangles: usize,
}

impl PrimitiveCounts {
    pub fn total(&self) -> usize {
        self.spheres + self.planes + self.triangles
    }
}

impl Scene {
    pub fn primitive_counts(&self) -> PrimitiveCounts {
        let mut counts = PrimitiveCounts::default();
        let mut pending: Vec<&Object> = self.root.iter().collect();
        while let Some(object) = pending.pop() {
            match &object.shape {
                Shape::Group(children) => pending.extend(children),
                Shape::Transform { child, .. } => pending.push(child),
                Shape::Sphere { .. } => counts.spheres += 1,
                Shape::Plane { .. } => counts.planes += 1,
                Shape::Triangle { .. } => counts.triangles += 1,
                Shape::Mesh { mesh, .. } => counts.triangles += mesh.triangles.len(),
            }
        }
        counts
    }
}
