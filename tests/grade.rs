//! `raycaster grade` as a teacher runs it on the course's assignment 4: a student's images
//! judged against our render, line by line; images changed as a student's mistakes change
//! them caught, and those FLIP cannot tell apart passed; a student's program that crashes,
//! hangs or writes nothing judged, never the grader's failure (tests/grade_sandbox.rs holds
//! the hostile ones). `raycaster gallery` on a
//! course folder of our own scenes.

mod common;

use common::bin::{command, path_str, report_line, stderr, stdout};
use image::RgbImage;
use std::path::{Path, PathBuf};
use std::process::Output;

/// The course's assignment 4, and a folder holding our render of every image of it, as
/// `raycaster batch` writes them (the route a student's images take: files on disk).
fn assignment_4_rendered() -> Option<(PathBuf, tempfile::TempDir)> {
    let a4 = common::corpus()?.join("a4");
    let images = tempfile::tempdir().unwrap();
    common::copy_course_folder(a4.parent().unwrap(), "a4", images.path());
    let batch = command().args(["batch", "commands.txt", "--backend", "cpu", "-q"]).current_dir(images.path()).output();
    let batch = batch.unwrap();
    assert!(batch.status.success(), "{}", stderr(&batch));
    Some((a4, images))
}

fn grade(args: &[&str]) -> Output {
    command().arg("grade").args(args).output().unwrap()
}

fn read(path: &Path) -> RgbImage {
    raycaster::image_io::read_image(path).unwrap()
}

/// Our own images pass, every one with no FLIP error at all; the HTML page shows each with
/// ours and the map beside it.
#[test]
fn our_own_images_all_pass() {
    let Some((a4, images)) = assignment_4_rendered() else { return };
    let html = images.path().join("report/grade.html");
    let result = grade(&[path_str(&a4), "--images", path_str(images.path()), "--html", path_str(&html), "-q"]);
    assert!(result.status.success(), "{}{}", stdout(&result), stderr(&result));
    let report = stdout(&result);
    // 30 command lines, of which 3 open the course's preview only and write nothing.
    assert!(report.ends_with("grade: 27 of 27 images pass\n"), "{report}");
    for line in report.lines().filter(|l| l.contains(".tga")) {
        assert!(line.starts_with("pass") && line.contains("FLIP mean 0.0000  p99 0.0000  0 px off"), "{line}");
    }
    let page = std::fs::read_to_string(&html).unwrap();
    assert_eq!(page.matches("<div class=\"card pass\">").count(), 27);
    assert!(page.contains("scene4_14_faceted_gem.txt -size 200 200 -output output4_14f.tga"), "the command lines");
    let pictures: Vec<&str> = page.split("<img src=\"").skip(1).map(|s| s.split('"').next().unwrap()).collect();
    assert_eq!(pictures.len(), 3 * 27, "ours, theirs and the map of each");
    for picture in pictures {
        assert_eq!(read(&html.parent().unwrap().join(picture)).dimensions(), (200, 200), "{picture}");
    }
}

