//! `-gui`: the render, live, in a window (docs/SPEC.md §9).
//!
//! The course's `-gui` opens an OpenGL preview and ray traces when `r` is pressed. Ours
//! shows the ray-traced image itself, re-rendered as the mouse moves the camera
//! ([`crate::app::orbit`]): at a fraction of the size while it moves, at full size once it stops. `c`,
//! `n` and `d` show colour, normals and depth; `r` writes the files the command line names,
//! as seen from the current camera; `q` or Esc closes the window.
//!
//! Each frame is a render like any other, on the device that presents to the window: the
//! same kernel, the same fallbacks to the reference, so the window never shows what a file
//! would not hold.

mod present;

use crate::app::args::RenderArgs;
use crate::app::exit::{say, Failure};
use crate::app::job;
use crate::app::orbit::Orbit;
use present::Screen;
use raycaster::gpu::{DetachedScene, GpuRenderer, PreparedScene, Presented};
use raycaster::image_io;
use raycaster::render::{Output, Outputs, RenderOptions};
use raycaster::renderer::Renderer;
use raycaster::scene::Scene;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// The side of the frame [`LiveView::warm_up`] renders: small, and below the size from
/// which the cost model takes bins.
const WARM_UP_SIDE: u32 = 32;

/// How long the view waits after the last move before rendering at full size.
const SETTLE: Duration = Duration::from_millis(150);

/// The time a frame may take while the camera moves: the view renders at a fraction of its
/// size, chosen from the last full frame, to stay near it.
const MOVING_FRAME: Duration = Duration::from_millis(33);

/// Scenes kept prepared between frames, one per size and output (the full size, and the
/// moving frames' sizes), the least recently drawn given up first.
const KEPT_SCENES: usize = 3;

/// How a `-gui` line ended.
pub enum Shown {
    /// The window was opened and closed.
    Closed,
    /// No window could be opened, for this reason: the line renders as without `-gui`.
    NoWindow(String),
}

/// Shows `scene` live in a window until it is closed, or says why no window can be opened.
pub fn show(args: &RenderArgs, scene: Scene, verbose: bool) -> Result<Shown, Failure> {
    let event_loop = match EventLoop::new() {
        Ok(event_loop) => event_loop,
        Err(e) => return Ok(Shown::NoWindow(format!("no display: {e}"))),
    };
    let mut view = LiveView::new(args, scene, verbose);
    event_loop.run_app(&mut view).map_err(|e| Failure::Failed(format!("-gui: {e}")))?;
    match view.ended {
        Some(Ended::NoWindow(why)) => Ok(Shown::NoWindow(why)),
        Some(Ended::Failed(failure)) => Err(failure),
        None => {
            if verbose {
                say(&view.timings.summary());
            }
            Ok(Shown::Closed)
        }
    }
}

/// On the Unix desktops winit drives (X11, Wayland), why there is no display to open a
/// window on; `None` elsewhere, where the event loop itself tells.
pub fn no_display() -> Option<String> {
    let unix_desktop = cfg!(all(unix, not(target_os = "macos"), not(target_os = "ios"), not(target_os = "android")));
    let unset = |name| std::env::var_os(name).is_none_or(|v| v.is_empty());
    (unix_desktop && unset("DISPLAY") && unset("WAYLAND_DISPLAY"))
        .then(|| "no display: DISPLAY and WAYLAND_DISPLAY are unset".to_string())
}

/// Why the event loop stopped before the window was closed.
enum Ended {
    NoWindow(String),
    Failed(Failure),
}

/// A mouse button held down, and where the cursor was when last seen.
#[derive(Clone, Copy)]
struct Drag {
    button: MouseButton,
    last: (f64, f64),
}

struct LiveView<'a> {
    args: &'a RenderArgs,
    scene: Scene,
    verbose: bool,
    orbit: Orbit,
    output: Output,
    window: Option<Arc<Window>>,
    screen: Option<(Screen, Renderer)>,
    cursor: (f64, f64),
    drag: Option<Drag>,
    /// The camera moved at this time; the view renders small until [`SETTLE`] has passed.
    moved: Option<Instant>,
    /// What a full-size frame takes, from the last frame's time, from which the size of
    /// moving frames follows.
    full_frame: Duration,
    /// The scales rendered at so far: the first frame at each may compile a kernel variant,
    /// and its time says nothing of the frames to come.
    scales_seen: Vec<u32>,
    /// Whether the kernel of the frames rendered while moving has been compiled.
    warmed: bool,
    timings: Timings,
    /// The scenes prepared for earlier frames, which the next frame of the same size and
    /// output aims at its camera instead of preparing the scene again
    /// ([`PreparedScene::aim`]).
    kept: Vec<DetachedScene>,
    ended: Option<Ended>,
}

