//! raycaster: a GPU ray caster (wgpu compute shader) for MIT 6.837 scenes, with an f64 CPU
//! reference renderer that serves as its ground truth.
//!
//! Data flows one way: scene text → [`scene`] (parsed model) → [`gpu`] (flattened buffers and
//! the WGSL kernel) or [`cpu`] (the reference, which walks the model itself) →
//! [`render::Frame`] (float buffers) → [`image_io`] (8-bit images, TGA or PNG).
//! [`cli`] and [`job`] are the command line's layer over that.

pub mod backend;
pub mod bench;
pub mod bvh;
pub mod camera;
pub mod cli;
pub mod cpu;
pub mod gpu;
pub mod image_io;
pub mod job;
pub mod metrics;
pub mod render;
pub mod scene;
