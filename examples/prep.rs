fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = raycaster::scene::load_scene(args[1].as_ref()).unwrap();
    let t = std::time::Instant::now();
    let acceleration = match args.get(2).map(|s| s.as_str()) {
        Some("flat") => raycaster::gpu::Acceleration::Flat,
        Some("bvh") => raycaster::gpu::Acceleration::Hierarchy,
        _ => raycaster::gpu::Acceleration::Bins,
    };
    let gpu =
        raycaster::gpu::GpuRenderer::with_options(raycaster::gpu::GpuOptions { acceleration, ..Default::default() })
            .unwrap();
    println!("open {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    let options = raycaster::render::RenderOptions {
        normals: false,
        depth: false,
        ..raycaster::render::RenderOptions::all(200, 200)
    };
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let p = gpu.prepare(&scene, &options, true).unwrap();
        let a = t.elapsed().as_secs_f64() * 1e3;
        p.render(|_| Ok::<(), raycaster::gpu::GpuError>(())).unwrap();
        println!("prepare {a:.1} ms, render total {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    }
}
