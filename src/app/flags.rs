//! The one table of flags: each flag's spellings, its value, the commands that take it, its
//! help and where its value goes. Parsing ([`crate::app::cli`]), the usage text ([`usage`]),
//! the "did you mean" suggestions ([`unknown_flag`]) and docs/SPEC.md §1's table
//! (`markdown_table`, checked by a test below) all read this table, so a flag is added,
//! renamed or documented in one place.

use crate::app::args::{
    BackendChoice, DepthArgs, OutputPaths, Picture, Pictures, Split, UsageError, Verbosity, MAX_THREADS,
};
use raycaster::grid::GridSize;
use raycaster::image_io::ExrCompression;
use raycaster::render::{Outputs, Shading, SphereTest, TriangleTest};
use raycaster::sampling::{Filter, Sampler};
use std::path::PathBuf;

/// What a command line is: a render, or one of the commands named by its first word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verb {
    Render = 0,
    Compare = 1,
    Batch = 2,
    Stitch = 3,
    Bench = 4,
    Grade = 5,
    Gallery = 6,
    Selftest = 7,
}

impl Verb {
    /// The verbs named by a first word, as typed.
    const NAMED: [Verb; 7] =
        [Verb::Compare, Verb::Batch, Verb::Stitch, Verb::Bench, Verb::Grade, Verb::Gallery, Verb::Selftest];

    pub fn name(self) -> &'static str {
        match self {
            Verb::Render => "",
            Verb::Compare => "compare",
            Verb::Batch => "batch",
            Verb::Stitch => "stitch",
            Verb::Bench => "bench",
            Verb::Grade => "grade",
            Verb::Gallery => "gallery",
            Verb::Selftest => "selftest",
        }
    }

    /// The verb a command line's first argument names; a render has none.
    pub fn of_first(arg: Option<&str>) -> Verb {
        Verb::NAMED.into_iter().find(|v| Some(v.name()) == arg).unwrap_or(Verb::Render)
    }

    /// What errors about a command's own flags start with: `stitch: `; nothing for a
    /// render or `compare`, whose flags are the render's.
    pub fn context(self) -> String {
        match self {
            Verb::Render | Verb::Compare => String::new(),
            other => format!("{}: ", other.name()),
        }
    }
}

/// A set of [`Verb`]s: the commands that take a flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Verbs(u8);

impl Verbs {
    const fn of(verbs: &[Verb]) -> Verbs {
        let mut bits = 0;
        let mut k = 0;
        while k < verbs.len() {
            bits |= 1 << verbs[k] as u8;
            k += 1;
        }
        Verbs(bits)
    }

    const EVERY: Verbs = Verbs(0b1111_1111);
    const NONE: Verbs = Verbs(0);

    pub fn contains(self, verb: Verb) -> bool {
        self.0 & 1 << verb as u8 != 0
    }
}

/// What everything a command line gives is collected into, before [`crate::app::cli`] makes
/// it a [`crate::app::args::Command`]; what was not given stays `None`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Given {
    pub input: Option<PathBuf>,
    pub size: Option<(u32, u32)>,
    pub files: OutputPaths,
    pub shading: Shading,
    /// `-gui`: the course's OpenGL window, which we do not open.
    pub gui: bool,
    /// `-tessellation θ φ` or `-gouraud`: how that window draws spheres.
    pub preview: bool,
    pub backend: Option<BackendChoice>,
    pub triangle_test: TriangleTest,
    pub sphere_test: SphereTest,
    pub tile: Option<Split>,
    pub outputs: Outputs,
    pub max_diff_pixels: Option<u64>,
    pub shard: Option<Split>,
    pub keep_parts: bool,
    pub quick: bool,
    pub runs: Option<usize>,
    pub out: Option<PathBuf>,
    pub corpus: Option<PathBuf>,
    pub only: Option<String>,
    pub threads: Option<usize>,
    /// `-grid NX NY NZ`.
    pub grid: Option<GridSize>,
    /// `-visualize_grid` or `-visualize_grid_count`.
    pub visualize_grid: bool,
    /// `-stats`.
    pub stats: bool,
    /// `-random_samples`, `-uniform_samples` or `-jittered_samples` (the last one wins).
    pub sampler: Option<Sampler>,
    /// `-box_filter`, `-tent_filter` or `-gaussian_filter` (the last one wins).
    pub filter: Option<Filter>,
    /// `--seed N`.
    pub seed: Option<u32>,
    /// `-render_samples FILE ZOOM` and `-render_filter FILE ZOOM`.
    pub pictures: Pictures,
    /// `grade --images DIR`.
    pub images: Option<PathBuf>,
    /// `grade --run COMMAND`.
    pub run: Option<String>,
    /// `grade --time-limit S`.
    pub time_limit: Option<f64>,
    /// `grade --limit NAME=VALUE`, as given, in order.
    pub limits: Vec<String>,
    /// `grade --env NAME[=VALUE]`, in order.
    pub env: Vec<String>,
    /// `grade --no-sandbox`.
    pub no_sandbox: bool,
    /// `grade --html FILE`, `gallery --html FILE`.
    pub html: Option<PathBuf>,
    /// `grade --max-flip-mean X`.
    pub max_flip_mean: Option<f64>,
    /// `grade --max-flip-p99 X`.
    pub max_flip_p99: Option<f64>,
}