impl<'a> LiveView<'a> {
    fn new(args: &'a RenderArgs, scene: Scene, verbose: bool) -> LiveView<'a> {
        let output = args.files.outputs().iter().next().unwrap_or(Output::Color);
        LiveView {
            args,
            orbit: Orbit::of_scene(&scene),
            scene,
            verbose,
            output,
            window: None,
            screen: None,
            cursor: (0.0, 0.0),
            drag: None,
            moved: None,
            full_frame: Duration::ZERO,
            scales_seen: Vec::new(),
            warmed: false,
            timings: Timings::default(),
            kept: Vec::new(),
            ended: None,
        }
    }

    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<(), Ended> {
        let name = self.args.input.file_name().map_or_else(|| "scene".into(), |n| n.to_string_lossy());
        let attributes = Window::default_attributes()
            .with_title(format!("raycaster: {name}"))
            .with_inner_size(PhysicalSize::new(self.args.width, self.args.height));
        let window = Arc::new(
            event_loop.create_window(attributes).map_err(|e| Ended::NoWindow(format!("cannot open a window: {e}")))?,
        );
        let screen = Screen::open(window.clone()).map_err(Ended::NoWindow)?;
        let backend = Renderer::on_gpu(screen.gpu().on_same_device(*screen.gpu().options()), self.args.backend);
        if self.verbose {
            say(&format!("gui: {}; keys: c n d (colour, normals, depth), r (write the files), q", backend.describe()));
        }
        self.screen = Some((screen, backend));
        window.request_redraw();
        self.window = Some(window);
        Ok(())
    }

    /// Renders the view at the surface's size, or while the camera moves at a fraction of
    /// it, and shows it.
    fn redraw(&mut self) -> Result<(), Failure> {
        let Some((screen, backend)) = self.screen.as_mut() else { return Ok(()) };
        let (width, height) = screen.size();
        let moving = self.moved.is_some_and(|t| t.elapsed() < SETTLE) || self.drag.is_some();
        let scale = if moving { moving_scale(self.full_frame) } else { 1 };
        let (w, h) = (width.div_ceil(scale), height.div_ceil(scale));
        let start = Instant::now();
        let Some(frame) = screen.next_texture() else { return Ok(()) };
        let view = (self.args, self.output, scale);
        let on_device = draw_on_device(screen, backend, &mut self.kept, &self.scene, view, &frame)?;
        if !on_device {
            let rgb = render_view(backend, &self.scene, self.args, self.output, (w, h))?;
            screen.write(&frame, &enlarge(&rgb, w, scale, (width, height)));
        }
        screen.present(frame);
        let took = start.elapsed();
        if self.scales_seen.contains(&scale) || self.scales_seen.is_empty() {
            // A frame's time goes with its pixels.
            self.full_frame = took * scale * scale;
        }
        if !self.scales_seen.contains(&scale) {
            self.scales_seen.push(scale);
        }
        self.timings.add(scale, took);
        if self.verbose {
            let path = if on_device { "on the device" } else { "from the host" };
            say(&format!(
                "gui: {} frame {w}x{h} in {:.1} ms, drawn {path}",
                self.output.name(),
                took.as_secs_f64() * 1e3
            ));
        }
        Ok(())
    }

    /// Once the first frame is shown, a tiny frame, thrown away, compiles the kernel variant
    /// of the small frames rendered while the camera moves (at a smaller size a bin covers
    /// more of the scene, and lists too long send the cost model to the hierarchy), so that
    /// the first drag does not wait for it.
    fn warm_up(&mut self) -> Result<(), Failure> {
        self.warmed = true;
        // The reference compiles nothing.
        let Some((_, backend @ Renderer::Gpu(..))) = self.screen.as_ref() else { return Ok(()) };
        let start = Instant::now();
        let options = view_options(self.args, self.output, (WARM_UP_SIDE, WARM_UP_SIDE));
        // The kernel the frames drawn on the device run (8-bit pixels), where they are.
        let gpu = device_drawn(backend, &self.scene, &options);
        match gpu.and_then(|gpu| gpu.prepare(&self.scene, &options, true).ok()) {
            Some(prepared) => {
                prepared.render(|_| Ok::<(), Failure>(()))?;
            }
            None => {
                render_view(backend, &self.scene, self.args, self.output, (WARM_UP_SIDE, WARM_UP_SIDE))?;
            }
        }
        if self.verbose {
            say(&format!("gui: compiled the moving frames' kernel in {:.0} ms", start.elapsed().as_secs_f64() * 1e3));
        }
        Ok(())
    }

    /// `r`: the files the command line names, rendered from the current camera.
    fn write_files(&self) -> Result<(), Failure> {
        let Some((_, backend)) = self.screen.as_ref() else { return Ok(()) };
        if !self.args.writes_something() {
            say("gui: nothing to write: the command line names no -output, -normals or -depth");
            return Ok(());
        }
        let report = job::run_loaded(self.scene.clone(), 0.0, self.args, backend, false)?;
        if let Some(notice) = &report.notice {
            say(&format!("warning: {notice}"));
        }
        let files: Vec<String> = self.args.files.named().iter().map(|(_, p)| p.display().to_string()).collect();
        say(&format!("gui: wrote {} in {:.0} ms", files.join(", "), report.render_ms + report.write_ms));
        if self.args.stats {
            let seconds = (report.render_ms + report.write_ms) / 1e3;
            crate::app::exit::print(&job::stats_text(self.args, &report.stats, seconds))?;
        }
        Ok(())
    }

    /// A key pressed: what it asks for, if anything.
    fn key(&mut self, key: &Key, event_loop: &ActiveEventLoop) -> Result<(), Failure> {
        let character = match key {
            Key::Named(NamedKey::Escape) => "q",
            Key::Character(c) => c.as_str(),
            _ => return Ok(()),
        };
        let output = match character.to_ascii_lowercase().as_str() {
            "q" => {
                event_loop.exit();
                return Ok(());
            }
            "r" => return self.write_files(),
            "c" => Output::Color,
            "n" => Output::Normals,
            "d" => Output::Depth,
            _ => return Ok(()),
        };
        self.output = output;
        self.request_redraw();
        Ok(())
    }

    /// The cursor moved to `at`: a held button orbits (left), pans (middle) or zooms
    /// (right: up is closer, 100 pixels a notch).
    fn cursor_moved(&mut self, at: (f64, f64)) {
        self.cursor = at;
        let Some(drag) = self.drag.as_mut() else { return };
        let (dx, dy) = (at.0 - drag.last.0, at.1 - drag.last.1);
        drag.last = at;
        match drag.button {
            MouseButton::Left => self.orbit.orbit(dx, dy),
            MouseButton::Middle => {
                let side = self.screen.as_ref().map_or(1, |(s, _)| s.size().0.max(s.size().1));
                self.orbit.pan(dx, dy, side)
            }
            MouseButton::Right => self.orbit.zoom(-dy / 100.0),
            _ => return,
        }
        self.camera_moved();
    }

    /// The events that change the view or close it, and cannot fail.
    fn input(&mut self, event: WindowEvent, event_loop: &ActiveEventLoop) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some((screen, _)) = self.screen.as_mut() {
                    screen.resize(size.width, size.height);
                }
                self.request_redraw();
            }
            WindowEvent::CursorMoved { position, .. } => self.cursor_moved((position.x, position.y)),
            WindowEvent::MouseInput { state: ElementState::Pressed, button, .. } => {
                self.drag = Some(Drag { button, last: self.cursor });
            }
            WindowEvent::MouseInput { state: ElementState::Released, .. } => {
                self.drag = None;
                // The last frame may have been a small one: settle to full size.
                self.camera_moved();
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 100.0,
                };
                self.orbit.zoom(notches);
                self.camera_moved();
            }
            _ => {}
        }
    }

    /// The orbit moved the camera: the scene every later frame and `r` render follows it.
    fn camera_moved(&mut self) {
        self.scene.camera = self.orbit.camera();
        self.moved = Some(Instant::now());
        self.request_redraw();
    }

    fn request_redraw(&self) {
        if let Some(window) = &self.window {
            window.request_redraw();
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, failure: Failure) {
        self.ended = Some(Ended::Failed(failure));
        event_loop.exit();
    }
}

