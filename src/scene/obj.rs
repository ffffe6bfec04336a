//! A small Wavefront OBJ reader: just the positions and faces a ray caster needs, with
//! errors that point at the OBJ file's line and column.
//!
//! Understood lines: `v x y z [w]` (w and any further values ignored) and
//! `f a b c ...` whose entries are `i`, `i/t`, `i/t/n` or `i//n` (only the vertex index
//! `i` is used). Indices are 1-based; negative ones count back from the last vertex read so
//! far. Positive indices may refer to vertices defined later in the file (they are checked
//! once the whole file is read). Faces with more than three vertices are fan-triangulated
//! as (v0, vi, vi+1). Every other line kind (`vn`, `vt`, `g`, `o`, `s`, `usemtl`, `mtllib`,
//! ...) and `#` comments are ignored; CRLF line ends are fine.

use super::error::SceneError;
use super::lexer::{char_count, describe, parse_decimal, read_source};
use super::model::{Location, Mesh};
use glam::DVec3;
use std::path::Path;

/// Reads and parses the OBJ file at `path`.
pub fn load_obj(path: &Path) -> Result<Mesh, SceneError> {
    let text = read_source(path)?;
    parse_obj(&text, path)
}

/// Parses OBJ text; `path` is used in error messages and stored in the [`Mesh`].
pub fn parse_obj(text: &str, path: &Path) -> Result<Mesh, SceneError> {
    let mut reader = ObjReader {
        path,
        positions: Vec::new(),
        triangles: Vec::new(),
        vertex_locations: Vec::new(),
        forward_refs: Vec::new(),
    };
    for (index, line) in text.split('\n').enumerate() {
        let line_number = u32::try_from(index + 1).unwrap_or(u32::MAX);
        reader.line(line_number, line)?;
    }
    reader.check_forward_refs()?;
    Ok(Mesh {
        path: path.to_path_buf(),
        positions: reader.positions,
        triangles: reader.triangles,
        vertex_locations: reader.vertex_locations,
    })
}

struct ObjReader<'p> {
    path: &'p Path,
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    vertex_locations: Vec<Location>,
    /// Positive indices beyond the vertices read so far, to check at the end of the file.
    forward_refs: Vec<(u64, Location)>,
}

/// A word of an OBJ line with the place where it starts.
struct Word<'a> {
    text: &'a str,
    location: Location,
}

/// The words of one line (comment removed), located in the file.
fn words(line_number: u32, line: &str) -> impl Iterator<Item = Word<'_>> {
    let content = line.split('#').next().unwrap_or("");
    // Columns are counted on from the previous word, not from the start of the line: a face
    // line of a million entries must not cost a million prefix scans.
    let (mut col, mut counted) = (1u32, 0usize);
    content.split_whitespace().map(move |text| {
        // `text` is a subslice of `content`, so the pointer difference is its byte offset.
        let offset = text.as_ptr() as usize - content.as_ptr() as usize;
        col = col.saturating_add(content.get(counted..offset).map_or(0, char_count));
        counted = offset;
        Word { text, location: Location { line: line_number, col } }
    })
}

