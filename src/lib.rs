//! raycaster: a GPU ray caster (wgpu compute shader) for MIT 6.837 scenes, with an f64 CPU
//! reference renderer that serves as its ground truth.
//!
//! Data flows one way: scene text → [`scene`] (parsed model) → [`gpu`] (flattened buffers and
//! the WGSL kernel) or [`cpu`] (the reference, which walks the model itself) →
//! [`render::Frame`] (float buffers) → [`image_io`] (8-bit images, TGA or PNG).
//! [`renderer::Renderer`] is the one place that chooses between the GPU and the reference
//! (`--backend gpu`, `cpu` or `auto`), above both and below every user of the library.
//! [`metrics`] says how far two renders are apart in levels and floats, [`flip`] how visible
//! the difference between two images is (NVIDIA's ꟻLIP, which `raycaster grade` judges with).
//! The command line (`src/main.rs`, `src/app/`) is a thin layer over this library.
//!
//! ```no_run
//! use raycaster::{gpu::GpuRenderer, image_io, metrics, render::RenderOptions, scene};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scene = scene::load_scene("scenes/triangles.txt".as_ref())?;
//! let options = RenderOptions::all(320, 240);
//! let gpu = GpuRenderer::new()?; // once per process; renders any number of scenes
//! let frame = gpu.render(&scene, &options)?; // float colour, normal and depth
//! image_io::write_image("out.png".as_ref(), &image_io::color_image(&frame))?;
//!
//! // The f64 reference, and what the GPU's f32 costs against it.
//! let reference = raycaster::cpu::render(&scene, &options);
//! let depth_range = metrics::depth_range_of(&reference);
//! print!("{}", metrics::errors_table(&metrics::compare_frames(&frame, &reference, depth_range)));
//! # Ok(())
//! # }
//! ```

pub mod bvh;
pub mod camera;
pub mod clock;
pub mod cpu;
pub mod flip;
pub mod gpu;
pub mod grid;
pub mod image_io;
pub mod metrics;
pub mod render;
pub mod renderer;
pub mod sampling;
pub mod scene;
