//! One command line's work: read the scene, render, write the requested images.

use crate::app::backend::Backend;
use crate::app::cli::RenderArgs;
use raycaster::gpu::GpuError;
use raycaster::image_io::{self, ImageError, ImageFile};
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
/// them or, on failure, none). Returns the scene's warnings and the backend's notice.
pub fn run(args: &RenderArgs, backend: &Backend) -> Result<Vec<String>, Error> {
    let scene = scene::load_scene(&args.input)?;
    let notice = render_scene(&scene, args, backend)?;
    Ok(scene.warnings.into_iter().chain(notice).collect())
}

/// Renders an already-loaded scene as `args` asks and writes the images, tile by tile, so
/// memory stays bounded by the tile whatever the image size. Returns the backend's notice
/// when it chose another renderer for this scene.
pub fn render_scene(scene: &Scene, args: &RenderArgs, backend: &Backend) -> Result<Option<String>, Error> {
    let options = options_for(args);
    let mut outputs = Vec::new();
    if let Some(path) = &args.output {
        outputs.push((ImageFile::create(path, args.width, args.height)?, Kind::Color));
    }
    if let Some(path) = &args.normals {
        outputs.push((ImageFile::create(path, args.width, args.height)?, Kind::Normals));
    }
    if let Some(depth) = &args.depth {
        outputs.push((ImageFile::create(&depth.path, args.width, args.height)?, Kind::Depth(depth.min, depth.max)));
    }
    let (_, notice) = backend.render_tiles(scene, &options, |_first_row, tile| {
        for (file, kind) in &mut outputs {
            let rows = match *kind {
                Kind::Color => image_io::color_image(&tile),
                Kind::Normals => image_io::normals_image(&tile),
                Kind::Depth(min, max) => image_io::depth_image(&tile, min, max),
            };
            file.write_rows(rows.as_raw())?;
        }
        Ok::<(), Error>(())
    })?;
    let finished = outputs.into_iter().map(|(file, _)| file.finish()).collect::<Result<Vec<_>, _>>()?;
    image_io::persist_all(finished)?;
    Ok(notice)
}

/// Which image an output file receives.
enum Kind {
    Color,
    Normals,
    Depth(f32, f32),
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

/// Runs each render command line of `text` with `backend`.
/// Returns the warnings printed along the way and the lines that failed; a failing line
/// does not stop the others.
pub fn run_batch(text: &str, backend: &Backend) -> (Vec<String>, Vec<BatchFailure>) {
    let mut warnings = Vec::new();
    let mut failures = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let line_number = index + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.is_empty() || words[0].starts_with('#') {
            continue;
        }
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
