//! What the kernel renders, stated and enforced: the GPU refuses a scene or a render whose
//! image its kernel would not finish faithfully, rather than return an image with rays
//! left out (docs/SPEC.md §6). It shades all of docs/SPEC.md §5 (Phong, point lights,
//! shadows, reflection and refraction); what it refuses is the solid textures of
//! assignment 6 (`Checkerboard`, `Noise`, `Marble`, `Wood`: not in the kernel yet), and a
//! ray tree deeper than its stack holds ([`TREE_STACK`](super::tree::TREE_STACK) − 1 bounces that a path's weight
//! can still reach, [`super::tree`]). A driver that cuts long loops short (lavapipe,
//! docs/lavapipe.md) is no reason to refuse: the kernel marks the pixels it cut, and the
//! reference renders them ([`super::PreparedScene`]).
//!
//! The flags that shape only the course's OpenGL preview (`-gui`, `-tessellation`,
//! `-gouraud`) change no pixel of the files, so the kernel honours them by ignoring them.

use super::tree::{TreeShape, TREE_STACK};
use crate::render::RenderOptions;
use crate::scene::{Location, Scene};
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
        super::precision::write_place(f, &self.file, self.location)?;
        write!(f, ": {}", self.what)
    }
}

impl std::error::Error for UnsupportedError {}

/// The shape of the kernel's ray tree for `scene` at `options`, or why its stack cannot
/// hold it.
pub fn check(scene: &Scene, options: &RenderOptions) -> Result<TreeShape, UnsupportedError> {
    refuse_textures(scene)?;
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

/// The first solid texture of the scene, refused: the kernel does not evaluate textures,
/// and its buffers hold only a texture's stand-in (its first material), which would render
/// a wrong image. First in [`check`], before anything reads the materials.
fn refuse_textures(scene: &Scene) -> Result<(), UnsupportedError> {
    let Some((index, texture)) =
        scene.textures.iter().enumerate().find_map(|(k, texture)| texture.as_ref().map(|t| (k, t)))
    else {
        return Ok(());
    };
    Err(UnsupportedError {
        file: scene.path.clone(),
        location: scene.material_locations.get(index).copied(),
        what: format!(
            "material {index} is a {} solid texture, which the GPU kernel does not render yet",
            texture.kind.keyword()
        ),
    })
}
