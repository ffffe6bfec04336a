//! The course's assignment 4 scenes scaled and moved render the same image: shadows,
//! reflection, refraction and point-light attenuation must not depend on where a scene sits or
//! on its units. For each scene below (with the flags of its line in `a4/commands.txt`) the
//! scene is rewritten three ways, everything in it transformed:
//!
//! - scaled by 10⁻⁴ about the origin, and by 10⁴;
//! - moved by (10⁶, 10⁶, 10⁶).
//!
//! The objects are wrapped in one `Transform { UniformScale s | Translate t }`; the camera's
//! `center` and each point light's `position` are mapped by hand, an orthographic camera's
//! `size` scaled, and a point light's `attenuation a0 a1 a2` becomes `a0 a1/s a2/s²`, so that
//! the light arriving at a scaled point is unchanged. Directions, angles, colours and the
//! other flags are kept. The rewritten text is loaded with the ordinary loader.
//!
//! Each transformed scene's colour image must match the original's, rendered by the same
//! backend, under the project's contract: at most `floor(pixels · MAX_OFF_FRACTION)` pixels
//! more than 1 level apart in some channel. The backends: `cpu` (the f64 reference), `auto`
//! (the binary's default, run as a user runs it) and `gpu`. The kernel shades all of
//! assignment 4: a case it refuses as unsupported fails the test.

mod common;

use raycaster::gpu::GpuError;
use raycaster::image_io::{color_image, read_image};
use raycaster::metrics::image_diff;
use raycaster::render::{RenderOptions, Shading};
use raycaster::scene::{load_scene, Light, Scene, Shape};
use std::io::Write as _;
use std::path::Path;

/// Image side: the course's own; the three backends' 108 renders take about 16 s on lavapipe
/// with 2 cores, and the contract allows 40 of the 40 000 pixels.
///
/// Measured with the spawn rule of docs/SPEC.md §5 (along the new ray, ε relative
/// to |p|): every GPU case 0 to 2 pixels off (scene4_06f scaled, max 84 levels); on the
/// reference the moved scenes 0 to 16 (scene4_14f: 16, max 9 levels; scene4_06f: 13, max 129),
/// since 2⁻³²·|p|∞ is 2.3·10⁻⁴ world units there and moves a few refraction boundaries.
const SIZE: u32 = 200;

/// The command lines whose scenes are transformed, by their `-output` name: a sphere's
/// shadow (01); a mirror sphere, 3 bounces (04d); transparent bars, 10 and 5 bounces (05,
/// 06f); a glass sphere of index 2, 5 bounces (09); a point light without fall-off beside a
/// directional one (10), with `a1` (12) and with `a2` (13); a faceted glass gem, 5 bounces
/// (14f). All with `-shadows`.
const LINES: [&str; 9] = [
    "output4_01",
    "output4_04d",
    "output4_05",
    "output4_06f",
    "output4_09",
    "output4_10",
    "output4_12",
    "output4_13",
    "output4_14f",
];

#[derive(Clone, Copy, Debug)]
enum Change {
    /// Scaled by the factor about the origin.
    Scale(f64),
    /// Moved by the same amount along each axis.
    Translate(f64),
}

const CHANGES: [Change; 3] = [Change::Scale(1e-4), Change::Scale(1e4), Change::Translate(1e6)];

impl Change {
    fn name(self) -> String {
        match self {
            Change::Scale(s) => format!("scaled by {s:e}"),
            Change::Translate(t) => format!("moved by ({t:e}, {t:e}, {t:e})"),
        }
    }

    /// The file name's suffix.
    fn tag(self) -> String {
        match self {
            Change::Scale(s) => format!("scaled_{s:e}"),
            Change::Translate(t) => format!("moved_{t:e}"),
        }
    }

    /// How lengths scale: the factor, or 1 for a move.
    fn factor(self) -> f64 {
        match self {
            Change::Scale(s) => s,
            Change::Translate(_) => 1.0,
        }
    }

    fn point(self, p: [f64; 3]) -> [f64; 3] {
        match self {
            Change::Scale(s) => p.map(|x| s * x),
            Change::Translate(t) => p.map(|x| x + t),
        }
    }

    /// The Transform step that does the same to the objects.
    fn step(self) -> String {
        match self {
            Change::Scale(s) => format!("UniformScale {s}"),
            Change::Translate(t) => format!("Translate {t} {t} {t}"),
        }
    }
}

