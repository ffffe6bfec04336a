//! The `raycaster` command: parses the command line and hands it to the library.

mod app;

use app::backend::Backend;
use app::cli::{self, BackendChoice, Command, RenderArgs};
use std::process::ExitCode;

fn main() -> ExitCode {
    give_mesa_a_runtime_dir();
    match cli::parse_args(std::env::args_os().skip(1)) {
        Ok(Command::Help) => {
            println!("{}", cli::USAGE);
            ExitCode::SUCCESS
        }
        Ok(Command::Render(args)) => render(&args),
        Ok(Command::Compare { args, max_diff_pixels }) => compare(&args, max_diff_pixels),
        Ok(Command::Batch { file, backend, shard }) => batch(&file, backend, shard),
        Ok(Command::Stitch(stitch_args)) => stitch(&stitch_args),
        Ok(Command::Bench(bench_args)) => bench(&bench_args),
        Err(e) => {
            eprintln!("raycaster: {e}");
            ExitCode::from(2)
        }
    }
}

fn render(args: &RenderArgs) -> ExitCode {
    let Some(backend) = open_backend(args.backend) else { return ExitCode::FAILURE };
    match app::job::run(args, &backend) {
        Ok(warnings) => {
            warn(&warnings);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            ExitCode::FAILURE
        }
    }
}

fn compare(args: &RenderArgs, max_diff_pixels: Option<u64>) -> ExitCode {
    let Some(Backend::Gpu(gpu)) = open_backend(BackendChoice::Gpu) else { return ExitCode::FAILURE };
    match app::job::compare(args, &gpu) {
        Ok(comparison) => {
            warn(&comparison.warnings);
            println!(
                "gpu ({}) against the f64 reference ({} triangles, {} spheres):",
                gpu.adapter_info().name,
                args.triangle_test.name(),
                args.sphere_test.name()
            );
            print!("{}", raycaster::metrics::errors_table(&comparison.errors));
            if comparison.passes(max_diff_pixels) {
                ExitCode::SUCCESS
            } else {
                eprintln!("raycaster: compare: the GPU's result exceeds the limit or holds NaN/infinity");
                ExitCode::FAILURE
            }
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            ExitCode::FAILURE
        }
    }
}

fn batch(file: &std::path::Path, choice: BackendChoice, shard: Option<app::split::Split>) -> ExitCode {
    let text = match std::fs::read_to_string(file) {
        Ok(text) => text,
        Err(e) => {
            eprintln!("raycaster: {}: {e}", file.display());
            return ExitCode::FAILURE;
        }
    };
    let Some(backend) = open_backend(choice) else { return ExitCode::FAILURE };
    let (warnings, failures) = app::job::run_batch(&text, &backend, shard);
    warn(&warnings);
    for f in &failures {
        eprintln!("raycaster: {}:{}: {}", file.display(), f.line, f.message);
    }
    if failures.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// `raycaster stitch`: every problem found is one line of its own.
fn stitch(args: &cli::StitchArgs) -> ExitCode {
    match app::split::stitch(args) {
        Ok(_) => ExitCode::SUCCESS,
        Err(app::split::Refusal(problems)) => {
            for p in problems {
                eprintln!("raycaster: stitch: {p}");
            }
            ExitCode::FAILURE
        }
    }
}

fn bench(args: &cli::BenchArgs) -> ExitCode {
    use app::bench;
    let Some(Backend::Gpu(gpu)) = open_backend(BackendChoice::Gpu) else { return ExitCode::FAILURE };
    let cases = match bench::standard_cases(&args.corpus, args.quick) {
        Ok(cases) => cases
            .into_iter()
            .filter(|c| args.only.as_ref().is_none_or(|o| c.name.contains(o.as_str())))
            .collect::<Vec<_>>(),
        Err(e) => {
            eprintln!("raycaster: bench: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut rows = Vec::new();
    for case in &cases {
        eprintln!("bench: {} {}×{} ({})", case.name, case.width, case.height, case.triangle_test.name());
        match bench::run_case(&gpu, case, args.runs) {
            Ok(row) => rows.push(row),
            Err(e) => {
                eprintln!("raycaster: bench: {}: {e}", case.name);
                return ExitCode::FAILURE;
            }
        }
    }
    print!("{}", bench::markdown(&rows, &gpu.adapter_info().name));
    let written = std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("{}: {e}", args.out.display()))
        .and_then(|()| std::fs::write(args.out.join("bench.csv"), bench::csv(&rows)).map_err(|e| e.to_string()))
        .and_then(|()| write_plot(&rows, &args.out));
    match written {
        Ok(()) => {
            eprintln!(
                "bench: wrote {}/bench.csv{}",
                args.out.display(),
                if cfg!(feature = "plot") { " and bench.png" } else { "" }
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("raycaster: bench: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(feature = "plot")]
fn write_plot(rows: &[app::bench::Row], out: &std::path::Path) -> Result<(), String> {
    app::bench::plot(rows, &out.join("bench.png")).map_err(|e| e.to_string())
}

/// Built without the `plot` feature: the table and the CSV only.
#[cfg(not(feature = "plot"))]
fn write_plot(_: &[app::bench::Row], _: &std::path::Path) -> Result<(), String> {
    Ok(())
}

fn open_backend(choice: BackendChoice) -> Option<Backend> {
    match Backend::open(choice) {
        Ok((backend, notice)) => {
            if let Some(notice) = notice {
                eprintln!("raycaster: {notice}");
            }
            Some(backend)
        }
        Err(e) => {
            eprintln!("raycaster: {e}");
            None
        }
    }
}

fn warn(warnings: &[String]) {
    for w in warnings {
        eprintln!("raycaster: warning: {w}");
    }
}
/// Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" on every start when
/// the variable is missing (headless machines, CI). Point it at a private folder of ours
/// before any thread exists, so the message does not bury our own.
fn give_mesa_a_runtime_dir() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("raycaster-runtime-{}", user_id()));
    if make_private_dir(&dir).is_ok() {
        std::env::set_var("XDG_RUNTIME_DIR", dir);
    }
}

#[cfg(unix)]
fn user_id() -> u32 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").map(|m| m.uid()).unwrap_or(0)
}

#[cfg(not(unix))]
fn user_id() -> u32 {
    0
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

#[cfg(not(unix))]
fn make_private_dir(_: &std::path::Path) -> std::io::Result<()> {
    Err(std::io::Error::other("unused"))
}
