//! `raycaster grade`: a student's images for an assignment (a folder of them, or what their
//! program writes when run on each line of `commands.txt`) judged against our render of the
//! same lines, image by image, with ꟻLIP ([`raycaster::flip`]) and the count of pixels more
//! than one level off; a line per image on stdout, and an HTML page with the pictures.

pub mod course;
pub mod html;
pub mod student;

use crate::app::args::{GradeArgs, Judged, Thresholds};
use crate::app::progress::Progress;
use course::CourseLine;
use html::{Card, Mark, Page, Panel};
use image::RgbImage;
use raycaster::flip::{self, ErrorMap};
use raycaster::renderer::Renderer;
use std::path::{Path, PathBuf};

/// How far a judged image is from ours.
#[derive(Clone, Debug)]
pub struct Scores {
    pub flip_mean: f64,
    /// The 99th percentile of the FLIP errors: a small region that is badly wrong (a missing
    /// shadow) shows here even where the mean stays low.
    pub flip_p99: f32,
    /// Pixels with a channel more than 1 level off.
    pub off: usize,
    pub map: ErrorMap,
}

/// ꟻLIP and the pixels off of `test` against `reference`, which must be of one size.
pub fn compare_images(reference: &RgbImage, test: &RgbImage) -> Scores {
    let map = flip::flip(reference, test, flip::DEFAULT_PIXELS_PER_DEGREE);
    Scores {
        flip_mean: map.mean(),
        flip_p99: map.percentile(0.99),
        off: raycaster::metrics::image_diff(reference, test).off_by_more_than_one,
        map,
    }
}

/// What became of one image.
#[derive(Clone, Debug)]
pub enum Verdict {
    Pass,
    /// Judged, and past a threshold: which ones.
    Fail(String),
    /// Not judged: no image, an unreadable one, one of another size, or no render of ours.
    NotJudged(String),
}

/// One image of the assignment, judged.
pub struct Graded {
    pub line: usize,
    pub command: String,
    pub name: PathBuf,
    pub reference: Result<RgbImage, String>,
    pub judged: Result<RgbImage, String>,
    pub scores: Option<Scores>,
    pub verdict: Verdict,
    /// How the student's program ended, where that went wrong (`--run`).
    pub trouble: Option<String>,
    pub stderr_tail: String,
}

impl Graded {
    pub fn passed(&self) -> bool {
        matches!(self.verdict, Verdict::Pass)
    }

    /// Worst first: images not judged, then by FLIP mean.
    fn badness(&self) -> (bool, f64) {
        (!self.passed(), self.scores.as_ref().map_or(f64::INFINITY, |s| s.flip_mean))
    }

    /// How an image that was not judged is called: `MISSING` when there is no file,
    /// `ERROR` when ours could not be rendered, `FAIL` for one unreadable or of another size.
    fn not_judged_word(&self) -> &'static str {
        match (&self.reference, &self.judged) {
            (Err(_), _) => "ERROR",
            (_, Err(why)) if why.starts_with("no file") => "MISSING",
            _ => "FAIL",
        }
    }

    /// The line of the report on stdout, the image's name padded to `width`.
    pub fn report_line(&self, width: usize) -> String {
        let name = self.name.display().to_string();
        let line = self.line;
        match (&self.verdict, &self.scores) {
            (Verdict::NotJudged(why), _) => format!("{:<7} {name:<width$} {why} (line {line})", self.not_judged_word()),
            (verdict, Some(s)) => {
                let word = if self.passed() { "pass" } else { "FAIL" };
                let why = match verdict {
                    Verdict::Fail(why) => format!("  {why}"),
                    _ => String::new(),
                };
                let trouble = self.trouble.as_ref().map_or(String::new(), |t| format!("; {t}"));
                format!(
                    "{word:<7} {name:<width$} FLIP mean {:.4}  p99 {:.4}  {} px off{why} (line {line}{trouble})",
                    s.flip_mean, s.flip_p99, s.off
                )
            }
            (_, None) => format!("MISSING {name:<width$} (line {line})"),
        }
    }
}

