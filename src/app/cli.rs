//! Command-line arguments (docs/SPEC.md §1). The course's single-dash spellings (`-input`,
//! `-shade_back`) and double-dash ones (`--input`, `--shade-back`) are the same flags, in any
//! order. Errors are one line naming the flag; the binary exits with status 2 on them.

use crate::app::split::Split;
use raycaster::image_io::ImageFormat;
use raycaster::render::{SphereTest, TriangleTest};
use std::ffi::OsString;
use std::fmt;
use std::path::{Path, PathBuf};

/// The largest image side: TGA stores sizes in 16 bits.
pub const MAX_SIDE: u32 = 65535;
/// The largest image, in pixels (16384²).
pub const MAX_PIXELS: u64 = 1 << 28;

pub const USAGE: &str = "\
raycaster: render an MIT 6.837 scene file on the GPU (wgpu) or with the f64 CPU reference

Usage: raycaster [compare] -input SCENE -size W H [-output FILE] [-normals FILE]
                 [-depth MIN MAX FILE] [-shade_back] [--backend gpu|cpu|auto]
                 [--triangle-test cramer|moller|watertight] [--sphere-test naive|robust]
                 [--tile K/N] [-q | -v] [--threads N]

  -input FILE            scene file (obj_file paths resolve from its folder)
  -size W H              image size in pixels
  -output FILE           diffuse-shaded image (.tga or .png; .exr: linear, unclamped)
  -normals FILE          normal visualisation |N| (.tga or .png; .exr: the signed normal)
  -depth MIN MAX FILE    depth visualisation, white at MIN, black at MAX (.tga or .png;
                         .exr: the distance t itself, +inf where nothing is hit; MIN and
                         MAX are then not used)
  -shade_back            shade back-facing hits as if they faced the viewer
  --backend B            gpu, cpu (the f64 reference) or auto (default: the GPU if one is
                         found, else the CPU with a notice)
  --triangle-test T      the GPU's ray/triangle test (default watertight)
  --sphere-test S        the GPU's ray/sphere test (default robust)
  --tile K/N             render only band K (0-based, from the top) of N bands of rows
                         and write FILE.part-K-of-N beside each output; see stitch
  -q, --quiet            errors only: no warnings, notices or progress bar
  -v, --verbose          also the adapter, the kernel variant, where the time went and
                         the peak memory
  --threads N            threads of the CPU reference (default: one per core)
  -h, --help             this text
  -V, --version          the version

raycaster stitch [-output FILE] [-normals FILE] [-depth MIN MAX FILE] [-input SCENE]
                 [-size W H] [--keep-parts]
  Assembles the part files of a --tile render into the images a single render writes,
  byte for byte. Refuses, naming them, when parts are missing or come from different
  renders (or from another scene or size than -input/-size say). Deletes the parts once
  the images are written, unless --keep-parts.

raycaster batch FILE [--backend B] [--shard K/N]
  Runs every line of FILE as a render command line (the course's commands.txt works as it
  is: arguments without the program name, paths relative to the working directory, split at
  spaces), in one process with one GPU device. Blank lines and lines starting with # are
  skipped. A failing line is reported with its number and the rest still run; the exit
  status is then 1. --shard K/N: run only the command lines whose index (0-based,
  counting command lines only, not blank or comment lines) is K modulo N. -q, -v and
  --threads belong on batch's own command line (on a line of FILE they are ignored).

raycaster bench [--quick] [--runs N] [--out DIR] [--corpus DIR] [--only NAME]
  Times the GPU kernel on the course scenes, larger meshes and image sizes, with the error
  against the f64 reference for each row; prints a Markdown table and writes DIR/bench.csv
  and DIR/bench.png (default DIR target/bench, 5 runs; the course's files are read from
  --corpus, else $RAYCASTER_CORPUS, else ../shared/mit6837 beside the source checkout).
  --quick: a few small cases, seconds in all. --only: the cases whose name contains NAME.

raycaster compare -input SCENE -size W H --outputs color,normals,depth [--max-diff-pixels N]
  Renders the outputs listed (or named by -output, -normals, -depth, whose files are not
  written) with the GPU and with the f64 reference, and prints their differences per
  output: pixels more than 1 level apart, hit/miss disagreements, depth and normal errors,
  NaN/inf counts. Exits 1 when an output has more than 0.1 % of its pixels (or N pixels)
  more than 1 level off, or the GPU produced NaN or infinity. Takes the kernel flags and
  -shade_back; not --backend (it always runs both).

Flags take one or two dashes; `-shade_back` and `--shade-back` are the same. A flag with
one value also takes it after '=' (--backend=cpu); -size and -depth take theirs after spaces.
-q, -v and --threads apply to every command. At least one of -output, -normals, -depth is
required. On a terminal, work that lasts more than a second shows a progress bar on stderr.";

/// Which renderer to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BackendChoice {
    Gpu,
    Cpu,
    #[default]
    Auto,
}

