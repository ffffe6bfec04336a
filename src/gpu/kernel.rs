//! The kernel's configuration: the `override` constants a kernel is compiled with, its
//! entry point, and the specialised module they make.

use super::binning;
use super::flatten::SceneBuffers;
use super::layout::PixelLayout;
use super::options::Acceleration;
use super::ray_tree::RenderRays;
use super::workgroup::BIN_PACKET;
use super::{fuse, shader, specialise};
use crate::render::{Output, RenderOptions, SphereTest, TriangleTest};

// A packet never straddles two bins (the kernel's `main_bins` relies on it).
const _: () = assert!(binning::BIN_ROWS.is_multiple_of(BIN_PACKET));

/// The `override` constants a kernel is compiled with: only what the scene and the requested
/// outputs need is compiled in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KernelConfig {
    pub has_spheres: bool,
    pub has_ellipsoids: bool,
    pub has_planes: bool,
    pub has_triangles: bool,
    pub orthographic: bool,
    pub pixel_layout: PixelLayout,
    pub num_lights: u32,
    /// The scene has one material (loaded once per invocation).
    pub one_material: bool,
    pub shade_back: bool,
    /// Some material has a specular colour.
    pub specular: bool,
    pub specular_fix: bool,
    /// Some light is a point light.
    pub point_lights: bool,
    /// Shadow rays ([`RenderRays::shadows`]).
    pub shadows: bool,
    /// A ray tree is traced: its depth ([`TreeShape::depth`](super::ray_tree::TreeShape::depth))
    /// is not part of the kernel but of its parameters (`Params::bounces`), so the lines that
    /// differ only in `-bounces` share one kernel.
    pub tree: bool,
    /// Check every pixel for loops the driver cut short ([`GpuRenderer::loop_limit`](super::GpuRenderer::loop_limit)).
    pub loop_canary: bool,
    pub triangle_test: TriangleTest,
    pub sphere_test: SphereTest,
    pub use_bvh: bool,
    pub use_bins: bool,
    /// With bins, the subgroup's lanes share each item's loads (`main_bins_shared`).
    pub shared_bin_loads: bool,
    pub use_grid: bool,
    /// Some material is a solid texture (`shaders/texture.wgsl`).
    pub textures: bool,
    /// `-stats`: count rays, tests and cells (`shaders/stats.wgsl`).
    pub stats: bool,
    /// `-visualize_grid`: draw the grid's occupied cells (`shaders/voxels.wgsl`).
    pub voxels: bool,
    /// Which of the kernel's passes this pipeline runs.
    pub stage: Stage,
    /// A kernel shared by small renders of different scenes ([`KernelConfig::shared`]).
    pub shared: bool,
}

/// Renders of at most this many samples (pixels × samples per pixel) share kernels
/// ([`KernelConfig::shared`]): assignment 4's 200² lines compile 4 kernels instead of 13 on
/// lavapipe. The branches a shared kernel keeps cost the heaviest of those lines 5 % of its
/// kernel's time (a scene of triangles alone about 10 %); at this size that is about 50 ms,
/// where compiling a kernel of its own costs lavapipe 0.1 to 2 s (docs/performance.md,
/// "Compiles").
pub const SHARED_KERNEL_MAX_SAMPLES: u64 = 512 * 512;

/// A kernel as the renderer's cache of pipelines names it: its configuration and the mask of
/// its bindings.
pub(super) type KernelKey = (KernelConfig, u32);

/// The kernel's passes: one pass for a pixel's centre sample, or, with sampling
/// (docs/SPEC.md §8), a pass tracing every sample and a pass filtering them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Stage {
    /// `main` or `main_bins`: one sample per pixel, at its centre.
    #[default]
    Pixels,
    /// `main_samples`: one invocation per sample; `main_samples_bins`, with bins: a packet of
    /// a pixel's samples per invocation, walking its bin.
    Samples,
    /// `main_filter`: one invocation per output pixel, reading the samples.
    Filter,
}

