//! What a command line asks for, once parsed: the types [`crate::app::cli`] produces and
//! the rest of the command reads. A leaf: it imports nothing of the app's, so every other
//! module can depend on it.

use raycaster::grid::GridSize;
use raycaster::image_io::ExrCompression;
use raycaster::render::{Output, Outputs, Shading, SphereTest, TriangleTest};
use raycaster::sampling::Sampling;
use std::fmt;
use std::path::{Path, PathBuf};

/// The largest image side: TGA stores sizes in 16 bits.
pub const MAX_SIDE: u32 = 65535;
/// The largest image, in pixels (16384²).
pub const MAX_PIXELS: u64 = 1 << 28;
/// The most `--threads` accepts: far above any core count, low enough to refuse a typo.
pub const MAX_THREADS: u64 = 1024;

/// A parsed command line: what to do, and the flags every command shares.
#[derive(Clone, Debug, PartialEq)]
pub struct CommandLine {
    pub command: Command,
    pub habits: Habits,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    Render(RenderArgs),
    /// `raycaster compare`: GPU against the reference, nothing written. `args`' file names
    /// only say which outputs to compare; `outputs` is the union of them and `--outputs`.
    Compare {
        args: RenderArgs,
        outputs: Outputs,
        max_diff_pixels: Option<u64>,
    },
    /// `raycaster batch FILE`: one render command line per line of FILE, in one process.
    Batch {
        file: PathBuf,
        backend: BackendChoice,
        /// `--shard K/N`: only the command lines whose index is K modulo N.
        shard: Option<Split>,
    },
    /// `raycaster stitch`: assemble the part files of a split render.
    Stitch(StitchArgs),
    /// `raycaster bench`: speed and error per scene and size.
    Bench(BenchArgs),
    /// `raycaster grade`: a student's images for an assignment against ours.
    Grade(GradeArgs),
    /// `raycaster gallery`: every assignment's images, ours beside the course's, on a page.
    Gallery(GalleryArgs),
    /// `raycaster selftest`: the built-in cases on the GPU against the reference.
    Selftest,
    Help,
    /// `--version`, `-V`.
    Version,
}

pub use raycaster::renderer::BackendChoice;

/// A render as the command line asks for it.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderArgs {
    pub input: PathBuf,
    pub width: u32,
    pub height: u32,
    pub files: OutputPaths,
    /// `-shade_back`, `--specular-fix`, `-shadows`, `-bounces N`, `-weight W`.
    pub shading: Shading,
    /// `-gui` was given: the render is shown live in a window (src/app/window), or where
    /// none can open, rendered as without it and a notice says why.
    pub gui: bool,
    /// `-gui`, `-tessellation` or `-gouraud` was given: the last two shape only the course's
    /// OpenGL preview, and change nothing.
    pub preview: bool,
    pub backend: BackendChoice,
    pub triangle_test: TriangleTest,
    pub sphere_test: SphereTest,
    /// `--tile K/N`: render band K of N and write part files (see [`crate::app::part`]).
    pub tile: Option<Split>,
    /// `-grid NX NY NZ`.
    pub grid: Option<GridSize>,
    /// `-visualize_grid` (or `-visualize_grid_count`); only with a grid.
    pub visualize_grid: bool,
    /// `-stats`: print the course's statistics after the render.
    pub stats: bool,
    /// A sampler or a filter (docs/SPEC.md §8); `None`: one sample at each pixel's centre.
    pub sampling: Option<Sampling>,
    /// `-render_samples` and `-render_filter`.
    pub pictures: Pictures,
}

/// One of the course's pictures of samples or filter weights: its file and enlargement.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub path: PathBuf,
    pub zoom: u32,
}

/// `-render_samples FILE ZOOM` and `-render_filter FILE ZOOM`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pictures {
    pub samples: Option<Picture>,
    pub filter: Option<Picture>,
}

impl Pictures {
    pub fn is_empty(&self) -> bool {
        self.samples.is_none() && self.filter.is_none()
    }

