//! The course's assignment 4 (shadows, reflection, refraction): the 30 command lines of
//! `a4/commands.txt`, run exactly as written inside copies of `a4/`, on the f64 reference
//! and on the GPU. The reference's images are compared with the course's samples where its
//! files hold one (`output4_04d`: a mirror sphere, three bounces; `output4_10`: point lights
//! and shadows), and the GPU's with the reference's on every line. At most 0.1 % of an
//! image's pixels may differ by more than 1 level in any channel.

mod common;

use common::{corpus, course_commands, course_lines_on_both_backends};

#[test]
fn course_images_a4_on_both_backends() {
    let Some(corpus) = corpus() else { return };
    let commands = course_commands(&corpus, "a4");
    assert_eq!(commands.len(), 30, "the course has 30 command lines for assignment 4");
    let (failures, samples) = course_lines_on_both_backends(&corpus, "a4", &commands);
    assert_eq!(samples, ["output4_04d", "output4_10"], "the course's a4 samples");
    assert!(failures.is_empty(), "{failures:?}");
}
