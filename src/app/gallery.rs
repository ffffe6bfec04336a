//! `raycaster gallery CORPUS --html FILE`: every image of every assignment's
//! `commands.txt` (the `a2` … `a7` folders of the course's files), rendered by us, on one
//! page, with the course's own image beside ours where `aN/expected/` has one and the ꟻLIP
//! map between them: what the course's scenes should look like, for a student who has
//! nothing to compare with.

use crate::app::args::GalleryArgs;
use crate::app::grade::compare_images;
use crate::app::grade::course::{self, CourseLine};
use crate::app::grade::html::{Card, Mark, Page, Panel};
use crate::app::progress::Progress;
use image::RgbImage;
use raycaster::renderer::Renderer;
use std::path::{Path, PathBuf};

/// What the gallery holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Count {
    pub images: usize,
    /// Of which the course has an image of its own.
    pub with_course_image: usize,
    /// Command lines we could not render (they are on the page, with why).
    pub failed_lines: usize,
}

/// Renders every assignment of `args.corpus` and writes the page; `Err` when the corpus
/// has no assignment or the page cannot be written.
pub fn gallery(args: &GalleryArgs, backend: &Renderer, progress: bool) -> Result<Count, String> {
    let folders = assignments(&args.corpus)?;
    let mut page = Page::new(&args.html)?.tiled();
    page.paragraph(&format!(
        "Every image of the course's command lines under {}, rendered by raycaster; beside it the \
         course's own image where the course gives one, and the FLIP map between the two (black: no \
         visible difference; purple, orange, yellow: more and more visible).",
        args.corpus.display()
    ));
    let mut count = Count::default();
    for folder in folders {
        let lines = course::read_lines(&folder).map_err(|e| e.to_string())?;
        let name = folder.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
        page.section(&name, &format!("{name}: {} command lines", lines.len()));
        let scratch = tempfile::Builder::new().prefix("raycaster-gallery-").tempdir().map_err(|e| e.to_string())?;
        let bar = Progress::new(progress, lines.len() as u64, &format!("{name} lines"));
        for line in &lines {
            let rendered = course::render_into(line, &folder, scratch.path(), backend);
            count.failed_lines += usize::from(rendered.is_err());
            for image in &line.images {
                let ours = rendered.clone().and_then(|()| read(&scratch.path().join(image)));
                let theirs = course_image(&folder, image);
                count.images += 1;
                count.with_course_image += usize::from(theirs.is_some());
                page.card(&card(line, image, ours, theirs))?;
            }
            bar.advance(1);
        }
    }
    page.finish("raycaster gallery: the MIT 6.837 assignments")?;
    Ok(count)
}

/// The course's assignment folders under `corpus` (`a2`, `a3`, …, each with a
/// `commands.txt`), in their numbers' order.
fn assignments(corpus: &Path) -> Result<Vec<PathBuf>, String> {
    let entries = std::fs::read_dir(corpus).map_err(|e| format!("{}: {e}", corpus.display()))?;
    let mut folders: Vec<(u32, PathBuf)> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("commands.txt").is_file())
        .filter_map(|p| {
            let number = p.file_name()?.to_str()?.strip_prefix('a')?.parse().ok()?;
            Some((number, p))
        })
        .collect();
    folders.sort();
    if folders.is_empty() {
        return Err(format!("{}: no assignment folders (a2, a3, … with a commands.txt)", corpus.display()));
    }
    Ok(folders.into_iter().map(|(_, p)| p).collect())
}

/// The course's own picture of `image`: `expected/` holds them as PNG, named as the
/// command line names its file.
fn course_image(folder: &Path, image: &Path) -> Option<RgbImage> {
    let name = Path::new(image.file_name()?).with_extension("png");
    raycaster::image_io::read_image(&folder.join("expected").join(name)).ok()
}

fn read(path: &Path) -> Result<RgbImage, String> {
    raycaster::image_io::read_image(path).map_err(|e| e.to_string())
}

/// Ours, the course's image where there is one, and the ꟻLIP map of ours against it.
fn card(line: &CourseLine, image: &Path, ours: Result<RgbImage, String>, theirs: Option<RgbImage>) -> Card {
    let mut lines = vec![format!("line {}: {}", line.number, line.text)];
    let scores = match (&ours, &theirs) {
        (Ok(ours), Some(theirs)) if ours.dimensions() == theirs.dimensions() => Some(compare_images(theirs, ours)),
        (Ok(ours), Some(theirs)) => {
            lines.push(format!(
                "the course's image is {}×{}, ours {}×{}",
                theirs.width(),
                theirs.height(),
                ours.width(),
                ours.height()
            ));
            None
        }
        _ => None,
    };
    let mut panels = vec![Panel { label: "raycaster".into(), image: ours }];
    if let Some(theirs) = theirs {
        panels.push(Panel { label: "the course's image".into(), image: Ok(theirs) });
    }
    if let Some(s) = scores {
        lines.push(format!(
            "against the course's: FLIP mean {:.4}, p99 {:.4}, {} px more than 1 level off",
            s.flip_mean, s.flip_p99, s.off
        ));
        panels.push(Panel { label: "FLIP map, ours against the course's".into(), image: Ok(s.map.magma()) });
    }
    Card { title: image.display().to_string(), mark: Mark::Plain, lines, panels }
}
