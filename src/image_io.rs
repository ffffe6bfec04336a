//! From float frames to 8-bit images (SPEC §5), and image files written atomically.
//!
//! Every channel is clamped to [0, 1] and stored as `floor(255·v)`: truncation, as the
//! course's own images are made.

use crate::render::Frame;
use image::codecs::png::PngEncoder;
use image::codecs::tga::TgaEncoder;
use image::{ExtendedColorType, ImageEncoder, RgbImage};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// SPEC §5: `floor(255·clamp(v, 0, 1))`. NaN becomes 0.
pub fn quantize(v: f32) -> u8 {
    if v.is_nan() {
        return 0;
    }
    (255.0 * v.clamp(0.0, 1.0)).floor() as u8
}

/// The diffuse-shaded image (`-output`). The frame must hold colour.
pub fn color_image(frame: &Frame) -> RgbImage {
    image_from(frame, |k| frame.color[k].map(quantize))
}

/// The normal visualisation (`-normals`): `|N|` per channel, black where nothing was hit.
pub fn normals_image(frame: &Frame) -> RgbImage {
    image_from(frame, |k| if frame.hit[k] { frame.normal[k].map(|c| quantize(c.abs())) } else { [0; 3] })
}

/// The depth visualisation (`-depth MIN MAX`): grey `(MAX − t)/(MAX − MIN)`, near = white,
/// black where nothing was hit.
pub fn depth_image(frame: &Frame, min: f32, max: f32) -> RgbImage {
    image_from(frame, |k| {
        if frame.hit[k] {
            // f64 so that MIN and MAX far from zero do not lose the depth's low digits.
            let v = (max as f64 - frame.depth[k] as f64) / (max as f64 - min as f64);
            [quantize(v as f32); 3]
        } else {
            [0; 3]
        }
    })
}

fn image_from(frame: &Frame, pixel: impl Fn(usize) -> [u8; 3]) -> RgbImage {
    let mut data = Vec::with_capacity(frame.hit.len() * 3);
    for k in 0..frame.hit.len() {
        data.extend_from_slice(&pixel(k));
    }
    RgbImage::from_raw(frame.width, frame.height, data).expect("buffer sized from the frame")
}

/// The image file formats we write, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// Uncompressed 24-bit true-colour TGA (type 2), as the course writes it.
    Tga,
    Png,
}

impl ImageFormat {
    /// The format for `path`'s extension (case-insensitive), or `None` if unsupported.
    pub fn from_path(path: &Path) -> Option<ImageFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "tga" => Some(ImageFormat::Tga),
            "png" => Some(ImageFormat::Png),
            _ => None,
        }
    }
}

/// An error writing an image, naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", path.display())]
pub struct ImageError {
    pub path: PathBuf,
    pub message: String,
}

/// Writes every `(path, image)` pair, or none of them: each is encoded into a temporary file
/// beside its destination, and only when all are complete are they renamed into place.
pub fn write_images(images: &[(PathBuf, RgbImage)]) -> Result<(), ImageError> {
    let mut pending = Vec::with_capacity(images.len());
    for (path, image) in images {
        pending.push((path, encode_to_temp(path, image)?));
    }
    for (path, temp) in pending {
        temp.persist(path).map_err(|e| ImageError { path: path.clone(), message: e.error.to_string() })?;
    }
    Ok(())
}

/// Writes one image atomically (see [`write_images`]).
pub fn write_image(path: &Path, image: &RgbImage) -> Result<(), ImageError> {
    write_images(&[(path.to_path_buf(), image.clone())])
}

fn encode_to_temp(path: &Path, image: &RgbImage) -> Result<tempfile::NamedTempFile, ImageError> {
    let fail = |message: String| ImageError { path: path.to_path_buf(), message };
    let format = ImageFormat::from_path(path)
        .ok_or_else(|| fail("unsupported image format (use a .tga or .png file name)".into()))?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let temp = tempfile::Builder::new()
        .prefix(".raycaster-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| fail(format!("cannot create a file in {}: {e}", dir.display())))?;
    let mut out = BufWriter::new(temp.as_file());
    let (w, h) = image.dimensions();
    let result = match format {
        ImageFormat::Tga => {
            TgaEncoder::new(&mut out).disable_rle().write_image(image.as_raw(), w, h, ExtendedColorType::Rgb8)
        }
        ImageFormat::Png => PngEncoder::new(&mut out).write_image(image.as_raw(), w, h, ExtendedColorType::Rgb8),
    };
    result.map_err(|e| fail(e.to_string()))?;
    out.flush().map_err(|e| fail(e.to_string()))?;
    drop(out);
    make_readable(&temp).map_err(|e| fail(e.to_string()))?;
    Ok(temp)
}

/// Temporary files are private (0600); an image is an ordinary file (0644).
#[cfg(unix)]
fn make_readable(temp: &tempfile::NamedTempFile) -> std::io::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    temp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644))
}

#[cfg(not(unix))]
fn make_readable(_: &tempfile::NamedTempFile) -> std::io::Result<()> {
    Ok(())
}

/// Reads a TGA or PNG image as 8-bit RGB (used by tests and `compare`).
pub fn read_image(path: &Path) -> Result<RgbImage, ImageError> {
    image::open(path).map(|i| i.to_rgb8()).map_err(|e| ImageError { path: path.to_path_buf(), message: e.to_string() })
}
