//! The Python package (python/, docs/python.md) as its users get it: a release wheel built
//! by maturin and installed into a fresh virtual environment, whose tests
//! (python/tests/) hold its arrays to this binary's files. Skipped, with one notice, where
//! Python or its `venv` module is missing; `RAYCASTER_REQUIRE_PYTHON=1` (set by CI) makes
//! that a failure.

use std::ffi::OsString;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const REQUIRE: &str = "RAYCASTER_REQUIRE_PYTHON";

#[test]
fn the_python_package_built_as_a_wheel_passes_its_tests() {
    let repository = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = std::env::var_os("RAYCASTER_PYTHON").unwrap_or_else(|| OsString::from("python3"));
    let work = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).unwrap();
    let venv = work.join("venv");
    match Command::new(&python).arg("-m").arg("venv").arg(&venv).output() {
        Ok(made) if made.status.success() => {}
        Ok(made) => return skip(&format!("{} -m venv: {}", python.to_string_lossy(), text(&made).trim())),
        Err(e) => return skip(&format!("{}: {e}", python.to_string_lossy())),
    }
    let bin = venv.join(if cfg!(windows) { "Scripts" } else { "bin" });
    let requirements = repository.join("python/requirements-test.txt");
    step(Command::new(bin.join("python")).args(["-m", "pip", "install", "-q", "-r"]).arg(&requirements));

    let wheels = work.join("wheels");
    // In this build's target folder: the dependencies the binary compiled (wgpu, naga...) are
    // compiled once for both.
    let target = Path::new(env!("CARGO_TARGET_TMPDIR")).parent().expect("target/tmp is in the target folder");
    step(
        Command::new(bin.join("maturin"))
            .args(["build", "--release", "--manifest-path"])
            .arg(repository.join("python/Cargo.toml"))
            .arg("--target-dir")
            .arg(target)
            .arg("--out")
            .arg(&wheels),
    );
    let wheel = only_wheel(&wheels);
    step(Command::new(bin.join("python")).args(["-m", "pip", "install", "-q", "--no-deps"]).arg(&wheel));

    let tested = Command::new(bin.join("python"))
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(repository.join("python/tests"))
        .current_dir(&work)
        .env("RAYCASTER_BIN", env!("CARGO_BIN_EXE_raycaster"))
        .output()
        .expect("pytest runs");
    let report = text(&tested);
    // pytest's closing line ("N passed, M skipped in S s"), in the log of a passing run too:
    // straight to the stream, as the harness captures println! of passing tests.
    let counts = report.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").to_string();
    let _ = writeln!(std::io::stdout(), "python/tests: {counts}");
    assert!(tested.status.success(), "pytest failed ({counts}):\n{report}");
    assert!(counts.contains(" passed"), "pytest ran no test:\n{report}");
}

/// The one notice of a skip, or the failure CI asks for.
fn skip(why: &str) {
    if std::env::var_os(REQUIRE).is_some_and(|v| v == "1") {
        panic!("{why}, and {REQUIRE}=1");
    }
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED: the Python package's tests: no Python with venv ({why}); {REQUIRE}=1 makes this a failure"
    );
}

fn step(command: &mut Command) {
    let done = command.output().unwrap_or_else(|e| panic!("{command:?}: {e}"));
    assert!(done.status.success(), "{command:?} failed:\n{}", text(&done));
}

fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

fn only_wheel(folder: &Path) -> PathBuf {
    let wheels: Vec<PathBuf> = std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "whl"))
        .collect();
    assert_eq!(wheels.len(), 1, "one wheel in {}: {wheels:?}", folder.display());
    wheels.into_iter().next().unwrap()
}
