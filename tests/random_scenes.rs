//! Random valid scenes, rendered by the GPU kernel and by the f64 reference: every output must
//! agree under the project's 0.1 % contract, and the kernel must never produce NaN or infinity.
//!
//! A scene is generated as a tree (spheres, planes, triangles, OBJ meshes, groups, nested
//! transforms with non-uniform scales, mirrors and general matrices, either camera, small
//! random image sizes), written out as scene text and OBJ files in a temporary folder and
//! loaded through the ordinary `load_scene`, so a failure prints exactly the files the binary
//! needs to reproduce it (`raycaster compare`).
//!
//! Each case draws its shading from one of the course's assignments ([`Assignment`]): the
//! diffuse term and directional lights of assignment 2; the Phong specular lobe of 3; point
//! lights with attenuation, shadows, mirror reflection and refraction of 4, with the shading
//! flags (`-shade_back`, `--specular-fix`, `-shadows`, `-bounces 0..4`, `-weight`) drawn per
//! case. One case in eight walks a `-grid` of 1 to 11 cells a side on both backends (the
//! reference's images are the same with or without one: tests/grid.rs), so the kernel's
//! grid meets every primitive, transform and ray kind here. One case in fifty also gets solid textures of assignment 6 (Checkerboard, Noise,
//! Marble, Wood, under a scale and a turn, blending earlier materials, textures included).
//! The kernel refuses by design a texture on a bounded primitive whose coordinates leave
//! its f32 contract, or a tree whose textures blend so many mirrors and glasses that its
//! stack cannot hold it: such a case is counted and the count printed, not failed. (A
//! plane's far hits, and a checkerboard seen by a reflected or refracted ray, it hands to
//! the reference pixel by pixel: those cases are compared like any other.)
//!
//! Every generated number is in a sane range for the f32 kernel (coordinates within ±10,
//! camera distances 2 to 30, radii from 0.05, scale factors 0.2 to 5 in magnitude; colours
//! 0 to 1, exponents 1 to 100, indices of refraction 1 to 2.5); only nested transforms
//! compose them further (at most 3 levels of nesting).
//!
//! The contract per output image: at most `floor(pixels / 1000)` pixels more than 1 level
//! apart, rounded down; images have 1000 to 9216 pixels, so 1 to 9 may differ (see
//! [`MIN_PIXELS`] for why no smaller images). Hit/miss disagreements are counted, and every
//! scene that differs at all is printed with `--nocapture` even when it passes.
//!
//! Besides those, a colour pixel may differ where its reference ray tree has a secondary ray
//! that meets another surface closer to its start than the kernel's spawn offset
//! (`common::spawn_gap`, docs/SPEC.md §5): the kernel's secondary rays start beyond such a
//! surface by design. A soup mesh folded onto itself at half a degree made a line of them
//! (2 pixels of a 12 × 87 image, 5 of a 49 × 37 one, up to 33 levels off). They are found
//! from the reference's geometry alone, never from the GPU's image, printed with the reason,
//! and counted in the run's summary.
//!
//! `RANDOM_SCENES_CASES=N` runs N cases instead of the default, for a longer search.
//! `RANDOM_SCENES_SEED=N` reruns the cases of the seed a run printed; failures found are also
//! persisted by proptest (`tests/proptest-regressions/`) and replayed first.

mod common;

use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, TestError, TestRng, TestRunner};
use raycaster::gpu::{GpuError, GpuRenderer};
use raycaster::grid::GridSize;
use raycaster::image_io::color_image;
use raycaster::metrics::{compare_frames, depth_range_of, OutputErrors};
use raycaster::render::{Frame, Output, RenderOptions, Shading};
use raycaster::scene::{generate, load_scene, Scene};
use std::cell::RefCell;
use std::fmt::Write as _;
use std::time::Instant;

/// About a minute on lavapipe on the project's 2-core machine: each case renders with one of
/// three ways of finding candidates, and each new combination of kernel switches compiles a
/// kernel (3000 cases took 207 s with a cold shader cache). `RANDOM_SCENES_CASES` runs more.
const CASES: u32 = 1000;

/// The smallest image: `floor(pixels / 1000)` allows it one pixel. Random scenes do produce
/// single pixels that f32 cannot get right, about one scene in 1000 at these sizes (22 in
/// 23 000, each a single pixel):
/// - a pixel centre within f32's rounding of a silhouette edge: 2·10⁻⁸ and 3·10⁻⁸ (in
///   barycentric terms) inside a triangle's free edge were seen; f64 hits the triangle, f32
///   misses it (and may hit what is behind);
/// - a plane's horizon: a ray almost parallel to the plane hits it 10⁶–10⁷ units away, where
///   f32's `t` can be off many times over (up to 17× seen); the depth image, whose range
///   reaches that far, shows it as one pixel off by tens of levels.
///
/// Images too small to allow one pixel would make these failures of several runs in ten;
/// two in one image have not been seen.
const MIN_PIXELS: u32 = 1000;

/// The largest image: sides up to 96 pixels.
const MAX_PIXELS: u32 = 96 * 96;

/// The largest image of a case whose rays may bounce: each bounce can double the rays of a
/// pixel (a mirror ray and a refracted ray per hit), so the cap halves per bounce, down to
/// twice [`MIN_PIXELS`], to keep a case about as fast as one without bounces.
fn max_pixels(bounces: u32) -> u32 {
    (MAX_PIXELS >> bounces).max(2 * MIN_PIXELS)
}

type V3 = [f64; 3];

#[derive(Clone, Debug)]
struct SceneSpec {
    width: u32,
    height: u32,
    /// The course assignment whose shading the scene and flags draw from.
    assignment: Assignment,
    /// The command line's shading flags (docs/SPEC.md §1).
    shading: Shading,
    /// `-grid NX NY NZ`, one case in eight: the GPU's grid walk (shaders/grid.wgsl) against
    /// the reference's own (src/grid.rs), primary, shadow and secondary rays alike.
    grid: Option<GridSize>,
    camera: CameraSpec,
    lights: Vec<LightSpec>,
    background: Option<(V3, V3)>,
    materials: Vec<MaterialSpec>,
    /// Written after `materials`, each blending materials before it.
    textures: Vec<TextureSpec>,
    /// The first item of the root group is always a `MaterialIndex`, so every object has one.
    root: Vec<Item>,
}

