//! An assignment's `commands.txt` as `grade` and `gallery` read it: which images each line
//! writes, and our own render of them into a folder of ours.

use crate::app::args::{Command, RenderArgs};
use crate::app::grade::untrusted;
use crate::app::{cli, job, validate};
use raycaster::renderer::Renderer;
use raycaster::scene::obj_file_names;
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
    /// The line's words, as a student's program gets them after its own name: the course's
    /// flags of its OpenGL preview left out (`-gui`, `-tessellation θ φ`, `-gouraud`). A
    /// preview opens a window and waits for a key, which in a sandbox without a display
    /// fails or runs to the time limit, saying nothing about the images.
    pub fn student_words(&self) -> Vec<String> {
        let mut words = Vec::new();
        let mut skip = 0;
        for word in self.text.split_whitespace() {
            match flag_name(word) {
                _ if skip > 0 => skip -= 1,
                Some("gui" | "gouraud") => {}
                Some("tessellation") => skip = 2,
                _ => words.push(word.to_string()),
            }
        }
        words
    }
}

/// A flag's name as the table spells it (`-gui`, `--gui` → `gui`); `None` for a value.
fn flag_name(word: &str) -> Option<&str> {
    let name = word.strip_prefix("--").or_else(|| word.strip_prefix('-'))?;
    name.starts_with(|c: char| c.is_ascii_alphabetic()).then_some(name)
}

/// Why an assignment's command lines cannot be graded.
#[derive(Debug)]
pub enum CourseError {
    /// `commands.txt` cannot be read.
    Unreadable(String),
    /// A line writes an image outside the assignment's folder: rendering or running it
    /// would write (or a clean-up delete) a file of the teacher's elsewhere.
    Outside(String),
}

impl std::fmt::Display for CourseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CourseError::Unreadable(why) | CourseError::Outside(why) => f.write_str(why),
        }
    }
}

/// The command lines of `folder/commands.txt` that write images, in order; lines that only
/// open the course's preview window (`-gui` without an output) write none and are left out,
/// and so are blank and `#` lines. `Err` names the file when it cannot be read, and the line
/// and the file when a line writes an image outside the folder.
pub fn read_lines(folder: &Path) -> Result<Vec<CourseLine>, CourseError> {
    let file = folder.join("commands.txt");
    let text =
        std::fs::read_to_string(&file).map_err(|e| CourseError::Unreadable(format!("{}: {e}", file.display())))?;
    let lines: Vec<CourseLine> = text
        .lines()
        .enumerate()
        .filter_map(|(index, line)| {
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
        })
        .collect();
    for line in &lines {
        for name in &line.images {
            if let Some(why) = untrusted::outside_reason(name) {
                return Err(CourseError::Outside(format!(
                    "{}:{}: {} {why}: a command line's images must stay inside the assignment's folder",
                    file.display(),
                    line.number,
                    name.display()
                )));
            }
        }
    }
    Ok(lines)
}

/// What a student's program needs in its working folder for `line`: the scene, and the
/// meshes it names (beside the scene, or in the folder, where the course's scenes find
/// them), as (the file, its path relative to the folder). A path may climb out of the folder
/// (`-input ../scene.txt`): it is placed where it would be from a working folder at the top.
pub fn inputs_of(line: &CourseLine, folder: &Path) -> Vec<(PathBuf, PathBuf)> {
    let Ok(args) = &line.args else { return Vec::new() };
    let mut inputs = vec![args.input.clone()];
    if let Ok(text) = std::fs::read_to_string(folder.join(&args.input)) {
        let scene_folder = args.input.parent().unwrap_or(Path::new("")).to_path_buf();
        for name in obj_file_names(&text).into_iter().map(PathBuf::from).filter(|n| n.is_relative()) {
            inputs.extend([scene_folder.join(&name), name.clone()]);
        }
    }
    inputs.sort();
    inputs.dedup();
    inputs.into_iter().filter(|relative| folder.join(relative).is_file()).map(|r| (folder.join(&r), r)).collect()
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
