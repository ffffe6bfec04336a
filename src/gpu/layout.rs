//! The host twins of the structs in `shaders/params.wgsl`: `#[repr(C)]`, `Pod`, padding
//! spelled out, with the same size and field offsets as naga reports for the WGSL side
//! (checked by `tests/layout.rs`); the numbering of primitive kinds; and the per-pixel
//! word layout of the kernel's output.

use crate::render::{Frame, Output, Outputs, Pixel, RenderOptions};
use bytemuck::{Pod, Zeroable};
/// WGSL `Params`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Params {
    pub direction: [f32; 3],
    pub width: u32,
    pub horizontal: [f32; 3],
    pub height: u32,
    pub up: [f32; 3],
    pub first_row: u32,
    pub background: [f32; 3],
    pub tile_rows: u32,
    pub ambient: [f32; 3],
    /// Bins per image row, when the kernel walks screen-space bins.
    pub bin_columns: u32,
    pub num_spheres: u32,
    pub num_ellipsoids: u32,
    pub num_planes: u32,
    pub num_triangles: u32,
    /// [`LOOP_CANARY_TRIPS`], read from the buffer so that the compiler cannot unroll the
    /// kernel's canary loop.
    pub loop_canary_trips: u32,
    /// `-weight`: no secondary ray whose weight falls below it.
    pub weight: f32,
    /// Cells of the `-grid` along x and y (USE_GRID).
    pub grid_nx: u32,
    pub grid_ny: u32,
    /// The corner of the grid's box, camera-relative like the primitives.
    pub grid_min: [f32; 3],
    pub grid_nz: u32,
    /// One cell's extent along each axis.
    pub grid_cell: [f32; 3],
    /// The first bin row of the band whose lists the tile's bindings hold (USE_BINS).
    pub first_bin_row: u32,
    /// Always 0: the kernel ors it into products whose rounding no compiler may choose
    /// (shaders/exact.wgsl).
    pub zero_bits: u32,
    /// The ray tree's depth ([`TreeShape::depth`](super::ray_tree::TreeShape::depth)), with
    /// the kernel's `TREE`: a value, so that each depth compiles no kernel of its own.
    pub bounces: u32,
    /// The scene's lights: the light loop's count in a kernel shared by small renders
    /// (`SHARED_KERNEL`; other kernels have it compiled in as `NUM_LIGHTS`).
    pub num_lights: u32,
    /// [`SWITCH_SHADE_BACK`], [`SWITCH_ORTHOGRAPHIC`] and [`SWITCH_TRIANGLES_ALONE`]: what a
    /// kernel shared by small renders reads here instead of its own `SHADE_BACK`,
    /// `ORTHOGRAPHIC` and primitive kinds.
    pub switches: u32,
}

/// `Params::switches`: `-shade_back`.
pub const SWITCH_SHADE_BACK: u32 = 1;
/// `Params::switches`: the camera is orthographic.
pub const SWITCH_ORTHOGRAPHIC: u32 = 2;
/// `Params::switches`: the scene's finite primitives are triangles alone, so the
/// hierarchy's leaves hold the triangles' own indices, in leaf order, not references
/// (`SceneBuffers::build_bvh`): what a shared kernel, which has spheres compiled in, cannot
/// tell from its kinds.
pub const SWITCH_TRIANGLES_ALONE: u32 = 4;

/// WGSL `Sampling` (shaders/sampling.wgsl): the sampler, the filter, and the rows of samples
/// one tile holds (docs/SPEC.md §8).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSampling {
    pub count: u32,
    pub side: u32,
    pub seed: u32,
    /// [`crate::sampling::Sampler::kind`].
    pub kind: u32,
    /// [`crate::sampling::Filter::kind`].
    pub filter_kind: u32,
    /// The filter's support radius in pixels.
    pub radius: u32,
    /// The filter's radius or σ.
    pub parameter: f32,
    /// The first image row (from the top) of the tile's samples, and how many rows.
    pub first_row: u32,
    pub rows: u32,
    pub _pad: [u32; 3],
}