/// The verdict `thresholds` give `scores`.
pub fn verdict(scores: &Scores, thresholds: &Thresholds) -> Verdict {
    let mut past = Vec::new();
    if scores.flip_mean > thresholds.max_flip_mean {
        past.push(format!("FLIP mean > {}", thresholds.max_flip_mean));
    }
    if f64::from(scores.flip_p99) > thresholds.max_flip_p99 {
        past.push(format!("FLIP p99 > {}", thresholds.max_flip_p99));
    }
    if let Some(max) = thresholds.max_diff_pixels.filter(|&max| scores.off as u64 > max) {
        past.push(format!("pixels off > {max}"));
    }
    if past.is_empty() {
        Verdict::Pass
    } else {
        Verdict::Fail(past.join(", "))
    }
}

/// Grades every image of `args.assignment`'s command lines, in their order; `note` gets a
/// line about each command line whose render of ours failed. `Err`: the assignment or the
/// student's folder cannot be read at all.
pub fn grade(args: &GradeArgs, backend: &Renderer, progress: bool) -> Result<Vec<Graded>, String> {
    let lines = course::read_lines(&args.assignment)?;
    let ours = tempfile::Builder::new().prefix("raycaster-reference-").tempdir().map_err(|e| e.to_string())?;
    let workspace = match &args.judged {
        Judged::Run { command, time_limit } => Some(student::Workspace::new(&args.assignment, command, *time_limit)?),
        Judged::Images(_) => None,
    };
    let bar = Progress::new(progress, lines.len() as u64, "lines");
    let mut graded = Vec::new();
    for line in &lines {
        let rendered = course::render_into(line, &args.assignment, ours.path(), backend);
        let run = workspace.as_ref().map(|w| w.run(line));
        let judged_dir = workspace.as_ref().map(|w| w.path());
        for name in &line.images {
            let reference = rendered.clone().and_then(|()| read(&ours.path().join(name)));
            let judged = match (&args.judged, judged_dir) {
                // The copy is deleted afterwards: its path would only puzzle the reader.
                (_, Some(dir)) => read(&dir.join(name)).map_err(|e| {
                    if dir.join(name).exists() {
                        e
                    } else {
                        "no file written".to_string()
                    }
                }),
                (Judged::Images(dir), None) => find_image(dir, name).and_then(|path| read(&path)),
                (Judged::Run { .. }, None) => unreachable!("a run has its workspace"),
            };
            let trouble = run.as_ref().and_then(|r| r.ending.trouble());
            let stderr_tail = run.as_ref().map_or(String::new(), |r| r.stderr_tail.clone());
            graded.push(judge(line, name, reference, judged, trouble, stderr_tail, &args.thresholds));
        }
        if let Err(why) = &line.args {
            graded.push(unparsed(line, why));
        }
        bar.advance(1);
    }
    Ok(graded)
}

/// A command line of the assignment that we cannot parse: nothing of it can be judged,
/// which the teacher must see.
fn unparsed(line: &CourseLine, why: &str) -> Graded {
    Graded {
        line: line.number,
        command: line.text.clone(),
        name: PathBuf::from(format!("commands.txt:{}", line.number)),
        reference: Err(why.to_string()),
        judged: Err("not judged".into()),
        scores: None,
        verdict: Verdict::NotJudged(format!("our parser refuses the line: {why}")),
        trouble: None,
        stderr_tail: String::new(),
    }
}

fn judge(
    line: &CourseLine,
    name: &Path,
    reference: Result<RgbImage, String>,
    judged: Result<RgbImage, String>,
    trouble: Option<String>,
    stderr_tail: String,
    thresholds: &Thresholds,
) -> Graded {
    let (scores, verdict) = match (&reference, &judged) {
        (Err(why), _) => (None, Verdict::NotJudged(format!("no render of ours: {why}"))),
        (_, Err(why)) => {
            let why = trouble.as_ref().map_or(why.clone(), |t| format!("{why}: {t}"));
            (None, Verdict::NotJudged(why))
        }
        (Ok(ours), Ok(theirs)) if ours.dimensions() != theirs.dimensions() => {
            let why = format!("is {}×{}, ours {}×{}", theirs.width(), theirs.height(), ours.width(), ours.height());
            (None, Verdict::NotJudged(why))
        }
        (Ok(ours), Ok(theirs)) => {
            let scores = compare_images(ours, theirs);
            let verdict = verdict(&scores, thresholds);
            (Some(scores), verdict)
        }
    };
    Graded {
        line: line.number,
        command: line.text.clone(),
        name: name.to_path_buf(),
        reference,
        judged,
        scores,
        verdict,
        trouble,
        stderr_tail,
    }
}

