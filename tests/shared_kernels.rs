//! Kernels shared by small renders (`gpu::KernelConfig::shared`): the light count,
//! `-shade_back` and the camera's kind read from the parameters, point lights, specular
//! colours, several materials and (where the adapter binds every buffer) spheres, planes and
//! triangles compiled in. A shared kernel must render what its
//! scene's own kernel renders (the one the reference tests hold to the contract at sizes
//! past the sharing limit), and it must actually be shared.

mod common;

use raycaster::gpu::{GpuOptions, GpuRenderer, SHARED_KERNEL_MAX_SAMPLES};
use raycaster::render::{Frame, RenderOptions, Shading};
use raycaster::scene::{load_scene, parse_scene, Scene};
use std::path::{Path, PathBuf};

/// Two renderers on the test device: one sharing kernels among small renders (the
/// default), one compiling each scene its own.
fn renderers() -> Option<(GpuRenderer, GpuRenderer)> {
    let gpu = common::gpu()?;
    let shared = gpu.on_same_device(GpuOptions::default());
    let own = gpu.on_same_device(GpuOptions { share_small_kernels: false, ..GpuOptions::default() });
    Some((shared, own))
}

/// The shadings the course's assignments 2 to 4 use: none, shadows, and a ray tree with
/// back faces shaded.
fn shadings() -> [Shading; 3] {
    [
        Shading::default(),
        Shading { shadows: true, ..Shading::default() },
        Shading { shadows: true, bounces: 3, weight: 0.01, shade_back: true, ..Shading::default() },
    ]
}

/// Where two frames differ: in what a pixel hits, its normal or its depth (bit for bit:
/// the camera's ray and the intersection tests are the same WGSL in both kernels, with
/// their products rounded where a compiler could fuse them, shaders/exact.wgsl), or in
/// its colour by more than [`COLOR_ROUNDINGS`].
fn first_difference(a: &Frame, b: &Frame) -> Option<String> {
    let bits3 = |v: &[f32; 3]| v.map(f32::to_bits);
    let close = |x: f32, y: f32| (x - y).abs() <= COLOR_ROUNDINGS * x.abs().max(y.abs());
    (0..a.hit.len()).find_map(|k| {
        let what = if a.hit[k] != b.hit[k] {
            "hit"
        } else if bits3(&a.normal[k]) != bits3(&b.normal[k]) {
            "normal"
        } else if a.depth[k].to_bits() != b.depth[k].to_bits() {
            "depth"
        } else if !(0..3).all(|c| close(a.color[k][c], b.color[k][c])) {
            "colour"
        } else {
            return None;
        };
        Some(format!(
            "{what} at ({}, {}): {:?} against {:?}",
            k as u32 % a.width,
            k as u32 / a.width,
            a.color[k],
            b.color[k]
        ))
    })
}

/// How far a shared kernel's colour may lie from the scene's own kernel's, relative to it:
/// the colour is a sum of products (ambient, and per light and surface of a tree a diffuse
/// and a specular term), and WGSL lets a compiler fuse a product into the sum or not, each
/// choice one rounding (2⁻²⁴) apart. A shared kernel's loop over the lights is shaped
/// otherwise than a loop unrolled for a fixed count, and lavapipe fuses them differently
/// (1 or 2 ulps, seen in these tests); 2⁻²⁰ allows 16 such roundings and lies far below
/// an 8-bit image's half level (2⁻⁹): `scripts/compare_builds.py` finds the course's images
/// byte for byte the same.
const COLOR_ROUNDINGS: f32 = 1.0 / (1 << 20) as f32;

/// Renders `scene` with both renderers under each shading and returns what differs.
fn differences(shared: &GpuRenderer, own: &GpuRenderer, name: &str, scene: &Scene, size: u32) -> Vec<String> {
    let mut found = Vec::new();
    for shading in shadings() {
        let options = RenderOptions { shading, ..RenderOptions::all(size, size) };
        // A scene the GPU refuses (precision, a driver limit) is refused by both alike.
        match (shared.render(scene, &options), own.render(scene, &options)) {
            (Ok(a), Ok(b)) => {
                if let Some(d) = first_difference(&a, &b) {
                    found.push(format!("{name} {shading:?}: {d}"));
                }
            }
            (Err(_), Err(_)) => {}
            (a, b) => found.push(format!("{name} {shading:?}: shared {:?}, own {:?}", a.err(), b.err())),
        }
    }
    found
}

