//! `raycaster bench`: speed and error side by side, per scene and size.
//!
//! Each row renders one scene at one size on the GPU several times and reports the medians
//! of the kernel time (GPU timestamps where the adapter has them, else wall time) and of the
//! whole render's wall time, the rays per second, the peak memory, and the error against the
//! f64 reference, measured on a regular subsample of pixels where the full reference would be
//! too slow. The result is printed as Markdown, saved as CSV and drawn as a speed-against-error
//! plot.

use crate::app::memory;
use crate::app::orbit::Orbit;
use glam::DVec3;
use raycaster::cpu::Reference;
use raycaster::gpu::ray_tree::RenderRays;
use raycaster::gpu::{Acceleration, GpuError, GpuOptions, GpuRenderer, PreparedScene, Presented, Presenter, ReadTile};
use raycaster::grid::GridSize;
use raycaster::metrics::{compare_frames, depth_range_of, OutputErrors};
use raycaster::render::{Frame, Output, Pixel, RenderOptions, Shading, TriangleTest};
use raycaster::sampling::{self, Filter, Sampling};
use raycaster::scene::{
    self, Background, Bounds, Camera, DirectionalLight, Light, Material, Mesh, Object, Projection, Scene, Shape,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// One scene at one size, to be measured.
pub struct Case {
    pub name: String,
    pub scene: Scene,
    pub width: u32,
    pub height: u32,
    pub triangle_test: TriangleTest,
    pub acceleration: Acceleration,
    /// Shadows, bounces and the rest (the course's flags on its A4 lines).
    pub shading: Shading,
    /// The GPU's `-grid` (with [`Acceleration::Grid`]).
    pub grid: Option<GridSize>,
    /// The grid the reference walks to check the row: the course line's own, whatever the
    /// GPU uses, so that a 40 000-triangle mesh with shadows takes it seconds, not minutes
    /// (its images are the same with and without a grid: tests/grid.rs).
    pub reference_grid: Option<GridSize>,
    /// Several samples per pixel and a filter (docs/SPEC.md §8).
    pub sampling: Option<Sampling>,
}

impl Case {
    /// Whether the case casts rays other than primary ones: then the whole image is
    /// rendered by the reference too, timed, and its rays counted.
    pub fn secondary_rays(&self) -> bool {
        RenderRays::new(&self.scene, &self.options()).secondary()
    }

    /// The render the GPU is timed on.
    pub fn options(&self) -> RenderOptions {
        RenderOptions {
            triangle_test: self.triangle_test,
            shading: self.shading,
            grid: self.grid,
            sampling: self.sampling,
            ..RenderOptions::all(self.width, self.height)
        }
    }
}

/// What one case measured.
#[derive(Clone, Debug)]
pub struct Row {
    pub name: String,
    pub triangle_test: TriangleTest,
    pub acceleration: Acceleration,
    pub primitives: usize,
    pub triangles: usize,
    pub width: u32,
    pub height: u32,
    /// Time to build the hierarchy, when the scene got one.
    pub acceleration_build_ms: Option<f64>,
    /// Bytes of scene data on the GPU (primitives, hierarchy, materials, lights).
    pub scene_bytes: u64,
    /// Median kernel time; from GPU timestamps when `timestamps`, else the render's wall time.
    pub kernel_ms: f64,
    pub timestamps: bool,
    /// Median wall time of the whole render (flatten, upload, kernel, read-back).
    pub wall_ms: f64,
    /// A warm frame: the scene prepared once, rendered again and read into host memory as
    /// floats ([`warm_frame_ms`]).
    pub warm_ms: f64,
    /// A warm frame of the colour alone as 8-bit RGB, quantised by the kernel (what
    /// `-output` writes and the live view shows; [`warm_rgb8_frame_ms`]).
    pub warm_rgb8_ms: f64,
    /// [`Row::warm_rgb8_ms`] with the camera turned a little each frame, the scene aimed at
    /// it rather than prepared again ([`moving_rgb8_frame_ms`]): the live view's orbit.
    pub moving_rgb8_ms: f64,
    /// [`Row::moving_rgb8_ms`] drawn onto a texture on the device instead of read back, as
    /// the live view draws a moving frame ([`moving_presented_frame_ms`]); `None` where the
    /// live view would draw it from the host (a pixel handed over to the reference).
    pub moving_presented_ms: Option<f64>,
    pub runs: usize,
    /// Peak resident memory of the process during the case (Linux only).
    pub peak_mib: Option<f64>,
    /// Pixels the error was measured on.
    pub samples: usize,
    pub errors: Vec<OutputErrors>,
    /// Every ray of the image, primary, reflected, refracted and shadow, as the reference
    /// counted them (the kernel traces the same tree, to f32 rounding); the pixels for a
    /// case of primary rays alone.
    pub rays: u64,
    /// Wall time of the reference's whole render, for a case with secondary rays.
    pub reference_ms: Option<f64>,
}

impl Row {
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// Rays per second in the kernel, every ray counted.
    pub fn mrays_per_s(&self) -> f64 {
        self.rays as f64 / (self.kernel_ms * 1e3)
    }

    /// Rays per second of the reference's whole render, where it was timed.
    pub fn reference_mrays_per_s(&self) -> Option<f64> {
        self.reference_ms.map(|ms| self.rays as f64 / (ms * 1e3))
    }

    /// The scene's name, with the image size and the triangle test where they are not the
    /// course's 200² and the default.
    #[cfg(feature = "plot")]
    pub fn label(&self) -> String {
        let mut label = self.name.clone();
        if (self.width, self.height) != (200, 200) {
            label.push_str(&format!(" {}×{}", self.width, self.height));
        }
        if self.triangle_test != TriangleTest::default() {
            label.push_str(&format!(" ({})", self.triangle_test.name()));
        }
        label
    }

    /// Sampled pixels one render hits and the other misses.
    pub fn hit_mismatches(&self) -> usize {
        self.errors.first().map_or(0, |e| e.hit_mismatches)
    }

    /// The largest |Δt| / |t| on the sample.
    pub fn depth_relative_max(&self) -> f64 {
        self.output(Output::Depth).and_then(|e| e.relative_max).unwrap_or(0.0)
    }

    /// The largest angle between the GPU's and the reference's normal, in radians.
    pub fn normal_angle_max(&self) -> f64 {
        self.output(Output::Normals).map_or(0.0, |e| e.float_max)
    }

    fn output(&self, output: Output) -> Option<&OutputErrors> {
        self.errors.iter().find(|e| e.output == output)
    }

    /// The share of sampled pixels more than 1 level off, worst over the outputs.
    pub fn off_fraction(&self) -> f64 {
        let worst = self.errors.iter().map(|e| e.image.off_by_more_than_one).max().unwrap_or(0);
        worst as f64 / self.samples.max(1) as f64
    }
}

/// Measures `case` with `runs` renders (at least 1).
pub fn run_case(gpu: &GpuRenderer, case: &Case, runs: usize) -> Result<Row, GpuError> {
    let options = case.options();
    let reference_options = RenderOptions { grid: case.reference_grid.or(case.grid), ..options };
    let gpu = &gpu.on_same_device(GpuOptions { acceleration: case.acceleration, ..*gpu.options() });
    let counts = case.scene.primitive_counts();
    // Secondary rays: every pixel is compared (and the reference's time is part of the row).
    let budget = if case.secondary_rays() { usize::MAX } else { sample_budget(counts.triangles) };
    // With sampling the reference traces, for each pixel it checks, every sample of the
    // pixels its filter reads.
    let budget = match case.sampling {
        Some(s) => (budget / (s.count() as usize * (2 * s.radius() as usize + 1).pow(2))).max(64),
        None => budget,
    };
    let sampler = Sampler::new(options.width, options.height, budget);
    memory::reset_peak();
    let mut kernel = Vec::new();
    let mut wall = Vec::new();
    let mut timestamps = false;
    let mut acceleration_build_ms = None;
    let mut used = case.acceleration;
    let mut scene_bytes = 0;
    let mut gpu_samples = Vec::new();
    for run in 0..runs.max(1) {
        let start = Instant::now();
        let stats = gpu.render_tiles(&case.scene, &options, |first_row, tile| {
            if run == 0 {
                sampler.collect(first_row, &tile, &mut gpu_samples);
            }
            Ok::<(), GpuError>(())
        })?;
        let elapsed = start.elapsed().as_secs_f64() * 1e3;
        wall.push(elapsed);
        timestamps = stats.kernel_ns.is_some();
        acceleration_build_ms = acceleration_build_ms.or(stats.acceleration_build_ms);
        used = stats.acceleration;
        scene_bytes = stats.scene_bytes;
        kernel.push(stats.kernel_ns.map_or(elapsed, |ns| ns as f64 / 1e6));
    }
    let warm_ms = warm_frame_ms(gpu, &case.scene, &options, runs)?;
    let warm_rgb8_ms = warm_rgb8_frame_ms(gpu, &case.scene, &options, runs)?;
    let moving_rgb8_ms = moving_rgb8_frame_ms(gpu, &case.scene, &options, runs)?;
    let moving_presented_ms = moving_presented_frame_ms(gpu, &case.scene, &options, runs)?;
    let peak_mib = memory::peak_mib();
    let positions: Vec<(u32, u32)> = gpu_samples.iter().map(|s: &Sample| s.position).collect();
    let reference_renderer = Reference::new(&case.scene, &reference_options);
    let start = Instant::now();
    let reference = reference_renderer.pixels(&positions);
    let reference_ms = case.secondary_rays().then(|| start.elapsed().as_secs_f64() * 1e3);
    let rays = if case.secondary_rays() { reference_renderer.rays_traced() } else { options.sample_count() };
    let ours = samples_frame(&options, &gpu_samples);
    Ok(Row {
        name: case.name.clone(),
        triangle_test: case.triangle_test,
        acceleration: used,
        primitives: counts.total(),
        triangles: counts.triangles,
        width: case.width,
        height: case.height,
        acceleration_build_ms,
        scene_bytes,
        kernel_ms: median(&mut kernel),
        timestamps,
        wall_ms: median(&mut wall),
        warm_ms,
        warm_rgb8_ms,
        moving_rgb8_ms,
        moving_presented_ms,
        runs: runs.max(1),
        peak_mib,
        samples: positions.len(),
        errors: compare_frames(&ours, &reference, depth_range_of(&reference)),
        rays,
        reference_ms,
    })
}

/// The median of `runs` warm frames (after one thrown away): `scene` prepared once (its
/// buffers, bins or hierarchy, and kernel), then rendered again and again, each frame's tiles
/// decoded straight into one host frame of floats that the loop keeps, as a live view or a
/// notebook's loop over frames would. What a frame that changes no buffer costs, and what
/// Mitsuba 3 calls a warm frame (docs/performance.md; Mitsuba's `numpy()` makes a new array
/// each frame).
pub fn warm_frame_ms(gpu: &GpuRenderer, scene: &Scene, options: &RenderOptions, runs: usize) -> Result<f64, GpuError> {
    let prepared = gpu.prepare(scene, options, false)?;
    let mut frame = Frame::new(options);
    let mut decode = |tile: &ReadTile| {
        tile.decode_into(&mut frame);
        Ok::<(), GpuError>(())
    };
    median_frame_ms(runs, || prepared.render(&mut decode).map(drop))
}

/// [`warm_frame_ms`] for the colour alone, quantised by the kernel and read into one 8-bit
/// RGB image the loop keeps: a quarter of the bytes of Mitsuba 3's frame of RGB floats, the
/// image a user sees.
pub fn warm_rgb8_frame_ms(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
    runs: usize,
) -> Result<f64, GpuError> {
    rgb8_frames_ms(gpu, scene, options, runs, |_| Ok(()))
}

/// Pixels of the live view's orbit ([`Orbit::orbit`], 0.005 rad a pixel) the camera of
/// [`moving_rgb8_frame_ms`] turns each frame: 0.02 rad.
pub const MOVING_PIXELS: f64 = 4.0;

/// [`warm_rgb8_frame_ms`] with the camera orbited by [`MOVING_PIXELS`] each frame, as a
/// drag turns the live view's (docs/SPEC.md §9): the scene prepared once, then aimed at
/// each frame's camera ([`PreparedScene::aim`]).
pub fn moving_rgb8_frame_ms(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
    runs: usize,
) -> Result<f64, GpuError> {
    rgb8_frames_ms(gpu, scene, options, runs, turning(scene))
}

/// [`moving_rgb8_frame_ms`] as the live view shows a moving frame (docs/SPEC.md §9): the
/// scene aimed at each frame's camera, its tiles drawn onto an 8-bit texture of the frame's
/// size on the device (`PreparedScene::present`), the frame done when the one word saying
/// whether a pixel was handed over is read back. The window's frame but the display's own
/// work (its surface and compositor), so measurable where there is no display. `None` where
/// a frame was not drawn on the device: a pixel handed over to the reference, or texels
/// beyond one binding, which the live view draws from the host.
pub fn moving_presented_frame_ms(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
    runs: usize,
) -> Result<Option<f64>, GpuError> {
    let mut prepared = prepared_colour(gpu, scene, options)?;
    let presenter = Presenter::new(gpu);
    let surface = Presenter::offscreen_target(gpu, options.width, options.height);
    let mut turn = turning(scene);
    let mut drawn = true;
    let ms = median_frame_ms(runs, || {
        turn(&mut prepared)?;
        drawn &= prepared.present(&presenter, &surface, 1)? == Presented::Drawn;
        Ok(())
    })?;
    Ok(drawn.then_some(ms))
}

/// What a moving frame does first: the camera of `scene` turned by [`MOVING_PIXELS`] of the
/// live view's orbit, and the prepared scene aimed at it ([`PreparedScene::aim`]).
fn turning(scene: &Scene) -> impl FnMut(&mut PreparedScene) -> Result<(), GpuError> {
    let mut orbit = Orbit::of_scene(scene);
    let mut moved = scene.clone();
    move |prepared| {
        orbit.orbit(MOVING_PIXELS, 0.0);
        moved.camera = orbit.camera();
        prepared.aim(&moved).map(drop)
    }
}

/// `scene` prepared for its colour alone, quantised by the kernel: the image a user sees.
fn prepared_colour<'g>(
    gpu: &'g GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<PreparedScene<'g>, GpuError> {
    gpu.prepare(scene, &RenderOptions { outputs: Output::Color.into(), ..*options }, true)
}

/// The median of `runs` frames (after one thrown away) of `scene`'s colour alone, quantised
/// by the kernel and read into one 8-bit RGB image the loop keeps, the scene prepared once
/// and changed by `before_frame` before each frame.
fn rgb8_frames_ms(
    gpu: &GpuRenderer,
    scene: &Scene,
    options: &RenderOptions,
    runs: usize,
    mut before_frame: impl FnMut(&mut PreparedScene) -> Result<(), GpuError>,
) -> Result<f64, GpuError> {
    let mut prepared = prepared_colour(gpu, scene, options)?;
    let mut rgb = vec![0u8; options.width as usize * options.height as usize * 3];
    median_frame_ms(runs, || {
        before_frame(&mut prepared)?;
        let mut read = |tile: &ReadTile| {
            tile.color_rgb_into(&mut rgb);
            Ok::<(), GpuError>(())
        };
        prepared.render(&mut read).map(drop)
    })
}

/// The median milliseconds of `runs` calls of `frame`, after one thrown away.
fn median_frame_ms(runs: usize, mut frame: impl FnMut() -> Result<(), GpuError>) -> Result<f64, GpuError> {
    frame()?;
    let mut times = Vec::new();
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        frame()?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    Ok(median(&mut times))
}

/// How many pixels to check against the reference: the reference tests every triangle of a
/// mesh whose box the ray enters, so bigger meshes get fewer samples (≈ 3·10⁸ triangle tests).
fn sample_budget(triangles: usize) -> usize {
    (300_000_000 / triangles.max(1)).clamp(256, 40_000)
}

/// A regular grid of pixels, every `stride`-th row and column (all pixels when stride is 1).
struct Sampler {
    width: u32,
    stride: u32,
}

struct Sample {
    position: (u32, u32),
    pixel: Pixel,
}

impl Sampler {
    fn new(width: u32, height: u32, budget: usize) -> Sampler {
        let pixels = width as f64 * height as f64;
        let stride = (pixels / budget as f64).sqrt().ceil().max(1.0) as u32;
        Sampler { width, stride }
    }

    fn picks(&self, x: u32) -> bool {
        x % self.stride == self.stride / 2
    }

    fn collect(&self, first_row: u32, tile: &Frame, into: &mut Vec<Sample>) {
        for r in 0..tile.height {
            let row = first_row + r;
            if !self.picks(row) {
                continue;
            }
            for i in (0..self.width).filter(|&i| self.picks(i)) {
                let k = (r * self.width + i) as usize;
                into.push(Sample { position: (i, row), pixel: tile.pixel(k) });
            }
        }
    }
}

/// The samples as a one-row frame, in their order.
fn samples_frame(options: &RenderOptions, samples: &[Sample]) -> Frame {
    Frame::from_pixels(
        &RenderOptions { width: samples.len() as u32, height: 1, ..*options },
        samples.iter().map(|s| s.pixel),
    )
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// A scene that frames `mesh`: a perspective camera in front of its bounding box (+z side),
/// one white light from the upper left, grey material.
pub fn mesh_scene(name: &str, mesh: Mesh) -> Scene {
    let Bounds { min: lo, max: hi } = mesh.bounds();
    let (center, radius) = ((lo + hi) / 2.0, ((hi - lo).length() / 2.0).max(1e-9));
    let angle: f64 = 40f64.to_radians();
    let distance = radius / (angle / 2.0).sin();
    Scene {
        path: PathBuf::from(name),
        camera: Camera::new(
            Projection::Perspective { angle },
            center + DVec3::new(0.0, 0.0, distance),
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::Y,
            Default::default(),
        )
        .expect("up (+y) is orthogonal to direction (−z)"),
        lights: vec![Light::Directional(DirectionalLight {
            direction: DVec3::new(-0.5, -0.5, -1.0),
            color: DVec3::splat(0.9),
        })],
        background: Background { color: DVec3::splat(0.2), ambient: DVec3::splat(0.1) },
        materials: vec![Material::diffuse(DVec3::splat(0.8))],
        material_locations: Vec::new(),
        textures: Vec::new(),
        root: vec![Object {
            shape: Shape::Mesh { mesh: Arc::new(mesh), material: 0 },
            location: Default::default(),
            fields: Default::default(),
        }],
        warnings: Vec::new(),
    }
}

/// The standard cases. `quick`: a few small ones that take seconds (CI runs these);
/// otherwise the course scenes, the mesh scaling series and the image size series.
pub fn standard_cases(corpus: &Path, quick: bool) -> Result<Vec<Case>, scene::SceneError> {
    let course = corpus.join("a2");
    let meshes = corpus.join("meshes");
    if !course.is_dir() {
        let hint = "no course files here (give --corpus DIR or set RAYCASTER_CORPUS)";
        return Err(scene::SceneError::in_file(&course, hint));
    }
    let case = |name: &str, scene: Scene, size: u32| Case {
        name: name.to_string(),
        scene,
        width: size,
        height: size,
        triangle_test: TriangleTest::default(),
        acceleration: Acceleration::Auto,
        shading: Shading::default(),
        grid: None,
        reference_grid: None,
        sampling: None,
    };
    let mut cases = Vec::new();
    if quick {
        for name in ["scene2_01_diffuse", "scene2_07_sphere_triangles", "scene2_15_crazy_transforms"] {
            cases.push(case(name, scene::load_scene(&course.join(format!("{name}.txt")))?, 64));
        }
        cases.push(case("bunny_1k", mesh_scene("bunny_1k", scene::load_obj(&course.join("bunny_1k.obj"))?), 64));
        cases.extend(course_line_cases(corpus, "a4", &["output4_04d"], 64)?);
        let sampling = Sampling { sampler: sampling::Sampler::Jittered(4), filter: Filter::Gaussian(0.4), seed: 0 };
        let bunny = mesh_scene("bunny_1k", scene::load_obj(&course.join("bunny_1k.obj"))?);
        cases.push(Case { sampling: Some(sampling), ..case("bunny_1k_4spp", bunny, 64) });
        return Ok(cases);
    }
    let mut course_files: Vec<PathBuf> = std::fs::read_dir(&course)
        .map_err(|e| scene::SceneError::in_file(&course, e.to_string()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|x| x == "txt")
                && p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("scene2_"))
        })
        .collect();
    course_files.sort();
    for path in course_files {
        let name = path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
        cases.push(case(&name, scene::load_scene(&path)?, 200));
    }
    // A course scene at the live view's full size, whose moving frames should keep up with a
    // display's refresh (`moving_presented_frame_ms`).
    let live = course.join("scene2_10_bunny_1k.txt");
    let (width, height) = LIVE_VIEW_SIZE;
    cases.push(Case { height, ..case("scene2_10_bunny_1k", scene::load_scene(&live)?, width) });
    let mesh = |name: &str, path: PathBuf| -> Result<Scene, scene::SceneError> {
        Ok(mesh_scene(name, scene::load_obj(&path)?))
    };
    let series = [
        ("bunny_200", course.join("bunny_200.obj")),
        ("bunny_1k", course.join("bunny_1k.obj")),
        ("bunny_5k", meshes.join("bunny_5k.obj")),
        ("bunny_40k", meshes.join("bunny_40k.obj")),
        ("teapot_high", meshes.join("teapot_high.obj")),
    ];
    for (name, path) in series {
        cases.push(case(name, mesh(name, path)?, 512));
    }
    let sphere = scene::generate::icosphere(DVec3::ZERO, 1.0, 8);
    let icosphere_name = format!("icosphere_{}", sphere.triangles.len());
    let icosphere = mesh_scene(&icosphere_name, sphere);
    cases.push(case(&icosphere_name, icosphere.clone(), 512));
    let bunny = mesh("bunny_40k", meshes.join("bunny_40k.obj"))?;
    for size in [200, 1024, 2048, 4096] {
        cases.push(case("bunny_40k", bunny.clone(), size));
    }
    for test in [TriangleTest::Cramer, TriangleTest::Moller] {
        cases.push(Case { triangle_test: test, ..case("bunny_40k", bunny.clone(), 2048) });
    }
    // Assignment 7: 1, 4, 16 and 36 jittered samples per pixel through the course's gaussian
    // of σ = 0.4, filtered on the device.
    for n in SAMPLES_PER_PIXEL {
        let sampling = Sampling { sampler: sampling::Sampler::Jittered(n), filter: Filter::Gaussian(0.4), seed: 0 };
        let name = format!("bunny_40k_{n}spp");
        cases.push(Case { sampling: Some(sampling), ..case(&name, bunny.clone(), 512) });
    }
    cases.extend(course_line_cases(corpus, "a4", A4_LINES, 200)?);
    cases.extend(grid_comparison(corpus)?);
    // The design choice measured in the same run: each way of finding candidates.
    for acceleration in [Acceleration::Bins, Acceleration::Hierarchy] {
        for (name, scene) in [("bunny_40k", &bunny), (icosphere_name.as_str(), &icosphere)] {
            cases.push(Case { acceleration, ..case(name, scene.clone(), 512) });
        }
        cases.push(Case { acceleration, ..case("bunny_40k", bunny.clone(), 2048) });
    }
    Ok(cases)
}

