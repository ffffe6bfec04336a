//! One command line's work: read the scene, render, write the requested images.

use crate::backend::Backend;
use crate::cli::RenderArgs;
use crate::gpu::GpuError;
use crate::image_io::{self, ImageError};
use crate::render::RenderOptions;
use crate::scene::{self, Scene, SceneError};

/// Anything that can stop a render.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// The render options a command line implies: only the outputs it names are computed.
pub fn options_for(args: &RenderArgs) -> RenderOptions {
    RenderOptions {
        width: args.width,
        height: args.height,
        color: args.output.is_some(),
        normals: args.normals.is_some(),
        depth: args.depth.is_some(),
        shade_back: args.shade_back,
    }
}

/// Loads `args.input`, renders it with `backend` and writes every requested image (all of
/// them or, on failure, none). Returns the scene's warnings.
pub fn run(args: &RenderArgs, backend: &Backend) -> Result<Vec<String>, Error> {
    let scene = scene::load_scene(&args.input)?;
    render_scene(&scene, args, backend)?;
    Ok(scene.warnings)
}

/// Renders an already-loaded scene as `args` asks and writes the images.
pub fn render_scene(scene: &Scene, args: &RenderArgs, backend: &Backend) -> Result<(), Error> {
    let frame = backend.render(scene, &options_for(args))?;
    let mut images = Vec::new();
    if let Some(path) = &args.output {
        images.push((path.clone(), image_io::color_image(&frame)));
    }
    if let Some(path) = &args.normals {
        images.push((path.clone(), image_io::normals_image(&frame)));
    }
    if let Some(depth) = &args.depth {
        images.push((depth.path.clone(), image_io::depth_image(&frame, depth.min, depth.max)));
    }
    image_io::write_images(&images)?;
    Ok(())
}