/// `text`, a scene file, with everything in it transformed by `change` (see the module
/// comment). Works on the tokens, so the result is one line per block end rather than the
/// file's layout; comments are dropped.
fn transformed(text: &str, change: Change) -> String {
    let tokens = common::hard::tokens(text);
    let number = |k: usize| -> f64 {
        tokens[k].parse().unwrap_or_else(|_| panic!("expected a number at token {k}, found {}", tokens[k]))
    };
    let s = change.factor();
    let mut out: Vec<String> = Vec::new();
    // The open blocks, innermost last, by their keyword.
    let mut blocks: Vec<&str> = Vec::new();
    let mut k = 0;
    while k < tokens.len() {
        let token = tokens[k].as_str();
        let block = blocks.last().copied().unwrap_or("");
        let camera = block == "OrthographicCamera" || block == "PerspectiveCamera";
        let point = |k: usize| change.point([number(k), number(k + 1), number(k + 2)]).map(|x| x.to_string()).join(" ");
        // What to write for the tokens from k on, and how many of them it replaces.
        let (text, used) = match token {
            "{" => {
                blocks.push(if k > 0 { tokens[k - 1].as_str() } else { "" });
                ("{".to_string(), 1)
            }
            // The top-level Group's end also ends the Transform and the Group around it.
            "}" => {
                let closed = blocks.pop();
                // The top-level Group's end also ends the Transform and the Group around it.
                let end = if closed == Some("Group") && blocks.is_empty() { "} } }" } else { "}" };
                (format!("{end}\n"), 1)
            }
            "Group" if blocks.is_empty() => (format!("Group {{ numObjects 1 Transform {{ {} Group", change.step()), 1),
            "center" if camera => (format!("center {}", point(k + 1)), 4),
            "size" if block == "OrthographicCamera" => (format!("size {}", s * number(k + 1)), 2),
            "position" if block == "PointLight" => (format!("position {}", point(k + 1)), 4),
            "attenuation" if block == "PointLight" => {
                let (a0, a1, a2) = (number(k + 1), number(k + 2) / s, number(k + 3) / (s * s));
                (format!("attenuation {a0} {a1} {a2}"), 4)
            }
            _ => (token.to_string(), 1),
        };
        out.push(text);
        k += used;
    }
    out.join(" ")
}

/// The shading flags of a course command line (its other words: `-input`, `-size`,
/// `-output` and the preview's flags, which change no pixel).
fn shading_of(command: &[String]) -> Shading {
    let mut shading = Shading::default();
    let mut words = command.iter().map(String::as_str);
    while let Some(word) = words.next() {
        match word {
            "-shadows" => shading.shadows = true,
            "-shade_back" => shading.shade_back = true,
            "--specular-fix" => shading.specular_fix = true,
            "-bounces" => shading.bounces = words.next().unwrap().parse().unwrap(),
            "-weight" => shading.weight = words.next().unwrap().parse().unwrap(),
            "-input" | "-output" => drop(words.next()),
            "-size" | "-tessellation" => drop((words.next(), words.next())),
            "-gui" | "-gouraud" => {}
            other => panic!("a flag this test does not know: {other} in {}", command.join(" ")),
        }
    }
    shading
}

