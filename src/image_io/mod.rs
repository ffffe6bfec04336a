//! From float frames to 8-bit images (docs/SPEC.md §5), and image files written atomically.
//!
//! Every channel is clamped to [0, 1] and stored as `floor(255·v)`: truncation, as the
//! course's own images are made.
//!
//! Images are written into temporary files beside their destinations. The process keeps a
//! list of those still live, so that a program interrupted mid-render can remove them all
//! with [`remove_temporary_files_for_exit`] before it ends.

use crate::render::Frame;
use image::RgbImage;
use in_order::InOrder;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

mod exr_file;
mod in_order;
mod rgb_rows;
pub use exr_file::{ExrChannels, ExrCompression, ExrFile};
pub use rgb_rows::{PackedRgb, RgbRows};

/// docs/SPEC.md §5: `floor(255·clamp(v, 0, 1))`. NaN becomes 0.
pub fn quantize(v: f32) -> u8 {
    if v.is_nan() {
        return 0;
    }
    (255.0 * v.clamp(0.0, 1.0)).floor() as u8
}

/// The shaded image (`-output`). The frame must hold colour.
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
    image_from(frame, |k| if frame.hit[k] { [depth_level(frame.depth[k], min, max); 3] } else { [0; 3] })
}

/// The grey level of a hit at distance `t` in the depth visualisation `-depth MIN MAX`.
pub fn depth_level(t: f32, min: f32, max: f32) -> u8 {
    // f64 so that MIN and MAX far from zero do not lose the depth's low digits.
    let v = (max as f64 - t as f64) / (max as f64 - min as f64);
    quantize(v as f32)
}

/// The range the depth view shows without a `-depth` range (the live window's `d`): from
/// the `nearest` to the `farthest` hit; half a unit either side of a depth every hit shares
/// (at least an ulp, so that the range is never empty); `(0, 1)` where nothing was hit
/// (`nearest` = +∞, `farthest` = −∞). Always `min < max`, both finite.
pub fn depth_view_range(nearest: f32, farthest: f32) -> (f32, f32) {
    if nearest < farthest {
        (nearest, farthest)
    } else if nearest.is_finite() {
        // An ulp of t is at most |t| · 2⁻²³ (f32::EPSILON).
        let half = 0.5f32.max(nearest.abs() * f32::EPSILON);
        (nearest - half, nearest + half)
    } else {
        (0.0, 1.0)
    }
}

/// [`depth_view_range`] over `frames`' hits.
pub fn hit_depth_range(frames: &[Frame]) -> (f32, f32) {
    let hits = frames.iter().flat_map(|f| f.depth.iter().zip(&f.hit).filter(|(_, &hit)| hit).map(|(&t, _)| t));
    let (nearest, farthest) = hits.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)));
    depth_view_range(nearest, farthest)
}

fn image_from(frame: &Frame, pixel: impl Fn(usize) -> [u8; 3]) -> RgbImage {
    let mut data = Vec::with_capacity(frame.hit.len() * 3);
    for k in 0..frame.hit.len() {
        data.extend_from_slice(&pixel(k));
    }
    RgbImage::from_raw(frame.width, frame.height, data).expect("buffer sized from the frame")
}

/// The linear colour, unclamped, three floats a pixel (`-output` as EXR).
pub fn color_values(frame: &Frame) -> Vec<f32> {
    frame.color.iter().flatten().copied().collect()
}

/// The signed unit world normal, three floats a pixel, zero where nothing was hit
/// (`-normals` as EXR).
pub fn normal_values(frame: &Frame) -> Vec<f32> {
    (0..frame.hit.len()).flat_map(|k| if frame.hit[k] { frame.normal[k] } else { [0.0; 3] }).collect()
}

/// The signed hit distance `t` in world units, one float a pixel (`-depth` as EXR).
/// Where nothing was hit: +∞, the distance of a surface that is not there. It sorts behind
/// every hit (orthographic depths can be negative, so no finite value would), and keeps
/// `min`/`<` depth tests meaningful, which NaN would not.
pub fn depth_values(frame: &Frame) -> Vec<f32> {
    (0..frame.hit.len()).map(|k| if frame.hit[k] { frame.depth[k] } else { f32::INFINITY }).collect()
}