/// Words of one sample in the kernel's `samples` buffer (WGSL `SAMPLE_WORDS`): flags, colour,
/// normal, t.
pub const SAMPLE_WORDS: u32 = 8;

/// How many times the kernel's canary loop runs (WGSL `loops_were_cut`): twice, unless the
/// driver's loop limit was reached, after which lavapipe lets every loop run one pass and
/// no more (docs/lavapipe.md).
pub const LOOP_CANARY_TRIPS: u32 = 2;

/// WGSL `Sphere`: a sphere in (camera-relative) world space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSphere {
    pub center: [f32; 3],
    pub radius: f32,
    pub material: u32,
    pub _pad: [u32; 3],
}

/// WGSL `Ellipsoid`: rows of the affine map from world space to the unit sphere's space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEllipsoid {
    pub rows: [[f32; 4]; 3],
    pub material: u32,
    pub _pad: [u32; 3],
}

/// WGSL `Plane`: `normal · p = offset`, normal of unit length.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPlane {
    pub normal: [f32; 3],
    pub offset: f32,
    pub material: u32,
    pub _pad: [u32; 3],
}

/// WGSL `Triangle`: world-space vertices, wound so that `(v1 − v0) × (v2 − v0)` is the normal,
/// and that normal, computed from the f64 vertices and stored as [`octahedral`] coordinates:
/// from the f32 vertices the kernel would lose about 2⁻²⁴ of their distance from the camera
/// over an edge's length, whole levels of the normal's image for a small triangle far away.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub material: u32,
    pub v1: [f32; 3],
    pub normal_u: f32,
    pub v2: [f32; 3],
    pub normal_v: f32,
}

/// The octahedral coordinates of the unit vector `n`: n over its 1-norm, the lower half
/// folded over the upper (Cigolle et al., "A Survey of Efficient Representations for
/// Independent Unit Vectors", JCGT 3(2), 2014, §3.1). In f32 they keep the direction to
/// about 2⁻²⁴; the kernel's `octahedral_decode` inverts them.
pub fn octahedral(n: glam::DVec3) -> [f32; 2] {
    let sign_not_zero = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
    let p = n / (n.x.abs() + n.y.abs() + n.z.abs());
    let (u, v) = if p.z >= 0.0 {
        (p.x, p.y)
    } else {
        ((1.0 - p.y.abs()) * sign_not_zero(p.x), (1.0 - p.x.abs()) * sign_not_zero(p.y))
    };
    [u as f32, v as f32]
}

/// WGSL `EyeTriangle`: a triangle's three edge planes through the rays' common origin or
/// along their common direction (`n · q − w`, with q the ray's direction or origin), and its
/// own plane `normal · p = w` (see `gpu::binning`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EyeTriangle {
    pub edges: [[f32; 4]; 3],
    pub plane: [f32; 4],
}

/// WGSL `BinItem`: a primitive listed in a screen bin ([`PrimitiveKind::reference`]), and a lower
/// bound of the distance at which a primary ray can meet it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BinItem {
    pub reference: u32,
    pub near: f32,
    /// The pixels of the bin whose rays may meet it, `[col0, row0, col1, row1]` inclusive
    /// and relative to the bin's corner, a byte each from the lowest.
    pub pixels: u32,
}

/// WGSL `Material`: [`crate::scene::Material`] in f32, each colour paired with a scalar
/// in 16 bytes as WGSL aligns a `vec3<f32>`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub diffuse: [f32; 3],
    pub exponent: f32,
    pub specular: [f32; 3],
    pub index_of_refraction: f32,
    pub reflective: [f32; 3],
    pub _pad0: u32,
    pub transparent: [f32; 3],
    pub _pad1: u32,
}

