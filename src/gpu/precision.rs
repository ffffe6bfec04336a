//! Single precision, stated and enforced: whether the f32 kernel can render a scene
//! faithfully, decided on the host (in f64) before the scene is flattened.
//!
//! # The contract
//!
//! The kernel rounds every input to f32 and works on camera-relative values (the host moves
//! the camera to the origin first, [`super::flatten`]). Rounding to f32 costs a relative
//! 2⁻²⁴ per operation, which the accuracy tests measure; what it cannot absorb is leaving
//! f32's range. A value beyond f32's largest (≈ 2¹²⁸), or a product the kernel forms that
//! overflows, becomes infinity or NaN; one that underflows becomes subnormal or zero
//! (WGSL allows flushing subnormals). Either gives wrong pixels without a word. So the
//! host checks, per scene and per render, that every magnitude the kernel receives is
//!
//! ```text
//! exactly 0, or within [2⁻²⁵, 2²⁸] ≈ [3.0e-8, 2.7e8]
//! ```
//!
//! and otherwise refuses with the place of the offending value ([`check`]): the field as
//! written (`radius`, `vertex1`, …), the innermost Transform when it is what scaled a
//! radius out of range, the `v` line of a mesh vertex in its OBJ file, the camera block for
//! its extent.
//!
//! The bound does not depend on the exact intersection formulas, only on their degree: the
//! kernel forms products of at most four such values (degree ≤ 3 in coordinates for any
//! ray/triangle test: determinants, edge functions, Cramer's rule, edge planes through the
//! eye; degree 2 for spheres; for ellipsoids `a·Δ` multiplies two matrix entries by two
//! unit-space coordinates), each factor a sum or difference of a few values, summed over a
//! few terms.
//!
//! - Overflow: a factor is at most 4·2²⁸ (a difference of two values, doubled once more by
//!   the watertight test's shear), so a product of four is below 2¹²⁰ and sums of up to
//!   2⁷ of them stay below f32's largest value: no infinity, no NaN.
//! - Underflow: a product of four values is at least 2⁻¹⁰⁰, whose rounding error 2⁻¹²⁴
//!   is still above the smallest normal f32, 2⁻¹²⁶. Flushing a subnormal result (from
//!   cancellation) to zero then changes nothing by more than rounding already does.
//!
//! The magnitudes checked, all camera-relative and after transforms: positions (sphere
//! centres, triangle and mesh vertices) by their largest component, sphere radii, plane
//! offsets (the plane's distance from the camera), the camera's extent (orthographic
//! `size`, perspective `1/tan(angle/2)`) and, for a sphere under a non-uniform transform,
//! its centre, its half-extents, the largest entry of the world-to-unit-sphere matrix and
//! the camera's position in the unit sphere's space (the matrix's entries are about
//! 1/size, so such a sphere must be between about 2⁻²⁸ and 2²⁵ large), and each
//! material's index of refraction (a ratio of two bends every refracted ray). A component far
//! below the largest of its vector is absorbed by rounding in every sum it enters, so its
//! own underflow does not matter; unit vectors (ray and light directions, plane normals,
//! the camera basis) are normalised in f64 and always in range. Colours (light, ambient,
//! diffuse, specular, reflective, transparent, background), a point light's position from
//! the camera and attenuation, and the specular exponent need only the upper bound: a
//! colour product of up to three factors stays finite, a colour factor small enough to
//! underflow makes a term far below one 8-bit level, and a light's distance is a
//! difference of positions.
//!
//! # Resolution
//!
//! In range is not enough: f32 places a point only to within about 2⁻²⁴ of the magnitudes it
//! was computed from, and the kernel must still tell neighbouring pixels apart. Everything
//! is camera-relative, so the error at a primitive is about 2⁻²⁴·M for M its distance from
//! the camera, and what matters is the ratio R of that distance to a pixel's footprint
//! there:
//!
//! - perspective: a pixel spans d·2/(W·D) at distance d (W the longer image side, D =
//!   1/tan(angle/2)), so R = W·D/2 wherever the primitive is (and the ray directions
//!   themselves differ by 2/(W·D) relative from pixel to pixel);
//! - orthographic: a pixel spans size/W everywhere, so R = M·W/size, with M the largest
//!   camera-relative magnitude of a sphere or triangle point (or of the rays' origins).
//!
//! Past a bound on R the refusal is [`Limit::Resolution`]. The bounds are measured
//! (`raycaster compare` at 200², pixels more than 1 level off the reference, same framing
//! at each R): a bunny of 1000 triangles, perspective and orthographic alike, has 0 at 2¹⁸,
//! 19–20 at 2¹⁹ and 226 at 2²⁰ (past the 0.1 % contract: its shared edges decide which
//! normal a pixel shows); a sphere has 0 up to 2²³ and 65 at 2²⁴. So a scene with triangles
//! may reach R = 2¹⁷ ([`MAX_RESOLUTION_TRIANGLES`]), one of spheres and planes 2²¹
//! ([`MAX_RESOLUTION_SMOOTH`]), each 8 times below the first failure. Planes have no edge to
//! misplace and do not count towards M.
//!
//! # Normals
//!
//! A hit point is off by about 2⁻²⁴·M wherever the pixels are, and a normal computed from it
//! (or from f32 vertices) is off by that over the primitive's size: whole levels of the
//! normal's image for a small primitive far away, at any R. Measured at 100², 150 spheres
//! of radius r at distance M ≈ 1000 in perspective, pixels more than 1 level off the
//! reference: 0 up to M/r = 2¹⁵ in both the normal and the lit colour images, 33 and 18 at
//! 2¹⁶, 128 and 64 at 2¹⁷. So a sphere may be at most 2¹³ of its radii from the camera
//! ([`MAX_DISTANCE_OVER_RADIUS`], 8 times below the first failure; [`Limit::SphereSize`]).
//! Triangles carry their normal from the host's f64 vertices instead
//! ([`super::layout::GpuTriangle`]): bunny_40k seen at R = 2¹⁷ had 526 of 40 000 normal
//! pixels off when the kernel crossed its f32 edges, and has none since.

