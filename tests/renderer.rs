//! The library's `Renderer`: the one place that chooses the GPU or the f64 reference
//! (src/renderer.rs). What `auto` hands the reference is checked against the reference
//! itself, rendered on its own; what the GPU renders, against the reference's pixels.

mod common;

use raycaster::gpu::GpuOptions;
use raycaster::render::RenderOptions;
use raycaster::renderer::{auto, fallback_notice, BackendChoice, Renderer};
use raycaster::scene::{self, Scene};
use std::path::Path;

/// A unit sphere at the origin, seen by an orthographic camera.
const SPHERE: &str = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }
Lights { numLights 1 DirectionalLight { direction -0.3 -0.5 -1 color 0.9 0.9 0.9 } }
Background { color 0.25 0.25 0.25 ambientLight 0.15 0.15 0.15 }
Materials { numMaterials 1 Material { diffuseColor 1 0.2 0.2 } }
Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }
";

fn sphere_at(scale: f64) -> Scene {
    // Scaled as a whole, the picture is the same; its coordinates leave the f32 kernel's range.
    let text = SPHERE
        .replace("center 0 0 10", &format!("center 0 0 {}", 10.0 * scale))
        .replace("size 3", &format!("size {}", 3.0 * scale))
        .replace("radius 1", &format!("radius {scale}"));
    scene::parse_scene(&text, Path::new("sphere.txt")).expect("the test's scene parses")
}

fn on_gpu(choice: BackendChoice) -> Option<Renderer> {
    common::gpu().map(|gpu| Renderer::on_gpu(gpu.on_same_device(GpuOptions::default()), choice))
}

#[test]
fn auto_gives_a_job_too_small_for_the_device_to_the_reference() {
    let scene = sphere_at(1.0);
    // One primitive: pixels × primitives against the 2 M pairs of REFERENCE_QUICKER_BELOW.
    assert!(auto::reference_is_quicker(&scene, &RenderOptions::all(64, 64)));
    assert!(!auto::reference_is_quicker(&scene, &RenderOptions::all(2000, 1001)));
    // Decided before any device is opened: this holds on a machine without a GPU too.
    let (renderer, notice) = Renderer::open_for(BackendChoice::Auto, &scene, &RenderOptions::all(64, 64)).unwrap();
    assert!(renderer.gpu().is_none(), "a 64² sphere is the reference's");
    assert_eq!(notice, None);
    let (renderer, _) = Renderer::open_for(BackendChoice::Cpu, &scene, &RenderOptions::all(2000, 2000)).unwrap();
    assert!(renderer.gpu().is_none());
}

#[test]
fn auto_renders_what_the_gpu_refuses_with_the_reference_and_says_why() {
    let (Some(gpu), Some(auto)) = (on_gpu(BackendChoice::Gpu), on_gpu(BackendChoice::Auto)) else { return };
    let scene = sphere_at(1e30);
    let options = RenderOptions::all(48, 48);

    let refused = gpu.render(&scene, &options).err().expect("1e30 is beyond the f32 kernel's range");
    let notice = fallback_notice(&refused).expect("a refusal the reference can mend");
    assert!(notice.contains("outside the range the GPU's f32 kernel renders faithfully"), "{notice}");
    assert!(notice.ends_with("; rendering with the f64 CPU reference instead"), "{notice}");

    let rendered = auto.render(&scene, &options).unwrap();
    assert_eq!(rendered.notice.as_deref(), Some(notice.as_str()));
    assert!(rendered.backend.starts_with("cpu, the f64 reference"), "{}", rendered.backend);
    // The reference's own frame, rendered without the Renderer: every float the same.
    assert_eq!(rendered.frame, raycaster::cpu::render(&scene, &options));
    // And the picture is the unit sphere's, scaled: a disk of diameter 2 in a square of side 3, π/9 of the pixels.
    let hits = rendered.frame.hit.iter().filter(|&&h| h).count() as f64 / options.pixel_count() as f64;
    assert!((hits - std::f64::consts::FRAC_PI_4 * 4.0 / 9.0).abs() < 0.03, "{hits}");
}

#[test]
fn the_gpu_renders_what_it_can_and_agrees_with_the_reference() {
    let Some(auto) = on_gpu(BackendChoice::Auto) else { return };
    let scene = sphere_at(1.0);
    let options = RenderOptions::all(80, 64);
    let rendered = auto.render(&scene, &options).unwrap();
    assert_eq!(rendered.notice, None);
    assert!(rendered.backend.starts_with("gpu, "), "{}", rendered.backend);
    assert!(rendered.stats.tiles >= 1);
    let reference = raycaster::cpu::render(&scene, &options);
    let depth_range = raycaster::metrics::depth_range_of(&reference);
    for errors in raycaster::metrics::compare_frames(&rendered.frame, &reference, depth_range) {
        assert_eq!(errors.hit_mismatches, 0, "{:?}", errors.output);
        assert_eq!(errors.image.off_by_more_than_one, 0, "{:?}", errors.output);
        assert_eq!(errors.non_finite, 0, "{:?}", errors.output);
    }
}

