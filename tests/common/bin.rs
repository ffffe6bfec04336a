//! The `raycaster` binary as a user runs it, and what it writes.

use std::path::Path;
use std::process::{Command, Output};

/// The binary with `args`, run in the package root (where `scenes/` is).
pub fn raycaster(args: &[&str]) -> Output {
    raycaster_in(Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

/// The binary, with no display to open `-gui`'s window on: the course's command lines
/// carry `-gui`, and a test run from a desktop must not open windows.
pub fn command() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_raycaster"));
    command.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY");
    command
}

/// The binary with `args`, run in `dir`.
pub fn raycaster_in(dir: &Path, args: &[&str]) -> Output {
    command().args(args).current_dir(dir).output().unwrap()
}

/// [`raycaster`] on a machine without a Vulkan driver, as far as wgpu can tell.
pub fn raycaster_without_gpu(args: &[&str]) -> Output {
    command()
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("WGPU_BACKEND", "vulkan")
        .output()
        .unwrap()
}

/// [`raycaster`] with owned arguments, as tests that build them up hold them.
pub fn raycaster_owned(args: &[String]) -> Output {
    raycaster(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// `output` of a run that must have succeeded; its stderr otherwise.
pub fn check(output: Output) -> Output {
    assert!(output.status.success(), "{}", stderr(&output));
    output
}

pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// The line of `grade`'s report for `image` (its second word).
pub fn report_line<'a>(report: &'a str, image: &str) -> &'a str {
    report
        .lines()
        .find(|l| l.split_whitespace().nth(1) == Some(image))
        .unwrap_or_else(|| panic!("no {image}:\n{report}"))
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

pub fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A scene of `scenes/`, as an argument.
pub fn scene(name: &str) -> String {
    super::scenes_dir().join(name).to_str().unwrap().to_string()
}

/// A float EXR read back with the `exr` crate: width, height and `(channel name, samples)`
/// in file order.
pub fn read_exr(path: &Path) -> (usize, usize, Vec<(String, Vec<f32>)>) {
    let image = exr::prelude::read_first_flat_layer_from_file(path).unwrap();
    let size = image.layer_data.size;
    let channels = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    (size.0, size.1, channels)
}

/// The samples of channel `name` of a [`read_exr`] result.
pub fn channel<'a>(channels: &'a [(String, Vec<f32>)], name: &str) -> &'a [f32] {
    &channels.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("no channel {name}")).1
}

/// The names of the files in `dir`, sorted.
pub fn file_names(dir: &Path) -> Vec<std::ffi::OsString> {
    let mut names: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    names.sort();
    names
}
