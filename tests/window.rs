//! `-gui`'s live view (docs/SPEC.md §9), as a user sees it: a window on an X server (Xvfb),
//! driven by real mouse and key events (xdotool) and read back from the screen (xwd).
//!
//! The window's pixels are compared with the f64 reference's files for the same camera,
//! under the 0.1 % contract; the camera after a drag is the one the orbit's formula gives,
//! computed here from the scene, not taken from the program.
//!
//! Needs Xvfb, xdotool and xwd (Debian: `xvfb xdotool x11-apps`). Without them the test
//! skips with one notice, unless `RAYCASTER_REQUIRE_DISPLAY=1` (CI sets it) makes that a
//! failure.

mod common;

use common::bin::{check, command};
use raycaster::image_io::read_image;
use raycaster::metrics::image_diff;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::Duration;

/// Two spheres of different colours either side of the origin, seen from +z: the bounds'
/// centre, the orbit's pivot, is the origin.
const SCENE: &str = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
Lights { numLights 1 DirectionalLight { direction -0.5 -0.5 -1 color 1 1 1 } }
Background { color 0.1 0.1 0.3 ambientLight 0.2 0.2 0.2 }
Materials { numMaterials 2
  PhongMaterial { diffuseColor 0.9 0.2 0.2 }
  PhongMaterial { diffuseColor 0.2 0.9 0.2 } }
Group { numObjects 2
  MaterialIndex 0 Sphere { center -1.2 0 0 radius 1 }
  MaterialIndex 1 Sphere { center 1.2 0 0 radius 0.6 } }
";

/// The same scene from the camera a drag of `dx` pixels to the right leaves: turned about
/// up (y) through the origin by −dx · 0.005 rad (the course's `rotateCamera`).
fn scene_after_drag(dx: f64) -> String {
    let angle = -dx * 0.005;
    let (x, z) = (10.0 * angle.sin(), 10.0 * angle.cos());
    SCENE.replace(
        "center 0 0 10 direction 0 0 -1",
        &format!("center {x:.17} 0 {z:.17} direction {:.17} 0 {:.17}", -x / 10.0, -z / 10.0),
    )
}

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;
const DRAG: f64 = 60.0;

#[test]
fn the_window_shows_the_render_and_the_mouse_turns_its_camera() {
    let Some(display) = Xvfb::start() else { return };
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.txt"), SCENE).unwrap();
    std::fs::write(dir.path().join("turned.txt"), scene_after_drag(DRAG)).unwrap();
    let reference = |scene: &str, flag: &[&str], name: &str| {
        let size = [WIDTH.to_string(), HEIGHT.to_string()];
        let args = [&["-input", scene, "-size", &size[0], &size[1]], flag, &[name, "--backend", "cpu"]].concat();
        check(command().args(args).current_dir(dir.path()).output().unwrap());
        read_image(&dir.path().join(name)).unwrap()
    };
    let colour = reference("scene.txt", &["-output"], "colour.tga");
    let normals = reference("scene.txt", &["-normals"], "normals.tga");
    // The spheres' fronts lie between 9 and 10 from the camera.
    let depth = reference("scene.txt", &["-depth", "9.2", "10"], "depth.tga");
    let greys: std::collections::BTreeSet<u8> = depth.pixels().map(|p| p.0[0]).collect();
    assert!(greys.len() > 20, "the range grades the spheres: {greys:?}");
    let turned = reference("turned.txt", &["-output"], "turned.tga");
    assert!(
        image_diff(&colour, &turned).off_by_more_than_one > 1000,
        "the drag must change the view for this test to mean anything"
    );

    let size = [WIDTH.to_string(), HEIGHT.to_string()];
    let mut window = LiveView::open(
        &display,
        dir.path(),
        &[
            "-input",
            "scene.txt",
            "-size",
            &size[0],
            &size[1],
            "-output",
            "written.tga",
            "-depth",
            "9.2",
            "10",
            "written_depth.tga",
            "-gui",
            "-v",
        ],
    );
    // Colour and normals are drawn on the device, the frame never crossing to the host.
    let first = window.wait_for(&format!("colour frame {WIDTH}x{HEIGHT}"));
    assert!(first.ends_with("drawn on the device"), "{first}");
    within_contract("the first frame", &window.screenshot(), &colour);

    window.xdotool(&["key", "n"]);
    let line = window.wait_for(&format!("normals frame {WIDTH}x{HEIGHT}"));
    assert!(line.ends_with("drawn on the device"), "{line}");
    within_contract("the normals", &window.screenshot(), &normals);
    // The depth over the command line's range too: its grey levels looked up on the device.
    window.xdotool(&["key", "d"]);
    let line = window.wait_for(&format!("depth frame {WIDTH}x{HEIGHT}"));
    assert!(line.ends_with("drawn on the device"), "{line}");
    within_contract("the depth", &window.screenshot(), &depth);

    window.xdotool(&["key", "c"]);
    window.wait_for(&format!("colour frame {WIDTH}x{HEIGHT}"));
    window.xdotool(&["mousemove", "--window", &window.id, "80", "60"]);
    window.xdotool(&["mousedown", "1"]);
    window.xdotool(&["mousemove_relative", "--", &DRAG.to_string(), "0"]);
    window.xdotool(&["mouseup", "1"]);
    // A frame at full size once the camera is still again.
    window.wait_for(&format!("colour frame {WIDTH}x{HEIGHT}"));
    within_contract("the frame after the drag", &window.screenshot(), &turned);

    window.xdotool(&["key", "r"]);
    window.wait_for("wrote written.tga");
    within_contract("the file r wrote", &read_image(&dir.path().join("written.tga")).unwrap(), &turned);

    window.xdotool(&["key", "q"]);
    let status = window.wait_for_exit();
    assert!(status.success(), "-gui exits 0 on q: {status}");
}

