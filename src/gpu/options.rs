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
    /// Tiles in flight at once: each has its own buffers, and while the caller reads one
    /// back the device renders the others ([`TILE_SLOTS_VARIABLE`]).
    pub tile_slots: usize,
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
            tile_slots: TILE_SLOTS,
            bvh_min_primitives: BVH_MIN_PRIMITIVES,
            acceleration: Acceleration::Auto,
            shared_bin_loads: true,
            mapped_buffers: true,
            share_small_kernels: true,
        }
    }
}

/// Tiles in flight unless [`TILE_SLOTS_VARIABLE`] says otherwise: the host reads one back
/// while the device renders the next. Measured on lavapipe only (docs/performance.md, "Tiles
/// in flight"); the variable is there to measure other adapters.
pub const TILE_SLOTS: usize = 2;

/// The variable that sets [`GpuOptions::tile_bytes`] for the command line and the Python
/// package: a whole number of MiB from 1 to 32 (docs/SPEC.md §6); unset or empty, the
/// adapter's kind decides.
pub const TILE_MIB_VARIABLE: &str = "RAYCASTER_TILE_MIB";

/// The variable that sets [`GpuOptions::tile_slots`] for the command line and the Python
/// package: a whole number from 1 to 8 (docs/SPEC.md §6); unset or empty, [`TILE_SLOTS`].
pub const TILE_SLOTS_VARIABLE: &str = "RAYCASTER_TILE_SLOTS";

impl GpuOptions {
    /// The defaults, with the tile [`TILE_MIB_VARIABLE`] and the tiles in flight
    /// [`TILE_SLOTS_VARIABLE`] ask for; an error names the variable and the value it refuses.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn from_env() -> Result<GpuOptions, String> {
        let read = |variable| std::env::var_os(variable).unwrap_or_default().to_string_lossy().into_owned();
        let mib = whole_number_of(TILE_MIB_VARIABLE, &read(TILE_MIB_VARIABLE), MAX_TILE_BYTES >> 20, TILE_MIB_IS)?;
        let slots = whole_number_of(TILE_SLOTS_VARIABLE, &read(TILE_SLOTS_VARIABLE), 8, TILE_SLOTS_ARE)?;
        Ok(GpuOptions {
            tile_bytes: mib.map(|mib| mib << 20),
            tile_slots: slots.map_or(TILE_SLOTS, |n| n as usize),
            ..GpuOptions::default()
        })
    }
}

#[cfg(not(target_arch = "wasm32"))]
const TILE_MIB_IS: &str = "the tile's size is a whole number of MiB";
#[cfg(not(target_arch = "wasm32"))]
const TILE_SLOTS_ARE: &str = "the tiles in flight are a whole number";

/// The whole number from 1 to `most` that `variable`'s `value` holds (`what` says what it
/// counts, for the error): `None` for an empty value.
#[cfg(not(target_arch = "wasm32"))]
fn whole_number_of(variable: &str, value: &str, most: u64, what: &str) -> Result<Option<u64>, String> {
    if value.is_empty() {
        return Ok(None);
    }
    match value.parse::<u64>() {
        Ok(n) if (1..=most).contains(&n) => Ok(Some(n)),
        _ => Err(format!("{variable}={value:?}: {what} from 1 to {most}")),
    }
}

pub use crate::render::Acceleration;

#[cfg(test)]
mod tests {
    use super::*;

    /// The variables take whole numbers within their bounds, and nothing else, naming
    /// themselves.
    #[test]
    fn the_tile_variables_take_whole_numbers_within_their_bounds() {
        let mib = |value| whole_number_of(TILE_MIB_VARIABLE, value, 32, TILE_MIB_IS);
        assert_eq!(mib(""), Ok(None));
        assert_eq!(mib("1"), Ok(Some(1)));
        assert_eq!(mib("32"), Ok(Some(32)));
        for refused in ["0", "33", "2.5", "-1", " 4", "four"] {
            let error = mib(refused).unwrap_err();
            assert!(error.starts_with(&format!("RAYCASTER_TILE_MIB={refused:?}")), "{error}");
        }
        let slots = |value| whole_number_of(TILE_SLOTS_VARIABLE, value, 8, TILE_SLOTS_ARE);
        assert_eq!(slots("8"), Ok(Some(8)));
        assert_eq!(
            slots("9").unwrap_err(),
            "RAYCASTER_TILE_SLOTS=\"9\": the tiles in flight are a whole number from 1 to 8"
        );
    }
}