/// The course assignment whose shading a case draws from: each adds to the one before.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Assignment {
    /// Diffuse materials and directional lights (what the GPU kernel shades today); no
    /// `-shadows`. `--specular-fix`, `-bounces` and `-weight` may be given: they change nothing.
    A2,
    /// Materials with `specularColor` and `exponent`.
    A3,
    /// Point lights, `-shadows`, `reflectiveColor`, `transparentColor`, `indexOfRefraction`.
    A4,
}

#[derive(Clone, Debug, PartialEq)]
enum LightSpec {
    Directional {
        direction: V3,
        color: V3,
    },
    /// `attenuation` is left out of the file when `None` (the parser's default, 1 0 0).
    Point {
        position: V3,
        color: V3,
        attenuation: Option<V3>,
    },
}

/// A material block; a field that is `None` is left out of the file (the parser's default).
#[derive(Clone, Debug, PartialEq)]
struct MaterialSpec {
    /// Written `PhongMaterial` rather than its synonym `Material`.
    phong: bool,
    diffuse: V3,
    specular: Option<V3>,
    exponent: Option<f64>,
    reflective: Option<V3>,
    transparent: Option<V3>,
    index_of_refraction: Option<f64>,
}

/// A solid texture block (GRAMMAR.md A6).
#[derive(Clone, Debug, PartialEq)]
struct TextureSpec {
    /// Checkerboard, Noise, Marble, Wood.
    kind: usize,
    /// `Transform { UniformScale scale ZRotate turn }`.
    scale: f64,
    turn: f64,
    /// Taken modulo the number of materials before the texture when written.
    materials: [usize; 2],
    octaves: u32,
    frequency: f64,
    amplitude: f64,
}

#[derive(Clone, Debug)]
struct CameraSpec {
    perspective: bool,
    center: V3,
    direction: V3,
    up: V3,
    /// `angle` in degrees, or `size`.
    extent: f64,
}

#[derive(Clone, Debug)]
enum Item {
    /// Taken modulo the number of materials when written.
    MaterialIndex(usize),
    Object(Obj),
}

#[derive(Clone, Debug)]
enum Obj {
    Sphere { center: V3, radius: f64 },
    Plane { normal: V3, offset: f64 },
    Triangle([V3; 3]),
    Mesh(MeshSpec),
    Group(Vec<Item>),
    Transform(Vec<Step>, Box<Obj>),
}

#[derive(Clone, Debug)]
enum Step {
    Scale(V3),
    UniformScale(f64),
    Translate(V3),
    XRotate(f64),
    YRotate(f64),
    ZRotate(f64),
    Rotate(V3, f64),
    /// The first three rows of an affine matrix, row-major.
    Matrix([f64; 12]),
}

#[derive(Clone, Debug)]
enum MeshSpec {
    /// Faces of 3 to 5 vertices (fan-triangulated by the reader), each index written in one
    /// of the OBJ spellings the reader accepts.
    Soup { vertices: Vec<V3>, faces: Vec<Vec<(usize, IndexForm)>> },
    /// A closed geodesic sphere (`generate::icosphere`), for meshes with shared edges.
    Icosphere { center: V3, radius: f64, subdivisions: u32 },
}

#[derive(Clone, Copy, Debug)]
enum IndexForm {
    Positive,
    Negative,
    Slashes,
}

// ---- strategies ----

/// Values are rounded to 3 decimals so that a failing scene reads well. An exact coincidence
/// (a pixel centre exactly on a silhouette or a shared edge) would also need the camera's
/// random position and direction to line up with it, which random draws practically never do;
/// shrinking can line them up (it moves values towards 0), so a shrunk failure is worth a look
/// for tangency before it is called a bug.
fn round(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

fn num(range: std::ops::Range<f64>) -> impl Strategy<Value = f64> {
    range.prop_map(round)
}

fn v3(lo: f64, hi: f64) -> impl Strategy<Value = V3> {
    [num(lo..hi), num(lo..hi), num(lo..hi)]
}

/// A vector of length 0.1 to √3, not too short to normalise meaningfully.
fn direction() -> impl Strategy<Value = V3> {
    v3(-1.0, 1.0).prop_filter("too short", |v| length(*v) > 0.1)
}

/// A magnitude in 0.2..5 (uniform in log scale) with a random sign: shrinks, stretches and mirrors.
fn scale_factor() -> impl Strategy<Value = f64> {
    ((0.2f64.ln())..(5f64.ln()), any::<bool>()).prop_map(|(l, negative)| {
        let s = (l.exp() * 1000.0).round() / 1000.0;
        if negative {
            -s
        } else {
            s
        }
    })
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        [scale_factor(), scale_factor(), scale_factor()].prop_map(Step::Scale),
        scale_factor().prop_map(Step::UniformScale),
        v3(-5.0, 5.0).prop_map(Step::Translate),
        num(-180.0..180.0).prop_map(Step::XRotate),
        num(-180.0..180.0).prop_map(Step::YRotate),
        num(-180.0..180.0).prop_map(Step::ZRotate),
        (direction(), num(-180.0..180.0)).prop_map(|(axis, degrees)| Step::Rotate(axis, degrees)),
        matrix().prop_map(Step::Matrix),
    ]
}

/// A general affine matrix `R1 · S · R2 + t`: shears included, singular values 0.2 to 5.
fn matrix() -> impl Strategy<Value = [f64; 12]> {
    (
        direction(),
        -180.0..180.0,
        [scale_factor(), scale_factor(), scale_factor()],
        direction(),
        -180.0..180.0,
        v3(-5.0, 5.0),
    )
        .prop_map(|(axis1, angle1, s, axis2, angle2, t)| {
            use glam::{DMat3, DVec3};
            let r1 = DMat3::from_axis_angle(DVec3::from(axis1).normalize(), f64::to_radians(angle1));
            let r2 = DMat3::from_axis_angle(DVec3::from(axis2).normalize(), f64::to_radians(angle2));
            let m = r1 * DMat3::from_diagonal(DVec3::from(s)) * r2;
            let mut rows = [0.0; 12];
            for r in 0..3 {
                let row = m.row(r);
                rows[4 * r..4 * r + 4].copy_from_slice(&[round(row.x), round(row.y), round(row.z), t[r]]);
            }
            rows
        })
}