/// The live view's window size the bench measures a course scene at: 1920×1080.
const LIVE_VIEW_SIZE: (u32, u32) = (1920, 1080);

/// Samples per pixel of the bench's rows of assignment 7.
const SAMPLES_PER_PIXEL: [u32; 4] = [1, 4, 16, 36];

/// The lines of the course's `a4/commands.txt` the bench measures, by their `-output`: a
/// sphere's shadow; a mirrored floor; a mirror sphere, 3 bounces; transparent bars, 10 and 5
/// bounces; a glass sphere, 5 bounces; point lights; the faceted gem, 5 bounces.
const A4_LINES: &[&str] = &[
    "output4_01",
    "output4_03",
    "output4_04d",
    "output4_05",
    "output4_06f",
    "output4_09",
    "output4_10",
    "output4_13",
    "output4_14f",
];

/// The lines of the course's `a6/commands.txt` whose scenes the bench renders with each
/// way of finding candidates, the course's comparison: bunnies of 200, 5000 and 40 000
/// triangles (the last two with shadows), the mirrored floor (one bounce) and the faceted
/// gem (five bounces), each with its line's `-grid`.
const A6_GRID_LINES: &[&str] = &["output6_04b", "output6_06", "output6_07", "output6_11b", "output6_12b"];

/// Primitives up to which the grid comparison has a flat-loops row: scene6_06's 5001 took
/// 25 s of kernel time on lavapipe, more than the rest of the comparison together.
const FLAT_COMPARED_UP_TO: usize = 1000;

