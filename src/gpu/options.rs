//! How a [`GpuRenderer`](super::GpuRenderer) renders: the choices its caller makes.

/// The caller's cap on the output tile of one dispatch; the kind of adapter sets a lower one
/// (`tiles::adapter_tile_bytes`: 1 MiB on lavapipe, 2 MiB on a GPU). It also bounds host
/// memory.
pub const MAX_TILE_BYTES: u64 = 32 << 20;

/// Below this many finite primitives the flat loops beat the hierarchy (lavapipe, at 200²:
/// docs/performance.md).
pub const BVH_MIN_PRIMITIVES: usize = 8;

/// How a [`GpuRenderer`](super::GpuRenderer) renders; [`Default`] is what the command line uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuOptions {
    /// Caps the output buffer of one dispatch (or less if the adapter's limits are lower;
    /// at least one row); taller images render in several tiles.
    pub max_tile_bytes: u64,
    /// Scenes with at least this many finite primitives get a hierarchy; `usize::MAX` turns
    /// it off, 1 forces it on.
    pub bvh_min_primitives: usize,
    /// How rays find their candidates.
    pub acceleration: Acceleration,
    /// Let the lanes of a bin's row share its loads (`main_bins_shared`) where the device
    /// allows it ([`GpuRenderer::shares_bin_loads`](super::GpuRenderer::shares_bin_loads));
    /// false keeps one load per lane (`main_bins`), as on every other adapter, for tests to
    /// compare the two.
    pub shared_bin_loads: bool,
    /// Let the host map the buffers the kernel binds where the device allows it
    /// ([`GpuRenderer::maps_kernel_buffers`](super::GpuRenderer::maps_kernel_buffers)); false
    /// copies through staging and readback buffers, as on a discrete GPU, for tests to
    /// compare the two.
    pub mapped_buffers: bool,
    /// Let renders of at most [`SHARED_KERNEL_MAX_SAMPLES`](super::kernel::SHARED_KERNEL_MAX_SAMPLES)
    /// samples run a kernel shared with other scenes ([`KernelConfig::shared`](super::KernelConfig::shared)),
    /// so that a batch of small renders compiles few kernels; false compiles each its own, for
    /// tests to compare the two, and for the window, which renders one scene at many sizes.
    pub share_small_kernels: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            max_tile_bytes: MAX_TILE_BYTES,
            bvh_min_primitives: BVH_MIN_PRIMITIVES,
            acceleration: Acceleration::Auto,
            shared_bin_loads: true,
            mapped_buffers: true,
            share_small_kernels: true,
        }
    }
}

pub use crate::render::Acceleration;
