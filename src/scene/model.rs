//! The parsed scene: a typed tree that mirrors the scene file (docs/SPEC.md §2), in f64.
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
    /// In file order: shading sums the lights in this order (docs/SPEC.md §5).
    pub lights: Vec<Light>,
    pub background: Background,
    pub materials: Vec<Material>,
    /// Where each material was written (its `Material`/`PhongMaterial` keyword), parallel
    /// to `materials`, for later stages that refuse a term; empty for scenes not read
    /// from a file.
    pub material_locations: Vec<Location>,
    /// The solid textures (GRAMMAR.md A6), parallel to `materials`: `textures[k]` is the
    /// texture material k is, if any; empty when the scene has none. A texture's own entry
    /// in `materials` is its first material's Phong terms, the course's OpenGL stand-in
    /// (`glSetMaterial` delegates to the first material), never shaded by the reference.
    pub textures: Vec<Option<Texture>>,
    /// The objects of the top-level `Group`.
    pub root: Vec<Object>,
    /// Non-fatal remarks made while reading (no lights, ...).
    pub warnings: Vec<super::SceneWarning>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// `size`: the width of the view (world units) across the longer image side.
    Orthographic { size: f64 },
    /// `angle`: the full field of view across the longer image side, in radians.
    Perspective { angle: f64 },
}

/// A camera: the file's fields as written, and the orthonormal frame derived from them,
/// validated when the camera is made ([`Camera::new`]), so that a `Camera` always has one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub projection: Projection,
    pub center: DVec3,
    /// As written (not normalised); the renderers use [`Camera::frame`].
    pub direction: DVec3,
    /// As written (neither normalised nor orthogonalised); the renderers use [`Camera::frame`].
    pub up: DVec3,
    pub location: Location,
    /// Built from `direction` and `up` by [`Camera::new`], the only way to make a `Camera`.
    frame: CameraBasis,
}

/// The orthonormal frame of a camera (docs/SPEC.md §3): unit `direction`, unit `up`
/// orthogonal to it, `horizontal = direction × up`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    pub direction: DVec3,
    pub up: DVec3,
    pub horizontal: DVec3,
}

impl CameraBasis {
    /// `direction` normalised, `up` made orthogonal to it and normalised (Gram–Schmidt),
    /// `horizontal = direction × up`. `None` when `up` is parallel to `direction`, either
    /// is zero, or either cannot be normalised in f64 (such as `1e-200 0 0`).
    pub fn new(direction: DVec3, up: DVec3) -> Option<CameraBasis> {
        let unit_direction = direction.try_normalize()?;
        let unit_up = orthogonal_part(up, unit_direction).try_normalize()?;
        // A tiny residue of up after Gram–Schmidt means up ∥ direction.
        if up.length() == 0.0 || up.cross(unit_direction).length() <= 1e-12 * up.length() {
            return None;
        }
        Some(CameraBasis { direction: unit_direction, up: unit_up, horizontal: unit_direction.cross(unit_up) })
    }
}

/// The part of `v` orthogonal to the unit vector `d` (Gram–Schmidt). When `v` is nearly
/// parallel to `d` the subtraction cancels, and one pass leaves a remainder that is far from
/// orthogonal to `d` relative to its own length; a second pass then restores orthogonality
/// ("twice is enough"), taken only when the first shrank `v` below 1/√2 of its length (the
/// criterion of Daniel, Gragg, Kaufman and Stewart, Math. Comp. 30, 1976), so that a frame
/// whose `up` is already far from `direction` is computed exactly as one pass computes it.
fn orthogonal_part(v: DVec3, d: DVec3) -> DVec3 {
    let once = v - v.dot(d) * d;
    if once.length_squared() >= 0.5 * v.length_squared() {
        return once;
    }
    once - once.dot(d) * d
}

impl Camera {
    /// A camera with its frame; `None` when `direction` and `up` have none
    /// ([`CameraBasis::new`]). The parser reports that case as an error in the file.
    pub fn new(
        projection: Projection,
        center: DVec3,
        direction: DVec3,
        up: DVec3,
        location: Location,
    ) -> Option<Camera> {
        let frame = CameraBasis::new(direction, up)?;
        Some(Camera { projection, center, direction, up, location, frame })
    }

    /// The validated orthonormal frame (docs/SPEC.md §3), built when the camera was made.
    pub fn frame(&self) -> &CameraBasis {
        &self.frame
    }
}

/// A light of the `Lights` block (docs/SPEC.md §2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Directional(DirectionalLight),
    Point(PointLight),
}

impl Light {
    /// The light's colour as written (before any attenuation).
    pub fn color(&self) -> DVec3 {
        match self {
            Light::Directional(light) => light.color,
            Light::Point(light) => light.color,
        }
    }