impl KernelConfig {
    /// The kernel for `buffers`, flattened from a scene that traces `rays`, that finds
    /// candidates by `acceleration` (never `Auto`: what the buffers hold, or will), on a
    /// driver with (`loop_limit`) or without a loop limit, whose subgroups can share a bin's
    /// loads (`shared_loads`, [`GpuRenderer::shares_bin_loads`](super::GpuRenderer::shares_bin_loads)) or not.
    pub fn new(
        buffers: &SceneBuffers,
        acceleration: Acceleration,
        pixel_layout: PixelLayout,
        options: &RenderOptions,
        rays: &RenderRays,
        loop_limit: bool,
        shared_loads: bool,
    ) -> KernelConfig {
        let shading = &options.shading;
        let specular = buffers.materials.iter().any(|m| m.specular != [0.0; 3]);
        let mut config = KernelConfig {
            has_spheres: !buffers.spheres.is_empty(),
            has_ellipsoids: !buffers.ellipsoids.is_empty(),
            has_planes: !buffers.planes.is_empty(),
            has_triangles: !buffers.triangles.is_empty(),
            orthographic: buffers.orthographic,
            pixel_layout,
            num_lights: buffers.lights.len() as u32,
            one_material: buffers.materials.len() == 1,
            shade_back: shading.shade_back,
            specular,
            specular_fix: specular && shading.specular_fix,
            point_lights: buffers.lights.iter().any(|l| l.is_point != 0),
            shadows: rays.shadows,
            tree: rays.tree.depth > 0,
            loop_canary: false,
            triangle_test: options.triangle_test,
            sphere_test: options.sphere_test,
            use_bvh: acceleration == Acceleration::Hierarchy,
            use_bins: acceleration == Acceleration::Bins,
            shared_bin_loads: false,
            use_grid: acceleration == Acceleration::Grid,
            textures: !buffers.textures.is_empty(),
            stats: options.stats,
            voxels: options.visualize_grid,
            stage: Stage::Pixels,
            shared: false,
        };
        // Every pixel, whatever it casts: a hierarchy that cannot cull (slivers across the
        // view), a crowded bin, a flat loop or a texture's blend passes the limit.
        config.loop_canary = loop_limit;
        // The shared walk tests triangles alone, with the watertight test's primary-ray form.
        let eye_only =
            !config.has_spheres && !config.has_ellipsoids && config.triangle_test == TriangleTest::Watertight;
        config.shared_bin_loads = shared_loads && config.use_bins && eye_only;
        config
    }

    /// This kernel as small renders share it, where it can be shared: the light count,
    /// `-shade_back` and the kind of camera read from `Params` (`num_lights`, `switches`),
    /// and point lights, specular colours and several materials compiled in whether the
    /// scene has them or not (each already decided per light or material at run time, so
    /// the image is the same). Many scenes then run one kernel, and the driver compiles it
    /// once. Bins, the grid and `-visualize_grid` keep their own kernels: they serve large
    /// renders, or their compiled-in camera is in the hot loop.
    ///
    /// Where the adapter takes every binding (`every_binding`,
    /// [`GpuRenderer::binds_every_buffer`](super::GpuRenderer::binds_every_buffer)), spheres,
    /// planes and triangles are compiled in too (a loop over none of them tests nothing),
    /// and a scene without lights shares as well. Elsewhere the shared kernel binds only what
    /// the scene's own binds: another kind of primitive or the lights' buffer would be a
    /// binding more, past a limit the scene's own kernel keeps within.
    pub fn shared(self, every_binding: bool) -> KernelConfig {
        if self.use_bins || self.use_grid || self.voxels || (self.num_lights == 0 && !every_binding) {
            return self;
        }
        KernelConfig {
            shared: true,
            num_lights: 0,
            shade_back: false,
            orthographic: false,
            specular: true,
            point_lights: true,
            one_material: false,
            has_spheres: self.has_spheres || every_binding,
            has_planes: self.has_planes || every_binding,
            has_triangles: self.has_triangles || every_binding,
            ..self
        }
    }

    /// Whether the kernel may hand pixels over to the reference (`gpu::handover`): its
    /// driver may cut loops short ([`KernelConfig::loop_canary`]), a solid texture may be
    /// blended beyond its reach ([`super::texture_range`]), or a reflected or refracted ray
    /// may leave its surface grazing it (`Leaving::grazing` in shaders/surface.wgsl).
    pub fn may_hand_over(&self) -> bool {
        self.loop_canary || self.textures || self.tree
    }

    /// Pixels each invocation renders, stacked in a column (the kernel's `PACKET` in
    /// `main_bins`): 4 rays share each load from a bin; `main` renders one pixel.
    pub fn packet(&self) -> u32 {
        if self.use_bins {
            BIN_PACKET
        } else {
            1
        }
    }

