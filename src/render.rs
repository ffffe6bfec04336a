//! What a render is asked for and what it returns, independent of the backend.
//!
//! Both backends fill a [`Frame`] of float buffers (before any quantisation), so the two can
//! be compared on the numbers themselves, and [`crate::image_io`] turns a frame into the
//! 8-bit images of docs/SPEC.md §5 the same way for both.

use crate::grid::GridSize;

/// One of the images a render makes (docs/SPEC.md §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Output {
    /// The shaded colour (`-output`).
    Color,
    /// The world normal (`-normals`).
    Normals,
    /// The hit distance (`-depth`).
    Depth,
}

impl Output {
    /// In the order the kernel writes them, the metrics list them and the command line
    /// names them.
    pub const ALL: [Output; 3] = [Output::Color, Output::Normals, Output::Depth];

    /// The name messages and tables use.
    pub fn name(self) -> &'static str {
        match self {
            Output::Color => "colour",
            Output::Normals => "normals",
            Output::Depth => "depth",
        }
    }

    fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// A set of [`Output`]s: what a render computes, or what a command line names.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Outputs(u8);

impl Outputs {
    pub const NONE: Outputs = Outputs(0);
    pub const ALL: Outputs = Outputs(0b111);

    pub fn contains(self, output: Output) -> bool {
        self.0 & output.bit() != 0
    }

    pub fn with(self, output: Output) -> Outputs {
        Outputs(self.0 | output.bit())
    }

    pub fn union(self, other: Outputs) -> Outputs {
        Outputs(self.0 | other.0)
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    pub fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    /// The members, in [`Output::ALL`]'s order.
    pub fn iter(self) -> impl Iterator<Item = Output> {
        Output::ALL.into_iter().filter(move |&o| self.contains(o))
    }
}

impl From<Output> for Outputs {
    fn from(output: Output) -> Outputs {
        Outputs::NONE.with(output)
    }
}

impl FromIterator<Output> for Outputs {
    fn from_iter<I: IntoIterator<Item = Output>>(outputs: I) -> Outputs {
        outputs.into_iter().fold(Outputs::NONE, Outputs::with)
    }
}

/// How hits are shaded (docs/SPEC.md §5): the flags that change only the colour image.
/// [`Default`] is the course's assignment 2: back faces black, local shading only.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shading {
    /// Shade back-facing hits as if they faced the viewer (`-shade_back`).
    pub shade_back: bool,
    /// The handout's optional specular fix (`--specular-fix`): the specular term is
    /// multiplied by N·L rather than cut to zero where N·L < 0.
    pub specular_fix: bool,
    /// `-shadows`: a shadow ray to every light that faces the hit.
    pub shadows: bool,
    /// `-bounces N`: how deep reflected and refracted rays go (0: local shading only).
    pub bounces: u32,
    /// `-weight W`: no secondary ray whose weight falls below W.
    pub weight: f64,
}

/// Which images to produce and how (docs/SPEC.md §1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// The images to compute; the frame's other buffers stay empty.
    pub outputs: Outputs,
    /// How hits are shaded.
    pub shading: Shading,
    /// The GPU kernel's ray/triangle algorithm (the reference always uses its f64 Cramer's rule).
    pub triangle_test: TriangleTest,
    /// The GPU kernel's ray/sphere algorithm (the reference always uses its f64 quadratic).
    pub sphere_test: SphereTest,
    /// `-grid nx ny nz`: find candidates through a uniform grid (docs/SPEC.md §7). An
    /// explicit grid means the grid: a backend that has none refuses the render.
    pub grid: Option<GridSize>,
    /// `-visualize_grid`: render the grid's occupied cells instead of the objects.
    pub visualize_grid: bool,
    /// `-stats`: count the course's statistics ([`RayStats`]).
    pub stats: bool,
    /// Several samples per pixel and a filter (docs/SPEC.md §8); `None`: one ray through
    /// each pixel's centre, the pixel that sample.
    pub sampling: Option<crate::sampling::Sampling>,
}

/// The course's `RayTracingStats` (assignment 6): what a render counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayStats {
    /// Primary, reflected and refracted rays (the course's `TraceRay` calls).
    pub non_shadow_rays: u64,
    pub shadow_rays: u64,
    /// Ray–primitive tests, a mesh's triangles one by one.
    pub intersections: u64,
    /// Grid cells the 3D-DDA entered.
    pub cells_traversed: u64,
}

impl RayStats {
    pub fn add(&mut self, other: &RayStats) {
        self.non_shadow_rays += other.non_shadow_rays;
        self.shadow_rays += other.shadow_rays;
        self.intersections += other.intersections;
        self.cells_traversed += other.cells_traversed;
    }
}

