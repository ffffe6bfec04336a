//! Assignment 6's solid textures on the f64 reference, each against an answer the
//! renderer did not produce:
//!
//! - Perlin's improved noise against values from an independent transcription of his
//!   reference Java code (`tests/data/perlin_reference.py`, run with python3; its
//!   permutation is copied from a public port, not from ours);
//! - the checkerboard against the parity of `floor x + floor y + floor z` of each pixel's hit
//!   point, carried into texture space by the test itself;
//! - the course's marble-and-noise image `output6_15`, by its own command line inside a
//!   copy of `a6/`, under the course-image contract; the wood image `output6_16` ("no right
//!   answer") is only compared and printed;
//! - the GPU kernel's f32 textures against the same answers and against the reference,
//!   under the 0.1 % contract: its refusal of texture coordinates just outside its
//!   precision contract (and not just inside); the far pixels of a plane seen to the
//!   horizon, handed to the reference, exactly those whose texture coordinates the test
//!   finds beyond reach; wood rings on a plane met by grazing rays; and a texture that
//!   blends a mirror and glass under `-bounces`.

mod common;

use glam::{DMat4, DVec3};
use raycaster::cpu::texture::{improved_noise, turbulence, PERMUTATION};
use raycaster::render::RenderOptions;
use raycaster::scene::{parse_scene, Location};
use std::path::Path;

/// `tests/data/perlin_reference.py`'s output (Perlin's `ImprovedNoise.noise`), printed with
/// Python's `repr`: every digit of the f64.
const PERLIN_REFERENCE: [([f64; 3], f64); 5] = [
    ([0.3, 0.7, 1.9], 0.36114951505958337),
    ([-2.25, 3.5, 0.125], 0.11533115059137344),
    ([12.34, -5.67, 8.9], 0.17869158358011097),
    // Beyond 256 cells the lattice wraps: this exercises the modulo of negative cells too.
    ([100.5, 200.25, -300.75], 0.20992088317871094),
    ([0.5, 0.5, 0.5], -0.25),
];

#[test]
fn improved_noise_matches_perlins_reference_code() {
    for (p, want) in PERLIN_REFERENCE {
        let got = improved_noise(DVec3::from_array(p));
        // The same operations in the same order: equal to the last bit but for the
        // compiler's freedom with fused multiply-adds, which Rust does not take.
        assert_eq!(got, want, "noise{p:?}");
    }
    // The handout's sum of octaves, N = Σ_{k<5} noise(2ᵏ p) / 2ᵏ, from the same script.
    assert_eq!(turbulence(DVec3::new(0.3, 0.7, 1.9), 5), 0.6788529153650429);
    assert_eq!(turbulence(DVec3::new(0.3, 0.7, 1.9), 0), 0.0, "no octaves, no noise");
}

#[test]
fn improved_noise_is_zero_on_the_lattice() {
    // Every gradient is dotted with the offset to its corner, which is zero at the corner
    // itself, and the fade curve weights that corner alone (Perlin 2002).
    for x in -3..3 {
        for (y, z) in [(0, 0), (-7, 250), (255, 256), (1000, -1000)] {
            assert_eq!(improved_noise(DVec3::new(x as f64, y as f64, z as f64)), 0.0, "({x}, {y}, {z})");
        }
    }
    let mut sorted = PERMUTATION;
    sorted.sort();
    assert!(sorted.iter().enumerate().all(|(k, &v)| v as usize == k), "a permutation of 0..=255");
}

const CHECKER_SIZE: u32 = 96;

/// An orthographic camera looking down −z at the plane z = 0.37, which wears a checkerboard
/// of two colours under ambient light alone (no lights: the parser's flat ambient of 1, so
/// a pixel shows its material's diffuse colour exactly), with a texture Transform that
/// scales, turns about two axes and moves the cells.
const CHECKER_SCENE: &str = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
Lights { numLights 0 }
Materials { numMaterials 3
  Material { diffuseColor 0.75 0.25 0 }
  Material { diffuseColor 0 0.5 1 }
  Checkerboard {
    Transform { UniformScale 1.7 ZRotate 30 XRotate 25 Translate 0.3 0.2 0 }
    materialIndex 0 materialIndex 1
  }
}
Group { numObjects 1 MaterialIndex 2 Plane { normal 0 0 1 offset 0.37 } }
";

