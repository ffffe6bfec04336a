//! The raycaster in a browser (docs/SPEC.md §10): the library compiled to wasm32, rendering
//! with wgpu's WebGPU backend and the same WGSL kernel. The page (`web/page.js`) reads or
//! fetches the files; this crate parses them with the library's parser, renders, falls back
//! to the f64 reference where the command line's `auto` would, and hands the page RGBA bytes
//! quantised as the command line's image files are.

use raycaster::clock::Instant;
use raycaster::gpu::{GpuError, GpuOptions, GpuRenderer};
use raycaster::render::{Frame, RenderOptions, Shading};
use raycaster::scene::{self, ObjFiles, Scene};
use raycaster::{image_io, metrics};
use std::cell::OnceCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use wasm_bindgen::prelude::*;

/// The command line's largest image (docs/SPEC.md §1: at most 16384² pixels).
const MAX_PIXELS: u64 = 16384 * 16384;

thread_local! {
    /// One device per page, opened on the first render and kept for the next ones.
    static GPU: OnceCell<Rc<GpuRenderer>> = const { OnceCell::new() };
}

/// The names the scene's `obj_file`s give, for the page to fetch before it renders.
#[wasm_bindgen(js_name = objFileNames)]
pub fn obj_file_names(scene_text: &str) -> Vec<String> {
    scene::obj_file_names(scene_text)
}

/// A render for the page: its three images and what it cost.
#[wasm_bindgen]
pub struct Rendered {
    width: u32,
    height: u32,
    frame: Frame,
    depth_range: (f32, f32),
    parse_ms: f64,
    render_ms: f64,
    kernel_ms: Option<f64>,
    backend: String,
    notes: Vec<String>,
}

#[wasm_bindgen]
impl Rendered {
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.width
    }

    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Milliseconds to parse the scene and its meshes.
    #[wasm_bindgen(getter, js_name = parseMs)]
    pub fn parse_ms(&self) -> f64 {
        self.parse_ms
    }

    /// Milliseconds from handing the scene to the renderer to the last tile read back
    /// (the device's first opening not included).
    #[wasm_bindgen(getter, js_name = renderMs)]
    pub fn render_ms(&self) -> f64 {
        self.render_ms
    }

    /// The kernel's own time, where the adapter has timestamp queries.
    #[wasm_bindgen(getter, js_name = kernelMs)]
    pub fn kernel_ms(&self) -> Option<f64> {
        self.kernel_ms
    }

    /// The adapter, or the f64 reference where the GPU refused the scene.
    #[wasm_bindgen(getter)]
    pub fn backend(&self) -> String {
        self.backend.clone()
    }

    /// The lines the command line would print on stderr for a render that succeeds
    /// (located scene warnings, the fallback notice).
    #[wasm_bindgen(getter)]
    pub fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// The depth image's `MIN MAX`.
    #[wasm_bindgen(getter, js_name = depthRange)]
    pub fn depth_range(&self) -> Vec<f32> {
        vec![self.depth_range.0, self.depth_range.1]
    }

    /// `color`, `normals` or `depth` as RGBA rows from the top, for an `ImageData`: the
    /// bytes the command line writes to its TGA or PNG files, opaque.
    pub fn rgba(&self, output: &str) -> Result<Vec<u8>, JsError> {
        let rgb = match output {
            "color" => image_io::color_image(&self.frame),
            "normals" => image_io::normals_image(&self.frame),
            "depth" => image_io::depth_image(&self.frame, self.depth_range.0, self.depth_range.1),
            other => return Err(JsError::new(&format!("no output `{other}` (color, normals or depth)"))),
        };
        Ok(rgb.pixels().flat_map(|p| [p[0], p[1], p[2], 255]).collect())
    }
}

/// What the page asks for: the command line's flags that change pixels.
#[wasm_bindgen]
#[derive(Clone, Copy, Default)]
pub struct Flags {
    pub shade_back: bool,
    pub shadows: bool,
    pub bounces: u32,
    /// `-depth MIN MAX`; where unset (NaN), the range of the depths hit.
    pub depth_min: f32,
    pub depth_max: f32,
}

#[wasm_bindgen]
impl Flags {
    #[wasm_bindgen(constructor)]
    pub fn new() -> Flags {
        Flags { depth_min: f32::NAN, depth_max: f32::NAN, ..Flags::default() }
    }
}

/// Parses `scene_text` (named `scene_path`, its `obj_file`s among `file_paths` with the
/// texts `file_texts`, paths as the command line resolves them from the scene's folder) and
/// renders it at `width × height`. Fails with the line the command line would print,
/// `raycaster: FILE:LINE:COL: ...`.
#[wasm_bindgen]
pub async fn render(
    scene_path: String,
    scene_text: String,
    file_paths: Vec<String>,
    file_texts: Vec<String>,
    width: u32,
    height: u32,
    flags: &Flags,
) -> Result<Rendered, JsValue> {
    let flags = *flags;
    render_scene(&scene_path, &scene_text, file_paths.into_iter().zip(file_texts), width, height, flags)
        .await
        .map_err(|line| JsValue::from_str(&format!("raycaster: {line}")))
}