/// A student's mistakes as FLIP sees them: swapped colour channels (line 1), missing shadows
/// (line 2) and a moved camera (line 18) fail; a ±1-level dither (line 4), invisible,
/// passes. Everything else is ours and passes; the exit status is 1.
#[test]
fn mutated_images_are_caught_and_a_dither_passes() {
    let Some((a4, images)) = assignment_4_rendered() else { return };
    let dir = images.path();
    let mut state = 35;
    let red = read(&dir.join("output4_01.tga"));
    assert!(red.pixels().any(|p| p[0] > 150 && p[2] < 50), "the sphere of output4_01 is red");
    let swapped = RgbImage::from_fn(200, 200, |x, y| {
        let [r, g, b] = red.get_pixel(x, y).0;
        image::Rgb([b, g, r])
    });
    swapped.save(dir.join("output4_01.tga")).unwrap();
    let ours = read(&dir.join("output4_04a.tga"));
    let dithered = RgbImage::from_fn(200, 200, |x, y| {
        let p = ours.get_pixel(x, y).0;
        image::Rgb(p.map(|c| (c as i32 + (common::splitmix64(&mut state) % 3) as i32 - 1).clamp(0, 255) as u8))
    });
    assert!(dithered.pixels().zip(ours.pixels()).filter(|(a, b)| a != b).count() > 30_000, "most pixels moved");
    dithered.save(dir.join("output4_04a.tga")).unwrap();
    // Line 2 without -shadows: the coloured shadows are gone.
    render_line(dir, "-input scene4_02_colored_shadows.txt -size 200 200 -output output4_02.tga");
    // Line 18's scene, its camera moved to the right by 2 % of its distance (0.57 of 28.3).
    let scene = std::fs::read_to_string(dir.join("scene4_10_point_light_distance.txt")).unwrap();
    assert!(scene.contains("center 0 20 20"));
    std::fs::write(dir.join("moved.txt"), scene.replacen("center 0 20 20", "center 0.57 20 20", 1)).unwrap();
    render_line(dir, "-input moved.txt -size 200 200 -output output4_10.tga -shadows");

    let result = grade(&[path_str(&a4), "--images", path_str(dir), "-q"]);
    let report = stdout(&result);
    assert_eq!(result.status.code(), Some(1), "{report}{}", stderr(&result));
    for failing in ["output4_01.tga", "output4_02.tga", "output4_10.tga"] {
        let line = report_line(&report, failing);
        assert!(line.starts_with("FAIL") && line.contains("FLIP p99 > 0.25"), "{line}");
    }
    let dither = report_line(&report, "output4_04a.tga");
    assert!(dither.starts_with("pass") && dither.contains("0 px off"), "{dither}");
    assert!(report.ends_with("grade: 24 of 27 images pass\n"), "{report}");
    assert!(stderr(&result).contains("grade: 3 of 27 images do not pass"), "{}", stderr(&result));
    // The same images with the thresholds opened up all pass; a pixel limit fails the dither.
    let lenient =
        grade(&[path_str(&a4), "--images", path_str(dir), "-q", "--max-flip-mean", "1", "--max-flip-p99", "1"]);
    assert!(lenient.status.success(), "{}", stdout(&lenient));
    let strict = grade(&[path_str(&a4), "--images", path_str(dir), "-q", "--max-diff-pixels", "0"]);
    assert!(report_line(&stdout(&strict), "output4_01.tga").contains("pixels off > 0"), "{}", stdout(&strict));
}

/// Renders a command line of ours in `dir`.
fn render_line(dir: &Path, line: &str) {
    let result = command().args(line.split_whitespace()).args(["--backend", "cpu", "-q"]).current_dir(dir).output();
    let result = result.unwrap();
    assert!(result.status.success(), "{line}: {}", stderr(&result));
}

/// The README's pictures (`scenes/gallery/`, rendered from `commands.txt` there) are what
/// the binary renders today: graded against it, all pass. Needs no course files.
#[test]
fn the_readme_gallery_is_what_we_render() {
    let gallery = common::scenes_dir().join("gallery");
    let result = grade(&[path_str(&gallery), "--images", path_str(&gallery), "-q"]);
    let report = stdout(&result);
    assert!(result.status.success(), "{report}{}", stderr(&result));
    assert!(report.ends_with("grade: 5 of 5 images pass\n"), "{report}");
    assert!(report_line(&report, "showcase.png").contains("FLIP mean 0.0000"), "{report}");
}

/// A four-line assignment: the first four lines of the course's assignment 4.
fn short_assignment(a4: &Path) -> tempfile::TempDir {
    let folder = tempfile::tempdir().unwrap();
    common::copy_course_folder(a4.parent().unwrap(), "a4", folder.path());
    let commands = std::fs::read_to_string(a4.join("commands.txt")).unwrap();
    let first_four: Vec<&str> = commands.lines().take(4).collect();
    std::fs::write(folder.path().join("commands.txt"), first_four.join("\n") + "\n").unwrap();
    folder
}

