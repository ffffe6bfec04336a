//! The one place that chooses who renders: the GPU kernel ([`crate::gpu`]) or the f64 CPU
//! reference ([`crate::cpu`]). The command line, the live window, the web page and the Python
//! package render through a [`Renderer`]; none of them re-implements the fallback.
//!
//! `--backend auto` ([`BackendChoice::Auto`]) renders on the GPU, and gives the reference
//! what the GPU would render unfaithfully or slower: a scene out of the f32 kernel's range or
//! with shading it does not implement (the GPU refuses it before its first tile,
//! [`fallback_notice`]), a job too small to pay for the device's start-up
//! ([`auto::reference_is_quicker`]), and small ray trees on a CPU Vulkan device
//! ([`auto::reference_traces_quicker`]). Each hand-over comes with a notice naming why.
//!
//! ```no_run
//! use raycaster::renderer::{BackendChoice, Renderer};
//! use raycaster::{render::RenderOptions, scene};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scene = scene::load_scene("scenes/triangles.txt".as_ref())?;
//! let options = RenderOptions::all(320, 240);
//! let (renderer, notice) = Renderer::open_for(BackendChoice::Auto, &scene, &options)?;
//! let rendered = renderer.render(&scene, &options)?;
//! println!("{} ({:?})", rendered.backend, notice.or(rendered.notice));
//! # Ok(())
//! # }
//! ```

pub mod auto;
#[cfg(not(target_arch = "wasm32"))]
mod bands;

use crate::gpu::{GpuError, GpuRenderer};
use crate::image_io::RgbRows;
use crate::render::{Frame, Output, RenderStats};
#[cfg(not(target_arch = "wasm32"))]
use crate::{render::RenderOptions, scene::Scene};
#[cfg(not(target_arch = "wasm32"))]
use bands::{or_reference, reference_band, Attempt};

/// Which renderer a user asks for (`--backend`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// The GPU; a scene it cannot render faithfully is refused.
    Gpu,
    /// The f64 reference.
    Cpu,
    /// The GPU, and the reference for what the GPU would render unfaithfully or slower.
    #[default]
    Auto,
}

impl BackendChoice {
    pub const ALL: [BackendChoice; 3] = [BackendChoice::Gpu, BackendChoice::Cpu, BackendChoice::Auto];

    pub fn name(self) -> &'static str {
        match self {
            BackendChoice::Gpu => "gpu",
            BackendChoice::Cpu => "cpu",
            BackendChoice::Auto => "auto",
        }
    }
}

/// A ready renderer.
pub enum Renderer {
    /// The GPU kernel; with [`Fallback::Reference`] (`auto`), scenes its f32 kernel cannot
    /// render faithfully ([`crate::gpu::precision`]) or does not shade yet
    /// ([`crate::gpu::unsupported`]) go to the CPU reference instead.
    Gpu(Box<GpuRenderer>, Fallback),
    Cpu,
}

/// Whether a GPU renderer hands scenes it refuses to the reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fallback {
    /// `--backend gpu`: refuse them.
    Refuse,
    /// `--backend auto`: render them with the f64 reference, with a notice.
    Reference,
}

/// The reference, for the jobs `auto` hands it from an open GPU ([`Renderer::for_scene`]).
/// (Native only: wgpu's WebGPU device is not `Sync`, and the page calls no blocking render.)
#[cfg(not(target_arch = "wasm32"))]
static REFERENCE: Renderer = Renderer::Cpu;

/// A whole frame and how it was rendered ([`Renderer::render`]).
pub struct Rendered {
    pub frame: Frame,
    pub stats: RenderStats,
    /// Who rendered, in words ([`Renderer::describe`]).
    pub backend: String,
    /// Why `auto` rendered with the reference, when it did.
    pub notice: Option<String>,
}

