//! One command line's work: read the scene, render, write the requested images.

use crate::app::backend::Backend;
use crate::app::cli::RenderArgs;
use crate::app::output::{self, Sink};
use crate::app::split::{self, Split};
use raycaster::gpu::GpuError;
use raycaster::image_io::ImageError;
use raycaster::render::RenderOptions;
use raycaster::scene::{self, Scene, SceneError};

/// Anything that can stop a render.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Image(#[from] ImageError),
    /// Identifying a split render's parts (reading the scene's text again).
    #[error("{0}")]
    Split(String),
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
pub fn run(args: &RenderArgs, backend: &Backend) -> Result<Vec<String>, Error> {
    let scene = scene::load_scene(&args.input)?;
    render_scene(&scene, args, backend)?;
    Ok(scene.warnings)
}

/// Renders an already-loaded scene as `args` asks and writes the images, tile by tile, so
/// memory stays bounded by the tile whatever the image size. With `--tile K/N` only band K
/// is rendered, into part files.
pub fn render_scene(scene: &Scene, args: &RenderArgs, backend: &Backend) -> Result<(), Error> {
    let options = options_for(args);
    let outputs = output::outputs(&args.output, &args.normals, &args.depth);
    let (first, rows) = args.tile.map_or((0, args.height), |t| t.band(args.height));
    let mut sinks = match args.tile {
        None => outputs.iter().map(|o| Sink::image(o, args.width, args.height)).collect::<Result<Vec<_>, _>>()?,
        Some(tile) => split::part_headers(scene, args, backend, tile, &outputs)
            .map_err(Error::Split)?
            .into_iter()
            .zip(&outputs)
            .map(|(header, o)| Sink::part(header, o))
            .collect::<Result<Vec<_>, _>>()?,
    };
    backend.render_band(scene, &options, first, rows, |_first_row, tile| {
        for (sink, o) in sinks.iter_mut().zip(&outputs) {
            sink.write(&o.pixels(&tile))?;
        }
        Ok::<(), Error>(())
    })?;
    let finished = sinks.into_iter().map(Sink::finish).collect::<Result<Vec<_>, _>>()?;
    output::persist_all(finished)?;
    Ok(())
}

/// What `raycaster compare` found: the GPU against the reference, per output.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub errors: Vec<raycaster::metrics::OutputErrors>,
    pub warnings: Vec<String>,
}

impl Comparison {
    /// Whether the GPU's result passes: no NaN or infinity anywhere, and no output with
    /// more than `max_diff_pixels` pixels off by more than 1 level (when a limit is given).
    pub fn passes(&self, max_diff_pixels: Option<u64>) -> bool {
        self.errors
            .iter()
            .all(|e| e.non_finite == 0 && max_diff_pixels.is_none_or(|n| e.image.off_by_more_than_one as u64 <= n))
    }
}

/// Renders what `args` names with the GPU and with the f64 reference, writing no file.
pub fn compare(args: &RenderArgs, gpu: &raycaster::gpu::GpuRenderer) -> Result<Comparison, Error> {
    let scene = scene::load_scene(&args.input)?;
    let options = options_for(args);
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

/// One failed line of a batch.
#[derive(Debug)]
pub struct BatchFailure {
    pub line: usize,
    pub message: String,
}

/// Runs each render command line of `text` with `backend` (with a shard, only its share:
/// the command lines, blank and comment lines not counted, whose 0-based index is K
/// modulo N). Returns the warnings printed along the way and the lines that failed; a
/// failing line does not stop the others.
pub fn run_batch(text: &str, backend: &Backend, shard: Option<Split>) -> (Vec<String>, Vec<BatchFailure>) {
    let mut warnings = Vec::new();
    let mut failures = Vec::new();
    let commands = text.lines().enumerate().filter(|(_, line)| {
        let first = line.split_whitespace().next();
        first.is_some_and(|w| !w.starts_with('#'))
    });
    for (command, (index, line)) in commands.enumerate() {
        if shard.is_some_and(|s| !s.takes(command)) {
            continue;
        }
        let line_number = index + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        let fail = |message: String| BatchFailure { line: line_number, message };
        match crate::app::cli::parse_args(&words) {
            Ok(crate::app::cli::Command::Render(args)) => match run(&args, backend) {
                Ok(w) => warnings.extend(w),
                Err(e) => failures.push(fail(e.to_string())),
            },
            Ok(_) => failures.push(fail("only render command lines can be batched".into())),
            Err(e) => failures.push(fail(e.0)),
        }
    }
    (warnings, failures)
}
