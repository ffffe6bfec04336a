//! The precision contract of the kernel's solid textures (`shaders/texture.wgsl`): where
//! f32 texture coordinates are too large for the blend to be faithful, the GPU refuses.
//!
//! The kernel computes a texture point `q = M · p` in f32 from the camera-relative hit p
//! (the host composes `M`, the texture's Transform after the move back from the camera, in
//! f64). Each component is a sum of four products, so it is off by at most about four
//! roundings of the largest term, `2⁻²² · Q` with `Q` the largest `Σⱼ |Mᵢⱼ| |pⱼ| + |tᵢ|`
//! over the points the texture is worn at (the box of each primitive wearing it; a plane
//! seen by an orthographic camera, the box of where the view's corners meet it; a plane in
//! perspective reaches the horizon and has no bound). How much a misplaced point moves the
//! first material's share depends on the texture:
//!
//! - Noise: `N = Σ_{k<octaves} noise(2ᵏ q)/2ᵏ` changes by at most [`NOISE_SLOPE`] per unit
//!   of each octave's own scale, and octave k sees the error `2ᵏ` times larger, so up to
//!   `NOISE_SLOPE · octaves` per unit of q (an octave beyond f32's fraction bits, which
//!   the f32 sum loses, is within that bound too: its term is below `2⁻ᵏ`);
//! - Marble and Wood: half of `|frequency| + |amplitude| · NOISE_SLOPE · octaves` (the
//!   band `(1 + sin)/2` has slope ½, and `√(x² + z²)` changes at most as fast as q);
//! - Checkerboard: a step, so any error flips the pixels whose hit lies that close to a
//!   cell face; the contract places faces to `2⁻¹³` of a cell, a rate of [`CHECKER_RATE`],
//!   so that at most about `6 · 2⁻¹³` ≈ 0.07 % of hits (three axes, either side of a face)
//!   can flip, within the 0.1 % contract.
//!
//! The GPU renders a texture when `2⁻²² · Q · rate ≤ 2⁻⁸` (one 8-bit level of share), that
//! is `Q ≤` [`reach`] `= MAX_SPREAD / rate`. Two checks hold it:
//!
//! - before the render, over the box of each bounded primitive wearing it ([`check`]): a
//!   texture beyond its reach there is refused (`auto` falls back to the reference),
//!   located at the texture's block;
//! - during the render, for every point the kernel blends (`check_reach` in
//!   `shaders/texture.wgsl`): a plane reaches the horizon, and reflected and refracted
//!   rays meet it anywhere, so its hits are checked one by one, and a pixel with a point
//!   beyond reach is handed over to the reference ([`super::layout::Handover`]). The hit
//!   point itself is off by a few ulps of its magnitudes (the f32 ray's direction, the
//!   division that finds t), and a ray meeting the surface at a cosine c stretches that
//!   along the surface by 1/c, so the kernel holds `Q ≤ c · reach` there: `p` is no
//!   better placed than `2⁻²² · |p| / c`. Observed at a plane met at c ≈ 10⁻³, the
//!   depth was off by 2⁻¹⁵·⁵ of itself, about 2⁻²⁵ / c: within this bound by about 10.
//!   Before the render a bounded primitive's box is checked at c = 1.

use super::precision_error::{show, Limit, PrecisionError};
use crate::render::RenderOptions;
use crate::scene::{try_for_each_leaf, Bounds, Leaf, Scene, Shape, Texture, TextureKind};
use glam::{DMat4, DVec3};

/// `Q · rate` at most: `2⁻²² · Q · rate ≤ 2⁻⁸`.
pub const MAX_SPREAD: f64 = 16384.0;

/// A bound on how fast Perlin's improved noise changes per unit along any direction (∞-norm
/// of the step): per axis, the fade weights' derivatives (at most 2 · 1.875 in all) times a
/// corner's value (|g · d| ≤ √2 · √3), plus the weights times a gradient component (≤ 1),
/// about 10.2, times 3 axes, rounded up to a power of two.
pub const NOISE_SLOPE: f64 = 32.0;

/// The checkerboard's rate: faces placed to `2⁻¹³` of a cell (Q ≤ 2⁹), `MAX_SPREAD / 2⁹`.
pub const CHECKER_RATE: f64 = 32.0;

