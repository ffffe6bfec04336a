//! The command: a parsed command line dispatched to the layers below, and the process's
//! settings for Mesa's drivers. The binary (`src/main.rs`) is [`run`] between its interrupt
//! handlers and its exit status; the Python package compiles this module too, so that
//! `raycaster.run(...)` writes the bytes the binary writes.

use crate::app::args::{
    BackendChoice, BenchArgs, Command, GalleryArgs, GradeArgs, Habits, RenderArgs, Split, StitchArgs, Verbosity,
};
use crate::app::exit::{self, say, Failure};
use crate::app::job::LineReport;
use raycaster::render::Outputs;
use raycaster::renderer::{auto, Renderer};
use raycaster::scene::SceneWarning;

/// Runs one command line (the words after the program's name) to its end: what the binary
/// does between installing its interrupt handlers and exiting with [`exit::report`]'s status.
/// It installs no handler itself, so that a host process (the Python package) keeps its own.
pub fn run(args: impl IntoIterator<Item = std::ffi::OsString>) -> Result<(), Failure> {
    let line = crate::app::cli::parse_command_line(args)?;
    crate::app::validate::check(&line.command)?;
    let habits = line.habits;
    if let Some(threads) = habits.threads {
        // Before anything uses rayon: the reference's rows run on the global pool.
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .map_err(|e| Failure::Failed(format!("--threads {threads}: {e}")))?;
    }
    match line.command {
        Command::Help => exit::print(&format!("{}\n", crate::app::flags::usage())),
        Command::Version => exit::print(&format!("raycaster {}\n", env!("CARGO_PKG_VERSION"))),
        Command::Render(args) => render(&args, habits),
        Command::Compare { args, outputs, max_diff_pixels } => compare(&args, outputs, max_diff_pixels, habits),
        Command::Batch { file, backend, shard } => batch(&file, backend, shard, habits),
        Command::Stitch(stitch_args) => stitch(&stitch_args, habits),
        Command::Bench(bench_args) => bench(&bench_args, habits),
        Command::Grade(grade_args) => grade(&grade_args, habits),
        Command::Gallery(gallery_args) => gallery(&gallery_args, habits),
        Command::Selftest => selftest(),
    }
}

