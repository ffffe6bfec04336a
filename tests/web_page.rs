//! The page of `web/` in headless Chromium (docs/SPEC.md §10): built with `web/build.sh`,
//! driven through its test hook by `tests/web/drive_page.py` (Playwright for Python on the
//! system's Chromium, WebGPU on SwiftShader where there is no GPU). Its canvas against the
//! f64 reference under the 0.1 % contract, and a bad scene's title against the command
//! line's message.
//!
//! Needs Chromium, Playwright for Python, Rust's wasm32 target and wasm-bindgen-cli of the
//! version in web/Cargo.lock. Without them the test skips with one notice naming what is
//! missing; `RAYCASTER_REQUIRE_BROWSER=1` (set by CI) turns the skip into a failure.

mod common;

use raycaster::image_io::{color_image, depth_image, normals_image, read_image};
use raycaster::metrics::image_diff;
use raycaster::render::RenderOptions;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A program on `PATH`.
fn on_path(name: &str) -> Option<PathBuf> {
    let paths = std::env::var_os("PATH")?;
    std::env::split_paths(&paths).map(|dir| dir.join(name)).find(|p| p.is_file())
}

fn runs(program: &str, args: &[&str]) -> Option<String> {
    let output = Command::new(program).args(args).output().ok()?;
    output.status.success().then(|| String::from_utf8_lossy(&output.stdout).into_owned())
}

/// The wasm-bindgen crate's version in web/Cargo.lock, which the CLI must match.
fn locked_wasm_bindgen() -> String {
    let lock = std::fs::read_to_string(root().join("web/Cargo.lock")).unwrap();
    let after = lock.split("name = \"wasm-bindgen\"\nversion = \"").nth(1).expect("web/Cargo.lock pins wasm-bindgen");
    after.split('"').next().unwrap().to_string()
}

/// The system's Chromium (`$RAYCASTER_CHROMIUM`, else `chromium` or `chromium-browser` on
/// `PATH`), or `None` after the one notice (or a failure, with `RAYCASTER_REQUIRE_BROWSER=1`)
/// naming every missing tool and how to install it.
fn browser() -> Option<PathBuf> {
    let chromium = std::env::var_os("RAYCASTER_CHROMIUM")
        .map(PathBuf::from)
        .or_else(|| on_path("chromium"))
        .or_else(|| on_path("chromium-browser"));
    let version = locked_wasm_bindgen();
    let wasm_target = runs("rustc", &["--print", "target-libdir", "--target", "wasm32-unknown-unknown"])
        .is_some_and(|dir| Path::new(dir.trim()).is_dir());
    let bindgen = runs("wasm-bindgen", &["--version"]).is_some_and(|v| v.split_whitespace().nth(1) == Some(&version));
    let mut missing = Vec::new();
    if chromium.is_none() {
        missing.push("Chromium (apt-get install chromium, or set RAYCASTER_CHROMIUM)".to_string());
    }
    if runs("python3", &["-c", "import playwright.sync_api"]).is_none() {
        missing.push("Playwright for Python (pip install playwright; no browser download needed)".to_string());
    }
    if !wasm_target {
        missing.push("Rust's wasm32 target (rustup target add wasm32-unknown-unknown)".to_string());
    }
    if !bindgen {
        missing.push(format!("wasm-bindgen-cli {version} (cargo install wasm-bindgen-cli --version {version})"));
    }
    if missing.is_empty() {
        return chromium;
    }
    let why = format!("the browser test needs {}", missing.join("; "));
    if std::env::var("RAYCASTER_REQUIRE_BROWSER").as_deref() == Ok("1") {
        panic!("{why}, and RAYCASTER_REQUIRE_BROWSER=1 requires it");
    }
    // Straight to the stream: the test harness captures eprintln! of passing tests.
    let _ = writeln!(std::io::stderr(), "SKIPPED: {why}");
    None
}

/// web/dist, built afresh (cargo rebuilds only what changed).
fn build_page() -> PathBuf {
    let output = Command::new("bash").arg(root().join("web/build.sh")).output().unwrap();
    assert!(output.status.success(), "web/build.sh failed:\n{}", String::from_utf8_lossy(&output.stderr));
    root().join("web/dist")
}

