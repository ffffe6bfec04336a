//! The same image on every driver (docs/SPEC.md §6, "What the kernel assumes of the
//! driver"): the binary on the machine's own Vulkan driver (lavapipe in CI), on a second
//! implementation, SwiftShader (Debian's `chromium` ships its Vulkan driver), and in the
//! fused mode (`RAYCASTER_FUSE_MUL_ADD=1`, a driver that fuses every multiply-add,
//! emulated). On each: `raycaster selftest` finds the driver faithful, and the course's
//! assignment 7 lines whose samples lie exactly on a triangle's edge (`*_low_res`) give the
//! reference's image, pixel for pixel, and `output7_01_low_res` the course's own.
//!
//! SwiftShader is looked for at `RAYCASTER_SWIFTSHADER_ICD`, else Debian's path; without
//! it its runs skip with a notice, unless `RAYCASTER_REQUIRE_SWIFTSHADER=1` (CI sets it).

mod common;

use common::bin::{command, stderr};
use std::path::{Path, PathBuf};
use std::process::Output;

/// A way of running the binary: the name the failures give, and its environment.
struct Driver {
    name: &'static str,
    env: Vec<(&'static str, String)>,
}

fn swiftshader_icd() -> Option<PathBuf> {
    let path = std::env::var_os("RAYCASTER_SWIFTSHADER_ICD")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/lib/chromium/vk_swiftshader_icd.json"));
    if path.is_file() {
        return Some(path);
    }
    let why = format!("no SwiftShader Vulkan driver at {} (apt-get install chromium)", path.display());
    assert!(
        std::env::var("RAYCASTER_REQUIRE_SWIFTSHADER").as_deref() != Ok("1"),
        "{why}, and RAYCASTER_REQUIRE_SWIFTSHADER=1 requires it"
    );
    eprintln!("SKIPPED: the SwiftShader runs: {why}");
    None
}

/// The drivers every test here runs on: the machine's own, SwiftShader where it is, and the
/// fused mode on the machine's own.
fn drivers() -> Vec<Driver> {
    let mut drivers = vec![Driver { name: "the machine's driver", env: vec![] }];
    if let Some(icd) = swiftshader_icd() {
        let icd = icd.to_string_lossy().into_owned();
        drivers.push(Driver {
            name: "SwiftShader",
            env: vec![("VK_ICD_FILENAMES", icd.clone()), ("VK_DRIVER_FILES", icd)],
        });
    }
    drivers.push(Driver { name: "the fused mode", env: vec![("RAYCASTER_FUSE_MUL_ADD", "1".into())] });
    drivers
}

fn run(driver: &Driver, dir: &Path, args: &[&str]) -> Output {
    let mut c = command();
    c.args(args).current_dir(dir).env_remove("RAYCASTER_FUSE_MUL_ADD");
    for (k, v) in &driver.env {
        c.env(k, v);
    }
    c.output().unwrap()
}

#[test]
fn selftest_finds_every_driver_faithful() {
    if common::gpu().is_none() {
        return;
    }
    for driver in drivers() {
        let out = run(&driver, Path::new(env!("CARGO_MANIFEST_DIR")), &["selftest"]);
        let table = String::from_utf8_lossy(&out.stdout);
        println!("{}:\n{table}", driver.name);
        assert!(out.status.success(), "{}: {}\n{table}", driver.name, stderr(&out));
        assert!(!table.contains("FAIL"), "{}: {table}", driver.name);
        // The hard cases that decide hits by a sign must render, not be refused.
        for case in ["degenerate_perspective.txt", "degenerate_triangles.txt", "edge_on_triangles.txt"] {
            let row = table.lines().find(|l| l.contains(case)).unwrap_or_else(|| panic!("{case} in {table}"));
            assert!(row.ends_with("| pass |"), "{}: {row}", driver.name);
        }
    }
}

/// The `*_low_res` lines of assignment 7: scene7_01's triangle has the edge x + y = 0
/// through the 12 × 12 image's anti-diagonal, and uniform samples lie on it exactly. The
/// kernel's products are rounded on their own and the samples' positions computed from
/// whole numbers (docs/SPEC.md §8), so every driver gets the reference's ties: 0 pixels off.
#[test]
fn samples_on_a_shared_edge_get_the_references_answer_on_every_driver() {
    let Some(corpus) = common::corpus() else { return };
    if common::gpu().is_none() {
        return;
    }
    let lines: Vec<String> = std::fs::read_to_string(corpus.join("a7/commands.txt"))
        .unwrap()
        .lines()
        .filter(|l| l.contains("low_res"))
        .map(String::from)
        .collect();
    assert_eq!(lines.len(), 16, "{lines:#?}");
    let files: Vec<String> = lines.iter().map(|l| written_file(l)).collect();
    let reference = tempfile::tempdir().unwrap();
    batch(&Driver { name: "the reference", env: vec![] }, &corpus, &lines, reference.path(), "cpu");
    let course = raycaster::image_io::read_image(&corpus.join("a7/expected/output7_01_low_res.png")).unwrap();
    let mut failures = Vec::new();
    for driver in drivers() {
        let dir = tempfile::tempdir().unwrap();
        batch(&driver, &corpus, &lines, dir.path(), "gpu");
        for file in &files {
            let ours = raycaster::image_io::read_image(&dir.path().join(file)).unwrap();
            let theirs = raycaster::image_io::read_image(&reference.path().join(file)).unwrap();
            let off = raycaster::metrics::image_diff(&ours, &theirs).off_by_more_than_one;
            println!("{}: {file}: {off} of 144 pixels off the reference", driver.name);
            if off > 0 {
                failures.push(format!("{}: {file}: {off} pixels off the reference", driver.name));
            }
        }
        let ours = raycaster::image_io::read_image(&dir.path().join("output7_01_low_res.tga")).unwrap();
        let off = raycaster::metrics::image_diff(&ours, &course).off_by_more_than_one;
        if off > 0 {
            failures.push(format!("{}: output7_01_low_res.tga: {off} pixels off the course's image", driver.name));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The image file a course line writes.
fn written_file(line: &str) -> String {
    let words: Vec<&str> = line.split_whitespace().collect();
    let flag = ["-output", "-render_samples", "-render_filter"].into_iter().find(|f| words.contains(f)).unwrap();
    let at = words.iter().position(|w| *w == flag).unwrap();
    words[at + 1].to_string()
}

/// Runs `lines` as one batch with `--backend backend` in `dir`, a copy of assignment 7's folder.
fn batch(driver: &Driver, corpus: &Path, lines: &[String], dir: &Path, backend: &str) {
    common::copy_course_folder(corpus, "a7", dir);
    std::fs::write(dir.join("low_res.txt"), lines.join("\n") + "\n").unwrap();
    let out = run(driver, dir, &["batch", "low_res.txt", "--backend", backend, "-q"]);
    assert!(out.status.success(), "{}: {}", driver.name, stderr(&out));
}