    /// The directional light, if this is one.
    pub fn directional(&self) -> Option<&DirectionalLight> {
        match self {
            Light::Directional(light) => Some(light),
            Light::Point(_) => None,
        }
    }
}

/// `PointLight { position V3 color V3 attenuation a0 a1 a2 }` (GRAMMAR.md A4): light from
/// `position`, its colour divided by `a0 + a1·d + a2·d²` at distance d.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: DVec3,
    pub color: DVec3,
    /// `(a0, a1, a2)`, default (1, 0, 0): no fall-off.
    pub attenuation: DVec3,
    /// Where the `PointLight` keyword was written.
    pub location: Location,
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

/// A material as the course defines it (`PhongMaterial`, `Material` for short; docs/SPEC.md
/// §2), with the course parser's defaults for fields a file leaves out
/// ([`Material::default`]). The reference shades with the diffuse and specular terms
/// (docs/SPEC.md §5); the GPU kernel with the diffuse term only, and it refuses a scene
/// whose materials have any other term (`raycaster::gpu::unsupported`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// `diffuseColor`, default (1, 1, 1).
    pub diffuse: DVec3,
    /// `specularColor`, default (0, 0, 0).
    pub specular: DVec3,
    /// `exponent` of the Blinn–Torrance specular lobe, default 1.
    pub exponent: f64,
    /// `reflectiveColor`: the weight of the mirror ray, default (0, 0, 0).
    pub reflective: DVec3,
    /// `transparentColor`: the weight of the refracted ray, default (0, 0, 0).
    pub transparent: DVec3,
    /// `indexOfRefraction` of the material's inside, default 1.
    pub index_of_refraction: f64,
}

impl Default for Material {
    /// The course parser's defaults (`../shared/mit6837/GRAMMAR.md`, A3 and A4).
    fn default() -> Self {
        Material {
            diffuse: DVec3::ONE,
            specular: DVec3::ZERO,
            exponent: 1.0,
            reflective: DVec3::ZERO,
            transparent: DVec3::ZERO,
            index_of_refraction: 1.0,
        }
    }
}

impl Material {
    /// A material with this diffuse colour and the defaults elsewhere.
    pub fn diffuse(color: DVec3) -> Material {
        Material { diffuse: color, ..Material::default() }
    }
}

/// A solid texture (GRAMMAR.md A6, docs/SPEC.md §5): a blend of two earlier materials,
/// evaluated at the hit's world point carried into texture space by `to_texture`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texture {
    pub kind: TextureKind,
    /// World → texture space (`Transform { … }` of the block; identity when absent).
    pub to_texture: DMat4,
    /// The two `materialIndex` entries, both earlier in the list than this material.
    pub materials: [u32; 2],
    /// `octaves` of the noise sum (0 for `Checkerboard`, which has none).
    pub octaves: u32,
    /// `frequency` of Marble and Wood (0 elsewhere).
    pub frequency: f64,
    /// `amplitude` of Marble and Wood (0 elsewhere).
    pub amplitude: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureKind {
    Checkerboard,
    Noise,
    Marble,
    Wood,
}

impl TextureKind {
    /// The block's keyword in the scene file.
    pub fn keyword(self) -> &'static str {
        match self {
            TextureKind::Checkerboard => "Checkerboard",
            TextureKind::Noise => "Noise",
            TextureKind::Marble => "Marble",
            TextureKind::Wood => "Wood",
        }
    }
}

impl Scene {
    /// The texture material `index` is, if it is one.
    pub fn texture(&self, index: u32) -> Option<&Texture> {
        self.textures.get(index as usize).and_then(Option::as_ref)
    }

    /// Whether any material is a solid texture.
    pub fn has_textures(&self) -> bool {
        self.textures.iter().any(Option::is_some)
    }
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
/// were read (docs/SPEC.md §2: `MaterialIndex` scopes by file order, not by hierarchy).
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

    /// The box of the mesh's positions, in its own coordinates ([`Bounds::EMPTY`] when it
    /// has none).
    pub fn bounds(&self) -> Bounds {
        Bounds::of_points(self.positions.iter().copied())
    }
}