/// A flag that answers the command line by itself, whatever else it holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer {
    Help,
    Version,
}

/// What a flag takes after it, and where the value goes.
pub enum Takes {
    Switch(fn(&mut Given)),
    /// `-q` or `-v`: the two exclude each other.
    Verbosity(Verbosity),
    Answer(Answer),
    /// A file name (not empty).
    Path(fn(&mut Given, PathBuf)),
    /// `W H`, each 1…[`crate::app::args::MAX_SIDE`], at most [`crate::app::args::MAX_PIXELS`].
    Size(fn(&mut Given, (u32, u32))),
    /// `MIN MAX FILE`, finite, `MIN < MAX`.
    Depth(fn(&mut Given, DepthArgs)),
    /// Two whole numbers ≥ 1 (`-tessellation THETA PHI`).
    Steps(fn(&mut Given, (u32, u32))),
    /// Three whole numbers ≥ 1, at most [`GridSize::MAX_CELLS`] in product (`-grid`).
    Cells(fn(&mut Given, GridSize)),
    /// One of `names()`; the setter gets its index.
    Choice {
        names: fn() -> Vec<&'static str>,
        set: fn(&mut Given, usize),
    },
    /// A number of samples per pixel, 1…[`MAX_SAMPLES`]; with `square`, a perfect square.
    Samples {
        square: bool,
        set: fn(&mut Given, u32),
    },
    /// A finite number > 0; `what` names it where it is missing.
    Positive {
        what: &'static str,
        set: fn(&mut Given, f64),
    },
    /// `FILE ZOOM`: an image file and a whole number ≥ 1.
    Picture(fn(&mut Given, Picture)),
    /// A finite number ≥ 0; `what` names it where it is missing.
    Real {
        what: &'static str,
        set: fn(&mut Given, f64),
    },
    /// A whole number from `min` to `max`; `what` names it where it is missing.
    Number {
        what: &'static str,
        min: u64,
        max: u64,
        set: fn(&mut Given, u64),
    },
    /// `K/N`.
    Split(fn(&mut Given, Split)),
    /// `color,normals,depth`, any of them.
    Outputs(fn(&mut Given, Outputs)),
    /// Any text; `what` names it where it is missing.
    Text {
        what: &'static str,
        set: fn(&mut Given, String),
    },
}

impl Takes {
    /// Whether it takes more than one value. Those cannot be glued on with `=`:
    /// `-size=200 200` would read as if the second value belonged to no flag.
    pub fn several_values(&self) -> bool {
        matches!(self, Takes::Size(_) | Takes::Depth(_) | Takes::Steps(_) | Takes::Cells(_) | Takes::Picture(_))
    }
}