/// The colour of each pixel of [`CHECKER_SCENE`] by the parity of its hit's floor sum,
/// `None` for the pixels whose hit lies within 1e-9 of a cell face.
fn checker_expected() -> Vec<Option<[f32; 3]>> {
    // The Transform's steps, first listed applied last (docs/SPEC.md §2).
    let to_texture = DMat4::from_scale(DVec3::splat(1.7))
        * DMat4::from_rotation_z(30f64.to_radians())
        * DMat4::from_rotation_x(25f64.to_radians())
        * DMat4::from_translation(DVec3::new(0.3, 0.2, 0.0));
    let n = CHECKER_SIZE as usize;
    (0..n * n)
        .map(|k| {
            let (i, j) = (k % n, n - 1 - k / n); // rows of a frame run from the top
                                                 // docs/SPEC.md §3: the ray through the pixel's centre starts at
                                                 // center + (x − ½)·size·horizontal + (y − ½)·size·up and meets z = 0.37 there.
            let (x, y) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let p = to_texture.transform_point3(DVec3::new((x - 0.5) * 5.0, (y - 0.5) * 5.0, 0.37));
            if p.to_array().iter().any(|c| (c - c.round()).abs() < 1e-9) {
                return None; // on a cell's face: either colour is right
            }
            let odd = (p.x.floor() + p.y.floor() + p.z.floor()) as i64 % 2 != 0;
            Some(if odd { [0.0, 0.5, 1.0] } else { [0.75, 0.25, 0.0] })
        })
        .collect()
}

#[test]
fn checkerboard_is_the_parity_of_the_floor_sum() {
    let scene = parse_scene(CHECKER_SCENE, Path::new("checker.txt")).unwrap();
    let options = RenderOptions::all(CHECKER_SIZE, CHECKER_SIZE);
    let expected = checker_expected();
    let checked = expected.iter().flatten().count();
    assert!(checked > expected.len() * 99 / 100, "{checked}");
    let odd = expected.iter().flatten().filter(|c| c[2] == 1.0).count();
    assert!(odd > checked / 4 && checked - odd > checked / 4, "both colours shown: {odd} of {checked}");
    // The reference: every checked pixel exactly.
    let frame = raycaster::cpu::render(&scene, &options);
    for (k, want) in expected.iter().enumerate() {
        if let Some(want) = want {
            assert_eq!(&frame.color[k], want, "reference, pixel {k}");
        }
    }
    // The kernel in f32: a pixel whose hit f32 places across a face may flip, within the
    // contract (at most one checked pixel in 1000).
    let Some(gpu) = common::gpu() else { return };
    let frame = gpu.render(&scene, &options).expect("the GPU renders an orthographic checkerboard");
    let off = expected.iter().enumerate().filter(|(k, want)| want.is_some_and(|w| frame.color[*k] != w)).count();
    println!("GPU checkerboard: {off} of {checked} checked pixels differ");
    assert!(off * 1000 <= checked, "{off} of {checked}");
}

#[test]
fn course_marble_image_within_the_contract_and_wood_compared() {
    let Some(corpus) = common::corpus() else { return };
    let dir = tempfile::tempdir().unwrap();
    common::copy_course_folder(&corpus, "a6", dir.path());
    let commands = common::course_commands(&corpus, "a6");
    let line = |output: &str| commands.iter().find(|c| c.iter().any(|a| a == output)).unwrap().clone();
    common::run_course_line(dir.path(), &line("output6_15.tga"), "cpu");
    let expected = corpus.join("a6/expected");
    let failure =
        common::against_sample(&dir.path().join("output6_15.tga"), &expected.join("output6_15.png"), "output6_15");
    assert_eq!(failure, None);
    // Wood has no right answer in the course: how close ours is gets printed, not judged.
    common::run_course_line(dir.path(), &line("output6_16.tga"), "cpu");
    common::against_sample(&dir.path().join("output6_16.tga"), &expected.join("output6_16.png"), "output6_16 (wood)");
    // The checkerboard line of the course runs too (the course gives no image of it).
    common::run_course_line(dir.path(), &line("output6_13.tga"), "cpu");
}

