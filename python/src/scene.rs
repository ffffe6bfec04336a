//! `raycaster.Scene`: a parsed scene, and `raycaster.SceneError`, located as the command
//! line locates it.

use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

pyo3::create_exception!(
    raycaster,
    SceneError,
    PyValueError,
    "A scene (or one of its OBJ meshes) that cannot be read. `str(e)` is the command line's \
     message, FILE:LINE:COLUMN: MESSAGE; `file`, `line`, `column` (None where the problem has \
     no single place) and `message` are attributes."
);
pyo3::create_exception!(
    raycaster,
    SceneWarning,
    PyUserWarning,
    "A remark about a scene that still renders, located as the command line locates it."
);

/// A parsed scene, shared by every render of it (renders read it without the GIL).
#[pyclass(module = "raycaster", frozen)]
pub struct Scene {
    pub scene: Arc<raycaster::scene::Scene>,
}

#[pymethods]
impl Scene {
    /// Reads the scene file `path`, its OBJ meshes beside it, as `-input` does.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        let parsed = py.detach(|| raycaster::scene::load_scene(&path));
        Scene::parsed(py, parsed)
    }

    /// Parses `text` as the scene file `path` (used in messages, and to resolve OBJ names);
    /// `obj_files` maps each `obj_file` name the scene gives to that mesh's text, and the
    /// file system is not read.
    #[staticmethod]
    #[pyo3(signature = (text, obj_files = None, path = PathBuf::from("scene.txt")))]
    fn from_text(
        py: Python<'_>,
        text: &str,
        obj_files: Option<HashMap<PathBuf, String>>,
        path: PathBuf,
    ) -> PyResult<Scene> {
        let files = obj_files.unwrap_or_default();
        let parsed =
            py.detach(|| raycaster::scene::parse_scene_with(text, &path, raycaster::scene::ObjFiles::Memory(&files)));
        Scene::parsed(py, parsed)
    }

    /// The file the scene was read from (or named by `from_text`).
    #[getter]
    fn path(&self) -> PathBuf {
        self.scene.path.clone()
    }

    /// The scene's warnings, as the command line prints them (each was also issued as a
    /// `raycaster.SceneWarning` when the scene was read).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.iter().map(ToString::to_string).collect()
    }

    fn __repr__(&self) -> String {
        format!("raycaster.Scene({:?})", self.scene.path.display().to_string())
    }
}

impl Scene {
    fn parsed(
        py: Python<'_>,
        parsed: Result<raycaster::scene::Scene, raycaster::scene::SceneError>,
    ) -> PyResult<Scene> {
        let scene = parsed.map_err(|e| scene_error(py, &e))?;
        let category = py.get_type::<SceneWarning>();
        for warning in &scene.warnings {
            let message = std::ffi::CString::new(warning.to_string()).unwrap_or_default();
            // stacklevel 1: the user's line that read the scene (this module has no frame).
            PyErr::warn(py, &category, &message, 1)?;
        }
        Ok(Scene { scene: Arc::new(scene) })
    }
}

/// `raycaster.SceneError` with the error's place as attributes.
pub fn scene_error(py: Python<'_>, e: &raycaster::scene::SceneError) -> PyErr {
    let err = SceneError::new_err(e.to_string());
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("file", e.file.display().to_string())?;
        value.setattr("line", e.location.map(|l| l.line))?;
        value.setattr("column", e.location.map(|l| l.col))?;
        value.setattr("message", &e.message)
    };
    match set() {
        Ok(()) => err,
        Err(failed) => failed,
    }
}
