//! The live window's frames drawn on the device ([`raycaster::gpu::Presenter`]): the
//! texels hold, byte for byte, what the window draws from the host for the same view (the
//! float frame quantised by `image_io`, each pixel repeated `scale × scale` times, opaque),
//! in either byte order a surface takes, with the image in one tile or many, through copies
//! or mapped buffers; the depth over a `-depth` range or over the frame's own hits; and a
//! frame with a pixel handed over to the reference says so.

mod common;

use raycaster::gpu::{GpuOptions, GpuRenderer, Presented, Presenter};
use raycaster::image_io;
use raycaster::render::{Output, Outputs, RenderOptions};
use raycaster::sampling::{Filter, Sampler, Sampling};
use raycaster::scene::{load_scene, Scene};

/// `texture`'s bytes, row by row from the top, without the copy's row padding.
fn read_texture(gpu: &GpuRenderer, texture: &wgpu::Texture) -> Vec<u8> {
    let (width, height) = (texture.width(), texture.height());
    let row = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = gpu.device().create_buffer(&wgpu::BufferDescriptor {
        label: Some("read"),
        size: row as u64 * height as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device().create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(height) },
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    gpu.queue().submit([encoder.finish()]);
    let slice = buffer.slice(..);
    slice.map_async(wgpu::MapMode::Read, |r| r.expect("the texture's copy maps"));
    gpu.device().poll(wgpu::PollType::Wait { submission_index: None, timeout: None }).expect("the device finishes");
    let view = slice.get_mapped_range().expect("mapped");
    view.chunks_exact(row as usize).flat_map(|r| r[..4 * width as usize].to_vec()).collect()
}

/// What a frame shows: colour, normals, or the depth over a `-depth MIN MAX` range.
#[derive(Clone, Copy, Debug)]
enum View {
    Color,
    Normals,
    Depth(f32, f32),
    /// The depth without a range: between the frame's nearest and farthest hits.
    DepthOfHits,
}

impl View {
    fn output(self) -> Output {
        match self {
            View::Color => Output::Color,
            View::Normals => Output::Normals,
            View::Depth(..) | View::DepthOfHits => Output::Depth,
        }
    }
}

/// What the window draws from the host: the float frame quantised as the files are, each
/// pixel a `scale × scale` block cut at the target's edges, each texel opaque in `format`'s
/// byte order.
fn drawn_from_host(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
    view: View,
    scale: u32,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
) -> Vec<u8> {
    let frame = gpu.render(scene, options).expect("the GPU renders the scene");
    let image = match view {
        View::Color => image_io::color_image(&frame),
        View::Normals => image_io::normals_image(&frame),
        View::Depth(min, max) => image_io::depth_image(&frame, min, max),
        View::DepthOfHits => {
            let (min, max) = image_io::hit_depth_range(std::slice::from_ref(&frame));
            image_io::depth_image(&frame, min, max)
        }
    };
    let mut texels = Vec::with_capacity(4 * (width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            let [r, g, b] = image.get_pixel(x / scale, y / scale).0;
            let rgba = match format {
                wgpu::TextureFormat::Bgra8Unorm => [b, g, r, 255],
                _ => [r, g, b, 255],
            };
            texels.extend_from_slice(&rgba);
        }
    }
    texels
}

/// Draws `scene`'s `view` at `size` pixels onto a target of `target_size` texels on the
/// device and from the host, and compares them.
fn compare(gpu: &GpuRenderer, scene: &str, view: View, size: (u32, u32), scale: u32, target_size: (u32, u32)) {
    let options = RenderOptions { outputs: Outputs::from(view.output()), ..RenderOptions::all(size.0, size.1) };
    compare_render(gpu, scene, &options, view, scale, target_size);
}

fn compare_render(
    gpu: &GpuRenderer,
    scene: &str,
    options: &RenderOptions,
    view: View,
    scale: u32,
    target_size: (u32, u32),
) {
    let output = view.output();
    for format in [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Bgra8Unorm] {
        let scene = load_scene(&common::scenes_dir().join(scene)).expect("the scene loads");
        let texture = common::texture(gpu, target_size, format);
        let prepared = gpu.prepare(&scene, options, true).expect("the GPU prepares the scene");
        let presenter = Presenter::new(gpu);
        let presented = match view {
            View::Depth(min, max) => prepared.present_depth(&presenter, &texture, scale, Some((min, max))),
            View::DepthOfHits => prepared.present_depth(&presenter, &texture, scale, None),
            View::Color | View::Normals => prepared.present(&presenter, &texture, scale),
        };
        assert_eq!(
            presented.expect("the frame is drawn"),
            Presented::Drawn,
            "{}: no pixel is handed over",
            scene.path.display()
        );
        let device = read_texture(gpu, &texture);
        let host = drawn_from_host(gpu, &scene, options, view, scale, target_size, format);
        let differing = device.chunks_exact(4).zip(host.chunks_exact(4)).filter(|(d, h)| d != h).count();
        assert_eq!(
            differing,
            0,
            "{} {output:?} {}x{} ×{scale} onto {target_size:?} {format:?}: texels differ from the host's",
            scene.path.display(),
            options.width,
            options.height
        );
    }
}

#[test]
fn a_frame_drawn_on_the_device_is_the_one_drawn_from_the_host() {
    let Some(gpu) = common::gpu() else { return };
    compare(gpu, "plane_and_sphere_perspective.txt", View::Color, (64, 48), 1, (64, 48));
    compare(gpu, "three_lights.txt", View::Normals, (64, 48), 1, (64, 48));
    // Moving frames: a smaller image enlarged, its last blocks cut at the target's edges.
    compare(gpu, "triangles.txt", View::Color, (23, 17), 3, (67, 50));
    compare(gpu, "mesh_octahedron.txt", View::Normals, (30, 20), 4, (117, 80));
    // Assignment 7's supersampling: the filter's pass writes the pixels the pass enlarges.
    let sampling = Sampling { sampler: Sampler::Jittered(4), filter: Filter::Tent(1.0), seed: 5 };
    let options =
        RenderOptions { outputs: Outputs::from(Output::Color), sampling: Some(sampling), ..RenderOptions::all(40, 30) };
    compare_render(gpu, "plane_and_sphere_perspective.txt", &options, View::Color, 2, (80, 59));
}

/// The depth over a `-depth` range, drawn on the device, is the host's `image_io::depth_image`
/// texel for texel: the range cuts the scene's hits (the nearest quarter white, the farthest
/// quarter black, grey levels between), and misses are black.
#[test]
fn the_depth_drawn_on_the_device_is_the_one_drawn_from_the_host() {
    let Some(gpu) = common::gpu() else { return };
    for (scene, size, scale, target) in
        [("plane_and_sphere_perspective.txt", (64, 48), 1, (64, 48)), ("mesh_octahedron.txt", (30, 20), 3, (89, 59))]
    {
        let loaded = load_scene(&common::scenes_dir().join(scene)).expect("the scene loads");
        let options = RenderOptions { outputs: Outputs::from(Output::Depth), ..RenderOptions::all(size.0, size.1) };
        let frame = gpu.render(&loaded, &options).expect("the GPU renders the scene");
        let mut hits: Vec<f32> = frame.depth.iter().zip(&frame.hit).filter(|(_, &h)| h).map(|(&t, _)| t).collect();
        hits.sort_by(f32::total_cmp);
        assert!(hits.len() < frame.hit.len(), "{scene}: some pixel misses");
        let range = (hits[hits.len() / 4], hits[3 * hits.len() / 4]);
        let image = image_io::depth_image(&frame, range.0, range.1);
        let levels: std::collections::BTreeSet<u8> = image.pixels().map(|p| p.0[0]).collect();
        assert!(levels.len() > 10 && levels.contains(&0) && levels.contains(&255), "{scene}: levels {levels:?}");
        compare(gpu, scene, View::Depth(range.0, range.1), size, scale, target);
    }
}

/// Without a `-depth` range the device gathers the frame's nearest and farthest hit itself
/// and draws what the host draws over the range it finds by folding the float frame's hits
/// (`image_io::hit_depth_range`): white at the nearest, black at the farthest and at misses;
/// over many tiles, whose hits are gathered across them; a frame that misses everything
/// is black.
#[test]
fn the_depth_over_the_frames_own_hits_is_the_one_drawn_from_the_host() {
    let Some(gpu) = common::gpu() else { return };
    for (scene, size, scale, target) in [
        ("plane_and_sphere_perspective.txt", (64, 48), 1, (64, 48)),
        ("mesh_octahedron.txt", (30, 20), 3, (89, 59)),
        ("three_lights.txt", (40, 30), 2, (80, 59)),
    ] {
        let loaded = load_scene(&common::scenes_dir().join(scene)).expect("the scene loads");
        let options = RenderOptions { outputs: Outputs::from(Output::Depth), ..RenderOptions::all(size.0, size.1) };
        let frame = gpu.render(&loaded, &options).expect("the GPU renders the scene");
        let (min, max) = image_io::hit_depth_range(std::slice::from_ref(&frame));
        let levels: std::collections::BTreeSet<u8> =
            image_io::depth_image(&frame, min, max).pixels().map(|p| p.0[0]).collect();
        assert!(levels.contains(&255) && levels.len() > 10, "{scene}: the nearest hit is white: {levels:?}");
        compare(gpu, scene, View::DepthOfHits, size, scale, target);
    }
    // Tiles of one row each: the nearest and farthest hits lie in different tiles.
    let small = gpu.on_same_device(GpuOptions { max_tile_bytes: 400, mapped_buffers: false, ..GpuOptions::default() });
    compare(&small, "plane_and_sphere_perspective.txt", View::DepthOfHits, (100, 60), 1, (100, 60));
    // A camera turned away from everything: no hit, a black frame.
    let away = "PerspectiveCamera { center 0 0 10 direction 0 0 1 up 0 1 0 angle 30 }
        Background { color 0.5 0.5 0.5 } Materials { numMaterials 1 Material { diffuseColor 1 0 0 } }
        Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }";
    let scene = raycaster::scene::parse_scene(away, std::path::Path::new("away.txt")).expect("the scene parses");
    let options = RenderOptions { outputs: Outputs::from(Output::Depth), ..RenderOptions::all(16, 8) };
    let texture = common::texture(gpu, (16, 8), wgpu::TextureFormat::Rgba8Unorm);
    let prepared = gpu.prepare(&scene, &options, true).expect("the GPU prepares the scene");
    assert_eq!(prepared.present_depth(&Presenter::new(gpu), &texture, 1, None).unwrap(), Presented::Drawn);
    assert!(read_texture(gpu, &texture).chunks_exact(4).all(|t| t == [0, 0, 0, 255]), "a frame of misses is black");
}