impl GpuMaterial {
    pub fn new(m: &crate::scene::Material) -> GpuMaterial {
        let f = |v: glam::DVec3| v.as_vec3().to_array();
        GpuMaterial {
            diffuse: f(m.diffuse),
            exponent: m.exponent as f32,
            specular: f(m.specular),
            index_of_refraction: m.index_of_refraction as f32,
            reflective: f(m.reflective),
            transparent: f(m.transparent),
            ..Default::default()
        }
    }
}

/// WGSL `Texture`: one per material when the scene has solid textures (`kind` 0 for a
/// Phong material), read only by kernels compiled with `TEXTURES`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTexture {
    /// The rows of the affine map from camera-relative world space to texture space: the
    /// texture's Transform after the move back from the camera, composed in f64.
    pub row0: [f32; 4],
    pub row1: [f32; 4],
    pub row2: [f32; 4],
    /// [`TextureKind`](crate::scene::TextureKind) as 1 to 4 (in its order), 0: none.
    pub kind: u32,
    pub first: u32,
    pub second: u32,
    pub octaves: u32,
    pub frequency: f32,
    pub amplitude: f32,
    /// The texture coordinates' magnitude `Q` up to which f32 blends it faithfully
    /// ([`super::texture_range::reach`]); a hit beyond it is handed over.
    pub reach: f32,
    /// 1 where a material it blends reflects or refracts: its hits spawn rays.
    pub spawns: u32,
}

impl GpuTexture {
    /// `kind` of a checkerboard.
    pub const CHECKERBOARD: u32 = 1;

    /// Material `texture`'s entry (zeros for a Phong material) for a camera at `camera`;
    /// `spawns`: whether a material it blends reflects or refracts.
    pub fn new(texture: Option<&crate::scene::Texture>, camera: glam::DVec3, spawns: bool) -> GpuTexture {
        use crate::scene::TextureKind;
        let Some(texture) = texture else { return GpuTexture::default() };
        let map = texture.to_texture * glam::DMat4::from_translation(camera);
        let row = |r: usize| map.row(r).as_vec4().to_array();
        GpuTexture {
            row0: row(0),
            row1: row(1),
            row2: row(2),
            kind: match texture.kind {
                TextureKind::Checkerboard => GpuTexture::CHECKERBOARD,
                TextureKind::Noise => 2,
                TextureKind::Marble => 3,
                TextureKind::Wood => 4,
            },
            first: texture.materials[0],
            second: texture.materials[1],
            octaves: texture.octaves,
            frequency: texture.frequency as f32,
            amplitude: texture.amplitude as f32,
            // A blend that never changes reaches everywhere: f32::MAX, not the infinity of
            // its rate of 0, since the kernel takes finite values only (gpu::finite).
            reach: (super::texture_range::reach(texture) as f32).min(f32::MAX),
            spawns: spawns as u32,
        }
    }
}

/// Perlin's published permutation of 0‥255 (Perlin 2002, "Improving Noise"; his
/// `ImprovedNoise.java`), the kernel's `permutation` buffer. The kernel's own copy: the
/// reference keeps another (`cpu::texture`), and a test holds the two equal.
pub const PERLIN_PERMUTATION: [u32; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99, 37, 240,
    21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88,
    237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83,
    111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216,
    80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173, 186,
    3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17,
    182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129,
    22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238,
    210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184,
    84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195,
    78, 66, 215, 61, 156, 180,
];

/// WGSL `Light`: a directional light (`is_point` 0, the unit vector toward the light) or
/// a point light (`is_point` 1, its camera-relative position and attenuation).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    pub to_light_or_position: [f32; 3],
    pub is_point: u32,
    pub color: [f32; 3],
    pub _pad0: u32,
    pub attenuation: [f32; 3],
    pub _pad1: u32,
}