impl Renderer {
    /// Opens the renderer `choice` asks for. With `Auto`, a missing GPU falls back to the CPU
    /// reference and the returned notice says so; a setting the GPU refuses is an error.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn open(choice: BackendChoice) -> Result<(Renderer, Option<String>), GpuError> {
        match choice {
            BackendChoice::Cpu => Ok((Renderer::Cpu, None)),
            BackendChoice::Gpu => Ok((Renderer::on_gpu(GpuRenderer::new()?, choice), None)),
            BackendChoice::Auto => match GpuRenderer::new() {
                Ok(gpu) => Ok((Renderer::on_gpu(gpu, choice), None)),
                Err(e @ GpuError::Setting(_)) => Err(e),
                Err(e) => Ok((Renderer::Cpu, Some(format!("{e}; rendering with the CPU reference instead")))),
            },
        }
    }

    /// [`Renderer::open`] for one job known in advance: with `Auto`, a job so small that the
    /// device's start-up would dominate ([`auto::reference_is_quicker`]) gets the reference
    /// without opening the GPU at all.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn open_for(
        choice: BackendChoice,
        scene: &Scene,
        options: &RenderOptions,
    ) -> Result<(Renderer, Option<String>), GpuError> {
        match choice == BackendChoice::Auto && auto::reference_is_quicker(scene, options) {
            true => Ok((Renderer::Cpu, None)),
            false => Renderer::open(choice),
        }
    }

    /// A renderer on a GPU already open (the live window's device): `Cpu` leaves the device
    /// to present only.
    pub fn on_gpu(gpu: GpuRenderer, choice: BackendChoice) -> Renderer {
        match choice {
            BackendChoice::Gpu => Renderer::Gpu(Box::new(gpu), Fallback::Refuse),
            BackendChoice::Auto => Renderer::Gpu(Box::new(gpu), Fallback::Reference),
            BackendChoice::Cpu => Renderer::Cpu,
        }
    }

    /// The renderer that renders `scene`: this one, or with `auto` the reference where it
    /// traces the scene quicker than the open GPU ([`auto::reference_traces_quicker`]), with
    /// the reason in words.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn for_scene(&self, scene: &Scene, options: &RenderOptions) -> (&Renderer, Option<&'static str>) {
        match self {
            Renderer::Gpu(gpu, Fallback::Reference) => match auto::reference_traces_quicker(gpu, scene, options) {
                Some(why) => (&REFERENCE, Some(why)),
                None => (self, None),
            },
            _ => (self, None),
        }
    }

    /// The f64 reference.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn reference() -> &'static Renderer {
        &REFERENCE
    }

    /// The GPU, where this renderer has one.
    pub fn gpu(&self) -> Option<&GpuRenderer> {
        match self {
            Renderer::Gpu(gpu, _) => Some(gpu),
            Renderer::Cpu => None,
        }
    }

    /// What renders, in words: the adapter, or the reference and its threads.
    pub fn describe(&self) -> String {
        match self {
            Renderer::Gpu(gpu, _) => {
                let info = gpu.adapter_info();
                format!("gpu, {} ({:?}, {:?})", info.name, info.backend, info.device_type)
            }
            Renderer::Cpu => match rayon::current_num_threads() {
                1 => "cpu, the f64 reference on 1 thread".to_string(),
                n => format!("cpu, the f64 reference on {n} threads"),
            },
        }
    }

    /// How one thread of a batch compiles kernels ahead for this renderer
    /// ([`GpuRenderer::ahead`]); `None` where it renders with the reference only.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn ahead(&self) -> Option<crate::gpu::Ahead<'_>> {
        self.gpu().map(GpuRenderer::ahead)
    }

    /// Compiles, with `ahead` (from [`Renderer::ahead`]), the GPU kernel of a render to
    /// come, where this renderer would render it on the GPU ([`Renderer::for_scene`];
    /// `packed`: 8-bit images, else floats), so that a batch compiles the next lines'
    /// kernels while it renders this one. What the GPU would refuse is left for the render
    /// to refuse (or hand over).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn precompile(&self, ahead: &crate::gpu::Ahead<'_>, scene: &Scene, options: &RenderOptions, packed: bool) {
        if let (Renderer::Gpu(..), None) = (self, self.for_scene(scene, options).1) {
            let _ = ahead.precompile(scene, options, packed);
        }
    }

    /// Renders `scene` whole, into float buffers, with whoever [`Renderer::for_scene`] picks.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render(&self, scene: &Scene, options: &RenderOptions) -> Result<Rendered, GpuError> {
        self.render_or_stop(scene, options, || Ok(()))
    }

    /// [`Renderer::render`], asking `go_on` after each tile whether to go on: its error stops
    /// the render there and is returned (the Python package's Ctrl-C, seen between tiles).
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_or_stop<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        mut go_on: impl FnMut() -> Result<(), E>,
    ) -> Result<Rendered, E> {
        let (renderer, handed_over) = self.for_scene(scene, options);
        let mut frame = Frame::new(options);
        let (stats, notice) = renderer.render_into(scene, options, &mut frame, &mut go_on)?;
        let backend = match &notice {
            Some(_) => REFERENCE.describe(),
            None => renderer.describe(),
        };
        Ok(Rendered { frame, stats, backend, notice: notice.or(handed_over.map(str::to_string)) })
    }

    /// Renders the whole image into `frame`, asking `go_on` after each tile: on the GPU each
    /// tile is decoded straight into its rows ([`GpuRenderer::render_into`]), with no frame
    /// of its own to make and copy; the reference's tiles are pasted.
    #[cfg(not(target_arch = "wasm32"))]
    fn render_into<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        frame: &mut Frame,
        go_on: &mut impl FnMut() -> Result<(), E>,
    ) -> Result<(RenderStats, Option<String>), E> {
        let mut into = (frame, go_on);
        let reference = |(frame, go_on): &mut (&mut Frame, &mut _)| {
            reference_band(scene, options, (0, options.height), |first_row, tile| {
                frame.paste(first_row, &tile);
                go_on()
            })
        };
        match self {
            Renderer::Gpu(gpu, fallback) => or_reference(
                *fallback,
                &mut into,
                |(frame, go_on)| gpu.render_into(scene, options, frame, || go_on().map_err(Attempt::Tile)),
                reference,
            ),
            Renderer::Cpu => Ok((reference(&mut into)?, None)),
        }
    }

    /// Renders image rows `first .. first + rows` (the whole image, or one band of a split
    /// render) in tiles of full rows, top first, handing each tile and its first image row
    /// to `on_tile`; see [`GpuRenderer::render_band`]. Returns the statistics, and a notice
    /// when `auto` handed the scene to the reference.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_band<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<(RenderStats, Option<String>), E> {
        match self {
            Renderer::Gpu(gpu, fallback) => or_reference(
                *fallback,
                &mut on_tile,
                |on_tile| gpu.render_band(scene, options, first, rows, |r, t| on_tile(r, t).map_err(Attempt::Tile)),
                |on_tile| reference_band(scene, options, (first, rows), on_tile),
            ),
            Renderer::Cpu => Ok((reference_band(scene, options, (first, rows), on_tile)?, None)),
        }
    }

    /// Renders the 8-bit images `options` asks for, and its depth as `depth` says, for image
    /// rows `first .. first + rows` (the whole image, or one band of a split render), in
    /// tiles of full rows, top first. On the GPU the kernel quantises the images and hands
    /// over the distances' bits, so only those words cross from the device.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_images<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        depth: DepthAs,
        (first, rows): (u32, u32),
        mut on_tile: impl FnMut(u32, ImageRows<'_>) -> Result<(), E>,
    ) -> Result<(RenderStats, Option<String>), E> {
        use crate::image_io;
        let wants = |output| options.outputs.contains(output);
        // The depth's grey range, or whether its distances are handed over, where it is asked for.
        let (grey, distances) = match depth {
            _ if !wants(Output::Depth) => (None, false),
            DepthAs::Grey { min, max } => (Some((min, max)), false),
            DepthAs::Distance => (None, true),
        };
        let from_frame = |frame: &Frame| ImageRows {
            rows: frame.height,
            color: wants(Output::Color).then(|| Rows8::Made(image_io::color_image(frame).into_raw())),
            normals: wants(Output::Normals).then(|| Rows8::Made(image_io::normals_image(frame).into_raw())),
            depth: grey.map(|(min, max)| Rows8::Made(image_io::depth_image(frame, min, max).into_raw())),
            distances: distances.then(|| image_io::depth_values(frame)),
        };
        match self {
            Renderer::Gpu(gpu, fallback) => or_reference(
                *fallback,
                &mut on_tile,
                |on_tile| {
                    gpu.prepare(scene, options, true)?.render_band(first, rows, |tile| {
                        let rows = ImageRows {
                            rows: tile.rows,
                            color: wants(Output::Color).then(|| Rows8::Read(tile.color_rows())),
                            normals: wants(Output::Normals).then(|| Rows8::Read(tile.normals_rows())),
                            depth: grey.map(|(min, max)| Rows8::Made(tile.depth_rgb(min, max))),
                            distances: distances.then(|| tile.depth_values()),
                        };
                        on_tile(tile.first_row, rows).map_err(Attempt::Tile)
                    })
                },
                |on_tile| reference_band(scene, options, (first, rows), |row, frame| on_tile(row, from_frame(&frame))),
            ),
            Renderer::Cpu => {
                let stats =
                    reference_band(scene, options, (first, rows), |row, frame| on_tile(row, from_frame(&frame)))?;
                Ok((stats, None))
            }
        }
    }
}