fn scene_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .filter(|p| p.file_name().unwrap() != "commands.txt")
        .collect();
    files.sort();
    files
}

/// The repository's scenes, the hard cases among them (degenerate and edge-on triangles,
/// far and offset scenes, orthographic cameras behind the scene): every float the same.
#[test]
fn shared_kernels_render_the_repository_scenes_as_their_own_kernels() {
    let Some((shared, own)) = renderers() else { return };
    let dir = common::scenes_dir();
    let mut found = Vec::new();
    let mut rendered = 0;
    for path in scene_files(&dir).into_iter().chain(scene_files(&dir.join("hard"))) {
        let Ok(scene) = load_scene(&path) else { continue };
        found.extend(differences(&shared, &own, &path.display().to_string(), &scene, 40));
        rendered += 1;
    }
    assert!(rendered >= 20, "only {rendered} scenes loaded");
    assert!(shared.kernels_compiled() < own.kernels_compiled(), "the shared renderer compiled as many kernels");
    assert!(found.is_empty(), "{} renders differ:\n{}", found.len(), found.join("\n"));
}

/// Assignment 4's scenes (point lights, specular, transparent and mirrored materials,
/// orthographic and perspective cameras), where the course's files are beside us.
#[test]
fn shared_kernels_render_the_course_scenes_as_their_own_kernels() {
    let Some(corpus) = common::corpus() else { return };
    let Some((shared, own)) = renderers() else { return };
    let mut found = Vec::new();
    for path in scene_files(&corpus.join("a4")) {
        let scene = load_scene(&path).expect("the course's scene loads");
        found.extend(differences(&shared, &own, &path.display().to_string(), &scene, 64));
    }
    assert!(found.is_empty(), "{} renders differ:\n{}", found.len(), found.join("\n"));
}

/// Where the adapter binds every buffer, spheres, planes and triangles are compiled into a
/// shared kernel whether the scene has them or not: scenes of spheres alone, of triangles
/// alone and of both share one kernel, each image its own kernel's. Elsewhere each kind
/// keeps its bindings, and so its kernels.
#[test]
fn small_renders_of_spheres_or_triangles_alone_share_one_kernel_where_every_buffer_binds() {
    let Some((shared, own)) = renderers() else { return };
    let every_buffer =
        shared.device().limits().max_storage_buffers_per_shader_stage as usize >= raycaster::gpu::Binding::ALL.len();
    let objects = [
        "numObjects 2 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } Plane { normal 0 1 0 offset -1 }",
        "numObjects 1 MaterialIndex 0 Triangle { vertex0 -2 -1 0 vertex1 2 -1 0 vertex2 0 2 0 }",
        "numObjects 2 MaterialIndex 0 Sphere { center 1 0 1 radius 0.5 } Triangle { vertex0 -2 -1 0 vertex1 2 -1 0 vertex2 0 2 0 }",
    ];
    let options = RenderOptions { shading: shadings()[1], ..RenderOptions::all(32, 32) };
    for (k, group) in objects.iter().enumerate() {
        let text = format!(
            "{PERSPECTIVE}
             Lights {{ numLights 1 DirectionalLight {{ direction -0.5 -1 -1 color 0.8 0.8 0.8 }} }}
             Background {{ color 0.1 0.1 0.2 ambientLight 0.1 0.1 0.1 }}
             Materials {{ numMaterials 1 PhongMaterial {{ diffuseColor 0.8 0.3 0.3 }} }}
             Group {{ {group} }}"
        );
        let scene = parse_scene(&text, Path::new("kinds.txt")).expect("the generated scene parses");
        let (a, b) = (shared.render(&scene, &options).unwrap(), own.render(&scene, &options).unwrap());
        assert!(a.hit.iter().any(|&h| h) && a.hit.iter().any(|&h| !h), "scene {k} hits and misses");
        assert_eq!(first_difference(&a, &b), None, "scene {k}");
    }
    assert_eq!(own.kernels_compiled(), 3);
    assert_eq!(shared.kernels_compiled(), if every_buffer { 1 } else { 3 });
}