#[test]
fn course_marble_and_wood_on_the_gpu_match_the_reference() {
    let Some(corpus) = common::corpus() else { return };
    let commands = common::course_commands(&corpus, "a6");
    let lines: Vec<Vec<String>> =
        commands.into_iter().filter(|c| c.iter().any(|a| a == "output6_15.tga" || a == "output6_16.tga")).collect();
    assert_eq!(lines.len(), 2);
    let (failures, samples) = common::course_lines_on_both_backends(&corpus, "a6", &lines[..1]);
    assert_eq!(samples, ["output6_15"]);
    assert!(failures.is_empty(), "{failures:?}");
    // Wood: GPU against the reference only (the course's image is for comparison).
    let Some(_) = common::gpu() else { return };
    let (cpu, gpu) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (dir, backend) in [(&cpu, "cpu"), (&gpu, "gpu")] {
        common::copy_course_folder(&corpus, "a6", dir.path());
        common::run_course_line(dir.path(), &lines[1], backend);
    }
    let wood = common::against_sample(
        &gpu.path().join("output6_16.tga"),
        &cpu.path().join("output6_16.tga"),
        "output6_16 (GPU against the reference)",
    );
    assert_eq!(wood, None);
}

/// A unit sphere at the origin under an orthographic camera at z = 10, wearing one-octave
/// noise scaled by `scale`. texture_range's bound: the map to texture space from
/// camera-relative points is `scale · (p + (0, 0, 10))`, the sphere's camera-relative box
/// reaches (1, 1, 11), so Q = 11·scale + 10·scale = 21·scale; the rate is 32 per octave, and
/// Q · rate ≤ 2¹⁴ holds up to scale = 16384 / 672 = 24.38095….
fn noise_sphere(scale: f64) -> raycaster::scene::Scene {
    parse_scene(&noise_sphere_text(scale), Path::new("noise.txt")).unwrap()
}

fn noise_sphere_text(scale: f64) -> String {
    format!(
        "OrthographicCamera {{ center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }}
Lights {{ numLights 1 DirectionalLight {{ direction -0.3 -0.5 -1 color 0.9 0.9 0.9 }} }}
Background {{ ambientLight 0.1 0.1 0.1 }}
Materials {{ numMaterials 3
  Material {{ diffuseColor 0.9 0.2 0.1 }}
  Material {{ diffuseColor 0.1 0.3 0.9 }}
  Noise {{ Transform {{ UniformScale {scale} }} materialIndex 0 materialIndex 1 octaves 1 }}
}}
Group {{ numObjects 1 MaterialIndex 2 Sphere {{ center 0 0 0 radius 1 }} }}"
    )
}

#[test]
fn gpu_texture_precision_contract_just_inside_and_just_outside() {
    let Some(gpu) = common::gpu() else { return };
    let options = RenderOptions::all(48, 48);
    let inside = noise_sphere(24.38);
    let frame = gpu.render(&inside, &options).expect("just inside the contract");
    let reference = raycaster::cpu::render(&inside, &options);
    let level = |v: f32| (255.0 * v.clamp(0.0, 1.0)).floor() as i32;
    let off = (0..frame.color.len())
        .filter(|&k| (0..3).any(|c| (level(frame.color[k][c]) - level(reference.color[k][c])).abs() > 1))
        .count();
    assert!(off * 1000 <= frame.color.len(), "{off} pixels more than one level off the reference");
    let outside = gpu.render(&noise_sphere(24.39), &options).map(|_| ()).unwrap_err();
    let raycaster::gpu::GpuError::Precision(e) = &outside else { panic!("{outside}") };
    assert_eq!(e.location, Some(Location { line: 7, col: 3 }), "{e}");
    assert!(e.what.contains("material 2, a Noise"), "{e}");
    assert!((e.magnitude - 21.0 * 24.39).abs() < 1e-9, "Q = 21·scale: {e}");
    assert!(outside.reference_renders_it(), "auto falls back to the reference");
}

