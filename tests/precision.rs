//! Single precision, stated and enforced (`raycaster::gpu::precision`): each kind of value
//! the f32 kernel receives, just inside and just outside its range [2⁻²⁵, 2²⁸]. Inside, the
//! GPU's images must equal the f64 reference's (no pixel more than 1 level off where both
//! agree on the hit, hit/miss disagreements within the 0.1% contract); outside, the GPU
//! refuses, naming the file, line and column of the value. The command line's `--backend
//! gpu` then fails and `auto` falls back to the reference with a notice.

mod common;

use common::bin::raycaster;
use raycaster::gpu::{precision, GpuError};
use raycaster::image_io::{color_image, depth_image, normals_image};
use raycaster::metrics::{compare_frames, depth_range_of, image_diff};
use raycaster::render::RenderOptions;
use raycaster::scene::{load_scene, Location};
use std::path::{Path, PathBuf};

const SIZE: u32 = 48;

fn p(exponent: i32) -> f64 {
    2f64.powi(exponent)
}

/// A number as the scene parser reads it back exactly (shortest round-trip form).
fn n(v: f64) -> String {
    format!("{v:e}")
}

fn ortho(size: f64) -> String {
    format!("OrthographicCamera {{ center 0 0 0 direction 0 0 -1 up 0 1 0 size {} }}", n(size))
}

fn perspective(center_z: f64, direction: &str, degrees: &str) -> String {
    format!("PerspectiveCamera {{ center 0 0 {} direction {direction} up 0 1 0 angle {degrees} }}", n(center_z))
}

/// The camera on line 1, the object on line 8 from column 5.
fn scene_text(camera: &str, object: &str) -> String {
    format!(
        "{camera}\n\
         Lights {{ numLights 1 DirectionalLight {{ direction -0.5 -0.3 -1 color 0.9 0.9 0.9 }} }}\n\
         Background {{ color 0.1 0.2 0.3 ambientLight 0.1 0.1 0.1 }}\n\
         Materials {{ numMaterials 1 Material {{ diffuseColor 0.8 0.6 0.4 }} }}\n\
         Group {{\n\
         \x20   numObjects 1\n\
         \x20   MaterialIndex 0\n\
         \x20   {object}\n\
         }}\n"
    )
}

const OBJECT_LINE: u32 = 8;

/// A triangle whose first vertex is the farthest from the camera (largest component `m`)
/// and the others less than half as far, facing the camera. The coefficients are not
/// dyadic, so that no edge runs through pixel centres (where rounding alone decides).
fn far_triangle(m: f64) -> [[f64; 3]; 3] {
    [[-m, -0.11 * m, -0.27 * m], [0.23 * m, -0.13 * m, -0.12 * m], [0.03 * m, 0.19 * m, -0.21 * m]]
}

/// A triangle whose first vertex is the nearest to the camera (largest component `m`) and
/// the others at least twice as far, facing the camera.
fn near_triangle(m: f64) -> [[f64; 3]; 3] {
    [[0.1 * m, 0.05 * m, -m], [3.1 * m, 0.3 * m, -2.0 * m], [0.2 * m, 2.9 * m, -2.1 * m]]
}

fn triangle(v: [[f64; 3]; 3]) -> String {
    let s = |k: usize| v[k].map(n).join(" ");
    format!("Triangle {{ vertex0 {} vertex1 {} vertex2 {} }}", s(0), s(1), s(2))
}

/// Two comment lines first, so the first vertex is at line 3, column 3.
fn obj(v: [[f64; 3]; 3]) -> String {
    let s = |k: usize| v[k].map(n).join(" ");
    format!("# precision test\n\n  v {}\nv {}\nv {}\nf 1 2 3\n", s(0), s(1), s(2))
}

const MESH: &str = "TriangleMesh { obj_file mesh.obj }";

