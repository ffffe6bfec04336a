//! One command line's work: read the scene, render, write the requested images.

use crate::app::backend::Backend;
use crate::app::cli::RenderArgs;
use crate::app::progress::Progress;
use raycaster::gpu::{GpuError, RenderStats};
use raycaster::image_io::{self, ImageError, ImageFile};
use raycaster::render::RenderOptions;
use raycaster::scene::{self, Scene, SceneError};
use std::time::Instant;

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

/// What a render did, and where its time went (for `--verbose`).
#[derive(Clone, Debug)]
pub struct Report {
    pub warnings: Vec<String>,
    pub stats: RenderStats,
    pub parse_ms: f64,
    /// The backend's time, from the first tile's preparation to the last tile's read-back,
    /// less the time spent writing.
    pub render_ms: f64,
    /// Converting tiles to 8-bit rows, encoding and writing them, and renaming the files.
    pub write_ms: f64,
}

impl Report {
    /// The lines `--verbose` prints after a render with `backend`.
    pub fn verbose_lines(&self, backend: &Backend, args: &RenderArgs) -> Vec<String> {
        let stats = &self.stats;
        let mut lines = vec![format!("backend: {}", backend.describe())];
        let tiles = if stats.tiles == 1 { "1 tile".to_string() } else { format!("{} tiles", stats.tiles) };
        let mut time = format!("time: parsing {:.1} ms, rendering {:.1} ms in {tiles}", self.parse_ms, self.render_ms);
        if let Backend::Gpu(_) = backend {
            lines.push(format!(
                "kernel: {} triangle test, {} sphere test",
                args.triangle_test.name(),
                args.sphere_test.name()
            ));
            // The parts of the GPU's rendering time that it measures on its own.
            time += &format!(" (preparing {:.1} ms: buffers, pipeline, upload", stats.prepare_ms);
            if let Some(bvh) = stats.bvh_build_ms {
                time += &format!("; hierarchy {bvh:.1} ms of it");
            }
            if let Some(ns) = stats.kernel_ns {
                time += &format!("; kernel {:.1} ms", ns as f64 / 1e6);
            }
            time += ")";
        }
        time += &format!(", writing {:.1} ms", self.write_ms);
        lines.push(time);
        let mut memory = format!("memory: peak resident {:.0} MiB", crate::app::bench::peak_memory_mib());
        if let Backend::Gpu(_) = backend {
            memory += &format!(", scene data on the GPU {:.1} KiB", stats.scene_bytes as f64 / 1024.0);
        }
        lines.push(memory);
        lines
    }
}

/// Loads `args.input`, renders it with `backend` and writes every requested image (all of
/// them or, on failure, none). With `progress`, a bar over the rows appears on a terminal
/// when the render takes long.
pub fn run(args: &RenderArgs, backend: &Backend, progress: bool) -> Result<Report, Error> {
    let start = Instant::now();
    let scene = scene::load_scene(&args.input)?;
    let parse_ms = start.elapsed().as_secs_f64() * 1e3;
    let (stats, render_ms, write_ms) = render_scene(&scene, args, backend, progress)?;
    Ok(Report { warnings: scene.warnings, stats, parse_ms, render_ms, write_ms })
}

/// Renders an already-loaded scene as `args` asks and writes the images, tile by tile, so
/// memory stays bounded by the tile whatever the image size. Returns the backend's
/// statistics, and the milliseconds spent rendering and writing.
pub fn render_scene(
    scene: &Scene,
    args: &RenderArgs,
    backend: &Backend,
    progress: bool,
) -> Result<(RenderStats, f64, f64), Error> {
    let start = Instant::now();
    let mut writing = std::time::Duration::ZERO;
    let bar = Progress::new(progress, args.height as u64, "rows");
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
    let stats = backend.render_tiles(scene, &options, |_first_row, tile| {
        let written = Instant::now();
        for (file, kind) in &mut outputs {
            let rows = match *kind {
                Kind::Color => image_io::color_image(&tile),
                Kind::Normals => image_io::normals_image(&tile),
                Kind::Depth(min, max) => image_io::depth_image(&tile, min, max),
            };
            file.write_rows(rows.as_raw())?;
        }
        writing += written.elapsed();
        bar.advance(tile.height as u64);
        Ok::<(), Error>(())
    })?;
    drop(bar);
    let render_ms = (start.elapsed() - writing).as_secs_f64() * 1e3;
    let finishing = Instant::now();
    let finished = outputs.into_iter().map(|(file, _)| file.finish()).collect::<Result<Vec<_>, _>>()?;
    image_io::persist_all(finished)?;
    let write_ms = (writing + finishing.elapsed()).as_secs_f64() * 1e3;
    Ok((stats, render_ms, write_ms))
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

/// One command line of a batch that rendered.
#[derive(Debug)]
pub struct BatchLine {
    pub line: usize,
    pub report: Report,
}

/// Runs each render command line of `text` with `backend`. Returns the lines that rendered
/// (with their warnings and timings) and the lines that failed; a failing line does not stop
/// the others. With `progress`, a bar over the lines appears on a terminal when the batch
/// takes long.
pub fn run_batch(text: &str, backend: &Backend, progress: bool) -> (Vec<BatchLine>, Vec<BatchFailure>) {
    let is_command = |line: &&str| line.split_whitespace().next().is_some_and(|w| !w.starts_with('#'));
    let bar = Progress::new(progress, text.lines().filter(is_command).count() as u64, "lines");
    let mut done = Vec::new();
    let mut failures = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let line_number = index + 1;
        if !is_command(&line) {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        let fail = |message: String| BatchFailure { line: line_number, message };
        match crate::app::cli::parse_args(&words) {
            Ok(crate::app::cli::Command::Render(args)) => match run(&args, backend, false) {
                Ok(report) => done.push(BatchLine { line: line_number, report }),
                Err(e) => failures.push(fail(e.to_string())),
            },
            Ok(_) => failures.push(fail("only render command lines can be batched".into())),
            Err(e) => failures.push(fail(e.0)),
        }
        bar.advance(1);
    }
    (done, failures)
}