/// The student's image named `name` in `dir`: that file, else one of the same name in the
/// other format (a teacher may have converted TGA files to PNG to look at them).
fn find_image(dir: &Path, name: &Path) -> Result<PathBuf, String> {
    let exact = dir.join(name);
    if exact.is_file() {
        return Ok(exact);
    }
    let other = ["png", "tga"].iter().map(|ext| exact.with_extension(ext)).find(|p| p.is_file());
    other.ok_or_else(|| format!("no file {}", exact.display()))
}

/// An image as 8-bit RGB; `Err` says why it cannot be read.
fn read(path: &Path) -> Result<RgbImage, String> {
    if !path.is_file() {
        return Err(format!("no file {}", path.display()));
    }
    raycaster::image_io::read_image(path).map_err(|e| format!("unreadable: {e}"))
}

/// The report on stdout: a line per image, then the count.
pub fn report(graded: &[Graded]) -> String {
    let width = graded.iter().map(|g| g.name.display().to_string().chars().count()).max().unwrap_or(0);
    let mut text: String = graded.iter().map(|g| g.report_line(width) + "\n").collect();
    let passed = graded.iter().filter(|g| g.passed()).count();
    text += &format!("grade: {passed} of {} images pass\n", graded.len());
    text
}

/// The HTML page: every image worst first, ours, theirs and the ꟻLIP map side by side.
pub fn write_html(path: &Path, args: &GradeArgs, graded: &[Graded]) -> Result<(), String> {
    let mut page = Page::new(path)?;
    let passed = graded.iter().filter(|g| g.passed()).count();
    let source = match &args.judged {
        Judged::Images(dir) => format!("images of {}", dir.display()),
        Judged::Run { command, .. } => format!("the images `{command}` wrote"),
    };
    page.paragraph(&format!(
        "{} judged against our render of {}: {passed} of {} images pass. Thresholds: FLIP mean ≤ {}, \
         FLIP 99th percentile ≤ {}{}. The FLIP map shows how visible each pixel's difference is, \
         from black (none) through purple and orange to yellow.",
        source,
        args.assignment.join("commands.txt").display(),
        graded.len(),
        args.thresholds.max_flip_mean,
        args.thresholds.max_flip_p99,
        args.thresholds
            .max_diff_pixels
            .map_or(String::new(), |n| format!(", at most {n} pixels more than 1 level off")),
    ));
    let mut order: Vec<&Graded> = graded.iter().collect();
    order.sort_by(|a, b| b.badness().partial_cmp(&a.badness()).unwrap_or(std::cmp::Ordering::Equal));
    for g in order {
        page.card(&card(g))?;
    }
    page.finish(&format!("raycaster grade: {}", args.assignment.display()))
}

fn card(g: &Graded) -> Card {
    let mut lines = vec![format!("line {}: {}", g.line, g.command), g.report_line(0)];
    if !g.stderr_tail.is_empty() {
        lines.push(format!("the program's stderr, last lines:\n{}", g.stderr_tail));
    }
    let map_panel = Panel {
        label: "FLIP error map".into(),
        image: g.scores.as_ref().map(|s| s.map.magma()).ok_or_else(|| "no FLIP map: not judged".to_string()),
    };
    Card {
        title: g.name.display().to_string(),
        mark: if g.passed() { Mark::Pass } else { Mark::Fail },
        lines,
        panels: vec![
            Panel { label: "ours (reference)".into(), image: g.reference.clone() },
            Panel { label: "judged".into(), image: g.judged.clone() },
            map_panel,
        ],
    }
}
