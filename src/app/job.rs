//! One command line's work: read the scene, render, write the requested images (whole, or
//! one band's part files); `compare`'s renders; and batches of command lines.

use crate::app::args::{Command, RenderArgs, Split};
use crate::app::lookahead::Lookahead;
use crate::app::output_file::{OutputFile, Pixels, Sink};
use crate::app::part::{self, Identity, PartHeader};
use crate::app::progress::Progress;
use crate::app::{cli, memory, validate};
use raycaster::gpu::GpuError;
use raycaster::image_io::SampleDot;
use raycaster::image_io::{self, ImageError, ImageFormat};
use raycaster::metrics::OutputErrors;
use raycaster::render::RenderStats;
use raycaster::render::{Output, Outputs, RenderOptions};
use raycaster::renderer::{DepthAs, Renderer};
use raycaster::sampling::{Sampler, Sampling};
use raycaster::scene::{self, Scene, SceneError, SceneWarning};
use std::fmt;
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
    /// Identifying a split render's parts (reading the scene's text again).
    #[error("{0}")]
    Split(String),
}

/// The render options a command line implies: only the outputs it names are computed.
pub fn options_for(args: &RenderArgs) -> RenderOptions {
    RenderOptions {
        width: args.width,
        height: args.height,
        outputs: args.files.outputs(),
        shading: args.shading,
        triangle_test: args.triangle_test,
        sphere_test: args.sphere_test,
        grid: args.grid,
        visualize_grid: args.visualize_grid,
        stats: args.stats,
        sampling: args.sampling,
    }
}

/// The notice for a command line with the course's preview flags where no window opens
/// (`no_window` says why): `-gui` renders as without it, and `-tessellation` and `-gouraud`,
/// which shape only the course's OpenGL preview, change nothing (GRAMMAR.md A3). `None`
/// without them.
pub fn preview_notice(args: &RenderArgs, no_window: &str) -> Option<String> {
    match (args.gui, args.preview, args.writes_something()) {
        (false, false, _) => None,
        (false, true, _) => Some("-tessellation and -gouraud shape only the course's OpenGL preview: ignored".into()),
        (true, _, true) => Some(format!("-gui: no window ({no_window}); the files are written as without it")),
        (true, _, false) => {
            Some(format!("-gui: no window ({no_window}), and no -output, -normals or -depth: nothing rendered"))
        }
    }
}

/// Why a batch's `-gui` lines open no window.
const BATCH_OPENS_NO_WINDOW: &str = "a batch opens none";

/// `-stats`: the course's `RayTracingStats::PrintStatistics` block (assignment 6, in its
/// order and wording), for a render that took `seconds` (rendering and writing, as the
/// course's timer runs from before the first ray to after the image is saved). Times are
/// given to the millisecond rather than the course's whole seconds.
pub fn stats_text(args: &RenderArgs, stats: &RenderStats, seconds: f64) -> String {
    let counted = stats.counted.unwrap_or_default();
    let pixels = u64::from(args.width) * u64::from(args.height);
    let rays = counted.non_shadow_rays + counted.shadow_rays;
    let per = |n: u64, of: u64| if of == 0 { 0.0 } else { n as f64 / of as f64 };
    let bounds = match stats.grid_bounds {
        Some(b) => format!("({} {} {}) ({} {} {})", b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z),
        None => "none".into(),
    };
    let cells = match args.grid {
        Some(g) => format!("{} ({}x{}x{})", g.cells(), g.nx, g.ny, g.nz),
        None => "none".into(),
    };
    let lines = [
        "********************************************".to_string(),
        "RAY TRACING STATISTICS".into(),
        format!("  total time                 {seconds:.3} s"),
        format!("  num pixels                 {pixels} ({}x{})", args.width, args.height),
        format!("  scene bounds               {bounds}"),
        format!("  num grid cells             {cells}"),
        format!("  num non-shadow rays        {}", counted.non_shadow_rays),
        format!("  num shadow rays            {}", counted.shadow_rays),
        format!("  total intersections        {}", counted.intersections),
        format!("  total cells traversed      {}", counted.cells_traversed),
        format!("  rays per second            {:.1}", rays as f64 / seconds.max(1e-9)),
        format!("  rays per pixel             {:.1}", per(rays, pixels)),
        format!("  intersections per ray      {:.1}", per(counted.intersections, rays)),
        format!("  cells traversed per ray    {:.1}", per(counted.cells_traversed, rays)),
        "********************************************".into(),
    ];
    lines.join("\n") + "\n"
}