/// The image file formats we write, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// Uncompressed 24-bit true-colour TGA (type 2), as the course writes it.
    Tga,
    Png,
    /// OpenEXR, 32-bit float channels: the frame's values themselves (see [`ExrFile`]).
    Exr,
}

impl ImageFormat {
    /// The format for `path`'s extension (case-insensitive), or `None` if unsupported.
    pub fn from_path(path: &Path) -> Option<ImageFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "tga" => Some(ImageFormat::Tga),
            "png" => Some(ImageFormat::Png),
            "exr" => Some(ImageFormat::Exr),
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

/// An image file being written row by row, top row first, into a temporary file beside its
/// destination; [`persist_all`] renames finished files into place. Memory stays bounded by
/// what one call passes in (and for PNG a few strips of 1 MiB per core), so any image the
/// formats allow can be written.
pub struct ImageFile {
    path: PathBuf,
    temp: LiveTemp,
    encoder: Encoder,
    width: u32,
    height: u32,
    rows_written: u32,
}

enum Encoder {
    /// Uncompressed true-colour TGA with the course's bottom-left origin: each call's rows
    /// are placed by seeking, so tiles can arrive top first.
    Tga(TgaWriter),
    Png(Box<PngWriter>),
}

/// TGA header length (no image id, no colour map).
const TGA_HEADER: u64 = 18;

/// Bytes of rows reordered before each write to a TGA file: few enough that the buffer stays
/// in the processor's cache between the reordering and the system call's copy, many enough
/// that system calls are few (docs/performance.md, "The file writers").
const TGA_WRITE: usize = 128 * 1024;

/// A TGA file and the buffer rows are reordered in, kept from call to call.
struct TgaWriter {
    file: std::fs::File,
    block: Vec<u8>,
}

impl ImageFile {
    /// Starts `path` (format from its extension) for a `width × height` image.
    pub fn create(path: &Path, width: u32, height: u32) -> Result<ImageFile, ImageError> {
        let fail = |message: String| ImageError { path: path.to_path_buf(), message };
        if path.is_dir() {
            return Err(fail("is a folder, not an image file name".into()));
        }
        let format = ImageFormat::from_path(path)
            .ok_or_else(|| fail("unsupported image format (use a .tga or .png file name)".into()))?;
        let (temp, file) = temp_beside(path)?;
        let encoder = match format {
            ImageFormat::Tga => Encoder::Tga(tga_start(file, width, height).map_err(|e| fail(e.to_string()))?),
            ImageFormat::Png => {
                Encoder::Png(Box::new(png_start(file, width, height).map_err(|e| fail(e.to_string()))?))
            }
            ImageFormat::Exr => return Err(fail("an EXR image holds floats: write it with ExrFile".into())),
        };
        Ok(ImageFile { path: path.to_path_buf(), temp, encoder, width, height, rows_written: 0 })
    }

    /// Appends whole rows of 8-bit RGB, continuing from the last row written.
    pub fn write_rows(&mut self, rgb: &[u8]) -> Result<(), ImageError> {
        assert_eq!(rgb.len() % (self.width as usize * 3), 0, "whole rows only");
        self.write_pixels(RgbRows::Bytes(rgb))
    }

    /// Appends whole rows of pixels, bytes or packed, continuing from the last row written.
    pub fn write_pixels(&mut self, pixels: RgbRows) -> Result<(), ImageError> {
        let width = self.width as usize;
        assert_eq!(pixels.pixels() % width, 0, "whole rows only");
        let rows = (pixels.pixels() / width) as u32;
        assert!(self.rows_written + rows <= self.height, "more rows than the image has");
        let result = match &mut self.encoder {
            Encoder::Tga(out) => out.write_rows(pixels, width, self.height - self.rows_written - rows),
            Encoder::Png(out) => out.write_rows(pixels),
        };
        result.map_err(|e| self.error(e.to_string()))?;
        self.rows_written += rows;
        Ok(())
    }