/// Each of [`A6_GRID_LINES`] with the course's grid, the hierarchy, flat loops (up to
/// [`FLAT_COMPARED_UP_TO`] primitives) and, for primary rays only, bins; the reference
/// checks every row through the line's grid.
fn grid_comparison(corpus: &Path) -> Result<Vec<Case>, scene::SceneError> {
    let mut cases = Vec::new();
    for line in course_line_cases(corpus, "a6", A6_GRID_LINES, 200)? {
        let flat_fits = line.scene.primitive_counts().total() <= FLAT_COMPARED_UP_TO;
        let mut accelerations = vec![Acceleration::Grid, Acceleration::Hierarchy];
        accelerations.extend(flat_fits.then_some(Acceleration::Flat));
        accelerations.extend((!line.secondary_rays()).then_some(Acceleration::Bins));
        for acceleration in accelerations {
            let grid = line.grid.filter(|_| acceleration == Acceleration::Grid);
            cases.push(Case {
                name: line.name.clone(),
                scene: line.scene.clone(),
                acceleration,
                grid,
                reference_grid: line.grid,
                sampling: None,
                ..line
            });
        }
    }
    Ok(cases)
}

/// The command lines of the course's `folder` (`a4`, `a6`) named in `lines` (by their
/// `-output`), as cases at `size`² with the line's shading flags and `-grid`; none where the
/// course's files lack the folder.
fn course_line_cases(corpus: &Path, folder: &str, lines: &[&str], size: u32) -> Result<Vec<Case>, scene::SceneError> {
    let folder = corpus.join(folder);
    let commands = folder.join("commands.txt");
    let Ok(text) = std::fs::read_to_string(&commands) else { return Ok(Vec::new()) };
    let mut cases = Vec::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let after = |flag: &str| words.iter().position(|w| *w == flag).and_then(|k| words.get(k + 1)).copied();
        let Some(name) = after("-output").map(|o| o.trim_end_matches(".tga")) else { continue };
        if !lines.contains(&name) {
            continue;
        }
        let number = |flag: &str| after(flag).and_then(|v| v.parse::<f64>().ok());
        let shading = Shading {
            shade_back: words.contains(&"-shade_back"),
            shadows: words.contains(&"-shadows"),
            bounces: number("-bounces").map_or(0, |b| b as u32),
            weight: number("-weight").unwrap_or(0.0),
            ..Shading::default()
        };
        let grid = words.iter().position(|w| *w == "-grid").and_then(|k| {
            let n = |i: usize| words.get(k + i).and_then(|v| v.parse::<u32>().ok());
            Some(GridSize { nx: n(1)?, ny: n(2)?, nz: n(3)? })
        });
        let input = after("-input").ok_or_else(|| scene::SceneError::in_file(&commands, "a line without -input"))?;
        cases.push(Case {
            name: name.to_string(),
            scene: scene::load_scene(&folder.join(input))?,
            width: size,
            height: size,
            triangle_test: TriangleTest::default(),
            acceleration: if grid.is_some() { Acceleration::Grid } else { Acceleration::Auto },
            shading,
            grid,
            reference_grid: grid,
            sampling: None,
        });
    }
    Ok(cases)
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row], adapter: &str) -> String {
    let mut out = format!(
        "Adapter: {adapter}. Kernel time from {}; medians of {} runs. Error against the f64 reference on the sampled pixels.\n\n",
        if rows.iter().all(|r| r.timestamps) { "GPU timestamps" } else { "wall clock" },
        rows.first().map_or(0, |r| r.runs)
    );
    out.push_str(
        "| scene | triangle test | candidates from | primitives | pixels | build ms | kernel ms | wall ms | warm frame ms | warm 8-bit colour ms | moving 8-bit colour ms | moving, drawn on the device ms | rays/pixel | Mrays/s | reference Mrays/s | scene MiB | peak MiB | samples | >1 level | hit/miss | depth rel. max | normal max (rad) |\n\
         | --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.2} | {:.2} | {:.2} | {} | {:.2} | {:.1} | {} | {:.2} | {} | {} | {:.3}% | {} | {:.1e} | {:.1e} |",
            r.name,
            r.triangle_test.name(),
            r.acceleration.name(),
            r.primitives,
            if r.width == r.height { format!("{}²", r.width) } else { format!("{}×{}", r.width, r.height) },
            r.acceleration_build_ms.map_or("-".to_string(), |ms| format!("{ms:.1}")),
            r.kernel_ms,
            r.wall_ms,
            r.warm_ms,
            r.warm_rgb8_ms,
            r.moving_rgb8_ms,
            r.moving_presented_ms.map_or("-".to_string(), |ms| format!("{ms:.2}")),
            r.rays as f64 / r.pixels() as f64,
            r.mrays_per_s(),
            r.reference_mrays_per_s().map_or("-".to_string(), |m| format!("{m:.2}")),
            r.scene_bytes as f64 / (1 << 20) as f64,
            r.peak_mib.map_or("-".to_string(), |mib| format!("{mib:.0}")),
            r.samples,
            100.0 * r.off_fraction(),
            r.hit_mismatches(),
            r.depth_relative_max(),
            r.normal_angle_max()
        );
    }
    out
}

