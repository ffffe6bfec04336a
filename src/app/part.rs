//! The part files of a render split across machines (docs/usage.md, "Renders split across
//! machines"): `OUT.part-K-of-N` beside each output, a short text header that identifies
//! the render and the band, then the band's final pixel data. This module writes and reads
//! them and knows nothing of how the pixels were made or are stitched.

use raycaster::image_io::{self, FinishedImage, ImageError, LiveTemp};
use raycaster::scene::{self, Scene, Shape};
use sha2::{Digest, Sha256};
use std::collections::{BTreeMap, HashSet};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// `out.tga` → `out.tga.part-K-of-N`, in the same folder.
pub fn part_path(output: &Path, index: u32, count: u32) -> PathBuf {
    let mut name = output.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".part-{index}-of-{count}"));
    output.with_file_name(name)
}

const MAGIC: &str = "raycaster part 1";
/// No header is longer; a longer first stretch is not a part file.
const MAX_HEADER: u64 = 4096;

/// What makes two parts pieces of one image: equal exactly when their pixels are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    pub width: u32,
    pub height: u32,
    pub count: u32,
    /// [`crate::app::output_file::OutputFile::describe`]: the output, the format, and the
    /// depth range where it is used.
    pub output: String,
    /// SHA-256 of the scene file's text and of every OBJ mesh it loads.
    pub scene: String,
    /// The flags that change pixels, as text (hashed into the header too).
    pub flags: String,
}

/// A part file's header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartHeader {
    pub identity: Identity,
    pub index: u32,
    pub first_row: u32,
    pub rows: u32,
}

impl PartHeader {
    pub fn payload_bytes(&self, pixel_bytes: usize) -> u64 {
        self.rows as u64 * self.identity.width as u64 * pixel_bytes as u64
    }

    fn text(&self, payload: u64) -> String {
        let id = &self.identity;
        format!(
            "{MAGIC}\nsize {} {}\ntile {} {}\nrows {} {}\noutput {}\nscene {}\nflags {} {}\nbytes {payload}\n\n",
            id.width,
            id.height,
            self.index,
            id.count,
            self.first_row,
            self.rows,
            id.output,
            id.scene,
            hex(&Sha256::digest(id.flags.as_bytes())),
            id.flags
        )
    }