fn render(args: &RenderArgs, habits: Habits) -> Result<(), Failure> {
    let progress = habits.verbosity != Verbosity::Quiet;
    let no_window = if args.gui { show_live(args, habits)? } else { Some(String::new()) };
    let Some(no_window) = no_window else {
        return Ok(()); // The window was shown, and closed.
    };
    if let Some(preview) = crate::app::job::preview_notice(args, &no_window).filter(|_| progress) {
        say(&format!("note: {preview}"));
    }
    if !args.writes_something() {
        return Ok(()); // `-gui` alone: the notice said so.
    }
    let options = crate::app::job::options_for(args);
    let (backend, report) = if args.backend == BackendChoice::Auto && !auto::samples_alone_open_the_gpu(&options) {
        // The scene first: a job small enough is rendered by the reference at once, without
        // paying for the GPU's start-up.
        let (scene, parse_ms) = crate::app::job::load(args)?;
        let (backend, fallback) = Renderer::open_for(args.backend, &scene, &options)?;
        say_fallback(fallback, habits);
        let report = crate::app::job::run_loaded(scene, parse_ms, args, &backend, progress)?;
        (backend, report)
    } else {
        // The scene is read while the device opens. The errors come in the order of before,
        // when one followed the other: `auto`'s scene first, a chosen backend's device first.
        let (opened, loaded) = std::thread::scope(|scope| {
            let loading = scope.spawn(|| crate::app::job::load(args));
            let opened = Renderer::open(args.backend);
            (opened, loading.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
        });
        let ((backend, fallback), (scene, parse_ms)) = match args.backend {
            BackendChoice::Auto => {
                let loaded = loaded?;
                (opened?, loaded)
            }
            _ => (opened?, loaded?),
        };
        say_fallback(fallback, habits);
        // `auto` opened the GPU for the job's size; a scene with nothing in it goes to the
        // reference all the same, as `Renderer::open_for` would have sent it.
        let backend = match backend {
            _ if args.backend == BackendChoice::Auto && auto::reference_is_quicker(&scene, &options) => Renderer::Cpu,
            backend => backend,
        };
        let report = crate::app::job::run_loaded(scene, parse_ms, args, &backend, progress)?;
        (backend, report)
    };
    say_warnings(&report.warnings, habits);
    if let Some(fallback) = report.notice.as_ref().filter(|_| habits.verbosity != Verbosity::Quiet) {
        say(&format!("warning: {fallback}"));
    }
    if habits.verbosity == Verbosity::Verbose {
        report.verbose_lines(&backend, args).iter().for_each(|line| say(line));
    }
    if args.stats {
        let seconds = (report.render_ms + report.write_ms) / 1e3;
        exit::print(&crate::app::job::stats_text(args, &report.stats, seconds))?;
    }
    Ok(())
}

/// `-gui`: the render live in a window (src/app/window) until it is closed; `None` then,
/// else why no window opened, and the line renders as without `-gui`.
#[cfg(feature = "gui")]
fn show_live(args: &RenderArgs, habits: Habits) -> Result<Option<String>, Failure> {
    if args.tile.is_some() {
        return Ok(Some("a --tile part is rendered without one".into()));
    }
    if let Some(why) = crate::app::window::no_display() {
        return Ok(Some(why));
    }
    let (scene, _) = crate::app::job::load(args)?;
    say_warnings(&scene.warnings, habits);
    match crate::app::window::show(args, scene, habits.verbosity == Verbosity::Verbose)? {
        crate::app::window::Shown::Closed => Ok(None),
        crate::app::window::Shown::NoWindow(why) => Ok(Some(why)),
    }
}

#[cfg(not(feature = "gui"))]
fn show_live(_: &RenderArgs, _: Habits) -> Result<Option<String>, Failure> {
    Ok(Some("built without the gui feature".into()))
}

fn compare(args: &RenderArgs, outputs: Outputs, max_diff_pixels: Option<u64>, habits: Habits) -> Result<(), Failure> {
    let gpu = open_gpu()?;
    let comparison = crate::app::job::compare(args, outputs, &gpu)?;
    say_warnings(&comparison.warnings, habits);
    exit::print(&format!(
        "gpu ({}) against the f64 reference ({} triangles, {} spheres):\n{}",
        gpu.adapter_info().name,
        args.triangle_test.name(),
        args.sphere_test.name(),
        raycaster::metrics::errors_table(&comparison.errors)
    ))?;
    comparison.verdict(max_diff_pixels).map_err(Failure::Failed)
}

fn batch(file: &std::path::Path, choice: BackendChoice, shard: Option<Split>, habits: Habits) -> Result<(), Failure> {
    let text = std::fs::read_to_string(file).map_err(|e| Failure::Failed(format!("{}: {e}", file.display())))?;
    let backend = open_renderer(choice, habits)?;
    let located = |line: usize, report: &LineReport| format!("{}:{line}: {report}", file.display());
    // `--verbose`'s time of each line, printed after the batch.
    let mut timings = Vec::new();
    let count =
        crate::app::job::run_batch(&text, &backend, shard, habits.verbosity != Verbosity::Quiet, |line, report| {
            match report {
                LineReport::Warning(_) | LineReport::Fallback(_) | LineReport::Notice(_)
                    if habits.verbosity == Verbosity::Quiet => {}
                LineReport::Rendered { .. } if habits.verbosity == Verbosity::Verbose => {
                    timings.push(located(line, &report))
                }
                LineReport::Rendered { .. } => {}
                // The course prints its statistics on stdout; nothing else goes there.
                LineReport::Stats(text) => {
                    let _ = exit::print(&text);
                }
                _ => say(&located(line, &report)),
            }
        });
    if habits.verbosity == Verbosity::Verbose {
        say(&format!("backend: {}", backend.describe()));
        timings.iter().for_each(|line| say(line));
        say(&format!("memory: {}", crate::app::memory::describe_peak()));
    }
    if count.failed > 0 {
        return Err(Failure::Failed(format!(
            "{}: {} of {} command lines failed",
            file.display(),
            count.failed,
            count.run
        )));
    }
    Ok(())
}

/// `raycaster stitch`: every problem found is one line of its own; the last is the failure
/// `main` reports.
fn stitch(args: &StitchArgs, habits: Habits) -> Result<(), Failure> {
    let stitched = crate::app::stitch::stitch(args).map_err(|crate::app::stitch::Refusal(mut problems)| {
        let last = problems.pop().unwrap_or_default();
        for p in problems {
            say(&format!("stitch: {p}"));
        }
        Failure::Failed(format!("stitch: {last}"))
    })?;
    if habits.verbosity == Verbosity::Verbose {
        say(&format!("stitch: {stitched} parts"));
    }
    Ok(())
}

fn bench(args: &BenchArgs, habits: Habits) -> Result<(), Failure> {
    use crate::app::bench;
    let gpu = open_gpu()?;
    let failed = |e: &dyn std::fmt::Display| Failure::Failed(format!("bench: {e}"));
    let cases = bench::standard_cases(&args.corpus, args.quick)
        .map_err(|e| failed(&e))?
        .into_iter()
        .filter(|c| args.only.as_ref().is_none_or(|o| c.name.contains(o.as_str())))
        .collect::<Vec<_>>();
    let quiet = habits.verbosity == Verbosity::Quiet;
    let mut rows = Vec::new();
    for case in &cases {
        if !quiet {
            say(&format!("bench: {} {}×{} ({})", case.name, case.width, case.height, case.triangle_test.name()));
        }
        rows.push(bench::run_case(&gpu, case, args.runs).map_err(|e| failed(&format!("{}: {e}", case.name)))?);
    }
    exit::print(&bench::markdown(&rows, &gpu.adapter_info().name))?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: {e}", args.out.display()))
        .and_then(|()| std::fs::write(args.out.join("bench.csv"), bench::csv(&rows)).map_err(|e| e.to_string()))
        .and_then(|()| write_plot(&rows, &args.out))
        .map_err(|e| failed(&e))?;
    if !quiet {
        say(&format!(
            "bench: wrote {}/bench.csv{}",
            args.out.display(),
            if cfg!(feature = "plot") { " and bench.png" } else { "" }
        ));
    }
    Ok(())
}

/// `raycaster grade`: the report on stdout (and the page), then the verdict: 1 when any
/// image fails or is missing.
fn grade(args: &GradeArgs, habits: Habits) -> Result<(), Failure> {
    let backend = open_renderer(args.backend, habits)?;
    let quiet = habits.verbosity == Verbosity::Quiet;
    let verbose = habits.verbosity == Verbosity::Verbose;
    let report = crate::app::grade::grade(args, &backend, !quiet, verbose)?;
    exit::print(&crate::app::grade::report(&report))?;
    let (count, failed) = (report.graded.len(), report.graded.iter().filter(|g| !g.passed()).count());
    crate::app::grade::write_html(report, args).map_err(|e| Failure::Failed(format!("grade: {e}")))?;
    if let Some(html) = args.html.as_ref().filter(|_| !quiet) {
        say(&format!("grade: wrote {}", html.display()));
    }
    if count == 0 {
        return Err(Failure::Failed(format!(
            "grade: {}: no command line writes an image",
            args.assignment.join("commands.txt").display()
        )));
    }
    if failed > 0 {
        return Err(Failure::Failed(format!("grade: {failed} of {count} images do not pass")));
    }
    Ok(())
}

/// `raycaster gallery`: the page, and a line saying what it holds.
fn gallery(args: &GalleryArgs, habits: Habits) -> Result<(), Failure> {
    let backend = open_renderer(args.backend, habits)?;
    let quiet = habits.verbosity == Verbosity::Quiet;
    let count =
        crate::app::gallery::gallery(args, &backend, !quiet).map_err(|e| Failure::Failed(format!("gallery: {e}")))?;
    exit::print(&format!(
        "gallery: {} images ({} beside the course's own) in {}\n",
        count.images,
        count.with_course_image,
        args.html.display()
    ))?;
    if count.failed_lines > 0 {
        return Err(Failure::Failed(format!(
            "gallery: {} command lines failed to render (named on the page)",
            count.failed_lines
        )));
    }
    Ok(())
}

#[cfg(feature = "plot")]
fn write_plot(rows: &[crate::app::bench::Row], out: &std::path::Path) -> Result<(), String> {
    crate::app::bench::plot(rows, &out.join("bench.png")).map_err(|e| e.to_string())
}

/// Built without the `plot` feature: the table and the CSV only.
#[cfg(not(feature = "plot"))]
fn write_plot(_: &[crate::app::bench::Row], _: &std::path::Path) -> Result<(), String> {
    Ok(())
}

fn open_renderer(choice: BackendChoice, habits: Habits) -> Result<Renderer, Failure> {
    let (renderer, fallback) = Renderer::open(choice)?;
    say_fallback(fallback, habits);
    Ok(renderer)
}

/// `auto`'s notice that no GPU opened, unless `-q`.
fn say_fallback(fallback: Option<String>, habits: Habits) {
    if let Some(fallback) = fallback.filter(|_| habits.verbosity != Verbosity::Quiet) {
        say(&fallback);
    }
}

/// `raycaster selftest`: the table on stdout; exit 1 where a case is not faithful.
fn selftest() -> Result<(), Failure> {
    let gpu = open_gpu()?;
    let report = crate::app::selftest::run(&gpu);
    exit::print(&report.table)?;
    match report.failed {
        0 => Ok(()),
        n => Err(Failure::Failed(format!(
            "selftest: {n} of {} cases are not rendered faithfully by this GPU and driver",
            report.cases
        ))),
    }
}

fn open_gpu() -> Result<raycaster::gpu::GpuRenderer, Failure> {
    Ok(raycaster::gpu::GpuRenderer::new()?)
}

/// The scene's warnings, unless `-q`. Each is located as errors are
/// (`FILE:LINE:COL: warning: ...`, [`raycaster::scene::SceneWarning`]'s text).
fn say_warnings(warnings: &[SceneWarning], habits: Habits) {
    if habits.verbosity != Verbosity::Quiet {
        warnings.iter().for_each(|w| say(&w.to_string()));
    }
}

/// lavapipe (Mesa's CPU Vulkan driver) cuts each dispatch's workgroups into one contiguous
/// share per thread, a thread per core by default, and the dispatch lasts as long as its
/// slowest share: bands of an image are not equally busy, and a thread may start late. Two
/// shares per core let the cores that finish early take up the rest (docs/lavapipe.md, "A
/// dispatch is cut into one share per thread"; the measurements are in docs/performance.md,
/// "Measured design choices"). Set before any thread exists, unless the user chose; on one
/// core lavapipe runs dispatches on the calling thread, and other drivers do not read it.
pub fn split_lavapipe_dispatches_finer() {
    const LAVAPIPE_THREADS: &str = "LP_NUM_THREADS";
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if cores > 1 && std::env::var_os(LAVAPIPE_THREADS).is_none() {
        std::env::set_var(LAVAPIPE_THREADS, (2 * cores).to_string());
    }
}

/// Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" on every start when
/// the variable is missing (headless machines, CI). Point it at a private folder of ours
/// before any thread exists, so the message does not bury our own. (A freedesktop variable:
/// nothing reads it on Windows.)
#[cfg(unix)]
pub fn give_mesa_a_runtime_dir() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("raycaster-runtime-{}", user_id()));
    if make_private_dir(&dir).is_ok() {
        std::env::set_var("XDG_RUNTIME_DIR", dir);
    }
}

#[cfg(not(unix))]
pub fn give_mesa_a_runtime_dir() {}

/// The owner of the folders we create, on every Unix (macOS has no /proc/self to ask).
#[cfg(unix)]
fn user_id() -> u32 {
    // SAFETY: geteuid takes nothing and cannot fail.
    unsafe { libc::geteuid() }
}

#[cfg(unix)]
fn make_private_dir(dir: &std::path::Path) -> std::io::Result<()> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    match std::fs::DirBuilder::new().mode(0o700).create(dir) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            let meta = std::fs::metadata(dir)?;
            let ours = meta.is_dir() && meta.uid() == user_id() && meta.permissions().mode() & 0o077 == 0;
            if ours {
                Ok(())
            } else {
                Err(std::io::Error::other("not a private directory of ours"))
            }
        }
        Err(e) => Err(e),
    }
}
