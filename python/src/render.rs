//! `raycaster.render` and `raycaster.compare`: renders without the GIL, stopped between
//! tiles by Ctrl-C.

use crate::arrays;
use crate::backends::{self, gpu_error};
use crate::options::{self, Keywords};
use crate::scene::Scene;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raycaster::gpu::GpuError;
use raycaster::renderer::{BackendChoice, Rendered, Renderer};

/// Why a render stopped: the GPU, or Python (Ctrl-C: a `KeyboardInterrupt`).
enum Stop {
    Gpu(GpuError),
    Python(PyErr),
}

impl From<GpuError> for Stop {
    fn from(e: GpuError) -> Self {
        Stop::Gpu(e)
    }
}

impl From<Stop> for PyErr {
    fn from(stop: Stop) -> PyErr {
        match stop {
            Stop::Gpu(e) => gpu_error(e),
            Stop::Python(e) => e,
        }
    }
}

/// Between two tiles: the GIL for a moment, to run Python's signal handlers (its Ctrl-C
/// handler raises `KeyboardInterrupt`, which stops the render).
fn go_on() -> Result<(), Stop> {
    Python::attach(|py| py.check_signals()).map_err(Stop::Python)
}

fn render_with(
    renderer: &Renderer,
    scene: &Scene,
    options: &raycaster::render::RenderOptions,
) -> Result<Rendered, Stop> {
    renderer.render_or_stop(&scene.scene, options, go_on)
}

/// The native render: `(arrays, notice)`; python/raycaster/__init__.py documents it, warns
/// with the notice.
#[pyfunction]
pub fn render<'py>(
    py: Python<'py>,
    scene: &Scene,
    width: u32,
    height: u32,
    backend: &str,
    keywords: Keywords,
) -> PyResult<(Bound<'py, PyDict>, Option<String>)> {
    let options = options::render_options(width, height, &keywords)?;
    let choice = backends::choice(backend)?;
    let (rendered, opened_notice) = py.detach(|| -> Result<_, Stop> {
        let opened = backends::open(choice, &scene.scene, &options)?;
        Ok((render_with(&opened.renderer, scene, &options)?, opened.notice.clone()))
    })?;
    let notice = opened_notice.or(rendered.notice.clone());
    let dict = arrays::frame_dict(py, rendered.frame)?;
    dict.set_item("stats", arrays::stats_dict(py, &rendered.stats)?)?;
    dict.set_item("backend", rendered.backend)?;
    Ok((dict, notice))
}

/// The native compare: the GPU against the f64 reference, as `raycaster compare` does.
#[pyfunction]
#[pyo3(signature = (scene, width, height, depth_range, keywords))]
pub fn compare<'py>(
    py: Python<'py>,
    scene: &Scene,
    width: u32,
    height: u32,
    depth_range: Option<(f32, f32)>,
    keywords: Keywords,
) -> PyResult<Bound<'py, PyDict>> {
    let options = options::render_options(width, height, &keywords)?;
    let (errors, adapter) = py.detach(|| -> Result<_, Stop> {
        let opened = backends::open(BackendChoice::Gpu, &scene.scene, &options)?;
        let ours = render_with(&opened.renderer, scene, &options)?.frame;
        let reference = render_with(Renderer::reference(), scene, &options)?.frame;
        let depth_range = depth_range.unwrap_or_else(|| raycaster::metrics::depth_range_of(&reference));
        let adapter = opened.renderer.gpu().map(|g| g.adapter_info().name.clone()).unwrap_or_default();
        Ok((raycaster::metrics::compare_frames(&ours, &reference, depth_range), adapter))
    })?;
    let verdict = crate::app::job::Comparison { errors: errors.clone(), warnings: Vec::new() }.verdict(None);
    let dict = PyDict::new(py);
    for e in &errors {
        let output = PyDict::new(py);
        output.set_item("pixels", e.image.pixels)?;
        output.set_item("off_by_more_than_one", e.image.off_by_more_than_one)?;
        output.set_item("max_level_diff", e.image.max)?;
        output.set_item("mean_level_diff", e.image.mean)?;
        output.set_item("hit_mismatches", e.hit_mismatches)?;
        output.set_item("float_max", e.float_max)?;
        output.set_item("float_mean", e.float_mean)?;
        output.set_item("relative_max", e.relative_max)?;
        output.set_item("non_finite", e.non_finite)?;
        dict.set_item(options::key(e.output), output)?;
    }
    dict.set_item("table", raycaster::metrics::errors_table(&errors))?;
    dict.set_item("gpu", adapter)?;
    dict.set_item("passed", verdict.is_ok())?;
    dict.set_item("verdict", verdict.err())?;
    Ok(dict)
}