impl ObjReader<'_> {
    fn line(&mut self, line_number: u32, line: &str) -> Result<(), SceneError> {
        let mut words = words(line_number, line);
        let Some(keyword) = words.next() else {
            return Ok(());
        };
        match keyword.text {
            "v" => self.vertex(&keyword, words),
            "f" => self.face(&keyword, words),
            _ => Ok(()),
        }
    }

    fn error(&self, location: Location, message: impl Into<String>) -> SceneError {
        SceneError::at(self.path, location, message)
    }

    fn vertex<'a>(&mut self, keyword: &Word, mut words: impl Iterator<Item = Word<'a>>) -> Result<(), SceneError> {
        let mut xyz = [0.0; 3];
        for (n, value) in xyz.iter_mut().enumerate() {
            let word = words.next().ok_or_else(|| {
                self.error(keyword.location, format!("vertex has {n} coordinates, expected 3 (`v x y z`)"))
            })?;
            *value = parse_decimal(word.text).ok_or_else(|| {
                self.error(word.location, format!("expected a number, found {}", describe(word.text)))
            })?;
        }
        self.positions.push(DVec3::from_array(xyz));
        self.vertex_locations.push(keyword.location);
        Ok(())
    }

    fn face<'a>(&mut self, keyword: &Word, words: impl Iterator<Item = Word<'a>>) -> Result<(), SceneError> {
        let mut first = None;
        let mut previous = None;
        let mut count = 0;
        for word in words {
            let index = self.vertex_index(&word)?;
            count += 1;
            if let (Some(v0), Some(vi)) = (first, previous) {
                self.triangles.push([v0, vi, index]);
            }
            if first.is_none() {
                first = Some(index);
            } else {
                previous = Some(index);
            }
        }
        if count < 3 {
            return Err(self.error(keyword.location, format!("face has {count} vertices, expected at least 3")));
        }
        Ok(())
    }

    /// The 0-based vertex index of a face entry (`i`, `i/t`, `i/t/n` or `i//n`).
    fn vertex_index(&mut self, word: &Word) -> Result<u32, SceneError> {
        let text = word.text.split('/').next().unwrap_or("");
        let index = parse_index(text).ok_or_else(|| {
            self.error(word.location, format!("expected a vertex index, found {}", describe(word.text)))
        })?;
        let read_so_far = self.positions.len() as u64;
        let resolved = match index {
            0 => return Err(self.error(word.location, "vertex index 0 is invalid (OBJ indices start at 1)")),
            i if i > 0 => {
                let i = i.unsigned_abs();
                if i > read_so_far {
                    self.forward_refs.push((i, word.location));
                }
                i - 1
            }
            i => read_so_far.checked_sub(i.unsigned_abs()).ok_or_else(|| {
                self.error(
                    word.location,
                    format!("vertex index {i} out of range: only {read_so_far} vertices read so far"),
                )
            })?,
        };
        u32::try_from(resolved)
            .map_err(|_| self.error(word.location, format!("vertex index {index} out of range: too large")))
    }

    fn check_forward_refs(&self) -> Result<(), SceneError> {
        let total = self.positions.len() as u64;
        match self.forward_refs.iter().find(|(index, _)| *index > total) {
            Some((index, location)) => {
                Err(self.error(*location, format!("vertex index {index} out of range: the file has {total} vertices")))
            }
            None => Ok(()),
        }
    }
}

/// An optionally signed decimal integer.
fn parse_index(text: &str) -> Option<i64> {
    let digits = text.strip_prefix(['+', '-']).unwrap_or(text);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Mesh, SceneError> {
        parse_obj(text, Path::new("m.obj"))
    }

    #[test]
    fn fans_slashes_negative_and_forward_indices() {
        let mesh =
            parse("# c\r\nv 0 0 0\r\nvn 0 0 1\nv 1 0 0 1\nv 1 1 0\nf 1/1/1 2//1 3/4 4\nf -1 -2 -3\nv 0 1 0\n").unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [2, 1, 0]]);
        let lines: Vec<_> = mesh.vertex_locations.iter().map(|l| (l.line, l.col)).collect();
        assert_eq!(lines, vec![(2, 1), (4, 1), (5, 1), (8, 1)]);
    }

    #[test]
    fn located_errors() {
        let err = |text: &str| parse(text).unwrap_err().to_string();
        assert_eq!(
            err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"),
            "m.obj:4:7: vertex index 4 out of range: the file has 3 vertices"
        );
        assert_eq!(err("v 0 0 0\nf 1 -2 1\n"), "m.obj:2:5: vertex index -2 out of range: only 1 vertices read so far");
        assert_eq!(err("v 0 0 0\nf 1 0 1\n"), "m.obj:2:5: vertex index 0 is invalid (OBJ indices start at 1)");
        assert_eq!(err("v 0 0 0\n  f 1 1\n"), "m.obj:2:3: face has 2 vertices, expected at least 3");
        assert_eq!(err("v 0 nan 0\n"), "m.obj:1:5: expected a number, found `nan`");
        assert_eq!(err("v 0 0\n"), "m.obj:1:1: vertex has 2 coordinates, expected 3 (`v x y z`)");
        assert_eq!(err("v 0 0 0\nf 1 x 1\n"), "m.obj:2:5: expected a vertex index, found `x`");
        assert_eq!(err("v 0 0 0\nf 1 1 99999999999\n"), "m.obj:2:7: vertex index 99999999999 out of range: too large");
    }
}