impl GpuLight {
    /// `light` for a kernel whose camera sits at `camera` (moved to the origin in f64).
    pub fn new(light: &crate::scene::Light, camera: glam::DVec3) -> GpuLight {
        let f = |v: glam::DVec3| v.as_vec3().to_array();
        match light {
            crate::scene::Light::Directional(l) => {
                GpuLight { to_light_or_position: f(-l.direction.normalize()), color: f(l.color), ..Default::default() }
            }
            crate::scene::Light::Point(l) => GpuLight {
                to_light_or_position: f(l.position - camera),
                is_point: 1,
                color: f(l.color),
                attenuation: f(l.attenuation),
                ..Default::default()
            },
        }
    }
}

/// What the kernel writes per pixel (WGSL `write_pixel`). As floats: a hit flag word, then
/// three words of colour, three of normal and one of depth, each only when that output is
/// asked for. Packed (`PACKED_8BIT`), for 8-bit images: one word per output asked for, the
/// colour and `|N|` quantised by the kernel (`r | g << 8 | b << 16`), the depth as the f32
/// bits of `t` (all ones where nothing was hit), which the host quantises in f64.
///
/// A pixel the kernel hands over is marked ([`Handover`]): whose loops the driver cut short
/// (`LOOP_CANARY`), its hit word [`CUT_SHORT_HIT`] or its first packed word
/// [`CUT_SHORT_WORD`]; beyond the f32 kernel's reach (a solid texture blended beyond its
/// reach, [`super::texture_range`], or a reflected or refracted ray leaving its surface
/// grazing it), [`BEYOND_REACH_HIT`] or [`BEYOND_REACH_WORD`]. The host
/// renders it again with the reference ([`PixelLayout::encode`]) before anyone reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PixelLayout {
    pub outputs: Outputs,
    pub packed: bool,
}

impl PixelLayout {
    pub fn new(options: &RenderOptions, packed: bool) -> PixelLayout {
        PixelLayout { outputs: options.outputs, packed }
    }

    /// 32-bit words per pixel (the kernel's `PIXEL_WORDS`).
    pub fn words(&self) -> u32 {
        if self.packed {
            (self.outputs.len() as u32).max(1)
        } else {
            let wants = |output| self.outputs.contains(output) as u32;
            1 + 3 * wants(Output::Color) + 3 * wants(Output::Normals) + wants(Output::Depth)
        }
    }

    /// The frame of `rows` full rows that `words` (one tile, as read back) encode.
    pub fn decode(&self, options: &RenderOptions, rows: u32, words: &[u32]) -> Frame {
        let mut frame = Frame::new(&RenderOptions { height: rows, ..*options });
        let pixels = frame.hit.len();
        assert_eq!(
            words.len(),
            pixels * self.words() as usize,
            "a {}×{rows} tile needs {pixels} pixels",
            options.width
        );
        self.decode_into(words, &mut frame, 0);
        frame
    }

    /// Writes the pixels that `words` (whole pixels of this float layout) encode into
    /// `frame`, from pixel `first_pixel` (counted row by row from the top) on: a tile
    /// decoded in place, with no frame of its own to make and copy.
    ///
    /// # Panics
    /// If `frame` lacks an output this layout holds, or the pixels run past its end.
    pub fn decode_into(&self, words: &[u32], frame: &mut Frame, first_pixel: usize) {
        let stride = self.words() as usize;
        let pixels = words.chunks_exact(stride);
        let at = first_pixel..first_pixel + pixels.len();
        let vector = |w: &[u32]| [f32::from_bits(w[0]), f32::from_bits(w[1]), f32::from_bits(w[2])];
        for (hit, w) in frame.hit[at.clone()].iter_mut().zip(pixels.clone()) {
            *hit = w[0] != 0;
        }
        let mut word = 1;
        if self.outputs.contains(Output::Color) {
            for (color, w) in frame.color[at.clone()].iter_mut().zip(pixels.clone()) {
                *color = vector(&w[word..]);
            }
            word += 3;
        }
        if self.outputs.contains(Output::Normals) {
            for (normal, w) in frame.normal[at.clone()].iter_mut().zip(pixels.clone()) {
                *normal = vector(&w[word..]);
            }
            word += 3;
        }
        if self.outputs.contains(Output::Depth) {
            for (depth, w) in frame.depth[at].iter_mut().zip(pixels) {
                *depth = f32::from_bits(w[word]);
            }
        }
    }
}

