//! The kernel's ray tree (shaders/tree.wgsl) where it is hardest: pixels whose rays together
//! pass the driver's loop limit, trees deeper than the kernel's stack, and the kernel's
//! choice of acceleration for secondary rays. The truth is the f64 reference.

mod common;

use raycaster::gpu::{Acceleration, GpuError};
use raycaster::metrics::compare_frames;
use raycaster::render::{Frame, Output, RenderOptions, Shading};
use raycaster::scene::{parse_scene, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// `count` small diffuse spheres in a square above a mirror floor, lit by four directional
/// lights: every ray of a pixel (the primary, one reflection, a shadow ray per light at
/// each hit) tests every sphere when the kernel walks flat loops.
fn sphere_field(count: usize) -> Scene {
    let side = (count as f64).sqrt().ceil() as usize;
    let mut text = String::from(
        "OrthographicCamera { center 0 6 6 direction 0 -1 -1 up 0 1 0 size 9 }
         Lights { numLights 4
           DirectionalLight { direction -1 -1 -1 color 0.3 0.3 0.3 }
           DirectionalLight { direction 1 -1 -1 color 0.2 0.3 0.2 }
           DirectionalLight { direction -1 -1 1 color 0.2 0.2 0.3 }
           DirectionalLight { direction 1 -2 0.5 color 0.3 0.2 0.2 } }
         Background { color 0.1 0.2 0.3 ambientLight 0.1 0.1 0.1 }
         Materials { numMaterials 2
           PhongMaterial { diffuseColor 0.3 0.3 0.3 reflectiveColor 0.6 0.6 0.6 }
           PhongMaterial { diffuseColor 0.9 0.5 0.2 specularColor 0.5 0.5 0.5 exponent 20 } }
         Group { numObjects ",
    );
    let _ = writeln!(text, "{}", count + 1);
    text.push_str("MaterialIndex 0 Plane { normal 0 1 0 offset -0.5 }\nMaterialIndex 1\n");
    let spacing = 8.0 / side as f64;
    for k in 0..count {
        let (x, z) = ((k % side) as f64, (k / side) as f64);
        let _ = writeln!(
            text,
            "Sphere {{ center {} 0 {} radius {} }}",
            -4.0 + spacing * (x + 0.5),
            -4.0 + spacing * (z + 0.5),
            0.3 * spacing
        );
    }
    text.push('}');
    parse_scene(&text, Path::new("sphere_field.txt")).expect("the generated scene parses")
}

fn options(size: u32, shading: Shading) -> RenderOptions {
    RenderOptions { shading, ..RenderOptions::all(size, size) }
}

/// The 8-bit colour image the files hold, as the kernel packs it (hand-overs patched by
/// the host), and the render's counts.
fn packed_color(
    gpu: &raycaster::gpu::GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
) -> (Vec<u8>, raycaster::render::RenderStats) {
    let prepared = gpu.prepare(scene, options, true).expect("the GPU prepares the scene");
    let mut rgb = Vec::new();
    let stats = prepared
        .render(|tile| {
            rgb.extend(tile.color_rgb());
            Ok::<(), GpuError>(())
        })
        .expect("the GPU renders the scene");
    (rgb, stats)
}

/// The colour image within the project's contract: at most one pixel in 1000 more than one
/// level off the reference's.
fn assert_within_contract(what: &str, ours: &Frame, reference: &Frame) {
    let errors = compare_frames(ours, reference, (0.0, 1.0));
    let color = errors.iter().find(|e| e.output == Output::Color).expect("a colour image was asked for");
    let (off, allowed) = (color.image.off_by_more_than_one, color.image.pixels / 1000);
    assert!(off <= allowed, "{what}: {off} pixels off the reference (at most {allowed})");
}

/// 8000 spheres in flat loops, 4 lights with shadows, a mirror: up to 10 rays of 8000 tests
/// each per pixel, past lavapipe's 65 535 loop iterations. The kernel marks the pixels its
/// driver cut short and the reference renders them: the image is the reference's either way,
/// in floats and in the 8-bit images alike.
#[test]
fn pixels_past_the_loop_limit_are_rendered_by_the_reference() {
    let Some(gpu) = common::gpu_with(Acceleration::Flat) else { return };
    let scene = sphere_field(8000);
    let options = options(24, Shading { shadows: true, bounces: 2, ..Shading::default() });
    let reference = raycaster::cpu::render(&scene, &options);
    let (ours, stats) = common::render_gpu_tiles(&gpu, &scene, &options);
    assert_within_contract("floats", &ours, &reference);
    if gpu.loop_limit().is_some() {
        let pixels = options.pixel_count() as u64;
        assert!(
            stats.pixels_cut_short > pixels / 4,
            "only {} of {pixels} pixels were cut short: the scene no longer tests the limit",
            stats.pixels_cut_short
        );
    } else {
        assert_eq!(stats.pixels_cut_short, 0, "no loop limit, nothing cut short");
    }
    // The 8-bit path marks and patches packed words.
    let (rgb, packed_stats) = packed_color(&gpu, &scene, &options);
    assert_eq!(packed_stats.pixels_cut_short, stats.pixels_cut_short);
    let expected = raycaster::image_io::color_image(&reference).into_raw();
    let off = rgb.chunks(3).zip(expected.chunks(3)).filter(|(a, b)| a.iter().zip(*b).any(|(x, y)| x.abs_diff(*y) > 1));
    assert!(off.count() <= options.pixel_count() / 1000, "8-bit image off the reference");
}

/// A tree deeper than the kernel's stack is refused with the reason, and `-weight` that
/// stops it sooner makes it fit.
#[test]
fn trees_deeper_than_the_stack_are_refused() {
    let Some(gpu) = common::gpu() else { return };
    let scene = sphere_field(4);
    let deep = options(16, Shading { bounces: 40, ..Shading::default() });
    match gpu.prepare(&scene, &deep, false) {
        Err(e @ GpuError::Unsupported(_)) => {
            assert!(e.reference_renders_it());
            let message = e.to_string();
            assert!(message.starts_with("sphere_field.txt: -bounces 40"), "{message}");
            assert!(message.contains("--backend cpu"), "{message}");
        }
        Err(e) => panic!("refused for the wrong reason: {e}"),
        Ok(_) => panic!("a 40-deep mirror chain fits no 16-slot stack"),
    }
    // The floor's reflective 0.6 (length 1.04) never falls below a weight; a colour of
    // length below 1 does: 0.5³ = 0.125 ≥ 0.1 > 0.5⁴.
    let text = "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 3 }
        Background { color 0.5 0.5 0.5 }
        Materials { numMaterials 1 PhongMaterial { diffuseColor 0.5 0.5 0.5 reflectiveColor 0.5 0 0 } }
        Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }";
    let scene = parse_scene(text, Path::new("fading.txt")).unwrap();
    let fading = options(16, Shading { bounces: 40, weight: 0.1, ..Shading::default() });
    let reference = raycaster::cpu::render(&scene, &fading);
    let ours = gpu.render(&scene, &fading).expect("weights fade out before the stack's end");
    assert_within_contract("fading", &ours, &reference);
}

/// Secondary rays need the hierarchy: bins hold primary rays only. A scene that would get
/// bins for its primary rays gets the hierarchy once it casts shadow rays, and renders as
/// the reference does either way.
#[test]
fn secondary_rays_walk_the_hierarchy() {
    let Some(gpu) = common::gpu_with(Acceleration::Bins) else { return };
    let scene = sphere_field(64);
    for shading in [Shading::default(), Shading { shadows: true, bounces: 1, ..Shading::default() }] {
        let options = options(64, shading);
        let (ours, stats) = common::render_gpu_tiles(&gpu, &scene, &options);
        let expected = if shading.shadows { Acceleration::Hierarchy } else { Acceleration::Bins };
        assert_eq!(stats.acceleration, expected, "{shading:?}");
        assert_within_contract(&format!("{shading:?}"), &ours, &raycaster::cpu::render(&scene, &options));
    }
}

/// `tests/random_scenes.rs`, seed 6292329014124542240, shrunk: a mirror-glass plane of
/// index 1 met 2·10⁵ units away at a cosine of about 10⁻⁵. Snell's `1 − η²(1 − cos²)`
/// rounds `1 − cos²` to 1 in f32, so k was 0 and the refracted ray lost the component that
/// takes it through the plane: 2 of 1 496 pixels up to 73 levels off the reference.
#[test]
fn a_ray_refracted_far_away_at_grazing_incidence_agrees_with_the_reference() {
    let Some(gpu) = common::gpu() else { return };
    let scene = parse_scene(
        "PerspectiveCamera { center 5.803 -1.841 -5.833 direction -0.596 0.161 0.686
           up -0.777 -0.706 0.454 angle 35.325 }
         Lights { numLights 2
           PointLight { position 3.253 -15.154 -13.771 color 0.836 0.787 0.463 attenuation 0 0.054 0 }
           DirectionalLight { direction -0.805 0.073 -0.273 color 0.532 0.108 0.015 } }
         Background { color 0.329 0.22 0.436 ambientLight 0.158 0.062 0.446 }
         Materials { numMaterials 1
           PhongMaterial { diffuseColor 0.08 0.908 0.627 specularColor 0.356 0.171 0.805 exponent 95.179
             reflectiveColor 0.395 0.111 0.933 transparentColor 0.488 0.053 0.661 } }
         Group { numObjects 2 MaterialIndex 0
           Plane { normal -0.352 -0.703 -0.129 offset -1.514 }
           Transform { Rotate { -0.15 -0.651 -0.204 137.71 } Sphere { center 2.448 -3.444 -1.241 radius 1.99 } } }",
        Path::new("far_glass.txt"),
    )
    .expect("the scene parses");
    let mut options = RenderOptions::all(88, 17);
    options.shading = Shading { shadows: true, bounces: 3, weight: 0.02, ..options.shading };
    let (ours, _) = common::render_gpu_tiles(gpu, &scene, &options);
    let reference = raycaster::cpu::render(&scene, &options);
    let errors = compare_frames(&ours, &reference, (0.0, 1.0));
    let color = errors.iter().find(|e| e.output == Output::Color).expect("a colour image was asked for");
    assert_eq!(color.image.off_by_more_than_one, 0, "{color:?}");
}

