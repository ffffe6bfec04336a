//! `raycaster selftest`: anyone's check of their own GPU and driver (docs/SPEC.md §6,
//! "What the kernel assumes of the driver"). The built-in cases are scenes of this
//! repository, compiled into the binary: the hard cases where drivers that round or fuse
//! differently give different images (degenerate and edge-on triangles seen in
//! perspective, a far and a squashed sphere, a horizon, a scene a million units from the
//! origin) and scenes like the course's. Each renders on the GPU and with the f64
//! reference at a small size; a case passes when every output is within the contract
//! (at most 0.1 % of the pixels more than 1 level off, no NaN or infinity).

use raycaster::gpu::GpuRenderer;
use raycaster::metrics::{compare_frames, depth_range_of};
use raycaster::render::RenderOptions;
use raycaster::scene::{parse_scene_with, ObjFiles};
use std::collections::HashMap;
use std::path::PathBuf;

/// The side of every case's image: large enough that 0.1 % is a tenth of a pixel row.
const SIZE: u32 = 100;

/// (name, scene text): the cases, in the order the table lists them.
const CASES: [(&str, &str); 13] = [
    ("hard/degenerate_perspective.txt", include_str!("../../scenes/hard/degenerate_perspective.txt")),
    ("hard/degenerate_triangles.txt", include_str!("../../scenes/hard/degenerate_triangles.txt")),
    ("hard/edge_on_triangles.txt", include_str!("../../scenes/hard/edge_on_triangles.txt")),
    ("hard/far_sphere.txt", include_str!("../../scenes/hard/far_sphere.txt")),
    ("hard/squashed_sphere.txt", include_str!("../../scenes/hard/squashed_sphere.txt")),
    ("hard/horizon_plane.txt", include_str!("../../scenes/hard/horizon_plane.txt")),
    ("hard/offset_translated_1e6.txt", include_str!("../../scenes/hard/offset_translated_1e6.txt")),
    ("spheres_ortho.txt", include_str!("../../scenes/spheres_ortho.txt")),
    ("plane_and_sphere_perspective.txt", include_str!("../../scenes/plane_and_sphere_perspective.txt")),
    ("mesh_octahedron.txt", include_str!("../../scenes/mesh_octahedron.txt")),
    ("transforms_all.txt", include_str!("../../scenes/transforms_all.txt")),
    ("ellipsoids.txt", include_str!("../../scenes/ellipsoids.txt")),
    ("three_lights.txt", include_str!("../../scenes/three_lights.txt")),
];

/// The meshes the cases name, by the name their `obj_file` gives.
const MESHES: [(&str, &str); 4] = [
    ("degenerate.obj", include_str!("../../scenes/hard/degenerate.obj")),
    ("octahedron.obj", include_str!("../../scenes/octahedron.obj")),
    ("box.obj", include_str!("../../scenes/box.obj")),
    ("../box.obj", include_str!("../../scenes/box.obj")),
];

pub struct Report {
    /// The adapter, then a Markdown table: case, outputs, pixels off, verdict.
    pub table: String,
    pub cases: usize,
    pub failed: usize,
}

/// What a case came to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Verdict {
    Pass,
    /// The GPU refused the scene by name (a limit of this adapter, or f32's range), as a
    /// render does before `auto` hands it to the reference: no wrong image, so no failure.
    Refused,
    Fail,
}

/// Renders every case on `gpu` and with the reference, and judges it.
pub fn run(gpu: &GpuRenderer) -> Report {
    let info = gpu.adapter_info();
    let mut table = format!(
        "adapter: {} ({:?}, {:?}); driver: {} {}\n",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    );
    if raycaster::gpu::fuse::requested() {
        table += &format!("mode: {}=1, every multiply-add of the kernel fused\n", raycaster::gpu::fuse::VARIABLE);
    }
    table += &format!("each case at {SIZE}×{SIZE}, GPU against the f64 reference (at most 0.1 % of pixels more than 1 level off, no NaN):\n");
    table += "| case | outputs | pixels off (colour / normals / depth) | verdict |\n| --- | --- | ---: | --- |\n";
    let meshes: HashMap<PathBuf, String> = MESHES.iter().map(|(n, t)| (PathBuf::from(n), t.to_string())).collect();
    let mut failed = 0;
    for (name, text) in CASES {
        let (cells, verdict) = judge(gpu, name, text, &meshes);
        failed += usize::from(verdict == Verdict::Fail);
        let verdict = match verdict {
            Verdict::Pass => "pass",
            Verdict::Refused => "refused (the reference renders it)",
            Verdict::Fail => "FAIL",
        };
        table += &format!("| {name} | colour, normals, depth | {cells} | {verdict} |\n");
    }
    Report { table, cases: CASES.len(), failed }
}

/// The pixels off per output, and the case's verdict.
fn judge(gpu: &GpuRenderer, name: &str, text: &str, meshes: &HashMap<PathBuf, String>) -> (String, Verdict) {
    let scene = match parse_scene_with(text, &PathBuf::from(name), ObjFiles::Memory(meshes)) {
        Ok(scene) => scene,
        Err(e) => return (format!("does not load: {e}"), Verdict::Fail),
    };
    let options = RenderOptions::all(SIZE, SIZE);
    let ours = match gpu.render(&scene, &options) {
        Ok(frame) => frame,
        Err(e) if e.reference_renders_it() => return (e.to_string(), Verdict::Refused),
        Err(e) => return (e.to_string(), Verdict::Fail),
    };
    let reference = raycaster::cpu::render(&scene, &options);
    let errors = compare_frames(&ours, &reference, depth_range_of(&reference));
    let limit = (SIZE * SIZE) as usize / 1000;
    let passes = errors.iter().all(|e| e.image.off_by_more_than_one <= limit && e.non_finite == 0);
    let verdict = if passes { Verdict::Pass } else { Verdict::Fail };
    let cells = errors
        .iter()
        .map(|e| {
            if e.non_finite > 0 {
                format!("{} (+{} NaN/inf)", e.image.off_by_more_than_one, e.non_finite)
            } else {
                e.image.off_by_more_than_one.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(" / ");
    (cells, verdict)
}