/// The hit word of a float pixel whose loops were cut short.
pub const CUT_SHORT_HIT: u32 = 2;
/// The first packed word of a pixel whose loops were cut short, whichever outputs it holds:
/// above every packed colour or normal (three bytes), and a NaN that is not [`PACKED_MISS`]
/// where it stands for a depth, which no t is. The pixel's other words are not read.
pub const CUT_SHORT_WORD: u32 = 0xffff_fffe;

/// The hit word of a float pixel beyond the kernel's reach ([`Handover::BeyondReach`]).
pub const BEYOND_REACH_HIT: u32 = 3;
/// The first packed word of a pixel beyond the kernel's reach ([`Handover::BeyondReach`]),
/// chosen as [`CUT_SHORT_WORD`] is (another NaN).
pub const BEYOND_REACH_WORD: u32 = 0xffff_fffd;

/// What a packed depth word holds where the ray hit nothing (a NaN no kernel computes).
pub const PACKED_MISS: u32 = u32::MAX;

/// Why the kernel left a pixel for the host's reference to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Handover {
    /// The driver cut the invocation's loops short (docs/lavapipe.md).
    LoopsCut,
    /// Beyond the f32 kernel's reach: a solid texture was blended where f32 does not place
    /// its points faithfully, or a reflected or refracted ray left its surface grazing it.
    BeyondReach,
}

impl PixelLayout {
    /// Whether, and why, the kernel handed over the pixel whose words are `words`.
    pub fn handover(&self, words: &[u32]) -> Option<Handover> {
        let (cut, beyond) = self.handover_words();
        match words[0] {
            w if w == cut => Some(Handover::LoopsCut),
            w if w == beyond => Some(Handover::BeyondReach),
            _ => None,
        }
    }

    /// Whether the kernel handed over any pixel of `words` (whole pixels of this layout).
    /// Almost every tile hands over none, so this pass has no branch and the compiler
    /// vectorises it, where a scan pixel by pixel with [`PixelLayout::handover`] cost a
    /// noticeable share of a tile (docs/performance.md).
    pub fn hands_over_any(&self, words: &[u32]) -> bool {
        let (cut, beyond) = self.handover_words();
        let marked = |any: bool, &w: &u32| any | (w == cut) | (w == beyond);
        match self.words() as usize {
            1 => words.iter().fold(false, marked),
            stride => words.iter().step_by(stride).fold(false, marked),
        }
    }

    /// The first words of a pixel whose loops were cut short and of one beyond a texture's
    /// reach.
    fn handover_words(&self) -> (u32, u32) {
        match self.packed {
            true => (CUT_SHORT_WORD, BEYOND_REACH_WORD),
            false => (CUT_SHORT_HIT, BEYOND_REACH_HIT),
        }
    }

    /// Writes `pixel` into `words` as the kernel's `write_pixel` does, unmarked.
    pub fn encode(&self, pixel: &Pixel, words: &mut [u32]) {
        let mut w = 0;
        let rgb8 = |c: [f32; 3]| {
            c.iter().enumerate().fold(0u32, |word, (k, &v)| word | (crate::image_io::quantize(v) as u32) << (8 * k))
        };
        if self.packed {
            if self.outputs.contains(Output::Color) {
                words[w] = rgb8(pixel.color);
                w += 1;
            }
            if self.outputs.contains(Output::Normals) {
                words[w] = if pixel.hit { rgb8(pixel.normal.map(f32::abs)) } else { 0 };
                w += 1;
            }
            if self.outputs.contains(Output::Depth) {
                words[w] = if pixel.hit { pixel.depth.to_bits() } else { PACKED_MISS };
            }
            return;
        }
        words[w] = pixel.hit as u32;
        w += 1;
        let mut put = |values: &[f32]| {
            for v in values {
                words[w] = v.to_bits();
                w += 1;
            }
        };
        if self.outputs.contains(Output::Color) {
            put(&pixel.color);
        }
        if self.outputs.contains(Output::Normals) {
            put(&pixel.normal);
        }
        if self.outputs.contains(Output::Depth) {
            put(&[pixel.depth]);
        }
    }
}

