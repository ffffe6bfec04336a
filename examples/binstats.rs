use raycaster::gpu::{flatten::SceneBuffers, Acceleration, GpuOptions};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = raycaster::scene::load_scene(args[1].as_ref()).unwrap();
    let size: u32 = args[2].parse().unwrap();
    let rays = raycaster::camera::PrimaryRays::for_camera(&scene.camera, size, size);
    let b = SceneBuffers::new(&scene, &rays, &GpuOptions { acceleration: Acceleration::Bins, ..Default::default() });
    let bins = b.bins.unwrap();
    let nonempty = bins.ranges.iter().filter(|r| r[1] > 0).count();
    let maxc = bins.ranges.iter().map(|r| r[1]).max().unwrap();
    println!(
        "bins {} nonempty {} items {} mean {:.1} mean over nonempty {:.1} max {} build {:.1} ms",
        bins.ranges.len(),
        nonempty,
        bins.items.len(),
        bins.mean_list_length(),
        bins.items.len() as f64 / nonempty as f64,
        maxc,
        bins.build_ms
    );
}
