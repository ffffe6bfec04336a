//! Choosing and calling a renderer: the GPU kernel or the f64 CPU reference.

use crate::app::args::BackendChoice;
use raycaster::cpu::Reference;
use raycaster::gpu::ray_tree::RenderRays;
use raycaster::gpu::{GpuError, GpuRenderer, RenderStats};
use raycaster::image_io;
use raycaster::render::{row_tiles, Frame, Output, RenderOptions};
use raycaster::scene::Scene;

/// About how many pixels the CPU reference renders per tile: enough rows to keep every core
/// busy, few enough to bound memory and to move a progress bar every second or so.
const CPU_TILE_PIXELS: u32 = 1 << 18;

/// A ready renderer.
pub enum Backend {
    /// The GPU kernel; with `fallback` (`--backend auto`), scenes its f32 kernel cannot
    /// render faithfully ([`raycaster::gpu::precision`]) or does not shade yet
    /// ([`raycaster::gpu::unsupported`]) go to the CPU reference instead.
    Gpu(Box<GpuRenderer>, Fallback),
    Cpu,
}

/// Whether a GPU backend hands scenes outside its f32 range to the reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fallback {
    /// `--backend gpu`: refuse them.
    Refuse,
    /// `--backend auto`: render them with the f64 reference, with a notice.
    Reference,
}

/// The reference, for the jobs `auto` hands it from an open GPU ([`Backend::for_scene`]).
static REFERENCE: Backend = Backend::Cpu;

impl Backend {
    /// Opens the backend `choice` asks for. With `Auto`, a missing GPU falls back to the CPU
    /// reference and the returned notice says so (for stderr).
    pub fn open(choice: BackendChoice) -> Result<(Backend, Option<String>), GpuError> {
        match choice {
            BackendChoice::Cpu => Ok((Backend::Cpu, None)),
            BackendChoice::Gpu => Ok((Backend::Gpu(Box::new(GpuRenderer::new()?), Fallback::Refuse), None)),
            BackendChoice::Auto => match GpuRenderer::new() {
                Ok(gpu) => Ok((Backend::Gpu(Box::new(gpu), Fallback::Reference), None)),
                Err(e) => Ok((Backend::Cpu, Some(format!("{e}; rendering with the CPU reference instead")))),
            },
        }
    }

    /// The backend that renders `scene`: this one, or with `auto` the reference where it
    /// traces the scene quicker than the open GPU ([`reference_traces_quicker`]), with the
    /// reason in words.
    pub fn for_scene(&self, scene: &Scene, options: &RenderOptions) -> (&Backend, Option<&'static str>) {
        match self {
            Backend::Gpu(gpu, Fallback::Reference) => match reference_traces_quicker(gpu, scene, options) {
                Some(why) => (&REFERENCE, Some(why)),
                None => (self, None),
            },
            _ => (self, None),
        }
    }

