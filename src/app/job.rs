//! One command line's work: read the scene, render, write the requested images.

use crate::app::backend::Backend;
use crate::app::cli::{Outputs, RenderArgs};
use raycaster::gpu::GpuError;
use raycaster::image_io::{self, ImageError, ImageFile};
use raycaster::metrics::OutputErrors;
use raycaster::render::RenderOptions;
use raycaster::scene::{self, Scene, SceneError, SceneWarning};
use std::fmt;

/// Anything that can stop a render.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// The render options a command line implies: only the outputs it names are computed.
pub fn options_for(args: &RenderArgs) -> RenderOptions {
    RenderOptions {
        width: args.width,
        height: args.height,
        color: args.output.is_some(),
        normals: args.normals.is_some(),
        depth: args.depth.is_some(),
        shade_back: args.shade_back,
        triangle_test: args.triangle_test,
        sphere_test: args.sphere_test,
    }
}

/// Loads `args.input`, renders it with `backend` and writes every requested image (all of
/// them or, on failure, none). Returns the scene's warnings.
pub fn run(args: &RenderArgs, backend: &Backend) -> Result<Vec<SceneWarning>, Error> {
    let scene = scene::load_scene(&args.input)?;
    render_scene(&scene, args, backend)?;
    Ok(scene.warnings)
}

/// Renders an already-loaded scene as `args` asks and writes the images, tile by tile, so
/// memory stays bounded by the tile whatever the image size.
pub fn render_scene(scene: &Scene, args: &RenderArgs, backend: &Backend) -> Result<(), Error> {
    let options = options_for(args);
    let mut color = args.output.as_ref().map(|p| ImageFile::create(p, args.width, args.height)).transpose()?;
    let mut normals = args.normals.as_ref().map(|p| ImageFile::create(p, args.width, args.height)).transpose()?;
    let mut depth = args.depth.as_ref().map(|d| ImageFile::create(&d.path, args.width, args.height)).transpose()?;
    let depth_range = args.depth.as_ref().map_or((0.0, 1.0), |d| (d.min, d.max));
    backend.render_images(scene, &options, depth_range, |_first_row, rows| {
        for (file, rows) in [(&mut color, rows.color), (&mut normals, rows.normals), (&mut depth, rows.depth)] {
            if let (Some(file), Some(rows)) = (file.as_mut(), rows) {
                file.write_rows(&rows)?;
            }
        }
        Ok::<(), Error>(())
    })?;
    let finished =
        [color, normals, depth].into_iter().flatten().map(ImageFile::finish).collect::<Result<Vec<_>, _>>()?;
    image_io::persist_all(finished)?;
    Ok(())
}

/// What `raycaster compare` found: the GPU against the reference, per output.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub errors: Vec<OutputErrors>,
    pub warnings: Vec<SceneWarning>,
}

/// The parity contract's default limit: an output may have 0.1 % of its pixels (1 in 1000)
/// more than 1 level off the reference.
pub const DEFAULT_LIMIT_PER_MILLE: u64 = 1;

impl Comparison {
    /// The parity contract: no NaN or infinity in any output, and no output with more than
    /// `max_diff_pixels` (by default 0.1 % of its pixels) more than 1 level off. The error
    /// names each output that fails and the limit it broke.
    pub fn verdict(&self, max_diff_pixels: Option<u64>) -> Result<(), String> {
        let failures: Vec<String> = self.errors.iter().filter_map(|e| output_failure(e, max_diff_pixels)).collect();
        if failures.is_empty() {
            Ok(())
        } else {
            Err(format!("compare: {}", failures.join("; ")))
        }
    }
}

/// Why one output breaks the parity contract, if it does.
fn output_failure(errors: &OutputErrors, max_diff_pixels: Option<u64>) -> Option<String> {
    let name = errors.output.name();
    if errors.non_finite > 0 {
        return Some(format!("{name}: {} NaN or infinite values from the GPU (limit 0)", errors.non_finite));
    }
    let pixels = errors.image.pixels as u64;
    let (limit, origin) = match max_diff_pixels {
        Some(n) => (n, "--max-diff-pixels"),
        None => (pixels * DEFAULT_LIMIT_PER_MILLE / 1000, "0.1 %"),
    };
    let off = errors.image.off_by_more_than_one as u64;
    (off > limit).then(|| {
        format!(
            "{name}: {off} of {pixels} pixels are more than 1 level off the reference; the limit is {limit} ({origin})"
        )
    })
}

