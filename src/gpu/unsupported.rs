//! What the kernel renders, stated and enforced: the GPU refuses a scene or a render whose
//! image its kernel would not finish faithfully, rather than return an image with rays
//! left out (docs/SPEC.md §6). It shades all of docs/SPEC.md §5 (Phong, point lights,
//! shadows, reflection and refraction, solid textures, whose materials each spawn their
//! own rays); what it refuses is a ray tree larger than its stack holds
//! ([`TREE_STACK`](super::ray_tree::TREE_STACK) slots: 15 bounces that a path's weight can
//! still reach, fewer where a texture blends several mirrors or glasses, [`super::ray_tree`]).
//! A driver that cuts long loops short (lavapipe, docs/lavapipe.md) is no reason to refuse:
//! the kernel marks the pixels it cut, and the reference renders them
//! ([`super::PreparedScene`]).
//!
//! The course's assignments 5 and 6 it renders too (docs/SPEC.md §7): `-grid` it walks
//! like the reference, `-visualize_grid` it draws from the reference's occupancy
//! ([`super::voxels`]), and `-stats` it counts in the kernel when asked (shaders/stats.wgsl).
//!
//! The flags that shape only the course's OpenGL preview (`-gui`, `-tessellation`,
//! `-gouraud`) change no pixel of the files, so the kernel honours them by ignoring them.

use super::ray_tree::RenderRays;
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
        super::precision_error::write_place(f, &self.file, self.location)?;
        write!(f, ": {}", self.what)
    }
}

impl std::error::Error for UnsupportedError {}

/// The rays a render of `scene` at `options` traces, or why the kernel's stack cannot hold
/// its ray tree.
pub fn check(scene: &Scene, options: &RenderOptions) -> Result<RenderRays, UnsupportedError> {
    let rays = RenderRays::new(scene, options);
    let shape = rays.tree;
    if !shape.fits_stack() {
        return Err(UnsupportedError {
            file: scene.path.clone(),
            location: None,
            what: format!(
                "-bounces {}: reflected and refracted rays can go {} deep here, and the GPU kernel traces at most {}{} \
                 (a larger -weight stops them sooner)",
                options.shading.bounces,
                shape.depth,
                shape.deepest(),
                if shape.spawned > 2 {
                    format!(" where a hit spawns {} rays (a solid texture's materials each spawn their own)", shape.spawned)
                } else {
                    String::new()
                }
            ),
        });
    }
    Ok(rays)
}
