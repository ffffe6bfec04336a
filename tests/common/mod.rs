//! Shared test support: where the course corpus lives, the GPU (opened once per test binary,
//! failing loudly when absent), and pixel comparisons.
#![allow(dead_code)]

pub mod bin;
pub mod hard;
pub mod occlusion;
pub mod spawn_gap;

use raycaster::gpu::GpuRenderer;
use std::io::Write as _;
use std::path::PathBuf;
use std::sync::{Once, OnceLock};

/// The course's files (`a2/`, `meshes/`): `$RAYCASTER_CORPUS`, else `../shared/mit6837`
/// beside the crate. They are not part of the repository, so a bare clone has none: then
/// this prints one notice per test binary and returns `None`, and the test skips. With
/// `RAYCASTER_REQUIRE_CORPUS=1` (CI sets it) a missing corpus fails the test instead.
pub fn corpus() -> Option<PathBuf> {
    let dir = match std::env::var_os("RAYCASTER_CORPUS") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/mit6837"),
    };
    if dir.join("a2").is_dir() {
        return Some(dir);
    }
    let why = format!("no course files in {} (set RAYCASTER_CORPUS to their folder)", dir.display());
    if std::env::var("RAYCASTER_REQUIRE_CORPUS").as_deref() == Ok("1") {
        panic!("{why}, and RAYCASTER_REQUIRE_CORPUS=1 requires them");
    }
    static NOTICE: Once = Once::new();
    NOTICE.call_once(|| {
        // Straight to the stream: the test harness captures eprintln! of passing tests.
        let _ = writeln!(std::io::stderr(), "SKIPPED: the tests that need the course's files: {why}");
    });
    None
}

/// SplitMix64 (Steele, Lea & Flood 2014), one step: deterministic random test inputs that
/// replay.
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The project's own scenes.
/// A texture of `size` a pass can copy onto and a test can copy from.
pub fn texture(gpu: &GpuRenderer, (width, height): (u32, u32), format: wgpu::TextureFormat) -> wgpu::Texture {
    gpu.device().create_texture(&wgpu::TextureDescriptor {
        label: Some("target"),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

pub fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// The GPU renderer, or `None` when `RAYCASTER_SKIP_GPU=1` is set on purpose and no adapter
/// exists. Without that variable a missing adapter fails the test: a skipped GPU test must
/// never pass for a run one.
pub fn gpu() -> Option<&'static GpuRenderer> {
    static GPU: OnceLock<Result<GpuRenderer, String>> = OnceLock::new();
    match GPU.get_or_init(|| GpuRenderer::new().map_err(|e| e.to_string())) {
        Ok(gpu) => Some(gpu),
        Err(e) if std::env::var("RAYCASTER_SKIP_GPU").as_deref() == Ok("1") => {
            eprintln!("SKIPPED (RAYCASTER_SKIP_GPU=1): {e}");
            None
        }
        Err(e) => panic!("GPU test without a GPU adapter: {e}\nInstall lavapipe (apt-get install mesa-vulkan-drivers), or set RAYCASTER_SKIP_GPU=1 to skip on purpose."),
    }
}

/// The float frame `gpu` renders, tile by tile, with its statistics (the pixels its driver
/// cut short among them).
pub fn render_gpu_tiles(
    gpu: &GpuRenderer,
    scene: &raycaster::scene::Scene,
    options: &raycaster::render::RenderOptions,
) -> (raycaster::render::Frame, raycaster::render::RenderStats) {
    let mut frame = raycaster::render::Frame::new(options);
    let stats = gpu
        .render_tiles(scene, options, |first_row, tile| {
            frame.paste(first_row, &tile);
            Ok::<(), raycaster::gpu::GpuError>(())
        })
        .expect("the GPU renders the scene");
    (frame, stats)
}

/// The GPU renderer on the same device, finding candidates as `acceleration` says.
pub fn gpu_with(acceleration: raycaster::gpu::Acceleration) -> Option<GpuRenderer> {
    gpu()
        .map(|g| g.on_same_device(raycaster::gpu::GpuOptions { acceleration, ..raycaster::gpu::GpuOptions::default() }))
}

/// The GPU renderer on the same device with bins, each lane loading its own items
/// (`main_bins`, as on real GPUs) even where the lanes of a bin could share them
/// (`main_bins_shared`, lavapipe): the tests cover both walks on one machine.
pub fn gpu_with_own_bin_loads() -> GpuRenderer {
    let options = raycaster::gpu::GpuOptions {
        acceleration: raycaster::gpu::Acceleration::Bins,
        shared_bin_loads: false,
        ..raycaster::gpu::GpuOptions::default()
    };
    let own = gpu().expect("a GPU adapter").on_same_device(options);
    assert!(!own.shares_bin_loads());
    own
}

/// Every way the kernel can find candidates, `auto` first, so that a test over all of them
/// covers the bins and the hierarchy whatever the cost model picks at the test's sizes.
pub const ACCELERATIONS: [raycaster::gpu::Acceleration; 3] =
    [raycaster::gpu::Acceleration::Auto, raycaster::gpu::Acceleration::Bins, raycaster::gpu::Acceleration::Hierarchy];

/// Copies the files of the course's `folder` (`a2`, `a3`, …) into `to`, where its
/// `commands.txt` lines run as the course runs them.
pub fn copy_course_folder(corpus: &std::path::Path, folder: &str, to: &std::path::Path) {
    for entry in std::fs::read_dir(corpus.join(folder)).expect("the course's folder is readable") {
        let path = entry.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
        }
    }
}

/// The command lines of the course's `folder/commands.txt`, split at spaces.
pub fn course_commands(corpus: &std::path::Path, folder: &str) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(corpus.join(folder).join("commands.txt")).unwrap();
    text.lines().filter(|l| !l.trim().is_empty()).map(|l| l.split_whitespace().map(String::from).collect()).collect()
}

