//! What the kernel renders, stated and enforced: the GPU refuses a scene or a render whose
//! image its kernel would not finish faithfully, rather than return an image with rays
//! left out (docs/SPEC.md §6). It shades all of docs/SPEC.md §5 (Phong, point lights,
//! shadows, reflection and refraction, solid textures); what it refuses is a texture that
//! blends a reflective or transparent material under `-bounces` (its rays are not traced
//! yet), and a ray tree deeper than its stack holds ([`TREE_STACK`](super::tree::TREE_STACK) − 1 bounces that a path's weight
//! can still reach, [`super::tree`]). A driver that cuts long loops short (lavapipe,
//! docs/lavapipe.md) is no reason to refuse: the kernel marks the pixels it cut, and the
//! reference renders them ([`super::PreparedScene`]).
//!
//! `-visualize_grid` and `-stats` (the course's assignments 5 and 6) it refuses for now:
//! the reference renders them (docs/SPEC.md §7). `-grid` it walks like the reference.
//!
//! The flags that shape only the course's OpenGL preview (`-gui`, `-tessellation`,
//! `-gouraud`) change no pixel of the files, so the kernel honours them by ignoring them.

use super::tree::{TreeShape, TREE_STACK};
use crate::render::RenderOptions;
use crate::scene::{Location, Scene, Texture};
use glam::DVec3;
use std::fmt;
use std::path::PathBuf;

/// A scene or render the kernel does not render faithfully, and where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct UnsupportedError {
    pub file: PathBuf,
    /// `None` where no one place of the file causes it.
    pub location: Option<Location>,
    /// What it is and why, e.g. `-bounces 20: …`.
    pub what: String,
}

impl fmt::Display for UnsupportedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        super::precision_error::write_place(f, &self.file, self.location)?;
        write!(f, ": {}", self.what)
    }
}

impl std::error::Error for UnsupportedError {}

/// The shape of the kernel's ray tree for `scene` at `options`, or why its stack cannot
/// hold it, or the course's flag it does not implement yet ([`voxels_or_stats`]).
pub fn check(scene: &Scene, options: &RenderOptions) -> Result<TreeShape, UnsupportedError> {
    if let Some(what) = voxels_or_stats(options) {
        return Err(UnsupportedError { file: scene.path.clone(), location: None, what });
    }

    refuse_texture_rays(scene, options)?;
    let shape = TreeShape::new(scene, &options.shading);
    if !shape.fits_stack() {
        return Err(UnsupportedError {
            file: scene.path.clone(),
            location: None,
            what: format!(
                "-bounces {}: reflected and refracted rays can go {} deep here, and the GPU kernel \
                 traces at most {} (a larger -weight stops them sooner)",
                options.shading.bounces,
                shape.depth,
                TREE_STACK - 1
            ),
        });
    }
    Ok(shape)
}

/// Why the kernel refuses the course's `-visualize_grid` and `-stats`, the first one given:
/// it draws no voxels and counts nothing yet. (`-grid` itself it walks: shaders/grid.wgsl.)
fn voxels_or_stats(options: &RenderOptions) -> Option<String> {
    if options.visualize_grid {
        return Some("-visualize_grid: the GPU kernel does not draw the grid's cells yet".into());
    }
    options.stats.then(|| "-stats: the GPU kernel does not count rays, tests or cells yet".into())
}

/// The first solid texture that blends a material which reflects or refracts, with
/// `-bounces` above 0, refused: the kernel shades a texture's materials where the ray hits
/// (shaders/shading.wgsl) but spawns its reflected and refracted rays from the material
/// alone, so they would be left out. First in [`check`]: [`TreeShape`] reads a texture's
/// stand-in, which reflects nothing for every texture this lets through.
fn refuse_texture_rays(scene: &Scene, options: &RenderOptions) -> Result<(), UnsupportedError> {
    if options.shading.bounces == 0 {
        return Ok(());
    }
    for (index, texture) in scene.textures.iter().enumerate() {
        let Some(texture) = texture else { continue };
        if let Some(leaf) = phong_leaves(scene, texture).into_iter().find(|&m| {
            let material = &scene.materials[m as usize];
            material.reflective != DVec3::ZERO || material.transparent != DVec3::ZERO
        }) {
            return Err(UnsupportedError {
                file: scene.path.clone(),
                location: scene.material_locations.get(index).copied(),
                what: format!(
                    "material {index}, a {} solid texture, blends material {leaf}, which reflects or \
                     refracts: the GPU kernel does not trace a texture's reflected and refracted rays yet",
                    texture.kind.keyword()
                ),
            });
        }
    }
    Ok(())
}

/// The Phong materials `texture` blends, through nested textures.
fn phong_leaves(scene: &Scene, texture: &Texture) -> Vec<u32> {
    texture
        .materials
        .iter()
        .flat_map(|&m| match scene.texture(m) {
            Some(inner) => phong_leaves(scene, inner),
            None => vec![m],
        })
        .collect()
}
