//! The binary as a user runs it: exit statuses, one-line errors that name the flag or the
//! file:line:col, no image left behind by a failed run, TGA/PNG by extension, and the
//! backend choice when no GPU is present.

mod common;

use common::bin::{file_names, path_str, raycaster, raycaster_in, raycaster_without_gpu, stderr};
use std::path::Path;
use std::process::{Command, Output};

/// An 8×8 render of `scene` on the CPU, run in `dir`.
fn cpu_render_in(dir: &Path, scene: &Path, outputs: &[&str]) -> Output {
    let args = [&["-input", path_str(scene), "-size", "8", "8", "--backend", "cpu"], outputs].concat();
    raycaster_in(dir, &args)
}

/// The README's first command: a scene of ours rendered from the project root.
#[test]
fn renders_an_uncompressed_tga_like_the_course() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let result = raycaster(&[
        "-input",
        "scenes/spheres_ortho.txt",
        "-size",
        "64",
        "48",
        "-output",
        path_str(&out),
        "--backend",
        "cpu",
    ]);
    assert!(result.status.success(), "{}", stderr(&result));
    let bytes = std::fs::read(&out).unwrap();
    // TGA header: image type 2 (uncompressed true colour), 64×48, 24 bits per pixel.
    assert_eq!(bytes[2], 2, "image type");
    assert_eq!(u16::from_le_bytes([bytes[12], bytes[13]]), 64);
    assert_eq!(u16::from_le_bytes([bytes[14], bytes[15]]), 48);
    assert_eq!(bytes[16], 24, "bits per pixel");
    assert!(bytes.len() >= 18 + 64 * 48 * 3);
}

#[test]
fn png_by_extension() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("n.png");
    let result = raycaster(&[
        "--input",
        "scenes/spheres_ortho.txt",
        "--size",
        "10",
        "10",
        "--normals",
        path_str(&out),
        "--backend",
        "cpu",
    ]);
    assert!(result.status.success(), "{}", stderr(&result));
    assert_eq!(&std::fs::read(&out).unwrap()[1..4], b"PNG");
}

/// Mesh paths resolve from the scene's folder, whatever the working directory.
#[test]
fn mesh_paths_resolve_from_the_scene_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let scene = common::scenes_dir().join("mesh_octahedron.txt");
    let result = raycaster_in(
        dir.path(),
        &["-input", path_str(&scene), "-size", "20", "20", "-output", "o.tga", "--backend", "cpu"],
    );
    assert!(result.status.success(), "{}", stderr(&result));
    assert!(out.exists());
}

/// Bad arguments: status 2, one line naming the flag, and no file written.
#[test]
fn bad_arguments_exit_2_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let o = path_str(&out);
    let cases: [(&[&str], &str); 5] = [
        (&["-input", "scenes/spheres_ortho.txt", "-size", "0", "5", "-output", o], "-size"),
        (
            &["-input", "scenes/spheres_ortho.txt", "-size", "5", "5", "-output", o, "-depth", "3", "1", "d.tga"],
            "-depth",
        ),
        (&["-input", "scenes/spheres_ortho.txt", "-size", "5", "5", "-output", o, "-frobnicate"], "-frobnicate"),
        (&["-input", "scenes/spheres_ortho.txt", "-size", "5", "5"], "-output"),
        (&["-input", "scenes/spheres_ortho.txt", "-size", "5", "5", "-output", o, "--backend"], "--backend"),
    ];
    for (args, flag) in cases {
        let result = raycaster(args);
        let message = stderr(&result);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {message}");
        assert_eq!(message.trim_end().lines().count(), 1, "{args:?}: {message}");
        assert!(message.contains(flag), "{args:?}: {message}");
        assert!(!out.exists(), "{args:?} wrote an image");
    }
}

#[test]
fn help_exits_0() {
    let result = raycaster(&["--help"]);
    assert!(result.status.success());
    assert!(String::from_utf8_lossy(&result.stdout).contains("-shade_back"));
}

/// A broken scene: non-zero status, the message names file:line:col, no image written.
#[test]
fn bad_scene_names_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.txt");
    std::fs::write(&scene, "OrthographicCamera {\n  center 0 0 10\n  direction 0 0 -1\n  up 0 1 0\n  size two\n}\n")
        .unwrap();
    let out = dir.path().join("o.tga");
    let result =
        raycaster(&["-input", path_str(&scene), "-size", "5", "5", "-output", path_str(&out), "--backend", "cpu"]);
    let message = stderr(&result);
    assert_eq!(result.status.code(), Some(1), "{message}");
    assert!(message.contains(&format!("{}:5:8", scene.display())), "{message}");
    assert!(!out.exists());
}

/// When one of several images cannot be written, none is: all are encoded to temporary
/// files first and renamed only when every one is complete.
#[test]
fn no_image_is_written_when_another_fails() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("o.tga");
    let bad = dir.path().join("missing-folder/n.tga");
    let result = raycaster(&[
        "-input",
        "scenes/spheres_ortho.txt",
        "-size",
        "8",
        "8",
        "-output",
        path_str(&good),
        "-normals",
        path_str(&bad),
        "--backend",
        "cpu",
    ]);
    let message = stderr(&result);
    assert_eq!(result.status.code(), Some(1), "{message}");
    assert!(message.contains("missing-folder"), "{message}");
    assert!(!good.exists(), "the first image was written although the second failed");
    let leftovers = file_names(dir.path());
    assert!(leftovers.is_empty(), "temporary files left behind: {leftovers:?}");
}

/// With no Vulkan driver: `--backend gpu` fails with a message that says how to get one;
/// `--backend auto` renders on the CPU and says so on stderr. (The image is large enough
/// that `auto` does try the GPU: see the next test for small jobs.)
#[test]
fn without_an_adapter_gpu_fails_and_auto_falls_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let run = |backend| render_1500_without_gpu("scenes/spheres_ortho.txt", &out, backend);
    let gpu = run("gpu");
    assert_eq!(gpu.status.code(), Some(1), "{}", stderr(&gpu));
    assert!(stderr(&gpu).contains("no GPU adapter found"), "{}", stderr(&gpu));
    assert!(!out.exists());
    let auto = run("auto");
    assert!(auto.status.success(), "{}", stderr(&auto));
    assert!(stderr(&auto).contains("rendering with the CPU reference instead"), "{}", stderr(&auto));
    assert!(out.exists());
}

