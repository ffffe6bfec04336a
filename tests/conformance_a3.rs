//! The course's assignment 3 (Phong shading): its 15 command lines, run through the binary
//! exactly as written (inside a copy of the course's `a3/` folder, `-gui`, `-tessellation`
//! and `-gouraud` included), on the f64 reference; each image is compared with the course's
//! own sample in `a3/expected/`. The three lines whose handout shows the optional specular
//! fix run again with `--specular-fix` and are compared with the `*_fix` samples. At most
//! 0.1 % of an image's pixels may differ by more than 1 level in any channel.
//!
//! The GPU kernel does not shade the specular term yet and refuses these scenes
//! (tests/cli.rs), so only the reference is checked here.

mod common;

use common::{against_sample, copy_course_folder, corpus, course_commands, run_course_line};
use std::path::Path;

/// The scenes whose handout shows the specular fix, and the sample it shows.
const FIXED: [(&str, &str); 3] = [
    ("scene3_09_exponent_variations.txt", "output3_09_fix"),
    ("scene3_10_exponent_variations_back.txt", "output3_10_fix"),
    ("scene3_12_weird_lighting_specular.txt", "output3_12_fix"),
];

fn value_after(command: &[String], flag: &str) -> String {
    let k = command.iter().position(|a| a == flag).unwrap_or_else(|| panic!("{flag} in {command:?}"));
    command[k + 1].clone()
}

/// Runs `command` in `dir` on the reference and compares its `-output` with the sample
/// `expected`; returns the failure, if any.
fn run_and_compare(corpus: &Path, dir: &Path, command: &[String], expected: &str) -> Option<String> {
    run_course_line(dir, command, "cpu");
    let sample = corpus.join(format!("a3/expected/{expected}.png"));
    against_sample(&dir.join(value_after(command, "-output")), &sample, expected)
}

#[test]
fn course_images_a3_reference() {
    let Some(corpus) = corpus() else { return };
    let dir = tempfile::tempdir().unwrap();
    copy_course_folder(&corpus, "a3", dir.path());
    let commands = course_commands(&corpus, "a3");
    assert_eq!(commands.len(), 15, "the course has 15 command lines for assignment 3");
    let mut failures = Vec::new();
    let mut images = 0;
    for command in &commands {
        let stem = value_after(command, "-output").trim_end_matches(".tga").to_string();
        failures.extend(run_and_compare(&corpus, dir.path(), command, &stem));
        images += 1;
        if let Some((_, fixed)) = FIXED.iter().find(|(scene, _)| value_after(command, "-input") == *scene) {
            let mut with_fix = command.clone();
            let k = with_fix.iter().position(|a| a == "-output").unwrap();
            with_fix[k + 1] = format!("{fixed}.tga");
            with_fix.push("--specular-fix".into());
            failures.extend(run_and_compare(&corpus, dir.path(), &with_fix, fixed));
            images += 1;
        }
    }
    assert_eq!(images, 18, "15 course images and 3 with the specular fix");
    assert!(failures.is_empty(), "{failures:?}");
}
