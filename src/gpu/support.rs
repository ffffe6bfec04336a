//! What the kernel shades, stated and enforced: the GPU refuses, before the scene is
//! flattened, a scene or a render option whose shading its kernel does not implement yet,
//! rather than render an image that silently leaves a term out (docs/SPEC.md §6).
//!
//! The kernel shades docs/SPEC.md §5 with directional lights and the diffuse term only. It
//! refuses, at the first offending place in the file:
//!
//! - `-shadows` in a scene with lights (the kernel casts no shadow rays);
//! - a `PointLight` (the kernel has no light position or attenuation);
//! - a material with a non-zero `specularColor` (no specular lobe, so `--specular-fix`
//!   changes nothing in what it renders), `reflectiveColor` or `transparentColor` (no
//!   secondary rays, so `-bounces` and `-weight` change nothing in what it renders).
//!
//! The flags that shape only the course's OpenGL preview (`-gui`, `-tessellation`,
//! `-gouraud`) change no pixel of the files, so the kernel honours them by ignoring them.

use crate::render::RenderOptions;
use crate::scene::{Light, Location, Scene};
use glam::DVec3;
use std::fmt;
use std::path::PathBuf;

/// A part of a scene or render the kernel does not shade yet, and where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct UnsupportedError {
    pub file: PathBuf,
    /// `None` for a material of a scene not read from a file.
    pub location: Option<Location>,
    /// What it is, e.g. `PointLight` or `material 2: specularColor 1 1 1`.
    pub what: String,
}

impl fmt::Display for UnsupportedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        super::precision::write_place(f, &self.file, self.location)?;
        write!(f, ": {}: the GPU kernel does not shade this yet", self.what)
    }
}

impl std::error::Error for UnsupportedError {}

/// Whether the kernel shades `scene` at `options` as the reference does; the first
/// light, then the first material, it does not otherwise.
pub fn check(scene: &Scene, options: &RenderOptions) -> Result<(), UnsupportedError> {
    let refuse =
        |location: Option<Location>, what: String| UnsupportedError { file: scene.path.clone(), location, what };
    if options.shading.shadows && !scene.lights.is_empty() {
        return Err(refuse(None, "-shadows (shadow rays)".into()));
    }
    if let Some(Light::Point(light)) = scene.lights.iter().find(|l| matches!(l, Light::Point(_))) {
        return Err(refuse(Some(light.location), "PointLight".into()));
    }
    for (k, material) in scene.materials.iter().enumerate() {
        let terms = [
            ("specularColor", material.specular),
            ("reflectiveColor", material.reflective),
            ("transparentColor", material.transparent),
        ];
        if let Some((name, value)) = terms.into_iter().find(|(_, v)| *v != DVec3::ZERO) {
            let location = scene.material_locations.get(k).copied();
            return Err(refuse(location, format!("material {k}: {name} {} {} {}", value.x, value.y, value.z)));
        }
    }
    Ok(())
}