pub struct Flag {
    /// The name as [`flag_name`] spells it (`shade_back`, `triangle_test`).
    pub name: &'static str,
    /// A one-letter spelling (`q` for `-q`).
    pub short: Option<&'static str>,
    /// The course's flags are shown with one dash (`-input`), ours with two (`--backend`).
    pub course: bool,
    /// The value as help shows it (`FILE`, `W H`).
    pub metavar: &'static str,
    pub takes: Takes,
    pub verbs: Verbs,
    /// The verbs the flag is required by.
    pub required: Verbs,
    /// Whether giving it twice is an error rather than the last one winning: a second file
    /// or size is far more likely a mistake than a change of mind.
    pub once: bool,
    /// A verb that refuses the flag for a reason other than not knowing it.
    pub refused: Option<(Verb, &'static str)>,
    pub help: &'static str,
    /// What docs/SPEC.md §1 adds to the help: the limits of the value and the section that
    /// defines the flag's effect. Empty where the help says it all. Only the test that
    /// checks the spec's copy reads it.
    #[cfg_attr(not(test), allow(dead_code))]
    pub details: &'static str,
}

use Verb::{Batch, Bench, Compare, Gallery, Grade, Render, Selftest, Stitch};

/// The deepest `-bounces` (the reference recurses once per bounce).
pub const MAX_BOUNCES: u64 = 1000;

const IMAGE_VERBS: Verbs = Verbs::of(&[Render, Compare, Stitch]);
const RENDER_VERBS: Verbs = Verbs::of(&[Render, Compare]);

/// Every flag, in the order help lists them.
pub static FLAGS: &[Flag] = &[
    Flag::course("input", "SCENE", Takes::Path(|g, path| g.input = Some(path)), IMAGE_VERBS)
        .required(RENDER_VERBS)
        .once()
        .help("scene file (obj_file paths resolve from its folder, then the working\ndirectory)"),
    Flag::course("size", "W H", Takes::Size(|g, size| g.size = Some(size)), IMAGE_VERBS)
        .required(RENDER_VERBS)
        .once()
        .help("image size in pixels")
        .details("each 1…65535 (TGA keeps sizes in 16 bits), and W·H at most 2²⁸ (16384²)"),
    Flag::course("output", "FILE", Takes::Path(|g, path| g.files.color = Some(path)), IMAGE_VERBS)
        .once()
        .help("shaded image (.tga or .png; .exr: linear, unclamped)")
        .details("§5"),
    Flag::course("normals", "FILE", Takes::Path(|g, path| g.files.normals = Some(path)), IMAGE_VERBS)
        .once()
        .help("normal visualisation |N| (.tga or .png; .exr: the signed normal)")
        .details("§5"),
    Flag::course("depth", "MIN MAX FILE", Takes::Depth(|g, depth| g.files.depth = Some(depth)), IMAGE_VERBS)
        .once()
        .help(
            "depth visualisation, white at MIN, black at MAX (.tga or .png;\n\
             .exr: the distance t itself, +inf where nothing is hit; MIN and\n\
             MAX are then not used)",
        )
        .details("MIN < MAX, both finite; §5"),
    Flag::course("shade_back", "", Takes::Switch(|g| g.shading.shade_back = true), RENDER_VERBS)
        .help("shade back-facing hits as if they faced the viewer")
        .details("§5"),
    Flag::course("shadows", "", Takes::Switch(|g| g.shading.shadows = true), RENDER_VERBS)
        .help("cast a shadow ray to every light")
        .details("to a point light, only up to the light; §5"),
    Flag::course(
        "bounces",
        "N",
        Takes::Number {
            what: "a number of bounces",
            min: 0,
            max: MAX_BOUNCES,
            set: |g, n| g.shading.bounces = n as u32,
        },
        RENDER_VERBS,
    )
    .help("reflected and refracted rays, at most N deep (default 0: local\nshading only)")
    .details("§5"),
    Flag::course("weight", "W", Takes::Real { what: "a ray weight", set: |g, w| g.shading.weight = w }, RENDER_VERBS)
        .help("no secondary ray whose weight falls below W (default 0)")
        .details("§5"),
    Flag::course("gui", "", Takes::Switch(|g| g.gui = true), RENDER_VERBS)
        .help("show the render live in a window (mouse: orbit, pan, zoom; r writes the files)")
        .details(
            "§9. Where no window can open (no display, a `batch`, a `--tile` part, a build \
            without the `gui` feature) the line renders and writes as without `-gui`, and \
            one notice says why (`-q` silences it); a line with `-gui` and no image flag \
            then renders nothing, says so, and exits 0",
        ),
    Flag::course("tessellation", "THETA PHI", Takes::Steps(|g, _| g.preview = true), RENDER_VERBS)
        .help("sphere facets of the course's OpenGL preview: accepted, ignored")
        .details("whole numbers ≥ 1; a notice says so when `-gui` is absent"),
    Flag::course("gouraud", "", Takes::Switch(|g| g.preview = true), RENDER_VERBS)
        .help("smooth spheres in the course's OpenGL preview: accepted, ignored"),
    Flag::course("grid", "NX NY NZ", Takes::Cells(|g, size| g.grid = Some(size)), RENDER_VERBS).help(
        "a uniform grid of NX×NY×NZ cells over the scene's bounds (planes\n\
         outside it) through which every ray finds what it hits",
    )
    .details("whole numbers ≥ 1, at most 2²⁴ cells in all; §7"),
    Flag::course("visualize_grid", "", Takes::Switch(|g| g.visualize_grid = true), RENDER_VERBS)
        .help("render the grid's occupied cells as boxes, coloured by how many\nprimitives each holds")
        .details("drawn instead of the objects; needs `-grid`; §7"),
    Flag::course("visualize_grid_count", "", Takes::Switch(|g| g.visualize_grid = true), RENDER_VERBS)
        .help("the course's optional count colouring: the same as -visualize_grid")
        .details("§7"),
    Flag::course("stats", "", Takes::Switch(|g| g.stats = true), Verbs::of(&[Render]))
        .help("print the course's ray tracing statistics on stdout at the end")
        .details("not with `--tile` (a usage error); §7"),
    Flag::course(
        "random_samples",
        "N",
        Takes::Samples { square: false, set: |g, n| g.sampler = Some(Sampler::Random(n)) },
        RENDER_VERBS,
    )
    .help("N samples per pixel at hashed random positions (see --seed)")
    .details("§8"),
    Flag::course(
        "uniform_samples",
        "N",
        Takes::Samples { square: true, set: |g, n| g.sampler = Some(Sampler::Uniform(n)) },
        RENDER_VERBS,
    )
    .help("N samples per pixel on a √N×√N grid (N a square number)")
    .details("§8"),
    Flag::course(
        "jittered_samples",
        "N",
        Takes::Samples { square: true, set: |g, n| g.sampler = Some(Sampler::Jittered(n)) },
        RENDER_VERBS,
    )
    .help("N samples per pixel, one at a hashed position in each cell of a\n√N×√N grid (N a square number)")
    .details("§8"),
    Flag::course(
        "box_filter",
        "R",
        Takes::Positive { what: "a radius", set: |g, r| g.filter = Some(Filter::Box(r)) },
        RENDER_VERBS,
    )
    .help("each pixel the average of the samples within R pixels across\n(default with a sampler: R = 0.5, the pixel's own samples)")
    .details("§8"),
    Flag::course(
        "tent_filter",
        "R",
        Takes::Positive { what: "a radius", set: |g, r| g.filter = Some(Filter::Tent(r)) },
        RENDER_VERBS,
    )
    .help("samples weighted 1 at the pixel's centre down to 0 at distance R")
    .details("the weight is `max(0, 1 − d/R)`; §8"),
    Flag::course(
        "gaussian_filter",
        "SIGMA",
        Takes::Positive { what: "a sigma", set: |g, s| g.filter = Some(Filter::Gaussian(s)) },
        RENDER_VERBS,
    )
    .help("samples weighted exp(-d²/2σ²), none beyond 2σ")
    .details("§8"),
    Flag::course(
        "render_samples",
        "FILE ZOOM",
        Takes::Picture(|g, p| g.pictures.samples = Some(p)),
        Verbs::of(&[Render]),
    )
    .once()
    .help("the samples' picture: each pixel enlarged ZOOM times, a dot of\nits colour at each sample")
    .details("ZOOM a whole number ≥ 1; §8"),
    Flag::course("render_filter", "FILE ZOOM", Takes::Picture(|g, p| g.pictures.filter = Some(p)), Verbs::of(&[Render]))
        .once()
        .help("the filter's picture: its weights around the centre pixel,\nenlarged ZOOM times")
        .details("ZOOM a whole number ≥ 1; §8"),
    Flag::ours(
        "seed",
        "N",
        Takes::Number { what: "a seed", min: 0, max: u32::MAX as u64, set: |g, n| g.seed = Some(n as u32) },
        RENDER_VERBS,
    )
    .help("the seed of random and jittered sample positions (default 0)")
    .details("§8"),
    Flag::ours("specular_fix", "", Takes::Switch(|g| g.shading.specular_fix = true), RENDER_VERBS).help(
        "the handout's optional specular fix: the specular term times\n\
         N·L",
    )
    .details("§5"),
    Flag::ours(
        "backend",
        "B",
        Takes::Choice {
            names: || BackendChoice::ALL.map(BackendChoice::name).to_vec(),
            set: |g, k| g.backend = Some(BackendChoice::ALL[k]),
        },
        Verbs::of(&[Render, Batch, Grade, Gallery]),
    )
    .refused(Compare, "compare always renders with both the GPU and the f64 reference")
    .help(
        "gpu, cpu (the f64 reference) or auto (default: the GPU if one is\n\
         found, else the CPU with a notice; grade: cpu, the ground truth)",
    )
    .details("§6"),
    Flag::ours(
        "triangle_test",
        "T",
        Takes::Choice {
            names: || TriangleTest::ALL.map(TriangleTest::name).to_vec(),
            set: |g, k| g.triangle_test = TriangleTest::ALL[k],
        },
        RENDER_VERBS,
    )
    .help("the GPU's ray/triangle test (default watertight)")
    .details("docs/accuracy.md"),
    Flag::ours(
        "sphere_test",
        "S",
        Takes::Choice {
            names: || SphereTest::ALL.map(SphereTest::name).to_vec(),
            set: |g, k| g.sphere_test = SphereTest::ALL[k],
        },
        RENDER_VERBS,
    )
    .help("the GPU's ray/sphere test (default robust)")
    .details("docs/accuracy.md"),
    Flag::ours(
        "exr_compression",
        "C",
        Takes::Choice {
            names: || ExrCompression::ALL.map(ExrCompression::name).to_vec(),
            set: |g, k| g.files.exr_compression = ExrCompression::ALL[k],
        },
        Verbs::of(&[Render, Stitch]),
    )
    .help(
        "how .exr files compress their blocks, all lossless: none, rle,\n\
         zips, zip (default) or piz (with --tile: give it to stitch)",
    )
    .details("OpenEXR's methods of those names; the floats read back are the same with each; docs/usage.md, \"Float outputs\""),
    Flag::ours("tile", "K/N", Takes::Split(|g, tile| g.tile = Some(tile)), Verbs::of(&[Render])).help(
        "render only band K (0-based, from the top) of N bands of rows\n\
         and write FILE.part-K-of-N beside each output; see stitch",
    )
    .details(
        "N at most the height; the part files and `stitch`: docs/usage.md, \"Renders \
        split across machines\"",
    ),
    Flag::ours("quiet", "", Takes::Verbosity(Verbosity::Quiet), Verbs::EVERY)
        .short("q")
        .help("errors only: no warnings, notices or progress bar"),
    Flag::ours("verbose", "", Takes::Verbosity(Verbosity::Verbose), Verbs::EVERY).short("v").help(
        "also the adapter, the kernel variant, where the time went and\n\
         the peak memory",
    ),
    Flag::ours(
        "threads",
        "N",
        Takes::Number {
            what: "a number of threads",
            min: 1,
            max: MAX_THREADS,
            set: |g, n| g.threads = Some(n as usize),
        },
        Verbs::EVERY,
    )
    .help("threads of the CPU reference (default: one per core)"),
    Flag::ours("help", "", Takes::Answer(Answer::Help), Verbs::EVERY).short("h").help("this text")
        .details("on stdout, status 0"),
    Flag::ours("version", "", Takes::Answer(Answer::Version), Verbs::EVERY).short("V").help("the version")
        .details("on stdout, status 0"),
    Flag::ours("keep_parts", "", Takes::Switch(|g| g.keep_parts = true), Verbs::of(&[Stitch]))
        .help("keep the part files"),
    Flag::ours("shard", "K/N", Takes::Split(|g, shard| g.shard = Some(shard)), Verbs::of(&[Batch])).help(
        "run only the command lines whose index (0-based, counting\n\
         command lines only, not blank or comment lines) is K modulo N",
    ),
    Flag::ours("quick", "", Takes::Switch(|g| g.quick = true), Verbs::of(&[Bench]))
        .help("a few small cases, seconds in all"),
    Flag::ours(
        "runs",
        "N",
        Takes::Number { what: "a number of runs", min: 1, max: u64::MAX, set: |g, n| g.runs = Some(n as usize) },
        Verbs::of(&[Bench]),
    )
    .help("renders per case, of which the medians are reported (default 5)"),
    Flag::ours("out", "DIR", Takes::Path(|g, dir| g.out = Some(dir)), Verbs::of(&[Bench]))
        .help("where bench.csv and bench.png go (default target/bench)"),
    Flag::ours("corpus", "DIR", Takes::Path(|g, dir| g.corpus = Some(dir)), Verbs::of(&[Bench])).help(
        "the course's files (default $RAYCASTER_CORPUS, else\n\
         ../shared/mit6837 beside the source checkout)",
    ),
    Flag::ours(
        "only",
        "NAME",
        Takes::Text { what: "a part of a case name", set: |g, name| g.only = Some(name) },
        Verbs::of(&[Bench]),
    )
    .help("only the cases whose name contains NAME"),
    Flag::ours("outputs", "LIST", Takes::Outputs(|g, outputs| g.outputs = outputs), Verbs::of(&[Compare]))
        .once()
        .help("the outputs to compare: color, normals, depth, comma-separated"),
    Flag::ours(
        "max_diff_pixels",
        "N",
        Takes::Number { what: "a number of pixels", min: 0, max: u64::MAX, set: |g, n| g.max_diff_pixels = Some(n) },
        Verbs::of(&[Compare, Grade]),
    )
    .help("pixels an output may have more than 1 level off (compare's\ndefault 0.1 %; grade's: no limit)")
    .details("compare: §6; grade: docs/grading.md"),
    Flag::ours("images", "DIR", Takes::Path(|g, dir| g.images = Some(dir)), Verbs::of(&[Grade]))
        .once()
        .help("the student's images, named as commands.txt names them (.png\nfor .tga is accepted)")
        .details("or `.tga` for `.png`, when the file named is missing"),
    Flag::ours(
        "run",
        "COMMAND",
        Takes::Text { what: "a command", set: |g, command| g.run = Some(command) },
        Verbs::of(&[Grade]),
    )
    .once()
    .help(
        "the student's program (split at spaces), run on each line of\n\
         commands.txt in a sandbox holding the line's scene",
    )
    .details("exactly one of `--images` and `--run`"),
    Flag::ours(
        "time_limit",
        "S",
        Takes::Positive { what: "a number of seconds", set: |g, s| g.time_limit = Some(s) },
        Verbs::of(&[Grade]),
    )
    .help("seconds --run's program may take on one line (default 60): the\nsame as --limit wall=S")
    .details("only with `--run`; every process the line started is killed then"),
    Flag::ours(
        "limit",
        "NAME=VALUE",
        Takes::Text { what: "NAME=VALUE", set: |g, limit| g.limits.push(limit) },
        Verbs::of(&[Grade]),
    )
    .help(
        "a limit of --run's program on each line: wall or cpu (seconds),\n\
         memory, file or folder (bytes; K, M, G), processes",
    )
    .details(
        "only with `--run`; any number of times. Defaults: wall 60, cpu as wall, memory 4G, \
         processes 256, file 64M, folder 256M (docs/grading.md)",
    ),
    Flag::ours("env", "NAME[=VALUE]", Takes::Text { what: "a variable", set: |g, var| g.env.push(var) }, Verbs::of(&[Grade]))
        .help("a variable for --run's program besides PATH, HOME and LANG (NAME\nalone passes yours on)")
        .details("only with `--run`; any number of times"),
    Flag::ours("no_sandbox", "", Takes::Switch(|g| g.no_sandbox = true), Verbs::of(&[Grade]))
        .help("run --run's program with your own rights, unisolated: only for a\nprogram you trust")
        .details("only with `--run`; the report says so on its first line (docs/grading.md)"),
    Flag::ours(
        "max_flip_mean",
        "X",
        Takes::Real { what: "a FLIP error", set: |g, x| g.max_flip_mean = Some(x) },
        Verbs::of(&[Grade]),
    )
    .help("the mean FLIP error an image may have and pass (default 0.05)")
    .details("docs/grading.md"),
    Flag::ours(
        "max_flip_p99",
        "X",
        Takes::Real { what: "a FLIP error", set: |g, x| g.max_flip_p99 = Some(x) },
        Verbs::of(&[Grade]),
    )
    .help("the FLIP error 99 % of an image's pixels may not pass (default\n0.25)")
    .details("docs/grading.md"),
    Flag::ours("html", "FILE", Takes::Path(|g, path| g.html = Some(path)), Verbs::of(&[Grade, Gallery]))
        .required(Verbs::of(&[Gallery]))
        .once()
        .help("an HTML page of the images, with FILE_files/ beside it for them")
        .details("grade's page lists the worst first"),
];

/// The table's rows say only what differs from these defaults: optional, given any number
/// of times (the last one wins), no short spelling.
impl Flag {
    /// A flag of the course's, shown with one dash (`-input`).
    const fn course(name: &'static str, metavar: &'static str, takes: Takes, verbs: Verbs) -> Flag {
        Flag {
            name,
            short: None,
            course: true,
            metavar,
            takes,
            verbs,
            required: Verbs::NONE,
            once: false,
            refused: None,
            help: "",
            details: "",
        }
    }