/// What the page did for one hook URL.
#[derive(Default)]
struct Visit {
    title: String,
    times: String,
    notes: Vec<String>,
}

/// Opens `index.html?QUERY` for each `(query, png)` in one browser, the test's scenes in
/// `extra` served under `extra/`; writes the canvas to `png` where the render is done.
fn visit(chromium: &Path, dist: &Path, extra: &Path, jobs: &[(String, Option<PathBuf>)]) -> Vec<Visit> {
    let jobs_json: Vec<String> = jobs
        .iter()
        .map(|(query, png)| {
            let png = png.as_ref().map_or("null".to_string(), |p| format!("{:?}", p.display().to_string()));
            format!("{{\"query\": {query:?}, \"png\": {png}}}")
        })
        .collect();
    let output = Command::new("python3")
        .arg(root().join("tests/web/drive_page.py"))
        .arg(chromium)
        .arg(dist)
        .arg(extra)
        .arg(format!("[{}]", jobs_json.join(", ")))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "drive_page.py failed:\n{stderr}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let mut visits: Vec<Visit> = Vec::new();
    for line in stdout.lines() {
        match (line.split_once(": "), visits.last_mut()) {
            (Some(("title", title)), _) => visits.push(Visit { title: title.to_string(), ..Visit::default() }),
            (Some(("times", times)), Some(visit)) => visit.times = times.to_string(),
            (Some(("note", note)), Some(visit)) => visit.notes.push(note.to_string()),
            _ => panic!("drive_page.py printed `{line}`"),
        }
    }
    assert_eq!(visits.len(), jobs.len(), "one result per page:\n{stdout}\n{stderr}");
    visits
}

/// The lines the command line prints on stderr rendering `scene` in `dir` at `w × h` on
/// the GPU (as the page does; `auto` would give small images to the reference at once),
/// which must exit with `status`.
fn cli_stderr(dir: &Path, scene: &str, (w, h): (u32, u32), status: i32) -> Vec<String> {
    let output = Command::new(env!("CARGO_BIN_EXE_raycaster"))
        .args(["-input", scene, "-size", &w.to_string(), &h.to_string(), "-output", "cli.tga", "--backend", "gpu"])
        .current_dir(dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(status), "{scene}: {stderr}");
    stderr.lines().map(str::to_string).collect()
}

/// `line:col` of the first `needle` in `text`, counted by hand (1-based, characters).
fn place_of(text: &str, needle: &str) -> String {
    let offset = text.find(needle).unwrap();
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().unwrap().chars().count() + 1;
    format!("{line}:{col}")
}

const HEADER: &str = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
Background { color 0 0 0 }
Materials { numMaterials 1 Material { diffuseColor 1 0 0 } }
";