/// An OBJ height field over [−1.1h, 1.1h]², `cells` × `cells` squares of two triangles, its
/// height a few tenths of h, facing +z. Inner vertices are moved by up to 0.3 of a square,
/// so that no edge runs through pixel centres (a regular grid's diagonals do, and there
/// rounding alone decides which triangle a pixel shows).
fn bumpy_mesh(h: f64, cells: usize) -> String {
    let mut text = String::from("# precision test\n");
    let inner = |k: usize| k > 0 && k < cells;
    for j in 0..=cells {
        for i in 0..=cells {
            let (fi, fj) = (i as f64, j as f64);
            let jx = if inner(i) { 0.3 * (12.9898 * fi + 78.233 * fj).sin() } else { 0.0 };
            let jy = if inner(j) { 0.3 * (39.3468 * fi + 11.135 * fj).cos() } else { 0.0 };
            let grid = |k: f64| (k / cells as f64 * 2.2 - 1.1) * h;
            let (x, y) = (grid(fi + jx), grid(fj + jy));
            let z = 0.15 * h * (3.1 * x / h).sin() * (2.3 * y / h).cos();
            text += &format!("v {} {} {}\n", n(x), n(y), n(z));
        }
    }
    let index = |i: usize, j: usize| j * (cells + 1) + i + 1;
    for j in 0..cells {
        for i in 0..cells {
            let (a, b, c, d) = (index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
            text += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
        }
    }
    text
}

enum Expect {
    /// The GPU renders it like the reference, and something is visible.
    Faithful,
    /// The GPU renders it like the reference, and nothing is visible.
    Empty,
    /// Refused: the file (scene or mesh), the line, the word on it where the column must
    /// point, and the start of the description.
    Refused { file: &'static str, line: u32, word: &'static str, what: &'static str },
}

struct Case {
    name: String,
    scene: String,
    obj: Option<String>,
    expect: Expect,
}

/// Refused at `word` on the object's line.
fn refused_at(word: &'static str, what: &'static str) -> Expect {
    Expect::Refused { file: "scene.txt", line: OBJECT_LINE, word, what }
}

fn cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let mut add =
        |name: &str, inside: f64, outside: f64, expect: Expect, make: &dyn Fn(f64) -> (String, Option<String>)| {
            for (m, expect) in [(inside, Expect::Faithful), (outside, expect)] {
                let (scene, obj) = make(m);
                cases.push(Case { name: format!("{name} {}", n(m)), scene, obj, expect });
            }
        };
    let (hi, hi_out, lo, lo_out) = (p(28), p(29), p(-25), p(-26));
    let sphere = |c: [f64; 3], r: f64| format!("Sphere {{ center {} radius {} }}", c.map(n).join(" "), n(r));

    add("sphere radius, large", hi, hi_out, refused_at("radius", "Sphere radius"), &|m| {
        (scene_text(&ortho(m / 2.0), &sphere([0.0; 3], m)), None)
    });
    add("sphere radius, small", lo, lo_out, refused_at("radius", "Sphere radius"), &|m| {
        (scene_text(&ortho(4.0 * m), &sphere([0.0, 0.0, -2.0 * m], m)), None)
    });
    add("sphere centre, far", hi, hi_out, refused_at("center", "Sphere center"), &|m| {
        (scene_text(&ortho(m / 2.0), &sphere([0.0, 0.0, -m], m / 4.0)), None)
    });
    add("sphere centre, near", lo, lo_out, refused_at("center", "Sphere center"), &|m| {
        (scene_text(&ortho(8.0 * m), &sphere([m, 0.0, 0.0], 2.0 * m)), None)
    });
    add("triangle vertex, far", hi, hi_out, refused_at("vertex0", "Triangle vertex0"), &|m| {
        (scene_text(&ortho(m / 2.0), &triangle(far_triangle(m))), None)
    });
    add("triangle vertex, near", lo, lo_out, refused_at("vertex0", "Triangle vertex0"), &|m| {
        (scene_text(&ortho(8.0 * m), &triangle(near_triangle(m))), None)
    });
    let vertex = || Expect::Refused { file: "mesh.obj", line: 3, word: "v", what: "mesh vertex 1" };
    add("OBJ vertex, far", hi, hi_out, vertex(), &|m| (scene_text(&ortho(m / 2.0), MESH), Some(obj(far_triangle(m)))));
    add("OBJ vertex, near", lo, lo_out, vertex(), &|m| {
        (scene_text(&ortho(8.0 * m), MESH), Some(obj(near_triangle(m))))
    });
    let plane = |m: f64| format!("Plane {{ normal 0 1 0 offset {} }}", n(-m));
    let looking_down = |m: f64| (scene_text(&perspective(0.0, "0 -0.5 -1", "60"), &plane(m)), None);
    add("plane offset, far", hi, hi_out, refused_at("offset", "Plane offset"), &looking_down);
    add("plane offset, near", lo, lo_out, refused_at("offset", "Plane offset"), &looking_down);
    // Scale 1 1 e: the matrix to the unit sphere's space has the entry 1/e.
    let squashed = |e: f64| format!("Transform {{ Scale 1 1 {} {} }}", n(e), sphere([0.0; 3], 1.0));
    // A radius fine in itself, scaled out of range: the Transform is to blame.
    let in_transform = |what| refused_at("Transform", what);
    add("transform entry (1/scale), large", p(-28), p(-29), in_transform("transformed Sphere inverse-matrix"), &|e| {
        (scene_text(&ortho(4.0), &squashed(e)), None)
    });
    // Scale m m m/2: not a similarity, so the sphere keeps its matrix, whose entries are
    // about 1/m: a sphere that keeps a matrix may be at most 2^25 large.
    let stretched =
        |m: f64| format!("Transform {{ Scale {} {} {} {} }}", n(m), n(m), n(m / 2.0), sphere([0.0; 3], 1.0));
    add("transform scale, large", p(26), p(27), in_transform("transformed Sphere inverse-matrix"), &|m| {
        (scene_text(&ortho(m / 2.0), &stretched(m)), None)
    });
    // Scale 1 1 256 on a sphere of radius m/256: it reaches m along z, with matrix entries
    // of 256/m and 1/m.
    let long = |m: f64| format!("Transform {{ Scale 1 1 256 {} }}", sphere([0.0; 3], m / 256.0));
    add("transformed sphere extent, large", hi, hi_out, in_transform("transformed Sphere half-extent"), &|m| {
        (scene_text(&ortho(m / 64.0), &long(m)), None)
    });
    let enlarged = |s: f64| format!("Transform {{ UniformScale {} {} }}", n(s), sphere([0.0; 3], p(26)));
    add("uniform scale, large", 4.0, 8.0, in_transform("Sphere radius"), &|s| {
        (scene_text(&ortho(p(27)), &enlarged(s)), None)
    });
    add("camera far away", hi, hi_out, refused_at("center", "Sphere center"), &|m| {
        (scene_text(&perspective(m, "0 0 -1", "30"), &sphere([0.0; 3], m / 4.0)), None)
    });
    let camera =
        || Expect::Refused { file: "scene.txt", line: 1, word: "OrthographicCamera", what: "OrthographicCamera size" };
    add("orthographic size, large", hi, hi_out, camera(), &|m| {
        (scene_text(&ortho(m), &sphere([0.0; 3], m / 4.0)), None)
    });
    add("orthographic size, small", lo, lo_out, camera(), &|m| {
        (scene_text(&ortho(m), &sphere([2.0 * m, 0.0, -4.0 * m], 2.0 * m)), None)
    });

    // Resolution (precision::MAX_RESOLUTION_*): R, the scene's distance from the camera over
    // a pixel's footprint there, 10 % inside and outside each bound. The camera names it.
    let perspective_r = |r: f64| {
        // R = W·D/2 with D = 1/tan(angle/2); the view is 2·100/D wide at the object, 100 away.
        let d = 2.0 * r / f64::from(SIZE);
        ((2.0 * (1.0 / d).atan()).to_degrees(), 100.0 / d)
    };
    let angle =
        || Expect::Refused { file: "scene.txt", line: 1, word: "PerspectiveCamera", what: "PerspectiveCamera angle" };
    let (tri, smooth) = (precision::MAX_RESOLUTION_TRIANGLES, precision::MAX_RESOLUTION_SMOOTH);
    add("narrow perspective, triangle", 0.9 * tri, 1.1 * tri, angle(), &|r| {
        let (degrees, h) = perspective_r(r);
        let corners = [[-0.61 * h, -0.52 * h, 0.0], [0.73 * h, -0.43 * h, 0.0], [0.11 * h, 0.67 * h, 0.0]];
        (scene_text(&perspective(100.0, "0 0 -1", &n(degrees)), &triangle(corners)), None)
    });
    // A sphere larger than the view, its silhouette across it: within 2^13 of its radii from
    // the camera (precision::MAX_DISTANCE_OVER_RADIUS), which a sphere inside the view at
    // 48² would not be.
    add("narrow perspective, sphere", 0.9 * smooth, 1.1 * smooth, angle(), &|r| {
        let (degrees, h) = perspective_r(r);
        (scene_text(&perspective(100.0, "0 0 -1", &n(degrees)), &sphere([2.5 * h, -0.07 * h, 0.0], 3.0 * h)), None)
    });
    // A sphere 10 % inside and outside 2^13 of its radii from the camera, filling the view:
    // its normals, not its pixels, are what f32 loses (precision::MAX_DISTANCE_OVER_RADIUS).
    let far_for_its_size = precision::MAX_DISTANCE_OVER_RADIUS;
    add(
        "sphere far for its size",
        0.9 * far_for_its_size,
        1.1 * far_for_its_size,
        refused_at("radius", "Sphere radius"),
        &|q| {
            // The farthest point's distance over the radius is q: centre (q − 1)·r away, r = 1.
            let degrees = (2.0 * (1.3 / (q - 1.0)).atan()).to_degrees();
            (scene_text(&perspective(q - 1.0, "0 0 -1", &n(degrees)), &sphere([0.11, -0.07, 0.0], 1.0)), None)
        },
    );
    // A bumpy mesh of 4608 triangles about a pixel across: its normals come from the host's
    // f64 vertices. Crossing the f32 edges in the kernel instead put them up to 2⁻²⁴ of the
    // distance over an edge off, whole levels here (bunny_40k at R = 2^17: 526 of 40 000
    // normal pixels).
    add("narrow perspective, pixel-sized triangles", 0.9 * tri, 1.1 * tri, angle(), &|r| {
        let (degrees, h) = perspective_r(r);
        (scene_text(&perspective(100.0, "0 0 -1", &n(degrees)), MESH), Some(bumpy_mesh(h, 48)))
    });
    let size_refused =
        || Expect::Refused { file: "scene.txt", line: 1, word: "OrthographicCamera", what: "OrthographicCamera size" };
    // R = M·W/size with M = 100, the triangle's distance: the size shrinks as R grows.
    add("tiny orthographic camera, triangle", 0.9 * tri, 1.1 * tri, size_refused(), &|r| {
        let size = 100.0 * f64::from(SIZE) / r;
        let corners = [
            [-0.31 * size, -0.26 * size, -100.0],
            [0.37 * size, -0.21 * size, -100.0],
            [0.06 * size, 0.33 * size, -100.0],
        ];
        (scene_text(&ortho(size), &triangle(corners)), None)
    });
    // A sphere of radius 3 seen through size 1 from M, its silhouette across the view: R = M·W
    // with M its far side, and M within 2^13 radii (precision::MAX_DISTANCE_OVER_RADIUS).
    add("sphere far away, orthographic", 0.9 * smooth, 1.1 * smooth, size_refused(), &|r| {
        let far_side = r / f64::from(SIZE);
        (scene_text(&ortho(1.0), &sphere([3.2, -0.02, -(far_side - 3.0)], 3.0)), None)
    });
    // Moved a million units away, camera and all: camera-relative, nothing changes.
    cases.push(Case {
        name: "sphere and camera moved by 1e6".into(),
        scene: scene_text(
            "PerspectiveCamera { center 1e6 1e6 1000005 direction 0 0 -1 up 0 1 0 angle 30 }",
            &sphere([1e6, 1e6, 1e6], 1.0),
        ),
        obj: None,
        expect: Expect::Faithful,
    });
    // The README's narrow camera: radius 3.5e-6 at 100 units through angle 1e-5 degrees, in
    // range but R = 2.7e8: 1346 of 10 000 pixels were wrong before it was refused.
    cases.push(Case {
        name: "README's narrow camera".into(),
        scene: scene_text(&perspective(100.0, "0 0 -1", "1e-5"), &sphere([0.0; 3], 3.5e-6)),
        obj: None,
        expect: angle(),
    });

    // Exactly zero is in range: the camera on the plane sees it edge-on, in both backends.
    cases.push(Case {
        name: "plane through the camera".into(),
        scene: scene_text(&perspective(0.0, "0 -0.5 -1", "60"), &plane(0.0)),
        obj: None,
        expect: Expect::Empty,
    });
    // The examples: values beyond f32 altogether.
    cases.push(Case {
        name: "sphere radius 1e39".into(),
        scene: scene_text(&ortho(4.0), "Sphere { center 0 0 -5 radius 1e39 }"),
        obj: None,
        expect: refused_at("radius", "Sphere radius"),
    });
    cases.push(Case {
        name: "OBJ vertex 1e39".into(),
        scene: scene_text(&ortho(4.0), MESH),
        obj: Some("# precision test\n\n  v 0 1e39 -1\nv 1 0 -1\nv 0 1 -1\nf 1 2 3\n".into()),
        expect: Expect::Refused { file: "mesh.obj", line: 3, word: "v", what: "mesh vertex 1" },
    });
    // A perspective camera's extent is 1/tan(angle/2): 1.1e9 for 1e-7 degrees.
    cases.push(Case {
        name: "perspective angle 1e-7 degrees".into(),
        scene: scene_text(&perspective(4.0, "0 0 -1", "1e-7"), &sphere([0.0; 3], 1.0)),
        obj: None,
        expect: Expect::Refused {
            file: "scene.txt",
            line: 1,
            word: "PerspectiveCamera",
            what: "PerspectiveCamera 1/tan(angle/2)",
        },
    });
    cases
}

fn write_case(dir: &Path, case: &Case) -> PathBuf {
    let path = dir.join("scene.txt");
    std::fs::write(&path, &case.scene).unwrap();
    if let Some(obj) = &case.obj {
        std::fs::write(dir.join("mesh.obj"), obj).unwrap();
    }
    path
}

#[test]
fn each_value_just_inside_renders_like_the_reference_and_just_outside_is_refused_where_written() {
    let options = RenderOptions::all(SIZE, SIZE);
    let gpu = common::gpu();
    let mut report = Vec::new();
    let mut failures = Vec::new();
    for case in cases() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_case(dir.path(), &case);
        let scene = load_scene(&path).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let checked = precision::check(&scene, &options);
        match case.expect {
            Expect::Refused { file, line, word, what } => {
                let text = if file == "mesh.obj" { case.obj.as_deref().unwrap() } else { &case.scene };
                let text_line = text.lines().nth(line as usize - 1).unwrap();
                let col = text_line.find(&format!("{word} ")).unwrap() as u32 + 1;
                let Err(e) = checked else {
                    failures.push(format!("{}: accepted, expected refused", case.name));
                    continue;
                };
                report.push(format!("{:<40} refused: {e}", case.name));
                assert_eq!(e.file, dir.path().join(file), "{}", case.name);
                assert_eq!(e.location, Some(Location { line, col }), "{}", case.name);
                assert!(e.what.starts_with(what), "{}: {e}", case.name);
                let prefix = format!("{}:{line}:{col}: {what}", dir.path().join(file).display());
                assert!(e.to_string().starts_with(&prefix), "{}: {e}", case.name);
                if let Some(gpu) = gpu {
                    match gpu.render(&scene, &options) {
                        Err(GpuError::Precision(g)) => {
                            assert_eq!(g, e);
                            assert!(GpuError::Precision(g).to_string().ends_with("; render it with --backend cpu"));
                        }
                        other => failures.push(format!("{}: the GPU rendered it: {:?}", case.name, other.err())),
                    }
                }
            }
            Expect::Faithful | Expect::Empty => {
                let must_hit = matches!(case.expect, Expect::Faithful);
                if let Err(e) = checked {
                    failures.push(format!("{}: refused, expected rendered: {e}", case.name));
                    continue;
                }
                let Some(gpu) = gpu else { continue };
                let ours = gpu.render(&scene, &options).unwrap_or_else(|e| panic!("{}: {e}", case.name));
                let reference = raycaster::cpu::render(&scene, &options);
                let (lo, hi) = depth_range_of(&reference);
                let diffs = [
                    image_diff(&color_image(&ours), &color_image(&reference)),
                    image_diff(&normals_image(&ours), &normals_image(&reference)),
                    image_diff(&depth_image(&ours, lo, hi), &depth_image(&reference, lo, hi)),
                ];
                let errors = compare_frames(&ours, &reference, (lo, hi));
                let mismatches = errors[0].hit_mismatches;
                let non_finite: usize = errors.iter().map(|e| e.non_finite).sum();
                let off = diffs.map(|d| d.off_by_more_than_one);
                let hits = reference.hit.iter().filter(|h| **h).count();
                report.push(format!(
                    "{:<40} rendered: {hits} hits, >1 level (colour, normals, depth) {off:?}, hit/miss {mismatches}",
                    case.name
                ));
                // Pixels more than a level off only where the hit itself differs, and
                // those within the 0.1% contract.
                let allowed = reference.hit.len() / 1000;
                if off.iter().any(|&o| o > mismatches)
                    || mismatches > allowed
                    || non_finite > 0
                    || must_hit != (hits > 0)
                {
                    failures.push(format!(
                        "{}: {off:?} pixels off by >1, {mismatches} hit/miss (≤ {allowed}), {non_finite} NaN/inf, {hits} hits",
                        case.name
                    ));
                }
            }
        }
    }
    println!("{}", report.join("\n"));
    assert!(failures.is_empty(), "{failures:#?}");
}

