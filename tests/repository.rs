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

/// GitHub's anchor of a Markdown heading: lower case, spaces to hyphens, and only letters,
/// digits, `-` and `_` kept (`## 1. Command line` → `1-command-line`).
fn anchor_of(heading: &str) -> String {
    let kept = |c: &char| c.is_alphanumeric() || matches!(c, '-' | '_' | ' ');
    heading.trim().to_lowercase().chars().filter(kept).map(|c| if c == ' ' { '-' } else { c }).collect()
}

/// The lines of a Markdown file outside its code blocks.
fn prose_lines(text: &str) -> Vec<&str> {
    let mut in_code = false;
    let mut lines = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
        } else if !in_code {
            lines.push(line);
        }
    }
    lines
}

/// The anchors of a Markdown file's headings.
fn anchors(text: &str) -> Vec<String> {
    let headings = prose_lines(text).into_iter().filter_map(|l| l.strip_prefix('#'));
    headings.map(|h| anchor_of(h.trim_start_matches('#'))).collect()
}

/// Every relative link of every Markdown file here (`[text](path#anchor)`, pictures
/// included) names a file that exists and, where it names a heading, one the file has: the
/// README and docs/ are cited by each other, by the code and by the scenes, and a section
/// moved or renamed would otherwise leave its links dead unnoticed.
#[test]
fn markdown_links_name_files_and_headings_that_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    text_files(root, &mut files);
    let mut dead = Vec::new();
    let mut checked = 0;
    for file in files.iter().filter(|f| f.extension().is_some_and(|e| e == "md")) {
        let text = std::fs::read_to_string(file).unwrap();
        for line in prose_lines(&text) {
            for (_, rest) in line.match_indices("](").map(|(k, _)| line.split_at(k + 2)) {
                let Some(end) = rest.find(')') else { continue };
                let target = &rest[..end];
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                let (path, anchor) = target.split_once('#').unwrap_or((target, ""));
                let linked = if path.is_empty() { file.clone() } else { file.parent().unwrap().join(path) };
                let name = file.strip_prefix(root).unwrap().display();
                checked += 1;
                if !linked.exists() {
                    dead.push(format!("{name}: {target}: no such file"));
                } else if !anchor.is_empty() && linked.extension().is_some_and(|e| e == "md") {
                    let headings = anchors(&std::fs::read_to_string(&linked).unwrap());
                    if !headings.iter().any(|h| h == anchor) {
                        dead.push(format!("{name}: {target}: no such heading"));
                    }
                }
            }
        }
    }
    assert!(checked > 20, "only {checked} links found");
    assert!(dead.is_empty(), "dead links:\n{}", dead.join("\n"));
}
