//! The renderers this process has opened, one per backend choice: a device opens once
//! (seconds on a CPU Vulkan driver) and renders every scene after it.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use raycaster::render::RenderOptions;
use raycaster::renderer::{BackendChoice, Renderer};
use raycaster::scene::Scene;
use std::sync::{Arc, Mutex, PoisonError};

pyo3::create_exception!(
    raycaster,
    GpuError,
    PyRuntimeError,
    "The GPU could not render: no adapter or device, a scene the f32 kernel refuses with \
     backend='gpu', a lost device."
);

/// An open renderer, and `auto`'s notice that no GPU opened, if it did not.
pub struct Opened {
    pub renderer: Renderer,
    pub notice: Option<String>,
}

static OPENED: Mutex<Vec<(BackendChoice, Arc<Opened>)>> = Mutex::new(Vec::new());

pub fn choice(name: &str) -> PyResult<BackendChoice> {
    BackendChoice::ALL
        .into_iter()
        .find(|c| c.name() == name)
        .ok_or_else(|| PyValueError::new_err(format!("backend: {name:?} is not one of 'auto', 'gpu' or 'cpu'")))
}

/// The renderer for `choice`, opened on first use. With `auto`, [`Renderer::open_for`] may
/// give a job too small to pay for the device's start-up to the reference without opening
/// it, as the command line does; that choice is the job's, so it is not kept, and once a
/// device is open every `auto` job goes to it (and to [`Renderer::for_scene`]'s choices).
pub fn open(
    choice: BackendChoice,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<Arc<Opened>, raycaster::gpu::GpuError> {
    let mut opened = OPENED.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((_, kept)) = opened.iter().find(|(c, _)| *c == choice) {
        return Ok(kept.clone());
    }
    let (renderer, notice) = Renderer::open_for(choice, scene, options)?;
    let small_job = choice == BackendChoice::Auto && renderer.gpu().is_none() && notice.is_none();
    let new = Arc::new(Opened { renderer, notice });
    if !small_job {
        opened.push((choice, new.clone()));
    }
    Ok(new)
}

pub fn gpu_error(e: raycaster::gpu::GpuError) -> PyErr {
    GpuError::new_err(e.to_string())
}