/// What a render did, and where its time went (for `--verbose`).
#[derive(Clone, Debug)]
pub struct Report {
    pub warnings: Vec<SceneWarning>,
    /// Why `auto` rendered this scene with the reference after the GPU refused it, when it
    /// did (a warning).
    pub notice: Option<String>,
    /// Why `auto` gave this scene to the reference without asking the GPU, when it did
    /// ([`Renderer::for_scene`]; for `--verbose`).
    pub handed_over: Option<&'static str>,
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
    pub fn verbose_lines(&self, backend: &Renderer, args: &RenderArgs) -> Vec<String> {
        let stats = &self.stats;
        let backend = if self.handed_over.is_some() { Renderer::reference() } else { backend };
        let mut lines = vec![format!("backend: {}", backend.describe())];
        lines.extend(self.handed_over.map(str::to_string));
        let tiles = if stats.tiles == 1 { "1 tile".to_string() } else { format!("{} tiles", stats.tiles) };
        let mut time = format!("time: parsing {:.1} ms, rendering {:.1} ms in {tiles}", self.parse_ms, self.render_ms);
        if let Renderer::Gpu(..) = backend {
            lines.push(format!(
                "kernel: {} triangle test, {} sphere test",
                args.triangle_test.name(),
                args.sphere_test.name()
            ));
            if let Some(cache) = backend.gpu().and_then(|gpu| gpu.pipeline_cache()) {
                let (file, read, written) = cache.describe();
                lines.push(format!(
                    "pipeline cache: {} ({:.1} KiB read, {:.1} KiB written)",
                    file.display(),
                    read as f64 / 1024.0,
                    written as f64 / 1024.0
                ));
            }
            if raycaster::gpu::fuse::requested() {
                lines.push(format!(
                    "fused mode ({}=1): every multiply-add, dot and cross of the kernel fused, in f64",
                    raycaster::gpu::fuse::VARIABLE
                ));
            }
            // The parts of the GPU's rendering time that it measures on its own.
            time += &format!(
                " (preparing {:.1} ms: buffers, pipeline, upload; the kernel compiled or found in {:.1} ms beside \
                 them, specialising it {:.1} ms",
                stats.prepare_ms, stats.compile_ms, stats.specialise_ms
            );
            if let Some(build) = stats.acceleration_build_ms {
                time += &format!("; building the {} {build:.1} ms of it", stats.acceleration.name());
            }
            if let Some(ns) = stats.kernel_ns {
                time += &format!("; kernel {:.1} ms", ns as f64 / 1e6);
            }
            time += &format!("; waiting for tiles {:.1} ms", stats.waited_ms);
            if stats.lists_ms > 0.0 {
                time += &format!("; filling the later tiles' lists {:.1} ms", stats.lists_ms);
            }
            time += ")";
            if stats.pixels_cut_short > 0 {
                lines.push(format!(
                    "loop limit: the driver cut {} pixels short; the reference rendered them",
                    stats.pixels_cut_short
                ));
            }
            if stats.pixels_beyond_reach > 0 {
                lines.push(format!(
                    "f32 reach: {} pixels beyond the f32 kernel's reach (a solid texture far away, a \
                     checkerboard seen by a reflected or refracted ray, or such a ray leaving its \
                     surface almost along it); the reference rendered them",
                    stats.pixels_beyond_reach
                ));
            }
        }
        time += &format!(", writing {:.1} ms", self.write_ms);
        lines.push(time);
        let mut memory = format!("memory: {}", memory::describe_peak());
        if let Renderer::Gpu(..) = backend {
            memory += &format!(", scene data on the GPU {:.1} KiB", stats.scene_bytes as f64 / 1024.0);
        }
        lines.push(memory);
        lines
    }
}

