//! The one error type of the scene front end.

use super::model::Location;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a scene (or one of its OBJ meshes) could not be read.
///
/// Displays as `FILE:LINE:COL: MESSAGE`, or `FILE: MESSAGE` when the problem has no single
/// place in the file (an unreadable file, a missing camera). For errors inside an OBJ mesh,
/// `file` is the OBJ file and the message says which scene line referenced it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    pub file: PathBuf,
    pub location: Option<Location>,
    pub message: String,
}

impl SceneError {
    /// An error at a place in `file`.
    pub fn at(file: &Path, location: Location, message: impl Into<String>) -> Self {
        SceneError { file: file.to_path_buf(), location: Some(location), message: message.into() }
    }

    /// An error about `file` as a whole.
    pub fn in_file(file: &Path, message: impl Into<String>) -> Self {
        SceneError { file: file.to_path_buf(), location: None, message: message.into() }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_place(f, &self.file, self.location)?;
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for SceneError {}

/// A remark about a scene that still renders (no lights, PhongMaterial terms ignored),
/// located like a [`SceneError`]: displays as `FILE:LINE:COL: warning: MESSAGE`, or
/// `FILE: warning: MESSAGE` when it has no single place in the file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneWarning {
    pub file: PathBuf,
    pub location: Option<Location>,
    pub message: String,
}

impl SceneWarning {
    /// A warning at a place in `file`, or about `file` as a whole.
    pub fn new(file: &Path, location: Option<Location>, message: impl Into<String>) -> Self {
        SceneWarning { file: file.to_path_buf(), location, message: message.into() }
    }
}

impl fmt::Display for SceneWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_place(f, &self.file, self.location)?;
        write!(f, ": warning: {}", self.message)
    }
}

/// `FILE:LINE:COL`, or `FILE` alone.
fn write_place(f: &mut fmt::Formatter<'_>, file: &Path, location: Option<Location>) -> fmt::Result {
    match location {
        Some(Location { line, col }) => write!(f, "{}:{line}:{col}", file.display()),
        None => write!(f, "{}", file.display()),
    }
}