    /// The pictures asked for, with their flags.
    pub fn named(&self) -> Vec<(&'static str, &Picture)> {
        [("-render_samples", self.samples.as_ref()), ("-render_filter", self.filter.as_ref())]
            .into_iter()
            .filter_map(|(flag, p)| Some((flag, p?)))
            .collect()
    }
}

impl RenderArgs {
    /// Whether the line writes anything: an image or a picture.
    pub fn writes_something(&self) -> bool {
        !self.files.outputs().is_empty() || !self.pictures.is_empty()
    }
}

/// The files of `-output`, `-normals` and `-depth MIN MAX`, and how those that are EXR
/// compress their blocks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OutputPaths {
    pub color: Option<PathBuf>,
    pub normals: Option<PathBuf>,
    pub depth: Option<DepthArgs>,
    /// `--exr-compression`.
    pub exr_compression: ExrCompression,
}

#[derive(Clone, Debug, PartialEq)]
pub struct DepthArgs {
    pub min: f32,
    pub max: f32,
    pub path: PathBuf,
}

impl OutputPaths {
    /// The outputs given a file, in [`Output::ALL`]'s order, with their files.
    pub fn named(&self) -> Vec<(Output, &Path)> {
        let depth = self.depth.as_ref().map(|d| d.path.as_path());
        [(Output::Color, self.color.as_deref()), (Output::Normals, self.normals.as_deref()), (Output::Depth, depth)]
            .into_iter()
            .filter_map(|(output, path)| Some((output, path?)))
            .collect()
    }

    /// The outputs given a file.
    pub fn outputs(&self) -> Outputs {
        self.named().into_iter().map(|(output, _)| output).collect()
    }

    /// The `-depth MIN MAX` range, when there is one.
    pub fn depth_range(&self) -> Option<(f32, f32)> {
        self.depth.as_ref().map(|d| (d.min, d.max))
    }
}

/// The course's flag that names `output`'s file.
pub fn flag_of(output: Output) -> &'static str {
    match output {
        Output::Color => "-output",
        Output::Normals => "-normals",
        Output::Depth => "-depth",
    }
}

/// `raycaster stitch`: the render's output flags, and what to check the parts against.
#[derive(Clone, Debug, PartialEq)]
pub struct StitchArgs {
    pub files: OutputPaths,
    /// Checked against the parts' scene hash when given.
    pub input: Option<PathBuf>,
    /// Checked against the parts' size when given.
    pub size: Option<(u32, u32)>,
    pub keep_parts: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct BenchArgs {
    /// A few small cases that take seconds (what CI runs).
    pub quick: bool,
    /// Renders per case (medians are reported).
    pub runs: usize,
    /// Where the CSV and the plot go.
    pub out: PathBuf,
    /// The course corpus (`a2/`, `meshes/`).
    pub corpus: PathBuf,
    /// Only the cases whose name contains this.
    pub only: Option<String>,
}

/// The FLIP mean an image may have and pass (`--max-flip-mean`). Measured on the course's
/// assignment 4 against our renders (docs/grading.md): a ±1-level dither scores 0.011 to
/// 0.016, every channel one level up 0.030 to 0.039 (a rounding choice, not a mistake); a
/// missing shadow, a camera moved by 2 % of its distance or swapped colour channels score
/// medians of 0.20 to 0.25.
pub const DEFAULT_MAX_FLIP_MEAN: f64 = 0.05;
/// The FLIP error that 99 % of an image's pixels may not exceed and pass (`--max-flip-p99`):
/// a small region badly wrong fails where the mean passes it. The dither and the one-level
/// offset stay below 0.06; a missing shadow or a moved camera gives 0.45 at the least.
pub const DEFAULT_MAX_FLIP_P99: f64 = 0.25;
/// How long a student's program may take on one command line (`--time-limit`), seconds.
pub const DEFAULT_TIME_LIMIT: f64 = 60.0;

/// `raycaster grade`.
#[derive(Clone, Debug, PartialEq)]
pub struct GradeArgs {
    /// The assignment's folder: its `commands.txt`, scenes and meshes.
    pub assignment: PathBuf,
    pub judged: Judged,
    /// `--html FILE`: the report with the pictures.
    pub html: Option<PathBuf>,
    /// What renders our images (default: the f64 reference, the ground truth).
    pub backend: BackendChoice,
    pub thresholds: Thresholds,
}

/// Where the student's images come from.
#[derive(Clone, Debug, PartialEq)]
pub enum Judged {
    /// `--images DIR`: a folder of them, named as the command lines name them.
    Images(PathBuf),
    /// `--run COMMAND`: their program, run on each command line.
    Run(RunArgs),
}

/// How `--run`'s program is run: in a sandbox (docs/grading.md, "The sandbox"), within limits.
#[derive(Clone, Debug, PartialEq)]
pub struct RunArgs {
    pub command: String,
    pub limits: Limits,
    /// `--no-sandbox`: the teacher trusts the program; it runs with their rights.
    pub trusted: bool,
    /// `--env NAME[=VALUE]`: variables the program gets besides `PATH`, `HOME` and `LANG`
    /// (a bare NAME passes the teacher's value on).
    pub env: Vec<String>,
}

/// What one command line's run of a student's program may use (`--limit NAME=VALUE`,
/// `--time-limit S`). The defaults suit the course: its programs render a few 200² to
/// 500² images of small scenes, in seconds and megabytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Wall time, seconds, from the start of the line's sandbox to its outputs read back.
    pub wall: f64,
    /// CPU time of each process, seconds.
    pub cpu: u64,
    /// Address space of each process, bytes.
    pub memory: u64,
    /// Processes and threads at once.
    pub processes: u64,
    /// The largest file the program may write, bytes.
    pub file: u64,
    /// What the working folder may hold in all, bytes; `/tmp` has as much again.
    pub folder: u64,
}