    /// One of ours, shown with two dashes (`--backend`).
    const fn ours(name: &'static str, metavar: &'static str, takes: Takes, verbs: Verbs) -> Flag {
        Flag { course: false, ..Flag::course(name, metavar, takes, verbs) }
    }

    const fn short(self, short: &'static str) -> Flag {
        Flag { short: Some(short), ..self }
    }

    const fn required(self, by: Verbs) -> Flag {
        Flag { required: by, ..self }
    }

    const fn once(self) -> Flag {
        Flag { once: true, ..self }
    }

    const fn refused(self, by: Verb, why: &'static str) -> Flag {
        Flag { refused: Some((by, why)), ..self }
    }

    const fn help(self, help: &'static str) -> Flag {
        Flag { help, ..self }
    }

    const fn details(self, details: &'static str) -> Flag {
        Flag { details, ..self }
    }
}

impl Flag {
    /// The flag named `name` (as [`flag_name`] spells it), in any spelling.
    pub fn find(name: &str) -> Option<&'static Flag> {
        FLAGS.iter().find(|f| f.name == name || f.short == Some(name))
    }

    /// How help spells the flag: `-input`, `--triangle-test`, `-q, --quiet`.
    fn spelled(&self) -> String {
        let long = if self.course { format!("-{}", self.name) } else { format!("--{}", self.name.replace('_', "-")) };
        match self.short {
            Some(short) => format!("-{short}, {long}"),
            None => long,
        }
    }