/// The rows as CSV, one line each.
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from("scene,triangle_test,acceleration,primitives,triangles,width,height,acceleration_build_ms,scene_bytes,kernel_ms,kernel_from_timestamps,wall_ms,warm_frame_ms,warm_rgb8_frame_ms,moving_rgb8_frame_ms,moving_presented_frame_ms,rays,mrays_per_s,reference_ms,peak_mib,samples,off_by_more_than_one_fraction,hit_mismatches,depth_rel_max,normal_angle_max_rad,color_float_max\n");
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{:.4},{},{:.3},{:.3},{:.3},{:.3},{},{},{:.3},{},{},{},{:.6},{},{:.3e},{:.3e},{:.3e}",
            r.name,
            r.triangle_test.name(),
            r.acceleration.name(),
            r.primitives,
            r.triangles,
            r.width,
            r.height,
            r.acceleration_build_ms.map_or(String::new(), |ms| format!("{ms:.3}")),
            r.scene_bytes,
            r.kernel_ms,
            r.timestamps,
            r.wall_ms,
            r.warm_ms,
            r.warm_rgb8_ms,
            r.moving_rgb8_ms,
            r.moving_presented_ms.map_or(String::new(), |ms| format!("{ms:.3}")),
            r.rays,
            r.mrays_per_s(),
            r.reference_ms.map_or(String::new(), |ms| format!("{ms:.3}")),
            r.peak_mib.map_or(String::new(), |mib| format!("{mib:.1}")),
            r.samples,
            r.off_fraction(),
            r.hit_mismatches(),
            r.depth_relative_max(),
            r.normal_angle_max(),
            r.output(Output::Color).map_or(0.0, |e| e.float_max)
        );
    }
    out
}