/// `scene` rendered at 1500² (large enough that `auto` opens the GPU for any scene) into
/// `out` with `backend`, where no Vulkan driver is found.
fn render_1500_without_gpu(scene: &str, out: &Path, backend: &str) -> Output {
    let size = "1500";
    raycaster_without_gpu(&["-input", scene, "-size", size, size, "-output", path_str(out), "--backend", backend])
}

/// Where the device opens while the scene is read (`--backend gpu`, and `auto` at a size
/// that puts any scene on the GPU), the errors come as when one followed the other: with no
/// adapter and a broken scene, `gpu` names the missing adapter and `auto` the scene's line
/// and column, without a fallback notice for a render that never happens; neither writes.
#[test]
fn a_device_opened_beside_the_scene_reports_errors_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.txt");
    std::fs::write(&scene, "OrthographicCamera {\n  center 0 0 10\n  size two\n}\n").unwrap();
    let out = dir.path().join("o.tga");
    let run = |backend| render_1500_without_gpu(path_str(&scene), &out, backend);
    let gpu = run("gpu");
    assert_eq!(gpu.status.code(), Some(1), "{}", stderr(&gpu));
    assert!(stderr(&gpu).contains("no GPU adapter found"), "{}", stderr(&gpu));
    let auto = run("auto");
    assert_eq!(auto.status.code(), Some(1), "{}", stderr(&auto));
    assert!(stderr(&auto).contains(&format!("{}:3:8", scene.display())), "{}", stderr(&auto));
    assert!(!stderr(&auto).contains("CPU reference"), "{}", stderr(&auto));
    assert!(!out.exists());
}

/// An empty scene at a size that opens the GPU beside the reading: `auto` renders it with
/// the reference, as it renders any job this small, and says nothing of the GPU.
#[test]
fn auto_sends_an_empty_scene_to_the_reference_at_any_size() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("empty.txt");
    std::fs::write(
        &scene,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 2 }\n\
         Background { color 0.2 0.4 0.6 }\nGroup { numObjects 0 }\n",
    )
    .unwrap();
    let out = dir.path().join("o.tga");
    let run = raycaster(&["-input", path_str(&scene), "-size", "1500", "1500", "-output", path_str(&out), "-v"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(stderr(&run).contains("backend: cpu"), "{}", stderr(&run));
    let image = raycaster::image_io::read_image(&out).unwrap();
    assert_eq!(image.get_pixel(700, 700).0, [51, 102, 153], "the background, floor(255·v)");
}

/// A tile size or a number of tiles in flight the variables ask for that we refuse is an
/// error naming the variable, with either GPU backend: `auto` does not hide it by rendering
/// with the reference. No GPU is needed: the settings are read before any adapter is looked
/// for.
#[test]
fn a_refused_tile_setting_is_an_error_not_a_fallback() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let refused = [
        (
            "RAYCASTER_TILE_MIB",
            "64",
            "RAYCASTER_TILE_MIB=\"64\": the tile's size is a whole number of MiB from 1 to 32",
        ),
        ("RAYCASTER_TILE_SLOTS", "0", "RAYCASTER_TILE_SLOTS=\"0\": the tiles in flight are a whole number from 1 to 8"),
    ];
    for (variable, value, said) in refused {
        for backend in ["gpu", "auto"] {
            let run = Command::new(env!("CARGO_BIN_EXE_raycaster"))
                .args(["-input", "scenes/spheres_ortho.txt", "-size", "1500", "1500", "-output", path_str(&out)])
                .args(["--backend", backend])
                .env(variable, value)
                .output()
                .unwrap();
            assert_eq!(run.status.code(), Some(1), "{backend}: {}", stderr(&run));
            assert!(stderr(&run).contains(said), "{}", stderr(&run));
            assert!(!stderr(&run).contains("CPU reference"), "{}", stderr(&run));
            assert!(!out.exists());
        }
    }
}

/// A job so small that the GPU's start-up would dominate (pixels × primitives at most
/// `REFERENCE_QUICKER_BELOW`) is rendered by `auto` with the reference without opening the
/// GPU at all: no driver is looked for, so none is missed, and the image is the reference's.
#[test]
fn auto_renders_small_jobs_with_the_reference_without_opening_the_gpu() {
    let dir = tempfile::tempdir().unwrap();
    let run = |backend: &str, size: &str, out: &str| {
        raycaster_without_gpu(&[
            "-input",
            "scenes/spheres_ortho.txt",
            "-size",
            size,
            size,
            "-output",
            out,
            "--backend",
            backend,
            "-v",
        ])
    };
    let auto = dir.path().join("auto.tga");
    let cpu = dir.path().join("cpu.tga");
    let small = run("auto", "64", path_str(&auto));
    assert!(small.status.success(), "{}", stderr(&small));
    assert!(!stderr(&small).contains("no GPU adapter"), "{}", stderr(&small));
    assert!(stderr(&small).contains("backend: cpu"), "{}", stderr(&small));
    assert!(run("cpu", "64", path_str(&cpu)).status.success());
    assert_eq!(std::fs::read(&auto).unwrap(), std::fs::read(&cpu).unwrap());
}

/// The GPU backend through the binary writes the same image as the reference.
#[test]
fn gpu_and_cpu_binaries_agree() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let images: Vec<_> = ["gpu", "cpu"]
        .iter()
        .map(|backend| {
            let out = dir.path().join(format!("{backend}.png"));
            let result = raycaster(&[
                "-input",
                "scenes/triangles.txt",
                "-size",
                "50",
                "40",
                "-output",
                path_str(&out),
                "--backend",
                backend,
            ]);
            assert!(result.status.success(), "{}", stderr(&result));
            raycaster::image_io::read_image(&out).unwrap()
        })
        .collect();
    let diff = raycaster::metrics::image_diff(&images[0], &images[1]);
    assert!(diff.off_by_more_than_one <= 2, "{diff:?}");
}