/// Loads `args.input`, renders it with `backend` and writes every requested image (all of
/// them or, on failure, none). With `progress`, a bar over the rows appears on a terminal
/// when the render takes long.
pub fn run(args: &RenderArgs, backend: &Renderer, progress: bool) -> Result<Report, Error> {
    let (scene, parse_ms) = load(args)?;
    run_loaded(scene, parse_ms, args, backend, progress)
}

/// Reads `args.input`; returns the scene and the milliseconds it took.
pub fn load(args: &RenderArgs) -> Result<(Scene, f64), Error> {
    let start = Instant::now();
    let scene = scene::load_scene(&args.input)?;
    Ok((scene, start.elapsed().as_secs_f64() * 1e3))
}

/// [`run`] for a scene [`load`] read.
pub fn run_loaded(
    scene: Scene,
    parse_ms: f64,
    args: &RenderArgs,
    backend: &Renderer,
    progress: bool,
) -> Result<Report, Error> {
    let (backend, handed_over) = backend.for_scene(&scene, &options_for(args));
    let (stats, notice, render_ms, write_ms) = render_scene(&scene, args, backend, progress)?;
    Ok(Report { warnings: scene.warnings, notice, handed_over, stats, parse_ms, render_ms, write_ms })
}

/// Renders an already-loaded scene as `args` asks and writes the images, tile by tile, so
/// memory stays bounded by the tile whatever the image size. With `--tile K/N` only band K
/// is rendered, into part files. Returns the backend's statistics and notice (see
/// [`Renderer::render_band`]), and the milliseconds spent rendering and writing.
pub fn render_scene(
    scene: &Scene,
    args: &RenderArgs,
    backend: &Renderer,
    progress: bool,
) -> Result<(RenderStats, Option<String>, f64, f64), Error> {
    let start = Instant::now();
    let mut writing = std::time::Duration::ZERO;
    let options = options_for(args);
    let outputs = OutputFile::list(&args.files);
    let band = args.tile.map_or((0, args.height), |t| t.band(args.height));
    let mut sinks = match args.tile {
        None => outputs.iter().map(|o| Sink::image(o, args.width, args.height)).collect::<Result<Vec<_>, _>>()?,
        Some(tile) => part_headers(scene, args, backend, tile, &outputs)
            .map_err(Error::Split)?
            .into_iter()
            .zip(&outputs)
            .map(|(header, o)| Sink::part(header, o))
            .collect::<Result<Vec<_>, _>>()?,
    };
    let bar = Progress::new(progress, u64::from(band.1), "rows");
    // One tile's rows into every sink, `write_to` writing each output's; counted as writing.
    let mut write = |rows: u32, write_to: &mut dyn FnMut(&OutputFile, &mut Sink) -> Result<(), ImageError>| {
        let written = Instant::now();
        for (sink, o) in sinks.iter_mut().zip(&outputs) {
            write_to(o, sink)?;
        }
        writing += written.elapsed();
        bar.advance(u64::from(rows));
        Ok::<(), Error>(())
    };
    let (stats, notice) = if outputs.is_empty() {
        // Only the course's pictures (`-render_samples`, `-render_filter`): no image.
        (RenderStats::default(), None)
    } else if reads_floats(&outputs) {
        // Floats leave the backend as they are, for the EXR files of colour or normals.
        backend.render_band(scene, &options, band.0, band.1, |_first_row, tile| {
            write(tile.height, &mut |o, sink| sink.write(&o.pixels(&tile)))
        })?
    } else {
        // 8-bit images and depth: on the GPU the kernel quantises the images and hands over
        // the distances' bits (a fraction of the bytes to read back, no float decoding).
        // An 8-bit depth file has its range (OutputFile::list); an EXR holds the distances.
        let depth = match outputs.iter().find_map(|o| o.depth_range) {
            Some((min, max)) => DepthAs::Grey { min, max },
            None => DepthAs::Distance,
        };
        backend.render_images(scene, &options, depth, band, |_first_row, mut images| {
            write(images.rows, &mut |o, sink| match o.output {
                Output::Depth if depth == DepthAs::Distance => {
                    sink.write(&Pixels::Float(images.distances.take().expect("the render handed over the depth")))
                }
                _ => sink.write(&Pixels::Rows(images.pixels(o.output))),
            })
        })?
    };
    drop(bar);
    let render_ms = (start.elapsed() - writing).as_secs_f64() * 1e3;
    let finishing = Instant::now();
    let mut finished = sinks.into_iter().map(Sink::finish).collect::<Result<Vec<_>, _>>()?;
    finished.extend(pictures(scene, args)?);
    image_io::persist_all(finished)?;
    let write_ms = (writing + finishing.elapsed()).as_secs_f64() * 1e3;
    Ok((stats, notice, render_ms, write_ms))
}