fn mesh() -> impl Strategy<Value = MeshSpec> {
    let index_form = prop_oneof![Just(IndexForm::Positive), Just(IndexForm::Negative), Just(IndexForm::Slashes)];
    let soup = prop::collection::vec(v3(-3.0, 3.0), 3..9).prop_flat_map(move |vertices| {
        let n = vertices.len();
        let face = prop::collection::vec((0..n, index_form.clone()), 3..6);
        (Just(vertices), prop::collection::vec(face, 1..7))
            .prop_map(|(vertices, faces)| MeshSpec::Soup { vertices, faces: without_coincident_triangles(faces) })
    });
    let icosphere = (v3(-3.0, 3.0), num(0.05..3.0), 0u32..2)
        .prop_map(|(center, radius, subdivisions)| MeshSpec::Icosphere { center, radius, subdivisions });
    prop_oneof![soup, icosphere]
}

/// Drops every face one of whose triangles (after the reader's fan triangulation) has the
/// same three vertices as a triangle before it. Two such triangles coincide, and which of the
/// two a ray hits first is decided by rounding (a tie in exact arithmetic): the scene has no
/// right answer. Degenerate triangles (a repeated vertex) never hit and may repeat.
fn without_coincident_triangles(faces: Vec<Vec<(usize, IndexForm)>>) -> Vec<Vec<(usize, IndexForm)>> {
    let mut seen: Vec<[usize; 3]> = Vec::new();
    faces
        .into_iter()
        .filter(|face| {
            let mut triangles: Vec<[usize; 3]> = (1..face.len() - 1)
                .map(|k| {
                    let mut t = [face[0].0, face[k].0, face[k + 1].0];
                    t.sort_unstable();
                    t
                })
                .filter(|t| t[0] != t[1] && t[1] != t[2])
                .collect();
            let count = triangles.len();
            triangles.sort_unstable();
            triangles.dedup();
            let fresh = triangles.len() == count && triangles.iter().all(|t| !seen.contains(t));
            if fresh {
                seen.extend(triangles);
            }
            fresh
        })
        .collect()
}

fn leaf() -> impl Strategy<Value = Obj> {
    prop_oneof![
        4 => (v3(-5.0, 5.0), num(0.05..3.0)).prop_map(|(center, radius)| Obj::Sphere { center, radius }),
        1 => (direction(), num(-10.0..10.0)).prop_map(|(normal, offset)| Obj::Plane { normal, offset }),
        4 => [v3(-5.0, 5.0), v3(-5.0, 5.0), v3(-5.0, 5.0)].prop_map(Obj::Triangle),
        2 => mesh().prop_map(Obj::Mesh),
    ]
}

fn object() -> impl Strategy<Value = Obj> {
    leaf().prop_recursive(3, 24, 4, |inner| {
        let item = prop_oneof![
            1 => (0usize..8).prop_map(Item::MaterialIndex),
            4 => inner.clone().prop_map(Item::Object),
        ];
        prop_oneof![
            prop::collection::vec(item, 0..5).prop_map(Obj::Group),
            (prop::collection::vec(step(), 1..3), inner)
                .prop_map(|(steps, child)| Obj::Transform(steps, Box::new(child))),
        ]
    })
}

/// Either camera, looking from 2 to 30 units away towards a point near the origin (so most
/// scenes show something), with a random `up` not parallel to the view.
fn camera() -> impl Strategy<Value = CameraSpec> {
    (any::<bool>(), v3(-2.0, 2.0), direction(), num(2.0..30.0), direction(), num(10.0..120.0), num(1.0..20.0))
        .prop_filter("up parallel to direction", |(_, _, d, _, up, _, _)| {
            let (d, up) = (glam::DVec3::from(*d), glam::DVec3::from(*up));
            d.normalize().cross(up.normalize()).length() > 0.1
        })
        .prop_map(|(perspective, target, direction, distance, up, angle, size)| {
            let unit = glam::DVec3::from(direction).normalize();
            let center = (glam::DVec3::from(target) - distance * unit).to_array().map(round);
            CameraSpec { perspective, center, direction, up, extent: if perspective { angle } else { size } }
        })
}

/// Sides of 12 to 96 pixels (aspect ratios up to 8:1 either way) with at least
/// [`MIN_PIXELS`] and at most `max_pixels` pixels (at least `2 * MIN_PIXELS`), in a random
/// order.
fn image_size(max_pixels: u32) -> impl Strategy<Value = (u32, u32)> {
    (12u32..97, any::<bool>()).prop_flat_map(move |(a, swap)| {
        let b_min = MIN_PIXELS.div_ceil(a).max(12);
        let b_max = (max_pixels / a).min(96);
        (b_min..=b_max).prop_map(move |b| if swap { (b, a) } else { (a, b) })
    })
}

fn colour() -> impl Strategy<Value = V3> {
    v3(0.0, 1.0)
}

/// A directional light, or a point light 12 to 25 units from the origin: outside every
/// primitive the generator writes untransformed (they reach at most √75 + 3 < 12 from it),
/// though a transformed one may still enclose it.
fn light() -> impl Strategy<Value = LightSpec> {
    prop_oneof![
        (direction(), colour()).prop_map(|(direction, color)| LightSpec::Directional { direction, color }),
        (direction(), num(12.0..25.0), colour(), prop::option::of(attenuation())).prop_map(
            |(towards, distance, color, attenuation)| {
                let position = (glam::DVec3::from(towards).normalize() * distance).to_array().map(round);
                LightSpec::Point { position, color, attenuation }
            }
        ),
    ]
}

/// `a0 a1 a2`, each ≥ 0, each 0 half of the time, not all 0 (the parser's rule): a fall-off
/// that leaves lights 12 to 25 units away visible.
fn attenuation() -> impl Strategy<Value = V3> {
    let coefficient = |hi: f64| prop_oneof![Just(0.0), num(0.0..hi)];
    [coefficient(1.0), coefficient(0.1), coefficient(0.01)].prop_filter("all 0", |a| a.iter().any(|&c| c > 0.0))
}

