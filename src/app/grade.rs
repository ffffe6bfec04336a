//! `raycaster grade`: a student's images for an assignment (a folder of them, or what their
//! program writes when run on each line of `commands.txt`) judged against our render of the
//! same lines, image by image, with ꟻLIP ([`raycaster::flip`]) and the count of pixels more
//! than one level off; a line per image on stdout, and an HTML page with the pictures.

pub mod course;
pub mod html;
#[cfg(target_os = "linux")]
pub mod keeper;
#[cfg(target_os = "linux")]
pub mod sandbox;
pub mod stderr;
pub mod student;
pub mod untrusted;

use crate::app::args::{GradeArgs, Judged, LimitKind, Thresholds};
use crate::app::exit::{say, Failure};
use crate::app::progress::Progress;
use crate::app::scratch::Scratch;
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

/// The scores of [`Scores`] without the map, kept for the report once the page has it.
#[derive(Clone, Copy, Debug)]
pub struct Summary {
    pub flip_mean: f64,
    pub flip_p99: f32,
    pub off: usize,
}

/// One image of the assignment, judged. Its pictures are not kept: the page's card was
/// written when it was judged, so that a run holds at most one line's images at a time.
pub struct Graded {
    pub line: usize,
    pub command: String,
    pub name: PathBuf,
    /// Whether ours was rendered and read, or why not.
    pub reference: Result<(), String>,
    /// Whether theirs was read, or why not.
    pub judged: Result<(), String>,
    pub scores: Option<Summary>,
    pub verdict: Verdict,
    /// How the student's program ended, where that went wrong (`--run`).
    pub trouble: Option<String>,
    /// The limits the line's run hit (`--run`).
    pub hits: Vec<LimitKind>,
    pub stderr_tail: String,
    /// The page's card of the image (`--html`).
    card: Option<String>,
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

    /// What went wrong with the run besides the image: how it ended, the limits it hit.
    fn run_notes(&self) -> String {
        let trouble = self.trouble.as_ref().map_or(String::new(), |t| format!("; {t}"));
        trouble + &self.hits_note()
    }

    /// `; limit hit: cpu, file`, or nothing.
    fn hits_note(&self) -> String {
        if self.hits.is_empty() {
            return String::new();
        }
        let names: Vec<&str> = self.hits.iter().map(|h| h.name()).collect();
        format!("; limit hit: {}", names.join(", "))
    }