/// A scene: `lights` directional lights, or one point light, two spheres, a plane and a
/// triangle turned away from the camera (black unless `-shade_back`) under `camera`, with a
/// specular material or not.
fn scene(camera: &str, lights: usize, point_light: bool, specular: bool) -> Scene {
    let light = if point_light {
        "PointLight { position 0 3 3 color 1 1 1 attenuation 1 0.1 0 }".to_string()
    } else {
        "DirectionalLight { direction -0.5 -1 -1 color 0.5 0.5 0.5 }".repeat(lights)
    };
    let count = if point_light { 1 } else { lights };
    let specular = if specular { "specularColor 0.5 0.5 0.5 exponent 10" } else { "" };
    let text = format!(
        "{camera}
         Lights {{ numLights {count} {light} }}
         Background {{ color 0.1 0.1 0.2 ambientLight 0.1 0.1 0.1 }}
         Materials {{ numMaterials 2
           PhongMaterial {{ diffuseColor 0.8 0.3 0.3 {specular} }}
           PhongMaterial {{ diffuseColor 0.3 0.8 0.3 reflectiveColor 0.5 0.5 0.5 }} }}
         Group {{ numObjects 4
           MaterialIndex 0 Sphere {{ center 0 0 0 radius 1 }}
           Triangle {{ vertex0 -2.5 0.5 1 vertex1 -2.5 1.5 1 vertex2 -1.5 0.5 1 }}
           MaterialIndex 1 Plane {{ normal 0 1 0 offset -1 }}
           Sphere {{ center 1.5 0 -1 radius 0.5 }} }}"
    );
    parse_scene(&text, Path::new("generated.txt")).expect("the generated scene parses")
}

const PERSPECTIVE: &str = "PerspectiveCamera { center 0 1 6 direction 0 -0.15 -1 up 0 1 0 angle 40 }";
const ORTHOGRAPHIC: &str = "OrthographicCamera { center 0 1 6 direction 0 -0.15 -1 up 0 1 0 size 5 }";

/// Scenes that differ in their light count, point lights, specular colours, camera and
/// `-shade_back` run one kernel when small, and each its own when large, or when the
/// renderer is told not to share; every image the same either way.
#[test]
fn small_renders_of_different_scenes_share_one_kernel() {
    let Some((shared, own)) = renderers() else { return };
    let scenes = [
        scene(PERSPECTIVE, 1, false, false),
        scene(PERSPECTIVE, 3, false, true),
        scene(PERSPECTIVE, 0, true, false),
        scene(ORTHOGRAPHIC, 2, false, true),
    ];
    let shadings = [
        Shading { shadows: true, ..Shading::default() },
        Shading { shadows: true, shade_back: true, ..Shading::default() },
    ];
    let small = |shading| RenderOptions { shading, ..RenderOptions::all(32, 32) };
    for (k, scene) in scenes.iter().enumerate() {
        for shading in shadings {
            let (a, b) = (shared.render(scene, &small(shading)).unwrap(), own.render(scene, &small(shading)).unwrap());
            assert_eq!(first_difference(&a, &b), None, "scene {k}, {shading:?}");
        }
    }
    assert_eq!(shared.kernels_compiled(), 1, "8 small renders of 4 scenes share one kernel");
    assert_eq!(own.kernels_compiled(), 8, "each scene and shading compiles its own");

    // Past the limit a render gets its own kernel.
    let side = (SHARED_KERNEL_MAX_SAMPLES as f64).sqrt() as u32;
    let large = RenderOptions { shading: shadings[0], ..RenderOptions::all(side + 1, side) };
    shared.render(&scenes[0], &large).unwrap();
    assert_eq!(shared.kernels_compiled(), 2, "a render of more than SHARED_KERNEL_MAX_SAMPLES samples");
}
