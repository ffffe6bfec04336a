//! The course's assignment 3 (Phong shading): its 15 command lines, run through the binary
//! exactly as written (inside copies of the course's `a3/` folder, `-gui`, `-tessellation`
//! and `-gouraud` included), on the f64 reference and on the GPU; the reference's images
//! are compared with the course's own samples in `a3/expected/`, the GPU's with the
//! reference's. The three lines whose handout shows the optional specular fix run again
//! with `--specular-fix` and are compared with the `*_fix` samples. At most 0.1 % of an
//! image's pixels may differ by more than 1 level in any channel.

mod common;

use common::{corpus, course_commands, course_lines_on_both_backends};

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

#[test]
fn course_images_a3_on_both_backends() {
    let Some(corpus) = corpus() else { return };
    let commands = course_commands(&corpus, "a3");
    assert_eq!(commands.len(), 15, "the course has 15 command lines for assignment 3");
    let mut lines = commands.clone();
    for command in &commands {
        if let Some((_, fixed)) = FIXED.iter().find(|(scene, _)| value_after(command, "-input") == *scene) {
            let mut with_fix = command.clone();
            let k = with_fix.iter().position(|a| a == "-output").unwrap();
            with_fix[k + 1] = format!("{fixed}.tga");
            with_fix.push("--specular-fix".into());
            lines.push(with_fix);
        }
    }
    let (failures, samples) = course_lines_on_both_backends(&corpus, "a3", &lines);
    assert_eq!(samples.len(), 18, "15 course images and 3 with the specular fix: {samples:?}");
    assert!(failures.is_empty(), "{failures:?}");
}
