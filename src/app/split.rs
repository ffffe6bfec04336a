//! Renders split across machines. `--tile K/N` renders band K of N and writes, beside each
//! output, a part file `OUT.part-K-of-N` holding a header that identifies the render and
//! the band's final pixel data; `raycaster stitch` checks the parts and streams them through
//! the same writers a single render uses, so the stitched files are byte for byte the
//! single render's. `batch --shard K/N` runs every N-th command line of a batch.

use crate::app::backend::Backend;
use crate::app::cli::{RenderArgs, StitchArgs};
use crate::app::output::{self, Output, Pixels, Sink};
use raycaster::image_io::{self, FinishedImage, ImageError, ImageFormat, LiveTemp};
use raycaster::scene::{self, Scene, Shape};
use sha2::{Digest, Sha256};
use std::collections::{BTreeMap, HashSet};
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// Member `index` (0-based) of `count`: a band of rows (`--tile`) or a batch shard (`--shard`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Split {
    pub index: u32,
    pub count: u32,
}

impl Split {
    /// `K/N` with `0 ≤ K < N`.
    pub fn parse(text: &str) -> Option<Split> {
        let (k, n) = text.split_once('/')?;
        let (index, count) = (k.parse::<u32>().ok()?, n.parse::<u32>().ok()?);
        (index < count).then_some(Split { index, count })
    }

    /// Band K of `height` rows as `(first_row, rows)`, rows counted from the top: rows
    /// `⌊K·H/N⌋ .. ⌊(K+1)·H/N⌋`, so band heights differ by at most one and the bands tile
    /// the image exactly.
    pub fn band(self, height: u32) -> (u32, u32) {
        let edge = |k: u32| (k as u64 * height as u64 / self.count as u64) as u32;
        let (first, end) = (edge(self.index), edge(self.index + 1));
        (first, end - first)
    }