/// What a render cost: every field the GPU measures; the reference fills `tiles`, `counted`
/// and `grid_bounds`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Time spent in the kernel, summed over tiles, from GPU timestamp queries; `None`
    /// where the adapter has none (then only wall time can be measured).
    pub kernel_ns: Option<u64>,
    /// Dispatches the image took.
    pub tiles: u32,
    /// Time to build the hierarchy or the bins on the CPU, when the scene got one.
    pub acceleration_build_ms: Option<f64>,
    /// Pixels whose loops the driver cut short
    /// ([`GpuRenderer::loop_limit`](crate::gpu::GpuRenderer::loop_limit)), which the reference
    /// rendered instead.
    pub pixels_cut_short: u64,
    /// Pixels beyond the f32 kernel's reach, which the reference rendered instead: a solid
    /// texture blended beyond its reach ([`crate::gpu::texture_range`]), or a reflected or
    /// refracted ray leaving its surface at a cosine below 1/1024 (docs/SPEC.md §5).
    pub pixels_beyond_reach: u64,
    /// Time to flatten the scene into buffers (BVH build included) and upload them.
    pub prepare_ms: f64,
    /// Of `prepare_ms`: the time a thread of its own took to compile the kernel, or find it
    /// compiled, while the others flattened, built and uploaded (the longer of the two is
    /// what preparing waited for).
    pub compile_ms: f64,
    /// Of `compile_ms`: specialising the kernel's module for this render (naga's IR, on the
    /// host), before wgpu and the driver compile it.
    pub specialise_ms: f64,
    /// Time the calling thread waited for tiles to be read back, after preparing: what the
    /// device, the readback and filling the tiles' lists cost beyond the caller's own work
    /// on the tiles (decoding, encoding, writing), which overlaps them.
    pub waited_ms: f64,
    /// Time spent filling the bins' lists of the tiles after the first (on the thread that
    /// submits them).
    pub lists_ms: f64,
    /// Bytes of scene data on the device (primitives, materials, lights, hierarchy, and
    /// the bins: their edge planes and the buffers of the lists of each tile in flight).
    pub scene_bytes: u64,
    /// How the kernel found candidates (never `Auto`: what the cost model chose).
    pub acceleration: Acceleration,
    /// The course's statistics (`-stats`), where the render was asked to count them
    /// (docs/SPEC.md §7).
    pub counted: Option<RayStats>,
    /// The box the `-grid` cells divide, where there was a grid.
    pub grid_bounds: Option<crate::scene::Bounds>,
}

/// How the kernel finds the primitives a ray may hit (planes are always tested directly).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Acceleration {
    /// Screen-space bins where their lists are short, else the hierarchy from
    /// [`GpuOptions::bvh_min_primitives`](crate::gpu::GpuOptions::bvh_min_primitives) on, else flat loops.
    #[default]
    Auto,
    /// Screen-space bins ([`crate::gpu::binning`]).
    Bins,
    /// The bounding volume hierarchy ([`crate::bvh`]).
    Hierarchy,
    /// Every primitive for every ray.
    Flat,
    /// The uniform grid `-grid` asks for (docs/SPEC.md §7); never chosen otherwise.
    Grid,
}

impl Acceleration {
    pub fn name(self) -> &'static str {
        match self {
            Acceleration::Auto => "auto",
            Acceleration::Bins => "bins",
            Acceleration::Hierarchy => "hierarchy",
            Acceleration::Flat => "flat",
            Acceleration::Grid => "grid",
        }
    }
}

/// Ray/triangle algorithms the kernel can be compiled with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TriangleTest {
    /// Cramer's rule, as the seed notes derive it. (Discriminants are the kernel's
    /// `TRIANGLE_TEST` values.)
    Cramer = 0,
    /// Möller–Trumbore (1997).
    Moller = 1,
    /// Woop, Benthin, Wald (2013): no ray slips between triangles sharing an edge.
    #[default]
    Watertight = 2,
}

/// Ray/sphere algorithms the kernel can be compiled with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SphereTest {
    /// The textbook quadratic `b² − 4ac`. (Discriminants are the kernel's `SPHERE_TEST`.)
    Naive = 0,
    /// Haines et al., Ray Tracing Gems ch. 7: no cancellation far from the sphere.
    #[default]
    Robust = 1,
}

impl TriangleTest {
    pub const ALL: [TriangleTest; 3] = [TriangleTest::Cramer, TriangleTest::Moller, TriangleTest::Watertight];

    pub fn name(self) -> &'static str {
        match self {
            TriangleTest::Cramer => "cramer",
            TriangleTest::Moller => "moller",
            TriangleTest::Watertight => "watertight",
        }
    }
}

impl SphereTest {
    pub const ALL: [SphereTest; 2] = [SphereTest::Naive, SphereTest::Robust];

    pub fn name(self) -> &'static str {
        match self {
            SphereTest::Naive => "naive",
            SphereTest::Robust => "robust",
        }
    }
}