/// `batch` runs every line in one process; a bad line is reported with its number and the
/// others still run, and the exit status says something failed.
#[test]
fn batch_runs_every_line_and_reports_failures() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::canonicalize("scenes/spheres_ortho.txt").unwrap();
    let s = scene.to_str().unwrap();
    let commands = format!(
        "# a comment\n-input {s} -size 8 8 -output a.tga\n\n-input {s} -size 0 8 -output b.tga\n-input {s} -size 8 8 -normals c.png\n"
    );
    std::fs::write(dir.path().join("commands.txt"), commands).unwrap();
    let result = raycaster_in(dir.path(), &["batch", "commands.txt", "--backend", "cpu"]);
    let message = stderr(&result);
    assert_eq!(result.status.code(), Some(1), "{message}");
    assert!(message.contains("commands.txt:4: -size"), "{message}");
    assert!(message.ends_with("raycaster: commands.txt: 1 of 3 command lines failed\n"), "{message}");
    assert!(dir.path().join("a.tga").exists() && dir.path().join("c.png").exists());
    assert!(!dir.path().join("b.tga").exists());
}

/// The bench's quick version runs in seconds and writes a table, a CSV and a plot whose
/// rows carry both a speed and an error (so the bench cannot rot unnoticed), one of them an
/// A4 line whose rays are all counted, and one of 4 samples per pixel; the plot has its text.
#[test]
fn bench_quick_writes_table_csv_and_plot() {
    let Some(corpus) = common::corpus() else { return };
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let result =
        raycaster(&["bench", "--quick", "--runs", "1", "--out", path_str(dir.path()), "--corpus", path_str(&corpus)]);
    assert!(result.status.success(), "{}", stderr(&result));
    let table = String::from_utf8_lossy(&result.stdout);
    assert!(table.contains("| scene2_07_sphere_triangles |"), "{table}");
    let csv = std::fs::read_to_string(dir.path().join("bench.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 6, "{csv}");
    // Assignment 7: 4 jittered samples per pixel, every one a ray.
    let sampled = rows.iter().find(|r| r[0] == "bunny_1k_4spp").expect("a row of 4 samples per pixel");
    assert_eq!(sampled[column("rays")], (4 * 64 * 64).to_string(), "{sampled:?}");
    // The A4 line (a mirror sphere, 3 bounces, shadows) counts every ray, more than a
    // pixel's one, and times the reference on the whole image.
    let a4 = rows.iter().find(|r| r[0] == "output4_04d").expect("an A4 row");
    let (rays, pixels): (u64, u64) = (a4[column("rays")].parse().unwrap(), 64 * 64);
    assert!(rays > pixels && a4[column("reference_ms")].parse::<f64>().unwrap() > 0.0, "{a4:?}");
    assert_eq!(a4[column("samples")], "4096", "every pixel compared");
    for row in &rows {
        let mrays: f64 = row[column("mrays_per_s")].parse().unwrap();
        let off: f64 = row[column("off_by_more_than_one_fraction")].parse().unwrap();
        let samples: usize = row[column("samples")].parse().unwrap();
        assert!(mrays > 0.0 && mrays.is_finite(), "{row:?}");
        assert!(samples > 0 && off <= 0.001, "{row:?}");
        for warm in ["warm_frame_ms", "warm_rgb8_frame_ms", "moving_rgb8_frame_ms", "moving_presented_frame_ms"] {
            let ms: f64 = row[column(warm)].parse().unwrap();
            assert!(ms > 0.0 && ms.is_finite(), "{warm}: {row:?}");
        }
    }
    let png = std::fs::read(dir.path().join("bench.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The caption is drawn (from the font inside the binary): dark pixels in the band above
    // the chart, which is white but for it.
    let plot = raycaster::image_io::read_image(&dir.path().join("bench.png")).unwrap();
    let caption = (0..plot.width()).flat_map(|x| (0..35).map(move |y| (x, y)));
    let dark = caption.filter(|&(x, y)| plot.get_pixel(x, y).0.iter().all(|&c| c < 100)).count();
    assert!(dark > 200, "{dark} dark pixels where the caption's text should be");
}

/// `compare` holds the GPU to the parity contract by default (at most 0.1 % of an output's
/// pixels more than 1 level off, no NaN): the default kernel passes on the far sphere, the
/// textbook quadratic fails and the message names the output and the limit;
/// `--max-diff-pixels` overrides the limit. It needs no file names and writes no file.
#[test]
fn compare_fails_by_default_beyond_the_parity_limit() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard/far_sphere.txt");
    let compare = |extra: &[&str]| {
        raycaster_in(dir.path(), &[&["compare", "-input", path_str(&scene), "-size", "100", "100"], extra].concat())
    };
    let good = compare(&["--outputs", "color,normals"]);
    let table = String::from_utf8_lossy(&good.stdout);
    assert!(good.status.success(), "{}{}", table, stderr(&good));
    assert!(table.contains("| colour |") && table.contains("| normals |"), "{table}");

    // 100×100 pixels: the default limit is 10 per output (0.1 %).
    let bad = compare(&["--outputs", "normals", "--sphere-test", "naive"]);
    let message = stderr(&bad);
    assert_eq!(bad.status.code(), Some(1), "{message}");
    assert_eq!(message.trim_end().lines().count(), 1, "{message}");
    assert!(message.starts_with("raycaster: compare: normals: "), "{message}");
    assert!(
        message.contains("of 10000 pixels are more than 1 level off the reference; the limit is 10 (0.1 %)"),
        "{message}"
    );

    // The old form, file names and all, with the limit raised above the image's pixel count.
    let raised =
        compare(&["-output", "o.tga", "-normals", "n.tga", "--sphere-test", "naive", "--max-diff-pixels", "10000"]);
    assert!(raised.status.success(), "{}", stderr(&raised));
    let limited = compare(&["-output", "o.tga", "--sphere-test", "naive", "--max-diff-pixels", "3"]);
    assert!(
        stderr(&limited).contains("colour: ") && stderr(&limited).contains("the limit is 3 (--max-diff-pixels)"),
        "{}",
        stderr(&limited)
    );

    let written = file_names(dir.path());
    assert!(written.is_empty(), "compare wrote {written:?}");
}

/// `compare` refuses what does not apply to it, and needs something to compare.
#[test]
fn compare_refuses_flags_that_do_not_apply() {
    let cases: [(&[&str], &str); 3] = [
        (
            &[
                "compare",
                "-input",
                "scenes/spheres_ortho.txt",
                "-size",
                "5",
                "5",
                "--outputs",
                "color",
                "--backend",
                "cpu",
            ],
            "raycaster: compare: --backend does not apply",
        ),
        (&["compare", "-input", "scenes/spheres_ortho.txt", "-size", "5", "5"], "compare: nothing to compare"),
        (
            &["compare", "-input", "scenes/spheres_ortho.txt", "-size", "5", "5", "--outputs", "color,shadows"],
            "--outputs: 'shadows' is not one of color, normals, depth",
        ),
    ];
    for (args, needle) in cases {
        let result = raycaster(args);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {}", stderr(&result));
        assert!(stderr(&result).contains(needle), "{args:?}: {}", stderr(&result));
    }
}

/// Two outputs naming one file (as written, or through `./`): refused before anything is
/// rendered, status 2, and no file appears.
#[test]
fn two_outputs_naming_one_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::canonicalize("scenes/spheres_ortho.txt").unwrap();
    // Named in the order -output, -normals, -depth, whatever the command line's order.
    let cases = [
        (["-output", "same.tga", "-normals", "same.tga"], "-output same.tga and -normals same.tga"),
        (["-normals", "same.tga", "-output", "./same.tga"], "-output ./same.tga and -normals same.tga"),
    ];
    for (outputs, named) in cases {
        let result = cpu_render_in(dir.path(), &scene, &outputs);
        let message = stderr(&result);
        assert_eq!(result.status.code(), Some(2), "{message}");
        let expected =
            format!("raycaster: {named} name the same file: one image would replace the other (try --help)\n");
        assert_eq!(message, expected);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "{outputs:?} wrote a file");
    }
    let depth = cpu_render_in(dir.path(), &scene, &["-output", "d.tga", "-depth", "1", "2", "d.tga"]);
    assert_eq!(depth.status.code(), Some(2), "{}", stderr(&depth));
    assert!(stderr(&depth).contains("-output d.tga and -depth d.tga name the same file"), "{}", stderr(&depth));
}

/// An output that is a folder is called one, with or without a trailing slash.
#[test]
fn an_output_that_is_a_folder_is_called_one() {
    let dir = tempfile::tempdir().unwrap();
    for folder in [path_str(dir.path()).to_string(), format!("{}/", dir.path().display())] {
        let result = raycaster(&["-input", "scenes/spheres_ortho.txt", "-size", "8", "8", "-output", &folder]);
        let message = stderr(&result);
        assert_eq!(result.status.code(), Some(2), "{message}");
        assert!(message.contains(&format!("-output {folder}: names a folder; give an image file name")), "{message}");
        assert!(!message.contains("unsupported image format"), "{message}");
    }
}

/// An output in a folder that does not exist: the message names that folder, and no
/// temporary file name the user never asked for.
#[test]
fn a_missing_output_folder_is_named_without_temporary_names() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("missing/o.tga");
    let scene = std::fs::canonicalize("scenes/spheres_ortho.txt").unwrap();
    let result = cpu_render_in(dir.path(), &scene, &["-output", path_str(&out)]);
    let expected = format!(
        "raycaster: {}: cannot write there: the folder {} does not exist\n",
        out.display(),
        dir.path().join("missing").display()
    );
    assert_eq!(result.status.code(), Some(1));
    assert_eq!(stderr(&result), expected);
}

