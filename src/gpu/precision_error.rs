//! What a refusal of the precision contract says ([`super::precision`] and
//! [`super::texture_range`] both make them): the value, where it was written and which
//! limit it passes. Below both checks, so that neither imports the other.

use crate::scene::Location;
use std::fmt;
use std::path::{Path, PathBuf};

/// A value the f32 kernel cannot render faithfully, and where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct PrecisionError {
    /// The file holding the value: the scene, or the OBJ file of a mesh vertex.
    pub file: PathBuf,
    /// Where in `file` (see [`super::precision`]); `None` for values the scene model keeps
    /// no place for (light, background and material colours).
    pub location: Option<Location>,
    /// What the value is, e.g. `Sphere radius`.
    pub what: String,
    /// Its magnitude, camera-relative and after transforms (NaN or infinite if f64 itself
    /// overflowed computing it); for [`Limit::Resolution`], the ratio R; for
    /// [`Limit::SphereSize`], the sphere's distance from the camera over its radius.
    pub magnitude: f64,
    /// The range it left, in words ([`RANGE`], or a texture's, [`super::texture_range`]).
    pub range: String,
    /// Which promise the value breaks.
    pub limit: Limit,
}

/// The two halves of the contract (see [`super::precision`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// A magnitude outside [`super::precision::MIN_MAGNITUDE`, `super::precision::MAX_MAGNITUDE`].
    Range,
    /// A pixel finer than f32 resolves at the scene's distance: R above
    /// [`super::precision::MAX_RESOLUTION_TRIANGLES`] or
    /// [`super::precision::MAX_RESOLUTION_SMOOTH`].
    Resolution { triangles: bool },
    /// A sphere too small for its distance from the camera to get its normal right: the
    /// distance over the radius above [`super::precision::MAX_DISTANCE_OVER_RADIUS`].
    SphereSize,
}

/// The range of every magnitude but textures', in words.
pub const RANGE: &str = "0 or 2^-25 to 2^28, with the camera at the origin";

impl fmt::Display for PrecisionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_place(f, &self.file, self.location)?;
        match self.limit {
            Limit::Range => write!(
                f,
                ": {}: magnitude {} is outside the range the GPU's f32 kernel renders faithfully ({})",
                self.what,
                show(self.magnitude),
                self.range
            ),
            Limit::Resolution { triangles } => write!(
                f,
                ": {}: a pixel spans 1/{} of the scene's distance from the camera, finer than the \
                 GPU's f32 kernel resolves ({})",
                self.what,
                show(self.magnitude),
                if triangles { "1/2^17 with triangles" } else { "1/2^19" }
            ),
            Limit::SphereSize => write!(
                f,
                ": {}: the sphere is {} radii from the camera; past 2^13 radii the GPU's f32 \
                 kernel cannot place its normals within a level",
                self.what,
                show(self.magnitude)
            ),
        }
    }
}

impl std::error::Error for PrecisionError {}

/// `FILE`, or `FILE:LINE:COL` where the place is known: how the GPU's refusals begin.
pub(super) fn write_place(f: &mut fmt::Formatter<'_>, file: &Path, location: Option<Location>) -> fmt::Result {
    write!(f, "{}", file.display())?;
    if let Some(Location { line, col }) = location {
        write!(f, ":{line}:{col}")?;
    }
    Ok(())
}

/// A magnitude in short scientific notation: `1e39`, `2.684e8`.
pub(super) fn show(value: f64) -> String {
    let text = format!("{value:.3e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            format!("{}e{exponent}", mantissa.trim_end_matches('0').trim_end_matches('.'))
        }
        _ => text,
    }
}