/// The limits a line's run can hit, as the report names them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitKind {
    Wall,
    Cpu,
    Memory,
    Processes,
    File,
    Folder,
}

const MIB: u64 = 1 << 20;

impl Default for Limits {
    fn default() -> Limits {
        Limits {
            wall: DEFAULT_TIME_LIMIT,
            cpu: DEFAULT_TIME_LIMIT as u64,
            memory: 4096 * MIB,
            processes: 256,
            file: 64 * MIB,
            folder: 256 * MIB,
        }
    }
}

impl LimitKind {
    pub const ALL: [LimitKind; 6] =
        [LimitKind::Wall, LimitKind::Cpu, LimitKind::Memory, LimitKind::Processes, LimitKind::File, LimitKind::Folder];

    /// The name `--limit` takes and the report prints.
    pub fn name(self) -> &'static str {
        match self {
            LimitKind::Wall => "wall",
            LimitKind::Cpu => "cpu",
            LimitKind::Memory => "memory",
            LimitKind::Processes => "processes",
            LimitKind::File => "file",
            LimitKind::Folder => "folder",
        }
    }

    pub fn named(name: &str) -> Option<LimitKind> {
        LimitKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Sizes take a unit (`64M`, `2G`), the others a plain number.
    fn is_size(self) -> bool {
        matches!(self, LimitKind::Memory | LimitKind::File | LimitKind::Folder)
    }
}

impl Limits {
    /// Sets the limit `NAME=VALUE` names: seconds for `wall` and `cpu`, a count for
    /// `processes`, bytes with an optional `K`, `M` or `G` (binary) for the sizes.
    pub fn set(&mut self, text: &str) -> Result<(), String> {
        let names = LimitKind::ALL.map(LimitKind::name).join(", ");
        let (name, value) =
            text.split_once('=').ok_or_else(|| format!("'{text}' is not NAME=VALUE (NAME: {names})"))?;
        let kind = LimitKind::named(name).ok_or_else(|| format!("no limit named '{name}' (the limits: {names})"))?;
        let number = if kind.is_size() { parse_size(value) } else { value.parse::<f64>().ok() };
        let number = number.filter(|n| n.is_finite() && *n > 0.0 && *n < 1e15).ok_or_else(|| {
            let what = if kind.is_size() { "a size > 0 such as 512M or 2G" } else { "a number > 0" };
            format!("{name}: '{value}' is not {what}")
        })?;
        match kind {
            LimitKind::Wall => self.wall = number,
            LimitKind::Cpu => self.cpu = number.ceil() as u64,
            LimitKind::Memory => self.memory = number as u64,
            LimitKind::Processes => self.processes = number.ceil() as u64,
            LimitKind::File => self.file = number as u64,
            LimitKind::Folder => self.folder = number as u64,
        }
        Ok(())
    }
}

