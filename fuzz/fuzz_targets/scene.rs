//! The scene parser on arbitrary bytes: it must return `Ok` or a located error, never panic,
//! hang, or allocate by a count the file declares.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // As `load_scene` reads a file: invalid UTF-8 becomes U+FFFD.
    let text = String::from_utf8_lossy(data);
    // The scene "lives" in scenes/, so `obj_file octahedron.obj` (as in the seeds) loads a
    // real mesh and the mesh path of the parser is fuzzed too.
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/fuzz.txt"));
    if let Ok(scene) = raycaster::scene::parse_scene(&text, path) {
        // What the parser promises the renderers about an accepted scene: a camera frame
        // (built at parse time, so it always exists) with finite axes.
        let frame = scene.camera.frame();
        let axes = [frame.direction, frame.up, frame.horizontal];
        assert!(axes.iter().all(|a| a.is_finite()), "accepted a camera without a finite frame: {frame:?}");
        // Attenuations that keep `a0 + a1·d + a2·d²` positive for d > 0 (docs/SPEC.md §2).
        for light in &scene.lights {
            if let raycaster::scene::Light::Point(light) = light {
                let a = light.attenuation;
                assert!(a.min_element() >= 0.0 && a.max_element() > 0.0, "accepted attenuation {a}");
            }
        }
        let _ = scene.primitive_counts();
    }
});
