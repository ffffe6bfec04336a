//! A prepared scene pointed at a moved camera (`PreparedScene::aim`, docs/SPEC.md §6 "A
//! camera moved"): the frames it renders are those of a scene prepared for that camera,
//! which the other suites hold to the reference.

mod common;

use glam::{DMat3, DVec3};
use raycaster::gpu::{Acceleration, Aimed, GpuError, GpuOptions, GpuRenderer, PreparedScene};
use raycaster::render::{Frame, RenderOptions, RenderStats};
use raycaster::scene::{parse_scene, Camera, Projection, Scene};
use std::path::Path;

/// A 9 × 9 lattice of small spheres, or of small triangles apart from each other (no two
/// primitives can meet a ray at one distance, so no hierarchy's order can change a hit).
fn lattice(triangles: bool, camera: &str) -> Scene {
    let mut objects = Vec::new();
    for y in -4..=4 {
        for x in -4..=4 {
            let (cx, cy, cz) = (x as f64 * 0.5, y as f64 * 0.55, ((x * 7 + y * 3) % 5) as f64 * 0.1);
            objects.push(match triangles {
                false => format!("Sphere {{ center {cx} {cy} {cz} radius 0.17 }}"),
                true => format!(
                    "Triangle {{ vertex0 {} {} {cz} vertex1 {} {} {} vertex2 {} {} {} }}",
                    cx - 0.2,
                    cy - 0.15,
                    cx + 0.2,
                    cy - 0.1,
                    cz + 0.05,
                    cx,
                    cy + 0.2,
                    cz - 0.05
                ),
            });
        }
    }
    let text = format!(
        "{camera}
         Lights {{ numLights 1 DirectionalLight {{ direction -0.3 -0.4 -1 color 1 1 1 }} }}
         Background {{ color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }}
         Materials {{ numMaterials 1 Material {{ diffuseColor 0.9 0.5 0.2 }} }}
         Group {{ numObjects {} MaterialIndex 0 {} }}",
        objects.len(),
        objects.join("\n")
    );
    parse_scene(&text, Path::new("lattice.txt")).unwrap()
}

const PERSPECTIVE: &str = "PerspectiveCamera { center 0.4 -0.3 6 direction -0.05 0.04 -1 up 0 1 0 angle 45 }";
const ORTHOGRAPHIC: &str = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5.2 }";

/// A floor's checkerboard seen in a mirror and through glass: those pixels are handed over
/// to the reference (docs/SPEC.md §6), which must see them from the moved camera.
const MIRROR_AND_GLASS: &str = "
PerspectiveCamera { center 0 -7 5 direction 0 1 -0.7 up 0 0 1 angle 40 }
Lights { numLights 1 DirectionalLight { direction -0.3 0.4 -1 color 0.8 0.8 0.8 } }
Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }
Materials { numMaterials 4
  Material { diffuseColor 0.75 0.75 0.7 }
  PhongMaterial { diffuseColor 0.1 0.1 0.2 reflectiveColor 0.6 0.6 0.6 }
  Checkerboard { Transform { UniformScale 0.8 Translate 0.1 0.2 0.5 } materialIndex 0 materialIndex 1 }
  PhongMaterial { diffuseColor 0.05 0.05 0.05 transparentColor 0.8 0.8 0.8 indexOfRefraction 1.5 }
}
Group { numObjects 3
  MaterialIndex 2 Plane { normal 0 0 1 offset 0 }
  MaterialIndex 1 Sphere { center -1 1.5 1.2 radius 1 }
  MaterialIndex 3 Sphere { center 1.3 -0.5 1 radius 1 }
}
";

/// `scene` with its camera turned by `angle` radians about its up vector through the origin
/// (as the live view orbits), and for an orthographic camera its view `zoom` times as wide.
fn turned(scene: &Scene, angle: f64, zoom: f64) -> Scene {
    let c = scene.camera;
    let turn = DMat3::from_axis_angle(c.up.normalize(), angle);
    let projection = match c.projection {
        Projection::Orthographic { size } => Projection::Orthographic { size: size * zoom },
        perspective => perspective,
    };
    let camera = Camera::new(projection, turn * c.center, turn * c.direction, c.up, c.location).unwrap();
    Scene { camera, ..scene.clone() }
}

/// A frame's outputs as the tiles hold them: floats, or for a scene prepared `packed` (the
/// live view's and `bench`'s moving frames) the 8-bit colour and normals and the depth's
/// bits as the kernel packed them.
#[derive(PartialEq)]
enum Shown {
    Floats(Frame),
    Packed(Vec<u8>),
}

