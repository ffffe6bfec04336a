//! Our Rust port of ꟻLIP (src/flip.rs) against NVIDIA's C++ implementation, which the
//! `nv-flip` crate builds (a dev-dependency: the binary does not link it). The port does the
//! same `f32` operations in the same order, so the two error maps agree to float rounding.

mod common;

use image::RgbImage;
use raycaster::render::RenderOptions;

/// NVIDIA's error map of `test` against `reference`.
fn nvidia(reference: &RgbImage, test: &RgbImage) -> Vec<f32> {
    let (w, h) = reference.dimensions();
    let reference = nv_flip::FlipImageRgb8::with_data(w, h, reference.as_raw());
    let test = nv_flip::FlipImageRgb8::with_data(w, h, test.as_raw());
    nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec()
}

/// The two maps agree pixel by pixel, and in their mean; `what` names the pair.
fn assert_same_map(reference: &RgbImage, test: &RgbImage, what: &str) {
    let ours = raycaster::flip::flip(reference, test, raycaster::flip::DEFAULT_PIXELS_PER_DEGREE);
    let theirs = nvidia(reference, test);
    assert_eq!(ours.values.len(), theirs.len(), "{what}");
    let worst = ours.values.iter().zip(&theirs).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    let their_mean = theirs.iter().map(|&v| v as f64).sum::<f64>() / theirs.len() as f64;
    assert!(worst < 1e-6, "{what}: a pixel's error differs by {worst}");
    assert!((ours.mean() - their_mean).abs() < 1e-6, "{what}: mean {} against {their_mean}", ours.mean());
    // Not two maps of zeros: the pair differs visibly somewhere.
    assert!(their_mean > 1e-3, "{what}: NVIDIA sees no difference (mean {their_mean})");
}

/// One of our scenes, rendered by the reference.
fn render(scene: &str, width: u32, height: u32) -> RgbImage {
    let scene = raycaster::scene::load_scene(&common::scenes_dir().join(scene)).unwrap();
    raycaster::image_io::color_image(&raycaster::cpu::render(&scene, &RenderOptions::all(width, height)))
}

/// Deterministic noise, so that every colour, edge and point of the filters is exercised.
fn noise(width: u32, height: u32, seed: u64) -> RgbImage {
    let mut state = seed;
    RgbImage::from_fn(width, height, |_, _| {
        let v = common::splitmix64(&mut state);
        image::Rgb([v as u8, (v >> 8) as u8, (v >> 16) as u8])
    })
}

#[test]
fn the_port_matches_nvidia_on_noise_and_odd_sizes() {
    let grey = |level| RgbImage::from_pixel(16, 16, image::Rgb([level; 3]));
    assert_same_map(&grey(128), &grey(129), "grey, one level apart");
    assert_same_map(&noise(37, 23, 1), &noise(37, 23, 2), "noise 37×23");
    // Narrower than the filters: every tap reads a clamped edge.
    assert_same_map(&noise(3, 40, 3), &noise(3, 40, 4), "noise 3×40");
}

#[test]
fn the_port_matches_nvidia_on_renders_changed_as_a_student_might() {
    let ours = render("three_lights.txt", 96, 80);
    let swapped = RgbImage::from_fn(96, 80, |x, y| {
        let [r, g, b] = ours.get_pixel(x, y).0;
        image::Rgb([b, g, r])
    });
    assert_same_map(&ours, &swapped, "swapped channels");
    let shifted = RgbImage::from_fn(96, 80, |x, y| *ours.get_pixel(x.saturating_sub(3), y));
    assert_same_map(&ours, &shifted, "shifted 3 pixels");
    assert_same_map(&ours, &render("spheres_ortho.txt", 96, 80), "another scene");
}

/// The course's own images, where the corpus is present: two renders of one scene.
#[test]
fn the_port_matches_nvidia_on_the_course_images() {
    let Some(corpus) = common::corpus() else { return };
    let read = |name: &str| raycaster::image_io::read_image(&corpus.join("a3/expected").join(name)).unwrap();
    assert_same_map(&read("output3_09.png"), &read("output3_09_fix.png"), "the course's specular fix");
}