/// The kinds of primitive, one numbering for the host and the kernel (whose `KIND_*`
/// constants [`super::shader::host_constants`] generates from this): a nearest hit names
/// its kind, and a reference in `prim_refs` or a bin is `kind << REF_KIND_SHIFT | index`.
/// Triangles are 0, so that a reference to a triangle is its index: with triangles alone
/// the kernel skips the decoding.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PrimitiveKind {
    Triangle = 0,
    Sphere = 1,
    Ellipsoid = 2,
    /// Never referenced (planes stay outside the bins and the hierarchy), but a hit.
    Plane = 3,
}

/// Bits of a reference below its kind: 2³⁰ primitives of each kind at most.
pub const REF_KIND_SHIFT: u32 = 30;

impl PrimitiveKind {
    pub const ALL: [PrimitiveKind; 4] =
        [PrimitiveKind::Triangle, PrimitiveKind::Sphere, PrimitiveKind::Ellipsoid, PrimitiveKind::Plane];

    /// The name of the kernel's constant.
    pub fn wgsl_name(self) -> &'static str {
        match self {
            PrimitiveKind::Triangle => "KIND_TRIANGLE",
            PrimitiveKind::Sphere => "KIND_SPHERE",
            PrimitiveKind::Ellipsoid => "KIND_ELLIPSOID",
            PrimitiveKind::Plane => "KIND_PLANE",
        }
    }

    /// The kind and index a reference names ([`PrimitiveKind::reference`]'s inverse).
    pub fn of_reference(reference: u32) -> (PrimitiveKind, usize) {
        let kind = Self::ALL[(reference >> REF_KIND_SHIFT) as usize];
        (kind, (reference & ((1 << REF_KIND_SHIFT) - 1)) as usize)
    }

    /// The reference to primitive `index` of this kind.
    pub fn reference(self, index: usize) -> u32 {
        debug_assert!(index < 1 << REF_KIND_SHIFT);
        (self as u32) << REF_KIND_SHIFT | index as u32
    }
}

/// Slots of the kernel's `-stats` counters (shaders/stats.wgsl): neighbouring invocations
/// add into different slots, so that few contend on one word.
pub const STATS_SLOTS: u32 = 64;

/// Words of one slot: a low and a high word for each of the four counts, in
/// [`crate::render::RayStats`]' order (non-shadow rays, shadow rays, tests, cells).
pub const STATS_WORDS: u32 = 8;