/// `--run`: a student's program that crashes on line 1, hangs on line 2 (killed at the time
/// limit, with the process it started) and writes nothing on line 3, then renders line 4 as
/// we do. Each of the first three is a missing image saying why; line 4 passes; exit 1.
#[cfg(unix)]
#[test]
fn a_student_program_that_crashes_hangs_or_writes_nothing_gets_verdicts() {
    use std::os::unix::fs::PermissionsExt;
    let Some(corpus) = common::corpus() else { return };
    let folder = short_assignment(&corpus.join("a4"));
    let student = tempfile::tempdir().unwrap();
    // Readable by the sandbox's user (grade run as root runs it as nobody).
    std::fs::set_permissions(student.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let program = student.path().join("raytracer.sh");
    // The student's own renderer, beside the script: the sandbox shows the program its
    // own folder only.
    std::fs::copy(env!("CARGO_BIN_EXE_raycaster"), student.path().join("raycaster")).unwrap();
    let script = "#!/bin/sh\ncase \"$*\" in\n\
         *scene4_01*) echo 'Segmentation fault (core dumped)' >&2; exit 139;;\n\
         *scene4_02*) sleep 30.0625;;\n\
         *scene4_03*) exit 0;;\n\
         *) exec \"$(dirname \"$0\")/raycaster\" \"$@\" --backend cpu -q;;\nesac\n";
    std::fs::write(&program, script).unwrap();
    std::fs::set_permissions(&program, std::fs::Permissions::from_mode(0o755)).unwrap();
    let html = student.path().join("report.html");
    let start = std::time::Instant::now();
    let run = format!("sh {}", program.display());
    let result = grade(&[path_str(folder.path()), "--run", &run, "--time-limit", "1", "--html", path_str(&html), "-q"]);
    let report = stdout(&result);
    assert_eq!(result.status.code(), Some(1), "{report}{}", stderr(&result));
    assert!(start.elapsed().as_secs() < 20, "the hang was not cut at the time limit");
    let crashed = report_line(&report, "output4_01.tga");
    assert!(crashed.starts_with("MISSING") && crashed.contains("the program exited with status 139"), "{crashed}");
    let hung = report_line(&report, "output4_02.tga");
    assert!(hung.starts_with("MISSING") && hung.contains("ran past the time limit (1 s)"), "{hung}");
    let silent = report_line(&report, "output4_03.tga");
    assert!(silent.starts_with("MISSING") && silent.contains("no file"), "{silent}");
    assert!(report_line(&report, "output4_04a.tga").starts_with("pass"), "{report}");
    assert!(report.ends_with("grade: 1 of 4 images pass\n"), "{report}");
    // The page names the missing images, and shows what the crashing program said.
    let page = std::fs::read_to_string(&html).unwrap();
    assert_eq!(page.matches("<div class=\"card fail\">").count(), 3);
    assert!(page.contains("Segmentation fault (core dumped)"));
    // Worst first: the passing image comes last.
    assert!(page.rfind("card fail").unwrap() < page.find("card pass").unwrap());
    // The teacher's folder is untouched: the program ran in a copy.
    assert!(!folder.path().join("output4_04a.tga").exists());
    // The sleeping child was killed with its parent, not left to finish.
    let sleeping =
        std::fs::read_dir("/proc").unwrap().flatten().filter_map(|e| std::fs::read(e.path().join("cmdline")).ok());
    assert!(!sleeping.map(|c| String::from_utf8_lossy(&c).replace('\0', " ")).any(|c| c.contains("sleep 30.0625")));
}

/// A program that is not there: every image missing, saying so; no crash.
#[test]
fn a_student_program_that_does_not_start_is_a_verdict() {
    let Some(corpus) = common::corpus() else { return };
    let folder = short_assignment(&corpus.join("a4"));
    let result = grade(&[path_str(folder.path()), "--run", "/nonexistent/raytracer", "-q"]);
    let report = stdout(&result);
    assert_eq!(result.status.code(), Some(1), "{report}{}", stderr(&result));
    assert_eq!(report.matches("the program did not start: /nonexistent/raytracer").count(), 4, "{report}");
}

/// The GPU renders our side where asked, and is faithful enough that our reference's
/// images pass against it. Fails loudly without an adapter (unless RAYCASTER_SKIP_GPU=1).
#[test]
fn the_gpu_may_render_our_side() {
    let Some(corpus) = common::corpus() else { return };
    if common::gpu().is_none() {
        return;
    }
    let folder = short_assignment(&corpus.join("a4"));
    let batch = command().args(["batch", "commands.txt", "--backend", "cpu", "-q"]).current_dir(folder.path()).output();
    assert!(batch.unwrap().status.success());
    let result = grade(&[path_str(folder.path()), "--images", path_str(folder.path()), "--backend", "gpu", "-q"]);
    assert!(result.status.success(), "{}{}", stdout(&result), stderr(&result));
    assert!(stdout(&result).ends_with("grade: 4 of 4 images pass\n"), "{}", stdout(&result));
}

/// Bad command lines name the flag or folder and exit 2, writing nothing.
#[test]
fn bad_usage_exits_2_naming_the_flag() {
    let empty = tempfile::tempdir().unwrap();
    let assignment = tempfile::tempdir().unwrap();
    std::fs::write(assignment.path().join("commands.txt"), "-input s.txt -size 8 8 -output o.tga\n").unwrap();
    let folder = path_str(assignment.path());
    let cases: [(&[&str], &str); 6] = [
        (&["grade", folder], "grade: give --images DIR"),
        (&["grade", path_str(empty.path()), "--images", "."], "no commands.txt there"),
        (&["grade", folder, "--images", "/nonexistent/images"], "--images /nonexistent/images: not a folder"),
        (&["grade", folder, "--images", ".", "--html", path_str(empty.path())], "--html"),
        (&["grade", folder, "--run", "rt", "--time-limit", "soon"], "--time-limit: 'soon'"),
        (&["gallery", "/nonexistent/corpus", "--html", "g.html"], "gallery /nonexistent/corpus: not a folder"),
    ];
    for (args, message) in cases {
        let result = command().args(args).output().unwrap();
        assert_eq!(result.status.code(), Some(2), "{args:?}: {}", stderr(&result));
        assert!(stderr(&result).contains(message), "{args:?}: {}", stderr(&result));
    }
}

/// The gallery of a course folder of our own scenes: each image ours, the course's where
/// `expected/` has it, and the FLIP map of the pair.
#[test]
fn the_gallery_shows_ours_beside_the_course_images() {
    let corpus = tempfile::tempdir().unwrap();
    let a2 = corpus.path().join("a2");
    std::fs::create_dir_all(a2.join("expected")).unwrap();
    for scene in ["triangles.txt", "spheres_ortho.txt"] {
        std::fs::copy(common::scenes_dir().join(scene), a2.join(scene)).unwrap();
    }
    std::fs::write(
        a2.join("commands.txt"),
        "-input triangles.txt -size 64 48 -output tri.tga -normals tri_n.tga\n\
         # a comment\n-input spheres_ortho.txt -size 40 40 -output spheres.tga -gui\n-input spheres_ortho.txt -size 8 8 -gui\n",
    )
    .unwrap();
    // The course's image of tri.tga: ours, one pixel changed (the map shows it).
    let ours = corpus.path().join("ours.png");
    let render = command()
        .args(["-input", "triangles.txt", "-size", "64", "48", "-output", path_str(&ours), "--backend", "cpu"])
        .current_dir(&a2)
        .output()
        .unwrap();
    assert!(render.status.success(), "{}", stderr(&render));
    let mut course = read(&ours);
    course.put_pixel(10, 10, image::Rgb([255, 255, 0]));
    course.save(a2.join("expected/tri.png")).unwrap();

    let html = corpus.path().join("out/gallery.html");
    let result = command()
        .args(["gallery", path_str(corpus.path()), "--html", path_str(&html), "--backend", "cpu", "-q"])
        .output()
        .unwrap();
    assert!(result.status.success(), "{}", stderr(&result));
    assert!(stdout(&result).starts_with("gallery: 3 images (1 beside the course's own)"), "{}", stdout(&result));
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(page.contains("<h2 id=\"a2\">a2: 2 command lines</h2>"), "the preview-only line is left out");
    for name in ["tri.tga", "tri_n.tga", "spheres.tga"] {
        assert!(page.contains(&format!("<h3>{name}</h3>")), "{name}");
    }
    assert_eq!(page.matches("<img src=").count(), 3 + 2, "three of ours, the course's and the map");
    let map = read(&html.parent().unwrap().join("gallery_files/0003.png"));
    let black = raycaster::flip::MAGMA[0];
    assert_ne!(map.get_pixel(10, 10).0, black, "the changed pixel shows on the map");
    assert_eq!(map.get_pixel(60, 40).0, black, "far from it nothing does");
}
