//! Parsing the command line (docs/SPEC.md §1). The course's single-dash spellings (`-input`,
//! `-shade_back`) and double-dash ones (`--input`, `--shade-back`) are the same flags, in any
//! order. One loop reads every command's arguments: it looks each flag up in
//! [`flags::FLAGS`], reads the value the table says it takes and hands it to the flag's
//! setter; then the command is assembled from what was given. Parsing looks at the words
//! only; what depends on the file system is [`crate::app::validate`]'s, afterwards. Errors
//! are one line naming the flag; the binary exits with status 2 on them.

use crate::app::args::{
    BackendChoice, BenchArgs, Command, CommandLine, DepthArgs, GalleryArgs, GradeArgs, Habits, Judged, Limits, Picture,
    RenderArgs, RunArgs, Split, StitchArgs, Thresholds, UsageError, Verbosity, DEFAULT_MAX_FLIP_MEAN,
    DEFAULT_MAX_FLIP_P99, DEFAULT_TIME_LIMIT, MAX_PIXELS, MAX_SIDE,
};
use crate::app::flags::{self, flag_name, Answer, Flag, Given, Takes, Verb};
use raycaster::grid::GridSize;
use raycaster::render::{Output, Outputs};
use raycaster::sampling::{Sampler, Sampling, DEFAULT_FILTER, MAX_SAMPLES};
use std::ffi::OsString;
use std::path::PathBuf;

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
    let verb = Verb::of_first(args.first().and_then(|a| a.to_str()));
    let mut values = Values::new(&args, usize::from(verb != Verb::Render));
    let mut given = Given::default();
    let mut verbosity = Verbosity::Normal;
    let mut seen: Vec<&str> = Vec::new();
    let mut operand = None;
    while let Some(raw) = values.next_flag() {
        let text = raw.to_string_lossy().into_owned();
        let Some(name) = flag_name(&text) else {
            operand = Some(take_operand(verb, raw, &text, operand.is_some(), values.next == 1)?);
            continue;
        };
        let flag = flag_for(verb, &name, &text)?;
        if flag.once && seen.contains(&flag.name) {
            return Err(UsageError(format!("{text} is given twice")));
        }
        seen.push(flag.name);
        match &flag.takes {
            Takes::Answer(answer) => return Ok(CommandLine { command: answered(*answer), habits: Habits::default() }),
            Takes::Verbosity(v) if verbosity != Verbosity::Normal && verbosity != *v => {
                return Err(UsageError(format!("{text}: -q and -v cannot be given together")));
            }
            Takes::Verbosity(v) => verbosity = *v,
            _ => values.read(flag, &text, &mut given)?,
        }
        values.no_value_left(&text)?;
    }
    let habits = Habits { verbosity, threads: given.threads };
    Ok(CommandLine { command: assemble(verb, given, operand, &seen)?, habits })
}

/// The flag of `verb` named `name` (typed as `text`), or why there is none.
fn flag_for(verb: Verb, name: &str, text: &str) -> Result<&'static Flag, UsageError> {
    match Flag::find(name) {
        Some(flag) if flag.verbs.contains(verb) => Ok(flag),
        Some(Flag { refused: Some((refuser, why)), .. }) if *refuser == verb => {
            Err(UsageError(format!("{}: {text} does not apply: {why}", verb.name())))
        }
        _ => Err(flags::unknown_flag(verb, text)),
    }
}

/// An argument that is not a flag: batch's file, and an error anywhere else. The first
/// argument of a render may be a mistyped command.
fn take_operand(verb: Verb, raw: OsString, text: &str, have_one: bool, first: bool) -> Result<PathBuf, UsageError> {
    match verb {
        Verb::Render | Verb::Compare => Err(flags::unexpected_argument(text, first)),
        Verb::Batch | Verb::Grade | Verb::Gallery if !have_one => Ok(PathBuf::from(raw)),
        _ => Err(UsageError(format!("{}unexpected argument '{text}'", verb.context()))),
    }
}

fn answered(answer: Answer) -> Command {
    match answer {
        Answer::Help => Command::Help,
        Answer::Version => Command::Version,
    }
}

