//! lavapipe ends an invocation's loops after 65 535 iterations in all (docs/lavapipe.md), and
//! primary rays alone can pass that: here a mesh of long thin slivers lying across the view,
//! whose boxes all overlap it, so that no hierarchy culls them and the bins around the centre
//! hold them all (flat loops, one pixel an invocation, refuse past half the limit). With
//! bins, with the hierarchy and with `auto`'s choice, in floats and in the 8-bit
//! images of every output, the GPU's image must be the reference's (the project's contract),
//! and on a driver with the limit the kernel must have marked pixels as cut short, which the
//! reference rendered: nothing is dropped in silence. The scene is generated, not one mesh
//! that happens to pass the limit today.

mod common;

use raycaster::gpu::{Acceleration, GpuError, GpuRenderer};
use raycaster::image_io::{color_image, depth_image, normals_image};
use raycaster::metrics::compare_frames;
use raycaster::render::RenderOptions;
use raycaster::render::RenderStats;
use raycaster::scene::{load_scene, Scene};
use std::fmt::Write as _;

const SIZE: u32 = 32;

/// `count` slivers through the centre of the view at as many angles, each reaching past the
/// view's edges on both sides, so that each one's box holds the centre and most of the view,
/// in front of a quad that fills it. A sliver is 10⁻⁵ wide where it is widest, and its angle
/// keeps at least 3·10⁻⁴ rad away from the direction of every pixel's centre (as seen from
/// the view's centre, which is no pixel's centre): more than twice its angular width at the
/// nearest centre, so no camera ray meets one, in f32 or f64. Every pixel shows the quad,
/// which a walk cut short misses: the slivers come first, nearest first in a bin and all
/// around it in the hierarchy. Returns the folder holding the scene and its OBJ file.
fn slivers(count: usize) -> (tempfile::TempDir, Scene) {
    let centre_of = |k: u32| (k as f64 + 0.5) / SIZE as f64 * 2.0 - 1.0;
    let mut centre_angles: Vec<f64> = (0..SIZE * SIZE)
        .map(|k| centre_of(k / SIZE).atan2(centre_of(k % SIZE)).rem_euclid(std::f64::consts::PI))
        .collect();
    centre_angles.sort_by(f64::total_cmp);
    let clear_of_every_centre = |angle: f64| {
        let next = centre_angles.partition_point(|&c| c < angle);
        let gap = |c: f64| (c - angle).abs().min(std::f64::consts::PI - (c - angle).abs());
        [next.checked_sub(1), Some(next % centre_angles.len()), Some(0), Some(centre_angles.len() - 1)]
            .into_iter()
            .flatten()
            .all(|k| gap(centre_angles[k]) >= 3e-4)
    };
    let angles = (0u64..)
        .map(|k| (k as f64 * 0.618_033_988_749_895).fract() * std::f64::consts::PI)
        .filter(|&angle| clear_of_every_centre(angle))
        .take(count);
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::from("v -3 -3 -5\nv 3 -3 -5\nv 3 3 -5\nv -3 3 -5\nf 1 2 3\nf 1 3 4\n");
    for (k, angle) in angles.enumerate() {
        let (along, across) = ([angle.cos(), angle.sin()], [-angle.sin(), angle.cos()]);
        let z = -(k as f64) / count as f64;
        let point = |a: f64, b: f64| [a * along[0] + b * across[0], a * along[1] + b * across[1], z];
        for [x, y, z] in [point(-2.0, 0.0), point(2.0, -0.5e-5), point(2.0, 0.5e-5)] {
            let _ = writeln!(obj, "v {x} {y} {z}");
        }
        let _ = writeln!(obj, "f {} {} {}", 3 * k + 5, 3 * k + 6, 3 * k + 7);
    }
    std::fs::write(dir.path().join("slivers.obj"), obj).unwrap();
    let scene = dir.path().join("slivers.txt");
    std::fs::write(
        &scene,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 2 }
         Lights { numLights 1 DirectionalLight { direction -0.2 -0.3 -1 color 0.9 0.9 0.9 } }
         Background { color 0.1 0.2 0.3 ambientLight 0.1 0.1 0.1 }
         Materials { numMaterials 1 Material { diffuseColor 0.9 0.6 0.3 } }
         Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file slivers.obj } }",
    )
    .unwrap();
    let scene = load_scene(&scene).expect("the generated scene loads");
    (dir, scene)
}