#[test]
fn a_frame_of_many_tiles_through_copies_is_drawn_whole() {
    let Some(gpu) = common::gpu() else { return };
    // A row of 100 packed pixels per tile, and the copies a discrete GPU makes: tiles take
    // turns in the slots while earlier ones are still being enlarged.
    let small = gpu.on_same_device(GpuOptions { max_tile_bytes: 400, mapped_buffers: false, ..GpuOptions::default() });
    compare(&small, "plane_and_sphere_perspective.txt", View::Color, (100, 60), 1, (100, 60));
    compare(&small, "three_lights.txt", View::Color, (100, 60), 2, (199, 119));
}

#[test]
fn a_target_larger_than_a_bindable_buffer_is_left_to_the_host() {
    if common::gpu().is_none() {
        return;
    }
    // A device whose storage bindings hold 1 MiB, and a 1024 × 768 target: 3 MiB of texels.
    let instance = GpuRenderer::instance();
    let adapter = pollster::block_on(instance.request_adapter(&Default::default())).expect("an adapter");
    let limits = wgpu::Limits { max_storage_buffer_binding_size: 1 << 20, ..adapter.limits() };
    let (device, queue) = pollster::block_on(
        adapter.request_device(&wgpu::DeviceDescriptor { required_limits: limits, ..Default::default() }),
    )
    .expect("the device opens with lower limits");
    let gpu = GpuRenderer::with_device(adapter.get_info(), device, queue, GpuOptions::default());
    let scene = load_scene(&common::scenes_dir().join("three_lights.txt")).expect("the scene loads");
    let options = RenderOptions { outputs: Outputs::from(Output::Color), ..RenderOptions::all(64, 48) };
    let prepared = gpu.prepare(&scene, &options, true).expect("the GPU prepares the scene");
    let texture = common::texture(&gpu, (1024, 768), wgpu::TextureFormat::Rgba8Unorm);
    assert_eq!(prepared.present(&Presenter::new(&gpu), &texture, 16).unwrap(), Presented::TooLarge);
    // Within the limit the same device draws.
    let texture = common::texture(&gpu, (256, 192), wgpu::TextureFormat::Rgba8Unorm);
    assert_eq!(prepared.present(&Presenter::new(&gpu), &texture, 4).unwrap(), Presented::Drawn);
}