/// `raycaster --help | head -1`: a reader that has gone away is no error and no panic.
#[test]
fn a_closed_stdout_is_not_an_error() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let result = Command::new(env!("CARGO_BIN_EXE_raycaster")).arg("--help").stdout(writer).output().unwrap();
    assert_eq!(result.status.code(), Some(0), "{}", stderr(&result));
    assert_eq!(stderr(&result), "");
}

/// Warnings are located like errors: file:line:col, and in a batch the batch file's line too.
#[test]
fn warnings_name_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let unlit = dir.path().join("unlit.txt");
    std::fs::write(
        &unlit,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n\n  Lights { numLights 0 }\n",
    )
    .unwrap();
    // A second scene whose empty Lights block sits at line 2, column 1, after a Background.
    let shaded = dir.path().join("shaded.txt");
    std::fs::write(
        &shaded,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n\
         Lights { numLights 0 } Background { ambientLight 0.5 0.5 0.5 }\n",
    )
    .unwrap();
    let render = |scene: &Path| cpu_render_in(dir.path(), scene, &["-output", "o.tga"]);
    let result = render(&shaded);
    assert!(result.status.success(), "{}", stderr(&result));
    let shaded_warning = format!(
        "{}:2:1: warning: no lights: ambient light set to 1 1 1 (flat colour), replacing the file's ambientLight 0.5 0.5 0.5",
        shaded.display()
    );
    assert_eq!(stderr(&result), format!("raycaster: {shaded_warning}\n"));
    let result = render(&unlit);
    let unlit_warning =
        format!("{}:3:3: warning: no lights: ambient light set to 1 1 1 (flat colour)", unlit.display());
    assert_eq!(stderr(&result), format!("raycaster: {unlit_warning}\n"));

    let commands = format!(
        "\n-input {} -size 8 8 -output a.tga\n-input {} -size 8 8 -output b.tga\n",
        shaded.display(),
        unlit.display()
    );
    std::fs::write(dir.path().join("commands.txt"), commands).unwrap();
    let result = raycaster_in(dir.path(), &["batch", "commands.txt", "--backend", "cpu"]);
    assert!(result.status.success(), "{}", stderr(&result));
    assert_eq!(
        stderr(&result),
        format!("raycaster: commands.txt:2: {shaded_warning}\nraycaster: commands.txt:3: {unlit_warning}\n")
    );
}