/// The course's images are matched when at most this share of an image's pixels is more
/// than one level off in some channel.
pub const MAX_OFF_FRACTION: f64 = 0.001;

/// Runs one of the course's command lines in `dir` with `--backend backend`, failing the
/// test with the command's stderr when it fails.
pub fn run_course_line(dir: &std::path::Path, command: &[String], backend: &str) {
    let output = bin::command().args(command).args(["--backend", backend]).current_dir(dir).output().unwrap();
    assert!(output.status.success(), "{}: {}", command.join(" "), String::from_utf8_lossy(&output.stderr));
}

/// Our image `ours` against the course's `sample`: prints a line for `name`, and returns
/// the failure when more than [`MAX_OFF_FRACTION`] of its pixels are more than 1 level off.
pub fn against_sample(ours: &std::path::Path, sample: &std::path::Path, name: &str) -> Option<String> {
    let ours = raycaster::image_io::read_image(ours).unwrap();
    let sample = raycaster::image_io::read_image(sample).unwrap();
    let diff = raycaster::metrics::image_diff(&ours, &sample);
    let off = format!("{} of {} pixels off by more than 1 level", diff.off_by_more_than_one, diff.pixels);
    println!("  {name:<22} {off}  (max diff {})", diff.max);
    (diff.off_by_more_than_one as f64 > MAX_OFF_FRACTION * diff.pixels as f64).then(|| format!("{name}: {off}"))
}

/// The course's command lines of `folder`, each run as written (plus `extra` lines built
/// from them) inside two copies of the folder, once with `--backend cpu` and once with
/// `--backend gpu`. For every line with an `-output`: both images against the course's
/// sample where `expected/` holds one, and the GPU's against the reference's, each within
/// [`MAX_OFF_FRACTION`]. Returns the failures and
/// the names of the samples compared.
pub fn course_lines_on_both_backends(
    corpus: &std::path::Path,
    folder: &str,
    lines: &[Vec<String>],
) -> (Vec<String>, Vec<String>) {
    let (cpu, gpu) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    copy_course_folder(corpus, folder, cpu.path());
    copy_course_folder(corpus, folder, gpu.path());
    let (mut failures, mut samples) = (Vec::new(), Vec::new());
    for command in lines {
        run_course_line(cpu.path(), command, "cpu");
        if self::gpu().is_some() {
            run_course_line(gpu.path(), command, "gpu");
        }
        let Some(k) = command.iter().position(|a| a == "-output") else { continue };
        let image = &command[k + 1];
        let stem = image.trim_end_matches(".tga");
        let sample = corpus.join(format!("{folder}/expected/{stem}.png"));
        if sample.exists() {
            failures.extend(against_sample(&cpu.path().join(image), &sample, stem));
            if self::gpu().is_some() {
                failures.extend(against_sample(&gpu.path().join(image), &sample, &format!("{stem} (GPU)")));
            }
            samples.push(stem.to_string());
        }
        if self::gpu().is_some() {
            let name = format!("{stem} (GPU against the reference)");
            failures.extend(against_sample(&gpu.path().join(image), &cpu.path().join(image), &name));
        }
    }
    (failures, samples)
}
