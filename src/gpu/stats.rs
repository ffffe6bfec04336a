//! What the GPU counts of a tile it reads back, into the render's [`RenderStats`].

use crate::render::RenderStats;

/// Pixels of a tile the reference rendered for the kernel, by why
/// ([`Handover`](super::layout::Handover)).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct HandedOver {
    pub loops_cut: u64,
    pub beyond_reach: u64,
}

impl HandedOver {
    /// Counts one tile read back into `stats`: its pixels handed over, by why, and its
    /// kernel time.
    pub(super) fn count_tile(self, stats: &mut RenderStats, kernel_ns: Option<u64>) {
        stats.pixels_cut_short += self.loops_cut;
        stats.pixels_beyond_reach += self.beyond_reach;
        stats.kernel_ns = stats.kernel_ns.zip(kernel_ns).map(|(a, b)| a + b);
        stats.tiles += 1;
    }
}