/// Ctrl-C (SIGINT) or SIGTERM in the middle of a render, or of a batch, removes every
/// temporary file and exits 130 or 143. The CPU backend at 12000² takes long enough that
/// the signal arrives while both outputs are being written. (Windows' console events are
/// covered by the unit tests of src/app/signals.)
#[cfg(unix)]
#[test]
fn an_interrupted_render_leaves_nothing_behind() {
    for (signal, status, name) in [(libc::SIGINT, 130, "SIGINT"), (libc::SIGTERM, 143, "SIGTERM")] {
        for batch in [false, true] {
            let out = tempfile::tempdir().unwrap();
            let scene = std::fs::canonicalize("scenes/spheres_ortho.txt").unwrap();
            let line = format!("-input {} -size 12000 12000 -output a.tga -normals b.png", scene.display());
            let commands = tempfile::NamedTempFile::new().unwrap();
            std::fs::write(commands.path(), format!("{line}\n{line}\n")).unwrap();
            let mut command = Command::new(env!("CARGO_BIN_EXE_raycaster"));
            if batch {
                command.args(["batch", path_str(commands.path()), "--backend", "cpu"]);
            } else {
                command.args(line.split(' ')).args(["--backend", "cpu"]);
            }
            with_default_signals(&mut command);
            let child = command.current_dir(out.path()).stderr(std::process::Stdio::piped()).spawn().unwrap();
            wait_for_temporary_files(&child, out.path(), 2);
            // SAFETY: kill(2) on our own child's pid, which cannot have been reused: the child
            // is not waited for yet.
            assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
            let result = child.wait_with_output().unwrap();
            let what = format!("{name}, batch {batch}: {}", stderr(&result));
            assert_eq!(result.status.code(), Some(status), "{what}");
            assert_eq!(stderr(&result), format!("raycaster: interrupted by {name}\n"), "{what}");
            let left = file_names(out.path());
            assert!(left.is_empty(), "{what}: left behind {left:?}");
        }
    }
}

/// Gives the child the default actions for SIGINT and SIGTERM, whatever the test process
/// inherited: a child started with SIGINT ignored keeps it ignored, as `nohup` expects
/// (src/app/signals/unix.rs). One run of the suite, launched from a background job of a
/// non-interactive shell (which ignores SIGINT), saw the render run to its end and exit 0;
/// the same test run alone, even under `trap '' INT`, passed.
#[cfg(unix)]
fn with_default_signals(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    // SAFETY: the closure runs in the forked child before exec and calls only signal(2),
    // which is async-signal-safe.
    unsafe {
        command.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            libc::signal(libc::SIGTERM, libc::SIG_DFL);
            Ok(())
        });
    }
}

/// Waits until `count` temporary files of a render exist in `dir` (at most a minute).
#[cfg(unix)]
fn wait_for_temporary_files(child: &std::process::Child, dir: &Path, count: usize) {
    let start = std::time::Instant::now();
    loop {
        let temporary = std::fs::read_dir(dir)
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with(".raycaster-"))
            .count();
        if temporary >= count {
            return;
        }
        assert!(start.elapsed().as_secs() < 60, "no temporary files after a minute (child {})", child.id());
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// About 9 million pixels of the octahedron on one CPU thread: a few seconds here, well past
/// the second after which a progress bar may appear.
fn long_render(out: &Path) -> Vec<String> {
    ["--threads", "1", "--backend", "cpu", "-input", "scenes/mesh_octahedron.txt", "-size", "3000", "3000", "-output"]
        .iter()
        .map(|s| s.to_string())
        .chain([path_str(out).to_string()])
        .collect()
}

/// Scripts and the course's command lines stay quiet: with stderr a pipe, even a render that
/// lasts seconds prints nothing there.
#[test]
fn a_long_render_through_a_pipe_prints_nothing_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let args = long_render(&out);
    let result = raycaster(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(result.status.success(), "{}", stderr(&result));
    assert_eq!(stderr(&result), "");
    assert!(out.exists());
}

/// On a terminal (a pseudo-terminal from util-linux's `script`), the same render shows a bar
/// with rows done, the rate and the time left; `-q` shows none.
#[cfg(target_os = "linux")]
#[test]
fn a_long_render_on_a_terminal_shows_progress_unless_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let on_terminal = |extra: &str| {
        let command = format!("'{}' {extra} {}", env!("CARGO_BIN_EXE_raycaster"), long_render(&out).join(" "));
        // script copies what the command writes to its terminal onto its own stdout.
        let result = Command::new("script")
            .args(["-qec", &command, "/dev/null"])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("util-linux's script runs");
        assert!(result.status.success(), "{}", stderr(&result));
        String::from_utf8_lossy(&result.stdout).into_owned()
    };
    let shown = on_terminal("");
    assert!(shown.contains("/3000 rows, ") && shown.contains("/s, ") && shown.contains(" left"), "{shown:?}");
    let quiet = on_terminal("-q");
    assert_eq!(quiet, "", "-q printed on the terminal");
}

/// `-q` silences warnings and notices; errors still show.
#[test]
fn quiet_silences_warnings_but_not_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let base = ["-input", "scenes/no_lights.txt", "-size", "8", "8", "-output", path_str(&out), "--backend", "cpu"];
    let loud = raycaster(&base);
    assert!(loud.status.success() && stderr(&loud).contains("warning: no lights"), "{}", stderr(&loud));
    let quiet = raycaster(&[&base[..], &["-q"]].concat());
    assert!(quiet.status.success());
    assert_eq!(stderr(&quiet), "");
    let failed = raycaster(&["--quiet", "-input", "scenes/missing.txt", "-size", "8", "8", "-output", path_str(&out)]);
    assert_eq!(failed.status.code(), Some(1));
    assert!(stderr(&failed).contains("missing.txt"), "{}", stderr(&failed));
    // batch too.
    let commands = dir.path().join("commands.txt");
    std::fs::write(&commands, base.join(" ")).unwrap();
    let batch = raycaster(&["batch", path_str(&commands), "--backend", "cpu", "-q"]);
    assert!(batch.status.success(), "{}", stderr(&batch));
    assert_eq!(stderr(&batch), "");
}