#[test]
fn page_renders_like_the_reference_and_fails_like_the_command_line() {
    let Some(chromium) = browser() else { return };
    let dist = build_page();
    let extra = tempfile::tempdir().unwrap();
    for name in ["three_lights.txt", "box.obj", "mesh_octahedron.txt", "octahedron.obj"] {
        std::fs::copy(common::scenes_dir().join(name), extra.path().join(name)).unwrap();
    }
    let bad_scenes = [
        (
            "bad_number.txt",
            format!("{HEADER}Group {{ numObjects 1 MaterialIndex 0\n  Sphere {{ center 0 0 oops radius 1 }}\n}}\n"),
            "oops",
        ),
        (
            "bad_mesh.txt",
            format!("{HEADER}Group {{ numObjects 1 MaterialIndex 0\n  TriangleMesh {{ obj_file bad.obj }}\n}}\n"),
            "7",
        ),
        (
            "no_mesh.txt",
            format!("{HEADER}Group {{ numObjects 1 MaterialIndex 0\n  TriangleMesh {{ obj_file none.obj }}\n}}\n"),
            "none.obj",
        ),
    ];
    // A sphere far below the kernel's f32 range beside one it renders: the page, as `auto`
    // does, renders the scene with the reference and says why.
    let refused = format!(
        "{HEADER}Group {{ numObjects 2 MaterialIndex 0\n  Sphere {{ center 0 0 0 radius 1 }}\n  Sphere {{ center 2 0 0 radius 1e-30 }}\n}}\n"
    );
    std::fs::write(extra.path().join("refused.txt"), &refused).unwrap();
    let bad_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n";
    std::fs::write(extra.path().join("bad.obj"), bad_obj).unwrap();
    for (name, text, _) in &bad_scenes {
        std::fs::write(extra.path().join(name), text).unwrap();
    }

    // Sphere and box under four lights; meshes from an OBJ file; not square either way. The
    // depth image of `-depth 6 10` (the octahedra lie 7 to 9 from the camera).
    let renders = [
        ("three_lights.txt", (160, 120), "color"),
        ("mesh_octahedron.txt", (120, 160), "color"),
        ("mesh_octahedron.txt", (120, 160), "normals"),
        ("mesh_octahedron.txt", (120, 160), "depth"),
        ("refused.txt", (64, 48), "color"),
    ];
    let mut jobs: Vec<(String, Option<PathBuf>)> = renders
        .iter()
        .enumerate()
        .map(|(k, (scene, (w, h), output))| {
            let png = extra.path().join(format!("page_{k}.png"));
            (format!("scene=extra/{scene}&size={w},{h}&output={output}&depth=6,10"), Some(png))
        })
        .collect();
    jobs.extend(bad_scenes.iter().map(|(name, _, _)| (format!("scene=extra/{name}&size=8,8"), None)));
    let visits = visit(&chromium, &dist, extra.path(), &jobs);

    let mut failures = Vec::new();
    for (k, (scene, (w, h), output)) in renders.iter().enumerate() {
        let visit = &visits[k];
        assert_eq!(visit.title, "done", "{scene} {output}");
        if *scene != "refused.txt" {
            assert_eq!(visit.notes, cli_stderr(extra.path(), scene, (*w, *h), 0), "{scene}: the command line's notes");
        }
        let page = read_image(&extra.path().join(format!("page_{k}.png"))).unwrap();
        let loaded = raycaster::scene::load_scene(&extra.path().join(scene)).unwrap();
        let frame = raycaster::cpu::render(&loaded, &RenderOptions::all(*w, *h));
        let reference = match *output {
            "color" => color_image(&frame),
            "normals" => normals_image(&frame),
            _ => depth_image(&frame, 6.0, 10.0),
        };
        assert_eq!(page.dimensions(), reference.dimensions(), "{scene} {output}");
        let diff = image_diff(&page, &reference);
        println!(
            "{scene} {output} {w}×{h}: {} of {} pixels more than 1 level off (max {}, mean {:.4}); page times {}",
            diff.off_by_more_than_one, diff.pixels, diff.max, diff.mean, visit.times
        );
        if diff.off_by_more_than_one as f64 > common::MAX_OFF_FRACTION * diff.pixels as f64 {
            failures.push(format!("{scene} {output}: {} pixels off", diff.off_by_more_than_one));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
    // `auto`'s notice: the GPU's refusal, `raycaster: FILE:LINE:COL: WHY; render it with
    // --backend cpu`, as a warning that the reference renders it instead.
    let refusal = cli_stderr(extra.path(), "refused.txt", (64, 48), 1).concat();
    let why = refusal.strip_prefix("raycaster: ").and_then(|r| r.strip_suffix("; render it with --backend cpu"));
    let notice = format!("raycaster: warning: {}; rendering with the f64 CPU reference instead", why.unwrap());
    assert!(notice.contains(&format!("refused.txt:{}: ", place_of(&refused, "radius 1e-30"))), "{notice}");
    assert_eq!(visits[renders.len() - 1].notes, [notice]);

    let bad_places = [
        format!("bad_number.txt:{}", place_of(&bad_scenes[0].1, bad_scenes[0].2)),
        format!("bad.obj:{}", place_of(bad_obj, bad_scenes[1].2)),
        format!("no_mesh.txt:{}", place_of(&bad_scenes[2].1, bad_scenes[2].2)),
    ];
    for (k, ((name, _, _), place)) in bad_scenes.iter().zip(&bad_places).enumerate() {
        let title = &visits[renders.len() + k].title;
        assert!(title.starts_with(&format!("raycaster: {place}: ")), "{name}: {title}");
        assert_eq!(title, &cli_stderr(extra.path(), name, (8, 8), 1).concat(), "{name}: the command line's line");
    }
}