    /// The flag and its value as a synopsis shows it: the choices themselves where there
    /// are a few (`--backend gpu|cpu|auto`), in brackets unless `verb` requires it.
    fn synopsis(&self, verb: Verb) -> String {
        let long = if self.course { format!("-{}", self.name) } else { format!("--{}", self.name.replace('_', "-")) };
        let value = match &self.takes {
            Takes::Choice { names, .. } => names().join("|"),
            _ => self.metavar.to_string(),
        };
        let text = if value.is_empty() { long } else { format!("{long} {value}") };
        if self.required.contains(verb) {
            text
        } else {
            format!("[{text}]")
        }
    }

    /// The flag's lines in help: its spelling and value, then its help, aligned.
    fn help_lines(&self) -> String {
        let head =
            if self.metavar.is_empty() { self.spelled() } else { format!("{} {}", self.spelled(), self.metavar) };
        let help = self.help.replace('\n', &format!("\n{:25}", ""));
        if head.chars().count() >= 23 {
            // Too long to share a line with its help (`-tessellation THETA PHI`).
            return format!("  {head}\n{:25}{help}\n", "");
        }
        format!("  {head:<23}{help}\n")
    }
}

/// `-shade_back`, `--shade-back` → `shade_back`; `None` for something that is not a flag
/// (a lone `-` or a word). A negative number is a value, never a flag, and values are read
/// by the flag that takes them, so `-depth -1 5 d.tga` works.
pub fn flag_name(arg: &str) -> Option<String> {
    let name = arg.strip_prefix("--").or_else(|| arg.strip_prefix('-'))?;
    if name.is_empty() {
        return None;
    }
    Some(name.replace('-', "_"))
}