/// Draws Mrays/s (log) against the largest relative depth error (log) of each row as a PNG.
/// The depth error is the finest error measure the reference gives (f32 rounding shows in it
/// even where no pixel changes level); rows with a pixel off by more than one level are red.
#[cfg(feature = "plot")]
pub fn plot(rows: &[Row], path: &Path) -> Result<(), raycaster::image_io::ImageError> {
    use plotters::prelude::*;
    const SIZE: (u32, u32) = (900, 600);
    let fail = |e: String| raycaster::image_io::ImageError { path: path.to_path_buf(), message: e };
    register_plot_font().map_err(fail)?;
    let mut buffer = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let points: Vec<(f64, f64, bool, String)> = rows
            .iter()
            .map(|r| {
                let depth = r.depth_relative_max().max(1e-9);
                (r.mrays_per_s().max(1e-3), depth, r.off_fraction() > 0.0, r.label())
            })
            .collect();
        let (x_lo, x_hi) = bounds_log(points.iter().map(|p| p.0));
        let (y_lo, y_hi) = bounds_log(points.iter().map(|p| p.1));
        let root = BitMapBackend::with_buffer(&mut buffer, SIZE).into_drawing_area();
        let mut chart = ChartBuilder::on(&root)
            .caption("raycaster: speed against error (GPU vs f64 reference)", ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d((x_lo..x_hi).log_scale(), (y_lo..y_hi).log_scale())
            .map_err(|e| fail(e.to_string()))?;
        chart
            .configure_mesh()
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .x_desc("kernel throughput, Mrays/s")
            .y_desc("largest relative depth error")
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        chart
            .draw_series(points.iter().map(|(x, y, off, name)| {
                let color = if *off { RED } else { BLUE };
                EmptyElement::at((*x, *y))
                    + Circle::new((0, 0), 4, color.filled())
                    + Text::new(name.clone(), (6, -6), ("sans-serif", 11))
            }))
            .map_err(|e| fail(e.to_string()))?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buffer).expect("sized buffer");
    raycaster::image_io::write_image(path, &image)
}

/// The plot's font, inside the binary: plotters' `ttf` text looked fonts up through
/// fontconfig and drew them with FreeType, so the binary needed both (and their libpng,
/// libexpat, libbrotli, libz) on every machine it ran on. `ab_glyph` draws this one in Rust.
/// DejaVu Sans cut to Latin-1 and a few symbols (17 KB; assets/fonts/LICENSE-DejaVu.txt).
#[cfg(feature = "plot")]
fn register_plot_font() -> Result<(), String> {
    const DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");
    plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, DEJAVU_SANS)
        .map_err(|_| "the embedded font (assets/fonts) does not parse".to_string())
}

/// A log-scale axis range around the values, a factor of 2 beyond each end.
#[cfg(feature = "plot")]
fn bounds_log(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        (0.1, 10.0)
    } else {
        (lo / 2.0, hi * 2.0)
    }
}
