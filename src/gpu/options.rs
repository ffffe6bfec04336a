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
    /// The tile to aim for instead of the one of the adapter's kind (`tiles::adapter_tile_bytes`),
    /// within `max_tile_bytes`: for measuring an adapter we have no figures for
    /// ([`TILE_MIB_VARIABLE`]).
    pub tile_bytes: Option<u64>,
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
            tile_bytes: None,
            bvh_min_primitives: BVH_MIN_PRIMITIVES,
            acceleration: Acceleration::Auto,
            shared_bin_loads: true,
            mapped_buffers: true,
            share_small_kernels: true,
        }
    }
}

/// The variable that sets [`GpuOptions::tile_bytes`] for the command line and the Python
/// package: a whole number of MiB from 1 to 32 (docs/SPEC.md §6); unset or empty, the
/// adapter's kind decides.
pub const TILE_MIB_VARIABLE: &str = "RAYCASTER_TILE_MIB";

impl GpuOptions {
    /// The defaults, with the tile [`TILE_MIB_VARIABLE`] asks for; an error names the
    /// variable and the value it refuses.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn from_env() -> Result<GpuOptions, String> {
        let value = std::env::var_os(TILE_MIB_VARIABLE).unwrap_or_default();
        Ok(GpuOptions { tile_bytes: tile_bytes_of(&value.to_string_lossy())?, ..GpuOptions::default() })
    }
}

/// The tile [`TILE_MIB_VARIABLE`]'s `value` asks for: `None` for an empty value.
#[cfg(not(target_arch = "wasm32"))]
fn tile_bytes_of(value: &str) -> Result<Option<u64>, String> {
    if value.is_empty() {
        return Ok(None);
    }
    let most = MAX_TILE_BYTES >> 20;
    match value.parse::<u64>() {
        Ok(mib) if (1..=most).contains(&mib) => Ok(Some(mib << 20)),
        _ => Err(format!("{TILE_MIB_VARIABLE}={value:?}: the tile's size is a whole number of MiB from 1 to {most}")),
    }
}

pub use crate::render::Acceleration;

#[cfg(test)]
mod tests {
    use super::*;

    /// The variable takes whole MiB within the cap, and nothing else, naming itself.
    #[test]
    fn the_tile_variable_takes_whole_mib_within_the_cap() {
        assert_eq!(tile_bytes_of(""), Ok(None));
        assert_eq!(tile_bytes_of("1"), Ok(Some(1 << 20)));
        assert_eq!(tile_bytes_of("32"), Ok(Some(32 << 20)));
        for refused in ["0", "33", "2.5", "-1", " 4", "four"] {
            let error = tile_bytes_of(refused).unwrap_err();
            assert!(error.starts_with(&format!("RAYCASTER_TILE_MIB={refused:?}")), "{error}");
        }
    }
}
