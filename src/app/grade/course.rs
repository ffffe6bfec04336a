//! An assignment's `commands.txt` as `grade` and `gallery` read it: which images each line
//! writes, and our own render of them into a folder of ours.

use crate::app::args::{Command, RenderArgs};
use crate::app::{cli, job, validate};
use raycaster::renderer::Renderer;
use std::path::{Path, PathBuf};

/// One command line of `commands.txt`, with the images it writes.
#[derive(Clone, Debug)]
pub struct CourseLine {
    /// 1-based, counting every line of the file.
    pub number: usize,
    /// The line as written (for the reports).
    pub text: String,
    /// The line's render; `Err` where we cannot parse it (then nothing of it is judged).
    pub args: Result<RenderArgs, String>,
    /// The image files it writes, as the line names them (relative to the folder).
    pub images: Vec<PathBuf>,
}

impl CourseLine {
    /// The line's words, as a program gets them after its own name.
    pub fn words(&self) -> Vec<&str> {
        self.text.split_whitespace().collect()
    }
}

/// The command lines of `folder/commands.txt` that write images, in order; lines that only
/// open the course's preview window (`-gui` without an output) write none and are left out,
/// and so are blank and `#` lines. `Err` names the file when it cannot be read.
pub fn read_lines(folder: &Path) -> Result<Vec<CourseLine>, String> {
    let file = folder.join("commands.txt");
    let text = std::fs::read_to_string(&file).map_err(|e| format!("{}: {e}", file.display()))?;
    let lines = text.lines().enumerate().filter_map(|(index, line)| {
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.first().is_none_or(|w| w.starts_with('#')) {
            return None;
        }
        let parsed = cli::parse_args(&words).and_then(|c| validate::check(&c).map(|()| c));
        let args = match parsed {
            Ok(Command::Render(args)) => Ok(args),
            Ok(_) => Err("not a render command line".to_string()),
            Err(e) => Err(e.0),
        };
        let images = args.as_ref().map(images_of).unwrap_or_default();
        let keep = args.is_err() || !images.is_empty();
        keep.then(|| CourseLine { number: index + 1, text: line.trim().to_string(), args, images })
    });
    Ok(lines.collect())
}

/// The files a render writes: its outputs, then its pictures.
fn images_of(args: &RenderArgs) -> Vec<PathBuf> {
    let outputs = args.files.named().into_iter().map(|(_, path)| path.to_path_buf());
    outputs.chain(args.pictures.named().into_iter().map(|(_, p)| p.path.clone())).collect()
}

/// Renders `line` as if run inside `folder` (its scene read from there), writing its images
/// under `into` at the paths the line names. `Err` says why it failed.
pub fn render_into(line: &CourseLine, folder: &Path, into: &Path, backend: &Renderer) -> Result<(), String> {
    let mut args = line.args.clone()?;
    args.input = folder.join(&args.input);
    args.gui = false;
    args.stats = false;
    let paths = [
        args.files.color.as_mut(),
        args.files.normals.as_mut(),
        args.files.depth.as_mut().map(|d| &mut d.path),
        args.pictures.samples.as_mut().map(|p| &mut p.path),
        args.pictures.filter.as_mut().map(|p| &mut p.path),
    ];
    for path in paths.into_iter().flatten() {
        *path = into.join(&*path);
    }
    for image in &line.images {
        if let Some(parent) = into.join(image).parent() {
            std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
        }
    }
    job::run(&args, backend, false).map(|_| ()).map_err(|e| e.to_string())
}