/// Whether every texture of `scene` is worn by bounded primitives only where f32 places
/// its points faithfully (see the module's contract); the first texture that is not, in
/// file order of the primitives wearing it, otherwise. Planes the kernel checks hit by hit.
pub fn check(scene: &Scene, options: &RenderOptions) -> Result<(), PrecisionError> {
    // The voxel picture (-visualize_grid) shades cells, never a material.
    if !scene.has_textures() || options.visualize_grid {
        return Ok(());
    }
    let to_camera = DMat4::from_translation(-scene.camera.center);
    try_for_each_leaf(&scene.root, &to_camera, &mut |leaf| {
        let material = leaf_material(leaf.shape());
        match camera_relative_box(leaf) {
            Some(worn) if scene.texture(material).is_some() => check_material(scene, material, &worn),
            _ => Ok(()),
        }
    })
}

/// `Q` at most for `texture`: `MAX_SPREAD / rate` (infinite for a rate of 0).
pub fn reach(texture: &Texture) -> f64 {
    MAX_SPREAD / change_rate(texture)
}

/// Material `index` and every texture it blends, worn over `worn`.
fn check_material(scene: &Scene, index: u32, worn: &Bounds) -> Result<(), PrecisionError> {
    let Some(texture) = scene.texture(index) else { return Ok(()) };
    let rate = change_rate(texture);
    let magnitude = coordinate_magnitude(texture, scene.camera.center, worn);
    let spread = magnitude * rate;
    if rate > 0.0 && (spread.is_nan() || spread > MAX_SPREAD) {
        return Err(PrecisionError {
            file: scene.path.clone(),
            location: scene.material_locations.get(index as usize).copied(),
            what: format!("the texture coordinates of material {index}, a {}", texture.kind.keyword()),
            magnitude,
            limit: Limit::Range,
            range: format!(
                "up to {} for this texture, whose blend changes by up to {} per unit of texture space: \
                 f32 places its points to 2^-22 of their magnitude",
                show(MAX_SPREAD / rate),
                show(rate)
            ),
        });
    }
    texture.materials.iter().try_for_each(|&m| check_material(scene, m, worn))
}

/// How many samples' checkerboard parities one output pixel averages under `sampling`: its
/// own and those of the pixels within the filter's support. Each may flip on its own, so
/// the contract's 0.07 % of hits becomes up to that many times more pixels: under sampling
/// a checkerboard's reach is divided by it (scene7_02's huge checkered triangles with 16
/// samples and a tent of radius 1.5 had 37 to 61 of 32 400 pixels off at the single-sample
/// reach, over the contract).
pub fn checker_samples_per_pixel(sampling: &crate::sampling::Sampling) -> u32 {
    let side = 2 * sampling.radius() + 1;
    sampling.count() * side * side
}

/// How fast the first material's share can change per unit of texture space (see the
/// module's contract).
pub fn change_rate(texture: &Texture) -> f64 {
    let noise = NOISE_SLOPE * texture.octaves as f64;
    match texture.kind {
        TextureKind::Checkerboard => CHECKER_RATE,
        TextureKind::Noise => noise,
        TextureKind::Marble | TextureKind::Wood => (texture.frequency.abs() + texture.amplitude.abs() * noise) / 2.0,
    }
}

/// `Q`: the largest `Σⱼ |Mᵢⱼ| |pⱼ| + |tᵢ|` over the camera-relative box `worn`, with `M`
/// the kernel's map from camera-relative space to texture space.
pub fn coordinate_magnitude(texture: &Texture, camera: DVec3, worn: &Bounds) -> f64 {
    let map = texture.to_texture * DMat4::from_translation(camera);
    let reach = worn.min.abs().max(worn.max.abs());
    (0..3).map(|i| map.row(i).truncate().abs().dot(reach) + map.row(i).w.abs()).fold(0.0, f64::max)
}

fn leaf_material(shape: &Shape) -> u32 {
    match shape {
        Shape::Sphere { material, .. }
        | Shape::Plane { material, .. }
        | Shape::Triangle { material, .. }
        | Shape::Mesh { material, .. } => *material,
        Shape::Group(_) | Shape::Transform { .. } => unreachable!("a walk's leaf is a primitive"),
    }
}

/// The camera-relative box of the primitive's points a ray can hit, `None` for a plane,
/// which has none.
fn camera_relative_box(leaf: &Leaf) -> Option<Bounds> {
    let to_world = leaf.to_world;
    match leaf.shape() {
        Shape::Sphere { center, radius, .. } => Some(Bounds::ellipsoid(
            &(to_world * DMat4::from_translation(*center) * DMat4::from_scale(DVec3::splat(*radius))),
        )),
        Shape::Triangle { vertices, .. } => Some(Bounds::of_points(vertices.map(|v| to_world.transform_point3(v)))),
        Shape::Mesh { mesh, .. } => {
            Some(Bounds::of_points(mesh.positions.iter().map(|&v| to_world.transform_point3(v))))
        }
        Shape::Plane { .. } | Shape::Group(_) | Shape::Transform { .. } => None,
    }
}