/// Below about 0.85, Jaro–Winkler pairs unrelated words of similar length.
const TYPO_SIMILARITY: f64 = 0.85;

/// The candidate most like `word`, when it is close enough to be a typo of it.
fn nearest<'a>(word: &str, candidates: impl Iterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .map(|c| (strsim::jaro_winkler(word, c), c))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .filter(|(score, _)| *score >= TYPO_SIMILARITY)
        .map(|(_, c)| c)
}

/// "unknown flag", with the nearest flag `verb` takes when one is close enough to be a
/// typo, spelled with the dashes the user typed (`-outptu` → `-output`, `--shade-bakc` →
/// `--shade-back`).
pub fn unknown_flag(verb: Verb, text: &str) -> UsageError {
    let name = flag_name(text).unwrap_or_default();
    let known = FLAGS.iter().filter(|f| f.verbs.contains(verb)).map(|f| f.name);
    let context = verb.context();
    match nearest(&name, known) {
        Some(k) => {
            let spelled = if text.starts_with("--") { format!("--{}", k.replace('_', "-")) } else { format!("-{k}") };
            UsageError(format!("{context}unknown flag '{text}'; did you mean '{spelled}'?"))
        }
        None => UsageError(format!("{context}unknown flag '{text}'")),
    }
}

/// A render's argument that is not a flag; the first argument of the line may be a
/// mistyped command (`stich` → `stitch`).
pub fn unexpected_argument(text: &str, first: bool) -> UsageError {
    match nearest(text, Verb::NAMED.iter().map(|v| v.name())).filter(|_| first) {
        Some(verb) => UsageError(format!("unexpected argument '{text}'; did you mean the command '{verb}'?")),
        None => UsageError(format!("unexpected argument '{text}': flags start with '-'")),
    }
}