/// A render as the command line asks for it.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderArgs {
    pub input: PathBuf,
    pub width: u32,
    pub height: u32,
    pub output: Option<PathBuf>,
    pub normals: Option<PathBuf>,
    pub depth: Option<DepthArgs>,
    pub shade_back: bool,
    pub backend: BackendChoice,
    pub triangle_test: TriangleTest,
    pub sphere_test: SphereTest,
    /// `--tile K/N`: render band K of N and write part files (see [`crate::app::split`]).
    pub tile: Option<Split>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct DepthArgs {
    pub min: f32,
    pub max: f32,
    pub path: PathBuf,
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
    Help,
    /// `--version`, `-V`.
    Version,
}

/// Which images to compute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Outputs {
    pub color: bool,
    pub normals: bool,
    pub depth: bool,
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

/// `raycaster stitch`: the render's output flags, and what to check the parts against.
#[derive(Clone, Debug, PartialEq)]
pub struct StitchArgs {
    pub output: Option<PathBuf>,
    pub normals: Option<PathBuf>,
    pub depth: Option<DepthArgs>,
    /// Checked against the parts' scene hash when given.
    pub input: Option<PathBuf>,
    /// Checked against the parts' size when given.
    pub size: Option<(u32, u32)>,
    pub keep_parts: bool,
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

/// Parses the arguments after the program name. The flags every command shares (`-q`, `-v`,
/// `--threads`) are accepted and dropped: a batch line uses this, and those flags belong to
/// the process, not to one line of it.
pub fn parse_args<I, S>(args: I) -> Result<Command, UsageError>
where
    I: IntoIterator<Item = S>,
    S: Into<OsString>,
{
    parse_command_line(args).map(|line| line.command)
}

/// Parses the arguments after the program name: the command and the shared flags.
pub fn parse_command_line<I, S>(args: I) -> Result<CommandLine, UsageError>
where
    I: IntoIterator<Item = S>,
    S: Into<OsString>,
{
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    let mut habits = Habits::default();
    let command = if args.first().is_some_and(|a| a == "batch") {
        parse_batch(&args[1..], &mut habits)
    } else if args.first().is_some_and(|a| a == "bench") {
        parse_bench(&args[1..], &mut habits)
    } else if args.first().is_some_and(|a| a == "stitch") {
        parse_stitch(&args[1..], &mut habits)
    } else {
        parse_render(&args, &mut habits)
    }?;
    Ok(CommandLine { command, habits })
}

/// A render or `compare` command line.
fn parse_render(args: &[OsString], habits: &mut Habits) -> Result<Command, UsageError> {
    let compare = args.first().is_some_and(|a| a == "compare");
    let mut values = Values::new(args, usize::from(compare));
    let mut max_diff_pixels = None;
    let mut listed_outputs = None;
    let mut triangle_test = TriangleTest::default();
    let mut sphere_test = SphereTest::default();
    let mut input = None;
    let mut size = None;
    let (mut output, mut normals, mut depth) = (None, None, None);
    let mut shade_back = false;
    let mut backend = BackendChoice::Auto;
    let mut tile = None;
    while let Some(raw) = values.next_flag() {
        let text = raw.to_string_lossy().into_owned();
        let Some(flag) = flag_name(&text) else {
            return Err(unexpected_argument(&text, values.next == 1));
        };
        let set_once = |seen: bool| if seen { Err(UsageError(format!("{text} is given twice"))) } else { Ok(()) };
        match flag.as_str() {
            "h" | "help" => return Ok(Command::Help),
            "V" | "version" => return Ok(Command::Version),
            shared if Habits::takes(shared) => habits.accept(shared, &text, &mut values)?,
            "input" => {
                set_once(input.is_some())?;
                input = Some(values.path(&text)?);
            }
            "size" => {
                set_once(size.is_some())?;
                size = Some(values.size(&text)?);
            }
            "output" => {
                set_once(output.is_some())?;
                output = Some(values.image_path(&text)?);
            }
            "normals" => {
                set_once(normals.is_some())?;
                normals = Some(values.image_path(&text)?);
            }
            "depth" => {
                set_once(depth.is_some())?;
                depth = Some(values.depth(&text)?);
            }
            "shade_back" => shade_back = true,
            "backend" if compare => return Err(not_for_compare(&text)),
            "backend" => backend = values.backend(&text)?,
            "outputs" if compare => {
                set_once(listed_outputs.is_some())?;
                listed_outputs = Some(values.outputs(&text)?);
            }
            "triangle_test" => triangle_test = values.choice(&text, &TriangleTest::ALL.map(|t| (t.name(), t)))?,
            "sphere_test" => sphere_test = values.choice(&text, &SphereTest::ALL.map(|t| (t.name(), t)))?,
            "tile" if !compare => tile = Some(values.split(&text)?),
            "max_diff_pixels" if compare => {
                let value = values.take(&text, "a number of pixels")?;
                let text_value = value.to_string_lossy();
                max_diff_pixels = Some(
                    text_value
                        .parse::<u64>()
                        .map_err(|_| UsageError(format!("{text}: '{text_value}' is not a whole number of pixels")))?,
                );
            }
            _ => {
                let mut known = RENDER_FLAGS.to_vec();
                if compare {
                    known.retain(|&k| k != "backend" && k != "tile");
                    known.extend(["outputs", "max_diff_pixels"]);
                }
                return Err(unknown_flag("", &text, &known));
            }
        }
        values.no_value_left(&text)?;
    }
    let input = input.ok_or_else(|| UsageError("-input SCENE is required".into()))?;
    let (width, height) = size.ok_or_else(|| UsageError("-size W H is required".into()))?;
    if let Some(t) = tile.filter(|t: &Split| t.count > height) {
        return Err(UsageError(format!("--tile {}/{}: more bands than the image's {height} rows", t.index, t.count)));
    }
    let args = RenderArgs {
        input,
        width,
        height,
        output,
        normals,
        depth,
        shade_back,
        backend,
        triangle_test,
        sphere_test,
        tile,
    };
    if compare {
        return compare_command(args, listed_outputs.unwrap_or_default(), max_diff_pixels);
    }
    render_command(args)
}

/// A render command line, once its flags are read: it must write something, and no two
/// outputs may name one file.
fn render_command(args: RenderArgs) -> Result<Command, UsageError> {
    if output_paths(&args).is_empty() {
        return Err(UsageError("nothing to write: give -output, -normals or -depth".into()));
    }
    check_distinct_outputs(&args)?;
    Ok(Command::Render(args))
}

/// `compare`, once its flags are read: it compares the outputs listed with `--outputs` and
/// those given a file name (the old form), and needs at least one.
fn compare_command(args: RenderArgs, listed: Outputs, max_diff_pixels: Option<u64>) -> Result<Command, UsageError> {
    let outputs = Outputs {
        color: listed.color || args.output.is_some(),
        normals: listed.normals || args.normals.is_some(),
        depth: listed.depth || args.depth.is_some(),
    };
    if outputs == Outputs::default() {
        return Err(UsageError("compare: nothing to compare: give --outputs color,normals,depth".into()));
    }
    Ok(Command::Compare { args, outputs, max_diff_pixels })
}

fn not_for_compare(flag: &str) -> UsageError {
    UsageError(format!(
        "compare: {flag} does not apply: compare always renders with both the GPU and the f64 reference"
    ))
}

/// The image files a render writes, with the flag naming each.
fn output_paths(args: &RenderArgs) -> Vec<(&'static str, &Path)> {
    let depth = args.depth.as_ref().map(|d| d.path.as_path());
    [("-output", args.output.as_deref()), ("-normals", args.normals.as_deref()), ("-depth", depth)]
        .into_iter()
        .filter_map(|(flag, path)| Some((flag, path?)))
        .collect()
}

/// Refuses two outputs naming one file: one image would silently replace the other.
fn check_distinct_outputs(args: &RenderArgs) -> Result<(), UsageError> {
    let paths = output_paths(args);
    for (k, &(first_flag, first)) in paths.iter().enumerate() {
        if let Some((flag, path)) = paths[k + 1..].iter().find(|(_, path)| same_file(first, path)) {
            return Err(UsageError(format!(
                "{first_flag} {} and {flag} {} name the same file: one image would replace the other",
                first.display(),
                path.display()
            )));
        }
    }
    Ok(())
}

/// Whether two output paths name one file: equal as written, or once their folders are
/// resolved (`a.tga`, `./a.tga` and `out/../a.tga` are one file).
fn same_file(a: &Path, b: &Path) -> bool {
    a == b || resolved(a).is_some_and(|a| resolved(b) == Some(a))
}

fn resolved(path: &Path) -> Option<PathBuf> {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(folder.canonicalize().ok()?.join(path.file_name()?))
}

/// An output path that is an existing folder, or ends with a separator as folder names do.
fn names_a_folder(path: &Path) -> bool {
    path.is_dir() || path.as_os_str().to_string_lossy().ends_with(std::path::is_separator)
}

/// `batch FILE [--backend B]`.
fn parse_batch(args: &[OsString], habits: &mut Habits) -> Result<Command, UsageError> {
    let mut values = Values::new(args, 0);
    let (mut file, mut backend, mut shard) = (None, BackendChoice::Auto, None);
    while let Some(raw) = values.next_flag() {
        let text = raw.to_string_lossy().into_owned();
        match flag_name(&text).as_deref() {
            Some("backend") => backend = values.backend(&text)?,
            Some("shard") => shard = Some(values.split(&text)?),
            Some("h" | "help") => return Ok(Command::Help),
            Some("V" | "version") => return Ok(Command::Version),
            Some(shared) if Habits::takes(shared) => habits.accept(shared, &text, &mut values)?,
            Some(_) => return Err(unknown_flag("batch: ", &text, &[&["backend", "shard"], SHARED_FLAGS].concat())),
            None if file.is_none() => file = Some(PathBuf::from(raw)),
            None => return Err(UsageError(format!("batch: unexpected argument '{text}'"))),
        }
        values.no_value_left(&text)?;
    }
    let file = file.ok_or_else(|| UsageError("batch expects a file of command lines".into()))?;
    Ok(Command::Batch { file, backend, shard })
}

/// `stitch [-output O] [-normals N] [-depth MIN MAX D] [-input S] [-size W H] [--keep-parts]`.
fn parse_stitch(args: &[OsString], habits: &mut Habits) -> Result<Command, UsageError> {
    let mut values = Values::new(args, 0);
    let mut stitch =
        StitchArgs { output: None, normals: None, depth: None, input: None, size: None, keep_parts: false };
    while let Some(raw) = values.next_flag() {
        let text = raw.to_string_lossy().into_owned();
        match flag_name(&text).as_deref() {
            Some("output") => stitch.output = Some(values.image_path(&text)?),
            Some("normals") => stitch.normals = Some(values.image_path(&text)?),
            Some("depth") => stitch.depth = Some(values.depth(&text)?),
            Some("input") => stitch.input = Some(values.path(&text)?),
            Some("size") => stitch.size = Some(values.size(&text)?),
            Some("keep_parts") => stitch.keep_parts = true,
            Some("h" | "help") => return Ok(Command::Help),
            Some("V" | "version") => return Ok(Command::Version),
            Some(shared) if Habits::takes(shared) => habits.accept(shared, &text, &mut values)?,
            Some(_) => {
                let known = [&["output", "normals", "depth", "input", "size", "keep_parts"], SHARED_FLAGS].concat();
                return Err(unknown_flag("stitch: ", &text, &known));
            }
            None => return Err(UsageError(format!("stitch: unexpected argument '{text}'"))),
        }
        values.no_value_left(&text)?;
    }
    if stitch.output.is_none() && stitch.normals.is_none() && stitch.depth.is_none() {
        return Err(UsageError("stitch: nothing to stitch: give -output, -normals or -depth".into()));
    }
    Ok(Command::Stitch(stitch))
}

/// `bench [--quick] [--runs N] [--out DIR] [--corpus DIR]`.
fn parse_bench(args: &[OsString], habits: &mut Habits) -> Result<Command, UsageError> {
    let mut values = Values::new(args, 0);
    let mut bench =
        BenchArgs { quick: false, runs: 5, out: PathBuf::from("target/bench"), corpus: default_corpus(), only: None };
    while let Some(raw) = values.next_flag() {
        let text = raw.to_string_lossy().into_owned();
        match flag_name(&text).as_deref() {
            Some("quick") => bench.quick = true,
            Some("out") => bench.out = values.path(&text)?,
            Some("corpus") => bench.corpus = values.path(&text)?,
            Some("only") => {
                bench.only = Some(values.take(&text, "a part of a case name")?.to_string_lossy().into_owned())
            }
            Some("runs") => {
                let value = values.take(&text, "a number of runs")?;
                let text_value = value.to_string_lossy();
                bench.runs = match text_value.parse::<usize>() {
                    Ok(n) if n >= 1 => n,
                    _ => return Err(UsageError(format!("{text}: '{text_value}' is not a whole number ≥ 1"))),
                };
            }
            Some("h" | "help") => return Ok(Command::Help),
            Some("V" | "version") => return Ok(Command::Version),
            Some(shared) if Habits::takes(shared) => habits.accept(shared, &text, &mut values)?,
            Some(_) => {
                let known = [&["quick", "runs", "out", "corpus", "only"], SHARED_FLAGS].concat();
                return Err(unknown_flag("bench: ", &text, &known));
            }
            None => return Err(UsageError(format!("bench: unexpected argument '{text}'"))),
        }
        values.no_value_left(&text)?;
    }
    Ok(Command::Bench(bench))
}

/// `-shade_back`, `--shade-back` → `shade_back`; `None` for something that is not a flag
/// (a lone `-` or a word). A negative number is a value, never a flag, and values are read
/// by the flag that takes them, so `-depth -1 5 d.tga` works.
fn flag_name(arg: &str) -> Option<String> {
    let name = arg.strip_prefix("--").or_else(|| arg.strip_prefix('-'))?;
    if name.is_empty() {
        return None;
    }
    Some(name.replace('-', "_"))
}

/// The argument list with a cursor, and readers for each kind of flag value.
struct Values<'a> {
    args: &'a [OsString],
    next: usize,
    /// The value of a `--flag=value` argument, until the flag's reader takes it.
    inline: Option<OsString>,
}

