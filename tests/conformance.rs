//! The course's 18 command lines, run through the binary exactly as written (inside a copy of
//! the course's `a2/` folder, as the course runs them; see [`common::corpus`]), with each backend; each of the 30 images
//! is compared with the course's own sample in `a2/expected/`. At most 0.1% of an image's
//! pixels (40 of 40 000) may differ by more than 1 level in any channel.

mod common;

use common::{against_sample, copy_course_folder, corpus, course_commands, run_course_line};

/// The image files a command line writes (the value after -output/-normals, the third after -depth).
fn outputs_of(command: &[String]) -> Vec<String> {
    let mut outputs = Vec::new();
    for (k, arg) in command.iter().enumerate() {
        match arg.as_str() {
            "-output" | "-normals" => outputs.push(command[k + 1].clone()),
            "-depth" => outputs.push(command[k + 3].clone()),
            _ => {}
        }
    }
    outputs
}

fn conformance(backend: &str) {
    let Some(corpus) = corpus() else { return };
    if backend == "gpu" && common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    copy_course_folder(&corpus, "a2", dir.path());
    let commands = course_commands(&corpus, "a2");
    assert_eq!(commands.len(), 18, "the course has 18 command lines");
    let mut failures = Vec::new();
    let mut images = 0;
    println!("backend {backend}: pixels off by more than 1 level (of 40000), per course image");
    for command in &commands {
        run_course_line(dir.path(), command, backend);
        for output in outputs_of(command) {
            let stem = output.trim_end_matches(".tga");
            let sample = corpus.join(format!("a2/expected/{stem}.png"));
            failures.extend(against_sample(&dir.path().join(&output), &sample, stem));
            images += 1;
        }
    }
    assert_eq!(images, 30, "the course's command lines write 30 images");
    assert!(failures.is_empty(), "backend {backend}: {failures:?}");
}

#[test]
fn course_images_cpu_reference() {
    conformance("cpu");
}

#[test]
fn course_images_gpu() {
    conformance("gpu");
}