/// The course's pictures the line asks for (`-render_samples`, `-render_filter`;
/// docs/SPEC.md §8), written beside the images and renamed with them. The samples'
/// colours are the reference's: the picture shows each sample on its own, which the
/// kernel, filtering on the device, never reads back.
fn pictures(scene: &Scene, args: &RenderArgs) -> Result<Vec<image_io::FinishedImage>, Error> {
    let sampling = args.sampling.unwrap_or(Sampling {
        sampler: Sampler::Uniform(1),
        filter: raycaster::sampling::DEFAULT_FILTER,
        seed: 0,
    });
    let mut finished = Vec::new();
    let mut write = |path: &std::path::Path, picture: image::RgbImage| -> Result<(), Error> {
        let mut file = image_io::ImageFile::create(path, picture.width(), picture.height())?;
        file.write_rows(picture.as_raw())?;
        finished.push(file.finish()?);
        Ok(())
    };
    if let Some(picture) = &args.pictures.samples {
        let options = RenderOptions { outputs: Output::Color.into(), sampling: Some(sampling), ..options_for(args) };
        let reference = raycaster::cpu::Reference::new(scene, &options);
        let image = raycaster::image_io::samples_picture(args.width, args.height, picture.zoom, |i, j| {
            reference
                .samples(&sampling, i, j, &mut raycaster::render::RayStats::default())
                .into_iter()
                .map(|(position, pixel)| SampleDot { position, color: pixel.color })
                .collect()
        });
        write(&picture.path, image)?;
    }
    if let Some(picture) = &args.pictures.filter {
        write(
            &picture.path,
            raycaster::image_io::filter_picture(sampling.filter, args.width, args.height, picture.zoom),
        )?;
    }
    Ok(finished)
}

/// The flags that change pixels, as text. The CPU reference has its own intersection
/// tests, so the kernel's variants count only on the GPU; the GPU and the reference differ
/// in the last bits, so the backend counts.
fn flags_text(args: &RenderArgs, backend: &Renderer) -> String {
    let shading = &args.shading;
    let mut shade_back = String::new();
    for (given, flag) in [
        (shading.shade_back, " -shade_back"),
        (shading.specular_fix, " --specular-fix"),
        (shading.shadows, " -shadows"),
    ] {
        if given {
            shade_back += flag;
        }
    }
    if shading.bounces > 0 {
        shade_back += &format!(" -bounces {} -weight {}", shading.bounces, shading.weight);
    }
    // The grid changes no pixel of a render, but a visualisation is another picture.
    if let Some(g) = args.grid.filter(|_| args.visualize_grid) {
        shade_back += &format!(" -grid {} {} {} -visualize_grid", g.nx, g.ny, g.nz);
    }
    if let Some(s) = &args.sampling {
        shade_back += &format!(
            " {} {} {} {} --seed {}",
            s.sampler.flag(),
            s.count(),
            s.filter.flag(),
            s.filter.parameter(),
            s.seed
        );
    }
    match backend {
        Renderer::Gpu(..) => format!(
            "--backend gpu --triangle-test {} --sphere-test {}{shade_back}",
            args.triangle_test.name(),
            args.sphere_test.name()
        ),
        Renderer::Cpu => format!("--backend cpu{shade_back}"),
    }
}