async fn render_scene(
    scene_path: &str,
    scene_text: &str,
    files: impl Iterator<Item = (String, String)>,
    width: u32,
    height: u32,
    flags: Flags,
) -> Result<Rendered, String> {
    check_size(width, height)?;
    if flags.depth_min >= flags.depth_max {
        return Err(format!("-depth: MIN ({}) must be less than MAX ({})", flags.depth_min, flags.depth_max));
    }
    let start = Instant::now();
    let files: HashMap<PathBuf, String> = files.map(|(path, text)| (PathBuf::from(path), text)).collect();
    let scene = scene::parse_scene_with(scene_text, Path::new(scene_path), ObjFiles::Memory(&files))
        .map_err(|e| e.to_string())?;
    let parse_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut notes: Vec<String> = scene.warnings.iter().map(|w| format!("raycaster: {w}")).collect();
    let options = RenderOptions {
        shading: Shading {
            shade_back: flags.shade_back,
            shadows: flags.shadows,
            bounces: flags.bounces,
            ..Shading::default()
        },
        ..RenderOptions::all(width, height)
    };
    let gpu = gpu().await?;
    let start = Instant::now();
    let (frame, kernel_ns, backend) = match render_gpu(&gpu, &scene, &options).await? {
        Ok((frame, kernel_ns)) => (frame, kernel_ns, adapter_name(gpu.adapter_info())),
        // As the command line's `--backend auto`: what the kernel refuses, the reference renders.
        Err(e) => match raycaster::renderer::fallback_notice(&e) {
            Some(notice) => {
                notes.push(format!("raycaster: warning: {notice}"));
                (raycaster::cpu::render(&scene, &options), None, "the f64 CPU reference".to_string())
            }
            None => return Err(e.to_string()),
        },
    };
    let render_ms = start.elapsed().as_secs_f64() * 1e3;
    let depth_range = match flags.depth_min.is_nan() || flags.depth_max.is_nan() {
        true => metrics::depth_range_of(&frame),
        false => (flags.depth_min, flags.depth_max),
    };
    Ok(Rendered {
        width,
        height,
        frame,
        depth_range,
        parse_ms,
        render_ms,
        kernel_ms: kernel_ns.map(|ns| ns as f64 / 1e6),
        backend,
        notes,
    })
}

/// `-size W H`'s bounds (docs/SPEC.md §1), with its message.
fn check_size(width: u32, height: u32) -> Result<(), String> {
    let pixels = width as u64 * height as u64;
    if width == 0 || height == 0 || width > 65535 || height > 65535 || pixels > MAX_PIXELS {
        return Err(format!(
            "-size: {width} {height}: each side must be 1 to 65535 pixels, and at most 16384² pixels in all"
        ));
    }
    Ok(())
}

/// The adapter's name where the browser tells it (Chromium does not).
fn adapter_name(info: &wgpu::AdapterInfo) -> String {
    match info.name.as_str() {
        "" => "WebGPU".to_string(),
        name => format!("WebGPU ({name})"),
    }
}

async fn gpu() -> Result<Rc<GpuRenderer>, String> {
    if let Some(gpu) = GPU.with(|cell| cell.get().cloned()) {
        return Ok(gpu);
    }
    let gpu = Rc::new(GpuRenderer::open(GpuOptions::default()).await.map_err(|e| e.to_string())?);
    GPU.with(|cell| cell.get_or_init(|| Rc::clone(&gpu)).clone());
    Ok(gpu)
}

/// The kernel's float frame (tiles awaited one by one) and its time, where measured. A
/// browser reports a device error (an invalid pipeline, memory exhausted) to its console,
/// not to the call that caused it, and the render would go on into a wrong image: error
/// scopes catch them, and the render fails with the first (the outer `Err`).
async fn render_gpu(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<Result<(Frame, Option<u64>), GpuError>, String> {
    let invalid = gpu.device().push_error_scope(wgpu::ErrorFilter::Validation);
    let memory = gpu.device().push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let internal = gpu.device().push_error_scope(wgpu::ErrorFilter::Internal);
    let rendered = render_tiles(gpu, scene, options).await;
    // Popped in the reverse order of pushing, each awaited: all of them, whatever the render did.
    let errors = [internal.pop().await, memory.pop().await, invalid.pop().await];
    match errors.into_iter().flatten().next() {
        Some(error) => Err(format!("the browser's WebGPU failed the render: {error}")),
        None => Ok(rendered),
    }
}

async fn render_tiles(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<(Frame, Option<u64>), GpuError> {
    let prepared = gpu.prepare(scene, options, false)?;
    let mut frame = Frame::new(options);
    let stats = prepared
        .render_async(|tile| {
            tile.decode_into(&mut frame);
            Ok::<(), GpuError>(())
        })
        .await?;
    Ok((frame, stats.kernel_ns))
}