    /// Whether this shard runs the batch's command number `command` (0-based).
    pub fn takes(self, command: usize) -> bool {
        command % self.count as usize == self.index as usize
    }
}

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
    /// [`Output::describe`]: kind, format, and the depth range where it is used.
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
    fn payload_bytes(&self, pixel_bytes: usize) -> u64 {
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

/// The flags that change pixels, as text. The CPU reference has its own intersection
/// tests, so the kernel's variants count only on the GPU; the GPU and the reference differ
/// in the last bits, so the backend counts.
pub fn flags_text(args: &RenderArgs, backend: &Backend) -> String {
    let shade_back = if args.shade_back { " -shade_back" } else { "" };
    match backend {
        Backend::Gpu(..) => format!(
            "--backend gpu --triangle-test {} --sphere-test {}{shade_back}",
            args.triangle_test.name(),
            args.sphere_test.name()
        ),
        Backend::Cpu => format!("--backend cpu{shade_back}"),
    }
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
    pub fn create(header: PartHeader, output: &Output) -> Result<PartWriter, ImageError> {
        let path = part_path(&output.path, header.index, header.identity.count);
        let fail = |message: String| ImageError { path: path.clone(), message };
        let (temp, file) = image_io::temp_beside(&path)?;
        let expected = header.payload_bytes(output.pixel_bytes());
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

/// The part headers of band `tile` for each output of a render.
pub fn part_headers(
    scene: &Scene,
    args: &RenderArgs,
    backend: &Backend,
    tile: Split,
    outputs: &[Output],
) -> Result<Vec<PartHeader>, String> {
    let scene_hash = scene_hash(scene)?;
    let flags = flags_text(args, backend);
    let (first_row, rows) = tile.band(args.height);
    Ok(outputs
        .iter()
        .map(|o| PartHeader {
            identity: Identity {
                width: args.width,
                height: args.height,
                count: tile.count,
                output: o.describe(),
                scene: scene_hash.clone(),
                flags: flags.clone(),
            },
            index: tile.index,
            first_row,
            rows,
        })
        .collect())
}

/// Why `stitch` refused: one line per problem found, every output checked.
#[derive(Debug)]
pub struct Refusal(pub Vec<String>);

/// A part file found beside an output, with its header read.
struct Part {
    path: PathBuf,
    header: PartHeader,
    /// Where the payload starts in the file.
    offset: u64,
}

/// Checks every output's parts and, when all are complete and from one render, writes the
/// stitched images (all of them, or none). Parts are deleted afterwards unless
/// `args.keep_parts`. Returns the parts stitched.
pub fn stitch(args: &StitchArgs) -> Result<usize, Refusal> {
    let outputs = output::outputs(&args.output, &args.normals, &args.depth);
    let scene_hash = match &args.input {
        Some(input) => {
            let scene = scene::load_scene(input).map_err(|e| Refusal(vec![e.to_string()]))?;
            Some(scene_hash(&scene).map_err(|e| Refusal(vec![e]))?)
        }
        None => None,
    };
    let mut problems = Vec::new();
    let mut plans = Vec::new();
    for o in &outputs {
        match check_parts(o, args.size, scene_hash.as_deref()) {
            Ok(parts) => plans.push((o, parts)),
            Err(mut p) => problems.append(&mut p),
        }
    }
    if !problems.is_empty() {
        return Err(Refusal(problems));
    }
    let fail = |e: ImageError| Refusal(vec![e.to_string()]);
    let mut finished = Vec::new();
    for (o, parts) in &plans {
        let id = &parts[0].header.identity;
        let mut sink = Sink::image(o, id.width, id.height).map_err(fail)?;
        for part in parts {
            copy_payload(part, o, &mut sink).map_err(fail)?;
        }
        finished.push(sink.finish().map_err(fail)?);
    }
    image_io::persist_all(finished).map_err(fail)?;
    let stitched = plans.iter().map(|(_, parts)| parts.len()).sum();
    if !args.keep_parts {
        for part in plans.iter().flat_map(|(_, parts)| parts) {
            // The images are in place: a part that cannot be removed costs only disk space.
            let _ = std::fs::remove_file(&part.path);
        }
    }
    Ok(stitched)
}

/// The parts of `output`, in band order, or every reason they cannot be stitched.
fn check_parts(output: &Output, size: Option<(u32, u32)>, scene_hash: Option<&str>) -> Result<Vec<Part>, Vec<String>> {
    let name = output.path.display();
    let found = find_parts(&output.path).map_err(|e| vec![format!("{name}: {e}")])?;
    if found.is_empty() {
        let pattern = part_path(&output.path, 0, 0).display().to_string().replace("part-0-of-0", "part-K-of-N");
        return Err(vec![format!("{name}: no part files ({pattern}) found")]);
    }
    let mut problems = Vec::new();
    let mut parts = Vec::new();
    for (index, count, path) in found {
        match read_part(&path, output) {
            Ok(part) if part.header.index != index || part.header.identity.count != count => problems.push(format!(
                "{}: renamed: its header says part {} of {}",
                path.display(),
                part.header.index,
                part.header.identity.count
            )),
            Ok(part) => parts.push(part),
            Err(e) => problems.push(format!("{}: {e}", path.display())),
        }
    }
    // The split most parts belong to is the render; parts of another split are strays.
    let mut counts = BTreeMap::new();
    parts.iter().for_each(|p| *counts.entry(p.header.identity.count).or_insert(0) += 1);
    let Some((&count, _)) = counts.iter().max_by_key(|&(&n, &found)| (found, n)) else { return Err(problems) };
    let first = parts.iter().find(|p| p.header.identity.count == count).expect("counted from the parts");
    let reference = first.header.identity.clone();
    let expected = Identity {
        width: size.map_or(reference.width, |s| s.0),
        height: size.map_or(reference.height, |s| s.1),
        output: output.describe(),
        scene: scene_hash.map_or(reference.scene.clone(), str::to_string),
        ..reference.clone()
    };
    let what_differs = |id: &Identity, against: &Identity| -> Vec<String> {
        let mut d = Vec::new();
        if (id.width, id.height) != (against.width, against.height) {
            d.push(format!("size {}×{} (not {}×{})", id.width, id.height, against.width, against.height));
        }
        if id.count != against.count {
            d.push(format!("split into {} (not {})", id.count, against.count));
        }
        if id.output != against.output {
            d.push(format!("output '{}' (not '{}')", id.output, against.output));
        }
        if id.scene != against.scene {
            let short = |hash: &str| hash.chars().take(12).collect::<String>();
            d.push(format!("scene {}… (not {}…)", short(&id.scene), short(&against.scene)));
        }
        if id.flags != against.flags {
            d.push(format!("flags '{}' (not '{}')", id.flags, against.flags));
        }
        d
    };
    // Against what the stitch command itself says first, then against the first part.
    let against_args = what_differs(&reference, &expected);
    if !against_args.is_empty() {
        problems.push(format!(
            "{name}: the parts (as {}) come from another render than asked for: {}",
            first.path.display(),
            against_args.join(", ")
        ));
    }
    for part in parts.iter().filter(|p| !std::ptr::eq(*p, first)) {
        let d = what_differs(&part.header.identity, &reference);
        if !d.is_empty() {
            problems.push(format!(
                "{}: from another render than {}: {}",
                part.path.display(),
                first.path.display(),
                d.join(", ")
            ));
        }
    }
    let present: HashSet<u32> =
        parts.iter().filter(|p| p.header.identity.count == reference.count).map(|p| p.header.index).collect();
    let missing: Vec<String> = (0..reference.count)
        .filter(|k| !present.contains(k))
        .map(|k| part_path(&output.path, k, reference.count).display().to_string())
        .collect();
    if !missing.is_empty() {
        problems.push(format!(
            "{name}: missing {} of {} parts: {}",
            missing.len(),
            reference.count,
            missing.join(", ")
        ));
    }
    for part in &parts {
        let band =
            Split { index: part.header.index, count: part.header.identity.count }.band(part.header.identity.height);
        if (part.header.first_row, part.header.rows) != band && part.header.index < part.header.identity.count {
            problems.push(format!("{}: holds rows that are not band {}", part.path.display(), part.header.index));
        }
    }
    if problems.is_empty() {
        Ok(parts)
    } else {
        Err(problems)
    }
}

/// The part files beside `output`: `(K, N, path)` sorted by N, then K.
fn find_parts(output: &Path) -> std::io::Result<Vec<(u32, u32, PathBuf)>> {
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

/// Reads a part's header and checks that the file holds exactly the payload it states.
fn read_part(path: &Path, output: &Output) -> Result<Part, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let length = file.metadata().map_err(|e| e.to_string())?.len();
    let mut head = Vec::new();
    file.take(MAX_HEADER).read_to_end(&mut head).map_err(|e| e.to_string())?;
    let (header, bytes, offset) = PartHeader::parse(&head)?;
    let expected = header.payload_bytes(output.pixel_bytes());
    if bytes != expected && header.identity.output == output.describe() {
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

/// Streams a part's pixels into `sink`, about 1 MiB of whole rows at a time.
fn copy_payload(part: &Part, output: &Output, sink: &mut Sink) -> Result<(), ImageError> {
    let fail = |e: std::io::Error| ImageError { path: part.path.clone(), message: e.to_string() };
    let mut file = std::fs::File::open(&part.path).map_err(fail)?;
    file.seek(SeekFrom::Start(part.offset)).map_err(fail)?;
    let mut reader = BufReader::new(file);
    let row_bytes = part.header.identity.width as usize * output.pixel_bytes();
    let rows_per_chunk = ((1 << 20) / row_bytes).max(1);
    let mut left = part.header.rows as usize;
    let mut buffer = Vec::new();
    while left > 0 {
        let rows = rows_per_chunk.min(left);
        buffer.resize(rows * row_bytes, 0);
        reader.read_exact(&mut buffer).map_err(fail)?;
        let pixels = match output.format {
            ImageFormat::Exr => {
                Pixels::Float(buffer.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
            }
            _ => Pixels::Rgb8(buffer.clone()),
        };
        sink.write(&pixels)?;
        left -= rows;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::cli::{parse_args, Command};

    #[test]
    fn bands_tile_the_image_and_differ_by_at_most_one_row() {
        let bands: Vec<_> = (0..3).map(|k| Split { index: k, count: 3 }.band(23)).collect();
        assert_eq!(bands, [(0, 7), (7, 8), (15, 8)]);
        for (height, count) in [(1, 1), (7, 7), (100, 7), (65535, 64), (5, 3)] {
            let mut next = 0;
            for index in 0..count {
                let (first, rows) = Split { index, count }.band(height);
                assert_eq!(first, next);
                assert!(rows == height / count || rows == height / count + 1, "{height}/{count}: {rows}");
                next = first + rows;
            }
            assert_eq!(next, height);
        }
    }

    #[test]
    fn shards_take_every_nth_command() {
        let shard = Split { index: 1, count: 3 };
        assert_eq!((0..8).filter(|&c| shard.takes(c)).collect::<Vec<_>>(), [1, 4, 7]);
    }

    #[test]
    fn parsing() {
        assert_eq!(Split::parse("2/5"), Some(Split { index: 2, count: 5 }));
        for bad in ["5/5", "0/0", "-1/3", "1", "a/b", "1/2/3", ""] {
            assert_eq!(Split::parse(bad), None, "{bad}");
        }
        let words = |line: &str| parse_args(line.split_whitespace());
        match words("-input s -size 4 9 -output o.exr --tile 1/3") {
            Ok(Command::Render(args)) => assert_eq!(args.tile, Some(Split { index: 1, count: 3 })),
            other => panic!("{other:?}"),
        }
        match words("batch f --shard 0/2") {
            Ok(Command::Batch { shard, .. }) => assert_eq!(shard, Some(Split { index: 0, count: 2 })),
            other => panic!("{other:?}"),
        }
        match words("stitch -depth 1 2 d.exr -size 4 9 --keep-parts") {
            Ok(Command::Stitch(s)) => {
                assert_eq!((s.size, s.keep_parts, s.output), (Some((4, 9)), true, None));
                assert_eq!(s.depth.map(|d| d.path), Some("d.exr".into()));
            }
            other => panic!("{other:?}"),
        }
        assert!(words("compare -input s -size 4 4 -output o.tga --tile 0/2").is_err(), "compare renders no band");
    }

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
