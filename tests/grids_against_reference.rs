//! The course's assignments 5 and 6 (grids, bigger meshes, solid textures): every line of
//! `a5/commands.txt` and `a6/commands.txt` that writes an image, run exactly as written
//! inside copies of the folders, on the f64 reference and on the GPU. The GPU's image is held
//! to the 0.1 % contract against the reference's wherever the kernel renders the scene; where
//! it refuses (exit 1, one located line on stderr, no image), its reason must be one the
//! kernel states (src/gpu/unsupported.rs, src/gpu/texture_range.rs); no textured line is
//! refused. The `-visualize_grid` lines are compared like the others: both backends draw the
//! course's occupancy (docs/SPEC.md §7). The reference's images are compared with the course's where `expected/` holds
//! one: `output6_15` within the contract; `output6_16`, `output5_12` and `output6_18b` only
//! printed, since the course's wood, and its grid visualisation's colours, are its own.
//!
//! No scene here needs the reference sped up: every line without `-grid` is a small scene
//! (the 40k-triangle bunny, `scene6_07`, is only ever run with `-grid`).

mod common;

use common::{copy_course_folder, corpus, course_commands, MAX_OFF_FRACTION};
use std::path::Path;

/// Why the GPU kernel refuses a line, as its message says it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Refusal {
    /// Texture coordinates beyond the f32 kernel's faithful range (e.g. a textured plane,
    /// unbounded, seen in perspective).
    TextureRange,
}

/// The known reason in one refusal's stderr, from the kernel's own wording.
fn refusal_kind(message: &str) -> Option<Refusal> {
    [("is outside the range the GPU's f32 kernel renders faithfully", Refusal::TextureRange)]
        .into_iter()
        .find_map(|(text, kind)| message.contains(text).then_some(kind))
}