impl ApplicationHandler for LiveView<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            if let Err(ended) = self.open(event_loop) {
                self.ended = Some(ended);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let result = match event {
            WindowEvent::RedrawRequested => self.redraw(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed && !event.repeat => {
                self.key(&event.logical_key, event_loop)
            }
            event => {
                self.input(event, event_loop);
                Ok(())
            }
        };
        if let Err(failure) = result {
            self.fail(event_loop, failure);
        }
    }

    /// Once the camera has been still for [`SETTLE`], one more frame at full size.
    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let idle = self.moved.is_none() && self.drag.is_none();
        if idle && !self.warmed && !self.scales_seen.is_empty() {
            if let Err(failure) = self.warm_up() {
                return self.fail(event_loop, failure);
            }
        }
        match self.moved {
            Some(t) if self.drag.is_none() && t.elapsed() >= SETTLE => {
                self.moved = None;
                self.request_redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            }
            Some(t) => event_loop.set_control_flow(ControlFlow::WaitUntil(t + SETTLE)),
            None => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }
}

/// How much smaller a frame is rendered while the camera moves, on each side: enough that
/// it takes about [`MOVING_FRAME`], the render's time going with its pixels.
fn moving_scale(full_frame: Duration) -> u32 {
    let ratio = full_frame.as_secs_f64() / MOVING_FRAME.as_secs_f64();
    (ratio.sqrt().ceil() as u32).clamp(1, 8)
}