use crate::camera::PrimaryRays;
use crate::render::RenderOptions;
use crate::scene::{try_for_each_leaf, Light, Location, Mesh, Object, Scene, Shape};
use glam::{DMat3, DMat4, DVec3};
use std::path::Path;

pub use super::precision_error::{Limit, PrecisionError, RANGE};

/// The smallest non-zero magnitude the f32 kernel renders faithfully: 2⁻²⁵.
pub const MIN_MAGNITUDE: f64 = 1.0 / 33_554_432.0;
/// The largest magnitude the f32 kernel renders faithfully: 2²⁸.
pub const MAX_MAGNITUDE: f64 = 268_435_456.0;

/// The largest ratio R of the scene's distance from the camera to a pixel's footprint there
/// that the f32 kernel resolves in a scene with triangles: 2¹⁷ (see the module's contract).
pub const MAX_RESOLUTION_TRIANGLES: f64 = 131_072.0;
/// The same for a scene of spheres and planes only: 2¹⁹.
pub const MAX_RESOLUTION_SMOOTH: f64 = 524_288.0;

/// The largest ratio of a sphere's distance from the camera (its farthest point's largest
/// camera-relative coordinate) to its radius at which the kernel's normals stay within a
/// level: 2¹³ (see the module's contract). Ellipsoids (spheres under a non-similarity)
/// compute theirs in the unit sphere's space and are not bounded by it: a sphere squashed
/// 10⁴ times, 10⁵ of its shortest half-axes away, keeps its normals
/// (scenes/hard/squashed_sphere.txt).
pub const MAX_DISTANCE_OVER_RADIUS: f64 = 8192.0;

