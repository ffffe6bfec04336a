use raycaster::gpu::{Acceleration, GpuOptions, GpuRenderer};
use raycaster::render::RenderOptions;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&args[1]).unwrap();
    std::fs::write(dir.path().join("s.txt"), &text).unwrap();
    let mesh = raycaster::scene::generate::icosphere(glam::DVec3::ZERO, 1.0, 5);
    raycaster::scene::generate::write_obj(&mesh, &dir.path().join("icosphere5.obj")).unwrap();
    let scene = raycaster::scene::load_scene(&dir.path().join("s.txt")).unwrap();
    let base = GpuRenderer::new().unwrap();
    let options = RenderOptions::all(96, 80);
    let r =
        |a| base.on_same_device(GpuOptions { acceleration: a, ..Default::default() }).render(&scene, &options).unwrap();
    let (f, b, n) = (r(Acceleration::Flat), r(Acceleration::Hierarchy), r(Acceleration::Bins));
    let rows: Vec<usize> = (0..80).filter(|r| (0..96).any(|c| f.hit[r * 96 + c] != b.hit[r * 96 + c])).collect();
    println!("rows with differences: {rows:?}");
    let cols: Vec<usize> = (0..96).filter(|c| (0..80).any(|r| f.hit[r * 96 + c] != b.hit[r * 96 + c])).collect();
    println!("cols: {cols:?}");
    for (name, x) in [("bvh", &b), ("bins", &n)] {
        let mut hit = 0;
        let mut depth = 0;
        let mut normal = 0;
        let mut first = None;
        for k in 0..f.hit.len() {
            if f.hit[k] != x.hit[k] {
                hit += 1;
                first.get_or_insert(k);
            } else if f.hit[k] && f.depth[k] != x.depth[k] {
                depth += 1;
                first.get_or_insert(k);
            } else if f.hit[k] && f.normal[k] != x.normal[k] {
                normal += 1;
            }
        }
        println!(
            "{name}: hit {hit} depth {depth} normal {normal}; flat hits {}; first {:?} flat {:?} {:?}",
            f.hit.iter().filter(|&&h| h).count(),
            first,
            first.map(|k| (f.hit[k], f.depth[k])),
            first.map(|k| (x.hit[k], x.depth[k]))
        );
    }
}
