//! Inputs that made the scene front end slow or crash, kept once fixed, and the committed
//! seeds the fuzzers start from. The fuzz targets are in `fuzz/` (see docs/testing.md, "Fuzzing"
//! section); each entry says what the input did.

use raycaster::scene::{parse_obj, parse_scene};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;
use std::time::Instant;

/// The system allocator, recording the largest single allocation of each thread, so a test
/// can show what `-malloc_limit_mb` shows the fuzzers: no count written in a file turns into
/// a reservation.
struct RecordingAllocator;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn record(size: usize) {
    // `try_with`: the allocator also runs while thread-locals are being torn down.
    let _ = LARGEST.try_with(|largest| largest.set(largest.get().max(size)));
}

unsafe impl GlobalAlloc for RecordingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: RecordingAllocator = RecordingAllocator;

/// The largest single allocation `f` makes on this thread.
fn largest_allocation(f: impl FnOnce()) -> usize {
    LARGEST.with(|largest| largest.set(0));
    f();
    LARGEST.with(Cell::get)
}

const CAMERA: &str = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }";

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

/// Counts of four billion, valid or not, in every counted block and as OBJ indices: what the
/// parser allocates follows what it has read (under 16 KiB at a time here), never what a file
/// declares.
#[test]
fn declared_counts_reserve_nothing() {
    let sphere = "MaterialIndex 0 Sphere { center 0 0 0 radius 1 }";
    let scenes = [
        format!("{CAMERA}\nMaterials {{ numMaterials 1 Material {{ }} }}\nGroup {{ numObjects 4000000000 {sphere} }}"),
        format!("{CAMERA}\nMaterials {{ numMaterials 1 Material {{ }} }}\nGroup {{ numObjects 4000000000 {sphere}"),
        format!("{CAMERA}\nLights {{ numLights 4000000000 DirectionalLight {{ direction 0 0 -1 color 1 1 1 }} }}"),
        format!("{CAMERA}\nMaterials {{ numMaterials 4000000000 Material {{ }} }}"),
        format!("{CAMERA}\nMaterials {{ numMaterials 1 Material {{ }} }}\nGroup {{ numObjects 1 MaterialIndex 3999999999 }}"),
    ];
    for text in &scenes {
        let largest = largest_allocation(|| assert!(parse_scene(text, Path::new("counts.txt")).is_err()));
        assert!(largest < 16 << 10, "{largest} bytes in one allocation for:\n{text}");
    }
    for text in ["v 0 0 0\nf 1 1 4000000000\n", "v 0 0 0\nf 1 1 -4000000000\n", "v 0 0 0\nf 1 1 18446744073709551615\n"]
    {
        let largest = largest_allocation(|| assert!(parse_obj(text, Path::new("counts.obj")).is_err()));
        assert!(largest < 16 << 10, "{largest} bytes in one allocation for:\n{text}");
    }
}

/// The recorder itself: a reservation by a parsed count would be seen.
#[test]
fn the_allocation_recorder_sees_a_reservation() {
    let count: usize = "4000000".parse().unwrap();
    let largest = largest_allocation(|| drop(std::hint::black_box(Vec::<u8>::with_capacity(count))));
    assert!(largest >= 4_000_000, "{largest}");
}

/// The committed seeds of `fuzz/seeds` load as the scene target reads its inputs (as a file in
/// `scenes/`, where their `obj_file` names resolve), and between them use every part of
/// assignment 4's grammar: so the fuzzer starts from inputs that reach point lights,
/// attenuation and every material field, and of assignment 6's: every solid texture, one
/// nested in another.
#[test]
fn the_committed_fuzz_seeds_load_and_cover_assignments_4_and_6() {
    use glam::DVec3;
    use raycaster::scene::{Light, TextureKind};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let as_the_target_reads = root.join("scenes/fuzz.txt");
    let mut scenes = Vec::new();
    for entry in std::fs::read_dir(root.join("fuzz/seeds")).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let scene = parse_scene(&text, &as_the_target_reads).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        scenes.push(scene);
    }
    let lights: Vec<&Light> = scenes.iter().flat_map(|s| &s.lights).collect();
    let materials: Vec<_> = scenes.iter().flat_map(|s| &s.materials).collect();
    let covered = [
        ("a point light", lights.iter().any(|l| matches!(l, Light::Point(_)))),
        ("an attenuation", lights.iter().any(|l| matches!(l, Light::Point(p) if p.attenuation != DVec3::X))),
        ("a specular colour", materials.iter().any(|m| m.specular != DVec3::ZERO && m.exponent != 1.0)),
        ("a reflective colour", materials.iter().any(|m| m.reflective != DVec3::ZERO)),
        ("a transparent colour", materials.iter().any(|m| m.transparent != DVec3::ZERO)),
        ("an index of refraction", materials.iter().any(|m| m.index_of_refraction != 1.0)),
        ("a mesh", scenes.iter().any(|s| s.primitive_counts().triangles > 0)),
    ];
    let textures: Vec<_> = scenes.iter().flat_map(|s| s.textures.iter().flatten().map(move |t| (s, t))).collect();
    let kind = |k: TextureKind| textures.iter().any(|(_, t)| t.kind == k);
    let nested = textures.iter().any(|(s, t)| t.materials.iter().any(|&m| s.texture(m).is_some()));
    let covered = covered.into_iter().chain([
        ("a Checkerboard", kind(TextureKind::Checkerboard)),
        ("a Noise", kind(TextureKind::Noise)),
        ("a Marble", kind(TextureKind::Marble)),
        ("a Wood", kind(TextureKind::Wood)),
        ("a texture of textures", nested),
    ]);
    let covered: Vec<(&str, bool)> = covered.collect();
    let missing: Vec<&str> = covered.iter().filter(|(_, found)| !found).map(|(what, _)| *what).collect();
    assert!(missing.is_empty(), "no seed has {missing:?}");
}