/// At most 0.1 % of the pixels more than one level off.
fn within_contract(what: &str, shown: &image::RgbImage, reference: &image::RgbImage) {
    let diff = image_diff(shown, reference);
    println!(
        "{what}: {} of {} pixels more than 1 level off (max {})",
        diff.off_by_more_than_one, diff.pixels, diff.max
    );
    assert!(
        diff.off_by_more_than_one as f64 <= (common::MAX_OFF_FRACTION * diff.pixels as f64).floor(),
        "{what}: {} of {} pixels more than 1 level off the reference",
        diff.off_by_more_than_one,
        diff.pixels
    );
}

/// An X server of our own on a free display number, stopped when dropped.
struct Xvfb {
    display: String,
    server: Child,
}

impl Xvfb {
    /// The server, or `None` (after one notice) where Xvfb, xdotool or xwd is missing and
    /// `RAYCASTER_REQUIRE_DISPLAY=1` is not set.
    fn start() -> Option<Xvfb> {
        let missing: Vec<&str> = ["Xvfb", "xdotool", "xwd"].into_iter().filter(|tool| !on_path(tool)).collect();
        if !missing.is_empty() {
            let why = format!("{} not found (Debian: apt-get install xvfb xdotool x11-apps)", missing.join(", "));
            assert!(
                std::env::var("RAYCASTER_REQUIRE_DISPLAY").as_deref() != Ok("1"),
                "{why}, and RAYCASTER_REQUIRE_DISPLAY=1 requires them"
            );
            eprintln!("SKIPPED: the -gui window test: {why}");
            return None;
        }
        // A display number no other server holds (its lock file is absent).
        let number = (90..190).find(|n| !Path::new(&format!("/tmp/.X{n}-lock")).exists()).expect("a free display");
        let display = format!(":{number}");
        let server = Command::new("Xvfb")
            .args([&display, "-screen", "0", "640x480x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Dropping it stops the server, also when it never came up.
        let xvfb = Xvfb { display, server };
        let socket = format!("/tmp/.X11-unix/X{number}");
        for _ in 0..100 {
            if Path::new(&socket).exists() {
                return Some(xvfb);
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        panic!("Xvfb {} did not start", xvfb.display);
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.server.kill();
        let _ = self.server.wait();
    }
}

fn on_path(tool: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|paths| std::env::split_paths(&paths).any(|p| p.join(tool).is_file()))
}

/// The `-gui` process, its stderr lines as they come, and its window.
struct LiveView {
    display: String,
    process: Child,
    lines: Receiver<String>,
    id: String,
}

/// How long a frame may take to come: the first compiles the kernel on a loaded machine.
const PATIENCE: Duration = Duration::from_secs(120);

impl LiveView {
    fn open(xvfb: &Xvfb, dir: &Path, args: &[&str]) -> LiveView {
        let mut process =
            command().args(args).current_dir(dir).env("DISPLAY", &xvfb.display).stderr(Stdio::piped()).spawn().unwrap();
        let (send, lines) = channel();
        let stderr = process.stderr.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if send.send(line).is_err() {
                    return;
                }
            }
        });
        let mut view = LiveView { display: xvfb.display.clone(), process, lines, id: String::new() };
        // -v's line once the window is open: a driver that cannot present to X (SwiftShader
        // as Chromium ships it) ends the command instead, which fails here rather than
        // leaving xdotool waiting for a window that never comes.
        view.wait_for("; keys:");
        let search = view.xdotool(&["search", "--sync", "--name", "^raycaster: scene.txt$"]);
        view.id = search.lines().next().expect("the window's id").to_string();
        // No window manager gives it the keyboard: keys go to the focused window.
        view.xdotool(&["windowfocus", "--sync", &view.id]);
        view
    }

