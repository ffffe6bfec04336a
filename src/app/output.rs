//! The images a command line asks for, what each holds per format, and the files they are
//! streamed into: whole images (TGA, PNG, EXR) or the part files of a split render.

use crate::app::cli::DepthArgs;
use crate::app::split::{PartHeader, PartWriter};
use raycaster::image_io::{self, ExrChannels, ExrFile, FinishedImage, ImageError, ImageFile, ImageFormat};
use raycaster::render::Frame;
use std::path::{Path, PathBuf};

/// Which image an output file receives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    Color,
    Normals,
    /// The range maps depth to grey in 8-bit files; an EXR holds `t` itself and ignores it.
    Depth {
        min: f32,
        max: f32,
    },
}

/// One requested image.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    pub kind: Kind,
    pub path: PathBuf,
    pub format: ImageFormat,
}

/// The outputs of `-output`, `-normals` and `-depth`, in that order.
pub fn outputs(output: &Option<PathBuf>, normals: &Option<PathBuf>, depth: &Option<DepthArgs>) -> Vec<Output> {
    let mut list = Vec::new();
    let mut add = |kind: Kind, path: &Path| {
        // The command line accepts only paths with a known extension.
        let format = ImageFormat::from_path(path).unwrap_or(ImageFormat::Tga);
        list.push(Output { kind, path: path.to_path_buf(), format });
    };
    if let Some(path) = output {
        add(Kind::Color, path);
    }
    if let Some(path) = normals {
        add(Kind::Normals, path);
    }
    if let Some(d) = depth {
        add(Kind::Depth { min: d.min, max: d.max }, &d.path);
    }
    list
}

/// Rows of final pixel data: 8-bit RGB, or floats for EXR.
pub enum Pixels {
    Rgb8(Vec<u8>),
    Float(Vec<f32>),
}

impl Output {
    /// The tile's rows as this output stores them.
    pub fn pixels(&self, tile: &Frame) -> Pixels {
        match (self.format, self.kind) {
            (ImageFormat::Exr, Kind::Color) => Pixels::Float(image_io::color_values(tile)),
            (ImageFormat::Exr, Kind::Normals) => Pixels::Float(image_io::normal_values(tile)),
            (ImageFormat::Exr, Kind::Depth { .. }) => Pixels::Float(image_io::depth_values(tile)),
            (_, Kind::Color) => Pixels::Rgb8(image_io::color_image(tile).into_raw()),
            (_, Kind::Normals) => Pixels::Rgb8(image_io::normals_image(tile).into_raw()),
            (_, Kind::Depth { min, max }) => Pixels::Rgb8(image_io::depth_image(tile, min, max).into_raw()),
        }
    }

    /// Bytes a pixel takes in a part file.
    pub fn pixel_bytes(&self) -> usize {
        match self.format {
            ImageFormat::Exr => self.exr_channels().count() * 4,
            _ => 3,
        }
    }

    fn exr_channels(&self) -> ExrChannels {
        match self.kind {
            Kind::Depth { .. } => ExrChannels::Depth,
            _ => ExrChannels::Rgb,
        }
    }

    /// What the pixels of this output are, in words that differ exactly when the pixels of
    /// one scene would: the kind, the format, and the depth range where it is used.
    pub fn describe(&self) -> String {
        let format = match self.format {
            ImageFormat::Tga => "tga",
            ImageFormat::Png => "png",
            ImageFormat::Exr => "exr",
        };
        match (self.kind, self.format) {
            (Kind::Color, _) => format!("color {format}"),
            (Kind::Normals, _) => format!("normals {format}"),
            (Kind::Depth { .. }, ImageFormat::Exr) => format!("depth {format}"),
            (Kind::Depth { min, max }, _) => format!("depth {min} {max} {format}"),
        }
    }
}

/// Where an output's rows go.
pub enum Sink {
    Image(ImageFile),
    Exr(ExrFile),
    Part(PartWriter),
}

impl Sink {
    /// The whole image file of `output`.
    pub fn image(output: &Output, width: u32, height: u32) -> Result<Sink, ImageError> {
        Ok(match output.format {
            ImageFormat::Exr => Sink::Exr(ExrFile::create(&output.path, width, height, output.exr_channels())?),
            _ => Sink::Image(ImageFile::create(&output.path, width, height)?),
        })
    }

    /// The part file of one band of `output`.
    pub fn part(header: PartHeader, output: &Output) -> Result<Sink, ImageError> {
        Ok(Sink::Part(PartWriter::create(header, output)?))
    }

    pub fn write(&mut self, pixels: &Pixels) -> Result<(), ImageError> {
        match (self, pixels) {
            (Sink::Image(file), Pixels::Rgb8(rgb)) => file.write_rows(rgb),
            (Sink::Exr(file), Pixels::Float(values)) => file.write_rows(values),
            (Sink::Part(part), Pixels::Rgb8(rgb)) => part.write(rgb),
            (Sink::Part(part), Pixels::Float(values)) => {
                part.write(&values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())
            }
            _ => unreachable!("Output::pixels gives each format its own kind of pixels"),
        }
    }

    /// Completes the file; it is still temporary until [`image_io::persist_all`].
    pub fn finish(self) -> Result<FinishedImage, ImageError> {
        match self {
            Sink::Image(file) => file.finish(),
            Sink::Exr(file) => file.finish(),
            Sink::Part(part) => part.finish(),
        }
    }
}