    /// Parses the header at the start of `head`: the header, the payload size it states, and
    /// where the payload starts.
    fn parse(head: &[u8]) -> Result<(PartHeader, u64, u64), String> {
        let not_a_part = || "not a raycaster part file".to_string();
        let end = head.windows(2).position(|w| w == b"\n\n").ok_or_else(not_a_part)?;
        let text = std::str::from_utf8(&head[..end]).map_err(|_| not_a_part())?;
        let mut lines = text.lines();
        if lines.next() != Some(MAGIC) {
            return Err(not_a_part());
        }
        let mut fields = BTreeMap::new();
        for line in lines {
            let (key, value) = line.split_once(' ').unwrap_or((line, ""));
            fields.insert(key, value);
        }
        let field = |key: &str| fields.get(key).copied().ok_or_else(|| format!("part header lacks '{key}'"));
        let pair = |key: &str| -> Result<(u64, u64), String> {
            let value = field(key)?;
            let mut words = value.split(' ').map(str::parse::<u64>);
            match (words.next(), words.next(), words.next()) {
                (Some(Ok(a)), Some(Ok(b)), None) => Ok((a, b)),
                _ => Err(format!("part header: bad '{key} {value}'")),
            }
        };
        let narrow = |v: u64| u32::try_from(v).map_err(|_| "part header: number out of range".to_string());
        let (width, height) = pair("size")?;
        let (index, count) = pair("tile")?;
        if index >= count {
            return Err(format!("part header: bad 'tile {index} {count}'"));
        }
        let (first_row, rows) = pair("rows")?;
        let (_, flags) = field("flags")?.split_once(' ').unwrap_or(("", ""));
        let bytes = field("bytes")?.parse::<u64>().map_err(|_| "part header: bad 'bytes'".to_string())?;
        let header = PartHeader {
            identity: Identity {
                width: narrow(width)?,
                height: narrow(height)?,
                count: narrow(count)?,
                output: field("output")?.to_string(),
                scene: field("scene")?.to_string(),
                flags: flags.to_string(),
            },
            index: narrow(index)?,
            first_row: narrow(first_row)?,
            rows: narrow(rows)?,
        };
        Ok((header, bytes, end as u64 + 2))
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 of the scene file's text and of the vertices and triangles of every mesh it
/// loads (an OBJ file changes the image as much as the scene file does).
pub fn scene_hash(scene: &Scene) -> Result<String, String> {
    let text = std::fs::read(&scene.path).map_err(|e| format!("{}: {e}", scene.path.display()))?;
    let mut hasher = Sha256::new();
    hasher.update((text.len() as u64).to_le_bytes());
    hasher.update(&text);
    let mut seen = HashSet::new();
    scene::for_each_leaf(&scene.root, &glam::DMat4::IDENTITY, &mut |leaf| match leaf.shape() {
        Shape::Mesh { mesh, .. } if seen.insert(std::sync::Arc::as_ptr(mesh)) => {
            hasher.update((mesh.positions.len() as u64).to_le_bytes());
            for p in &mesh.positions {
                p.to_array().iter().for_each(|c| hasher.update(c.to_le_bytes()));
            }
            hasher.update((mesh.triangles.len() as u64).to_le_bytes());
            for t in &mesh.triangles {
                t.iter().for_each(|i| hasher.update(i.to_le_bytes()));
            }
        }
        _ => {}
    });
    Ok(hex(&hasher.finalize()))
}

/// A part file being written into a temporary file beside it.
pub struct PartWriter {
    path: PathBuf,
    temp: LiveTemp,
    out: BufWriter<std::fs::File>,
    expected: u64,
    written: u64,
}

impl PartWriter {
    /// The part file of band `header.index` of `image`, whose pixels take `pixel_bytes`.
    pub fn create(header: PartHeader, image: &Path, pixel_bytes: usize) -> Result<PartWriter, ImageError> {
        let path = part_path(image, header.index, header.identity.count);
        let fail = |message: String| ImageError { path: path.clone(), message };
        let (temp, file) = image_io::temp_beside(&path)?;
        let expected = header.payload_bytes(pixel_bytes);
        let mut out = BufWriter::new(file);
        out.write_all(header.text(expected).as_bytes()).map_err(|e| fail(e.to_string()))?;
        Ok(PartWriter { path, temp, out, expected, written: 0 })
    }

    pub fn write(&mut self, bytes: &[u8]) -> Result<(), ImageError> {
        self.out.write_all(bytes).map_err(|e| ImageError { path: self.path.clone(), message: e.to_string() })?;
        self.written += bytes.len() as u64;
        Ok(())
    }

    /// Completes the part file; it is still temporary until [`image_io::persist_all`].
    pub fn finish(mut self) -> Result<FinishedImage, ImageError> {
        let fail = |message: String| ImageError { path: self.path.clone(), message };
        if self.written != self.expected {
            return Err(fail(format!("{} of {} bytes were written", self.written, self.expected)));
        }
        self.out.flush().map_err(|e| fail(e.to_string()))?;
        FinishedImage::new(self.path, self.temp)
    }
}

/// A part file found beside an output, with its header read.
pub struct Part {
    pub path: PathBuf,
    pub header: PartHeader,
    /// Where the payload starts in the file.
    pub offset: u64,
}

/// The part files beside `output`: `(K, N, path)` sorted by N, then K.
pub fn find(output: &Path) -> std::io::Result<Vec<(u32, u32, PathBuf)>> {
    let dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let prefix = format!("{}.part-", output.file_name().unwrap_or_default().to_string_lossy());
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let name = entry?.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix(&prefix) else { continue };
        let Some((k, n)) = rest.split_once("-of-") else { continue };
        if let (Ok(k), Ok(n)) = (k.parse::<u32>(), n.parse::<u32>()) {
            if k >= n {
                continue;
            }
            found.push((k, n, part_path(output, k, n)));
        }
    }
    found.sort_by_key(|&(k, n, _)| (n, k));
    Ok(found)
}

/// Reads a part's header and checks that the file holds exactly the payload it states,
/// for an output described as `output` whose pixels take `pixel_bytes`.
pub fn read(path: &Path, output: &str, pixel_bytes: usize) -> Result<Part, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let length = file.metadata().map_err(|e| e.to_string())?.len();
    let mut head = Vec::new();
    file.take(MAX_HEADER).read_to_end(&mut head).map_err(|e| e.to_string())?;
    let (header, bytes, offset) = PartHeader::parse(&head)?;
    let expected = header.payload_bytes(pixel_bytes);
    if bytes != expected && header.identity.output == output {
        return Err(format!("states {bytes} bytes of pixels where its band needs {expected}"));
    }
    if length != offset + bytes {
        return Err(format!(
            "truncated or overlong: {} bytes of pixels where its header states {bytes}",
            length.saturating_sub(offset)
        ));
    }
    Ok(Part { path: path.to_path_buf(), header, offset })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_names_sit_beside_the_output() {
        assert_eq!(part_path(Path::new("out/a.tga"), 2, 7), Path::new("out/a.tga.part-2-of-7"));
        assert_eq!(part_path(Path::new("a.exr"), 0, 1), Path::new("a.exr.part-0-of-1"));
    }

    #[test]
    fn headers_read_back() {
        let header = PartHeader {
            identity: Identity {
                width: 640,
                height: 480,
                count: 4,
                output: "depth 9 11 tga".into(),
                scene: "ab".repeat(32),
                flags: "--backend gpu --triangle-test watertight --sphere-test robust -shade_back".into(),
            },
            index: 3,
            first_row: 360,
            rows: 120,
        };
        let text = header.text(230400);
        let mut bytes = text.clone().into_bytes();
        bytes.extend_from_slice(&[0, 1, 2]);
        assert_eq!(PartHeader::parse(&bytes), Ok((header, 230400, text.len() as u64)));
        assert!(PartHeader::parse(b"P6\n640 480\n255\n\n").is_err());
    }
}