/// The command `verb` makes of what was given: required flags present, defaults filled in.
fn assemble(verb: Verb, given: Given, operand: Option<PathBuf>, seen: &[&str]) -> Result<Command, UsageError> {
    if let Some(missing) = flags::FLAGS.iter().find(|f| f.required.contains(verb) && !seen.contains(&f.name)) {
        return Err(UsageError(format!("-{} {} is required", missing.name, missing.metavar)));
    }
    match verb {
        Verb::Render | Verb::Compare => render_or_compare(verb, given),
        Verb::Batch => Ok(Command::Batch {
            file: operand.ok_or_else(|| UsageError("batch expects a file of command lines".into()))?,
            backend: given.backend.unwrap_or_default(),
            shard: given.shard,
        }),
        Verb::Stitch if given.files.outputs().is_empty() => {
            Err(UsageError("stitch: nothing to stitch: give -output, -normals or -depth".into()))
        }
        Verb::Stitch => Ok(Command::Stitch(StitchArgs {
            files: given.files,
            input: given.input,
            size: given.size,
            keep_parts: given.keep_parts,
        })),
        Verb::Selftest => Ok(Command::Selftest),
        Verb::Bench => Ok(Command::Bench(BenchArgs {
            quick: given.quick,
            runs: given.runs.unwrap_or(5),
            out: given.out.unwrap_or_else(|| PathBuf::from("target/bench")),
            corpus: given.corpus.unwrap_or_else(default_corpus),
            only: given.only,
        })),
        Verb::Grade => grade(given, operand),
        Verb::Gallery => Ok(Command::Gallery(GalleryArgs {
            corpus: operand.ok_or_else(|| UsageError("gallery expects the course's folder (with a2, a3, …)".into()))?,
            html: given.html.expect("required"),
            backend: given.backend.unwrap_or_default(),
        })),
    }
}

/// `grade ASSIGNMENT`: the student's images from exactly one of `--images` and `--run`.
fn grade(given: Given, operand: Option<PathBuf>) -> Result<Command, UsageError> {
    let assignment =
        operand.ok_or_else(|| UsageError("grade expects an assignment's folder (the one with commands.txt)".into()))?;
    let judged = match (given.images, given.run) {
        (Some(_), Some(_)) => return Err(UsageError("grade: give --images or --run, not both".into())),
        (None, None) => {
            return Err(UsageError(
                "grade: give --images DIR (the student's images) or --run COMMAND (their program)".into(),
            ))
        }
        (Some(dir), None) => {
            let run_only = [
                (given.time_limit.is_some(), "--time-limit"),
                (!given.limits.is_empty(), "--limit"),
                (!given.env.is_empty(), "--env"),
                (given.no_sandbox, "--no-sandbox"),
            ];
            if let Some((_, flag)) = run_only.iter().find(|(given, _)| *given) {
                return Err(UsageError(format!("grade: {flag} applies to --run only")));
            }
            Judged::Images(dir)
        }
        (None, Some(command)) if command.trim().is_empty() => {
            return Err(UsageError("grade: --run expects a command, got an empty one".into()))
        }
        (None, Some(command)) => Judged::Run(RunArgs {
            command,
            limits: limits(given.time_limit, &given.limits)?,
            trusted: given.no_sandbox,
            env: environment(given.env)?,
        }),
    };
    Ok(Command::Grade(GradeArgs {
        assignment,
        judged,
        html: given.html,
        // The f64 reference is the ground truth; a teacher may choose the GPU's speed.
        backend: given.backend.unwrap_or(BackendChoice::Cpu),
        thresholds: Thresholds {
            max_flip_mean: given.max_flip_mean.unwrap_or(DEFAULT_MAX_FLIP_MEAN),
            max_flip_p99: given.max_flip_p99.unwrap_or(DEFAULT_MAX_FLIP_P99),
            max_diff_pixels: given.max_diff_pixels,
        },
    }))
}

/// `--time-limit` and the `--limit`s, in the order given; the CPU time follows the wall
/// time unless set itself, so that a longer wall time is not cut short by it.
fn limits(time_limit: Option<f64>, given: &[String]) -> Result<Limits, UsageError> {
    let mut limits = Limits::default();
    let wall = time_limit.unwrap_or(DEFAULT_TIME_LIMIT);
    limits.wall = wall;
    for limit in given {
        limits.set(limit).map_err(|why| UsageError(format!("--limit {why}")))?;
    }
    if !given.iter().any(|l| l.starts_with("cpu=")) {
        limits.cpu = limits.wall.ceil() as u64;
    }
    Ok(limits)
}

/// `--env`'s variables as `NAME=VALUE`, a bare NAME taking the teacher's value.
fn environment(given: Vec<String>) -> Result<Vec<String>, UsageError> {
    given
        .into_iter()
        .map(|var| {
            let (name, value) = match var.split_once('=') {
                Some((name, value)) => (name.to_string(), Some(value.to_string())),
                None => (var.clone(), None),
            };
            let valid = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !valid {
                return Err(UsageError(format!("--env '{var}': not NAME or NAME=VALUE")));
            }
            let value = value.or_else(|| std::env::var(&name).ok()).unwrap_or_default();
            Ok(format!("{name}={value}"))
        })
        .collect()
}

