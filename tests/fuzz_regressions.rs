//! Inputs that made the scene front end slow or crash, kept once fixed. The fuzz targets are
//! in `fuzz/` (see the README's "Fuzzing" section); each entry says what the input did.

use raycaster::scene::parse_obj;
use std::path::Path;
use std::time::Instant;

/// One face line of 300 000 entries. Each entry's column used to be counted from the start
/// of the line, so the line cost N²/2 character scans: 50 s on this (loaded) machine. Linear, it is
/// a few tens of milliseconds; 1 s leaves room for a loaded machine and debug builds.
#[test]
fn a_face_line_with_many_entries_reads_in_linear_time() {
    const ENTRIES: usize = 300_000;
    let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf {}\n", "1 2 3 ".repeat(ENTRIES / 3));
    let start = Instant::now();
    let mesh = parse_obj(&text, Path::new("long_face.obj")).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    assert_eq!(mesh.triangles.len(), ENTRIES - 2);
    assert!(seconds < 1.0, "{seconds:.2} s for one face line of {ENTRIES} entries");
}

/// The last entry's column is still right after the incremental counting (a multi-byte
/// character before it counts as one column).
#[test]
fn columns_of_a_long_face_line() {
    let text = format!("v 0 0 0\nf {}ä 0\n", "1 ".repeat(1000));
    let error = parse_obj(&text, Path::new("m.obj")).unwrap_err();
    assert_eq!(error.to_string(), "m.obj:2:2003: expected a vertex index, found `ä`");
}
