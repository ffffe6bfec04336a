//! Command-line arguments (SPEC §1). The course's single-dash spellings (`-input`,
//! `-shade_back`) and double-dash ones (`--input`, `--shade-back`) are the same flags, in any
//! order. Errors are one line naming the flag; the binary exits with status 2 on them.

use crate::app::split::Split;
use raycaster::image_io::ImageFormat;
use raycaster::render::{SphereTest, TriangleTest};
use std::ffi::OsString;
use std::fmt;
use std::path::PathBuf;

/// The largest image side: TGA stores sizes in 16 bits.
pub const MAX_SIDE: u32 = 65535;
/// The largest image, in pixels (16384²).
pub const MAX_PIXELS: u64 = 1 << 28;

pub const USAGE: &str = "\
raycaster: render an MIT 6.837 scene file on the GPU (wgpu) or with the f64 CPU reference

Usage: raycaster [compare] -input SCENE -size W H [-output FILE] [-normals FILE]
                 [-depth MIN MAX FILE] [-shade_back] [--backend gpu|cpu|auto]
                 [--triangle-test cramer|moller|watertight] [--sphere-test naive|robust]
                 [--tile K/N]

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
  -h, --help             this text

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
  counting command lines only, not blank or comment lines) is K modulo N.

raycaster bench [--quick] [--runs N] [--out DIR] [--corpus DIR] [--only NAME]
  Times the GPU kernel on the course scenes, larger meshes and image sizes, with the error
  against the f64 reference for each row; prints a Markdown table and writes DIR/bench.csv
  and DIR/bench.png (default DIR target/bench, corpus ../shared/mit6837, 5 runs).
  --quick: a few small cases, seconds in all. --only: the cases whose name contains NAME.

raycaster compare ... [--max-diff-pixels N]
  Renders the outputs named with the GPU and with the f64 reference, writes no file, and
  prints their differences per output: pixels more than 1 level apart, hit/miss
  disagreements, depth and normal errors, NaN/inf counts. Exits 1 when an output has more
  than N pixels off by more than 1 level, or the GPU produced NaN or infinity.