/// [`CHECKER_SCENE`]'s plane seen at a grazing angle by a perspective camera one unit
/// above it, the horizon in view: its far hits lie beyond the checkerboard's reach.
fn grazing_checker() -> raycaster::scene::Scene {
    let text = CHECKER_SCENE.replace(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }",
        "PerspectiveCamera { center 0 0 1.37 direction 0 1 -0.2 up 0 0 1 angle 30 }",
    );
    parse_scene(&text, Path::new("checker.txt")).unwrap()
}

/// The pixels (frame order, top row first) whose hit on [`grazing_checker`]'s plane has
/// texture coordinates of magnitude `Q` (gpu::texture_range's `max_i Σ_j |M_ij||p_j| +
/// |t_i|`, p relative to the camera) beyond the checkerboard's reach, 2¹⁴ / 32 = 512,
/// shrunk by the cosine at which the ray meets the plane (a grazing hit's error stretches
/// along it), worked out here in f64; and those within 10⁻⁴ of it either way, where f32's
/// values may fall on the other side.
fn beyond_checker_reach(scene: &raycaster::scene::Scene, options: &RenderOptions) -> (Vec<usize>, Vec<usize>) {
    let rays = raycaster::camera::PrimaryRays::for_camera(&scene.camera, options.width, options.height);
    let to_texture = DMat4::from_scale(DVec3::splat(1.7))
        * DMat4::from_rotation_z(30f64.to_radians())
        * DMat4::from_rotation_x(25f64.to_radians())
        * DMat4::from_translation(DVec3::new(0.3, 0.2, 0.0));
    let map = to_texture * DMat4::from_translation(scene.camera.center);
    let (w, h) = (options.width as usize, options.height as usize);
    let (mut beyond, mut borderline) = (Vec::new(), Vec::new());
    for k in 0..w * h {
        let ray = rays.ray((k % w) as u32, (h - 1 - k / w) as u32);
        // The plane z = 0.37, from a camera at z = 1.37.
        let t = (0.37 - ray.origin.z) / ray.direction.z;
        if t.is_nan() || t <= 0.0 {
            continue; // above the horizon: the background
        }
        let p = ray.at(t) - scene.camera.center;
        let q = (0..3).map(|i| map.row(i).truncate().abs().dot(p.abs()) + map.row(i).w.abs()).fold(0.0, f64::max);
        let reach = 512.0 * ray.direction.normalize().z.abs();
        if (q / reach - 1.0).abs() < 1e-4 {
            borderline.push(k);
        } else if q > reach {
            beyond.push(k);
        }
    }
    (beyond, borderline)
}

#[test]
fn a_plane_seen_to_the_horizon_hands_its_far_pixels_to_the_reference() {
    let Some(gpu) = common::gpu() else { return };
    let scene = grazing_checker();
    let options = RenderOptions::all(96, 160);
    let (beyond, borderline) = beyond_checker_reach(&scene, &options);
    assert!(beyond.len() > 20, "the view reaches past the checkerboard's reach: {}", beyond.len());
    let (frame, stats) = common::render_gpu_tiles(gpu, &scene, &options);
    let handed = stats.pixels_beyond_reach as usize;
    println!("{handed} pixels handed over; {} beyond reach in f64, {} borderline", beyond.len(), borderline.len());
    assert!(
        handed >= beyond.len() && handed <= beyond.len() + borderline.len(),
        "the kernel hands over exactly the pixels beyond reach: {handed}, expected {} (+ up to {} borderline)",
        beyond.len(),
        borderline.len()
    );
    let reference = raycaster::cpu::render(&scene, &options);
    for k in &beyond {
        assert_eq!(frame.color[*k], reference.color[*k], "pixel {k}, handed over, is the reference's");
    }
    let errors = raycaster::metrics::compare_frames(&frame, &reference, (0.0, 100.0));
    for e in &errors {
        assert_eq!(e.hit_mismatches, 0, "{:?}", e.output);
        assert!(e.image.off_by_more_than_one * 1000 <= options.pixel_count(), "{:?}: {e:?}", e.output);
    }
}

