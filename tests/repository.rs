//! The repository's own text: what a merge can leave behind unnoticed by the compiler
//! (a README or a spec is not compiled).

use std::path::{Path, PathBuf};

/// The text files under `dir` (no build outputs), recursively.
fn text_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if path.is_dir() {
            if !matches!(name.as_str(), "target" | "dist" | "node_modules") && !name.starts_with('.') {
                text_files(&path, out);
            }
        } else if ["md", "rs", "wgsl", "toml", "sh", "py", "html", "js", "css", "txt"]
            .iter()
            .any(|ext| path.extension().is_some_and(|e| e == *ext))
        {
            out.push(path);
        }
    }
}

#[test]
fn no_merge_conflict_markers_are_left() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join(".ci/run")];
    text_files(root, &mut files);
    let mut found = Vec::new();
    for file in &files {
        let Ok(text) = std::fs::read_to_string(file) else { continue };
        for (n, line) in text.lines().enumerate() {
            if line.starts_with("<<<<<<< ") || line.starts_with(">>>>>>> ") || line == "=======" {
                found.push(format!("{}:{}: {line}", file.strip_prefix(root).unwrap().display(), n + 1));
            }
        }
    }
    assert!(files.len() > 50, "only {} files read", files.len());
    assert!(found.is_empty(), "conflict markers:\n{}", found.join("\n"));
}