/// No scene of ours or of the course is refused at the course's size, nor out of range at
/// any size: the bounds cost them nothing, but for the checkerboard of scene7_02, whose
/// texture coordinates reach past what f32 places finely enough for its squares. At 16384²
/// a pixel is finer than f32 resolves for the narrowest cameras only, which are named here.
#[test]
fn every_project_and_course_scene_is_in_range() {
    let mut files = Vec::new();
    let mut dirs = vec![common::scenes_dir(), common::scenes_dir().join("hard")];
    let course = common::corpus();
    dirs.extend(course.iter().flat_map(|c| ["a2", "a3", "a4", "a5", "a6", "a7"].map(|a| c.join(a))));
    for dir in dirs {
        for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|x| x == "txt") && !path.ends_with("commands.txt") {
                files.push(path);
            }
        }
    }
    let mut checked = 0;
    let mut too_fine_at_16384 = Vec::new();
    let mut texture_refused = Vec::new();
    for path in &files {
        let Some((_meshes, scene)) = common::hard::load_listed(path) else { continue };
        checked += 1;
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        match precision::check(&scene, &RenderOptions::all(200, 200)) {
            Err(e) if e.to_string().contains("texture coordinates") => {
                texture_refused.push(name);
                continue;
            }
            result => result.unwrap_or_else(|e| panic!("200x200: {e}")),
        }
        precision::check(&scene, &RenderOptions::all(1, 1)).unwrap_or_else(|e| panic!("1x1: {e}"));
        match precision::check(&scene, &RenderOptions::all(16384, 16384)) {
            Ok(()) => {}
            Err(e) if matches!(e.limit, precision::Limit::Resolution { .. }) => too_fine_at_16384.push(name),
            Err(e) => panic!("16384x16384: {e}"),
        }
    }
    // The folders were found and read: every scene of ours but one, and the course's
    // 16 + 12 + 14 + 12 of assignments 2 to 5, and those of 6 and 7.
    let expected = files.len() - 1;
    assert!(
        checked == expected && expected >= 30 + if course.is_some() { 54 + 20 } else { 0 },
        "{checked} of {} scenes checked",
        files.len()
    );
    let known: &[&str] = if course.is_some() { &["scene7_02_checkerboard.txt"] } else { &[] };
    assert_eq!(texture_refused, known, "refused at 200² for their textures");
    too_fine_at_16384.sort();
    assert_eq!(too_fine_at_16384, ["far_sphere.txt"], "refused at 16384² for resolution");
}