/// Renders the `outputs` with the GPU and with the f64 reference, writing no file.
pub fn compare(args: &RenderArgs, outputs: Outputs, gpu: &raycaster::gpu::GpuRenderer) -> Result<Comparison, Error> {
    let scene = scene::load_scene(&args.input)?;
    let options =
        RenderOptions { color: outputs.color, normals: outputs.normals, depth: outputs.depth, ..options_for(args) };
    let ours = gpu.render(&scene, &options)?;
    let reference = raycaster::cpu::render(&scene, &options);
    let depth_range = match &args.depth {
        Some(d) => (d.min, d.max),
        None => raycaster::metrics::depth_range_of(&reference),
    };
    Ok(Comparison {
        errors: raycaster::metrics::compare_frames(&ours, &reference, depth_range),
        warnings: scene.warnings,
    })
}

/// What a line of a batch reports besides its images.
#[derive(Debug)]
pub enum LineReport {
    Warning(SceneWarning),
    Failure(String),
}

impl fmt::Display for LineReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LineReport::Warning(w) => w.fmt(f),
            LineReport::Failure(message) => f.write_str(message),
        }
    }
}

/// How many command lines a batch ran, and how many of them failed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchCount {
    pub run: usize,
    pub failed: usize,
}

/// Runs each render command line of `text` with `backend`, handing every warning and
/// failure to `report` with its line number as it happens. A failing line does not stop
/// the others.
pub fn run_batch(text: &str, backend: &Backend, mut report: impl FnMut(usize, LineReport)) -> BatchCount {
    let mut count = BatchCount::default();
    for (index, line) in text.lines().enumerate() {
        let line_number = index + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.is_empty() || words[0].starts_with('#') {
            continue;
        }
        count.run += 1;
        let failure = match crate::app::cli::parse_args(&words) {
            Ok(crate::app::cli::Command::Render(args)) => match run(&args, backend) {
                Ok(warnings) => {
                    warnings.into_iter().for_each(|w| report(line_number, LineReport::Warning(w)));
                    continue;
                }
                Err(e) => e.to_string(),
            },
            Ok(_) => "only render command lines can be batched".into(),
            Err(e) => e.0,
        };
        count.failed += 1;
        report(line_number, LineReport::Failure(failure));
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use raycaster::metrics::{ImageDiff, Output};

    fn errors(output: Output, pixels: usize, off: usize, non_finite: usize) -> OutputErrors {
        OutputErrors {
            output,
            image: ImageDiff { pixels, off_by_more_than_one: off, max: 2, mean: 0.0 },
            hit_mismatches: 0,
            float_max: 0.0,
            float_mean: 0.0,
            relative_max: None,
            non_finite,
        }
    }

    fn verdict(outputs: Vec<OutputErrors>, max_diff_pixels: Option<u64>) -> Result<(), String> {
        Comparison { errors: outputs, warnings: Vec::new() }.verdict(max_diff_pixels)
    }

    /// 0.1 % of 10000 pixels is 10: 10 off passes, 11 fails; 1999 pixels allow 1.
    #[test]
    fn the_default_limit_is_a_tenth_of_a_percent() {
        assert_eq!(verdict(vec![errors(Output::Color, 10_000, 10, 0)], None), Ok(()));
        assert_eq!(
            verdict(vec![errors(Output::Color, 10_000, 11, 0), errors(Output::Depth, 1999, 2, 0)], None),
            Err("compare: colour: 11 of 10000 pixels are more than 1 level off the reference; the limit is 10 \
                 (0.1 %); depth: 2 of 1999 pixels are more than 1 level off the reference; the limit is 1 (0.1 %)"
                .into())
        );
    }

    #[test]
    fn max_diff_pixels_overrides_and_nan_always_fails() {
        assert_eq!(verdict(vec![errors(Output::Normals, 100, 100, 0)], Some(100)), Ok(()));
        assert_eq!(
            verdict(vec![errors(Output::Normals, 100, 4, 0)], Some(3)),
            Err("compare: normals: 4 of 100 pixels are more than 1 level off the reference; the limit is 3 \
                 (--max-diff-pixels)"
                .into())
        );
        assert_eq!(
            verdict(vec![errors(Output::Depth, 100, 0, 1)], Some(100)),
            Err("compare: depth: 1 NaN or infinite values from the GPU (limit 0)".into())
        );
    }
}
