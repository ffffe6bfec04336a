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
        // What the parser promises the renderers about an accepted scene.
        assert!(scene.camera.basis().is_some(), "accepted a degenerate camera");
        let _ = scene.primitive_counts();
    }
});
