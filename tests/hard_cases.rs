//! The hard cases of `scenes/hard/`, where ray casters usually fail, rendered on the GPU with
//! each kernel variant and judged against the f64 reference. The default variant (watertight
//! triangles, robust spheres) must pass every case; the weaker variants' failures are asserted
//! too, so the published table (printed with --nocapture) cannot change silently.

mod common;

use common::hard::load_hard_ok;
use raycaster::gpu::Acceleration;
use raycaster::metrics::{compare_frames, image_diff};
use raycaster::render::{Frame, Output, RenderOptions, SphereTest, TriangleTest};
use raycaster::scene::Scene;

/// The kernel variants every case runs with: the default first.
const VARIANTS: [(TriangleTest, SphereTest); 4] = [
    (TriangleTest::Watertight, SphereTest::Robust),
    (TriangleTest::Moller, SphereTest::Robust),
    (TriangleTest::Cramer, SphereTest::Robust),
    (TriangleTest::Watertight, SphereTest::Naive),
];

/// How a case judges the GPU's frame: the number of failing pixels, and how many may fail.
#[derive(Clone, Copy)]
enum Criterion {
    /// Pixels the reference hits and the GPU misses (cracks); none allowed.
    NoCracks,
    /// Pixels the GPU misses; every pixel must hit.
    EveryPixelHits,
    /// Pixels off by more than 1 level in any output (colour, normals, depth) against the
    /// reference, plus NaN/infinite values; at most 0.1% of the pixels, no NaN.
    AgreesWithReference,
    /// As `AgreesWithReference`, but against the reference of another scene (the same scene
    /// moved or scaled), with that scene's depth range.
    AgreesWith { scene: &'static str, depth: (f32, f32) },
    /// Only the normals image is judged (≤ 0.1% off by more than 1 level, no NaN).
    NormalsAgree,
}

struct Case {
    scene: &'static str,
    size: u32,
    depth: (f32, f32),
    criterion: Criterion,
    /// Expected pass (true) or fail, per entry of VARIANTS.
    expected: [bool; 4],
}

const PASS_ALL: [bool; 4] = [true; 4];

fn cases() -> Vec<Case> {
    use Criterion::*;
    let case = |scene, size, depth, criterion, expected| Case { scene, size, depth, criterion, expected };
    vec![
        case("closed_mesh_outside.txt", 200, (3.0, 4.0), NoCracks, PASS_ALL),
        case("closed_mesh_inside.txt", 200, (0.0, 2.0), EveryPixelHits, PASS_ALL),
        case("grid_vertices_on_pixel_centres.txt", 64, (9.0, 11.0), EveryPixelHits, PASS_ALL),
        case("grid_edges_on_pixel_centres.txt", 64, (9.0, 11.0), EveryPixelHits, PASS_ALL),
        case("grid_diagonals_on_pixel_centres.txt", 64, (9.0, 11.0), EveryPixelHits, PASS_ALL),
        // Rounding decides each shared edge: only the watertight test never cracks.
        case("grid_diagonals_rotated.txt", 64, (9.0, 11.0), EveryPixelHits, [true, false, false, true]),
        // 5000 units away, b² − 4ac cancels to noise in f32.
        case("far_sphere.txt", 200, (4999.0, 5000.0), AgreesWithReference, [true, true, true, false]),
        case(
            "offset_translated_1e6.txt",
            200,
            (4.0, 14.0),
            AgreesWith { scene: "offset_base.txt", depth: (4.0, 14.0) },
            PASS_ALL,
        ),
        case(
            "offset_scaled_1e-4.txt",
            200,
            (0.0004, 0.0014),
            AgreesWith { scene: "offset_base.txt", depth: (4.0, 14.0) },
            PASS_ALL,
        ),
        case(
            "offset_scaled_1e4.txt",
            200,
            (40000.0, 140000.0),
            AgreesWith { scene: "offset_base.txt", depth: (4.0, 14.0) },
            PASS_ALL,
        ),
        // The unit-sphere space is stretched 10⁴ times: the same cancellation.
        case("squashed_sphere.txt", 200, (9.0, 11.0), NormalsAgree, [true, true, true, false]),
        case("horizon_plane.txt", 200, (0.0, 1.0), AgreesWithReference, PASS_ALL),
        case("edge_on_triangles.txt", 64, (17.0, 19.0), AgreesWithReference, PASS_ALL),
        case("degenerate_triangles.txt", 64, (14.0, 18.0), AgreesWithReference, PASS_ALL),
    ]
}

fn options(size: u32, (triangle_test, sphere_test): (TriangleTest, SphereTest)) -> RenderOptions {
    RenderOptions { triangle_test, sphere_test, ..RenderOptions::all(size, size) }
}

/// Pixels off by more than one level in the worst output, and NaN/inf counts.
fn disagreement(ours: &Frame, reference: &Frame, our_depth: (f32, f32), reference_depth: (f32, f32)) -> usize {
    use raycaster::image_io::{color_image, depth_image, normals_image};
    let diffs = [
        image_diff(&color_image(ours), &color_image(reference)),
        image_diff(&normals_image(ours), &normals_image(reference)),
        image_diff(
            &depth_image(ours, our_depth.0, our_depth.1),
            &depth_image(reference, reference_depth.0, reference_depth.1),
        ),
    ];
    diffs.iter().map(|d| d.off_by_more_than_one).max().unwrap_or(0)
}

/// (failing pixels, passes) of one case for one GPU frame.
fn judge(case: &Case, ours: &Frame, reference: &Frame, other: Option<&Frame>) -> (usize, bool) {
    let allowed = ours.hit.len() / 1000;
    let errors = compare_frames(ours, reference, case.depth);
    let nan: usize = errors.iter().map(|e| e.non_finite).sum();
    match case.criterion {
        Criterion::NoCracks => {
            let cracks = (0..ours.hit.len()).filter(|&k| reference.hit[k] && !ours.hit[k]).count();
            (cracks + nan, cracks == 0 && nan == 0)
        }
        Criterion::EveryPixelHits => {
            let misses = ours.hit.iter().filter(|h| !**h).count();
            (misses + nan, misses == 0 && nan == 0)
        }
        Criterion::AgreesWithReference => {
            let off = disagreement(ours, reference, case.depth, case.depth);
            (off + nan, off <= allowed && nan == 0)
        }
        Criterion::AgreesWith { depth, .. } => {
            let off = disagreement(ours, other.expect("the other scene's reference"), case.depth, depth);
            (off + nan, off <= allowed && nan == 0)
        }
        Criterion::NormalsAgree => {
            let normals = errors.iter().find(|e| e.output == Output::Normals).unwrap();
            let off = normals.image.off_by_more_than_one;
            (off + normals.non_finite, off <= allowed && normals.non_finite == 0)
        }
    }
}

/// One row of the error table: the default variant against the reference of the same scene.
fn errors_row(name: &str, ours: &Frame, reference: &Frame, depth: (f32, f32)) -> String {
    let errors = compare_frames(ours, reference, depth);
    let of = |o: Output| errors.iter().find(|e| e.output == o).unwrap();
    let (colour, normals, depth) = (of(Output::Color), of(Output::Normals), of(Output::Depth));
    format!(
        "| {name} | {} | {} | {} | {} | {:.1e} | {:.1e} | {} |\n",
        colour.image.off_by_more_than_one,
        normals.image.off_by_more_than_one,
        depth.image.off_by_more_than_one,
        colour.hit_mismatches,
        depth.relative_max.unwrap_or(0.0),
        normals.float_max,
        colour.non_finite + normals.non_finite + depth.non_finite
    )
}

fn render_reference(scene: &Scene, size: u32) -> Frame {
    raycaster::cpu::render(scene, &RenderOptions::all(size, size))
}

#[test]
fn hard_cases_per_variant() {
    let Some(gpu) = common::gpu() else { return };
    // The default variant once more with each way of finding candidates forced: it must pass
    // every case with bins and with the hierarchy too.
    let forced: Vec<_> = common::ACCELERATIONS[1..].iter().map(|&a| (a, common::gpu_with(a).unwrap())).collect();
    let mut names: Vec<String> = VARIANTS.iter().map(|(t, s)| format!("{}/{}", t.name(), s.name())).collect();
    names.extend(forced.iter().map(|(a, _)| format!("default, {}", a.name())));
    let mut table = format!("| case | {} |\n| --- |{}\n", names.join(" | "), " ---: |".repeat(names.len()));
    let mut errors_table = String::from(
        "| case | colour >1 | normals >1 | depth >1 | hit/miss | depth rel. max | normal max (rad) | NaN/inf |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    let mut surprises = Vec::new();
    for case in cases() {
        let (_dir, scene) = load_hard_ok(case.scene);
        let reference = render_reference(&scene, case.size);
        let other = match case.criterion {
            Criterion::AgreesWith { scene: other, .. } => Some(render_reference(&load_hard_ok(other).1, case.size)),
            _ => None,
        };
        let mut cells = Vec::new();
        for (k, variant) in VARIANTS.iter().enumerate() {
            let ours = gpu.render(&scene, &options(case.size, *variant)).unwrap();
            if k == 0 {
                errors_table.push_str(&errors_row(case.scene, &ours, &reference, case.depth));
            }
            let (failing, passes) = judge(&case, &ours, &reference, other.as_ref());
            cells.push(format!("{} {failing}", if passes { "pass" } else { "FAIL" }));
            if passes != case.expected[k] {
                surprises.push(format!(
                    "{} with {}: expected {}, got {failing} failing pixels",
                    case.scene,
                    names[k],
                    if case.expected[k] { "pass" } else { "fail" }
                ));
            }
        }
        for (acceleration, renderer) in &forced {
            let ours = renderer.render(&scene, &options(case.size, VARIANTS[0])).unwrap();
            let (failing, passes) = judge(&case, &ours, &reference, other.as_ref());
            cells.push(format!("{} {failing}", if passes { "pass" } else { "FAIL" }));
            if passes != case.expected[0] {
                surprises.push(format!(
                    "{} with the default variant and {}: {failing} failing pixels",
                    case.scene,
                    acceleration.name()
                ));
            }
        }
        table.push_str(&format!("| {} | {} |\n", case.scene, cells.join(" | ")));
    }
    println!("Failing pixels per hard case and kernel variant (criteria in tests/hard_cases.rs):\n{table}");
    println!("\nThe default variant against the f64 reference of the same scene:\n{errors_table}");
    assert!(surprises.is_empty(), "{surprises:#?}");
}

/// `Scale 1 0 1` is refused at load time with its line and column; nothing is written.
#[test]
fn singular_transform_is_a_located_load_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let scene = common::hard::hard_dir().join("singular_transform.txt");
    let result = std::process::Command::new(env!("CARGO_BIN_EXE_raycaster"))
        .args([
            "-input",
            scene.to_str().unwrap(),
            "-size",
            "20",
            "20",
            "-output",
            out.to_str().unwrap(),
            "--backend",
            "cpu",
        ])
        .output()
        .unwrap();
    let message = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success());
    assert!(message.contains("singular_transform.txt:35:5: singular transform"), "{message}");
    assert!(!out.exists());
}