/// Wood rings on a plane seen to the horizon, found by `tests/random_scenes.rs` (seed
/// 3239860459201332866, shrunk): the texture coordinates stay well within wood's reach, but
/// the rays meet the plane at cosines down to 10⁻³, which stretch the hit's own rounding
/// along the plane a thousandfold. Without the cosine in the reach, 31 of 9 072 pixels were
/// more than one level off the reference, up to 93 levels.
const GRAZING_WOOD: &str = "
PerspectiveCamera { center -16.724 -7.53 19.964 direction 0.573 0.258 -0.684 up 0 -0.386 0 angle 50.52 }
Lights { numLights 0 }
Background { color 0 0 0 ambientLight 1 1 1 }
Materials { numMaterials 3
  Material { diffuseColor 0 0 0 }
  Material { diffuseColor 0 0 0.67 }
  Wood { Transform { UniformScale 0.3 } materialIndex 0 materialIndex 1 octaves 0 frequency 5.827 amplitude 0 }
}
Group { numObjects 1
  MaterialIndex 2
  Transform { Rotate { 0.443 0.917 0 27.719 } Plane { normal -0.487 0.377 -0.339 offset 0 } }
}
";

#[test]
fn wood_on_a_plane_met_at_grazing_rays_hands_those_pixels_to_the_reference() {
    let Some(gpu) = common::gpu() else { return };
    let scene = parse_scene(GRAZING_WOOD, Path::new("wood.txt")).unwrap();
    let options = RenderOptions::all(36, 252);
    let (frame, stats) = common::render_gpu_tiles(gpu, &scene, &options);
    let reference = raycaster::cpu::render(&scene, &options);
    println!("{} pixels handed over", stats.pixels_beyond_reach);
    assert!(stats.pixels_beyond_reach > 0, "the far rings go to the reference");
    for e in raycaster::metrics::compare_frames(&frame, &reference, (0.0, 100.0)) {
        assert_eq!(e.hit_mismatches, 0, "{:?}", e.output);
        assert!(e.image.off_by_more_than_one * 1000 <= options.pixel_count(), "{:?}: {e:?}", e.output);
    }
}

/// The live window draws such a frame from the host: drawn on the device, the pixels
/// handed over would show the kernel's marker, so the pass says it met one.
#[test]
fn a_frame_with_pixels_handed_over_is_not_drawn_on_the_device() {
    let Some(gpu) = common::gpu() else { return };
    let scene = grazing_checker();
    let options = RenderOptions {
        outputs: raycaster::render::Outputs::from(raycaster::render::Output::Color),
        ..RenderOptions::all(96, 160)
    };
    let texture = common::texture(gpu, (96, 160), wgpu::TextureFormat::Rgba8Unorm);
    let presenter = raycaster::gpu::Presenter::new(gpu);
    let prepared = gpu.prepare(&scene, &options, true).expect("the GPU prepares the scene");
    assert_eq!(prepared.present(&presenter, &texture, 1).unwrap(), raycaster::gpu::Presented::HandedOver);
    // The flag is the frame's: the checkerboard seen from above, next, is drawn.
    let near = parse_scene(CHECKER_SCENE, Path::new("checker.txt")).unwrap();
    let prepared = gpu.prepare(&near, &options, true).expect("the GPU prepares the scene");
    assert_eq!(prepared.present(&presenter, &texture, 1).unwrap(), raycaster::gpu::Presented::Drawn);
}

/// A checkerboard of a diffuse material and a mirror with a little glass in it, under a
/// red sphere the mirror cells reflect, and a sphere of noise blending glass and a mirror:
/// a texture's materials each spawn their own rays, weighted by their share.
const MIRROR_TEXTURES: &str = "
OrthographicCamera { center 0 -6 6 direction 0 1 -1 up 0 0 1 size 6 }
Lights { numLights 1 DirectionalLight { direction -0.3 0.4 -1 color 0.8 0.8 0.8 } }
Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }
Materials { numMaterials 6
  Material { diffuseColor 0.75 0.75 0.7 }
  PhongMaterial { diffuseColor 0.1 0.1 0.2 reflectiveColor 0.6 0.6 0.6 transparentColor 0.2 0.2 0.2 indexOfRefraction 1.3 }
  Checkerboard { Transform { UniformScale 0.8 Translate 0.1 0.2 0.5 } materialIndex 0 materialIndex 1 }
  Material { diffuseColor 0.9 0.1 0.1 }
  PhongMaterial { diffuseColor 0.05 0.05 0.05 transparentColor 0.8 0.8 0.8 indexOfRefraction 1.5 }
  Noise { Transform { UniformScale 2 } materialIndex 4 materialIndex 1 octaves 3 }
}
Group { numObjects 3
  MaterialIndex 2 Plane { normal 0 0 1 offset 0 }
  MaterialIndex 3 Sphere { center -1 1.5 1.2 radius 1 }
  MaterialIndex 5 Sphere { center 1.3 -0.5 1 radius 1 }
}
";