fn material() -> impl Strategy<Value = MaterialSpec> {
    (
        any::<bool>(),
        colour(),
        (prop::option::of(colour()), prop::option::of(num(1.0..100.0))),
        (prop::option::of(colour()), prop::option::of(colour()), prop::option::of(num(1.0..2.5))),
    )
        .prop_map(|(phong, diffuse, (specular, exponent), (reflective, transparent, index_of_refraction))| {
            MaterialSpec { phong, diffuse, specular, exponent, reflective, transparent, index_of_refraction }
        })
}

fn texture() -> impl Strategy<Value = TextureSpec> {
    (0usize..4, num(0.3..4.0), num(-90.0..90.0), [0usize..8, 0usize..8], 0u32..4, num(0.5..8.0), num(0.0..4.0))
        .prop_map(|(kind, scale, turn, materials, octaves, frequency, amplitude)| TextureSpec {
            kind,
            scale,
            turn,
            materials,
            octaves,
            frequency,
            amplitude,
        })
}

/// Textures in one case in fifty: texture kernels are slow to compile on lavapipe, and
/// nearly every textured case needs one of its own (on the shared 2-core machine, 300 cases
/// with textures in one in nine took 141 s, 1000 with one in fifty 412 s).
/// `RANDOM_SCENES_CASES` runs more.
fn textures() -> impl Strategy<Value = Vec<TextureSpec>> {
    prop_oneof![49 => Just(Vec::new()), 1 => prop::collection::vec(texture(), 1..3)]
}

/// The shading flags: `-bounces` 0 to 4, `-weight` 0 or 0.01 to 0.2.
fn shading() -> impl Strategy<Value = Shading> {
    (any::<bool>(), any::<bool>(), any::<bool>(), 0u32..5, prop_oneof![Just(0.0), num(0.01..0.2)]).prop_map(
        |(shade_back, specular_fix, shadows, bounces, weight)| Shading {
            shade_back,
            specular_fix,
            shadows,
            bounces,
            weight,
        },
    )
}

/// Most cases draw from assignment 2, one in 18 each from 3 and 4: a kernel with a ray tree
/// takes about a second to compile on lavapipe with an empty shader cache (CI's), against a
/// tenth of that without, and nearly every A4 case needs a kernel of its own.
fn assignment() -> impl Strategy<Value = Assignment> {
    prop_oneof![16 => Just(Assignment::A2), 1 => Just(Assignment::A3), 1 => Just(Assignment::A4)]
}

/// No grid in most cases; otherwise 1 to 11 cells along each axis, as uneven as the course's.
fn grid() -> impl Strategy<Value = Option<GridSize>> {
    prop_oneof![
        7 => Just(None),
        1 => (1u32..12, 1u32..12, 1u32..12).prop_map(|(nx, ny, nz)| Some(GridSize { nx, ny, nz })),
    ]
}

fn scene() -> impl Strategy<Value = SceneSpec> {
    let flags = (assignment(), shading(), grid()).prop_flat_map(|(assignment, shading, grid)| {
        // Without reflective or transparent materials (before assignment 4) no ray bounces.
        let bounces = if assignment == Assignment::A4 { shading.bounces } else { 0 };
        (Just(assignment), Just(shading), Just(grid), image_size(max_pixels(bounces)))
    });
    (
        flags,
        camera(),
        prop::collection::vec(light(), 0..4),
        prop::option::of((colour(), v3(0.0, 0.5))),
        (prop::collection::vec(material(), 1..5), textures()),
        (
            0usize..8,
            prop::collection::vec(
                prop_oneof![1 => (0usize..8).prop_map(Item::MaterialIndex), 6 => object().prop_map(Item::Object)],
                1..7,
            ),
        ),
    )
        .prop_map(
            |(
                (assignment, shading, grid, (width, height)),
                camera,
                lights,
                background,
                (materials, textures),
                (first, mut root),
            )| {
                root.insert(0, Item::MaterialIndex(first));
                let spec = SceneSpec {
                    width,
                    height,
                    assignment,
                    shading,
                    grid,
                    camera,
                    lights,
                    background,
                    materials,
                    textures,
                    root,
                };
                spec.restricted()
            },
        )
}

impl SceneSpec {
    /// The scene with what comes after its assignment taken out.
    fn restricted(mut self) -> SceneSpec {
        let assignment = self.assignment;
        if assignment < Assignment::A4 {
            self.shading.shadows = false;
            self.lights.retain(|light| matches!(light, LightSpec::Directional { .. }));
            for m in &mut self.materials {
                (m.reflective, m.transparent, m.index_of_refraction) = (None, None, None);
            }
        }
        if assignment < Assignment::A3 {
            for m in &mut self.materials {
                (m.specular, m.exponent) = (None, None);
            }
        }
        self
    }
}

fn length(v: V3) -> f64 {
    glam::DVec3::from(v).length()
}

// ---- writing the files ----

/// The scene text and the OBJ files (name, text) it refers to.
struct Files {
    scene: String,
    objs: Vec<(String, String)>,
}

impl SceneSpec {
    fn material_count(&self) -> usize {
        self.materials.len() + self.textures.len()
    }

    fn files(&self) -> Files {
        let mut files = Files { scene: String::new(), objs: Vec::new() };
        let s = &mut files.scene;
        let c = &self.camera;
        let (kind, extent) =
            if c.perspective { ("PerspectiveCamera", "angle") } else { ("OrthographicCamera", "size") };
        let _ = writeln!(
            s,
            "{kind} {{\n  center {}\n  direction {}\n  up {}\n  {extent} {}\n}}",
            show(c.center),
            show(c.direction),
            show(c.up),
            c.extent
        );
        if !self.lights.is_empty() {
            let _ = writeln!(s, "Lights {{\n  numLights {}", self.lights.len());
            for light in &self.lights {
                let _ = writeln!(s, "  {}", light_text(light));
            }
            s.push_str("}\n");
        }
        if let Some((colour, ambient)) = self.background {
            let _ = writeln!(s, "Background {{ color {} ambientLight {} }}", show(colour), show(ambient));
        }
        let _ = writeln!(s, "Materials {{\n  numMaterials {}", self.material_count());
        for material in &self.materials {
            let _ = writeln!(s, "  {}", material_text(material));
        }
        for (k, texture) in self.textures.iter().enumerate() {
            let _ = writeln!(s, "  {}", texture_text(texture, self.materials.len() + k));
        }
        s.push_str("}\n");
        self.group(&self.root, 0, &mut files);
        files
    }