/// The render of one output of the view at `size`.
fn view_options(args: &RenderArgs, output: Output, (width, height): (u32, u32)) -> RenderOptions {
    let mut options = job::options_for(args);
    options.width = width;
    options.height = height;
    options.outputs = Outputs::from(output);
    options.stats = false;
    options
}

/// The GPU that draws the render `options` on the device, where the GPU renders it (`auto`
/// may hand a scene to the reference): colour and normals as the kernel quantises them,
/// the depth over the command line's `-depth` range or, without one, over the frame's own
/// hits (`gpu::present`).
fn device_drawn<'r>(backend: &'r Renderer, scene: &Scene, options: &RenderOptions) -> Option<&'r GpuRenderer> {
    let (renderer, _) = backend.for_scene(scene, options);
    renderer.gpu()
}

/// Renders the view at the frame's size divided by `scale` and draws it onto `frame` on the
/// device, without the pixels crossing to the host; returns false where it cannot (the
/// reference renders the scene, [`device_drawn`]; the GPU refuses it, which the host's
/// path then reports or hands to the reference; or a pixel was handed over to the
/// reference), for the caller to draw the frame from the host. The scene prepared for it
/// is kept in `kept` for the next frame of its size and output.
fn draw_on_device(
    screen: &Screen,
    backend: &Renderer,
    kept: &mut Vec<DetachedScene>,
    scene: &Scene,
    (args, output, scale): (&RenderArgs, Output, u32),
    frame: &wgpu::SurfaceTexture,
) -> Result<bool, Failure> {
    let (width, height) = screen.size();
    let options = view_options(args, output, (width.div_ceil(scale), height.div_ceil(scale)));
    let Some(gpu) = device_drawn(backend, scene, &options) else { return Ok(false) };
    let Some(prepared) = aimed_or_prepared(gpu, kept, scene, &options) else { return Ok(false) };
    let presented = match output {
        Output::Depth => prepared.present_depth(screen.presenter(), &frame.texture, scale, args.files.depth_range())?,
        _ => prepared.present(screen.presenter(), &frame.texture, scale)?,
    };
    if kept.len() == KEPT_SCENES {
        kept.remove(0);
    }
    kept.push(prepared.detach());
    Ok(presented == Presented::Drawn)
}