/// `--backend gpu` refuses with the located one-line error and exit status 1, writing
/// nothing; `auto` (at a size where it does try the GPU) renders with the reference, says
/// so in one line, exits 0, and writes
/// the very image `--backend cpu` writes.
#[test]
fn the_command_line_refuses_on_gpu_and_falls_back_on_auto() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let case = Case {
        name: String::new(),
        scene: scene_text(&ortho(4.0), MESH),
        obj: Some("# precision test\n\n  v 0 1e39 -1\nv 1 0 -1\nv 0 1 -1\nf 1 2 3\n".into()),
        expect: Expect::Faithful,
    };
    let scene = write_case(dir.path(), &case);
    let scene = scene.to_str().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = |backend: &str, image: &str| {
        raycaster(&["-input", scene, "-size", "1500", "1500", "-output", image, "--backend", backend])
    };

    let gpu = run("gpu", &out("gpu.tga"));
    let stderr = String::from_utf8_lossy(&gpu.stderr);
    let mesh = dir.path().join("mesh.obj");
    assert_eq!(gpu.status.code(), Some(1), "{stderr}");
    assert_eq!(
        stderr.trim_end(),
        format!(
            "raycaster: {}:3:3: mesh vertex 1: magnitude 1e39 is outside the range the GPU's f32 kernel \
             renders faithfully (0 or 2^-25 to 2^28, with the camera at the origin); render it with --backend cpu",
            mesh.display()
        )
    );
    assert!(!Path::new(&out("gpu.tga")).exists());

    let auto = run("auto", &out("auto.tga"));
    let stderr = String::from_utf8_lossy(&auto.stderr);
    assert_eq!(auto.status.code(), Some(0), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains(&format!("{}:3:3: mesh vertex 1: magnitude 1e39", mesh.display())), "{stderr}");
    assert!(stderr.trim_end().ends_with("; rendering with the f64 CPU reference instead"), "{stderr}");

    let cpu = run("cpu", &out("cpu.tga"));
    assert_eq!(cpu.status.code(), Some(0));
    assert!(cpu.stderr.is_empty());
    assert_eq!(std::fs::read(out("auto.tga")).unwrap(), std::fs::read(out("cpu.tga")).unwrap());
}