/// A sheet of clear glass of index 1, tilted, with the camera one unit above it looking
/// along it and down by 10⁻⁴: invisible, every pixel shows the background, through the
/// sheet or past it. The middle row's rays meet the sheet 10⁴ units away at a cosine of
/// 10⁻⁴, where a refracted ray's start, moved 1024 times the kernel's offset along itself,
/// lies within the hit's own error of the sheet: it found the sheet again, from behind,
/// and showed black (3 of its 15 pixels). The kernel hands such pixels to the reference.
#[test]
fn a_ray_leaving_glass_almost_along_it_goes_to_the_reference() {
    let Some(gpu) = common::gpu() else { return };
    let scene = parse_scene(
        "PerspectiveCamera { center 0.303045763 -0.505076272 0.808122036
           direction -0.000030305 0.848048812 0.529918128 up 0.303045763 -0.505076272 0.808122036 angle 30 }
         Lights { numLights 0 }
         Background { color 0.2 0.4 0.8 ambientLight 0 0 0 }
         Materials { numMaterials 1
           Material { diffuseColor 0 0 0 transparentColor 1 1 1 indexOfRefraction 1 } }
         Group { numObjects 1 MaterialIndex 0 Plane { normal 0.3 -0.5 0.8 offset 0 } }",
        Path::new("glass_sheet.txt"),
    )
    .expect("the scene parses");
    let mut options = RenderOptions::all(15, 9);
    options.shading.bounces = 2;
    let background = [0.2f32, 0.4, 0.8].map(raycaster::image_io::quantize);
    let (ours, stats) = common::render_gpu_tiles(gpu, &scene, &options);
    let reference = raycaster::cpu::render(&scene, &options);
    assert!(reference.hit.iter().filter(|&&h| h).count() >= 15 * 5, "the sheet fills the lower rows and the middle");
    for (name, frame) in [("reference", &reference), ("gpu", &ours)] {
        let off: Vec<usize> = (0..frame.color.len())
            .filter(|&k| frame.color[k].map(raycaster::image_io::quantize) != background)
            .collect();
        assert!(off.is_empty(), "{name}: pixels {off:?} are not the background");
    }
    // The middle row, and no more: the rows below meet the sheet at cosines of 0.036 and up.
    assert_eq!(stats.pixels_beyond_reach, 15, "the middle row is handed over");
    // The 8-bit images the files hold, on every driver (not only where a loop limit makes
    // the kernel hand pixels over already): no marker left in them.
    let (rgb, stats) = packed_color(gpu, &scene, &options);
    assert_eq!(stats.pixels_beyond_reach, 15, "packed: the middle row is handed over");
    assert!(rgb.chunks_exact(3).all(|p| p == background), "packed: every pixel is the background");
}