impl<'a> Values<'a> {
    fn new(args: &'a [OsString], next: usize) -> Self {
        Values { args, next, inline: None }
    }

    fn next_raw(&mut self) -> Option<&OsString> {
        let arg = self.args.get(self.next)?;
        self.next += 1;
        Some(arg)
    }

    /// The next argument where a flag is expected; `--flag=value` is split there, and its
    /// value is what the flag's reader takes first.
    fn next_flag(&mut self) -> Option<OsString> {
        let raw = self.next_raw()?.clone();
        if let Some((name, value)) = raw.to_str().and_then(|t| t.split_once('=')) {
            if flag_name(name).is_some() {
                self.inline = Some(value.into());
                return Some(name.into());
            }
        }
        Some(raw)
    }

    /// After a flag's reader: a `=value` it did not take was given to a flag without values.
    fn no_value_left(&mut self, flag: &str) -> Result<(), UsageError> {
        match self.inline.take() {
            Some(value) => Err(UsageError(format!("{flag} takes no value, got '={}'", value.to_string_lossy()))),
            None => Ok(()),
        }
    }

    /// Flags with several values take them as separate arguments only: `-size=200 200` would
    /// read as if the first value belonged to the flag and the second did not.
    fn no_inline_value(&self, flag: &str, usage: &str) -> Result<(), UsageError> {
        match &self.inline {
            Some(_) => Err(UsageError(format!("{flag}= is not supported: write {usage}"))),
            None => Ok(()),
        }
    }