/// The part headers of band `tile` for each output of a render.
fn part_headers(
    scene: &Scene,
    args: &RenderArgs,
    backend: &Renderer,
    tile: Split,
    outputs: &[OutputFile],
) -> Result<Vec<PartHeader>, String> {
    let scene_hash = part::scene_hash(scene)?;
    let flags = flags_text(args, backend);
    let (first_row, rows) = tile.band(args.height);
    Ok(outputs
        .iter()
        .map(|o| PartHeader {
            identity: Identity {
                width: args.width,
                height: args.height,
                count: tile.count,
                output: o.describe(),
                scene: scene_hash.clone(),
                flags: flags.clone(),
            },
            index: tile.index,
            first_row,
            rows,
        })
        .collect())
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
    let options = RenderOptions { outputs, ..options_for(args) };
    let ours = gpu.render(&scene, &options)?;
    let reference = raycaster::cpu::render(&scene, &options);
    let depth_range = args.files.depth_range().unwrap_or_else(|| raycaster::metrics::depth_range_of(&reference));
    Ok(Comparison {
        errors: raycaster::metrics::compare_frames(&ours, &reference, depth_range),
        warnings: scene.warnings,
    })
}

/// What a line of a batch reports besides its images.
#[derive(Debug)]
pub enum LineReport {
    Warning(SceneWarning),
    /// `auto` rendered the line with the reference after the GPU refused it, and why.
    Fallback(String),
    /// Something the line asked for that is not done, as [`preview_notice`] says.
    Notice(String),
    /// `-stats`: the block [`stats_text`] writes, for stdout.
    Stats(String),
    Failure(String),
    /// The line rendered, in this many milliseconds (parsing, rendering, writing; for
    /// `--verbose`); by the reference when `auto` handed it over ([`Renderer::for_scene`]).
    Rendered {
        ms: f64,
        by_reference: bool,
    },
}

impl fmt::Display for LineReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LineReport::Warning(w) => w.fmt(f),
            LineReport::Fallback(notice) => write!(f, "warning: {notice}"),
            LineReport::Notice(notice) => write!(f, "note: {notice}"),
            LineReport::Stats(text) => f.write_str(text),
            LineReport::Failure(message) => f.write_str(message),
            LineReport::Rendered { ms, by_reference: false } => write!(f, "{ms:.1} ms"),
            LineReport::Rendered { ms, by_reference: true } => write!(f, "{ms:.1} ms, by the reference"),
        }
    }
}

/// How many command lines a batch ran, and how many of them failed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BatchCount {
    pub run: usize,
    pub failed: usize,
}