    /// The kernel's entry point: `main_bins` renders packets from bins (`main_bins_shared`
    /// sharing their loads), `main` one pixel.
    pub fn entry_point(&self) -> &'static str {
        match self.stage {
            Stage::Samples if self.use_bins => return "main_samples_bins",
            Stage::Samples => return "main_samples",
            Stage::Filter => return "main_filter",
            Stage::Pixels => {}
        }
        match (self.use_bins, self.shared_bin_loads) {
            (true, true) => "main_bins_shared",
            (true, false) => "main_bins",
            (false, _) => "main",
        }
    }

    /// Whether rays other than primary ones are traced (shadow, reflected, refracted).
    pub fn secondary_rays(&self) -> bool {
        self.shadows || self.tree
    }

    /// The values for `PipelineCompilationOptions::constants`.
    pub fn constants(&self) -> [(&'static str, f64); 28] {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        [
            ("HAS_SPHERES", b(self.has_spheres)),
            ("HAS_ELLIPSOIDS", b(self.has_ellipsoids)),
            ("HAS_PLANES", b(self.has_planes)),
            ("HAS_TRIANGLES", b(self.has_triangles)),
            ("ORTHOGRAPHIC", b(self.orthographic)),
            ("WANT_COLOR", b(self.pixel_layout.outputs.contains(Output::Color))),
            ("WANT_NORMAL", b(self.pixel_layout.outputs.contains(Output::Normals))),
            ("WANT_DEPTH", b(self.pixel_layout.outputs.contains(Output::Depth))),
            ("PIXEL_WORDS", self.pixel_layout.words() as f64),
            ("PACKED_8BIT", b(self.pixel_layout.packed)),
            ("NUM_LIGHTS", self.num_lights as f64),
            ("ONE_MATERIAL", b(self.one_material)),
            ("SHADE_BACK", b(self.shade_back)),
            ("SPECULAR", b(self.specular)),
            ("SPECULAR_FIX", b(self.specular_fix)),
            ("POINT_LIGHTS", b(self.point_lights)),
            ("SHADOWS", b(self.shadows)),
            ("TREE", b(self.tree)),
            ("LOOP_CANARY", b(self.loop_canary)),
            ("TRIANGLE_TEST", self.triangle_test as u32 as f64),
            ("SPHERE_TEST", self.sphere_test as u32 as f64),
            ("USE_BVH", b(self.use_bvh)),
            ("USE_BINS", b(self.use_bins)),
            ("USE_GRID", b(self.use_grid)),
            ("TEXTURES", b(self.textures)),
            ("STATS", b(self.stats)),
            ("VOXELS", b(self.voxels)),
            ("SHARED_KERNEL", b(self.shared)),
        ]
    }

    /// The kernel itself: the composed WGSL ([`shader`]) with this configuration's constants
    /// fixed and what they rule out cut away ([`specialise`]).
    pub(super) fn module(&self) -> naga::Module {
        if fuse::requested() {
            return specialise::specialise(&shader::fused_module().0, &self.constants(), self.entry_point());
        }
        specialise::specialise(shader::module(), &self.constants(), self.entry_point())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Shading;

    /// The kernel of a small scene with a sphere, a triangle and one light, from the host's
    /// own steps (flattened buffers, the rays the options trace), as a render would have it.
    fn scene_config(shading: Shading, acceleration: Acceleration) -> KernelConfig {
        let text = "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 4 }
            Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
            Background { color 0 0 0 ambientLight 0.1 0.1 0.1 }
            Materials { numMaterials 1 PhongMaterial { diffuseColor 0.5 0.5 0.5 } }
            Group { numObjects 2 MaterialIndex 0 Sphere { center 0 0 0 radius 1 }
              Triangle { vertex0 -2 -2 -1 vertex1 2 -2 -1 vertex2 0 2 -1 } }";
        let scene = crate::scene::parse_scene(text, std::path::Path::new("kernel.txt")).unwrap();
        let options = RenderOptions { shading, ..RenderOptions::all(16, 16) };
        let rays = crate::camera::PrimaryRays::for_camera(&scene.camera, 16, 16);
        let buffers = SceneBuffers::flattened(&scene, &rays);
        let traced = super::super::unsupported::check(&scene, &options).unwrap();
        KernelConfig::new(&buffers, acceleration, PixelLayout::new(&options, true), &options, &traced, false, false)
    }

    /// Where the adapter does not take every binding, a shared kernel binds exactly the
    /// buffers its scene's own kernel binds: sharing must never take a scene past the
    /// adapter's limit. Where it does, spheres, planes and triangles are compiled in too:
    /// scenes of spheres alone, of triangles alone and of both share one kernel, which
    /// binds what each of their own kernels binds.
    #[test]
    fn a_shared_kernel_binds_what_its_own_kernel_binds() {
        let tree = Shading { shadows: true, bounces: 2, ..Shading::default() };
        let referenced = |c: &KernelConfig| super::super::bindings::referenced(&c.module());
        for shading in [Shading::default(), Shading { shadows: true, ..Shading::default() }, tree] {
            for acceleration in [Acceleration::Flat, Acceleration::Hierarchy] {
                let own = scene_config(shading, acceleration);
                let mut roomy_kernels = Vec::new();
                for (has_spheres, has_triangles, num_lights) in [(true, true, 1), (false, true, 3), (true, false, 2)] {
                    let config = KernelConfig { has_spheres, has_triangles, num_lights, ..own };
                    let within_limits = config.shared(false);
                    assert!(within_limits.shared);
                    assert_eq!(referenced(&within_limits), referenced(&config), "{config:?}");
                    let roomy = config.shared(true);
                    assert!(roomy.shared && roomy.has_planes && roomy.has_spheres && roomy.has_triangles);
                    assert_eq!(referenced(&roomy) & referenced(&config), referenced(&config), "{config:?}");
                    roomy_kernels.push(roomy);
                }
                assert!(roomy_kernels.windows(2).all(|w| w[0] == w[1]), "{roomy_kernels:?}");
            }
        }
        let no_lights = KernelConfig { num_lights: 0, ..scene_config(Shading::default(), Acceleration::Flat) };
        assert_eq!(no_lights.shared(false), no_lights, "a scene without lights keeps its own kernel");
        assert!(no_lights.shared(true).shared);
    }
}