#[test]
fn a_texture_of_mirrors_and_glass_traces_each_materials_rays() {
    let Some(gpu) = common::gpu() else { return };
    let scene = parse_scene(MIRROR_TEXTURES, Path::new("mirrors.txt")).unwrap();
    let options = RenderOptions::all(120, 120);
    let mut bounces = options;
    bounces.shading.bounces = 3;
    bounces.shading.shadows = true;
    let reference = raycaster::cpu::render(&scene, &bounces);
    let flat = raycaster::cpu::render(
        &scene,
        &RenderOptions { shading: raycaster::render::Shading { bounces: 0, ..bounces.shading }, ..options },
    );
    let level = |v: f32| (255.0 * v.clamp(0.0, 1.0)).floor() as i32;
    let differs = |a: &[f32; 3], b: &[f32; 3]| (0..3).any(|c| (level(a[c]) - level(b[c])).abs() > 1);
    // The test means something: the rays change much of the image.
    let changed = (0..reference.color.len()).filter(|&k| differs(&reference.color[k], &flat.color[k])).count();
    assert!(changed > 3000, "reflections and refractions show in {changed} pixels");
    let (frame, stats) = common::render_gpu_tiles(gpu, &scene, &bounces);
    let off = (0..frame.color.len()).filter(|&k| differs(&frame.color[k], &reference.color[k])).count();
    println!("{off} pixels more than one level off; {} handed over", stats.pixels_beyond_reach);
    assert!(off * 1000 <= options.pixel_count(), "{off} pixels off the reference");
    // The floor's checkerboard seen in the mirror and the glass goes to the reference;
    // the noise sphere's own hits, and the floor seen directly, do not.
    assert!(
        stats.pixels_beyond_reach > 0 && (stats.pixels_beyond_reach as usize) < options.pixel_count() / 2,
        "{stats:?}"
    );
}

#[test]
fn the_kernels_permutation_is_the_references() {
    let reference: Vec<u32> = PERMUTATION.iter().map(|&p| p as u32).collect();
    assert_eq!(raycaster::gpu::layout::PERLIN_PERMUTATION.to_vec(), reference);
}

#[test]
fn gpu_backend_exits_1_and_auto_falls_back_with_one_warning() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("noise.txt");
    // A second, plain sphere behind: large enough (1.1 M pixels × 2 primitives) that `auto`
    // opens the GPU rather than hand so small a job to the reference at once.
    let text = noise_sphere_text(24.39).replace(
        "Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1 } }",
        "Group { numObjects 2 MaterialIndex 2 Sphere { center 0 0 0 radius 1 }\n  MaterialIndex 0 Sphere { center 0 0 -5 radius 2 } }",
    );
    assert_ne!(text, noise_sphere_text(24.39));
    std::fs::write(&scene, text).unwrap();
    let run = |backend: &str| {
        let args = ["-input", "noise.txt", "-size", "1100", "1000", "-output", "o.tga", "--backend", backend];
        common::bin::raycaster_in(dir.path(), &args)
    };
    let gpu = run("gpu");
    let stderr = String::from_utf8_lossy(&gpu.stderr);
    assert_eq!(gpu.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("noise.txt:7:3: the texture coordinates of material 2"), "{stderr}");
    assert!(!dir.path().join("o.tga").exists(), "no image from a refused render");
    let auto = run("auto");
    let stderr = String::from_utf8_lossy(&auto.stderr);
    assert!(auto.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(warnings[0].contains("rendering with the f64 CPU reference instead"), "{stderr}");
}
