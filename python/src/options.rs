//! The keywords of `raycaster.render` and `raycaster.compare` are the course's flags: each
//! becomes its flag and the command line's own parser (src/app/cli.rs, from the one flag
//! table) reads them, so a keyword means what its flag means and a value the command line
//! refuses is refused with the same message.

use crate::app::{args::Command, cli, job};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use raycaster::render::{Output, Outputs, RenderOptions};

/// The keywords, as python/raycaster/__init__.py passes them (one dict).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Keywords {
    outputs: Vec<String>,
    shade_back: bool,
    specular_fix: bool,
    shadows: bool,
    bounces: u32,
    weight: f64,
    samples: Option<u32>,
    sampler: String,
    filter: Option<(String, f64)>,
    seed: u32,
    grid: Option<(u32, u32, u32)>,
    visualize_grid: bool,
    stats: bool,
    triangle_test: String,
    sphere_test: String,
}

/// The render options the keywords ask for, of a `width × height` image.
pub fn render_options(width: u32, height: u32, keywords: &Keywords) -> PyResult<RenderOptions> {
    let mut words: Vec<String> =
        ["-input", "scene", "-size", &width.to_string(), &height.to_string()].map(String::from).to_vec();
    // Any image file: the outputs are set below; nothing is written.
    words.extend(["-output", "keywords.tga"].map(String::from));
    let mut flag = |name: &str, values: &[String]| {
        words.push(name.to_string());
        words.extend(values.iter().cloned());
    };
    for (on, name) in [
        (keywords.shade_back, "-shade_back"),
        (keywords.specular_fix, "--specular-fix"),
        (keywords.shadows, "-shadows"),
        (keywords.visualize_grid, "-visualize_grid"),
        (keywords.stats, "-stats"),
    ] {
        if on {
            flag(name, &[]);
        }
    }
    flag("-bounces", &[keywords.bounces.to_string()]);
    flag("-weight", &[keywords.weight.to_string()]);
    if let Some(n) = keywords.samples {
        let sampler = match keywords.sampler.as_str() {
            "uniform" | "random" | "jittered" => format!("-{}_samples", keywords.sampler),
            other => return Err(refused("sampler", other, "'uniform', 'random' or 'jittered'")),
        };
        flag(&sampler, &[n.to_string()]);
    }
    if let Some((kind, size)) = &keywords.filter {
        match kind.as_str() {
            "box" | "tent" | "gaussian" => flag(&format!("-{kind}_filter"), &[size.to_string()]),
            other => return Err(refused("filter", other, "('box' | 'tent' | 'gaussian', size)")),
        }
    }
    flag("--seed", &[keywords.seed.to_string()]);
    if let Some((nx, ny, nz)) = keywords.grid {
        flag("-grid", &[nx.to_string(), ny.to_string(), nz.to_string()]);
    }
    flag("--triangle-test", &[keywords.triangle_test.clone()]);
    flag("--sphere-test", &[keywords.sphere_test.clone()]);
    let args = match cli::parse_args(&words) {
        Ok(Command::Render(args)) => args,
        Ok(_) => unreachable!("-input ... -output is a render"),
        Err(e) => return Err(PyValueError::new_err(e.0)),
    };
    Ok(RenderOptions { outputs: outputs(&keywords.outputs)?, ..job::options_for(&args) })
}

/// The outputs by the names the arrays have.
fn outputs(names: &[String]) -> PyResult<Outputs> {
    let mut outputs = Outputs::NONE;
    for name in names {
        outputs = outputs.with(match name.as_str() {
            "color" => Output::Color,
            "normals" => Output::Normals,
            "depth" => Output::Depth,
            other => return Err(refused("outputs", other, "'color', 'normals' or 'depth'")),
        });
    }
    match outputs.is_empty() {
        true => Err(PyValueError::new_err("outputs: name at least one of 'color', 'normals' and 'depth'")),
        false => Ok(outputs),
    }
}

/// The name of an output in the arrays' keys.
pub fn key(output: Output) -> &'static str {
    match output {
        Output::Color => "color",
        Output::Normals => "normals",
        Output::Depth => "depth",
    }
}

fn refused(keyword: &str, value: &str, expected: &str) -> PyErr {
    PyValueError::new_err(format!("{keyword}: {value:?} is not one of {expected}"))
}