/// Degenerate (point, segment, collinear, sliver) and edge-on triangles, alone and in a mesh,
/// seen by perspective cameras at several positions (scenes/hard/degenerate_perspective.txt,
/// its `center` line rewritten), with shadows and every way of finding candidates (flat
/// loops too): within the 0.1 % of
/// the f64 reference in every output. Run with RAYCASTER_FUSE_MUL_ADD=1 (CI does), a
/// driver that fuses multiply-adds is emulated; a fused edge function made a point cover the
/// whole image (docs/SPEC.md §6).
#[test]
fn degenerate_and_edge_on_triangles_from_several_cameras() {
    let Some(_) = common::gpu() else { return };
    let hard = common::hard::hard_dir();
    let text = std::fs::read_to_string(hard.join("degenerate_perspective.txt")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(hard.join("degenerate.obj"), dir.path().join("degenerate.obj")).unwrap();
    let centres = ["0.31 0.17 6", "-2.3 1.9 4.5", "3.1 -0.4 2.2", "0.1234 0.5678 5", "0.31 -0.7 4"];
    let size = 100;
    // Flat loops test every triangle with every ray; shadow rays test them again from the
    // surface behind, whatever finds the candidates.
    let accelerations = [Acceleration::Flat, Acceleration::Bins, Acceleration::Hierarchy, Acceleration::Auto];
    let mut options = options(size, VARIANTS[0]);
    options.shading.shadows = true;
    let case =
        Case { scene: "", size, depth: (0.0, 12.0), criterion: Criterion::AgreesWithReference, expected: PASS_ALL };
    let mut failures = Vec::new();
    for centre in centres {
        let moved = text.replacen("center 0.31 0.17 6", &format!("center {centre}"), 1);
        let path = dir.path().join("scene.txt");
        std::fs::write(&path, &moved).unwrap();
        let scene = raycaster::scene::load_scene(&path).unwrap();
        let reference = raycaster::cpu::render(&scene, &options);
        for acceleration in accelerations {
            let ours = common::gpu_with(acceleration).unwrap().render(&scene, &options).unwrap();
            let (failing, passes) = judge(&case, &ours, &reference, None);
            println!("camera at {centre}, {}: {failing} failing pixels of {}", acceleration.name(), size * size);
            if !passes {
                failures.push(format!("camera at {centre}, {}: {failing} pixels off", acceleration.name()));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