    fn group(&self, items: &[Item], depth: usize, files: &mut Files) {
        let pad = "  ".repeat(depth);
        let objects = items.iter().filter(|i| matches!(i, Item::Object(_))).count();
        let _ = writeln!(files.scene, "{pad}Group {{\n{pad}  numObjects {objects}");
        for item in items {
            match item {
                Item::MaterialIndex(i) => {
                    let _ = writeln!(files.scene, "{pad}  MaterialIndex {}", i % self.material_count());
                }
                Item::Object(object) => self.object(object, depth + 1, files),
            }
        }
        let _ = writeln!(files.scene, "{pad}}}");
    }

    fn object(&self, object: &Obj, depth: usize, files: &mut Files) {
        let pad = "  ".repeat(depth);
        let line = match object {
            Obj::Sphere { center, radius } => format!("Sphere {{ center {} radius {radius} }}", show(*center)),
            Obj::Plane { normal, offset } => format!("Plane {{ normal {} offset {offset} }}", show(*normal)),
            Obj::Triangle([a, b, c]) => {
                format!("Triangle {{ vertex0 {} vertex1 {} vertex2 {} }}", show(*a), show(*b), show(*c))
            }
            Obj::Mesh(mesh) => {
                let name = format!("mesh{}.obj", files.objs.len());
                files.objs.push((name.clone(), obj_text(mesh)));
                format!("TriangleMesh {{ obj_file {name} }}")
            }
            Obj::Group(items) => return self.group(items, depth, files),
            Obj::Transform(steps, child) => {
                let _ = writeln!(files.scene, "{pad}Transform {{");
                for step in steps {
                    let _ = writeln!(files.scene, "{pad}  {}", step_text(step));
                }
                self.object(child, depth + 1, files);
                let _ = writeln!(files.scene, "{pad}}}");
                return;
            }
        };
        let _ = writeln!(files.scene, "{pad}{line}");
    }
}

fn show(v: V3) -> String {
    format!("{} {} {}", v[0], v[1], v[2])
}

fn light_text(light: &LightSpec) -> String {
    match light {
        LightSpec::Directional { direction, color } => {
            format!("DirectionalLight {{ direction {} color {} }}", show(*direction), show(*color))
        }
        LightSpec::Point { position, color, attenuation } => {
            let attenuation = attenuation.map_or(String::new(), |a| format!(" attenuation {}", show(a)));
            format!("PointLight {{ position {} color {}{attenuation} }}", show(*position), show(*color))
        }
    }
}

/// The material's block, with the fields that are given.
/// The texture that will be material `index`, its two materials among those before it.
fn texture_text(t: &TextureSpec, index: usize) -> String {
    let kind = ["Checkerboard", "Noise", "Marble", "Wood"][t.kind];
    let numbers = match t.kind {
        0 => String::new(),
        1 => format!(" octaves {}", t.octaves),
        _ => format!(" octaves {} frequency {} amplitude {}", t.octaves, t.frequency, t.amplitude),
    };
    format!(
        "{kind} {{ Transform {{ UniformScale {} ZRotate {} }} materialIndex {} materialIndex {}{numbers} }}",
        t.scale,
        t.turn,
        t.materials[0] % index,
        t.materials[1] % index
    )
}

fn material_text(m: &MaterialSpec) -> String {
    let vector = |name: &str, v: Option<V3>| v.map(|v| format!(" {name} {}", show(v))).unwrap_or_default();
    let number = |name: &str, x: Option<f64>| x.map(|x| format!(" {name} {x}")).unwrap_or_default();
    format!(
        "{} {{ diffuseColor {}{}{}{}{}{} }}",
        if m.phong { "PhongMaterial" } else { "Material" },
        show(m.diffuse),
        vector("specularColor", m.specular),
        number("exponent", m.exponent),
        vector("reflectiveColor", m.reflective),
        vector("transparentColor", m.transparent),
        number("indexOfRefraction", m.index_of_refraction),
    )
}

/// The shading flags as the command line spells them, each after a space.
fn flags_text(shading: &Shading) -> String {
    let mut text = String::new();
    if shading.shade_back {
        text.push_str(" -shade_back");
    }
    if shading.specular_fix {
        text.push_str(" --specular-fix");
    }
    if shading.shadows {
        text.push_str(" -shadows");
    }
    if shading.bounces > 0 {
        let _ = write!(text, " -bounces {}", shading.bounces);
    }
    if shading.weight > 0.0 {
        let _ = write!(text, " -weight {}", shading.weight);
    }
    text
}

fn step_text(step: &Step) -> String {
    match step {
        Step::Scale(v) => format!("Scale {}", show(*v)),
        Step::UniformScale(s) => format!("UniformScale {s}"),
        Step::Translate(v) => format!("Translate {}", show(*v)),
        Step::XRotate(d) => format!("XRotate {d}"),
        Step::YRotate(d) => format!("YRotate {d}"),
        Step::ZRotate(d) => format!("ZRotate {d}"),
        Step::Rotate(axis, d) => format!("Rotate {{ {} {d} }}", show(*axis)),
        Step::Matrix(m) => {
            let rows: Vec<String> = m.iter().map(f64::to_string).collect();
            format!("Matrix {{ {} 0 0 0 1 }}", rows.join(" "))
        }
    }
}