impl RenderOptions {
    /// A render of every output at `width × height`, back faces black.
    pub fn all(width: u32, height: u32) -> Self {
        RenderOptions {
            width,
            height,
            outputs: Outputs::ALL,
            shading: Shading::default(),
            triangle_test: TriangleTest::default(),
            sphere_test: SphereTest::default(),
            grid: None,
            visualize_grid: false,
            stats: false,
            sampling: None,
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The samples the image traces: a pixel's centre each, or with sampling (docs/SPEC.md
    /// §8) each pixel's samples.
    pub fn sample_count(&self) -> u64 {
        self.pixel_count() as u64 * self.sampling.map_or(1, |s| s.count()) as u64
    }
}

/// The float result of a render. Pixels are stored row by row from the **top** row of the
/// image (the order image files use); buffers that were not asked for are empty.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Whether the pixel's ray hit anything (always filled).
    pub hit: Vec<bool>,
    /// Linear RGB, unclamped (background colour where nothing was hit).
    pub color: Vec<[f32; 3]>,
    /// Unit world-space normal as the intersection returned it (not flipped, not abs'd);
    /// zero where nothing was hit.
    pub normal: Vec<[f32; 3]>,
    /// Signed world-space ray parameter `t` of the closest hit; 0 where nothing was hit.
    pub depth: Vec<f32>,
}

/// What a render computes for one pixel, as stored in a [`Frame`]: zero for what was not
/// asked for, and normal and depth zero where nothing was hit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pixel {
    pub hit: bool,
    pub color: [f32; 3],
    pub normal: [f32; 3],
    pub depth: f32,
}

impl Frame {
    /// A frame with buffers sized for what `options` asks for, every pixel a miss and zero.
    pub fn new(options: &RenderOptions) -> Frame {
        let n = options.pixel_count();
        let wants = |output| options.outputs.contains(output);
        Frame {
            width: options.width,
            height: options.height,
            hit: vec![false; n],
            color: if wants(Output::Color) { vec![[0.0; 3]; n] } else { Vec::new() },
            normal: if wants(Output::Normals) { vec![[0.0; 3]; n] } else { Vec::new() },
            depth: if wants(Output::Depth) { vec![0.0; n] } else { Vec::new() },
        }
    }

    /// The `options.width × options.height` frame of `pixels`, row by row from the top,
    /// keeping the outputs `options` asks for (the other buffers stay empty).
    ///
    /// # Panics
    /// If there are not exactly `options.pixel_count()` pixels.
    pub fn from_pixels(options: &RenderOptions, pixels: impl IntoIterator<Item = Pixel>) -> Frame {
        let n = options.pixel_count();
        let (color, normals, depth) = (
            options.outputs.contains(Output::Color),
            options.outputs.contains(Output::Normals),
            options.outputs.contains(Output::Depth),
        );
        let capacity = |wanted: bool| if wanted { n } else { 0 };
        let mut frame = Frame {
            width: options.width,
            height: options.height,
            hit: Vec::with_capacity(n),
            color: Vec::with_capacity(capacity(color)),
            normal: Vec::with_capacity(capacity(normals)),
            depth: Vec::with_capacity(capacity(depth)),
        };
        for pixel in pixels {
            frame.hit.push(pixel.hit);
            if color {
                frame.color.push(pixel.color);
            }
            if normals {
                frame.normal.push(pixel.normal);
            }
            if depth {
                frame.depth.push(pixel.depth);
            }
        }
        assert_eq!(frame.hit.len(), n, "a {}×{} frame needs {n} pixels", options.width, options.height);
        frame
    }

    /// Pixel `k` (counted row by row from the top), zero in the outputs the frame lacks.
    pub fn pixel(&self, k: usize) -> Pixel {
        Pixel {
            hit: self.hit[k],
            color: self.color.get(k).copied().unwrap_or_default(),
            normal: self.normal.get(k).copied().unwrap_or_default(),
            depth: self.depth.get(k).copied().unwrap_or_default(),
        }
    }
}

/// Splits `height` image rows into tiles of at most `rows_per_tile` (≥ 1) rows, top first:
/// `(first_row, rows)` for each.
pub fn row_tiles(height: u32, rows_per_tile: u32) -> impl Iterator<Item = (u32, u32)> {
    let step = rows_per_tile.max(1);
    (0..height).step_by(step as usize).map(move |first| (first, step.min(height - first)))
}

impl Frame {
    /// Copies `tile` (full-width rows) into this frame starting at image row `first_row`.
    pub fn paste(&mut self, first_row: u32, tile: &Frame) {
        assert_eq!(tile.width, self.width, "tiles are full rows");
        let start = first_row as usize * self.width as usize;
        let end = start + tile.hit.len();
        self.hit[start..end].copy_from_slice(&tile.hit);
        if !self.color.is_empty() {
            self.color[start..end].copy_from_slice(&tile.color);
        }
        if !self.normal.is_empty() {
            self.normal[start..end].copy_from_slice(&tile.normal);
        }
        if !self.depth.is_empty() {
            self.depth[start..end].copy_from_slice(&tile.depth);
        }
    }
}
