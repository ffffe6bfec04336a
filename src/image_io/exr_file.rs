//! OpenEXR files of 32-bit floats, written block by block as rows arrive.

use super::in_order::InOrder;
use super::{temp_beside, FinishedImage, ImageError, LiveTemp};
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The channels of an EXR file (32-bit float each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrChannels {
    /// `R`, `G`, `B`: a colour, or a normal's x, y, z (so any viewer shows it).
    Rgb,
    /// `Z`, OpenEXR's standard name for depth.
    Depth,
}

impl ExrChannels {
    /// Floats per pixel.
    pub fn count(self) -> usize {
        match self {
            ExrChannels::Rgb => 3,
            ExrChannels::Depth => 1,
        }
    }
}

/// How the blocks of an EXR file are compressed (`--exr-compression`): OpenEXR's lossless
/// methods, by the names OpenEXR gives them. Each keeps every float bit for bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExrCompression {
    /// Uncompressed, one row a block.
    None,
    /// Run-length encoding, one row a block.
    Rle,
    /// Deflate (zlib), one row a block.
    Zips,
    /// Deflate (zlib) over blocks of 16 rows: the default, smaller than `zips` for the
    /// same speed, and at most 16 rows wait in memory for their block.
    #[default]
    Zip,
    /// Wavelet and Huffman coding over blocks of 32 rows.
    Piz,
}

impl ExrCompression {
    pub const ALL: [ExrCompression; 5] =
        [ExrCompression::None, ExrCompression::Rle, ExrCompression::Zips, ExrCompression::Zip, ExrCompression::Piz];

    /// The name the command line takes.
    pub fn name(self) -> &'static str {
        match self {
            ExrCompression::None => "none",
            ExrCompression::Rle => "rle",
            ExrCompression::Zips => "zips",
            ExrCompression::Zip => "zip",
            ExrCompression::Piz => "piz",
        }
    }

    fn method(self) -> exr::compression::Compression {
        use exr::compression::Compression;
        match self {
            ExrCompression::None => Compression::Uncompressed,
            ExrCompression::Rle => Compression::RLE,
            ExrCompression::Zips => Compression::ZIP1,
            ExrCompression::Zip => Compression::ZIP16,
            ExrCompression::Piz => Compression::PIZ,
        }
    }
}

/// An OpenEXR file of 32-bit floats written row by row, top row first, into a temporary file
/// like [`super::ImageFile`]. The `exr` crate writes blocks only from inside a closure, so the
/// encoder runs on its own thread, fed through a channel of at most two row batches. ZIP and
/// ZIPS blocks are deflated here, by zlib-rs on the writers' threads ([`zip_chunk`]); the
/// other methods' by the `exr` crate's pool. Either way blocks are written in order, so the
/// file's bytes are those of one thread. Memory stays bounded by what one call passes in
/// plus a few blocks per compressing thread.
pub struct ExrFile {
    path: PathBuf,
    temp: LiveTemp,
    rows: Option<std::sync::mpsc::SyncSender<Vec<f32>>>,
    encoder: Option<std::thread::JoinHandle<exr::error::UnitResult>>,
    width: u32,
    height: u32,
    channels: ExrChannels,
    rows_written: u32,
}