#[test]
fn a_gpu_failure_the_reference_cannot_mend_has_no_fallback() {
    let lost = raycaster::gpu::GpuError::NoAdapter("none in this test".into());
    assert_eq!(fallback_notice(&lost), None);
}

/// What the caller's `go_on` says between tiles: an error stops the render after that tile
/// and comes back as it is; `Ok` all along is `render` itself.
#[test]
fn render_or_stop_stops_where_the_caller_says() {
    let scene = sphere_at(1.0);
    // 600² pixels: more than one of the reference's tiles (2^18 pixels each, src/renderer/bands.rs).
    let options = RenderOptions::all(600, 600);
    let reference = Renderer::reference();
    let mut asked = 0;
    let stopped = reference.render_or_stop(&scene, &options, || {
        asked += 1;
        Err(raycaster::gpu::GpuError::NoAdapter("stopped by the test".into()))
    });
    assert!(matches!(stopped, Err(raycaster::gpu::GpuError::NoAdapter(why)) if why == "stopped by the test"));
    assert_eq!(asked, 1, "asked after the first tile, and not again");

    let mut tiles = 0;
    let whole = reference.render_or_stop(&scene, &options, || Ok::<(), raycaster::gpu::GpuError>(tiles += 1)).unwrap();
    assert!(tiles > 1, "{tiles} tiles");
    assert_eq!(whole.stats.tiles, tiles);
    assert_eq!(whole.frame, raycaster::cpu::render(&scene, &options));
}

/// On lavapipe, which compiles a kernel at its first dispatch, a batch's threads also
/// dispatch it once on twin devices of their own, whose machine code Mesa's disk cache hands
/// to the renderer's device (gpu::ahead): the image is the one a renderer that compiled its
/// kernel at its own dispatch renders. Everywhere the pipeline is created ahead on the
/// renderer's own device, and the render finds it there.
#[test]
fn a_kernel_compiled_on_a_twin_device_renders_the_same_image() {
    let Some(shared) = common::gpu() else { return };
    let gpu = shared.on_same_device(GpuOptions::default());
    let info = gpu.adapter_info();
    let lavapipe = info.driver.contains("llvmpipe") || info.name.contains("llvmpipe");
    let cache_switch = ["MESA_SHADER_CACHE_DISABLE", "MESA_GLSL_CACHE_DISABLE"].map(std::env::var_os);
    let ahead = gpu.ahead();
    if !lavapipe || cache_switch.iter().all(Option::is_none) {
        assert_eq!(ahead.on_twin(), lavapipe, "{}: {}", info.name, info.driver);
    }
    let scene = sphere_at(1.5);
    let options = RenderOptions {
        shading: raycaster::render::Shading { shadows: true, ..Default::default() },
        ..RenderOptions::all(37, 29)
    };
    ahead.precompile(&scene, &options, false).unwrap();
    ahead.precompile(&scene, &options, false).unwrap();
    assert_eq!(gpu.kernels_compiled(), 1, "a kernel compiled ahead is not compiled twice");
    let (frame, _) = common::render_gpu_tiles(&gpu, &scene, &options);
    assert_eq!(gpu.kernels_compiled(), 1, "the render found its pipeline created ahead");
    let (compiled_at_dispatch, _) =
        common::render_gpu_tiles(&shared.on_same_device(GpuOptions::default()), &scene, &options);
    assert_eq!(frame, compiled_at_dispatch);
}

/// A batch compiles the next line's kernel while it renders this one: the render then finds
/// it compiled, and two threads asking for one kernel at once compile it once.
#[test]
fn a_kernel_compiled_ahead_is_compiled_once() {
    let Some(gpu) = common::gpu().map(|g| g.on_same_device(GpuOptions::default())) else { return };
    let scene = sphere_at(1.0);
    let options = RenderOptions {
        outputs: raycaster::render::Outputs::from(raycaster::render::Output::Normals),
        ..RenderOptions::all(90, 70)
    };
    gpu.precompile(&scene, &options, true).unwrap();
    assert_eq!(gpu.kernels_compiled(), 1);
    gpu.prepare(&scene, &options, true).unwrap();
    assert_eq!(gpu.kernels_compiled(), 1, "the render found the kernel compiled ahead");
    let wider = RenderOptions { outputs: raycaster::render::Outputs::ALL, ..options };
    std::thread::scope(|scope| {
        scope.spawn(|| gpu.precompile(&scene, &wider, true).unwrap());
        scope.spawn(|| gpu.prepare(&scene, &wider, true).map(drop).unwrap());
    });
    assert_eq!(gpu.kernels_compiled(), 2, "one kernel more, compiled by one of the two threads");
    // Ahead of a render the reference would take (`auto` on a CPU device, a small tree), the
    // renderer compiles nothing.
    let on_cpu = gpu.adapter_info().device_type == wgpu::DeviceType::Cpu;
    let auto = Renderer::on_gpu(gpu.on_same_device(GpuOptions::default()), BackendChoice::Auto);
    let tree = RenderOptions { shading: raycaster::render::Shading { shadows: true, ..options.shading }, ..options };
    auto.precompile(&auto.ahead().unwrap(), &scene, &tree, true);
    assert_eq!(auto.gpu().unwrap().kernels_compiled(), usize::from(!on_cpu));
}
