//! The OBJ reader on arbitrary bytes: `Ok` with every index in range, or a located error.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(mesh) = raycaster::scene::parse_obj(&text, Path::new("fuzz.obj")) {
        let count = mesh.positions.len();
        assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < count), "index out of range");
        assert!(mesh.positions.iter().all(|p| p.is_finite()), "non-finite vertex");
    }
});