/// Every output of a prepared scene's frame.
fn frame_of(prepared: &PreparedScene, options: &RenderOptions, packed: bool) -> (Shown, RenderStats) {
    let mut frame = Frame::new(options);
    let mut bytes = Vec::new();
    let stats = prepared
        .render(|tile| {
            match packed {
                false => frame.paste(tile.first_row, &tile.to_frame()),
                true => {
                    bytes.extend(tile.color_rgb());
                    bytes.extend(tile.normals_rgb());
                    bytes.extend(tile.depth_values().iter().flat_map(|t| t.to_le_bytes()));
                }
            }
            Ok::<(), GpuError>(())
        })
        .unwrap();
    (if packed { Shown::Packed(bytes) } else { Shown::Floats(frame) }, stats)
}

/// The frame of `scene` prepared afresh, `packed` or as floats.
fn fresh(gpu: &GpuRenderer, scene: &Scene, options: &RenderOptions, packed: bool) -> (Shown, RenderStats) {
    frame_of(&gpu.prepare(scene, options, packed).unwrap(), options, packed)
}

/// Turns the camera of `scene` step by step, aiming one prepared scene (`packed` or not) at
/// each camera: each frame is the fresh one, and differs from the frame before (the camera
/// did move). Returns how many aims were in place.
fn orbit(gpu: &GpuRenderer, scene: &Scene, options: &RenderOptions, steps: &[f64], packed: bool) -> usize {
    let mut prepared = gpu.prepare(scene, options, packed).unwrap();
    let (mut before, _) = frame_of(&prepared, options, packed);
    let mut in_place = 0;
    for (k, &angle) in steps.iter().enumerate() {
        let moved = turned(scene, angle, 1.0);
        in_place += (prepared.aim(&moved).unwrap() == Aimed::InPlace) as usize;
        let (aimed, stats) = frame_of(&prepared, options, packed);
        let (expected, fresh_stats) = fresh(gpu, &moved, options, packed);
        assert!(aimed == expected, "step {k} ({angle} rad) differs from a scene prepared for its camera");
        assert_eq!(stats.acceleration, fresh_stats.acceleration, "step {k}");
        assert_eq!(stats.pixels_beyond_reach, fresh_stats.pixels_beyond_reach, "step {k}");
        assert!(aimed != before, "step {k}: the camera moved, so the image does");
        before = aimed;
    }
    in_place
}

/// The ways a scene's buffers travel: mapped by the host where the adapter allows it (a CPU
/// adapter, as here), and copied through staging and readback buffers, as on a discrete GPU.
const MAPPED_AND_COPIED: [bool; 2] = [true, false];

#[test]
fn an_aimed_scene_renders_what_a_scene_prepared_for_its_camera_renders() {
    let Some(gpu) = common::gpu() else { return };
    let options = RenderOptions::all(61, 53);
    let steps = [0.04, 0.1, 0.25, -0.2, 0.0];
    for acceleration in [Acceleration::Bins, Acceleration::Hierarchy] {
        for mapped_buffers in MAPPED_AND_COPIED {
            let gpu = gpu.on_same_device(GpuOptions {
                acceleration,
                mapped_buffers,
                max_tile_bytes: 61 * 8 * 32,
                ..GpuOptions::default()
            });
            for (triangles, camera, packed) in ways() {
                let scene = lattice(triangles, camera);
                let in_place = orbit(&gpu, &scene, &options, &steps, packed);
                // Small turns keep the bins' lists within the slots; the hierarchy always fits.
                let least = if acceleration == Acceleration::Hierarchy { steps.len() } else { 1 };
                let case = format!("{acceleration:?}, mapped {mapped_buffers}, triangles {triangles}, packed {packed}");
                assert!(in_place >= least, "{case}: {in_place} aims in place");
            }
        }
    }
}

/// Spheres or triangles, seen in perspective or orthographically, as floats or packed.
fn ways() -> impl Iterator<Item = (bool, &'static str, bool)> {
    let scenes = [false, true].into_iter().flat_map(|t| [PERSPECTIVE, ORTHOGRAPHIC].map(|c| (t, c)));
    scenes.flat_map(|(triangles, camera)| [false, true].map(|packed| (triangles, camera, packed)))
}

/// Under sampling (docs/SPEC.md §8: jittered samples and a tent filter reaching into the
/// neighbouring rows), whose bins hold rays anywhere in a pixel, an aimed frame is the fresh
/// one too.
#[test]
fn an_aimed_sampled_scene_renders_what_a_scene_prepared_for_its_camera_renders() {
    use raycaster::sampling::{Filter, Sampler, Sampling};
    let Some(gpu) = common::gpu() else { return };
    let sampling = Sampling { sampler: Sampler::Jittered(4), filter: Filter::Tent(1.5), seed: 5 };
    let options = RenderOptions { sampling: Some(sampling), ..RenderOptions::all(45, 37) };
    for acceleration in [Acceleration::Bins, Acceleration::Hierarchy] {
        let gpu = gpu.on_same_device(GpuOptions { acceleration, max_tile_bytes: 45 * 6 * 32, ..GpuOptions::default() });
        for packed in [false, true] {
            let in_place = orbit(&gpu, &lattice(true, PERSPECTIVE), &options, &[0.05, -0.1, 0.2], packed);
            assert!(in_place >= 1, "{acceleration:?}, packed {packed}: {in_place} aims in place");
        }
    }
}