/// Whether the f32 kernel renders `scene` at `options` faithfully (see the module's
/// contract); the first offending value in file order otherwise.
pub fn check(scene: &Scene, options: &RenderOptions) -> Result<(), PrecisionError> {
    let checker = Checker {
        scene: &scene.path,
        farthest: std::cell::Cell::new(0.0),
        triangles: std::cell::Cell::new(false),
        smallest_sphere: std::cell::Cell::new(None),
    };
    let rays = PrimaryRays::for_camera(&scene.camera, options.width, options.height);
    // Orthographic: `horizontal` is the basis vector times `size`; perspective: the
    // direction is scaled by D = 1/tan(angle/2) and the extent is fixed (2).
    let (what, extent) = if rays.orthographic {
        ("OrthographicCamera size", rays.horizontal.length())
    } else {
        ("PerspectiveCamera 1/tan(angle/2)", rays.direction.length())
    };
    checker.scalar(Some(scene.camera.location), what, extent)?;
    for (k, light) in scene.lights.iter().enumerate() {
        match light {
            Light::Directional(light) => checker.colour(&format!("DirectionalLight {} color", k + 1), light.color)?,
            Light::Point(light) => {
                let at = Some(light.location);
                checker.bounded(at, &format!("PointLight {} color", k + 1), max_norm(light.color))?;
                // Only its distance to points matters, a difference: no lower bound.
                let position = max_norm(light.position - scene.camera.center);
                checker.bounded(at, &format!("PointLight {} position from the camera", k + 1), position)?;
                checker.bounded(at, &format!("PointLight {} attenuation", k + 1), max_norm(light.attenuation))?;
            }
        }
    }
    checker.colour("Background color", scene.background.color)?;
    checker.colour("Background ambientLight", scene.background.ambient)?;
    for (k, material) in scene.materials.iter().enumerate() {
        let at = scene.material_locations.get(k).copied();
        checker.colour(&format!("Material {} diffuseColor", k), material.diffuse)?;
        for (name, colour) in [
            ("specularColor", material.specular),
            ("reflectiveColor", material.reflective),
            ("transparentColor", material.transparent),
        ] {
            checker.bounded(at, &format!("Material {k} {name}"), max_norm(colour))?;
        }
        checker.bounded(at, &format!("Material {k} exponent"), material.exponent.abs())?;
        // A ratio of indices bends every refracted ray: both ends of the range matter.
        checker.scalar(at, &format!("Material {k} indexOfRefraction"), material.index_of_refraction)?;
    }
    checker.objects(&scene.root, &DMat4::from_translation(-scene.camera.center))?;
    let resolution = rays.resolution(checker.farthest.get());
    let triangles = checker.triangles.get();
    if resolution <= if triangles { MAX_RESOLUTION_TRIANGLES } else { MAX_RESOLUTION_SMOOTH } {
        // The camera's resolution first: it is written before any sphere.
        if let Some((ratio, location)) = checker.smallest_sphere.get().filter(|s| s.0 > MAX_DISTANCE_OVER_RADIUS) {
            return Err(PrecisionError {
                file: scene.path.clone(),
                location: Some(location),
                what: "Sphere radius".to_string(),
                magnitude: ratio,
                range: String::new(),
                limit: Limit::SphereSize,
            });
        }
        return super::texture_range::check(scene, options);
    }
    let what = if rays.orthographic { "OrthographicCamera size" } else { "PerspectiveCamera angle" };
    Err(PrecisionError {
        file: scene.path.clone(),
        location: Some(scene.camera.location),
        what: what.to_string(),
        magnitude: resolution,
        range: String::new(),
        limit: Limit::Resolution { triangles },
    })
}

struct Checker<'a> {
    scene: &'a Path,
    /// The largest camera-relative magnitude of any point of a sphere or triangle seen so
    /// far (planes have no place: their hits carry no edge to misplace).
    farthest: std::cell::Cell<f64>,
    /// Whether any triangle was seen: the edges a mesh's triangles share decide which
    /// normal a pixel shows, so they need a finer resolution than silhouettes.
    triangles: std::cell::Cell<bool>,
    /// The sphere farthest from the camera for its size: distance over radius, and where its
    /// radius (or the Transform that scaled it) was written.
    smallest_sphere: std::cell::Cell<Option<(f64, Location)>>,
}

fn in_range(magnitude: f64) -> bool {
    magnitude == 0.0 || (MIN_MAGNITUDE..=MAX_MAGNITUDE).contains(&magnitude)
}

/// The largest absolute component (NaN propagates, so that it is refused).
fn max_norm(v: DVec3) -> f64 {
    if v.is_nan() {
        f64::NAN
    } else {
        v.abs().max_element()
    }
}