/// Runs `command` in `dir` with `--backend backend`: `Ok` on success, else the stderr lines
/// that are not the binary's notes (e.g. `-gui` opening no window).
fn run(dir: &Path, command: &[String], backend: &str) -> Result<(), Vec<String>> {
    let output = common::bin::command().args(command).args(["--backend", backend]).current_dir(dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    match output.status.code() {
        Some(0) => Ok(()),
        _ => Err(stderr.lines().filter(|l| !l.starts_with("raycaster: note:")).map(String::from).collect()),
    }
}

/// Pixels more than 1 level off in some channel, of how many, and whether within
/// [`MAX_OFF_FRACTION`] (at most ⌊pixels · fraction⌋).
fn off(ours: &Path, other: &Path) -> (usize, usize, bool) {
    let d = raycaster::metrics::image_diff(
        &raycaster::image_io::read_image(ours).unwrap(),
        &raycaster::image_io::read_image(other).unwrap(),
    );
    let limit = (d.pixels as f64 * MAX_OFF_FRACTION).floor() as usize;
    (d.off_by_more_than_one, d.pixels, d.off_by_more_than_one <= limit)
}

/// What one folder's lines gave: the failures, the table's rows, and how many GPU images
/// were compared, of them how many `-visualize_grid` pictures.
#[derive(Default)]
struct Outcome {
    failures: Vec<String>,
    rows: Vec<String>,
    compared: usize,
    visualize_grid: usize,
    texture_refusals: Vec<String>,
}

fn folder_on_both_backends(corpus: &Path, folder: &str, outcome: &mut Outcome) {
    let (cpu, gpu) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    copy_course_folder(corpus, folder, cpu.path());
    copy_course_folder(corpus, folder, gpu.path());
    let gpu_here = common::gpu().is_some();
    for command in course_commands(corpus, folder) {
        // Lines without `-output` (the course's `-gui` previews) write no image.
        let Some(k) = command.iter().position(|a| a == "-output") else { continue };
        let image = command[k + 1].clone();
        let stem = image.trim_end_matches(".tga").to_string();
        if let Err(e) = run(cpu.path(), &command, "cpu") {
            outcome.failures.push(format!("{stem}: the reference failed: {e:?}"));
            continue;
        }
        let reference = cpu.path().join(&image);
        let (ours, theirs) = (gpu.path().join(&image), format!("{folder}/expected/{stem}.png"));
        let sample = corpus.join(&theirs);
        let sample_off = sample.exists().then(|| off(&reference, &sample));
        if stem == "output6_15" {
            // Marble on cubes, no -bounces: the course's colours are the reference's, so its
            // image is held to the contract; the other samples' colours are the course's own.
            match sample_off {
                Some((_, _, true)) => {}
                _ => outcome.failures.push(format!("{stem}: the reference against {theirs}: {sample_off:?}")),
            }
        }
        let sample_text = sample_off.map_or(String::new(), |(n, p, _)| format!("  course sample: {n}/{p} off"));
        if !gpu_here {
            outcome.rows.push(format!("{stem:<12} cpu ok, gpu skipped{sample_text}"));
            continue;
        }
        let (gpu_text, rendered) = match run(gpu.path(), &command, "gpu") {
            Ok(()) => ("rendered".to_string(), true),
            Err(lines) => {
                // A refusal is one located line, and leaves no image behind.
                let kind = refusal_kind(&lines.join("\n"));
                if lines.len() != 1 || kind.is_none() || ours.exists() {
                    outcome.failures.push(format!("{stem}: the GPU failed, not a known refusal: {lines:?}"));
                    outcome.rows.push(format!("{stem:<12} cpu ok, gpu FAILED"));
                    continue;
                }
                outcome.texture_refusals.push(stem.clone());
                (format!("refused {:?}: {}", kind.unwrap(), lines[0]), false)
            }
        };
        let mut row = format!("{stem:<12} cpu ok, gpu {gpu_text}");
        if rendered {
            let (n, p, within) = off(&ours, &reference);
            outcome.compared += 1;
            outcome.visualize_grid += usize::from(command.iter().any(|a| a == "-visualize_grid"));
            row += &format!("  GPU vs reference: {n}/{p} off");
            if !within {
                outcome.failures.push(format!("{stem}: GPU against the reference: {n} of {p} pixels off"));
            }
        }
        outcome.rows.push(row + &sample_text);
    }
}

#[test]
fn course_images_a5_a6_on_both_backends() {
    let Some(corpus) = corpus() else { return };
    let (a5, a6) = (course_commands(&corpus, "a5"), course_commands(&corpus, "a6"));
    assert_eq!((a5.len(), a6.len()), (21, 44), "the course's command lines for assignments 5 and 6");
    let start = std::time::Instant::now();
    let mut outcome = Outcome::default();
    folder_on_both_backends(&corpus, "a5", &mut outcome);
    folder_on_both_backends(&corpus, "a6", &mut outcome);
    println!("{}", outcome.rows.join("\n"));
    println!(
        "{} lines with an image; {} GPU images compared with the reference, {} of them \
         -visualize_grid pictures; texture refusals: {:?}; {:.1} s",
        outcome.rows.len(),
        outcome.compared,
        outcome.visualize_grid,
        outcome.texture_refusals,
        start.elapsed().as_secs_f64()
    );
    // 15 lines of a5 and all 44 of a6 write an image.
    assert_eq!(outcome.rows.len(), 59, "{:?}", outcome.rows);
    if common::gpu().is_some() {
        // 15 lines of a5 and 11 of a6 draw the grid, each compared.
        assert_eq!(outcome.visualize_grid, 26, "{:?}", outcome.rows);
    }
    assert!(outcome.failures.is_empty(), "{:#?}", outcome.failures);
    // Every textured line renders on the GPU: a plane's far hits, and a checkerboard seen
    // through reflection or refraction, are pixels the kernel hands to the reference.
    assert!(outcome.texture_refusals.is_empty(), "{:?}", outcome.texture_refusals);
}