/// With `-grid` the kernel walks the grid, whose box is camera-relative, and with
/// `-visualize_grid` it draws the grid's cells (docs/SPEC.md §7): an aimed frame is the
/// fresh one for both.
#[test]
fn an_aimed_scene_with_a_grid_renders_what_a_scene_prepared_for_its_camera_renders() {
    use raycaster::grid::GridSize;
    let Some(gpu) = common::gpu() else { return };
    let grid = Some(GridSize { nx: 7, ny: 6, nz: 3 });
    for visualize_grid in [false, true] {
        let options = RenderOptions { grid, visualize_grid, ..RenderOptions::all(40, 36) };
        let in_place = orbit(gpu, &lattice(false, PERSPECTIVE), &options, &[0.05, -0.1, 0.2], false);
        assert_eq!(in_place, 3, "visualize_grid {visualize_grid}");
    }
}

/// Reflected, refracted and shadow rays walk what the camera moved too, and the pixels
/// handed over to the reference are rendered from the moved camera.
#[test]
fn an_aimed_scene_hands_over_what_the_moved_camera_sees() {
    let Some(gpu) = common::gpu() else { return };
    let scene = parse_scene(MIRROR_AND_GLASS, Path::new("mirrors.txt")).unwrap();
    let mut options = RenderOptions::all(48, 40);
    options.shading.bounces = 3;
    options.shading.shadows = true;
    let (_, stats) = fresh(gpu, &scene, &options, false);
    assert!(stats.pixels_beyond_reach > 0, "the test means something: {stats:?}");
    for mapped_buffers in MAPPED_AND_COPIED {
        let gpu = gpu.on_same_device(GpuOptions { mapped_buffers, ..GpuOptions::default() });
        for packed in [false, true] {
            let in_place = orbit(&gpu, &scene, &options, &[0.05, 0.12, -0.08], packed);
            assert_eq!(in_place, 3, "mapped {mapped_buffers}, packed {packed}");
        }
    }
}

/// Lists that outgrow the slots' buffers (the lattice seen from the side, with bins: its
/// spheres line up behind each other, each bin listing a row of them) prepare the scene
/// again, which then renders the fresh frame.
#[test]
fn a_camera_that_outgrows_the_slots_prepares_again() {
    let Some(gpu) = common::gpu() else { return };
    let options = RenderOptions::all(64, 64);
    let scene = lattice(false, PERSPECTIVE);
    let side = turned(&scene, 1.3, 1.0);
    for mapped_buffers in MAPPED_AND_COPIED {
        let gpu = gpu.on_same_device(GpuOptions {
            acceleration: Acceleration::Bins,
            mapped_buffers,
            ..GpuOptions::default()
        });
        let mut prepared = gpu.prepare(&scene, &options, false).unwrap();
        assert_eq!(prepared.aim(&side).unwrap(), Aimed::Prepared, "mapped {mapped_buffers}");
        assert!(frame_of(&prepared, &options, false).0 == fresh(&gpu, &side, &options, false).0);
        // And back: the larger slots hold the first camera's lists.
        assert_eq!(prepared.aim(&scene).unwrap(), Aimed::InPlace, "mapped {mapped_buffers}");
        assert!(frame_of(&prepared, &options, false).0 == fresh(&gpu, &scene, &options, false).0);
    }
}

/// A camera the f32 kernel cannot serve (docs/SPEC.md §6: a sphere more than 2¹³ of its
/// radii away) is refused as `prepare` refuses it, and the prepared scene keeps its camera.
#[test]
fn a_camera_too_far_for_the_precision_contract_is_refused_and_the_scene_kept() {
    let Some(gpu) = common::gpu() else { return };
    let options = RenderOptions::all(40, 30);
    let scene = lattice(false, ORTHOGRAPHIC);
    let mut prepared = gpu.prepare(&scene, &options, false).unwrap();
    let c = scene.camera;
    let far = Camera::new(c.projection, c.center + DVec3::new(0.0, 0.0, 4000.0), c.direction, c.up, c.location);
    let far = Scene { camera: far.unwrap(), ..scene.clone() };
    assert!(matches!(gpu.prepare(&far, &options, false), Err(GpuError::Precision(_))));
    assert!(matches!(prepared.aim(&far), Err(GpuError::Precision(_))));
    assert!(frame_of(&prepared, &options, false).0 == fresh(gpu, &scene, &options, false).0);
}
