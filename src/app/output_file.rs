//! The image files a command line asks for, what each holds per format, and the files they
//! are streamed into: whole images (TGA, PNG, EXR) or the part files of a split render.

use crate::app::args::OutputPaths;
use crate::app::part::{PartHeader, PartWriter};
use raycaster::image_io::{
    self, ExrChannels, ExrCompression, ExrFile, FinishedImage, ImageError, ImageFile, ImageFormat, RgbRows,
};
use raycaster::render::{Frame, Output};
use std::path::PathBuf;

/// One requested image file.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputFile {
    pub output: Output,
    pub path: PathBuf,
    pub format: ImageFormat,
    /// The `-depth MIN MAX` range that maps depth to grey: for an 8-bit depth image only (an
    /// EXR holds `t` itself).
    pub depth_range: Option<(f32, f32)>,
    /// How an EXR file compresses its blocks; the pixels are the same whichever it is.
    pub exr_compression: ExrCompression,
}

/// Rows of final pixel data: 8-bit RGB made on the host or read back (perhaps packed), or
/// floats for EXR.
pub enum Pixels<'a> {
    Rgb8(Vec<u8>),
    Rows(RgbRows<'a>),
    Float(Vec<f32>),
}

impl OutputFile {
    /// The files of `-output`, `-normals` and `-depth`, in that order.
    pub fn list(files: &OutputPaths) -> Vec<OutputFile> {
        let range = files.depth_range();
        files
            .named()
            .into_iter()
            .map(|(output, path)| {
                // The command line accepts only paths with a known extension.
                let format = ImageFormat::from_path(path).unwrap_or(ImageFormat::Tga);
                let depth_range = range.filter(|_| output == Output::Depth && format != ImageFormat::Exr);
                OutputFile {
                    output,
                    path: path.to_path_buf(),
                    format,
                    depth_range,
                    exr_compression: files.exr_compression,
                }
            })
            .collect()
    }

    /// The tile's rows as this file stores them.
    pub fn pixels(&self, tile: &Frame) -> Pixels<'static> {
        match (self.format, self.output) {
            (ImageFormat::Exr, Output::Color) => Pixels::Float(image_io::color_values(tile)),
            (ImageFormat::Exr, Output::Normals) => Pixels::Float(image_io::normal_values(tile)),
            (ImageFormat::Exr, Output::Depth) => Pixels::Float(image_io::depth_values(tile)),
            (_, Output::Color) => Pixels::Rgb8(image_io::color_image(tile).into_raw()),
            (_, Output::Normals) => Pixels::Rgb8(image_io::normals_image(tile).into_raw()),
            (_, Output::Depth) => {
                let (min, max) = self.depth_range.expect("an 8-bit depth file has its range");
                Pixels::Rgb8(image_io::depth_image(tile, min, max).into_raw())
            }
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
        match self.output {
            Output::Depth => ExrChannels::Depth,
            _ => ExrChannels::Rgb,
        }
    }

    /// What the pixels of this file are, in words that differ exactly when the pixels of
    /// one scene would: the output, the format, and the depth range where it is used.
    pub fn describe(&self) -> String {
        let format = match self.format {
            ImageFormat::Tga => "tga",
            ImageFormat::Png => "png",
            ImageFormat::Exr => "exr",
        };
        // Part headers of earlier releases spell it so; stitch compares them as text.
        let output = match self.output {
            Output::Color => "color",
            Output::Normals => "normals",
            Output::Depth => "depth",
        };
        match self.depth_range {
            Some((min, max)) => format!("{output} {min} {max} {format}"),
            None => format!("{output} {format}"),
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
    /// The whole image `file`.
    pub fn image(file: &OutputFile, width: u32, height: u32) -> Result<Sink, ImageError> {
        Ok(match file.format {
            ImageFormat::Exr => {
                Sink::Exr(ExrFile::create(&file.path, width, height, file.exr_channels(), file.exr_compression)?)
            }
            _ => Sink::Image(ImageFile::create(&file.path, width, height)?),
        })
    }

    /// The part file of one band of `file`.
    pub fn part(header: PartHeader, file: &OutputFile) -> Result<Sink, ImageError> {
        Ok(Sink::Part(PartWriter::create(header, &file.path, file.pixel_bytes())?))
    }

    pub fn write(&mut self, pixels: &Pixels) -> Result<(), ImageError> {
        match (self, pixels) {
            (Sink::Image(file), Pixels::Rgb8(rgb)) => file.write_rows(rgb),
            (Sink::Image(file), Pixels::Rows(rows)) => file.write_pixels(*rows),
            (Sink::Exr(file), Pixels::Float(values)) => file.write_rows(values),
            (Sink::Part(part), Pixels::Rgb8(rgb)) => part.write(rgb),
            (Sink::Part(part), Pixels::Rows(rows)) => part.write(&rows.to_vec()),
            (Sink::Part(part), Pixels::Float(values)) => {
                part.write(&values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())
            }
            _ => unreachable!("OutputFile::pixels gives each format its own kind of pixels"),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::args::DepthArgs;

    /// The depth range belongs to an 8-bit depth file only: an EXR holds `t`, so two EXR
    /// renders with other ranges are one render.
    #[test]
    fn descriptions_hold_the_depth_range_where_it_shapes_the_pixels() {
        let files = |depth: &str| OutputPaths {
            color: Some("c.png".into()),
            normals: None,
            depth: Some(DepthArgs { min: 9.0, max: 11.5, path: depth.into() }),
            exr_compression: Default::default(),
        };
        let described = |depth| OutputFile::list(&files(depth)).iter().map(OutputFile::describe).collect::<Vec<_>>();
        assert_eq!(described("d.tga"), ["color png", "depth 9 11.5 tga"]);
        assert_eq!(described("d.exr"), ["color png", "depth exr"]);
    }
}