fn obj_text(mesh: &MeshSpec) -> String {
    match mesh {
        MeshSpec::Soup { vertices, faces } => {
            let mut text = String::new();
            for v in vertices {
                let _ = writeln!(text, "v {}", show(*v));
            }
            for face in faces {
                let entries: Vec<String> = face
                    .iter()
                    .map(|&(i, form)| match form {
                        IndexForm::Positive => format!("{}", i + 1),
                        IndexForm::Negative => format!("-{}", vertices.len() - i),
                        IndexForm::Slashes => format!("{}//1", i + 1),
                    })
                    .collect();
                let _ = writeln!(text, "f {}", entries.join(" "));
            }
            text
        }
        MeshSpec::Icosphere { center, radius, subdivisions } => {
            let mesh = generate::icosphere(glam::DVec3::from(*center), *radius, *subdivisions);
            let dir = tempfile::tempdir().expect("temporary folder");
            let path = dir.path().join("icosphere.obj");
            generate::write_obj(&mesh, &path).expect("writing the icosphere");
            std::fs::read_to_string(&path).expect("reading the icosphere back")
        }
    }
}

// ---- the property ----

#[derive(Default)]
struct Totals {
    cases: usize,
    pixels: usize,
    /// Pixels the reference hits: a generator that mostly shows background would test little.
    hits: usize,
    hit_mismatches: usize,
    off_by_more_than_one: usize,
    /// Of those, colour pixels within the kernel's spawn gap (`common::spawn_gap`).
    within_spawn_gap: usize,
    /// Cases the kernel refused for a texture, by design (see the module's notes).
    texture_refusals: usize,
    reference_seconds: f64,
    gpu_seconds: f64,
}

/// Renders one scene both ways and checks the contract; the error message carries everything
/// needed to reproduce a failure with the binary.
fn check(gpu: &GpuRenderer, spec: &SceneSpec, totals: &RefCell<Totals>) -> Result<(), TestCaseError> {
    let files = spec.files();
    let reproduce = || reproduction(spec, &files);
    let (_dir, scene) = load(spec, &files)?;

    let options =
        RenderOptions { shading: spec.shading, grid: spec.grid, ..RenderOptions::all(spec.width, spec.height) };
    totals.borrow_mut().cases += 1;
    let start = Instant::now();
    let ours = match gpu.render(&scene, &options) {
        Ok(frame) => frame,
        // The kernel shades assignments 2 to 4, and these trees fit its stack: refusing
        // any would be a regression.
        Err(refusal) if refused_texture(&refusal) => {
            totals.borrow_mut().texture_refusals += 1;
            return Ok(());
        }
        Err(GpuError::Unsupported(refusal)) => {
            return Err(TestCaseError::fail(format!(
                "GPU refused a scene of {:?}: {refusal}\n{}",
                spec.assignment,
                reproduce()
            )));
        }
        Err(e) => return Err(TestCaseError::fail(format!("GPU render failed: {e}\n{}", reproduce()))),
    };
    let gpu_seconds = start.elapsed().as_secs_f64();
    let reference = raycaster::cpu::render(&scene, &options);
    let reference_seconds = start.elapsed().as_secs_f64() - gpu_seconds;
    let errors = compare_frames(&ours, &reference, depth_range_of(&reference));
    let excused = colour_pixels_within_spawn_gap(&scene, spec, &errors, &ours, &reference);

    let pixels = options.pixel_count();
    let allowed = pixels / 1000;
    let mut totals = totals.borrow_mut();
    totals.pixels += pixels;
    totals.hits += reference.hit.iter().filter(|&&h| h).count();
    totals.reference_seconds += reference_seconds;
    totals.gpu_seconds += gpu_seconds;
    totals.hit_mismatches += errors.first().map_or(0, |e| e.hit_mismatches);
    totals.off_by_more_than_one += errors.iter().map(|e| e.image.off_by_more_than_one).sum::<usize>();
    totals.within_spawn_gap += excused.len();
    // Only colour has secondary rays: the excused pixels are colour pixels.
    let counted = |e: &OutputErrors| match e.output {
        Output::Color => e.image.off_by_more_than_one - excused.len(),
        _ => e.image.off_by_more_than_one,
    };
    let failed = errors.iter().any(|e| counted(e) > allowed || e.non_finite > 0);
    let excuses: String =
        excused.iter().map(|(i, row, why)| format!("pixel ({i}, {row}) from the top: {why}\n")).collect();
    if !failed && errors.iter().any(|e| e.hit_mismatches > 0 || e.image.off_by_more_than_one > 0) {
        // Within the contract, but worth seeing (with --nocapture): these are the silhouettes
        // where f32 and f64 part.
        println!(
            "within the contract ({allowed} allowed per output), but not equal:\n{}\n{excuses}{}",
            raycaster::metrics::errors_table(&errors),
            reproduce()
        );
    }
    if failed {
        let table = raycaster::metrics::errors_table(&errors);
        let (min, max) = depth_range_of(&reference);
        return Err(TestCaseError::fail(format!(
            "GPU and reference disagree (allowed: {allowed} pixels more than 1 level off per output, no NaN/inf, \
             besides colour pixels within the kernel's spawn gap)\n\
             {table}\n{excuses}depth range {min} {max}\n{}",
            reproduce()
        )));
    }
    Ok(())
}

/// The colour pixels more than one level apart whose colour depends on a surface within the
/// kernel's spawn gap (`common::spawn_gap`), with the reason: column, row from the top.
fn colour_pixels_within_spawn_gap(
    scene: &Scene,
    spec: &SceneSpec,
    errors: &[OutputErrors],
    ours: &Frame,
    reference: &Frame,
) -> Vec<(u32, u32, String)> {
    let colour_off = errors.iter().any(|e| e.output == Output::Color && e.image.off_by_more_than_one > 0);
    if !colour_off || (spec.shading.bounces == 0 && !spec.shading.shadows) {
        return Vec::new();
    }
    let (a, b) = (color_image(ours), color_image(reference));
    let gaps = common::spawn_gap::SpawnGaps::new(scene, spec.shading);
    a.enumerate_pixels()
        .filter(|&(i, row, p)| (0..3).any(|c| p[c].abs_diff(b.get_pixel(i, row)[c]) > 1))
        .filter_map(|(i, row, _)| gaps.within_spawn_gap(spec.width, spec.height, i, row).map(|why| (i, row, why)))
        .collect()
}