    fn take(&mut self, flag: &str, what: &str) -> Result<OsString, UsageError> {
        if let Some(value) = self.inline.take() {
            return Ok(value);
        }
        self.next_raw().cloned().ok_or_else(|| UsageError(format!("{flag} expects {what}")))
    }

    fn path(&mut self, flag: &str) -> Result<PathBuf, UsageError> {
        let value = self.take(flag, "a file name")?;
        if value.is_empty() {
            return Err(UsageError(format!("{flag} expects a file name, got an empty one")));
        }
        Ok(PathBuf::from(value))
    }

    fn image_path(&mut self, flag: &str) -> Result<PathBuf, UsageError> {
        let path = self.path(flag)?;
        if names_a_folder(&path) {
            return Err(UsageError(format!(
                "{flag} {}: names a folder; give an image file name, such as {}",
                path.display(),
                path.join("image.tga").display()
            )));
        }
        if ImageFormat::from_path(&path).is_none() {
            return Err(UsageError(format!(
                "{flag} {}: unsupported image format, use .tga, .png or .exr",
                path.display()
            )));
        }
        Ok(path)
    }

    fn size(&mut self, flag: &str) -> Result<(u32, u32), UsageError> {
        let what = "two sizes: W H";
        self.no_inline_value(flag, &format!("{flag} W H"))?;
        let w = self.take(flag, what)?;
        let h = self.take(flag, what)?;
        let side = |v: &OsString| -> Result<u32, UsageError> {
            let text = v.to_string_lossy();
            match text.parse::<u32>() {
                Ok(n) if (1..=MAX_SIDE).contains(&n) => Ok(n),
                _ => Err(UsageError(format!("{flag}: '{text}' is not a whole number from 1 to {MAX_SIDE}"))),
            }
        };
        let (w, h) = (side(&w)?, side(&h)?);
        if w as u64 * h as u64 > MAX_PIXELS {
            return Err(UsageError(format!("{flag} {w} {h}: more than {MAX_PIXELS} pixels")));
        }
        Ok((w, h))
    }

