//! What a GPU render cost, and what it handed over to the reference.

use super::options::Acceleration;

/// What a render cost, as far as the GPU can tell.
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
    /// ([`GpuRenderer::loop_limit`](super::GpuRenderer::loop_limit)), which the reference
    /// rendered instead.
    pub pixels_cut_short: u64,
    /// Pixels where a solid texture was blended beyond its reach
    /// ([`super::texture_range`]), which the reference rendered instead.
    pub pixels_beyond_reach: u64,
    /// Time to flatten the scene into buffers (BVH build included) and upload them.
    pub prepare_ms: f64,
    /// Bytes of scene data on the device (primitives, materials, lights, hierarchy, and
    /// the bins: their edge planes and the buffers of the lists of each tile in flight).
    pub scene_bytes: u64,
    /// How the kernel found candidates (never `Auto`: what the cost model chose).
    pub acceleration: Acceleration,
    /// The course's statistics (`-stats`), where the render was asked to count them
    /// (docs/SPEC.md §7).
    pub counted: Option<crate::render::RayStats>,
    /// The box the `-grid` cells divide, where there was a grid.
    pub grid_bounds: Option<crate::scene::Bounds>,
}

/// Pixels of a tile the reference rendered for the kernel, by why
/// ([`Handover`](super::layout::Handover)).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct HandedOver {
    pub loops_cut: u64,
    pub beyond_reach: u64,
}

impl RenderStats {
    /// Counts one tile read back: its pixels handed over, by why, and its kernel time.
    pub(super) fn add_tile(&mut self, handed: HandedOver, kernel_ns: Option<u64>) {
        self.pixels_cut_short += handed.loops_cut;
        self.pixels_beyond_reach += handed.beyond_reach;
        self.kernel_ns = self.kernel_ns.zip(kernel_ns).map(|(a, b)| a + b);
        self.tiles += 1;
    }
}