/// The octahedrons (16 triangles: enough for a hierarchy) at 40×30 into `out`, with `flags`.
fn octahedron_40x30(out: &Path, flags: &[&str]) -> Output {
    let args = ["-input", "scenes/mesh_octahedron.txt", "-size", "40", "30", "-output", path_str(out)];
    raycaster(&[flags, &args[..]].concat())
}

/// `-v` on the CPU: the backend with its threads (as `--threads` set them), and where the time
/// and memory went; the image does not depend on the number of threads.
#[test]
fn verbose_and_threads_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let mut images = Vec::new();
    for threads in ["1", "3"] {
        let out = dir.path().join(format!("o{threads}.tga"));
        let result = octahedron_40x30(&out, &["-v", "--threads", threads, "--backend=cpu"]);
        let message = stderr(&result);
        assert!(result.status.success(), "{message}");
        let plural = if threads == "1" { "thread" } else { "threads" };
        assert!(message.contains(&format!("backend: cpu, the f64 reference on {threads} {plural}")), "{message}");
        for needle in ["time: parsing ", " ms, rendering ", " ms in 1 tile, writing ", "memory: peak resident "] {
            assert!(message.contains(needle), "{needle}: {message}");
        }
        images.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(images[0], images[1]);
    let bad = raycaster(&["--threads", "0", "-input", "scenes/triangles.txt", "-size", "8", "8", "-output", "o.tga"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("--threads: '0'"), "{}", stderr(&bad));
}

/// `-v` on the GPU: the adapter, the kernel variant, and the time of the kernel and of what
/// finds its candidates: the bins for primary rays alone, the hierarchy once shadow rays
/// need it.
#[test]
fn verbose_on_the_gpu_names_adapter_and_kernel() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    for (extra, built) in [(None, "; building the bins "), (Some("-shadows"), "; building the hierarchy ")] {
        let mut flags = vec!["--verbose", "--backend", "gpu", "--triangle-test", "moller"];
        flags.extend(extra);
        let result = octahedron_40x30(&out, &flags);
        let message = stderr(&result);
        assert!(result.status.success(), "{message}");
        assert!(message.contains(&format!("backend: gpu, {}", gpu.adapter_info().name)), "{message}");
        assert!(message.contains("kernel: moller triangle test, robust sphere test"), "{message}");
        let needles = ["time: parsing ", " (preparing ", built, ", writing ", "memory: peak resident ", "on the GPU"];
        for needle in needles {
            assert!(message.contains(needle), "{needle}: {message}");
        }
    }
}

#[test]
fn version_in_both_spellings() {
    for flag in ["--version", "-V"] {
        let result = raycaster(&[flag]);
        assert!(result.status.success());
        assert_eq!(String::from_utf8_lossy(&result.stdout), format!("raycaster {}\n", env!("CARGO_PKG_VERSION")));
    }
}

/// `--flag=value` for flags with one value; a mistyped flag gets the nearest one suggested.
#[test]
fn flag_equals_value_and_did_you_mean() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let ok = raycaster(&[
        "--input=scenes/spheres_ortho.txt",
        "-size",
        "8",
        "8",
        &format!("--output={}", path_str(&out)),
        "--backend=cpu",
    ]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    assert!(out.exists());
    let cases: [(&[&str], &str); 4] = [
        (&["-input", "scenes/spheres_ortho.txt", "-size", "8", "8", "-outptu", "o.tga"], "did you mean '-output'?"),
        (&["-input", "scenes/spheres_ortho.txt", "--size=8", "8", "-output", "o.tga"], "--size= is not supported"),
        (&["-input", "scenes/spheres_ortho.txt", "-size", "8", "8", "-output", "o.tga", "--shade-back=1"], "no value"),
        (&["batch", "c.txt", "--backedn", "cpu"], "did you mean '--backend'?"),
    ];
    for (args, needle) in cases {
        let result = raycaster(args);
        let message = stderr(&result);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {message}");
        assert_eq!(message.trim_end().lines().count(), 1, "{args:?}: {message}");
        assert!(message.contains(needle), "{args:?}: {message}");
    }
}