/// The loaded transformed scene is the original with `change` applied: the camera's centre
/// and the point lights' positions as mapped, attenuations rescaled, and the objects under
/// one Transform that maps points the same way. Guards against a rewrite that changes
/// nothing, which would make the comparison vacuous.
fn check_rewrite(original: &Scene, changed: &Scene, change: Change) {
    let close = |a: glam::DVec3, b: glam::DVec3| (a - b).abs().max_element() <= 1e-12 * b.abs().max_element().max(1.0);
    let map = |p: glam::DVec3| glam::DVec3::from(change.point(p.to_array()));
    assert!(close(changed.camera.center, map(original.camera.center)), "camera not moved: {change:?}");
    assert_eq!(changed.lights.len(), original.lights.len());
    for (a, b) in original.lights.iter().zip(&changed.lights) {
        if let (Light::Point(a), Light::Point(b)) = (a, b) {
            let s = change.factor();
            assert!(close(b.position, map(a.position)), "light not moved: {change:?}");
            let rescaled = glam::DVec3::new(a.attenuation.x, a.attenuation.y / s, a.attenuation.z / (s * s));
            assert!(close(b.attenuation, rescaled), "attenuation not rescaled: {change:?}");
        }
    }
    let [object] = &changed.root[..] else { panic!("expected the objects under one node: {change:?}") };
    let Shape::Transform { matrix, .. } = &object.shape else { panic!("expected a Transform: {change:?}") };
    let p = glam::DVec3::new(1.0, -2.0, 3.0);
    assert!(close(matrix.transform_point3(p), map(p)), "the Transform is not the change: {change:?}");
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Backend {
    /// The f64 reference, in this process.
    Cpu,
    /// The binary with its default backend, as a user runs it.
    Auto,
    /// The GPU kernel, in this process.
    Gpu,
}

/// What one render gave.
enum Rendered {
    /// The colour image, and what rendered it (for `auto`, what the binary chose).
    Image(image::RgbImage, &'static str),
    /// The GPU kernel refused the scene as shading it does not implement yet.
    Unsupported(String),
}

/// One scene of the course: its file name, the flags of its command line, its text.
struct Line {
    output: String,
    command: Vec<String>,
    scene: String,
    text: String,
}

fn course_lines(corpus: &Path) -> Vec<Line> {
    let commands = common::course_commands(corpus, "a4");
    LINES
        .iter()
        .map(|&output| {
            let command = commands
                .iter()
                .find(|c| c.iter().any(|w| w.trim_end_matches(".tga") == output))
                .unwrap_or_else(|| panic!("no line of a4/commands.txt writes {output}"))
                .clone();
            let input = command.iter().position(|w| w == "-input").expect("an -input");
            let scene = command[input + 1].clone();
            let text = std::fs::read_to_string(corpus.join("a4").join(&scene)).unwrap();
            Line { output: output.to_string(), command, scene, text }
        })
        .collect()
}

/// Renders `file` (in `dir`) with `shading` on `backend`: the colour image.
fn render(backend: Backend, dir: &Path, file: &str, line: &Line) -> Rendered {
    let shading = shading_of(&line.command);
    let path = dir.join(file);
    let options = RenderOptions { shading, ..RenderOptions::all(SIZE, SIZE) };
    match backend {
        Backend::Cpu => {
            let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
            Rendered::Image(color_image(&raycaster::cpu::render(&scene, &options)), "the reference")
        }
        Backend::Gpu => {
            let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
            match common::gpu().expect("a GPU").render(&scene, &options) {
                Ok(frame) => Rendered::Image(color_image(&frame), "the GPU"),
                Err(GpuError::Unsupported(e)) => Rendered::Unsupported(e.to_string()),
                Err(e) => panic!("{file}: {e}"),
            }
        }
        Backend::Auto => {
            // The course's own command line, at our size, into a PNG (lossless).
            let out = dir.join(format!("{file}.png"));
            let mut args = vec!["-input".to_string(), file.to_string()];
            args.extend(["-size".to_string(), SIZE.to_string(), SIZE.to_string()]);
            args.extend(["-output".to_string(), out.to_str().unwrap().to_string(), "-v".to_string()]);
            let mut words = line.command.iter();
            while let Some(word) = words.next() {
                match word.as_str() {
                    "-input" | "-output" => drop(words.next()),
                    "-size" => drop((words.next(), words.next())),
                    _ => args.push(word.clone()),
                }
            }
            let run = common::bin::raycaster_in(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
            let said = common::bin::stderr(&run);
            assert!(run.status.success(), "raycaster {}: {said}", args.join(" "));
            // -v names the backend; a scene the GPU refuses is handed to the reference with a
            // warning.
            let by = if said.contains("rendering with the f64 CPU reference instead") {
                "the reference (the GPU refused it)"
            } else if said.contains("backend: gpu") {
                "the GPU"
            } else {
                "the reference (a small job)"
            };
            Rendered::Image(read_image(&out).unwrap(), by)
        }
    }
}

/// Every line's scene and its three transforms on `backend`; fails with one line per case
/// over the contract. Returns the number of cases the GPU refused as unsupported.
fn transformed_scenes_match(backend: Backend) -> Option<usize> {
    let corpus = common::corpus()?;
    if backend == Backend::Gpu && common::gpu().is_none() {
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    common::copy_course_folder(&corpus, "a4", dir.path());
    let allowed = (common::MAX_OFF_FRACTION * (SIZE * SIZE) as f64).floor() as usize;
    let mut refused_as_unsupported = 0;
    let mut refusals = Vec::new();
    let mut failures = Vec::new();
    let mut table = Vec::new();
    for line in course_lines(&corpus) {
        let original = load_scene(&dir.path().join(&line.scene)).unwrap_or_else(|e| panic!("{e}"));
        let base = render(backend, dir.path(), &line.scene, &line);
        for change in CHANGES {
            let file = format!("{}_{}.txt", line.scene.trim_end_matches(".txt"), change.tag());
            std::fs::write(dir.path().join(&file), transformed(&line.text, change)).unwrap();
            let changed = load_scene(&dir.path().join(&file)).unwrap_or_else(|e| panic!("{file}: {e}"));
            check_rewrite(&original, &changed, change);
            let case = format!("{} ({}), {}", line.scene, line.output, change.name());
            match (&base, &render(backend, dir.path(), &file, &line)) {
                (Rendered::Image(base, _), Rendered::Image(ours, by)) => {
                    let diff = image_diff(ours, base);
                    table.push(format!(
                        "  {case:<75} {:>4} of {} pixels more than 1 level off (max {}), by {by}",
                        diff.off_by_more_than_one, diff.pixels, diff.max
                    ));
                    if diff.off_by_more_than_one > allowed {
                        failures.push(format!(
                            "{case}: {} of {} pixels more than 1 level off (allowed {allowed}), max difference {}",
                            diff.off_by_more_than_one, diff.pixels, diff.max
                        ));
                    }
                }
                (Rendered::Unsupported(why), _) | (_, Rendered::Unsupported(why)) => {
                    refused_as_unsupported += 1;
                    refusals.push(format!("  {case}: {why}"));
                }
            }
        }
    }
    println!("{backend:?}: each transformed scene against the original\n{}", table.join("\n"));
    if refused_as_unsupported > 0 {
        // Straight to the stream, so that it shows without --nocapture too.
        let _ = writeln!(
            std::io::stderr(),
            "{backend:?}: {refused_as_unsupported} of {} cases refused by the GPU kernel as unsupported \
             :\n{}",
            LINES.len() * CHANGES.len(),
            refusals.join("\n")
        );
    }
    assert!(failures.is_empty(), "{backend:?}: transformed scenes that do not match the original:\n{failures:#?}");
    Some(refused_as_unsupported)
}

#[test]
fn a4_scenes_scaled_and_moved_match_on_the_reference() {
    assert_eq!(transformed_scenes_match(Backend::Cpu).unwrap_or(0), 0);
}

#[test]
fn a4_scenes_scaled_and_moved_match_with_the_default_backend() {
    // `auto` falls back to the reference for what the GPU refuses: nothing is refused.
    assert_eq!(transformed_scenes_match(Backend::Auto).unwrap_or(0), 0);
}

#[test]
fn a4_scenes_scaled_and_moved_match_on_the_gpu() {
    // The kernel shades all of assignment 4: nothing is refused.
    assert_eq!(transformed_scenes_match(Backend::Gpu).unwrap_or(0), 0);
}

/// The rewrite itself, on a small scene: every place it changes, and nothing else.
#[test]
fn the_rewrite_transforms_camera_lights_and_objects() {
    let text = "OrthographicCamera { center 1 2 3 direction 0 0 -1 up 0 1 0 size 4 }\n\
                Lights { numLights 2 PointLight { position 0 5 0 color 1 1 1 attenuation 1 0.5 0.25 }\n\
                DirectionalLight { direction 0 -1 0 color 1 1 1 } }\n\
                Materials { numMaterials 1 Material { } }\n\
                Group { numObjects 1 MaterialIndex 0 Sphere { center 1 2 3 radius 1 } }";
    assert_eq!(
        transformed(text, Change::Scale(2.0)),
        "OrthographicCamera { center 2 4 6 direction 0 0 -1 up 0 1 0 size 8 }\n \
         Lights { numLights 2 PointLight { position 0 10 0 color 1 1 1 attenuation 1 0.25 0.0625 }\n \
         DirectionalLight { direction 0 -1 0 color 1 1 1 }\n }\n \
         Materials { numMaterials 1 Material { }\n }\n \
         Group { numObjects 1 Transform { UniformScale 2 Group { numObjects 1 MaterialIndex 0 Sphere { center 1 2 3 radius 1 }\n } } }\n"
    );
    let moved = transformed(text, Change::Translate(10.0));
    assert!(moved.contains("center 11 12 13 direction"), "{moved}");
    assert!(moved.contains("size 4 }") && moved.contains("attenuation 1 0.5 0.25 }"), "{moved}");
    assert!(moved.contains("Transform { Translate 10 10 10 Group"), "{moved}");
}