/// The 8-bit colour, normal and depth images as the kernel packs them.
fn render_packed(gpu: &GpuRenderer, scene: &Scene, options: &RenderOptions) -> ([Vec<u8>; 3], RenderStats) {
    let prepared = gpu.prepare(scene, options, true).expect("the GPU prepares the slivers");
    let mut images: [Vec<u8>; 3] = Default::default();
    let stats = prepared
        .render(|tile| {
            images[0].extend(tile.color_rgb());
            images[1].extend(tile.normals_rgb());
            images[2].extend(tile.depth_rgb(0.0, 20.0));
            Ok::<(), GpuError>(())
        })
        .expect("the GPU renders the slivers");
    (images, stats)
}

fn pixels_off(ours: &[u8], reference: &[u8]) -> usize {
    ours.chunks(3).zip(reference.chunks(3)).filter(|(a, b)| a.iter().zip(*b).any(|(x, y)| x.abs_diff(*y) > 1)).count()
}

#[test]
fn primary_rays_past_the_loop_limit_are_rendered_by_the_reference() {
    if common::gpu().is_none() {
        return;
    }
    let (_dir, scene) = slivers(70_000);
    let options = RenderOptions::all(SIZE, SIZE);
    let reference = raycaster::cpu::render(&scene, &options);
    assert!(reference.hit.iter().all(|&hit| hit), "every pixel shows the quad behind the slivers");
    let expected = [color_image(&reference), normals_image(&reference), depth_image(&reference, 0.0, 20.0)]
        .map(|image| image.into_raw());
    let allowed = options.pixel_count() / 1000;
    // Flat loops stop at half the limit: they refuse the scene rather than walk it.
    let flat = common::gpu_with(Acceleration::Flat).unwrap();
    match flat.render(&scene, &options) {
        Err(GpuError::TooLarge(why)) => assert!(why.contains("flat loops"), "{why}"),
        other => {
            panic!("flat loops over {} slivers: {:?}", scene.primitive_counts().total(), other.map(|_| "an image"))
        }
    }
    for acceleration in [Acceleration::Bins, Acceleration::Hierarchy, Acceleration::Auto] {
        let gpu = common::gpu_with(acceleration).unwrap();
        let (ours, stats) = common::render_gpu_tiles(&gpu, &scene, &options);
        for errors in compare_frames(&ours, &reference, (0.0, 20.0)) {
            let off = errors.image.off_by_more_than_one;
            assert!(off <= allowed, "{acceleration:?}, floats, {:?}: {off} pixels off the reference", errors.output);
            assert_eq!(errors.hit_mismatches, 0, "{acceleration:?}: hit/miss differs from the reference");
        }
        let (packed, packed_stats) = render_packed(&gpu, &scene, &options);
        for (output, (ours, theirs)) in ["colour", "normals", "depth"].iter().zip(packed.iter().zip(&expected)) {
            let off = pixels_off(ours, theirs);
            assert!(off <= allowed, "{acceleration:?}, 8-bit {output}: {off} pixels off the reference");
        }
        assert_eq!(packed_stats.pixels_cut_short, stats.pixels_cut_short, "{acceleration:?}");
        println!("{acceleration:?} ({}): {} pixels cut short", stats.acceleration.name(), stats.pixels_cut_short);
        if gpu.loop_limit().is_some() && acceleration != Acceleration::Auto {
            assert!(
                stats.pixels_cut_short > 0,
                "{acceleration:?}: no pixel was cut short, so the scene no longer tests the limit"
            );
        }
    }
}