    fn depth(&mut self, flag: &str) -> Result<DepthArgs, UsageError> {
        let what = "three values: MIN MAX FILE";
        self.no_inline_value(flag, &format!("{flag} MIN MAX FILE"))?;
        let number = |v: OsString| -> Result<f32, UsageError> {
            let text = v.to_string_lossy();
            match text.parse::<f32>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(UsageError(format!("{flag}: '{text}' is not a finite number"))),
            }
        };
        let min = number(self.take(flag, what)?)?;
        let max = number(self.take(flag, what)?)?;
        if self.next >= self.args.len() {
            return Err(UsageError(format!("{flag} expects {what}")));
        }
        let path = self.image_path(flag)?;
        if min >= max {
            return Err(UsageError(format!("{flag}: MIN ({min}) must be less than MAX ({max})")));
        }
        Ok(DepthArgs { min, max, path })
    }

    /// `--outputs color,normals,depth`: a comma-separated list (`colour` is also accepted).
    fn outputs(&mut self, flag: &str) -> Result<Outputs, UsageError> {
        let value = self.take(flag, "a list such as color,normals,depth")?;
        let mut outputs = Outputs::default();
        for name in value.to_string_lossy().split(',') {
            match name {
                "color" | "colour" => outputs.color = true,
                "normals" => outputs.normals = true,
                "depth" => outputs.depth = true,
                _ => return Err(UsageError(format!("{flag}: '{name}' is not one of color, normals, depth"))),
            }
        }
        Ok(outputs)
    }

    /// `K/N`: member K (0-based) of N.
    fn split(&mut self, flag: &str) -> Result<Split, UsageError> {
        let value = self.take(flag, "K/N")?;
        let text = value.to_string_lossy();
        Split::parse(&text)
            .ok_or_else(|| UsageError(format!("{flag}: '{text}' is not K/N with whole numbers 0 ≤ K < N")))
    }

    fn backend(&mut self, flag: &str) -> Result<BackendChoice, UsageError> {
        self.choice(flag, &[("gpu", BackendChoice::Gpu), ("cpu", BackendChoice::Cpu), ("auto", BackendChoice::Auto)])
    }

    /// One of a fixed set of words.
    fn choice<T: Copy>(&mut self, flag: &str, choices: &[(&str, T)]) -> Result<T, UsageError> {
        let names: Vec<&str> = choices.iter().map(|(name, _)| *name).collect();
        let value = self.take(flag, &names.join(", "))?;
        let text = value.to_string_lossy();
        choices
            .iter()
            .find(|(name, _)| *name == text)
            .map(|(_, v)| *v)
            .ok_or_else(|| UsageError(format!("{flag}: '{text}' is not one of {}", names.join(", "))))
    }
}