impl ExrFile {
    /// Starts `path` for a `width × height` image with `channels`, its blocks compressed
    /// with `compression`.
    pub fn create(
        path: &Path,
        width: u32,
        height: u32,
        channels: ExrChannels,
        compression: ExrCompression,
    ) -> Result<ExrFile, ImageError> {
        use exr::meta::attribute::{ChannelDescription, LineOrder, SampleType};
        use exr::meta::header::{Header, LayerAttributes};
        let (temp, file) = temp_beside(path)?;
        // EXR lists channels in alphabetical order; blocks store them in that order.
        let names: &[&str] = match channels {
            ExrChannels::Rgb => &["B", "G", "R"],
            ExrChannels::Depth => &["Z"],
        };
        let list = names.iter().map(|n| ChannelDescription::new(*n, SampleType::F32, true)).collect();
        let size = (width as usize, height as usize);
        let header = Header::new("".into(), size, list).with_attributes(LayerAttributes::default()).with_encoding(
            compression.method(),
            exr::meta::BlockDescription::ScanLines,
            LineOrder::Increasing,
        );
        let (sender, receiver) = std::sync::mpsc::sync_channel::<Vec<f32>>(2);
        let encoder = std::thread::Builder::new()
            .name("exr-writer".into())
            .spawn(move || {
                let out = BufWriter::new(file);
                exr::block::write(out, std::iter::once(header).collect(), true, |meta, chunks| {
                    use exr::block::writer::ChunksWriter;
                    let header = &meta.headers[0];
                    if matches!(compression, ExrCompression::Zip | ExrCompression::Zips) {
                        let mut blocks = InOrder::new();
                        let top = header.own_attributes.layer_position.y();
                        let mut write = |(index, chunk)| chunks.write_chunk(index, chunk);
                        encode_exr_blocks(header, size, channels, receiver, |index, block| {
                            blocks.start(move || (index, zip_chunk(block, top)), &mut write)
                        })?;
                        return blocks.finish(&mut write);
                    }
                    // None where nothing is compressed, one block, or no threads (wasm).
                    let blocks = chunks.total_chunks_count();
                    let parallel = if blocks > 1 { chunks.parallel_blocks_compressor(&meta) } else { None };
                    match parallel {
                        Some(mut compressor) => encode_exr_blocks(header, size, channels, receiver, |index, block| {
                            compressor.add_block_to_compression_queue(index, block)
                        }),
                        None => {
                            let mut compressor = chunks.sequential_blocks_compressor(&meta);
                            encode_exr_blocks(header, size, channels, receiver, |index, block| {
                                compressor.compress_block(index, block)
                            })
                        }
                    }
                })
            })
            .map_err(|e| ImageError { path: path.to_path_buf(), message: e.to_string() })?;
        Ok(ExrFile {
            path: path.to_path_buf(),
            temp,
            rows: Some(sender),
            encoder: Some(encoder),
            width,
            height,
            channels,
            rows_written: 0,
        })
    }

    /// Appends whole rows of pixels, `channels.count()` floats each, continuing from the last
    /// row written.
    pub fn write_rows(&mut self, values: &[f32]) -> Result<(), ImageError> {
        let row_len = self.width as usize * self.channels.count();
        assert_eq!(values.len() % row_len, 0, "whole rows only");
        let rows = (values.len() / row_len) as u32;
        assert!(self.rows_written + rows <= self.height, "more rows than the image has");
        let sent = self.rows.as_ref().is_some_and(|r| r.send(values.to_vec()).is_ok());
        if !sent {
            // The encoder stopped early: its error says why.
            return Err(self.join_encoder().err().unwrap_or_else(|| self.error("the EXR encoder stopped".into())));
        }
        self.rows_written += rows;
        Ok(())
    }

    /// Completes the file; it is still temporary until [`persist_all`].
    pub fn finish(mut self) -> Result<FinishedImage, ImageError> {
        if self.rows_written != self.height {
            return Err(self.error(format!("only {} of {} rows were written", self.rows_written, self.height)));
        }
        self.join_encoder()?;
        FinishedImage::new(self.path, self.temp)
    }

    /// Closes the channel and waits for the encoder to write the offset table.
    fn join_encoder(&mut self) -> Result<(), ImageError> {
        self.rows = None;
        match self.encoder.take().map(|e| e.join()) {
            Some(Ok(Ok(()))) | None => Ok(()),
            Some(Ok(Err(e))) => Err(self.error(e.to_string())),
            Some(Err(_)) => Err(self.error("the EXR encoder panicked".into())),
        }
    }

    fn error(&self, message: String) -> ImageError {
        ImageError { path: self.path.clone(), message }
    }
}