/// Whether the kernel refused a texture by design: coordinates outside its f32 contract, or a
/// blend of a reflective or transparent material under `-bounces`.
fn refused_texture(error: &GpuError) -> bool {
    match error {
        GpuError::Precision(e) => e.what.starts_with("the texture coordinates"),
        GpuError::Unsupported(e) => e.what.contains("a solid texture's materials each spawn their own"),
        _ => false,
    }
}

/// Writes the scene's files into a temporary folder (returned: the files live as long as
/// it) and loads the scene from there.
fn load(spec: &SceneSpec, files: &Files) -> Result<(tempfile::TempDir, Scene), TestCaseError> {
    let dir = tempfile::tempdir().map_err(|e| TestCaseError::fail(e.to_string()))?;
    let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).expect("writing a scene file");
    write("scene.txt", &files.scene);
    for (name, text) in &files.objs {
        write(name, text);
    }
    let scene = load_scene(&dir.path().join("scene.txt")).map_err(|e| {
        TestCaseError::fail(format!("a generated scene does not load: {e}\n{}", reproduction(spec, files)))
    })?;
    Ok((dir, scene))
}

fn reproduction(spec: &SceneSpec, files: &Files) -> String {
    let mut text = format!(
        "---- scene.txt ----\n{}---- end ----\nraycaster compare -input scene.txt -size {} {} -output o.tga -normals n.tga{}{}\n",
        files.scene,
        spec.width,
        spec.height,
        flags_text(&spec.shading),
        spec.grid.map_or(String::new(), |g| format!(" -grid {} {} {}", g.nx, g.ny, g.nz))
    );
    for (name, obj) in &files.objs {
        let _ = write!(text, "---- {name} ----\n{obj}---- end ----\n");
    }
    text
}

fn seed() -> u64 {
    match std::env::var("RANDOM_SCENES_SEED") {
        Ok(text) => text.parse().unwrap_or_else(|_| panic!("RANDOM_SCENES_SEED={text} is not a u64")),
        Err(_) => {
            use std::hash::{BuildHasher, Hasher};
            std::collections::hash_map::RandomState::new().build_hasher().finish()
        }
    }
}

