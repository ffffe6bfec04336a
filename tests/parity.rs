//! The GPU against the f64 reference on every course scene and every scene in `scenes/`:
//! each output image must have ≥ 99.9% of its pixels within 1 level of the reference's, and
//! the test prints how many pixels differ and by how much.

mod common;

use common::{corpus, scenes_dir};
use raycaster::metrics::compare_frames;
use raycaster::render::{RenderOptions, Shading};
use raycaster::scene::load_scene;
use std::path::{Path, PathBuf};

const MIN_AGREEING_FRACTION: f64 = 0.999;

/// The scene files in `dir` whose names start with `prefix`.
fn scene_files(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "txt"))
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with(prefix))
        .collect();
    files.sort();
    files
}

/// A size written in the scene's name (`wide_320x180.txt`), else 200×200.
fn size_for(path: &Path) -> (u32, u32) {
    let stem = path.file_stem().unwrap().to_string_lossy();
    stem.rsplit('_')
        .next()
        .and_then(|last| last.split_once('x'))
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .unwrap_or((200, 200))
}

fn parity(files: &[PathBuf]) {
    if common::gpu().is_none() {
        return;
    }
    let mut renderers: Vec<_> =
        common::ACCELERATIONS.iter().map(|&a| (a.name().to_string(), common::gpu_with(a).unwrap())).collect();
    // Bins with one load per lane (`main_bins`, as on real GPUs), where lavapipe's lanes share them.
    renderers.push(("bins, own loads".to_string(), common::gpu_with_own_bin_loads()));
    let mut report = vec![format!(
        "{:<58} {:>9} {:>7} {:>9} {:>7} {:>9} {:>7}",
        "scene (shade_back, candidates from)", "colour>1", "max", "normal>1", "max", "depth>1", "max"
    )];
    let mut failures = Vec::new();
    for path in files {
        let scene = load_scene(path).unwrap_or_else(|e| panic!("{e}"));
        let (width, height) = size_for(path);
        for shade_back in [false, true] {
            let options = RenderOptions {
                shading: Shading { shade_back, ..Shading::default() },
                ..RenderOptions::all(width, height)
            };
            let reference = raycaster::cpu::render(&scene, &options);
            for (candidates, gpu) in &renderers {
                let ours = gpu.render(&scene, &options).unwrap();
                let (min, max) = raycaster::metrics::depth_range_of(&reference);
                // Colour, normals and depth, in that order.
                let diffs: Vec<_> = compare_frames(&ours, &reference, (min, max)).iter().map(|e| e.image).collect();
                let name = format!("{} ({shade_back}, {candidates})", path.file_name().unwrap().to_string_lossy());
                let cells: Vec<String> =
                    diffs.iter().map(|d| format!("{:>9} {:>7}", d.off_by_more_than_one, d.max)).collect();
                report.push(format!("{name:<58} {}", cells.join(" ")));
                for (d, what) in diffs.iter().zip(["colour", "normals", "depth"]) {
                    if ((d.pixels - d.off_by_more_than_one) as f64) < MIN_AGREEING_FRACTION * d.pixels as f64 {
                        failures.push(format!(
                            "{name} {what}: {} of {} pixels off by more than 1",
                            d.off_by_more_than_one, d.pixels
                        ));
                    }
                }
            }
        }
    }
    println!(
        "GPU against the f64 reference: pixels off by more than 1 level, and the largest difference\n{}",
        report.join("\n")
    );
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn gpu_matches_reference_on_course_scenes() {
    let Some(corpus) = corpus() else { return };
    let files = scene_files(&corpus.join("a2"), "scene2_");
    assert_eq!(files.len(), 16, "the course has 16 scenes");
    parity(&files);
}

#[test]
fn gpu_matches_reference_on_our_scenes() {
    let files = scene_files(&scenes_dir(), "");
    assert!(files.len() >= 10, "scenes/ should cover every feature; found {}", files.len());
    parity(&files);
}
