use raycaster::gpu::{GpuOptions, GpuRenderer};
use raycaster::render::RenderOptions;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = raycaster::scene::load_scene(args[1].as_ref()).unwrap();
    let size: u32 = args[2].parse().unwrap();
    let variants: Vec<String> = args[3].split(',').map(|s| s.to_string()).collect();
    let base = GpuRenderer::with_options(GpuOptions::default()).unwrap();
    let gpus: Vec<GpuRenderer> = variants
        .iter()
        .map(|v| {
            let acceleration = match v.split(':').nth(1) {
                Some("flat") => raycaster::gpu::Acceleration::Flat,
                Some("bvh") => raycaster::gpu::Acceleration::Hierarchy,
                Some("bins") => raycaster::gpu::Acceleration::Bins,
                _ => raycaster::gpu::Acceleration::Auto,
            };
            base.on_same_device(GpuOptions { acceleration, ..GpuOptions::default() })
        })
        .collect();
    let options = RenderOptions { normals: false, depth: false, ..RenderOptions::all(size, size) };
    let mut k: Vec<Vec<f64>> = vec![vec![]; variants.len()];
    let mut images: Vec<Vec<u8>> = vec![vec![]; variants.len()];
    for round in 0..7 {
        for (v, name) in variants.iter().enumerate() {
            let mut parts = name.split(':');
            std::env::set_var("RCX", parts.next().unwrap());
            let _ = parts.next();
            if let Some(wg) = parts.next() {
                let mut w = wg.split('x');
                std::env::set_var("RCWX", w.next().unwrap());
                std::env::set_var("RCWY", w.next().unwrap());
            }
            let p = gpus[v].prepare(&scene, &options, true).unwrap();
            let mut img = vec![];
            let stats = p
                .render(|tile| {
                    if round == 0 {
                        img.extend(tile.color_rgb());
                    }
                    Ok::<(), raycaster::gpu::GpuError>(())
                })
                .unwrap();
            if round == 0 {
                images[v] = img;
            }
            k[v].push(stats.kernel_ns.unwrap() as f64 / 1e6);
        }
    }
    for (v, name) in variants.iter().enumerate() {
        k[v].sort_by(|a, b| a.partial_cmp(b).unwrap());
        let diff = images[v].iter().zip(&images[0]).filter(|(a, b)| a != b).count();
        println!(
            "variant {name}: kernel median {:.1} ms (min {:.1}); bytes differing from first: {diff}",
            k[v][3], k[v][0]
        );
    }
}