/// Assignments 3 and 4's values: a point light's position (from the camera), attenuation
/// and colour, and a material's specular, reflective and transparent colours and exponent
/// need the upper bound; the index of refraction, a ratio, both bounds. Each is refused at
/// the keyword that wrote it, and accepted just inside.
#[test]
fn shading_values_outside_f32_are_refused_where_written() {
    let scene = |light: &str, material: &str| {
        format!(
            "OrthographicCamera {{ center 0 0 5 direction 0 0 -1 up 0 1 0 size 4 }}\n\
             Lights {{ numLights 1\n  {light} }}\n\
             Materials {{ numMaterials 1\n    {material} }}\n\
             Group {{ numObjects 1 MaterialIndex 0 Sphere {{ center 0 0 0 radius 1 }} }}\n"
        )
    };
    let point = |position: f64, attenuation: f64| {
        format!("PointLight {{ position 0 0 {} color 1 1 1 attenuation 1 0 {} }}", n(position), n(attenuation))
    };
    let phong = |exponent: f64, index: f64, reflective: f64| {
        format!(
            "PhongMaterial {{ diffuseColor 1 1 1 specularColor 1 1 1 exponent {} reflectiveColor {} 0 0 \
             transparentColor 0.5 0.5 0.5 indexOfRefraction {} }}",
            n(exponent),
            n(reflective),
            n(index)
        )
    };
    let ok_light = point(10.0, 0.1);
    let ok_material = phong(20.0, 1.5, 0.5);
    let cases = [
        (point(p(28) + 5.0, 0.1), ok_material.clone(), None),
        (point(p(28) + 5.0 + p(5), 0.1), ok_material.clone(), Some((3, 3, "PointLight 1 position from the camera"))),
        (point(10.0, p(29)), ok_material.clone(), Some((3, 3, "PointLight 1 attenuation"))),
        (point(10.0, p(28)), ok_material.clone(), None),
        (ok_light.clone(), phong(p(29), 1.5, 0.5), Some((5, 5, "Material 0 exponent"))),
        (ok_light.clone(), phong(20.0, p(-26), 0.5), Some((5, 5, "Material 0 indexOfRefraction"))),
        (ok_light.clone(), phong(20.0, p(-25), 0.5), None),
        (ok_light.clone(), phong(20.0, 1.5, p(29)), Some((5, 5, "Material 0 reflectiveColor"))),
        (ok_light.clone(), ok_material.clone(), None),
    ];
    let options = raycaster::render::RenderOptions::all(8, 8);
    for (light, material, expected) in cases {
        let text = scene(&light, &material);
        let parsed = raycaster::scene::parse_scene(&text, Path::new("values.txt")).unwrap();
        let result = raycaster::gpu::precision::check(&parsed, &options);
        match (result, expected) {
            (Ok(()), None) => {}
            (Err(e), Some((line, col, what))) => {
                let at = e.location.expect("located");
                assert_eq!((at.line, at.col, e.what.as_str()), (line, col, what), "{text}");
            }
            (result, expected) => panic!("{text}: got {result:?}, expected a refusal of {expected:?}"),
        }
    }
}