/// The course's assignment 3 lines carry `-gui`, `-tessellation θ φ` and `-gouraud`. Without
/// a display (these tests remove it) no window opens: one notice says why, and the image is
/// the one the line writes without them. `-gui` with no image flag then renders nothing,
/// says so and exits 0; a malformed `-tessellation` is a usage error.
#[test]
fn preview_flags_are_accepted_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::bin::scene("spheres_ortho.txt");
    let render = |extra: &[&str], image: &str| {
        let args =
            [&["-input", scene.as_str(), "-size", "16", "12", "-output", image, "--backend", "cpu"], extra].concat();
        raycaster_in(dir.path(), &args)
    };
    let plain = render(&[], "plain.tga");
    assert!(plain.status.success() && plain.stderr.is_empty(), "{}", stderr(&plain));
    let preview = render(&["-gui", "-tessellation", "100", "50", "-gouraud"], "preview.tga");
    assert!(preview.status.success(), "{}", stderr(&preview));
    assert_eq!(
        stderr(&preview),
        "raycaster: note: -gui: no window (no display: DISPLAY and WAYLAND_DISPLAY are unset); the files are \
         written as without it\n"
    );
    let ignored = render(&["-tessellation", "10", "5"], "ignored.tga");
    assert_eq!(
        stderr(&ignored),
        "raycaster: note: -tessellation and -gouraud shape only the course's OpenGL preview: ignored\n"
    );
    assert_eq!(
        std::fs::read(dir.path().join("preview.tga")).unwrap(),
        std::fs::read(dir.path().join("plain.tga")).unwrap()
    );
    // -q silences the notice.
    let quiet = render(&["-gui", "-q"], "quiet.tga");
    assert!(quiet.status.success() && quiet.stderr.is_empty(), "{}", stderr(&quiet));

    let before = file_names(dir.path());
    let window_only = raycaster_in(dir.path(), &["-input", scene.as_str(), "-size", "16", "12", "-gui"]);
    assert_eq!(window_only.status.code(), Some(0), "{}", stderr(&window_only));
    assert_eq!(
        stderr(&window_only),
        "raycaster: note: -gui: no window (no display: DISPLAY and WAYLAND_DISPLAY are unset), and no -output, \
         -normals or -depth: nothing rendered\n"
    );
    assert_eq!(file_names(dir.path()), before);
    // Without -gui, a line that writes nothing is still an error.
    let nothing = raycaster_in(dir.path(), &["-input", scene.as_str(), "-size", "16", "12", "-gouraud"]);
    assert_eq!(nothing.status.code(), Some(2));
    assert!(stderr(&nothing).contains("nothing to write"), "{}", stderr(&nothing));
    for (bad, message) in [
        (&["-tessellation", "10"][..], "-tessellation expects two numbers of steps: THETA PHI"),
        (&["-tessellation", "0", "5"][..], "-tessellation: '0' is not a whole number of steps, 1 or more"),
        (&["-tessellation", "10", "x"][..], "-tessellation: 'x' is not a whole number of steps, 1 or more"),
    ] {
        let result = render(bad, "bad.tga");
        assert_eq!(result.status.code(), Some(2), "{bad:?}");
        assert!(stderr(&result).contains(message), "{bad:?}: {}", stderr(&result));
    }
    let typo = render(&["--specular-fx"], "typo.tga");
    assert!(stderr(&typo).contains("did you mean '--specular-fix'?"), "{}", stderr(&typo));
}

/// `--specular-fix` changes a scene with a specular lobe (scenes/phong_material.txt) and
/// leaves a specular-free one byte for byte as it was.
#[test]
fn specular_fix_changes_only_specular_scenes() {
    let dir = tempfile::tempdir().unwrap();
    for (name, changes) in [("phong_material.txt", true), ("spheres_ortho.txt", false)] {
        let scene = common::bin::scene(name);
        let run = |extra: &[&str], image: &str| {
            let args = [&["-input", scene.as_str(), "-size", "64", "64", "-output", image, "--backend", "cpu"], extra]
                .concat();
            let result = raycaster_in(dir.path(), &args);
            assert!(result.status.success(), "{}", stderr(&result));
            std::fs::read(dir.path().join(image)).unwrap()
        };
        let plain = run(&[], "plain.tga");
        let fixed = run(&["--specular-fix"], "fixed.tga");
        assert_eq!(plain != fixed, changes, "{name}");
    }
}

/// The GPU kernel's ray tree holds 15 bounces: a deeper one (a mirror whose weight never
/// fades) is refused by `--backend gpu` with one line and status 1, writing nothing;
/// `auto` (at a size where it does try the GPU) renders it with the reference, says so in
/// one line and writes the very image `--backend cpu` writes.
#[test]
fn gpu_refuses_a_tree_deeper_than_its_stack_and_auto_falls_back() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("mirrors.txt");
    std::fs::write(
        &scene,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n\
         Lights { numLights 1 PointLight { position 0 0 5 color 1 1 1 attenuation 0 0 0.04 } }\n\
         Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0.5 0.25 reflectiveColor 1 1 1 } }\n\
         Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 2 } }\n",
    )
    .unwrap();
    // More primitives than `auto` traces with the reference anyway on a CPU device: specks
    // behind the mirror, so that `auto` asks the GPU first on every device.
    let mut text = std::fs::read_to_string(&scene).unwrap().replace("numObjects 1", "numObjects 201");
    text.insert_str(
        text.rfind('}').unwrap(),
        &(0..200).map(|k| format!("Sphere {{ center {k} 0 -50 radius 0.01 }}\n")).collect::<String>(),
    );
    std::fs::write(&scene, text).unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = |backend: &str, image: &str| {
        raycaster(&[
            "-input",
            path_str(&scene),
            "-size",
            "1500",
            "1500",
            "-output",
            image,
            "-bounces",
            "20",
            "--backend",
            backend,
        ])
    };
    let refusal = format!(
        "{}: -bounces 20: reflected and refracted rays can go 20 deep here, and the GPU kernel traces at most 15 \
         (a larger -weight stops them sooner)",
        scene.display()
    );
    let gpu = run("gpu", &out("gpu.tga"));
    assert_eq!(gpu.status.code(), Some(1), "{}", stderr(&gpu));
    assert_eq!(stderr(&gpu), format!("raycaster: {refusal}; render it with --backend cpu\n"));
    assert!(!Path::new(&out("gpu.tga")).exists());

    let auto = run("auto", &out("auto.tga"));
    assert_eq!(auto.status.code(), Some(0), "{}", stderr(&auto));
    assert_eq!(stderr(&auto), format!("raycaster: warning: {refusal}; rendering with the f64 CPU reference instead\n"));
    let cpu = run("cpu", &out("cpu.tga"));
    assert!(cpu.status.success() && cpu.stderr.is_empty(), "{}", stderr(&cpu));
    assert_eq!(std::fs::read(out("auto.tga")).unwrap(), std::fs::read(out("cpu.tga")).unwrap());
}

/// The course's own a3 commands.txt runs as a batch: one notice for the preview flags,
/// whatever the number of lines that carry them.
#[test]
fn a_batch_of_preview_lines_says_so_once() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::bin::scene("spheres_ortho.txt");
    let line = format!("-input {scene} -size 8 8 -output o.tga -gui -tessellation 10 5");
    std::fs::write(
        dir.path().join("commands.txt"),
        format!("{line}\n{line} -gouraud\n-input {scene} -size 8 8 -gui\n"),
    )
    .unwrap();
    let result = raycaster_in(dir.path(), &["batch", "commands.txt", "--backend", "cpu"]);
    assert!(result.status.success(), "{}", stderr(&result));
    assert_eq!(
        stderr(&result),
        "raycaster: commands.txt:1: note: -gui: no window (a batch opens none); the files are written as without \
         it\n\
         raycaster: commands.txt:3: note: -gui: no window (a batch opens none), and no -output, -normals or -depth: \
         nothing rendered\n"
    );
}