/// What each command is for, in help, after its synopsis: the verb, what it takes besides
/// flags, and a paragraph.
const COMMANDS: [(Verb, &str, &str); 7] = [
    (
        Stitch,
        "",
        "Assembles the part files of a --tile render into the images a single render writes,
  byte for byte. Refuses, naming them, when parts are missing or come from different
  renders (or from another scene or size than -input/-size say). Deletes the parts once
  the images are written.",
    ),
    (
        Batch,
        "FILE",
        "Runs every line of FILE as a render command line (the course's commands.txt works as it
  is: arguments without the program name, paths relative to the working directory, split at
  spaces), in one process with one GPU device. Blank lines and lines starting with # are
  skipped. A failing line is reported with its number and the rest still run; the exit
  status is then 1. -q, -v and --threads belong on batch's own command line (on a line of
  FILE they are ignored).",
    ),
    (
        Selftest,
        "",
        "Checks this machine's GPU and driver: renders built-in hard cases (degenerate and
  edge-on triangles, far and squashed spheres, a horizon) and scenes like the course's on
  the GPU and with the f64 reference, prints a table (case, outputs, pixels off, verdict)
  with the adapter and driver, and exits 1 where the driver is not faithful.",
    ),
    (
        Bench,
        "",
        "Times the GPU kernel on the course scenes, larger meshes and image sizes, with the error
  against the f64 reference for each row; prints a Markdown table and writes DIR/bench.csv
  and DIR/bench.png.",
    ),
    (
        Compare,
        "",
        "Renders the outputs listed (or named by -output, -normals, -depth, whose files are not
  written) with the GPU and with the f64 reference, and prints their differences per
  output: pixels more than 1 level apart, hit/miss disagreements, depth and normal errors,
  NaN/inf counts. Exits 1 when an output has more than 0.1 % of its pixels (or N pixels)
  more than 1 level off, or the GPU produced NaN or infinity. Takes the kernel flags and
  -shade_back; not --backend (it always runs both).",
    ),
    (
        Grade,
        "ASSIGNMENT",
        "Judges a student's images for the course's assignment folder ASSIGNMENT (its
  commands.txt, scenes and meshes): every image its command lines write is rendered by us
  and compared with the student's by NVIDIA's FLIP (0: no visible difference, 1: the
  largest) and by the pixels more than 1 level off. Prints a line per image and exits 0 when
  every image passes, 1 when any fails or is missing. The images come from --images DIR or
  from --run COMMAND; a crash, a time-out or a missing file is that image's verdict.",
    ),
    (
        Gallery,
        "CORPUS",
        "Renders every command line of the course's assignment folders under CORPUS (a2 … a7)
  onto one HTML page, beside the course's own image from aN/expected/ where there is one,
  with the FLIP map between them.",
    ),
];

const USAGE_HEAD: &str = "raycaster: render an MIT 6.837 scene file on the GPU (wgpu) or with the f64 CPU reference";

const USAGE_TAIL: &str = "\
Flags take one or two dashes; `-shade_back` and `--shade-back` are the same. A flag with
one value also takes it after '=' (--backend=cpu); -size and -depth take theirs after spaces.
-q, -v and --threads apply to every command. At least one of -output, -normals, -depth is
required. On a terminal, work that lasts more than a second shows a progress bar on stderr.";

/// The lines around docs/SPEC.md §1's copy of [`markdown_table`].
#[cfg(test)]
const SPEC_TABLE_BEGIN: &str =
    "<!-- The flag table, generated from src/app/flags.rs (markdown_table): edit it there. -->";
#[cfg(test)]
const SPEC_TABLE_END: &str = "<!-- End of the generated flag table. -->";

/// Synopses are wrapped to this width.
const WIDTH: usize = 90;

/// The usage text `--help` prints: the render's synopsis and every flag it takes, then
/// each command's synopsis, paragraph and the flags only it takes.
pub fn usage() -> String {
    let mut text = format!("{USAGE_HEAD}\n\n");
    text += &synopsis("Usage: raycaster", Render, "");
    text += "\n";
    FLAGS.iter().filter(|f| f.verbs.contains(Render)).for_each(|f| text += &f.help_lines());
    // A flag of several commands is explained under the first of them only.
    let mut explained: Vec<&str> = Vec::new();
    for (verb, operand, paragraph) in COMMANDS {
        text += "\n";
        text += &synopsis(&format!("raycaster {}", verb.name()), verb, operand);
        text += &format!("  {paragraph}\n");
        for flag in FLAGS.iter().filter(|f| f.verbs.contains(verb) && !f.verbs.contains(Render)) {
            if !explained.contains(&flag.name) {
                explained.push(flag.name);
                text += &flag.help_lines();
            }
        }
    }
    text + "\n" + USAGE_TAIL
}

/// `start`, then `operand` and every flag `verb` takes, wrapped under the first. The flags
/// every command takes are listed once, in the render's; `-q | -v` exclude each other.
fn synopsis(start: &str, verb: Verb, operand: &str) -> String {
    let flags = FLAGS.iter().filter(|f| f.verbs.contains(verb) && !matches!(f.takes, Takes::Answer(_)));
    let flags = flags.filter(|f| verb == Render || f.verbs != Verbs::EVERY);
    let mut words: Vec<String> = Vec::new();
    words.extend((!operand.is_empty()).then(|| operand.to_string()));
    for flag in flags {
        match (&flag.takes, words.last_mut()) {
            (Takes::Verbosity(_), Some(last)) if last.starts_with("[-q") => {
                *last = format!("{} | -{}]", last.trim_end_matches(']'), flag.short.unwrap_or(flag.name));
            }
            (Takes::Verbosity(_), _) => words.push(format!("[-{}]", flag.short.unwrap_or(flag.name))),
            _ => words.push(flag.synopsis(verb)),
        }
    }
    let indent = " ".repeat(start.len() + 1);
    let mut lines = vec![start.to_string()];
    for word in words {
        let line = lines.last_mut().expect("starts with one line");
        if line.len() + 1 + word.len() > WIDTH && line.len() > indent.len() {
            lines.push(format!("{indent}{word}"));
        } else {
            line.push(' ');
            line.push_str(&word);
        }
    }
    lines.join("\n") + "\n"
}