/// `scene` prepared on `gpu` for `options` as 8-bit pixels: the one `kept` for an earlier
/// frame of these options, aimed at the scene's camera, or else prepared afresh; `None`
/// where the GPU refuses the scene from this camera.
fn aimed_or_prepared<'g>(
    gpu: &'g GpuRenderer,
    kept: &mut Vec<DetachedScene>,
    scene: &Scene,
    options: &RenderOptions,
) -> Option<PreparedScene<'g>> {
    let earlier = kept.iter().position(|k| k.options() == options).map(|k| kept.remove(k));
    match earlier.and_then(|k| k.attach(gpu)) {
        Some(mut prepared) => prepared.aim(scene).ok().map(|_| prepared),
        None => gpu.prepare(scene, options, true).ok(),
    }
}

/// One output of `scene` at `size`, as the 8-bit RGB bytes its file would hold. Depth is
/// shown over the command line's `-depth` range, else over the nearest and farthest hits.
fn render_view(
    backend: &Renderer,
    scene: &Scene,
    args: &RenderArgs,
    output: Output,
    size: (u32, u32),
) -> Result<Vec<u8>, Failure> {
    let options = view_options(args, output, size);
    let mut tiles = Vec::new();
    let (_, _) = backend.render_band(scene, &options, 0, options.height, |_, frame| {
        tiles.push(frame);
        Ok::<(), Failure>(())
    })?;
    let (min, max) = args.files.depth_range().unwrap_or_else(|| image_io::hit_depth_range(&tiles));
    Ok(tiles
        .iter()
        .flat_map(|tile| match output {
            Output::Color => image_io::color_image(tile).into_raw(),
            Output::Normals => image_io::normals_image(tile).into_raw(),
            Output::Depth => image_io::depth_image(tile, min, max).into_raw(),
        })
        .collect())
}

/// `rgb`, `width` pixels wide, enlarged onto an image of size `to`: each pixel a
/// `scale × scale` block from the top left, cut at `to`'s edges (as the device draws it,
/// `shaders/present/enlarge.wgsl`).
fn enlarge(rgb: &[u8], width: u32, scale: u32, to: (u32, u32)) -> Vec<u8> {
    if scale == 1 && width == to.0 {
        return rgb.to_vec();
    }
    let mut out = Vec::with_capacity(3 * to.0 as usize * to.1 as usize);
    for y in 0..to.1 {
        let row = (y / scale) as usize * width as usize;
        for x in 0..to.0 {
            let at = 3 * (row + (x / scale) as usize);
            out.extend_from_slice(&rgb[at..at + 3]);
        }
    }
    out
}

/// The frames' times, for `-v`'s summary when the window closes.
#[derive(Default)]
struct Timings {
    full: Vec<Duration>,
    moving: Vec<(u32, Duration)>,
}

impl Timings {
    fn add(&mut self, scale: u32, took: Duration) {
        if scale == 1 {
            self.full.push(took)
        } else {
            self.moving.push((scale, took))
        }
    }

    fn summary(&self) -> String {
        let median = |mut v: Vec<Duration>| {
            v.sort();
            v.get(v.len() / 2).map_or(0.0, |d| d.as_secs_f64() * 1e3)
        };
        let moving_ms = median(self.moving.iter().map(|m| m.1).collect());
        let fps = |ms: f64| if ms > 0.0 { 1e3 / ms } else { 0.0 };
        let full_ms = median(self.full.clone());
        format!(
            "gui: {} full-size frames, median {:.1} ms ({:.1} fps); {} frames while moving, median {:.1} ms ({:.1} fps)",
            self.full.len(),
            full_ms,
            fps(full_ms),
            self.moving.len(),
            moving_ms,
            fps(moving_ms)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_enlarged_image_repeats_each_pixel() {
        let rgb = [1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4];
        let big = enlarge(&rgb, 2, 2, (4, 3));
        let firsts: Vec<u8> = big.chunks(3).map(|p| p[0]).collect();
        assert_eq!(firsts, [1, 1, 2, 2, 1, 1, 2, 2, 3, 3, 4, 4]);
    }

    #[test]
    fn moving_frames_shrink_with_the_square_root_of_the_full_frames_time() {
        assert_eq!(moving_scale(Duration::from_millis(20)), 1);
        assert_eq!(moving_scale(Duration::from_millis(120)), 2);
        assert_eq!(moving_scale(Duration::from_millis(10_000)), 8);
    }
}