/// Receives rows of interleaved pixels and hands each complete block, channels planar per
/// row as EXR stores them (little-endian, which the `exr` crate also takes on the only
/// machines we build for), to `compress` with its index.
fn encode_exr_blocks(
    header: &exr::meta::header::Header,
    (width, height): (usize, usize),
    channels: ExrChannels,
    rows: std::sync::mpsc::Receiver<Vec<f32>>,
    mut compress: impl FnMut(usize, exr::block::UncompressedBlock) -> exr::error::UnitResult,
) -> exr::error::UnitResult {
    let lines_per_block = header.compression.scan_lines_per_block();
    let n = channels.count();
    let row_len = width * n;
    let mut pending: Vec<f32> = Vec::new();
    let mut next_row = 0;
    for batch in rows {
        pending.extend_from_slice(&batch);
        loop {
            let lines = lines_per_block.min(height - next_row);
            if lines == 0 || pending.len() < lines * row_len {
                break;
            }
            let mut data = Vec::with_capacity(lines * row_len * 4);
            for row in pending[..lines * row_len].chunks_exact(row_len) {
                // Alphabetical channel order: B, G, R is the interleaved pixel read backwards.
                for c in (0..n).rev() {
                    for pixel in row.chunks_exact(n) {
                        data.extend_from_slice(&pixel[c].to_le_bytes());
                    }
                }
            }
            let index = exr::block::BlockIndex {
                layer: 0,
                pixel_position: exr::math::Vec2(0, next_row),
                pixel_size: exr::math::Vec2(width, lines),
                level: exr::math::Vec2(0, 0),
            };
            compress(next_row / lines_per_block, exr::block::UncompressedBlock { index, data })?;
            pending.drain(..lines * row_len);
            next_row += lines;
        }
    }
    Ok(())
}

/// zlib's compression level for EXR's ZIP blocks: the `exr` crate's own for them (its
/// `zip::compress_bytes`), so files keep their size (docs/performance.md, "The file writers").
const ZIP_LEVEL: u32 = 4;

/// The scan-line block `block` compressed as OpenEXR's ZIP and ZIPS do (OpenEXR's
/// `ImfZip.cpp`, `Zip::compress`): the little-endian bytes reordered, even-indexed bytes then
/// odd ones, each byte then replaced by its difference from the one before plus 128 (the
/// first kept), and the whole deflated as one zlib stream. A block that does not shrink is
/// stored as it is, which readers know by its size (OpenEXR's `ScanLineOutputFile`).
/// `top` is the data window's first row, which a block's own y counts from.
fn zip_chunk(block: exr::block::UncompressedBlock, top: i32) -> exr::block::chunk::Chunk {
    use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
    let raw = block.data;
    // 32-bit floats: an even number of bytes, so the halves are equal.
    let mut predicted = vec![0; raw.len()];
    let (evens, odds) = predicted.split_at_mut(raw.len() / 2);
    for (pair, (even, odd)) in raw.chunks_exact(2).zip(evens.iter_mut().zip(odds.iter_mut())) {
        (*even, *odd) = (pair[0], pair[1]);
    }
    let mut differences = predicted.clone();
    for (difference, pair) in differences[1..].iter_mut().zip(predicted.windows(2)) {
        *difference = pair[1].wrapping_sub(pair[0]).wrapping_add(128);
    }
    let mut deflated = Vec::with_capacity(raw.len());
    let mut compress = flate2::Compress::new(flate2::Compression::new(ZIP_LEVEL), true);
    let finished = compress.compress_vec(&differences, &mut deflated, flate2::FlushCompress::Finish);
    let shrank = matches!(finished, Ok(flate2::Status::StreamEnd)) && deflated.len() < raw.len();
    Chunk {
        layer_index: 0,
        compressed_block: CompressedBlock::ScanLine(CompressedScanLineBlock {
            y_coordinate: top + block.index.pixel_position.y() as i32,
            compressed_pixels_le: if shrank { deflated } else { raw },
        }),
    }
}