/// Runs each render command line of `text` with `backend` (with a shard, only its share:
/// the command lines, blank and comment lines not counted, whose 0-based index is K modulo
/// N), handing every warning, failure and finished line to `report` with its line number as
/// it happens. A failing line does not stop the others. With `progress`, a bar over the
/// lines appears on a terminal when the batch takes long; it steps aside while `report`
/// prints.
pub fn run_batch(
    text: &str,
    backend: &Renderer,
    shard: Option<Split>,
    progress: bool,
    mut report: impl FnMut(usize, LineReport),
) -> BatchCount {
    let is_command = |line: &&str| line.split_whitespace().next().is_some_and(|w| !w.starts_with('#'));
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .filter(|(_, line)| is_command(line))
        .enumerate()
        .filter(|(command, _)| shard.is_none_or(|s| s.takes(*command)))
        .map(|(_, (index, line))| (index + 1, line))
        .collect();
    let bar = Progress::new(progress, lines.len() as u64, "lines");
    let mut tell = |line: usize, what: LineReport| bar.suspend(|| report(line, what));
    let mut count = BatchCount::default();
    // The course's own commands.txt has -gui on every line: say it once.
    let mut preview_told = false;
    // The kernels of the lines after the one rendering, compiled meanwhile on every core (the
    // next lines' renders find them compiled, or wait for them: docs/SPEC.md §6).
    let threads = compiling_threads();
    let lookahead = Lookahead::new(lines.len(), LINES_AHEAD);
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                // The reference alone has nothing to compile.
                let Some(ahead) = backend.ahead() else { return };
                while let Some(k) = lookahead.take() {
                    precompile_line(lines[k].1, backend, &ahead);
                }
            });
        }
        for (k, &(line_number, line)) in lines.iter().enumerate() {
            lookahead.starting(k);
            let words: Vec<&str> = line.split_whitespace().collect();
            count.run += 1;
            let failure = match cli::parse_args(&words).and_then(|c| validate::check(&c).map(|()| c)) {
                Ok(Command::Render(args)) if !args.writes_something() => {
                    let notice = preview_notice(&args, BATCH_OPENS_NO_WINDOW).expect("-gui, with nothing to write");
                    tell(line_number, LineReport::Notice(notice));
                    None
                }
                Ok(Command::Render(args)) => match run(&args, backend, false) {
                    Ok(done) => {
                        let ms = done.parse_ms + done.render_ms + done.write_ms;
                        if let Some(notice) = preview_notice(&args, BATCH_OPENS_NO_WINDOW).filter(|_| !preview_told) {
                            preview_told = true;
                            tell(line_number, LineReport::Notice(notice));
                        }
                        done.warnings.into_iter().for_each(|w| tell(line_number, LineReport::Warning(w)));
                        if let Some(fallback) = done.notice.clone() {
                            tell(line_number, LineReport::Fallback(fallback));
                        }
                        if args.stats {
                            let seconds = (done.render_ms + done.write_ms) / 1e3;
                            tell(line_number, LineReport::Stats(stats_text(&args, &done.stats, seconds)));
                        }
                        tell(line_number, LineReport::Rendered { ms, by_reference: done.handed_over.is_some() });
                        None
                    }
                    Err(e) => Some(e.to_string()),
                },
                Ok(_) => Some("only render command lines can be batched".into()),
                Err(e) => Some(e.0),
            };
            if let Some(failure) = failure {
                count.failed += 1;
                tell(line_number, LineReport::Failure(failure));
            }
            bar.advance(1);
        }
        lookahead.finish();
    });
    count
}

/// Threads that compile a batch's next kernels: one per core, at most
/// [`MAX_COMPILING_THREADS`].
fn compiling_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()).min(MAX_COMPILING_THREADS)
}

/// Enough to compile a batch's few distinct kernels at once (assignment 4's lines need 6), few
/// enough that scenes loaded ahead stay few.
const MAX_COMPILING_THREADS: usize = 4;

/// How far past the line rendering the compiling threads take lines: past a run of lines that
/// share a kernel (assignment 4's six `-bounces` of one scene) to the next kernels, while
/// the kernels compiled ahead stay few beside the renderer's cache of kernels. A line whose
/// kernel is known costs a thread its parsing and plan only.
const LINES_AHEAD: usize = 8;

/// Compiles the GPU kernel a batch's `line` will need, where it is a render the GPU would
/// run ([`Renderer::precompile`]); a line that does not parse or load is left for its turn
/// to report.
fn precompile_line(line: &str, backend: &Renderer, ahead: &raycaster::gpu::Ahead<'_>) {
    let words: Vec<&str> = line.split_whitespace().collect();
    let Ok(Command::Render(args)) = cli::parse_args(&words) else { return };
    if !args.writes_something() {
        return;
    }
    let Ok((scene, _)) = load(&args) else { return };
    backend.precompile(ahead, &scene, &options_for(&args), !reads_floats(&OutputFile::list(&args.files)));
}

/// Whether a render writing `outputs` reads floats back (an EXR file of colour or normals
/// among them), else 8-bit images the kernel quantises and the distances' own bits (which
/// a depth EXR holds as they are).
fn reads_floats(outputs: &[OutputFile]) -> bool {
    outputs.iter().any(|o| o.format == ImageFormat::Exr && o.output != Output::Depth)
}

#[cfg(test)]
mod tests {
    use super::*;
    use raycaster::metrics::ImageDiff;
    use raycaster::render::Output;

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