    /// The f64 reference.
    pub fn reference() -> &'static Backend {
        &REFERENCE
    }

    /// What renders, in words: the adapter, or the reference and its threads.
    pub fn describe(&self) -> String {
        match self {
            Backend::Gpu(gpu, _) => {
                let info = gpu.adapter_info();
                format!("gpu, {} ({:?}, {:?})", info.name, info.backend, info.device_type)
            }
            Backend::Cpu => match rayon::current_num_threads() {
                1 => "cpu, the f64 reference on 1 thread".to_string(),
                n => format!("cpu, the f64 reference on {n} threads"),
            },
        }
    }

    /// Renders image rows `first .. first + rows` (the whole image, or one band of a split
    /// render) in tiles of full rows, top first, handing each tile and its first image row
    /// to `on_tile`; see [`GpuRenderer::render_band`]. Returns the statistics, and a notice
    /// when `auto` handed the scene to the reference.
    pub fn render_band<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<(RenderStats, Option<String>), E> {
        match self {
            Backend::Gpu(gpu, fallback) => or_reference(
                *fallback,
                &mut on_tile,
                |on_tile| gpu.render_band(scene, options, first, rows, |r, t| on_tile(r, t).map_err(Attempt::Tile)),
                |on_tile| reference_band(scene, options, (first, rows), on_tile),
            ),
            Backend::Cpu => Ok((reference_band(scene, options, (first, rows), on_tile)?, None)),
        }
    }

    /// Renders the 8-bit images `options` asks for (the depth visualisation over
    /// `depth_range`) for image rows `first .. first + rows` (the whole image, or one band of
    /// a split render), in tiles of full rows, top first. On the GPU the kernel quantises,
    /// so only the bytes of the images cross from the device.
    pub fn render_images<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        depth_range: (f32, f32),
        (first, rows): (u32, u32),
        mut on_tile: impl FnMut(u32, ImageRows) -> Result<(), E>,
    ) -> Result<(RenderStats, Option<String>), E> {
        let (min, max) = depth_range;
        let wants = |output| options.outputs.contains(output);
        let from_frame = |frame: &Frame| ImageRows {
            rows: frame.height,
            color: wants(Output::Color).then(|| image_io::color_image(frame).into_raw()),
            normals: wants(Output::Normals).then(|| image_io::normals_image(frame).into_raw()),
            depth: wants(Output::Depth).then(|| image_io::depth_image(frame, min, max).into_raw()),
        };
        match self {
            Backend::Gpu(gpu, fallback) => or_reference(
                *fallback,
                &mut on_tile,
                |on_tile| {
                    gpu.prepare(scene, options, true)?.render_band(first, rows, |tile| {
                        let rows = ImageRows {
                            rows: tile.rows,
                            color: wants(Output::Color).then(|| tile.color_rgb()),
                            normals: wants(Output::Normals).then(|| tile.normals_rgb()),
                            depth: wants(Output::Depth).then(|| tile.depth_rgb(min, max)),
                        };
                        on_tile(tile.first_row, rows).map_err(Attempt::Tile)
                    })
                },
                |on_tile| reference_band(scene, options, (first, rows), |row, frame| on_tile(row, from_frame(&frame))),
            ),
            Backend::Cpu => {
                let stats =
                    reference_band(scene, options, (first, rows), |row, frame| on_tile(row, from_frame(&frame)))?;
                Ok((stats, None))
            }
        }
    }
}

/// The GPU's render, or with [`Fallback::Reference`] and a scene the GPU refuses (its f32
/// range, or shading it does not implement), the reference's, with a notice naming why. The GPU refuses before its
/// first tile, so nothing has reached `on_tile` yet and the reference starts from the top.
fn or_reference<T, E: From<GpuError>>(
    fallback: Fallback,
    on_tile: &mut T,
    gpu: impl FnOnce(&mut T) -> Result<RenderStats, Attempt<E>>,
    reference: impl FnOnce(&mut T) -> Result<RenderStats, E>,
) -> Result<(RenderStats, Option<String>), E> {
    match gpu(on_tile) {
        Ok(stats) => Ok((stats, None)),
        Err(Attempt::Tile(e)) => Err(e),
        Err(Attempt::Gpu(e)) if fallback == Fallback::Reference && e.reference_renders_it() => {
            let reason = match e {
                GpuError::Precision(e) => e.to_string(),
                GpuError::Unsupported(e) => e.to_string(),
                GpuError::NonFinite(what) => what,
                other => other.to_string(),
            };
            let notice = format!("{reason}; rendering with the f64 CPU reference instead");
            Ok((reference(on_tile)?, Some(notice)))
        }
        Err(Attempt::Gpu(e)) => Err(e.into()),
    }
}

/// A GPU render's failure, told apart from the caller's own.
enum Attempt<E> {
    Gpu(GpuError),
    Tile(E),
}

impl<E> From<GpuError> for Attempt<E> {
    fn from(e: GpuError) -> Self {
        Attempt::Gpu(e)
    }
}

/// The f64 reference over image rows `first .. first + rows`, in tiles.
fn reference_band<E>(
    scene: &Scene,
    options: &RenderOptions,
    (first, rows): (u32, u32),
    mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
) -> Result<RenderStats, E> {
    let reference = Reference::new(scene, options);
    let mut stats = RenderStats::default();
    // Samples are kept until the tile is filtered: fewer rows per tile the more there are.
    let samples = options.sampling.map_or(1, |s| s.count());
    for (offset, rows) in row_tiles(rows, CPU_TILE_PIXELS / options.width / samples) {
        let first_row = first + offset;
        on_tile(first_row, reference.rows(first_row, rows))?;
        stats.tiles += 1;
    }
    stats.counted = Some(reference.stats());
    stats.grid_bounds = reference.grid().map(|g| g.grid.bounds).filter(|b| !b.is_empty());
    Ok(stats)
}