/// The cases of `seed`: `RANDOM_SCENES_CASES` of them, else [`CASES`].
fn runner(seed: u64) -> TestRunner {
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let cases = match std::env::var("RANDOM_SCENES_CASES") {
        Ok(text) => text.parse().unwrap_or_else(|_| panic!("RANDOM_SCENES_CASES={text} is not a u32")),
        Err(_) => CASES,
    };
    let config = Config {
        cases,
        source_file: Some(file!()),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// Fails with the minimal failing scene, if the run found one.
fn passed(seed: u64, result: Result<(), TestError<SceneSpec>>) {
    match result {
        Ok(()) => {}
        Err(TestError::Fail(reason, _)) => panic!("seed {seed}: minimal failing scene:\n{reason}"),
        Err(TestError::Abort(reason)) => panic!("seed {seed}: aborted: {reason}"),
    }
}

#[test]
fn gpu_matches_reference_on_random_scenes() {
    if common::gpu().is_none() {
        return;
    }
    // Each case with one way of finding candidates in turn, so that the bins and the
    // hierarchy meet random scenes whatever the cost model picks at these small sizes.
    let renderers: Vec<_> = common::ACCELERATIONS.iter().map(|&a| common::gpu_with(a).unwrap()).collect();
    let seed = seed();
    let mut runner = runner(seed);
    let totals = RefCell::new(Totals::default());
    let start = Instant::now();
    eprintln!("random scenes: seed {seed} (RANDOM_SCENES_SEED={seed} reruns these cases)");
    let result = runner.run(&scene(), |spec| {
        let gpu = &renderers[totals.borrow().cases % renderers.len()];
        check(gpu, &spec, &totals)
    });
    let t = totals.borrow();
    println!(
        "random scenes: {} renders ({} pixels, {} hit) in {:.1} s (reference {:.1} s, GPU {:.1} s); \
         {} hit/miss disagreements, {} output pixels more than 1 level off ({} of them within the kernel's \
         spawn gap); {} refused for a texture",
        t.cases,
        t.pixels,
        t.hits,
        start.elapsed().as_secs_f64(),
        t.reference_seconds,
        t.gpu_seconds,
        t.hit_mismatches,
        t.off_by_more_than_one,
        t.within_spawn_gap,
        t.texture_refusals
    );
    passed(seed, result);
}

/// The reference alone (no GPU needed): its any-hit query agrees with its closest hit on
/// random scenes, for the primary rays of a 24 × 24 image and the secondary rays from their
/// hits (`common::occlusion`).
#[test]
fn occluded_agrees_with_closest_hit_on_random_scenes() {
    let seed = seed();
    eprintln!("occlusion on random scenes: seed {seed} (RANDOM_SCENES_SEED={seed} reruns these cases)");
    let total = RefCell::new(common::occlusion::Tally::default());
    let result = runner(seed).run(&scene(), |spec| {
        let files = spec.files();
        let (_dir, scene) = load(&spec, &files)?;
        let tally = common::occlusion::check_scene(&scene, 24, 24)
            .map_err(|e| TestCaseError::fail(format!("{e}\n{}", reproduction(&spec, &files))))?;
        total.borrow_mut().add(tally);
        Ok(())
    });
    passed(seed, result);
    let total = total.into_inner();
    assert!(total.occluded > 0 && total.clear > 0, "one answer never came up: {total:?}");
}

#[test]
fn generated_scenes_are_written_as_the_parser_reads_them() {
    // The writer itself, checked on a fixed scene: counts, material indices modulo the
    // materials, OBJ index spellings, the Matrix's constant last row, every light and material
    // field (and the defaults of those left out), and the shading flags.
    let shading = Shading { shade_back: true, specular_fix: true, shadows: true, bounces: 2, weight: 0.05 };
    let phong = MaterialSpec {
        phong: true,
        diffuse: [0.5, 0.25, 0.125],
        specular: Some([0.75, 0.5, 0.25]),
        exponent: Some(12.5),
        reflective: Some([0.25, 0.5, 0.75]),
        // Weight 0.035 (its length): below -weight 0.05, so that -weight cuts this ray.
        transparent: Some([0.02, 0.02, 0.02]),
        index_of_refraction: Some(1.5),
    };
    let plain = MaterialSpec {
        phong: false,
        diffuse: [0.0, 1.0, 0.0],
        specular: None,
        exponent: None,
        reflective: None,
        transparent: None,
        index_of_refraction: None,
    };
    let spec = SceneSpec {
        width: 16,
        height: 16,
        assignment: Assignment::A4,
        shading,
        grid: None,
        camera: CameraSpec {
            perspective: false,
            center: [0.0, 0.0, 10.0],
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
            extent: 4.0,
        },
        lights: vec![
            LightSpec::Directional { direction: [-1.0, 0.0, -1.0], color: [0.5, 0.5, 0.5] },
            LightSpec::Point {
                position: [0.0, 3.0, 12.0],
                color: [1.0, 0.5, 0.25],
                attenuation: Some([0.5, 0.1, 0.01]),
            },
            LightSpec::Point { position: [1.0, 2.0, 3.0], color: [0.25, 0.25, 0.25], attenuation: None },
        ],
        background: None,
        materials: vec![phong, plain],
        textures: Vec::new(),
        root: vec![
            Item::MaterialIndex(2),
            Item::Object(Obj::Transform(
                vec![Step::Matrix([2.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0])],
                Box::new(Obj::Mesh(MeshSpec::Soup {
                    vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
                    faces: vec![vec![
                        (0, IndexForm::Positive),
                        (1, IndexForm::Negative),
                        (2, IndexForm::Slashes),
                        (3, IndexForm::Negative),
                    ]],
                })),
            )),
            Item::MaterialIndex(3),
            // Out of view, between the quad and the directional light: its shadow.
            Item::Object(Obj::Sphere { center: [3.5, 0.5, 2.0], radius: 0.7 }),
            // Its back to the camera: black without -shade_back.
            Item::Object(Obj::Triangle([[-2.0, -2.0, 0.0], [-1.0, -1.0, 0.0], [-1.0, -2.0, 0.0]])),
        ],
    };
    let files = spec.files();
    assert!(files.scene.contains("MaterialIndex 0") && files.scene.contains("MaterialIndex 1"), "{}", files.scene);
    assert!(files.scene.contains("Matrix { 2 0 0 1 0 1 0 0 0 0 1 0 0 0 0 1 }"), "{}", files.scene);
    assert_eq!(
        files.objs,
        vec![("mesh0.obj".to_string(), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 -3 3//1 -1\n".to_string())]
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.txt"), &files.scene).unwrap();
    std::fs::write(dir.path().join("mesh0.obj"), &files.objs[0].1).unwrap();
    let scene = load_scene(&dir.path().join("scene.txt")).unwrap_or_else(|e| panic!("{e}\n{}", files.scene));
    // Two triangles of the quad's fan and one more; the matrix maps the mesh's (1, 1, 0) to
    // (3, 1, 0).
    assert_eq!(scene.primitive_counts().triangles, 3);
    let Some(raycaster::scene::Shape::Transform { matrix, .. }) = scene.root.first().map(|o| &o.shape) else {
        panic!("expected a Transform: {:?}", scene.root)
    };
    assert_eq!(matrix.transform_point3(glam::DVec3::new(1.0, 1.0, 0.0)), glam::DVec3::new(3.0, 1.0, 0.0));

    // Lights and materials as written; what is left out takes the parser's default.
    use glam::DVec3;
    use raycaster::scene::{Light, Material};
    let [Light::Directional(d), Light::Point(p), Light::Point(q)] = &scene.lights[..] else {
        panic!("expected a directional and two point lights: {:?}\n{}", scene.lights, files.scene)
    };
    assert_eq!((d.direction, d.color), (DVec3::new(-1.0, 0.0, -1.0), DVec3::splat(0.5)));
    assert_eq!(
        (p.position, p.color, p.attenuation),
        (DVec3::new(0.0, 3.0, 12.0), DVec3::new(1.0, 0.5, 0.25), DVec3::new(0.5, 0.1, 0.01))
    );
    assert_eq!((q.position, q.color, q.attenuation), (DVec3::new(1.0, 2.0, 3.0), DVec3::splat(0.25), DVec3::X));
    let expected_phong = Material {
        diffuse: DVec3::new(0.5, 0.25, 0.125),
        specular: DVec3::new(0.75, 0.5, 0.25),
        exponent: 12.5,
        reflective: DVec3::new(0.25, 0.5, 0.75),
        transparent: DVec3::splat(0.02),
        index_of_refraction: 1.5,
    };
    assert_eq!(scene.materials, [expected_phong, Material::diffuse(DVec3::Y)]);
    assert!(files.scene.contains("  PhongMaterial {") && files.scene.contains("  Material {"), "{}", files.scene);

    // The flags of the reproduction line: the binary renders with them what the reference
    // renders with `shading`, and each of them changes the image.
    let args = format!("-input scene.txt -size 16 16 -output o.tga --backend cpu{}", flags_text(&shading));
    assert!(reproduction(&spec, &files).contains(&flags_text(&shading)));
    let run = common::bin::raycaster_in(dir.path(), &args.split_whitespace().collect::<Vec<_>>());
    assert!(run.status.success(), "{args}: {}", common::bin::stderr(&run));
    let written = raycaster::image_io::read_image(&dir.path().join("o.tga")).unwrap();
    let image = |shading| {
        let options = RenderOptions { shading, ..RenderOptions::all(16, 16) };
        raycaster::image_io::color_image(&raycaster::cpu::render(&scene, &options))
    };
    assert_eq!(written, image(shading), "{args}");
    let without = [
        ("-shade_back", Shading { shade_back: false, ..shading }),
        ("--specular-fix", Shading { specular_fix: false, ..shading }),
        ("-shadows", Shading { shadows: false, ..shading }),
        ("-bounces", Shading { bounces: 0, ..shading }),
        ("-weight", Shading { weight: 0.0, ..shading }),
    ];
    for (flag, shading) in without {
        assert_ne!(written, image(shading), "{flag} changes nothing in this scene");
    }
}
