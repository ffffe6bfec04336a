//! A frame into numpy arrays. Each buffer of the frame becomes its array as it is: the
//! array owns the Vec's allocation (numpy's `into_pyarray`), so the only copy of the pixels
//! after the render is `color8`, which is computed (docs/python.md, "What it costs").

use numpy::ndarray::{Array2, Array3};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use raycaster::render::{Frame, RenderStats};

/// `color` and `color8`, `normals`, `depth` (for those the frame holds) and `hit`, each
/// height × width (× 3).
pub fn frame_dict(py: Python<'_>, frame: Frame) -> PyResult<Bound<'_, PyDict>> {
    let (h, w) = (frame.height as usize, frame.width as usize);
    // As the image files quantise it (src/image_io.rs), from the same floats.
    let color8 = (!frame.color.is_empty()).then(|| raycaster::image_io::color_image(&frame).into_raw());
    let Frame { hit, color, mut normal, mut depth, .. } = frame;
    let dict = PyDict::new(py);
    let rgb = |values: Vec<[f32; 3]>| {
        Array3::from_shape_vec((h, w, 3), bytemuck::cast_vec::<[f32; 3], f32>(values)).expect("h × w pixels")
    };
    if let Some(color8) = color8 {
        dict.set_item("color", rgb(color).into_pyarray(py))?;
        dict.set_item("color8", Array3::from_shape_vec((h, w, 3), color8).expect("h × w pixels").into_pyarray(py))?;
    }
    if !normal.is_empty() {
        // Zero where nothing was hit, as the EXR's normals (image_io::normal_values).
        normal.iter_mut().zip(&hit).filter(|(_, &h)| !h).for_each(|(n, _)| *n = [0.0; 3]);
        dict.set_item("normals", rgb(normal).into_pyarray(py))?;
    }
    if !depth.is_empty() {
        // +inf where nothing was hit, as the EXR's depth (image_io::depth_values says why).
        depth.iter_mut().zip(&hit).filter(|(_, &h)| !h).for_each(|(t, _)| *t = f32::INFINITY);
        dict.set_item("depth", Array2::from_shape_vec((h, w), depth).expect("h × w").into_pyarray(py))?;
    }
    dict.set_item("hit", Array2::from_shape_vec((h, w), hit).expect("h × w").into_pyarray(py))?;
    Ok(dict)
}

/// What the render cost and counted (`-stats`: the course's statistics, when asked for).
pub fn stats_dict<'py>(py: Python<'py>, stats: &RenderStats) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("tiles", stats.tiles)?;
    dict.set_item("kernel_ms", stats.kernel_ns.map(|ns| ns as f64 / 1e6))?;
    dict.set_item("prepare_ms", stats.prepare_ms)?;
    dict.set_item("acceleration", stats.acceleration.name())?;
    if let Some(counted) = stats.counted {
        dict.set_item("non_shadow_rays", counted.non_shadow_rays)?;
        dict.set_item("shadow_rays", counted.shadow_rays)?;
        dict.set_item("intersections", counted.intersections)?;
        dict.set_item("cells_traversed", counted.cells_traversed)?;
    }
    Ok(dict)
}