/// An axis-aligned box in f64, `min ≤ p ≤ max` (pbrt's `Bounds3`). Exact: no padding.
/// [`crate::bvh::Aabb`] is its f32 twin at GPU precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    /// The box that contains nothing (`min > max`), the identity of [`Bounds::union`].
    pub const EMPTY: Bounds = Bounds { min: DVec3::INFINITY, max: DVec3::NEG_INFINITY };

    /// The smallest box holding every point.
    pub fn of_points(points: impl IntoIterator<Item = DVec3>) -> Bounds {
        points.into_iter().fold(Bounds::EMPTY, |b, p| Bounds { min: b.min.min(p), max: b.max.max(p) })
    }

    /// `center ± half` (`half ≥ 0` on every axis).
    pub fn centered(center: DVec3, half: DVec3) -> Bounds {
        Bounds { min: center - half, max: center + half }
    }

    /// The box of the sphere `|p − center| = radius`.
    pub fn sphere(center: DVec3, radius: f64) -> Bounds {
        Bounds::centered(center, DVec3::splat(radius))
    }

    /// The box of the unit sphere carried by the affine map `to_world` (an ellipsoid):
    /// [`ellipsoid_extent`] as a box.
    pub fn ellipsoid(to_world: &DMat4) -> Bounds {
        let (center, half) = ellipsoid_extent(to_world);
        Bounds::centered(center, half)
    }

    pub fn union(&self, other: &Bounds) -> Bounds {
        Bounds { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Whether the box contains no point (`min > max` on some axis).
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }
}

/// The centre and the half-extent along each axis of the image of the unit sphere under the
/// affine map `to_world` (an ellipsoid). The half-extent along axis i is the length of row i
/// of the linear part: the largest `eᵢ · A·u` over unit vectors `u` is `|Aᵀ·eᵢ|`. Exact, so
/// the box touches the ellipsoid on all six sides.
pub fn ellipsoid_extent(to_world: &DMat4) -> (DVec3, DVec3) {
    let half = DVec3::from_array([0, 1, 2].map(|r| to_world.row(r).truncate().length()));
    (to_world.w_axis.truncate(), half)
}

/// How far a shape reaches: a box, or everywhere. Planes are unbounded, and so is
/// anything that contains one (a group, a transform, a scene).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Extent {
    Bounded(Bounds),
    Unbounded,
}

impl Extent {
    pub fn union(&self, other: &Extent) -> Extent {
        match (self, other) {
            (Extent::Bounded(a), Extent::Bounded(b)) => Extent::Bounded(a.union(b)),
            _ => Extent::Unbounded,
        }
    }

    /// The box, or `None` when unbounded.
    pub fn bounds(&self) -> Option<Bounds> {
        match self {
            Extent::Bounded(b) => Some(*b),
            Extent::Unbounded => None,
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_basis_is_validated_once() {
        // direction (0, 0, −2) → (0, 0, −1); up (0, 3, −1) loses its component along it,
        // (0, 3, 0) → (0, 1, 0); horizontal = direction × up = (1, 0, 0).
        let basis = CameraBasis::new(DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.0, 3.0, -1.0)).unwrap();
        assert_eq!(basis, CameraBasis { direction: -DVec3::Z, up: DVec3::Y, horizontal: DVec3::X });
        let ortho = Projection::Orthographic { size: 1.0 };
        let camera = Camera::new(
            ortho,
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, -2.0),
            DVec3::new(0.0, 3.0, -1.0),
            Location::default(),
        )
        .unwrap();
        assert_eq!(*camera.frame(), basis);
        assert_eq!(
            (camera.direction, camera.up),
            (DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.0, 3.0, -1.0)),
            "kept as written"
        );

        // Nearly parallel: one Gram–Schmidt pass leaves up 1e-6 off orthogonal here (a
        // direction 4.3e9 times longer along y than across; found by the parser's property
        // test); the second pass makes the frame orthonormal to rounding.
        let steep = CameraBasis::new(DVec3::new(-0.16, 4294967296.0, -0.5), DVec3::Y).unwrap();
        let [d, u, h] = [steep.direction, steep.up, steep.horizontal];
        for (x, y) in [(d, u), (u, h), (h, d)] {
            assert!(x.dot(y).abs() < 1e-15 && (x.length() - 1.0).abs() < 1e-15, "{steep:?}");
        }

        // Any basis that exists is orthonormal and right-handed.
        let tilted = CameraBasis::new(DVec3::new(1.0, -2.0, 0.5), DVec3::new(0.3, 1.0, 4.0)).unwrap();
        let [d, u, h] = [tilted.direction, tilted.up, tilted.horizontal];
        for (x, y) in [(d, u), (u, h), (h, d)] {
            assert!(x.dot(y).abs() < 1e-15 && (x.length() - 1.0).abs() < 1e-15);
        }
        assert!((d.cross(u) - h).length() < 1e-15);

        // No frame, no camera: up ∥ direction, a zero vector, or one f64 cannot normalise.
        for (direction, up) in [
            (DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 2.0)),
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(-3.0, -3.0, 0.0)),
            (DVec3::ZERO, DVec3::Y),
            (DVec3::Z, DVec3::ZERO),
            (DVec3::new(1e-200, 0.0, 0.0), DVec3::Y),
        ] {
            assert_eq!(CameraBasis::new(direction, up), None, "{direction} {up}");
            assert_eq!(Camera::new(ortho, DVec3::ZERO, direction, up, Location::default()), None);
        }
    }
}