/// A render must write something; `compare` compares the outputs listed with `--outputs`
/// and those given a file name (the old form), and needs at least one.
fn render_or_compare(verb: Verb, given: Given) -> Result<Command, UsageError> {
    let (width, height) = given.size.expect("required");
    if let Some(t) = given.tile.filter(|t| t.count > height) {
        return Err(UsageError(format!("--tile {}/{}: more bands than the image's {height} rows", t.index, t.count)));
    }
    let named = given.files.outputs();
    let sampling = sampling(&given);
    let args = RenderArgs {
        input: given.input.expect("required"),
        width,
        height,
        files: given.files,
        shading: given.shading,
        gui: given.gui,
        preview: given.gui || given.preview,
        backend: given.backend.unwrap_or_default(),
        triangle_test: given.triangle_test,
        sphere_test: given.sphere_test,
        tile: given.tile,
        grid: given.grid,
        visualize_grid: given.visualize_grid,
        stats: given.stats,
        sampling,
        pictures: given.pictures,
    };
    pictures_fit(&args)?;
    if args.tile.is_some() && !args.pictures.is_empty() {
        return Err(UsageError("--tile: -render_samples and -render_filter pictures are not split into bands".into()));
    }
    if args.visualize_grid && args.grid.is_none() {
        return Err(UsageError("-visualize_grid draws the grid's cells: give -grid NX NY NZ too".into()));
    }
    if let Some(t) = args.tile.filter(|_| args.stats) {
        return Err(UsageError(format!(
            "-stats with --tile {}/{}: a band counts only its own rows; render the image in one piece to count it",
            t.index, t.count
        )));
    }
    if verb == Verb::Render {
        // `-gui` alone asks for the course's window only: nothing to render, not an error.
        if named.is_empty() && args.pictures.is_empty() && !given.gui {
            return Err(UsageError("nothing to write: give -output, -normals or -depth".into()));
        }
        return Ok(Command::Render(args));
    }
    let outputs = given.outputs.union(named);
    if outputs.is_empty() {
        return Err(UsageError("compare: nothing to compare: give --outputs color,normals,depth".into()));
    }
    Ok(Command::Compare { args, outputs, max_diff_pixels: given.max_diff_pixels })
}

/// docs/SPEC.md §8: a sampler or a filter asks for sampling; the sampler defaults to one
/// sample at the pixel's centre, the filter to the box of radius ½.
fn sampling(given: &Given) -> Option<Sampling> {
    if given.sampler.is_none() && given.filter.is_none() {
        return None;
    }
    Some(Sampling {
        sampler: given.sampler.unwrap_or(Sampler::Uniform(1)),
        filter: given.filter.unwrap_or(DEFAULT_FILTER),
        seed: given.seed.unwrap_or(0),
    })
}

