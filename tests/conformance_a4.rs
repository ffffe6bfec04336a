//! The course's assignment 4 (shadows, reflection, refraction) on the f64 reference: the
//! command lines of `a4/commands.txt` whose sample image the course's files hold
//! (`output4_04d`: a mirror sphere, three bounces; `output4_10`: point lights and shadows),
//! run exactly as written inside a copy of `a4/`, each compared with its sample. At most
//! 0.1 % of an image's pixels may differ by more than 1 level in any channel.
//!
//! The GPU kernel casts no secondary rays yet and refuses these lines (tests/cli.rs).

mod common;

use common::{against_sample, copy_course_folder, corpus, course_commands, run_course_line};

#[test]
fn course_images_a4_reference() {
    let Some(corpus) = corpus() else { return };
    let dir = tempfile::tempdir().unwrap();
    copy_course_folder(&corpus, "a4", dir.path());
    let mut compared = Vec::new();
    let mut failures = Vec::new();
    for command in course_commands(&corpus, "a4") {
        let Some(k) = command.iter().position(|a| a == "-output") else { continue };
        let stem = command[k + 1].trim_end_matches(".tga").to_string();
        let sample = corpus.join(format!("a4/expected/{stem}.png"));
        if !sample.exists() {
            continue;
        }
        run_course_line(dir.path(), &command, "cpu");
        failures.extend(against_sample(&dir.path().join(&command[k + 1]), &sample, &stem));
        compared.push(stem);
    }
    assert_eq!(compared, ["output4_04d", "output4_10"], "the course's a4 samples");
    assert!(failures.is_empty(), "{failures:?}");
}