    /// Completes the file; it is still temporary until [`persist_all`].
    pub fn finish(self) -> Result<FinishedImage, ImageError> {
        if self.rows_written != self.height {
            return Err(self.error(format!("only {} of {} rows were written", self.rows_written, self.height)));
        }
        let result = match self.encoder {
            Encoder::Tga(mut out) => out.file.flush(),
            Encoder::Png(out) => out.finish(),
        };
        let fail = |message: String| ImageError { path: self.path.clone(), message };
        result.map_err(|e| fail(e.to_string()))?;
        FinishedImage::new(self.path, self.temp)
    }

    fn error(&self, message: String) -> ImageError {
        ImageError { path: self.path.clone(), message }
    }
}

/// A complete image (or part file) in its temporary file.
pub struct FinishedImage {
    path: PathBuf,
    temp: LiveTemp,
}

impl FinishedImage {
    /// The complete contents of `path`, written to `temp`: made readable (temporary files are
    /// private) and ready for [`persist_all`].
    pub fn new(path: PathBuf, temp: LiveTemp) -> Result<FinishedImage, ImageError> {
        make_readable(temp.file()).map_err(|e| ImageError { path: path.clone(), message: e.to_string() })?;
        Ok(FinishedImage { path, temp })
    }
}

/// Renames every finished image into place. Called only once all are complete, so a failed
/// run leaves no image half-written (and, short of a failing rename, none at all). An
/// interrupt that arrives meanwhile waits until the whole set is in place.
pub fn persist_all(images: Vec<FinishedImage>) -> Result<(), ImageError> {
    let mut live = live_temp_files();
    for image in images {
        image.temp.persist(&mut live, &image.path).map_err(|e| ImageError { path: image.path.clone(), message: e })?;
    }
    Ok(())
}

/// The temporary files of the images being written in this process.
static LIVE_TEMP_FILES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The list, locked. A panic elsewhere cannot leave it wrong (each change is one push or
/// one removal), so a poisoned lock is still used.
fn live_temp_files() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE_TEMP_FILES.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Removes the temporary file of every image still being written in this process, and
/// keeps the list locked for good, so that no other temporary file can be created or renamed
/// into place afterwards (those calls block). For a signal handler that ends the process
/// right after: an interrupted render leaves no file behind. Returns how many were removed.
pub fn remove_temporary_files_for_exit() -> usize {
    let mut live = live_temp_files();
    let removed = live.drain(..).filter(|path| std::fs::remove_file(path).is_ok()).count();
    std::mem::forget(live);
    removed
}

/// A temporary file beside an image's destination, on the list of live ones from its
/// creation until it is renamed into place or dropped (which deletes it).
pub struct LiveTemp(Option<tempfile::NamedTempFile>);

impl LiveTemp {
    fn create_in(dir: &Path) -> std::io::Result<LiveTemp> {
        // Locked across creation, so an interrupt cannot fall between creating and listing.
        let mut live = live_temp_files();
        let temp = tempfile::Builder::new().prefix(".raycaster-").suffix(".tmp").tempfile_in(dir)?;
        live.push(temp.path().to_path_buf());
        Ok(LiveTemp(Some(temp)))
    }

    fn file(&self) -> &std::fs::File {
        self.0.as_ref().expect("a LiveTemp holds its file until persisted or dropped").as_file()
    }

    /// Renames the file to `path`; `live` is the locked list, held by the caller.
    fn persist(mut self, live: &mut Vec<PathBuf>, path: &Path) -> Result<(), String> {
        let temp = self.0.take().expect("a LiveTemp is persisted once");
        unlist(live, temp.path());
        // On failure the returned file is dropped here, which deletes it.
        temp.persist(path).map(drop).map_err(|e| e.error.to_string())
    }
}

impl Drop for LiveTemp {
    fn drop(&mut self) {
        if let Some(temp) = self.0.take() {
            let mut live = live_temp_files();
            unlist(&mut live, temp.path());
            drop(temp);
        }
    }
}

fn unlist(live: &mut Vec<PathBuf>, path: &Path) {
    live.retain(|p| p != path);
}

/// The folder a file goes into (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Why no file could be created in `dir`, in terms of the user's paths only: the error the
/// temporary-file crate returns names the temporary file, which the user never asked for.
fn cannot_create_in(dir: &Path, e: &std::io::Error) -> String {
    use std::io::ErrorKind;
    let dir = dir.display();
    match e.kind() {
        ErrorKind::NotFound => format!("cannot write there: the folder {dir} does not exist"),
        ErrorKind::NotADirectory => format!("cannot write there: {dir} is not a folder"),
        ErrorKind::PermissionDenied => format!("cannot write there: no permission to create files in {dir}"),
        kind => format!("cannot create a file in {dir}: {kind}"),
    }
}

/// Writes every `(path, image)` pair, or none of them (see [`ImageFile`]).
pub fn write_images(images: &[(PathBuf, RgbImage)]) -> Result<(), ImageError> {
    let mut finished = Vec::with_capacity(images.len());
    for (path, image) in images {
        let mut file = ImageFile::create(path, image.width(), image.height())?;
        file.write_rows(image.as_raw())?;
        finished.push(file.finish()?);
    }
    persist_all(finished)
}

/// Writes one image atomically (see [`write_images`]).
pub fn write_image(path: &Path, image: &RgbImage) -> Result<(), ImageError> {
    write_images(&[(path.to_path_buf(), image.clone())])
}

/// A private temporary file in `path`'s folder (so the final rename stays on one file
/// system), and a second handle to it for writing. Errors name `path`.
pub fn temp_beside(path: &Path) -> Result<(LiveTemp, std::fs::File), ImageError> {
    let fail = |message: String| ImageError { path: path.to_path_buf(), message };
    let dir = folder_of(path);
    let temp = LiveTemp::create_in(dir).map_err(|e| fail(cannot_create_in(dir, &e)))?;
    let file = temp.file().try_clone().map_err(|e| fail(e.to_string()))?;
    Ok((temp, file))
}

/// TGA type 2 (uncompressed true colour), 24 bits, origin bottom-left as the course writes it.
fn tga_start(mut file: std::fs::File, width: u32, height: u32) -> std::io::Result<TgaWriter> {
    let too_big = |side: u32| u16::try_from(side).map_err(|_| std::io::Error::other("TGA sides are at most 65535"));
    let (w, h) = (too_big(width)?, too_big(height)?);
    let mut header = [0u8; TGA_HEADER as usize];
    header[2] = 2;
    header[12..14].copy_from_slice(&w.to_le_bytes());
    header[14..16].copy_from_slice(&h.to_le_bytes());
    header[16] = 24;
    file.write_all(&header)?;
    Ok(TgaWriter { file, block: Vec::new() })
}

impl TgaWriter {
    /// Rows arrive top first but TGA stores the bottom row first: the block lands at file
    /// row `bottom_row` (counted from the bottom), its rows reversed, pixels as BGR.
    fn write_rows(&mut self, pixels: RgbRows, width: usize, bottom_row: u32) -> std::io::Result<()> {
        use std::io::{Seek, SeekFrom};
        let row_bytes = 3 * width;
        self.file.seek(SeekFrom::Start(TGA_HEADER + bottom_row as u64 * row_bytes as u64))?;
        // Bottom row first, the rows go out in file order, a few at a time.
        let rows_per_write = (TGA_WRITE / row_bytes).max(1);
        let mut rows = (0..pixels.pixels() / width).rev().peekable();
        while rows.peek().is_some() {
            let batch: Vec<usize> = rows.by_ref().take(rows_per_write).collect();
            self.block.resize(batch.len() * row_bytes, 0);
            for (to, row) in self.block.chunks_exact_mut(row_bytes).zip(batch) {
                pixels.bgr_into(row * width, to);
            }
            self.file.write_all(&self.block)?;
        }
        Ok(())
    }
}

fn png_start(file: std::fs::File, width: u32, height: u32) -> Result<PngWriter, png::EncodingError> {
    let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // Refuses a side of 0 before the strips divide by the row's length.
    let out = encoder.write_header()?;
    let row_bytes = width as usize * 3;
    Ok(PngWriter {
        stream: PngStream { out, adler: 1 },
        row_bytes,
        strip_rows: (PNG_STRIP_BYTES / row_bytes).max(1),
        strip: Vec::new(),
        above: Vec::new(),
        rows_left: height as usize,
        strips_started: 0,
        strips: InOrder::new(),
    })
}

/// Raw bytes of rows deflated as one strip: enough that restarting the deflate stream at
/// each strip costs little (docs/performance.md, "The file writers").
const PNG_STRIP_BYTES: usize = 1 << 20;

/// zlib's compression level for PNG image data (docs/performance.md, "The file writers").
const PNG_LEVEL: u32 = 4;

/// A PNG whose image data is deflated in strips of rows, on the writers' threads, and written
/// in order as IDAT chunks of one zlib stream. Each strip's raw deflate ends on a byte
/// boundary (a sync flush; the last one finishes the stream), so the strips concatenate
/// into one valid stream (RFC 1951 §3.2.4, as `pigz` joins its blocks); the stream's
/// Adler-32 is combined from the strips' (RFC 1950 §2.2). Every row is filtered with Up (PNG
/// §9.2, type 2), which needs only the row above: a strip carries its first row's.
struct PngWriter {
    stream: PngStream,
    row_bytes: usize,
    strip_rows: usize,
    /// Rows gathered for the next strip.
    strip: Vec<u8>,
    /// The row above `strip` (empty above the first row: PNG's Up then takes zeros).
    above: Vec<u8>,
    /// Rows of the image not yet gathered.
    rows_left: usize,
    strips_started: usize,
    /// The strips being deflated.
    strips: InOrder<Strip>,
}

/// The PNG's image data as written so far.
struct PngStream {
    out: png::Writer<BufWriter<std::fs::File>>,
    /// Adler-32 of the filtered bytes written so far.
    adler: u32,
}

/// A deflated strip: its bytes, and the Adler-32 and length of the filtered bytes it holds.
struct Strip {
    deflated: std::io::Result<Vec<u8>>,
    adler: u32,
    len: u64,
    /// The image's last: the stream ends with it.
    last: bool,
}

impl PngWriter {
    fn write_rows(&mut self, pixels: RgbRows) -> std::io::Result<()> {
        let width = self.row_bytes / 3;
        let mut row = 0;
        let rows = pixels.pixels() / width;
        while row < rows {
            let gathered = self.strip.len() / self.row_bytes;
            let take = (self.strip_rows - gathered).min(rows - row);
            if gathered == 0 {
                self.strip.reserve_exact(self.strip_rows.min(self.rows_left) * self.row_bytes);
            }
            self.strip.resize((gathered + take) * self.row_bytes, 0);
            pixels.rgb_into(row * width, &mut self.strip[gathered * self.row_bytes..]);
            self.rows_left -= take;
            row += take;
            if gathered + take == self.strip_rows || self.rows_left == 0 {
                self.deflate_strip()?;
            }
        }
        Ok(())
    }

    /// Sends the gathered rows to be deflated; writes out finished strips while too many wait.
    fn deflate_strip(&mut self) -> std::io::Result<()> {
        let rows = std::mem::take(&mut self.strip);
        let above = std::mem::replace(&mut self.above, rows[rows.len() - self.row_bytes..].to_vec());
        let (first, last, row_bytes) = (self.strips_started == 0, self.rows_left == 0, self.row_bytes);
        self.strips_started += 1;
        let job = move || deflate_png_strip(&above, &rows, row_bytes, first, last);
        self.strips.start(job, |strip| self.stream.write_strip(strip))
    }

    fn finish(mut self) -> std::io::Result<()> {
        self.strips.finish(|strip| self.stream.write_strip(strip))?;
        self.stream.out.finish().map_err(std::io::Error::other)
    }
}

impl PngStream {
    fn write_strip(&mut self, strip: Strip) -> std::io::Result<()> {
        let mut deflated = strip.deflated?;
        self.adler = zlib_rs::adler32::adler32_combine(self.adler, strip.adler, strip.len);
        if strip.last {
            // RFC 1950 §2.2: the stream ends with its Adler-32, big-endian.
            deflated.extend_from_slice(&self.adler.to_be_bytes());
        }
        self.out.write_chunk(png::chunk::IDAT, &deflated).map_err(std::io::Error::other)
    }
}

/// Filters `rows` (PNG's Up, `above` the row before them) and deflates them raw: the zlib
/// header first for the first strip, a finished stream for the last, a sync flush otherwise.
fn deflate_png_strip(above: &[u8], rows: &[u8], row_bytes: usize, first: bool, last: bool) -> Strip {
    let mut filtered = Vec::with_capacity(rows.len() + rows.len() / row_bytes);
    let mut prior = above;
    for row in rows.chunks_exact(row_bytes) {
        filtered.push(2);
        if prior.is_empty() {
            filtered.extend_from_slice(row);
        } else {
            filtered.extend(row.iter().zip(prior).map(|(x, b)| x.wrapping_sub(*b)));
        }
        prior = row;
    }
    let adler = zlib_rs::adler32::adler32(1, &filtered);
    let mut deflated = Vec::with_capacity(filtered.len() / 16 + 1024);
    if first {
        deflated.extend_from_slice(&ZLIB_HEADER);
    }
    let mut compress = flate2::Compress::new(flate2::Compression::new(PNG_LEVEL), false);
    let flush = if last { flate2::FlushCompress::Finish } else { flate2::FlushCompress::Sync };
    let deflated = loop {
        if deflated.capacity() - deflated.len() < 64 {
            deflated.reserve(deflated.capacity());
        }
        let done = compress.total_in() as usize;
        match compress.compress_vec(&filtered[done..], &mut deflated, flush) {
            Err(e) => break Err(std::io::Error::other(e)),
            Ok(flate2::Status::StreamEnd) => break Ok(deflated),
            // A flush is complete once it leaves room unused.
            Ok(_)
                if !last && compress.total_in() as usize == filtered.len() && deflated.len() < deflated.capacity() =>
            {
                break Ok(deflated)
            }
            Ok(_) => {}
        }
    };
    Strip { deflated, adler, len: filtered.len() as u64, last }
}

/// RFC 1950 §2.2: deflate with a 32 KiB window (0x78), then FLEVEL as zlib sets it for
/// [`PNG_LEVEL`] and FCHECK, which makes the pair a multiple of 31.
const ZLIB_HEADER: [u8; 2] = {
    let flevel: u32 = match PNG_LEVEL {
        0 | 1 => 0,
        2..=5 => 1,
        6 => 2,
        _ => 3,
    };
    let flg = flevel << 6;
    [0x78, (flg + (31 - (0x78 * 256 + flg) % 31) % 31) as u8]
};

/// Temporary files are private (0600); an image is an ordinary file (0644).
#[cfg(unix)]
fn make_readable(file: &std::fs::File) -> std::io::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    file.set_permissions(std::fs::Permissions::from_mode(0o644))
}

#[cfg(not(unix))]
fn make_readable(_: &std::fs::File) -> std::io::Result<()> {
    Ok(())
}

/// Reads a TGA or PNG image as 8-bit RGB (used by tests and `compare`).
pub fn read_image(path: &Path) -> Result<RgbImage, ImageError> {
    image::open(path).map(|i| i.to_rgb8()).map_err(|e| ImageError { path: path.to_path_buf(), message: e.to_string() })
}

// The course's pictures of assignment 7 (docs/SPEC.md §8), drawn from the sampling's
// positions and weights: images, so here beside the other images and their quantisation.

/// The course's `Film::renderFilter` picture: the weights the filter gives around the
/// centre pixel (column and row ⌊W/2⌋) of a `width × height` image, each pixel within the
/// support radius enlarged `zoom` times, on a dark blue ground (0, 0, ½) with a blue grid
/// (0, 0, 1) on the pixel borders; `(W·zoom + 1) × (H·zoom + 1)`, RGB rows from the top.
/// The weight drawn at sub-pixel (i2, j2) of pixel (i, j) is the one at the sub-pixel's
/// lower left corner, (i + i2/zoom − c − ½, j + j2/zoom − c − ½), not normalised.
pub fn filter_picture(filter: crate::sampling::Filter, width: u32, height: u32, zoom: u32) -> image::RgbImage {
    let (w, h) = (width * zoom + 1, height * zoom + 1);
    let mut picture = image::RgbImage::from_pixel(w, h, image::Rgb([0, 0, quantize(0.5)]));
    let radius = filter.support_radius() as i64;
    // The course centres both axes on width / 2.
    let center = (width / 2) as i64;
    let mut set = |x: u32, y: u32, rgb: [f32; 3]| {
        // y counts from the bottom, as the course's image does.
        picture.put_pixel(x, h - 1 - y, image::Rgb(rgb.map(quantize)));
    };
    for i in (center - radius)..=(center + radius) {
        for j in (center - radius)..=(center + radius) {
            if i < 0 || j < 0 || i >= width as i64 || j >= height as i64 {
                continue;
            }
            for i2 in 0..zoom {
                for j2 in 0..zoom {
                    let x = i as f64 + i2 as f64 / zoom as f64 - (center as f64 + 0.5);
                    let y = j as f64 + j2 as f64 / zoom as f64 - (center as f64 + 0.5);
                    let weight = filter.weight(x, y) as f32;
                    set(i as u32 * zoom + i2, j as u32 * zoom + j2, [weight; 3]);
                }
            }
        }
    }
    for x in 0..w {
        for y in 0..h {
            if x % zoom == 0 || y % zoom == 0 {
                set(x, y, [0.0, 0.0, 1.0]);
            }
        }
    }
    picture
}

/// One sample as the pictures need it: its pixel-local position and colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleDot {
    pub position: (f64, f64),
    pub color: [f32; 3],
}