/// A parsed command line: what to do, and the flags every command shares.
#[derive(Clone, Debug, PartialEq)]
pub struct CommandLine {
    pub command: Command,
    pub habits: Habits,
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

/// The most `--threads` accepts: far above any core count, low enough to refuse a typo.
pub const MAX_THREADS: usize = 1024;

/// The shared flags' names, as [`flag_name`] spells them.
const SHARED_FLAGS: &[&str] = &["q", "quiet", "v", "verbose", "threads", "version", "help"];

/// The render command line's flags, for "did you mean".
const RENDER_FLAGS: &[&str] = &[
    "input",
    "size",
    "output",
    "normals",
    "depth",
    "shade_back",
    "backend",
    "triangle_test",
    "sphere_test",
    "tile",
    "quiet",
    "verbose",
    "threads",
    "version",
    "help",
];

impl Habits {
    /// Whether `flag` (as [`flag_name`] spells it) is one of the shared flags.
    fn takes(flag: &str) -> bool {
        matches!(flag, "q" | "quiet" | "v" | "verbose" | "threads")
    }

    fn accept(&mut self, flag: &str, text: &str, values: &mut Values) -> Result<(), UsageError> {
        let verbosity = match flag {
            "q" | "quiet" => Verbosity::Quiet,
            "v" | "verbose" => Verbosity::Verbose,
            _ => {
                let value = values.take(text, "a number of threads")?;
                let value = value.to_string_lossy();
                self.threads = match value.parse::<usize>() {
                    Ok(n) if (1..=MAX_THREADS).contains(&n) => Some(n),
                    _ => {
                        return Err(UsageError(format!(
                            "{text}: '{value}' is not a whole number from 1 to {MAX_THREADS}"
                        )))
                    }
                };
                return Ok(());
            }
        };
        if self.verbosity != Verbosity::Normal && self.verbosity != verbosity {
            return Err(UsageError(format!("{text}: -q and -v cannot be given together")));
        }
        self.verbosity = verbosity;
        Ok(())
    }
}

/// "unknown flag", with the nearest known flag when one is close enough to be a typo, spelled
/// with the dashes the user typed (`-outptu` → `-output`, `--shade-bakc` → `--shade-back`).
fn unknown_flag(context: &str, text: &str, known: &[&str]) -> UsageError {
    let name = flag_name(text).unwrap_or_default();
    let nearest = known
        .iter()
        .filter(|k| k.len() > 1)
        .map(|k| (strsim::jaro_winkler(&name, k), *k))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    match nearest {
        // Below about 0.85, Jaro–Winkler pairs unrelated words of similar length.
        Some((score, k)) if score >= 0.85 => {
            let spelled = if text.starts_with("--") { format!("--{}", k.replace('_', "-")) } else { format!("-{k}") };
            UsageError(format!("{context}unknown flag '{text}'; did you mean '{spelled}'?"))
        }
        _ => UsageError(format!("{context}unknown flag '{text}'")),
    }
}

/// The commands besides a plain render, for "did you mean".
const COMMANDS: &[&str] = &["compare", "batch", "bench", "stitch"];

/// A render's argument that is not a flag; the first argument of the line may be a
/// mistyped command (`stich` → `stitch`).
fn unexpected_argument(text: &str, first: bool) -> UsageError {
    let nearest = COMMANDS.iter().map(|c| (strsim::jaro_winkler(text, c), *c)).max_by(|a, b| a.0.total_cmp(&b.0));
    match nearest {
        Some((score, command)) if first && score >= 0.85 => {
            UsageError(format!("unexpected argument '{text}'; did you mean the command '{command}'?"))
        }
        _ => UsageError(format!("unexpected argument '{text}': flags start with '-'")),
    }
}

/// Where `raycaster bench` looks for the course's files without `--corpus`:
/// `$RAYCASTER_CORPUS`, else `../shared/mit6837` beside the crate, as the tests do. The bench
/// is a developer's tool run from a checkout, so the checkout's path, not the working
/// directory, is what stays true.
fn default_corpus() -> PathBuf {
    match std::env::var_os("RAYCASTER_CORPUS") {
        Some(dir) if !dir.is_empty() => PathBuf::from(dir),
        _ => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/mit6837"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(line: &str) -> Result<Command, UsageError> {
        parse_args(line.split_whitespace())
    }

    fn render(line: &str) -> RenderArgs {
        match parse(line) {
            Ok(Command::Render(args)) => args,
            other => panic!("{line}: {other:?}"),
        }
    }

    #[test]
    fn course_command_line_parses() {
        let args = render("-input s.txt -size 200 100 -output o.tga -depth 9 11 d.tga -normals n.tga -shade_back");
        assert_eq!(args.input, PathBuf::from("s.txt"));
        assert_eq!((args.width, args.height), (200, 100));
        assert_eq!(args.output, Some(PathBuf::from("o.tga")));
        assert_eq!(args.normals, Some(PathBuf::from("n.tga")));
        assert_eq!(args.depth, Some(DepthArgs { min: 9.0, max: 11.0, path: "d.tga".into() }));
        assert!(args.shade_back);
        assert_eq!(args.backend, BackendChoice::Auto);
    }

    #[test]
    fn double_dash_spellings_and_any_order() {
        let a = render("--shade-back --output o.png --size 3 4 --input s.txt --backend cpu");
        let b = render("-input s.txt -size 3 4 -output o.png -shade_back --backend cpu");
        assert_eq!(a, b);
        assert_eq!(a.backend, BackendChoice::Cpu);
    }

    #[test]
    fn negative_depth_range_is_values_not_flags() {
        let args = render("-input s -size 1 1 -depth -5 -1.5 d.tga");
        assert_eq!(args.depth, Some(DepthArgs { min: -5.0, max: -1.5, path: "d.tga".into() }));
    }

    #[test]
    fn kernel_variants_and_compare() {
        let args = render("-input s -size 1 1 -output o.tga --triangle-test moller --sphere-test naive");
        assert_eq!((args.triangle_test, args.sphere_test), (TriangleTest::Moller, SphereTest::Naive));
        let default = render("-input s -size 1 1 -output o.tga");
        assert_eq!((default.triangle_test, default.sphere_test), (TriangleTest::Watertight, SphereTest::Robust));
        match parse("compare -input s -size 1 1 -normals n.tga --max-diff-pixels 7") {
            Ok(Command::Compare { args, outputs, max_diff_pixels }) => {
                assert_eq!(max_diff_pixels, Some(7));
                assert_eq!(args.normals, Some(PathBuf::from("n.tga")));
                assert_eq!(outputs, Outputs { normals: true, ..Outputs::default() });
            }
            other => panic!("{other:?}"),
        }
        // Only compare takes --max-diff-pixels.
        assert!(parse("-input s -size 1 1 -output o.tga --max-diff-pixels 7").is_err());
        assert!(parse("-input s -size 1 1 -output o.tga --triangle-test fast")
            .unwrap_err()
            .0
            .contains("cramer, moller, watertight"));
    }

    /// `compare` takes `--outputs` instead of file names (or both), and refuses `--backend`.
    #[test]
    fn compare_outputs() {
        match parse("compare -input s -size 2 2 --outputs depth,colour -normals n.tga") {
            Ok(Command::Compare { args, outputs, max_diff_pixels: None }) => {
                assert_eq!(outputs, Outputs { color: true, normals: true, depth: true });
                assert_eq!((args.output, args.depth), (None, None));
            }
            other => panic!("{other:?}"),
        }
        let cases = [
            ("compare -input s -size 2 2 --outputs color --backend gpu", "compare: --backend does not apply"),
            ("compare -input s -size 2 2 --outputs color --outputs depth", "--outputs is given twice"),
            ("compare -input s -size 2 2 --outputs color,", "--outputs: '' is not one of"),
            ("compare -input s -size 2 2", "nothing to compare"),
            ("-input s -size 2 2 --outputs color", "unknown flag '--outputs'"),
        ];
        for (line, needle) in cases {
            assert!(parse(line).expect_err(line).0.contains(needle), "{line}: {:?}", parse(line));
        }
    }

    /// Two outputs naming one file are refused, however the name is spelled; compare writes
    /// no file, so it does not mind.
    #[test]
    fn outputs_must_name_distinct_files() {
        let err = parse("-input s -size 1 1 -normals a.tga -depth 0 1 ./a.tga").unwrap_err();
        assert_eq!(err.0, "-normals a.tga and -depth ./a.tga name the same file: one image would replace the other");
        // Unit tests run in the package root, which has a src folder.
        assert!(parse("-input s -size 1 1 -output a.tga -normals src/../a.tga").unwrap_err().0.contains("same file"));
        assert!(parse("-input s -size 1 1 -output a.tga -normals b.tga -depth 0 1 c.png").is_ok());
        assert!(parse("compare -input s -size 1 1 -output a.tga -normals a.tga").is_ok());
    }

    #[test]
    fn batch() {
        assert_eq!(
            parse("batch commands.txt --backend gpu"),
            Ok(Command::Batch { file: "commands.txt".into(), backend: BackendChoice::Gpu, shard: None })
        );
        assert!(parse("batch").unwrap_err().0.contains("expects a file"));
        assert!(parse("batch a b").unwrap_err().0.contains("'b'"));
    }

    #[test]
    fn help() {
        assert_eq!(parse("--help"), Ok(Command::Help));
        assert_eq!(parse("-input s -h"), Ok(Command::Help));
    }

    #[test]
    fn shared_flags_anywhere_and_for_every_command() {
        let line = parse_command_line("-q -input s -size 1 1 -output o.tga --threads 3".split_whitespace()).unwrap();
        assert_eq!(line.habits, Habits { verbosity: Verbosity::Quiet, threads: Some(3) });
        let line = parse_command_line("batch c.txt --verbose".split_whitespace()).unwrap();
        assert_eq!(line.habits.verbosity, Verbosity::Verbose);
        let line = parse_command_line("bench --quick -v --threads=1".split_whitespace()).unwrap();
        assert_eq!(line.habits, Habits { verbosity: Verbosity::Verbose, threads: Some(1) });
        // Defaults: normal verbosity, one thread per core.
        let line = parse_command_line("-input s -size 1 1 -output o.tga".split_whitespace()).unwrap();
        assert_eq!(line.habits, Habits::default());
        assert_eq!(parse("--version"), Ok(Command::Version));
        assert_eq!(parse("-V"), Ok(Command::Version));
        assert!(parse("-q -v").unwrap_err().0.contains("cannot be given together"));
    }

    #[test]
    fn flag_equals_value() {
        let a = render("--input=s.txt -size 3 4 --output=o.png --backend=cpu --triangle-test=moller");
        let b = render("-input s.txt -size 3 4 -output o.png --backend cpu --triangle-test moller");
        assert_eq!(a, b);
        // An '=' inside the value stays in the value.
        assert_eq!(render("--input=a=b.txt -size 1 1 -output o.tga").input, PathBuf::from("a=b.txt"));
        match parse("compare -input s -size 1 1 -output o.tga --max-diff-pixels=4") {
            Ok(Command::Compare { max_diff_pixels, .. }) => assert_eq!(max_diff_pixels, Some(4)),
            other => panic!("{other:?}"),
        }
        assert!(parse("--size=3 4 -input s -output o.tga").unwrap_err().0.contains("--size W H"));
        assert!(parse("-input s -size 1 1 -depth=1 2 d.tga").unwrap_err().0.contains("-depth MIN MAX FILE"));
        assert!(parse("-input s -size 1 1 -output o.tga --shade-back=yes").unwrap_err().0.contains("takes no value"));
        assert!(parse("-input s -size 1 1 -output o.tga --backend=").unwrap_err().0.contains("''"));
    }

    #[test]
    fn unknown_flags_suggest_the_nearest() {
        let cases = [
            ("-input s -size 1 1 -outptu o.tga", "did you mean '-output'?"),
            ("-input s -size 1 1 -output o.tga --shade-bakc", "did you mean '--shade-back'?"),
            ("-input s -size 1 1 -output o.tga -shadeback", "did you mean '-shade_back'?"),
            ("-input s -size 1 1 -output o.tga --thread 2", "did you mean '--threads'?"),
            ("compare -input s -size 1 1 -output o.tga --max-diff-pixel 2", "did you mean '--max-diff-pixels'?"),
            ("batch c.txt --backedn cpu", "did you mean '--backend'?"),
            ("bench --quik", "did you mean '--quick'?"),
            ("-input s -size 8 8 -output o.tga --tiel 0/2", "did you mean '--tile'?"),
            ("batch c.txt --shrad 0/2", "did you mean '--shard'?"),
            ("stitch -output o.tga --keep-part", "did you mean '--keep-parts'?"),
            ("stich -output o.tga", "did you mean the command 'stitch'?"),
        ];
        for (line, needle) in cases {
            let err = parse(line).expect_err(line).to_string();
            assert!(err.contains(needle), "{line}: {err}");
        }
        for line in ["-input s -size 1 1 -output o.tga -frobnicate", "-input s -size 1 1 -output o.tga -x"] {
            let err = parse(line).expect_err(line).to_string();
            assert!(!err.contains("did you mean"), "{line}: {err}");
        }
    }

    /// Each bad line gives an error naming the offending flag or value.
    #[test]
    fn errors_name_the_flag() {
        let cases = [
            ("-input s -size 1 1 -output o.tga -bogus", "-bogus"),
            ("-input s -size 1 -output o.tga", "-size"),
            ("-input s -size 0 10 -output o.tga", "-size"),
            ("-input s -size 10 x -output o.tga", "'x'"),
            ("-input s -size 70000 10 -output o.tga", "-size"),
            ("-input s -size 60000 60000 -output o.tga", "-size 60000 60000"),
            ("-input s -size 1 1 -depth 5 5 d.tga", "MIN (5) must be less than MAX (5)"),
            ("-input s -size 1 1 -depth 5 nan d.tga", "'nan'"),
            ("-input s -size 1 1 -depth 1 2", "-depth expects three values"),
            ("-input s -size 1 1 -output o.bmp", "unsupported image format"),
            ("-input s -size 1 1", "nothing to write"),
            ("-size 1 1 -output o.tga", "-input"),
            ("-input s -output o.tga", "-size"),
            ("-input s -size 1 1 -output o.tga --backend metal", "'metal'"),
            ("-input s -input t -size 1 1 -output o.tga", "-input is given twice"),
            ("-input s -size 1 1 -output o.tga stray", "'stray'"),
            ("-input", "-input expects a file name"),
            ("-input s -size 1 1 -output o.tga --threads 0", "--threads: '0'"),
            ("-input s -size 1 1 -output o.tga --threads lots", "--threads: 'lots'"),
            ("-input s -size 1 1 -output o.tga --threads", "--threads expects a number"),
        ];
        for (line, needle) in cases {
            let err = parse(line).expect_err(line);
            assert!(err.to_string().contains(needle), "{line}: {err}");
            assert!(!err.to_string().contains('\n'), "{line}: not one line: {err}");
        }
    }
}