/// Where `auto` gives a scene the GPU refused to the reference (out of the kernel's f32
/// range, shading it does not implement, a value it cannot upload), the notice that says
/// why; `None` for a failure the reference cannot mend (no device, a lost device).
pub fn fallback_notice(e: &GpuError) -> Option<String> {
    let reason = match e {
        GpuError::Precision(e) => e.to_string(),
        GpuError::Unsupported(e) => e.to_string(),
        GpuError::NonFinite(what) => what.clone(),
        _ => return None,
    };
    Some(format!("{reason}; rendering with the f64 CPU reference instead"))
}

/// How [`Renderer::render_images`] hands over the depth: as the grey levels of an 8-bit image
/// over `min ..= max` (docs/SPEC.md §5), or as the distances themselves (an EXR file).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthAs {
    Grey { min: f32, max: f32 },
    Distance,
}

/// One tile's rows of each 8-bit image asked for, top row first: as the kernel packed them
/// where the GPU rendered them (a writer reorders them into its file at once), else as
/// bytes quantised on the host; and the depth as [`DepthAs`] asked.
pub struct ImageRows<'a> {
    /// How many rows the tile has.
    pub rows: u32,
    pub color: Option<Rows8<'a>>,
    pub normals: Option<Rows8<'a>>,
    /// The depth's grey levels ([`DepthAs::Grey`]).
    pub depth: Option<Rows8<'a>>,
    /// The hit distances `t`, +∞ where nothing was hit ([`DepthAs::Distance`]).
    pub distances: Option<Vec<f32>>,
}

/// An 8-bit image's rows, read back from the device or made on the host.
pub enum Rows8<'a> {
    Read(RgbRows<'a>),
    Made(Vec<u8>),
}

impl ImageRows<'_> {
    /// The rows of `output`'s image.
    ///
    /// # Panics
    /// If the render did not compute `output`.
    pub fn pixels(&self, output: Output) -> RgbRows<'_> {
        let rows = match output {
            Output::Color => &self.color,
            Output::Normals => &self.normals,
            Output::Depth => &self.depth,
        };
        match rows.as_ref().expect("the render computed every output asked for") {
            Rows8::Read(read) => *read,
            Rows8::Made(bytes) => RgbRows::Bytes(bytes),
        }
    }
}