/// The course's `Film::renderSamples` picture: the image plane enlarged `zoom` times, a
/// checkerboard of dark grey (0.2) and black pixels, with a dot of the sample's colour at
/// each sample, `(W·zoom) × (H·zoom)`, RGB rows from the top. `samples(i, j)` gives pixel
/// (i from the left, j from the bottom)'s samples in order; a later sample on the same
/// dot covers an earlier one.
pub fn samples_picture(
    width: u32,
    height: u32,
    zoom: u32,
    samples: impl Fn(u32, u32) -> Vec<SampleDot>,
) -> image::RgbImage {
    let (w, h) = (width * zoom, height * zoom);
    let mut picture = image::RgbImage::new(w, h);
    let grey = quantize(0.2);
    for i in 0..width {
        for j in 0..height {
            let ground = if (i + j) % 2 == 0 { [grey; 3] } else { [0; 3] };
            for x in i * zoom..(i + 1) * zoom {
                for y in j * zoom..(j + 1) * zoom {
                    picture.put_pixel(x, h - 1 - y, image::Rgb(ground));
                }
            }
            for dot in samples(i, j) {
                let x = (((i as f64 + dot.position.0) * zoom as f64).floor() as u32).min(w - 1);
                let y = (((j as f64 + dot.position.1) * zoom as f64).floor() as u32).min(h - 1);
                picture.put_pixel(x, h - 1 - y, image::Rgb(dot.color.map(quantize)));
            }
        }
    }
    picture
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_is_shown_between_the_nearest_and_farthest_hits() {
        let frame = Frame {
            width: 3,
            height: 1,
            hit: vec![true, false, true],
            color: vec![],
            normal: vec![],
            depth: vec![2.0, 9.0, 5.0],
        };
        assert_eq!(hit_depth_range(&[frame]), (2.0, 5.0));
        assert_eq!(hit_depth_range(&[]), (0.0, 1.0));
        assert_eq!(depth_view_range(f32::INFINITY, f32::NEG_INFINITY), (0.0, 1.0));
        assert_eq!(depth_view_range(3.0, 3.0), (2.5, 3.5));
        // Where half a unit is below an ulp, the range still holds one either side.
        let far = 3.0e9f32;
        let (min, max) = depth_view_range(far, far);
        assert!(min < far && far < max && max - min <= 4.0 * far * f32::EPSILON, "{min} {max}");
    }
}