    /// Runs xdotool on the view's display; returns its stdout.
    fn xdotool(&self, args: &[&str]) -> String {
        let output = Command::new("xdotool").args(args).env("DISPLAY", &self.display).output().unwrap();
        assert!(output.status.success(), "xdotool {args:?}: {}", String::from_utf8_lossy(&output.stderr));
        String::from_utf8(output.stdout).unwrap()
    }

    /// Reads stderr until a line containing `needle`; returns it.
    fn wait_for(&mut self, needle: &str) -> String {
        let mut seen = Vec::new();
        loop {
            match self.lines.recv_timeout(PATIENCE) {
                Ok(line) if line.contains(needle) => return line,
                Ok(line) => seen.push(line),
                Err(e) => {
                    let _ = self.process.kill();
                    panic!("no line with {needle:?} from -gui ({e}); it said:\n{}", seen.join("\n"));
                }
            }
        }
    }

    /// The window's pixels as the X server holds them, once they hold still: the frame was
    /// presented before its line was written, but the server may show it a moment later.
    fn screenshot(&self) -> image::RgbImage {
        let mut last = self.grab();
        for _ in 0..20 {
            std::thread::sleep(Duration::from_millis(200));
            let next = self.grab();
            if next == last {
                return next;
            }
            last = next;
        }
        panic!("the window's pixels kept changing for 4 s");
    }

    fn grab(&self) -> image::RgbImage {
        let output =
            Command::new("xwd").args(["-silent", "-id", &self.id]).env("DISPLAY", &self.display).output().unwrap();
        assert!(output.status.success(), "xwd: {}", String::from_utf8_lossy(&output.stderr));
        xwd::rgb(&output.stdout)
    }

    fn wait_for_exit(&mut self) -> std::process::ExitStatus {
        for _ in 0..600 {
            if let Some(status) = self.process.try_wait().unwrap() {
                return status;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let _ = self.process.kill();
        panic!("-gui did not exit");
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        let _ = self.process.kill();
        let _ = self.process.wait();
    }
}

/// The X Window Dump format that `xwd` writes (X11's XWDFile.h): a header of big-endian
/// 32-bit fields, the window's name, a colour map, then the pixels as the server stores
/// them.
mod xwd {
    pub fn rgb(data: &[u8]) -> image::RgbImage {
        let field = |k: usize| u32::from_be_bytes(data[4 * k..4 * k + 4].try_into().unwrap());
        let (header_size, version) = (field(0) as usize, field(1));
        assert_eq!(version, 7, "XWD version 7");
        let (width, height) = (field(4), field(5));
        let little_endian = field(7) == 0; // byte_order: LSBFirst
        let (bits_per_pixel, bytes_per_line) = (field(11), field(12) as usize);
        let masks = [field(14), field(15), field(16)];
        let colours = field(19) as usize;
        assert_eq!(bits_per_pixel, 32, "a 24-bit TrueColor screen");
        let pixels = &data[header_size + 12 * colours..];
        image::RgbImage::from_fn(width, height, |x, y| {
            let at = y as usize * bytes_per_line + 4 * x as usize;
            let bytes: [u8; 4] = pixels[at..at + 4].try_into().unwrap();
            let word = if little_endian { u32::from_le_bytes(bytes) } else { u32::from_be_bytes(bytes) };
            image::Rgb(masks.map(|m| ((word & m) >> m.trailing_zeros()) as u8))
        })
    }
}
