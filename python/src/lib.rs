//! `raycaster._raycaster`: the native module of the Python package (python/raycaster/ wraps
//! it with signatures, docstrings and warnings). It renders through the library's
//! [`raycaster::renderer::Renderer`], which alone chooses the GPU or the f64 reference, and
//! runs command lines through the binary's own code, compiled here (docs/python.md).

use pyo3::prelude::*;

/// The command line (src/app/), compiled into this module so that `raycaster.run` is the
/// binary's code and writes the binary's bytes. What only the binary's `main` calls (the
/// interrupt handlers) is never called here; so is its part of the window and bench code
/// that is cut out without the `gui` and `plot` features.
#[path = "../../src/app/mod.rs"]
#[allow(dead_code, unused_imports)]
mod app;
mod arrays;
mod backends;
mod command;
mod options;
mod render;
mod scene;

#[pymodule]
fn _raycaster(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // As the binary does before anything opens a device (src/app/command.rs says why); a
    // variable the user has set is left alone.
    app::command::give_mesa_a_runtime_dir();
    app::command::split_lavapipe_dispatches_finer();
    let py = m.py();
    m.add_class::<scene::Scene>()?;
    m.add("SceneError", py.get_type::<scene::SceneError>())?;
    m.add("SceneWarning", py.get_type::<scene::SceneWarning>())?;
    m.add("GpuError", py.get_type::<backends::GpuError>())?;
    m.add("CommandError", py.get_type::<command::CommandError>())?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::compare, m)?)?;
    m.add_function(wrap_pyfunction!(command::run, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
