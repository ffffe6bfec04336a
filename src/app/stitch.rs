//! `raycaster stitch`: checks the part files of a split render (see [`crate::app::part`])
//! and streams them, band by band, through the same writers a single render uses, so the
//! stitched files are byte for byte the single render's.

use crate::app::args::{Split, StitchArgs};
use crate::app::output_file::{OutputFile, Pixels, Sink};
use crate::app::part::{self, part_path, Identity, Part};
use raycaster::image_io::{self, ImageError, ImageFormat};
use raycaster::scene;
use std::collections::{BTreeMap, HashSet};
use std::io::{BufReader, Read, Seek, SeekFrom};

/// Why `stitch` refused: one line per problem found, every output checked.
#[derive(Debug)]
pub struct Refusal(pub Vec<String>);

/// Checks every output's parts and, when all are complete and from one render, writes the
/// stitched images (all of them, or none). Parts are deleted afterwards unless
/// `args.keep_parts`. Returns the parts stitched.
pub fn stitch(args: &StitchArgs) -> Result<usize, Refusal> {
    let outputs = OutputFile::list(&args.files);
    let scene_hash = match &args.input {
        Some(input) => {
            let scene = scene::load_scene(input).map_err(|e| Refusal(vec![e.to_string()]))?;
            Some(part::scene_hash(&scene).map_err(|e| Refusal(vec![e]))?)
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
fn check_parts(
    output: &OutputFile,
    size: Option<(u32, u32)>,
    scene_hash: Option<&str>,
) -> Result<Vec<Part>, Vec<String>> {
    let name = output.path.display();
    let found = part::find(&output.path).map_err(|e| vec![format!("{name}: {e}")])?;
    if found.is_empty() {
        let pattern = part_path(&output.path, 0, 0).display().to_string().replace("part-0-of-0", "part-K-of-N");
        return Err(vec![format!("{name}: no part files ({pattern}) found")]);
    }
    let mut problems = Vec::new();
    let mut parts = Vec::new();
    for (index, count, path) in found {
        match part::read(&path, &output.describe(), output.pixel_bytes()) {
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

/// Streams a part's pixels into `sink`, about 1 MiB of whole rows at a time.
fn copy_payload(part: &Part, output: &OutputFile, sink: &mut Sink) -> Result<(), ImageError> {
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