impl Checker<'_> {
    fn error(&self, location: Option<Location>, what: &str, magnitude: f64) -> PrecisionError {
        PrecisionError {
            file: self.scene.to_path_buf(),
            location,
            what: what.to_string(),
            magnitude,
            range: RANGE.to_string(),
            limit: Limit::Range,
        }
    }

    /// Notes a sphere's distance from the camera over its radius, for its normals.
    fn sphere_size(&self, distance: f64, radius: f64, location: Location) {
        let ratio = distance / radius;
        if self.smallest_sphere.get().is_none_or(|(largest, _)| ratio > largest) {
            self.smallest_sphere.set(Some((ratio, location)));
        }
    }

    /// Notes a point's camera-relative magnitude, for the resolution.
    fn reaches(&self, magnitude: f64) {
        self.farthest.set(self.farthest.get().max(magnitude));
    }

    fn scalar(&self, location: Option<Location>, what: &str, value: f64) -> Result<(), PrecisionError> {
        let magnitude = value.abs();
        if in_range(magnitude) {
            Ok(())
        } else {
            Err(self.error(location, what, magnitude))
        }
    }

    fn vector(&self, location: Location, what: &str, v: DVec3) -> Result<(), PrecisionError> {
        self.scalar(Some(location), what, max_norm(v))
    }

    fn colour(&self, what: &str, colour: DVec3) -> Result<(), PrecisionError> {
        self.bounded(None, what, max_norm(colour))
    }

    /// A value that needs only the upper bound (see the module's contract).
    fn bounded(&self, location: Option<Location>, what: &str, magnitude: f64) -> Result<(), PrecisionError> {
        if magnitude <= MAX_MAGNITUDE {
            Ok(())
        } else {
            Err(self.error(location, what, magnitude))
        }
    }

    /// Every primitive, with `leaf.to_world` mapping its object space to camera-relative
    /// world space as in [`super::flatten`], in file order.
    fn objects(&self, objects: &[Object], to_camera: &DMat4) -> Result<(), PrecisionError> {
        try_for_each_leaf(objects, to_camera, &mut |leaf| {
            let (object, matrix, transform) = (leaf.object, &leaf.to_world, leaf.transform);
            // A field's own place where the parser kept it, else the object's.
            let field = |k: usize| Some(object.fields[k]).filter(|l| l.line != 0).unwrap_or(object.location);
            match &object.shape {
                Shape::Sphere { center, radius, .. } => {
                    // A radius fine in itself is made out of range by the transform around it.
                    let scaled_by = if in_range(*radius) { transform.unwrap_or(field(1)) } else { field(1) };
                    self.sphere([field(0), field(1), scaled_by], matrix, *center, *radius)
                }
                Shape::Plane { normal, offset, .. } => {
                    let n = normal.normalize();
                    let world_normal = DMat3::from_mat4(*matrix).inverse().transpose().mul_vec3(n).normalize();
                    self.vector(field(0), "Plane normal", world_normal)?;
                    let offset = world_normal.dot(matrix.transform_point3(*offset * n));
                    self.scalar(Some(field(1)), "Plane offset from the camera", offset)
                }
                Shape::Triangle { vertices, .. } => {
                    self.triangles.set(true);
                    for (k, v) in vertices.iter().enumerate() {
                        let vertex = matrix.transform_point3(*v);
                        self.reaches(max_norm(vertex));
                        self.vector(field(k), &format!("Triangle vertex{k}"), vertex)?;
                    }
                    Ok(())
                }
                Shape::Mesh { mesh, .. } => {
                    self.triangles.set(true);
                    self.mesh(object.location, matrix, mesh)
                }
                Shape::Group(_) | Shape::Transform { .. } => Ok(()),
            }
        })
    }

    /// The same cases as the flattening: a sphere under a similarity stays a sphere, any
    /// other keeps the matrix to the unit sphere's space. `at`: where the centre and the
    /// radius were written, and what scaled the radius (the radius itself or a Transform).
    fn sphere(&self, at: [Location; 3], matrix: &DMat4, center: DVec3, radius: f64) -> Result<(), PrecisionError> {
        let [center_at, radius_at, scaled_at] = at;
        let linear = DMat3::from_mat4(*matrix);
        if let Some(scale) = super::flatten::similarity_scale(&linear) {
            let (centre, world_radius) = (matrix.transform_point3(center), radius * scale);
            let farthest = max_norm(centre) + world_radius;
            self.reaches(farthest);
            self.vector(center_at, "Sphere center", centre)?;
            let at = if scale == 1.0 { radius_at } else { scaled_at };
            self.scalar(Some(at), "Sphere radius", world_radius)?;
            self.sphere_size(farthest, world_radius, at);
            return Ok(());
        }
        let to_world = *matrix * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
        let to_unit = to_world.inverse();
        self.vector(center_at, "transformed Sphere center", to_world.w_axis.truncate())?;
        let half = DVec3::from_array([0, 1, 2].map(|r| to_world.row(r).truncate().length()));
        self.reaches(max_norm(to_world.w_axis.truncate()) + max_norm(half));
        self.vector(scaled_at, "transformed Sphere half-extent", half)?;
        let entries = DMat3::from_mat4(to_unit).to_cols_array();
        let largest = entries.iter().try_fold(0.0_f64, |m, e| (!e.is_nan()).then(|| m.max(e.abs())));
        self.scalar(Some(scaled_at), "transformed Sphere inverse-matrix entry", largest.unwrap_or(f64::NAN))?;
        // The camera is the origin: its place in the unit sphere's space is to_unit · 0.
        let camera = to_unit.w_axis.truncate();
        self.vector(scaled_at, "camera position in the transformed Sphere's unit space", camera)
    }

    /// Every vertex a triangle uses (an unused one never reaches the kernel), first in file
    /// order, located in the OBJ file where the mesh knows its lines.
    fn mesh(&self, at: Location, matrix: &DMat4, mesh: &Mesh) -> Result<(), PrecisionError> {
        let mut used = vec![false; mesh.positions.len()];
        for &index in mesh.triangles.iter().flatten() {
            if let Some(u) = used.get_mut(index as usize) {
                *u = true;
            }
        }
        let vertices = mesh.positions.iter().zip(&used).enumerate().filter(|(_, (_, used))| **used);
        for (k, (position, _)) in vertices {
            let magnitude = max_norm(matrix.transform_point3(*position));
            self.reaches(magnitude);
            if in_range(magnitude) {
                continue;
            }
            return Err(match mesh.vertex_locations.get(k) {
                Some(&location) => PrecisionError {
                    file: mesh.path.clone(),
                    location: Some(location),
                    what: format!("mesh vertex {}", k + 1),
                    magnitude,
                    limit: Limit::Range,
                    range: RANGE.to_string(),
                },
                None => self.error(
                    Some(at),
                    &format!("TriangleMesh vertex {} of {}", k + 1, mesh.path.display()),
                    magnitude,
                ),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::precision_error::show;
    use super::*;

    #[test]
    fn the_bounds_are_the_stated_powers_of_two() {
        assert_eq!(MIN_MAGNITUDE, 2f64.powi(-25));
        assert_eq!(MAX_MAGNITUDE, 2f64.powi(28));
        // The overflow argument: four factors of at most 4·2²⁸, times 2⁷ terms, fit in f32.
        assert!((4.0 * MAX_MAGNITUDE).powi(4) * 128.0 < f32::MAX as f64);
        // The underflow argument: the rounding error of a product of four is a normal f32.
        assert!(MIN_MAGNITUDE.powi(4) * 2f64.powi(-24) >= f32::MIN_POSITIVE as f64);
    }

    #[test]
    fn range_and_formatting() {
        assert!(in_range(0.0) && in_range(MIN_MAGNITUDE) && in_range(MAX_MAGNITUDE) && in_range(1.0));
        assert!(!in_range(MIN_MAGNITUDE / 2.0) && !in_range(MAX_MAGNITUDE * 2.0));
        assert!(!in_range(f64::NAN) && !in_range(f64::INFINITY));
        assert!(max_norm(DVec3::new(1.0, f64::NAN, 0.0)).is_nan());
        assert_eq!(show(1e39), "1e39");
        assert_eq!(show(MAX_MAGNITUDE), "2.684e8");
        assert_eq!(show(MIN_MAGNITUDE / 2.0), "1.49e-8");
        assert_eq!(show(f64::INFINITY), "inf");
    }
}