/// The pictures' sizes: `W·ZOOM × H·ZOOM` (the filter's one more each way) within the
/// image limits of `-size`.
fn pictures_fit(args: &RenderArgs) -> Result<(), UsageError> {
    for (flag, picture) in args.pictures.named() {
        let extra = u64::from(flag == "-render_filter");
        let (w, h) =
            (args.width as u64 * picture.zoom as u64 + extra, args.height as u64 * picture.zoom as u64 + extra);
        if w > MAX_SIDE as u64 || h > MAX_SIDE as u64 || w * h > MAX_PIXELS {
            return Err(UsageError(format!(
                "{flag} {} {}: a picture of {w}×{h} pixels is past the limits of -size",
                picture.path.display(),
                picture.zoom
            )));
        }
    }
    Ok(())
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

    /// Reads the value `flag` (typed as `text`) takes and hands it to the flag's setter.
    fn read(&mut self, flag: &Flag, text: &str, given: &mut Given) -> Result<(), UsageError> {
        if flag.takes.several_values() && self.inline.is_some() {
            return Err(UsageError(format!("{text}= is not supported: write {text} {}", flag.metavar)));
        }
        match &flag.takes {
            Takes::Switch(set) => set(given),
            Takes::Path(set) => set(given, self.path(text)?),
            Takes::Size(set) => set(given, self.size(text)?),
            Takes::Depth(set) => set(given, self.depth(text)?),
            Takes::Steps(set) => set(given, self.steps(text)?),
            Takes::Cells(set) => set(given, self.cells(text)?),
            Takes::Choice { names, set } => set(given, self.choice(text, &names())?),
            Takes::Real { what, set } => set(given, self.real(text, what)?),
            Takes::Positive { what, set } => set(given, self.positive(text, what)?),
            Takes::Samples { square, set } => set(given, self.samples(text, *square)?),
            Takes::Picture(set) => set(given, self.picture(text)?),
            Takes::Number { what, min, max, set } => set(given, self.number(text, what, *min, *max)?),
            Takes::Split(set) => set(given, self.split(text)?),
            Takes::Outputs(set) => set(given, self.outputs(text)?),
            Takes::Text { what, set } => set(given, self.take(text, what)?.to_string_lossy().into_owned()),
            Takes::Verbosity(_) | Takes::Answer(_) => unreachable!("handled by the parsing loop"),
        }
        Ok(())
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

    fn size(&mut self, flag: &str) -> Result<(u32, u32), UsageError> {
        let (w, h) = self.two_whole(flag, "two sizes: W H", 1..=MAX_SIDE, &format!("from 1 to {MAX_SIDE}"))?;
        if w as u64 * h as u64 > MAX_PIXELS {
            return Err(UsageError(format!("{flag} {w} {h}: more than {MAX_PIXELS} pixels")));
        }
        Ok((w, h))
    }

    fn steps(&mut self, flag: &str) -> Result<(u32, u32), UsageError> {
        self.two_whole(flag, "two numbers of steps: THETA PHI", 1..=u32::MAX, "of steps, 1 or more")
    }

    /// `-grid NX NY NZ`: three whole numbers ≥ 1, at most [`GridSize::MAX_CELLS`] cells.
    fn cells(&mut self, flag: &str) -> Result<GridSize, UsageError> {
        let what = "three numbers of cells: NX NY NZ";
        let [nx, ny, nz] = self.whole_numbers(flag, what, 1..=u32::MAX, "of cells, 1 or more")?;
        let size = GridSize { nx, ny, nz };
        if size.cells() > GridSize::MAX_CELLS {
            return Err(UsageError(format!("{flag} {nx} {ny} {nz}: more than {} cells", GridSize::MAX_CELLS)));
        }
        Ok(size)
    }

    /// Two whole numbers in `range` (see [`Self::whole_numbers`]).
    fn two_whole(
        &mut self,
        flag: &str,
        what: &str,
        range: std::ops::RangeInclusive<u32>,
        range_text: &str,
    ) -> Result<(u32, u32), UsageError> {
        let [first, second] = self.whole_numbers(flag, what, range, range_text)?;
        Ok((first, second))
    }

    /// `N` whole numbers in `range` (`what` names them where they are missing; `range_text`
    /// says the range where one is not in it). All are taken before any is checked, so that
    /// a missing one is reported as missing.
    fn whole_numbers<const N: usize>(
        &mut self,
        flag: &str,
        what: &str,
        range: std::ops::RangeInclusive<u32>,
        range_text: &str,
    ) -> Result<[u32; N], UsageError> {
        let mut values = Vec::with_capacity(N);
        for _ in 0..N {
            values.push(self.take(flag, what)?);
        }
        let mut numbers = [0; N];
        for (number, v) in numbers.iter_mut().zip(&values) {
            let text = v.to_string_lossy();
            *number = match text.parse::<u32>() {
                Ok(n) if range.contains(&n) => n,
                _ => return Err(UsageError(format!("{flag}: '{text}' is not a whole number {range_text}"))),
            };
        }
        Ok(numbers)
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
        let path = self.path(flag)?;
        if min >= max {
            return Err(UsageError(format!("{flag}: MIN ({min}) must be less than MAX ({max})")));
        }
        Ok(DepthArgs { min, max, path })
    }

    /// `--outputs color,normals,depth`: a comma-separated list (`colour` is also accepted).
    fn outputs(&mut self, flag: &str) -> Result<Outputs, UsageError> {
        let value = self.take(flag, "a list such as color,normals,depth")?;
        let mut outputs = Outputs::NONE;
        for name in value.to_string_lossy().split(',') {
            let output = match name {
                "color" | "colour" => Output::Color,
                "normals" => Output::Normals,
                "depth" => Output::Depth,
                _ => return Err(UsageError(format!("{flag}: '{name}' is not one of color, normals, depth"))),
            };
            outputs = outputs.with(output);
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

    /// One of a fixed set of words, as its index.
    fn choice(&mut self, flag: &str, names: &[&str]) -> Result<usize, UsageError> {
        let value = self.take(flag, &names.join(", "))?;
        let text = value.to_string_lossy();
        names
            .iter()
            .position(|name| *name == text)
            .ok_or_else(|| UsageError(format!("{flag}: '{text}' is not one of {}", names.join(", "))))
    }

    /// A whole number from `min` to `max`, `what` saying what it counts ("a number of runs").
    fn real(&mut self, flag: &str, what: &str) -> Result<f64, UsageError> {
        let value = self.take(flag, what)?;
        let text = value.to_string_lossy();
        match text.parse::<f64>() {
            Ok(w) if w.is_finite() && w >= 0.0 => Ok(w),
            _ => Err(UsageError(format!("{flag}: '{text}' is not a number ≥ 0"))),
        }
    }

    /// A filter's radius or σ: a finite number > 0.
    fn positive(&mut self, flag: &str, what: &str) -> Result<f64, UsageError> {
        let value = self.take(flag, what)?;
        let text = value.to_string_lossy();
        match text.parse::<f64>() {
            Ok(w) if w.is_finite() && w > 0.0 => Ok(w),
            _ => Err(UsageError(format!("{flag}: '{text}' is not a number > 0"))),
        }
    }

    /// Samples per pixel: 1…[`MAX_SAMPLES`], with `square` a perfect square (the regular
    /// patterns lay them on a √n × √n grid).
    fn samples(&mut self, flag: &str, square: bool) -> Result<u32, UsageError> {
        let n = self.number(flag, "a number of samples", 1, MAX_SAMPLES as u64)? as u32;
        if square && n.isqrt() * n.isqrt() != n {
            let (below, above) = (n.isqrt() * n.isqrt(), (n.isqrt() + 1) * (n.isqrt() + 1));
            return Err(UsageError(format!(
                "{flag}: {n} is not a square number: the samples lie on a √n×√n grid (try {below} or {above})"
            )));
        }
        Ok(n)
    }

    /// `FILE ZOOM` of `-render_samples` and `-render_filter`.
    fn picture(&mut self, flag: &str) -> Result<Picture, UsageError> {
        let what = "two values: FILE ZOOM";
        let path = self.take(flag, what)?;
        if path.is_empty() {
            return Err(UsageError(format!("{flag} expects a file name, got an empty one")));
        }
        let zoom = self.take(flag, what)?;
        let text = zoom.to_string_lossy();
        match text.parse::<u32>() {
            Ok(zoom) if (1..=MAX_SIDE).contains(&zoom) => Ok(Picture { path: PathBuf::from(path), zoom }),
            _ => Err(UsageError(format!("{flag}: '{text}' is not a whole number from 1 to {MAX_SIDE}"))),
        }
    }

    fn number(&mut self, flag: &str, what: &str, min: u64, max: u64) -> Result<u64, UsageError> {
        let value = self.take(flag, what)?;
        let text = value.to_string_lossy();
        match text.parse::<u64>() {
            Ok(n) if (min..=max).contains(&n) => Ok(n),
            _ => {
                let range = match (min, max) {
                    (_, u64::MAX) if min > 0 => format!("a whole number ≥ {min}"),
                    (_, u64::MAX) => format!("a whole {}", what.trim_start_matches("a ")),
                    _ => format!("a whole number from {min} to {max}"),
                };
                Err(UsageError(format!("{flag}: '{text}' is not {range}")))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::args::BackendChoice;
    use raycaster::render::{SphereTest, TriangleTest};

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
        assert_eq!(args.files.color, Some(PathBuf::from("o.tga")));
        assert_eq!(args.files.normals, Some(PathBuf::from("n.tga")));
        assert_eq!(args.files.depth, Some(DepthArgs { min: 9.0, max: 11.0, path: "d.tga".into() }));
        assert!(args.shading.shade_back);
        assert_eq!(args.backend, BackendChoice::Auto);
    }

    /// docs/SPEC.md §8: the samplers, the filters and their defaults, the seed, the pictures.
    #[test]
    fn sampling_flags() {
        use raycaster::sampling::Filter;
        assert_eq!(render("-input s -size 9 9 -output o.tga").sampling, None);
        let args = render("-input s -size 9 9 -output o.tga -jittered_samples 16 --seed 7");
        assert_eq!(args.sampling, Some(Sampling { sampler: Sampler::Jittered(16), filter: Filter::Box(0.5), seed: 7 }));
        let args = render("-input s -size 9 9 -output o.tga -gaussian_filter 0.4");
        assert_eq!(
            args.sampling,
            Some(Sampling { sampler: Sampler::Uniform(1), filter: Filter::Gaussian(0.4), seed: 0 })
        );
        let args = render("-input s -size 9 9 -render_filter f.tga 20 -tent_filter 1.7");
        assert_eq!(args.pictures.filter, Some(Picture { path: "f.tga".into(), zoom: 20 }));
        assert!(args.files.outputs().is_empty());
        let cases = [
            (
                "-uniform_samples 5",
                "-uniform_samples: 5 is not a square number: the samples lie on a √n×√n grid (try 4 or 9)",
            ),
            ("-jittered_samples 8", "-jittered_samples: 8 is not a square number"),
            ("-random_samples 0", "-random_samples: '0' is not a whole number from 1 to 1024"),
            ("-box_filter 0", "-box_filter: '0' is not a number > 0"),
            ("-tent_filter -1", "-tent_filter: '-1' is not a number > 0"),
            ("-gaussian_filter nan", "-gaussian_filter: 'nan' is not a number > 0"),
            ("--seed -1", "--seed: '-1' is not a whole number from 0 to 4294967295"),
            ("-render_samples s.tga 0", "-render_samples: '0' is not a whole number from 1 to 65535"),
            (
                "-render_samples s.tga 8000",
                "-render_samples s.tga 8000: a picture of 72000×72000 pixels is past the limits",
            ),
            ("-render_filter f.tga 2 --tile 0/2", "--tile: -render_samples and -render_filter pictures are not split"),
        ];
        for (extra, needle) in cases {
            let line = format!("-input s -size 9 9 -output o.tga {extra}");
            let err = parse(&line).expect_err(&line);
            assert!(err.0.contains(needle), "{line}: {err}");
        }
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
        assert_eq!(args.files.depth, Some(DepthArgs { min: -5.0, max: -1.5, path: "d.tga".into() }));
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
                assert_eq!(args.files.normals, Some(PathBuf::from("n.tga")));
                assert_eq!(outputs, Outputs::from(Output::Normals));
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

    /// `--exr-compression` takes OpenEXR's names of its lossless methods, on a render and on
    /// `stitch` (which writes the files of a split render); zip is the default. Anything else
    /// is refused by name, with the choices; `compare` writes no file and does not take it.
    #[test]
    fn exr_compression_choices() {
        use raycaster::image_io::ExrCompression;
        let chosen = |line: &str| render(line).files.exr_compression;
        assert_eq!(chosen("-input s -size 1 1 -depth 0 1 d.exr"), ExrCompression::Zip);
        assert_eq!(chosen("-input s -size 1 1 -depth 0 1 d.exr --exr-compression piz"), ExrCompression::Piz);
        assert_eq!(chosen("-input s -size 1 1 -output o.exr --exr-compression=rle"), ExrCompression::Rle);
        match parse("stitch -depth 0 1 d.exr --exr-compression none") {
            Ok(Command::Stitch(args)) => assert_eq!(args.files.exr_compression, ExrCompression::None),
            other => panic!("{other:?}"),
        }
        let refused = parse("-input s -size 1 1 -depth 0 1 d.exr --exr-compression lzw").unwrap_err().0;
        assert!(refused.contains("--exr-compression: 'lzw' is not one of none, rle, zips, zip, piz"), "{refused}");
        assert!(parse("compare -input s -size 1 1 -depth 0 1 d.exr --exr-compression zip").is_err());
    }

    /// `compare` takes `--outputs` instead of file names (or both), and refuses `--backend`.
    #[test]
    fn compare_outputs() {
        match parse("compare -input s -size 2 2 --outputs depth,colour -normals n.tga") {
            Ok(Command::Compare { args, outputs, max_diff_pixels: None }) => {
                assert_eq!(outputs, Outputs::ALL);
                assert_eq!((args.files.color, args.files.depth), (None, None));
            }
            other => panic!("{other:?}"),
        }
        let cases = [
            ("compare -input s -size 2 2 --outputs color --backend gpu", "compare: --backend does not apply"),
            ("compare -input s -size 2 2 --outputs color --outputs depth", "--outputs is given twice"),
            ("compare -input s -size 2 2 --outputs color,", "--outputs: '' is not one of"),
            ("compare -input s -size 2 2", "nothing to compare"),
            ("compare -input s -size 4 4 -output o.tga --tile 0/2", "unknown flag '--tile'"),
            ("-input s -size 2 2 --outputs color", "unknown flag '--outputs'"),
        ];
        for (line, needle) in cases {
            assert!(parse(line).expect_err(line).0.contains(needle), "{line}: {:?}", parse(line));
        }
    }

    #[test]
    fn batch() {
        assert_eq!(
            parse("batch commands.txt --backend gpu"),
            Ok(Command::Batch { file: "commands.txt".into(), backend: BackendChoice::Gpu, shard: None })
        );
        assert_eq!(
            parse("batch f --shard 0/2"),
            Ok(Command::Batch {
                file: "f".into(),
                backend: BackendChoice::Auto,
                shard: Some(Split { index: 0, count: 2 })
            })
        );
        assert!(parse("batch").unwrap_err().0.contains("expects a file"));
        assert!(parse("batch a b").unwrap_err().0.contains("'b'"));
    }

    #[test]
    fn stitch_and_tile() {
        match parse("stitch -depth 1 2 d.exr -size 4 9 --keep-parts") {
            Ok(Command::Stitch(s)) => {
                assert_eq!((s.size, s.keep_parts, s.files.color), (Some((4, 9)), true, None));
                assert_eq!(s.files.depth.map(|d| d.path), Some("d.exr".into()));
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(render("-input s -size 4 9 -output o.exr --tile 1/3").tile, Some(Split { index: 1, count: 3 }));
        // A band's -stats would count its own rows under the whole image's size.
        let stats = parse("-input s -size 8 8 -output o.tga --tile 0/2 -stats").unwrap_err().0;
        assert!(stats.starts_with("-stats with --tile 0/2: a band counts only its own rows"), "{stats}");
    }

    #[test]
    fn bench_defaults_and_values() {
        match parse("bench --runs 2 --only scene2 --out o") {
            Ok(Command::Bench(b)) => {
                assert_eq!((b.quick, b.runs, b.out, b.only), (false, 2, "o".into(), Some("scene2".into())));
            }
            other => panic!("{other:?}"),
        }
        match parse("bench --quick") {
            Ok(Command::Bench(b)) => assert_eq!((b.quick, b.runs, b.out), (true, 5, "target/bench".into())),
            other => panic!("{other:?}"),
        }
        assert_eq!(parse("bench --runs 0").unwrap_err().0, "--runs: '0' is not a whole number ≥ 1");
    }

    /// `grade`: the reference renders by default, the thresholds are the documented ones,
    /// and the student's images come from exactly one of `--images` and `--run`.
    #[test]
    fn grade_and_gallery_defaults_and_values() {
        let thresholds = Thresholds {
            max_flip_mean: DEFAULT_MAX_FLIP_MEAN,
            max_flip_p99: DEFAULT_MAX_FLIP_P99,
            max_diff_pixels: None,
        };
        match parse("grade a4 --images shots") {
            Ok(Command::Grade(g)) => assert_eq!(
                g,
                GradeArgs {
                    assignment: "a4".into(),
                    judged: Judged::Images("shots".into()),
                    html: None,
                    backend: BackendChoice::Cpu,
                    thresholds,
                }
            ),
            other => panic!("{other:?}"),
        }
        let words =
            ["grade", "a4", "--run", "python3 rt.py", "--time-limit", "2.5", "--max-flip-p99=0.5", "--html", "r.html"];
        match parse_args(words) {
            Ok(Command::Grade(g)) => {
                let limits = Limits { wall: 2.5, cpu: 3, ..Limits::default() };
                let run = RunArgs { command: "python3 rt.py".into(), limits, trusted: false, env: vec![] };
                assert_eq!(g.judged, Judged::Run(run));
                assert_eq!((g.thresholds.max_flip_p99, g.html), (0.5, Some("r.html".into())));
            }
            other => panic!("{other:?}"),
        }
        match parse("grade a4 --run ./rt") {
            Ok(Command::Grade(g)) => {
                let run = RunArgs { command: "./rt".into(), limits: Limits::default(), trusted: false, env: vec![] };
                assert_eq!(g.judged, Judged::Run(run))
            }
            other => panic!("{other:?}"),
        }
        std::env::set_var("RAYCASTER_TEST_GRADE_ENV", "theirs");
        let words = [
            "grade",
            "a4",
            "--run",
            "./rt",
            "--limit",
            "cpu=5",
            "--time-limit",
            "9",
            "--limit",
            "memory=1G",
            "--no-sandbox",
            "--env",
            "OMP_NUM_THREADS=1",
            "--env",
            "RAYCASTER_TEST_GRADE_ENV",
        ];
        match parse_args(words) {
            Ok(Command::Grade(GradeArgs { judged: Judged::Run(run), .. })) => {
                assert_eq!(run.limits, Limits { wall: 9.0, cpu: 5, memory: 1 << 30, ..Limits::default() });
                assert!(run.trusted);
                assert_eq!(run.env, ["OMP_NUM_THREADS=1", "RAYCASTER_TEST_GRADE_ENV=theirs"]);
            }
            other => panic!("{other:?}"),
        }
        match parse("gallery corpus --html g.html") {
            Ok(Command::Gallery(g)) => {
                assert_eq!((g.corpus, g.html, g.backend), ("corpus".into(), "g.html".into(), BackendChoice::Auto))
            }
            other => panic!("{other:?}"),
        }
        // Help states the defaults the code uses.
        let usage = flags::usage();
        for default in [DEFAULT_MAX_FLIP_MEAN, DEFAULT_MAX_FLIP_P99, DEFAULT_TIME_LIMIT] {
            assert!(
                usage.contains(&format!("(default {default})"))
                    || usage.contains(&format!("(default\n{:25}{default})", "")),
                "{default}"
            );
        }
        let errors = [
            ("grade a4", "grade: give --images DIR (the student's images) or --run COMMAND (their program)"),
            ("grade a4 --images s --run r", "grade: give --images or --run, not both"),
            ("grade a4 --images s --time-limit 3", "grade: --time-limit applies to --run only"),
            ("grade a4 --run r --time-limit 0", "--time-limit: '0' is not a number > 0"),
            ("grade a4 --images s --limit cpu=1", "grade: --limit applies to --run only"),
            ("grade a4 --images s --no-sandbox", "grade: --no-sandbox applies to --run only"),
            ("grade a4 --run r --limit disk=1G", "--limit no limit named 'disk'"),
            ("grade a4 --run r --env A-B", "--env 'A-B': not NAME or NAME=VALUE"),
            ("grade --images s", "grade expects an assignment's folder (the one with commands.txt)"),
            ("grade a4 a5 --images s", "grade: unexpected argument 'a5'"),
            ("grade a4 --images s --max-flip-mean -1", "--max-flip-mean"),
            ("grade a4 --images s --outputs color", "grade: unknown flag '--outputs'"),
            ("gallery corpus", "-html FILE is required"),
            ("gallery --html g.html", "gallery expects the course's folder (with a2, a3, …)"),
        ];
        for (line, message) in errors {
            let err = parse(line).expect_err(line);
            assert!(err.0.contains(message), "{line}: {err}");
        }
    }

    #[test]
    fn help() {
        assert_eq!(parse("--help"), Ok(Command::Help));
        assert_eq!(parse("-input s -h"), Ok(Command::Help));
        assert_eq!(parse("stitch --help"), Ok(Command::Help));
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
            ("batch c.txt --backedn cpu", "batch: unknown flag '--backedn'; did you mean '--backend'?"),
            ("bench --quik", "bench: unknown flag '--quik'; did you mean '--quick'?"),
            ("-input s -size 8 8 -output o.tga --tiel 0/2", "did you mean '--tile'?"),
            ("batch c.txt --shrad 0/2", "did you mean '--shard'?"),
            ("stitch -output o.tga --keep-part", "stitch: unknown flag '--keep-part'; did you mean '--keep-parts'?"),
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
            ("-input s -size 1 1", "nothing to write"),
            ("-size 1 1 -output o.tga", "-input SCENE is required"),
            ("-input s -output o.tga", "-size W H is required"),
            ("-input s -size 1 1 -output o.tga --backend metal", "'metal'"),
            ("-input s -input t -size 1 1 -output o.tga", "-input is given twice"),
            ("-input s -size 1 1 -output o.tga stray", "'stray'"),
            ("-input", "-input expects a file name"),
            ("-input s -size 1 1 -output o.tga --threads 0", "--threads: '0' is not a whole number from 1 to 1024"),
            ("-input s -size 1 1 -output o.tga --threads lots", "--threads: 'lots'"),
            ("-input s -size 1 1 -output o.tga --threads", "--threads expects a number"),
            ("compare -input s -size 1 1 -output o.tga --max-diff-pixels x", "'x' is not a whole number of pixels"),
            ("stitch a", "stitch: unexpected argument 'a'"),
        ];
        for (line, needle) in cases {
            let err = parse(line).expect_err(line);
            assert!(err.to_string().contains(needle), "{line}: {err}");
            assert!(!err.to_string().contains('\n'), "{line}: not one line: {err}");
        }
    }
}