/// Ray/primitive pairs up to which `auto` renders with the f64 reference instead of opening
/// the GPU: the reference tests about 150 M pairs a second on this project's 2-core machine
/// (scene2_10's 40 000 rays × 1000 triangles in 270 ms), so this many cost it about 13 ms,
/// while opening Vulkan and compiling a kernel costs 60–70 ms on lavapipe (scene2_01 at 200²:
/// 7.7 ms wall with the reference, 81 ms with the GPU).
pub const REFERENCE_QUICKER_BELOW: u64 = 2_000_000;

/// Whether `auto` should render `scene` with the reference without opening the GPU: a job
/// so small that the device's start-up would dominate. Counts every primitive for every
/// pixel, an upper bound of the reference's work; through an explicit `-grid nx ny nz`, at
/// most `nx + ny + nz` of them, the cells a ray can cross, which the course sizes to hold a
/// primitive or so each (scene6_04b's 200 triangles at 200 × 200 through 10 × 10 × 7
/// cells: 0.02 s on the reference, 0.30 s on lavapipe).
pub fn reference_is_quicker(scene: &Scene, options: &RenderOptions) -> bool {
    let primitives = scene.primitive_counts().total() as u64;
    let per_ray = options.grid.map_or(primitives, |g| primitives.min(g.nx as u64 + g.ny as u64 + g.nz as u64));
    let samples = options.sampling.map_or(1, |s| s.count()) as u64;
    options.pixel_count() as u64 * samples * per_ray <= REFERENCE_QUICKER_BELOW
}

/// Primitives (each triangle of a mesh counted) up to which `auto` traces a scene that needs
/// secondary rays with the reference rather than with a CPU Vulkan device (lavapipe; WARP).
/// There the kernel's ray trees run no faster than the reference, which tests every
/// primitive, on scenes this small, and compiling a tree kernel costs about a second more.
/// Measured on the project's 2-core machine (lavapipe, wall time of the whole process, median
/// of 3; docs/SPEC.md §6): assignment 4's scenes of 3 to 112 primitives are 1.4 to 13 times
/// quicker on the reference at 200 × 200, and 1.5 to 3 times at 800 × 800 but the gem
/// (scene4_14, 112 primitives, 0.8 to 1.7); scene6_07's plane and a bunny of 1000 triangles
/// with shadows 2.5 times quicker on the GPU at 200 × 200 (0.39 s against 1.0 s), of 40 000
/// triangles 180 times. A real GPU always gets the scene.
pub const CPU_DEVICE_TREE_PRIMITIVES: usize = 128;

/// Why the reference traces `scene` quicker than `gpu`, if it does: on a CPU device, a
/// scene with secondary rays and few primitives (see [`CPU_DEVICE_TREE_PRIMITIVES`]), or
/// walked through an explicit `-grid`. The reference then walks the same grid, and every
/// line of assignment 6 that casts secondary rays through a grid was quicker on it
/// (lavapipe, wall time of the whole process, loaded machine): 3 to 10 times at the
/// course's 200 × 200 (scene6_07, 40 000 triangles with shadows: 0.14 s against 0.60 s;
/// scene6_18's logo, 5 bounces: 0.98 s against 5.3 s), 1.7 to 2.3 times at 800 to 1000
/// pixels a side (scene6_07 at 1000²: 5.1 s against 8.7 s).
pub fn reference_traces_quicker(gpu: &GpuRenderer, scene: &Scene, options: &RenderOptions) -> Option<&'static str> {
    let cpu_device = gpu.adapter_info().device_type == wgpu::DeviceType::Cpu;
    if !cpu_device || !RenderRays::new(scene, options).secondary() {
        None
    } else if scene.primitive_counts().total() <= CPU_DEVICE_TREE_PRIMITIVES {
        Some("auto: ray trees of a scene this small are quicker here than on a CPU Vulkan device")
    } else if options.grid.is_some() {
        Some("auto: ray trees through a -grid are quicker here on the reference than on a CPU Vulkan device")
    } else {
        None
    }
}

/// One tile's rows of each 8-bit image asked for, RGB, top row first.
pub struct ImageRows {
    /// How many rows the tile has.
    pub rows: u32,
    pub color: Option<Vec<u8>>,
    pub normals: Option<Vec<u8>>,
    pub depth: Option<Vec<u8>>,
}

impl ImageRows {
    /// The rows of `output`'s image, once (each output is asked for at most once).
    pub fn take(&mut self, output: Output) -> Vec<u8> {
        let rows = match output {
            Output::Color => &mut self.color,
            Output::Normals => &mut self.normals,
            Output::Depth => &mut self.depth,
        };
        rows.take().expect("the render computed every output asked for")
    }
}