/// `512M`, `2G`, `4096` (bytes), `1.5G`.
fn parse_size(text: &str) -> Option<f64> {
    let (digits, unit) = match text.char_indices().last()? {
        (k, 'K' | 'k') => (&text[..k], 1u64 << 10),
        (k, 'M' | 'm') => (&text[..k], 1 << 20),
        (k, 'G' | 'g') => (&text[..k], 1 << 30),
        _ => (text, 1),
    };
    digits.parse::<f64>().ok().map(|n| n * unit as f64)
}

/// What an image must stay within to pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    pub max_flip_mean: f64,
    pub max_flip_p99: f64,
    /// Pixels more than 1 level off; no limit by default (FLIP judges what is visible).
    pub max_diff_pixels: Option<u64>,
}

/// `raycaster gallery`.
#[derive(Clone, Debug, PartialEq)]
pub struct GalleryArgs {
    /// The course's files: `a2/` … `a7/`.
    pub corpus: PathBuf,
    pub html: PathBuf,
    pub backend: BackendChoice,
}

/// How much the program says on stderr besides errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Verbosity {
    /// `-q`: errors only (no warnings, notices or progress).
    Quiet,
    #[default]
    Normal,
    /// `-v`: also the adapter, the kernel variant and where the time and memory went.
    Verbose,
}

/// The flags every command takes: `-q`/`--quiet`, `-v`/`--verbose`, `--threads N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Habits {
    pub verbosity: Verbosity,
    /// Threads of the CPU reference's pool (rayon); `None`: one per core.
    pub threads: Option<usize>,
}

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

/// A bad command line, as one line of text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UsageError(pub String);

impl fmt::Display for UsageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (try --help)", self.0)
    }
}

impl std::error::Error for UsageError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_are_set_by_name_with_units() {
        let mut limits = Limits::default();
        limits.set("memory=512M").unwrap();
        limits.set("folder=1.5G").unwrap();
        limits.set("file=4096").unwrap();
        limits.set("cpu=2.5").unwrap();
        limits.set("processes=8").unwrap();
        limits.set("wall=0.5").unwrap();
        let expected = Limits { wall: 0.5, cpu: 3, memory: 512 << 20, processes: 8, file: 4096, folder: 3 << 29 };
        assert_eq!(limits, expected);
        for (bad, message) in [
            ("memory", "is not NAME=VALUE"),
            ("disk=1G", "no limit named 'disk'"),
            ("memory=lots", "is not a size > 0"),
            ("cpu=-1", "is not a number > 0"),
            ("file=0", "is not a size"),
        ] {
            let error = limits.set(bad).unwrap_err();
            assert!(error.contains(message), "{bad}: {error}");
        }
        assert_eq!(limits, expected, "a refused value changes nothing");
    }

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
    fn splits_parse_only_k_below_n() {
        assert_eq!(Split::parse("2/5"), Some(Split { index: 2, count: 5 }));
        for bad in ["5/5", "0/0", "-1/3", "1", "a/b", "1/2/3", ""] {
            assert_eq!(Split::parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn named_outputs_come_in_the_course_order() {
        let files = OutputPaths {
            color: None,
            normals: Some("n.tga".into()),
            depth: Some(DepthArgs { min: 1.0, max: 2.0, path: "d.exr".into() }),
            exr_compression: ExrCompression::default(),
        };
        assert_eq!(files.named(), [(Output::Normals, Path::new("n.tga")), (Output::Depth, Path::new("d.exr"))]);
        assert_eq!(files.outputs(), Outputs::from(Output::Normals).with(Output::Depth));
        assert_eq!(files.depth_range(), Some((1.0, 2.0)));
    }
}