/// The flag table as docs/SPEC.md §1 shows it, in Markdown: one row a flag, in help's order,
/// with the commands that take it and its help (joined into one line) followed by its
/// [`Flag::details`]. The copy in the spec is checked against this by a test, which is
/// all that calls it: the spec is edited by pasting what the test prints.
#[cfg(test)]
pub fn markdown_table() -> String {
    let cell = |text: &str| text.replace('\n', " ").replace('|', "\\|");
    let mut table = String::from("| flag | value | commands | effect |\n| --- | --- | --- | --- |\n");
    for flag in FLAGS {
        let value = match &flag.takes {
            Takes::Choice { names, .. } => names().join("|"),
            _ => flag.metavar.to_string(),
        };
        let value = if value.is_empty() { String::new() } else { format!("`{}`", cell(&value)) };
        let commands = if flag.verbs == Verbs::EVERY {
            "all".to_string()
        } else {
            let verbs = [Render, Compare, Batch, Stitch, Bench, Grade, Gallery, Selftest];
            let named = verbs.into_iter().filter(|v| flag.verbs.contains(*v)).map(|v| {
                let name = if v == Render { "render" } else { v.name() };
                if flag.required.contains(v) {
                    format!("{name} (required)")
                } else {
                    name.to_string()
                }
            });
            named.collect::<Vec<_>>().join(", ")
        };
        // The value's limits, from what parsing checks.
        let limits = match &flag.takes {
            Takes::Number { min, max, .. } if *max < u64::MAX => format!("{} from {min} to {max}", flag.metavar),
            Takes::Samples { .. } => {
                format!("N from 1 to {}", raycaster::sampling::MAX_SAMPLES)
            }
            Takes::Positive { .. } => format!("{} > 0", flag.metavar),
            Takes::Real { .. } => format!("{} ≥ 0", flag.metavar),
            _ => String::new(),
        };
        let effect = [flag.help, limits.as_str(), flag.details].into_iter().filter(|part| !part.is_empty());
        let effect = effect.map(cell).collect::<Vec<_>>().join("; ");
        table += &format!("| `{}` | {value} | {commands} | {effect} |\n", flag.spelled());
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every flag has one name, and its spellings cannot be taken for another's.
    #[test]
    fn names_are_unique() {
        let mut names: Vec<&str> = FLAGS.iter().flat_map(|f| [Some(f.name), f.short]).flatten().collect();
        let count = names.len();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), count);
    }

    /// Help lists every flag once, with its help, and the synopses hold only what the
    /// commands take.
    #[test]
    fn usage_lists_every_flag() {
        let text = usage();
        for flag in FLAGS {
            assert_eq!(text.matches(&format!("\n  {} ", flag.spelled())).count(), 1, "{}", flag.name);
            assert!(text.contains(flag.help.lines().next().unwrap()), "{}", flag.name);
        }
        assert!(text.contains("Usage: raycaster -input SCENE -size W H [-output FILE]"), "{text}");
        // A flag too long for the column gets its help on the next line, never glued on.
        assert!(text.contains("  -tessellation THETA PHI\n                         sphere facets"), "{text}");
        assert!(text.contains("raycaster batch FILE [--backend gpu|cpu|auto] [--shard K/N]\n"), "{text}");
        let compare = text.split("raycaster compare").nth(1).unwrap().split("  Renders").next().unwrap();
        assert!(!compare.contains("--backend") && !compare.contains("--tile"), "{compare}");
        for verb in [Render, Compare, Batch, Stitch, Bench, Grade, Gallery, Selftest] {
            let lines = synopsis("raycaster", verb, "");
            assert!(lines.lines().all(|l| l.chars().count() <= WIDTH), "{lines}");
        }
    }

    /// docs/SPEC.md §1's flag table is the one [`markdown_table`] generates from [`FLAGS`]:
    /// a flag added or changed here without the spec fails, printing the block to paste.
    #[test]
    fn the_specs_flag_table_is_generated_from_this_one() {
        let spec = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/SPEC.md")).unwrap();
        let (begin, end) = (SPEC_TABLE_BEGIN, SPEC_TABLE_END);
        let start = spec.find(begin).expect("docs/SPEC.md has the flag table's first marker") + begin.len();
        let stop = start + spec[start..].find(end).expect("docs/SPEC.md has the flag table's last marker");
        let expected = markdown_table();
        assert!(
            spec[start..stop].trim_matches('\n') == expected.trim_end(),
            "docs/SPEC.md §1's flag table differs from src/app/flags.rs; the table to paste between \
             the markers:\n\n{expected}"
        );
    }

    #[test]
    fn verbs_by_first_word() {
        assert_eq!(Verb::of_first(Some("stitch")), Stitch);
        assert_eq!(Verb::of_first(Some("-input")), Render);
        assert_eq!(Verb::of_first(None), Render);
    }
}