/// `auto` on a CPU Vulkan device (lavapipe) traces the ray trees of a small scene with the
/// reference, which is quicker there (`CPU_DEVICE_TREE_PRIMITIVES` in src/renderer/auto.rs),
/// and `-v` says so; any other device gets the scene, as does a scene of more primitives
/// everywhere. (900 × 900, so that neither is a job small enough for the reference at once.) Handed over or not, the image is the one its renderer makes on its own.
#[test]
fn auto_traces_small_ray_trees_with_the_reference_on_a_cpu_device() {
    let Some(gpu) = common::gpu() else { return };
    let cpu_device = gpu.adapter_info().device_type == wgpu::DeviceType::Cpu;
    let dir = tempfile::tempdir().unwrap();
    let scene_with = |specks: usize| {
        let path = dir.path().join(format!("mirror_{specks}.txt"));
        let mut text = String::from(
            "PerspectiveCamera { center 0 2 8 direction 0 -0.2 -1 up 0 1 0 angle 30 }\n\
             Lights { numLights 1 DirectionalLight { direction -0.3 -1 -0.5 color 0.9 0.9 0.9 } }\n\
             Materials { numMaterials 2 PhongMaterial { diffuseColor 0.2 0.2 0.2 reflectiveColor 0.7 0.7 0.7 }\n\
             PhongMaterial { diffuseColor 0.9 0.4 0.1 } }\n",
        );
        text += &format!(
            "Group {{ numObjects {} MaterialIndex 0 Plane {{ normal 0 1 0 offset -1 }} MaterialIndex 1\n",
            specks + 3
        );
        text += "Sphere { center -1 0 0 radius 1 } Sphere { center 1.2 0 -1 radius 1 }\n";
        text += &(0..specks).map(|k| format!("Sphere {{ center {k} 0 -60 radius 0.03 }}\n")).collect::<String>();
        std::fs::write(&path, text + "}\n").unwrap();
        path
    };
    let small = "auto: ray trees of a scene this small are quicker here";
    let grid = "auto: ray trees through a -grid are quicker here on the reference";
    // Through an explicit -grid the reference walks the same cells, quicker than lavapipe.
    for (specks, cells, why) in [(0, None, small), (200, None, ""), (200, Some("4"), grid)] {
        let handed_over = cpu_device && !why.is_empty();
        let scene = scene_with(specks);
        let render = |backend: &str| {
            let image = dir.path().join(format!("{specks}_{cells:?}_{backend}.tga"));
            let args = ["-input", path_str(&scene), "-size", "900", "900", "-output", path_str(&image)];
            let mut flags = vec!["-shadows", "-bounces", "2", "--backend", backend, "-v"];
            if let Some(n) = cells {
                flags.extend(["-grid", n, n, n]);
            }
            let run = raycaster(&[&args[..], &flags].concat());
            assert!(run.status.success(), "{}", stderr(&run));
            (stderr(&run), std::fs::read(&image).unwrap())
        };
        let (said, image) = render("auto");
        let by = if handed_over { "cpu" } else { "gpu" };
        assert!(said.starts_with(&format!("raycaster: backend: {by}")), "{specks} specks, {cells:?}: {said}");
        for reason in [small, grid] {
            assert_eq!(said.contains(reason), handed_over && reason == why, "{said}");
        }
        assert!(image == render(by).1, "{specks} specks, {cells:?}: auto's image is not the {by} backend's");
    }
}

/// `-shadows`, `-bounces N` and `-weight W` (GRAMMAR.md A4) are checked like every other
/// flag's values, and both backends honour them.
#[test]
fn shadows_bounces_and_weight() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::canonicalize("scenes/spheres_ortho.txt").unwrap();
    let run = |extra: &[&str]| {
        let args = [&["-input", path_str(&scene), "-size", "64", "64", "-output", "o.tga"], extra].concat();
        raycaster_in(dir.path(), &args)
    };
    for (bad, message) in [
        (&["-bounces", "x"][..], "-bounces: 'x' is not a whole number from 0 to 1000"),
        (&["-bounces", "1001"][..], "-bounces: '1001' is not a whole number from 0 to 1000"),
        (&["-weight", "-0.5"][..], "-weight: '-0.5' is not a number ≥ 0"),
        (&["-weight", "nan"][..], "-weight: 'nan' is not a number ≥ 0"),
    ] {
        let result = run(bad);
        assert_eq!(result.status.code(), Some(2), "{bad:?}");
        assert!(stderr(&result).contains(message), "{bad:?}: {}", stderr(&result));
    }
    if common::gpu().is_none() {
        return;
    }
    // Shadows change the image (a sphere above a plane), on either backend, and the
    // backends agree.
    let scene = std::fs::canonicalize("scenes/plane_and_sphere_perspective.txt").unwrap();
    let image = |backend: &str, shadows: bool| {
        let name = format!("{backend}_{shadows}.tga");
        let shading: &[&str] = if shadows { &["-shadows"] } else { &[] };
        let args = [&["-input", path_str(&scene), "-size", "64", "64", "-output", &name][..], shading].concat();
        let result = raycaster_in(
            dir.path(),
            &[&args[..], &["-bounces", "2", "-weight", "0.01", "--backend", backend]].concat(),
        );
        assert!(result.status.success() && result.stderr.is_empty(), "{backend}: {}", stderr(&result));
        raycaster::image_io::read_image(&dir.path().join(name)).unwrap()
    };
    for backend in ["cpu", "gpu"] {
        assert!(image(backend, false) != image(backend, true), "-shadows changes the {backend} image");
    }
    for shadows in [false, true] {
        let diff = raycaster::metrics::image_diff(&image("gpu", shadows), &image("cpu", shadows));
        assert!(diff.off_by_more_than_one <= diff.pixels / 1000, "GPU against the reference: {diff:?}");
    }
}