/// The counts the kernel left in `counters` (`STATS_SLOTS · STATS_WORDS` words), summed over
/// the slots, each count its high word times 2³² plus its low word.
pub fn sum_counters(words: &[u32]) -> crate::render::RayStats {
    let mut sums = [0u64; 4];
    for slot in words.chunks_exact(STATS_WORDS as usize) {
        for (k, sum) in sums.iter_mut().enumerate() {
            *sum += u64::from(slot[2 * k + 1]) << 32 | u64::from(slot[2 * k]);
        }
    }
    let [non_shadow_rays, shadow_rays, intersections, cells_traversed] = sums;
    crate::render::RayStats { non_shadow_rays, shadow_rays, intersections, cells_traversed }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sets of outputs that put each output first, after another and last in a pixel.
    fn some_outputs() -> [Outputs; 5] {
        [
            Outputs::from(Output::Color),
            Outputs::from(Output::Depth),
            [Output::Color, Output::Normals].into_iter().collect(),
            [Output::Normals, Output::Depth].into_iter().collect(),
            Outputs::ALL,
        ]
    }

    /// A float tile decoded in place lands on its rows of the frame, every output where the
    /// pixel's words put it, and leaves the rows around it as they were.
    #[test]
    fn a_tile_decoded_into_a_frame_fills_its_rows_only() {
        let (width, height, first_row, rows) = (5u32, 7u32, 2u32, 3u32);
        let pixel = |k: usize| Pixel {
            hit: !k.is_multiple_of(3),
            color: [k as f32, 0.5 + k as f32, -(k as f32)],
            normal: [1.0 / (k + 1) as f32, -2.0, 3.5],
            depth: 10.0 + k as f32 * 0.25,
        };
        for outputs in some_outputs() {
            let layout = PixelLayout { outputs, packed: false };
            let stride = layout.words() as usize;
            let tile_pixels = (width * rows) as usize;
            let mut words = vec![0u32; tile_pixels * stride];
            for k in 0..tile_pixels {
                layout.encode(&pixel(k), &mut words[k * stride..(k + 1) * stride]);
            }
            let options = RenderOptions { outputs, ..RenderOptions::all(width, height) };
            let mut frame = Frame::new(&options);
            let untouched = Pixel { hit: true, color: [7.0; 3], normal: [7.0; 3], depth: 7.0 };
            frame.hit.fill(untouched.hit);
            frame.color.fill(untouched.color);
            frame.normal.fill(untouched.normal);
            frame.depth.fill(untouched.depth);
            let first = (first_row * width) as usize;
            layout.decode_into(&words, &mut frame, first);
            for k in 0..options.pixel_count() {
                let expected = match k.checked_sub(first).filter(|&j| j < tile_pixels) {
                    Some(j) => pixel(j),
                    None => untouched,
                };
                let wants = |output| outputs.contains(output);
                let got = frame.pixel(k);
                assert_eq!(got.hit, expected.hit, "{outputs:?}: pixel {k}");
                assert_eq!(
                    got.color,
                    if wants(Output::Color) { expected.color } else { [0.0; 3] },
                    "{outputs:?}: pixel {k}"
                );
                assert_eq!(
                    got.normal,
                    if wants(Output::Normals) { expected.normal } else { [0.0; 3] },
                    "{outputs:?}: pixel {k}"
                );
                assert_eq!(
                    got.depth,
                    if wants(Output::Depth) { expected.depth } else { 0.0 },
                    "{outputs:?}: pixel {k}"
                );
            }
        }
    }

    /// Every layout: the vectorised scan finds a mark wherever the pixel-by-pixel reading
    /// finds one, and ignores the mark's value in a pixel's other words (a float colour or
    /// depth may hold those bits).
    #[test]
    fn hands_over_any_agrees_with_handover() {
        for (outputs, packed) in some_outputs().into_iter().flat_map(|o| [(o, true), (o, false)]) {
            let layout = PixelLayout { outputs, packed };
            let stride = layout.words() as usize;
            let pixels = 37;
            let plain = || -> Vec<u32> { (0..pixels * stride).map(|k| (k as u32 * 2_654_435_761) >> 9).collect() };
            let by_pixel = |words: &[u32]| (0..pixels).any(|k| layout.handover(&words[k * stride..]).is_some());
            let words = plain();
            assert!(!layout.hands_over_any(&words) && !by_pixel(&words), "{layout:?}: nothing marked");
            let (cut, beyond) = layout.handover_words();
            for mark in [cut, beyond] {
                for k in 0..pixels * stride {
                    let mut words = plain();
                    words[k] = mark;
                    let first_word = k % stride == 0;
                    assert_eq!(layout.hands_over_any(&words), first_word, "{layout:?}: mark {mark:#x} at word {k}");
                    assert_eq!(by_pixel(&words), first_word, "{layout:?}: mark {mark:#x} at word {k}");
                }
            }
        }
    }
}