Flags take one or two dashes; `-shade_back` and `--shade-back` are the same.
At least one of -output, -normals, -depth is required.";

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
    /// `raycaster compare`: GPU against the reference, nothing written.
    Compare {
        args: RenderArgs,
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

/// Parses the arguments after the program name.
pub fn parse_args<I, S>(args: I) -> Result<Command, UsageError>
where
    I: IntoIterator<Item = S>,
    S: Into<OsString>,
{
    let args: Vec<OsString> = args.into_iter().map(Into::into).collect();
    if args.first().is_some_and(|a| a == "batch") {
        return parse_batch(&args[1..]);
    }
    if args.first().is_some_and(|a| a == "bench") {
        return parse_bench(&args[1..]);
    }
    if args.first().is_some_and(|a| a == "stitch") {
        return parse_stitch(&args[1..]);
    }
    let compare = args.first().is_some_and(|a| a == "compare");
    let mut values = Values { args: &args, next: usize::from(compare) };
    let mut max_diff_pixels = None;
    let mut triangle_test = TriangleTest::default();
    let mut sphere_test = SphereTest::default();
    let mut input = None;
    let mut size = None;
    let (mut output, mut normals, mut depth) = (None, None, None);
    let mut shade_back = false;
    let mut backend = BackendChoice::Auto;
    let mut tile = None;
    while let Some(raw) = values.next_raw() {
        let text = raw.to_string_lossy().into_owned();
        let Some(flag) = flag_name(&text) else {
            return Err(UsageError(format!("unexpected argument '{text}': flags start with '-'")));
        };
        let set_once = |seen: bool| if seen { Err(UsageError(format!("{text} is given twice"))) } else { Ok(()) };
        match flag.as_str() {
            "h" | "help" => return Ok(Command::Help),
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
            "backend" => backend = values.backend(&text)?,
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
            _ => return Err(UsageError(format!("unknown flag '{text}'"))),
        }
    }
    let input = input.ok_or_else(|| UsageError("-input SCENE is required".into()))?;
    let (width, height) = size.ok_or_else(|| UsageError("-size W H is required".into()))?;
    if output.is_none() && normals.is_none() && depth.is_none() {
        return Err(UsageError("nothing to write: give -output, -normals or -depth".into()));
    }
    if let Some(t) = tile.filter(|t| t.count > height) {
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
        return Ok(Command::Compare { args, max_diff_pixels });
    }
    Ok(Command::Render(args))
}

/// `batch FILE [--backend B]`.
fn parse_batch(args: &[OsString]) -> Result<Command, UsageError> {
    let mut values = Values { args, next: 0 };
    let (mut file, mut backend, mut shard) = (None, BackendChoice::Auto, None);
    while let Some(raw) = values.next_raw() {
        let text = raw.to_string_lossy().into_owned();
        match flag_name(&text).as_deref() {
            Some("backend") => backend = values.backend(&text)?,
            Some("shard") => shard = Some(values.split(&text)?),
            Some("h" | "help") => return Ok(Command::Help),
            Some(_) => return Err(UsageError(format!("batch: unknown flag '{text}'"))),
            None if file.is_none() => file = Some(PathBuf::from(raw)),
            None => return Err(UsageError(format!("batch: unexpected argument '{text}'"))),
        }
    }
    let file = file.ok_or_else(|| UsageError("batch expects a file of command lines".into()))?;
    Ok(Command::Batch { file, backend, shard })
}

/// `stitch [-output O] [-normals N] [-depth MIN MAX D] [-input S] [-size W H] [--keep-parts]`.
fn parse_stitch(args: &[OsString]) -> Result<Command, UsageError> {
    let mut values = Values { args, next: 0 };
    let mut stitch =
        StitchArgs { output: None, normals: None, depth: None, input: None, size: None, keep_parts: false };
    while let Some(raw) = values.next_raw() {
        let text = raw.to_string_lossy().into_owned();
        match flag_name(&text).as_deref() {
            Some("output") => stitch.output = Some(values.image_path(&text)?),
            Some("normals") => stitch.normals = Some(values.image_path(&text)?),
            Some("depth") => stitch.depth = Some(values.depth(&text)?),
            Some("input") => stitch.input = Some(values.path(&text)?),
            Some("size") => stitch.size = Some(values.size(&text)?),
            Some("keep_parts") => stitch.keep_parts = true,
            Some("h" | "help") => return Ok(Command::Help),
            _ => return Err(UsageError(format!("stitch: unknown argument '{text}'"))),
        }
    }
    if stitch.output.is_none() && stitch.normals.is_none() && stitch.depth.is_none() {
        return Err(UsageError("stitch: nothing to stitch: give -output, -normals or -depth".into()));
    }
    Ok(Command::Stitch(stitch))
}

/// `bench [--quick] [--runs N] [--out DIR] [--corpus DIR]`.
fn parse_bench(args: &[OsString]) -> Result<Command, UsageError> {
    let mut values = Values { args, next: 0 };
    let mut bench = BenchArgs {
        quick: false,
        runs: 5,
        out: PathBuf::from("target/bench"),
        corpus: PathBuf::from("../shared/mit6837"),
        only: None,
    };
    while let Some(raw) = values.next_raw() {
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
            _ => return Err(UsageError(format!("bench: unknown argument '{text}'"))),
        }
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
}

impl Values<'_> {
    fn next_raw(&mut self) -> Option<&OsString> {
        let arg = self.args.get(self.next)?;
        self.next += 1;
        Some(arg)
    }

    fn take(&mut self, flag: &str, what: &str) -> Result<OsString, UsageError> {
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
            Ok(Command::Compare { args, max_diff_pixels }) => {
                assert_eq!(max_diff_pixels, Some(7));
                assert_eq!(args.normals, Some(PathBuf::from("n.tga")));
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
        ];
        for (line, needle) in cases {
            let err = parse(line).expect_err(line);
            assert!(err.to_string().contains(needle), "{line}: {err}");
            assert!(!err.to_string().contains('\n'), "{line}: not one line: {err}");
        }
    }
}