    /// The line of the report on stdout, the image's name padded to `width`.
    pub fn report_line(&self, width: usize) -> String {
        let name = self.name.display().to_string();
        let line = self.line;
        match (&self.verdict, &self.scores) {
            (Verdict::NotJudged(why), _) => {
                format!("{:<7} {name:<width$} {why} (line {line}{})", self.not_judged_word(), self.hits_note())
            }
            (verdict, Some(s)) => {
                let word = if self.passed() { "pass" } else { "FAIL" };
                let why = match verdict {
                    Verdict::Fail(why) => format!("  {why}"),
                    _ => String::new(),
                };
                format!(
                    "{word:<7} {name:<width$} FLIP mean {:.4}  p99 {:.4}  {} px off{why} (line {line}{})",
                    s.flip_mean,
                    s.flip_p99,
                    s.off,
                    self.run_notes()
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

/// The prefix of grade's private folders under the system's temporary folder.
const SCRATCH_PREFIX: &str = "raycaster-grade-";

/// Grades every image of `args.assignment`'s command lines, in their order, writing each
/// image's card of the page (`--html`) as it is judged. `Err`: the assignment or the
/// student's folder cannot be used at all (status 2 where the teacher's input is at fault).
pub fn grade(args: &GradeArgs, backend: &Renderer, progress: bool, verbose: bool) -> Result<Report, Failure> {
    let lines = course::read_lines(&args.assignment).map_err(|e| match e {
        course::CourseError::Outside(why) => Failure::BadInput(format!("grade: {why}")),
        course::CourseError::Unreadable(why) => Failure::Failed(format!("grade: {why}")),
    })?;
    let failed = |e: String| Failure::Failed(format!("grade: {e}"));
    let scratch = Scratch::new(SCRATCH_PREFIX).map_err(|e| failed(format!("a private folder: {e}")))?;
    let ours = scratch.path().join("reference");
    std::fs::create_dir(&ours).map_err(|e| failed(e.to_string()))?;
    let student = match &args.judged {
        Judged::Run(run) => {
            let hidden = hidden_folders(args, scratch.path());
            let student = student::Student::new(&args.assignment, run, scratch.path(), &hidden).map_err(|why| {
                Failure::BadInput(format!("grade --run: {why}; --no-sandbox runs a program you trust"))
            })?;
            Some(student)
        }
        Judged::Images(_) => None,
    };
    let mut page = args.html.as_deref().map(Page::new).transpose().map_err(failed)?;
    let bar = Progress::new(progress, lines.len() as u64, "lines");
    let mut graded = Vec::new();
    for line in &lines {
        let rendered = course::render_into(line, &args.assignment, &ours, backend);
        let start = std::time::Instant::now();
        let run = student.as_ref().map(|s| s.run(line));
        if let Some(run) = run.as_ref().filter(|_| verbose) {
            let took = start.elapsed().as_secs_f64() * 1000.0;
            say(&format!("grade: line {}: the program's run took {took:.1} ms ({:?})", line.number, run.ending));
        }
        for (k, name) in line.images.iter().enumerate() {
            let reference = rendered.clone().and_then(|()| read_ours(&ours.join(name)));
            let expected = reference.as_ref().map_or((0, 0), RgbImage::dimensions);
            let judged = match (&args.judged, &run) {
                (_, Some(run)) => match &run.outputs[k] {
                    Ok((folder, file)) => untrusted::read_image(folder, file, name, expected),
                    Err(why) => Err(why.clone()),
                },
                (Judged::Images(dir), None) => read_theirs(dir, name, expected),
                (Judged::Run(_), None) => unreachable!("a run has its student"),
            };
            let mut image = judge(line, name, reference, judged, run.as_ref(), &args.thresholds);
            if let Some(page) = page.as_mut() {
                image.graded.card = Some(page.card_html(&image.card()).map_err(failed)?);
            }
            graded.push(image.graded);
        }
        if let Err(why) = &line.args {
            graded.push(unparsed(line, why));
        }
        let _ = std::fs::remove_dir_all(&ours);
        let _ = std::fs::create_dir(&ours);
        bar.advance(1);
    }
    Ok(Report { graded, page, sandboxed: !matches!(&args.judged, Judged::Run(run) if run.trusted) })
}

/// What `grade` found, and its page, to be finished once the verdicts are all in.
pub struct Report {
    pub graded: Vec<Graded>,
    page: Option<Page>,
    /// False when `--no-sandbox` ran the program with the teacher's rights.
    pub sandboxed: bool,
}

/// The teacher's folders a student's program must not see even where its own folder holds
/// them: the assignment's (its `expected/` images) and grade's private one, which the
/// program may not be inside of either; and the page's, hidden where the program's folder
/// holds it (a page beside the program, in its folder, is the teacher's choice).
fn hidden_folders(args: &GradeArgs, scratch: &Path) -> student::Hidden {
    let canonical = |f: &Path| f.canonicalize().ok();
    let page_folder =
        args.html.as_deref().and_then(Path::parent).map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p });
    student::Hidden {
        forbidden: [args.assignment.as_path(), scratch].into_iter().filter_map(canonical).collect(),
        masked: page_folder.and_then(canonical).into_iter().collect(),
    }
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
        hits: Vec::new(),
        stderr_tail: String::new(),
        card: None,
    }
}

/// An image judged, with its pictures until its card is made.
struct Judging {
    graded: Graded,
    reference: Result<RgbImage, String>,
    judged: Result<RgbImage, String>,
    map: Option<ErrorMap>,
}

fn judge(
    line: &CourseLine,
    name: &Path,
    reference: Result<RgbImage, String>,
    judged: Result<RgbImage, String>,
    run: Option<&student::Run>,
    thresholds: &Thresholds,
) -> Judging {
    let trouble = run.and_then(|r| r.ending.trouble());
    let (scores, verdict) = match (&reference, &judged) {
        (Err(why), _) => (None, Verdict::NotJudged(format!("no render of ours: {why}"))),
        (_, Err(why)) => {
            let why = trouble.as_ref().map_or(why.clone(), |t| format!("{why}: {t}"));
            (None, Verdict::NotJudged(why))
        }
        (Ok(ours), Ok(theirs)) => {
            let scores = compare_images(ours, theirs);
            let verdict = verdict(&scores, thresholds);
            (Some(scores), verdict)
        }
    };
    let summary = scores.as_ref().map(|s| Summary { flip_mean: s.flip_mean, flip_p99: s.flip_p99, off: s.off });
    let graded = Graded {
        line: line.number,
        command: line.text.clone(),
        name: name.to_path_buf(),
        reference: reference.as_ref().map(|_| ()).map_err(Clone::clone),
        judged: judged.as_ref().map(|_| ()).map_err(Clone::clone),
        scores: summary,
        verdict,
        trouble,
        hits: run.map_or(Vec::new(), |r| r.hits.clone()),
        stderr_tail: run.map_or(String::new(), |r| r.stderr_tail.clone()),
        card: None,
    };
    Judging { graded, reference, judged, map: scores.map(|s| s.map) }
}

impl Judging {
    fn card(&self) -> Card {
        let g = &self.graded;
        let mut lines = vec![format!("line {}: {}", g.line, g.command), g.report_line(0)];
        if !g.stderr_tail.is_empty() {
            lines.push(format!("the program's stderr, last lines:\n{}", g.stderr_tail));
        }
        let map_panel = Panel {
            label: "FLIP error map".into(),
            image: self.map.as_ref().map(ErrorMap::magma).ok_or_else(|| "no FLIP map: not judged".to_string()),
        };
        Card {
            title: g.name.display().to_string(),
            mark: if g.passed() { Mark::Pass } else { Mark::Fail },
            lines,
            panels: vec![
                Panel { label: "ours (reference)".into(), image: self.reference.clone() },
                Panel { label: "judged".into(), image: self.judged.clone() },
                map_panel,
            ],
        }
    }
}

/// The student's image named `name` in `dir`: that file, else one of the same name in the
/// other format (a teacher may have converted TGA files to PNG to look at them); read as
/// anything of a student's is ([`untrusted`]), if it is `expected`'s size.
fn read_theirs(dir: &Path, name: &Path, expected: (u32, u32)) -> Result<RgbImage, String> {
    let exact = untrusted::read_image(dir, name, name, expected);
    if !matches!(&exact, Err(why) if why.starts_with("no file")) {
        return exact;
    }
    let other = ["png", "tga"].iter().map(|ext| name.with_extension(ext)).filter(|n| n != name);
    for other in other {
        let read = untrusted::read_image(dir, &other, &other, expected);
        if !matches!(&read, Err(why) if why.starts_with("no file")) {
            return read;
        }
    }
    Err(format!("no file {}", dir.join(name).display()))
}

/// Our own render: a file we wrote where no student can reach.
fn read_ours(path: &Path) -> Result<RgbImage, String> {
    if !path.is_file() {
        return Err(format!("no file {}", path.display()));
    }
    raycaster::image_io::read_image(path).map_err(|e| format!("unreadable: {e}"))
}

/// The report on stdout: a line per image, then the count; first, where the program ran
/// with the teacher's rights, a line saying so.
pub fn report(report: &Report) -> String {
    let graded = &report.graded;
    let width = graded.iter().map(|g| g.name.display().to_string().chars().count()).max().unwrap_or(0);
    let mut text = if report.sandboxed { String::new() } else { format!("{NOT_SANDBOXED}\n") };
    text += &graded.iter().map(|g| g.report_line(width) + "\n").collect::<String>();
    let passed = graded.iter().filter(|g| g.passed()).count();
    text += &format!("grade: {passed} of {} images pass\n", graded.len());
    text
}

/// The first line of a report of `--no-sandbox`.
const NOT_SANDBOXED: &str =
    "NOT SANDBOXED (--no-sandbox): the program ran with the teacher's rights; it could have read or changed anything they can";

/// The HTML page: every image worst first, ours, theirs and the ꟻLIP map side by side.
pub fn write_html(report: Report, args: &GradeArgs) -> Result<(), String> {
    let Some(mut page) = report.page else { return Ok(()) };
    let graded = &report.graded;
    let passed = graded.iter().filter(|g| g.passed()).count();
    let source = match &args.judged {
        Judged::Images(dir) => format!("images of {}", dir.display()),
        Judged::Run(run) => format!("the images `{}` wrote", run.command),
    };
    if !report.sandboxed {
        page.paragraph(NOT_SANDBOXED);
    }
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
        if let Some(card) = &g.card {
            page.push_html(card);
        }
    }
    page.finish(&format!("raycaster grade: {}", args.assignment.display()))
}
