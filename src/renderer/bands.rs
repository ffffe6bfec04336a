//! A render in bands of rows, tile by tile: the reference's own, and the GPU's with the
//! reference taking over where `auto` lets it ([`Fallback::Reference`]).

use super::{fallback_notice, Fallback};
use crate::cpu::Reference;
use crate::gpu::GpuError;
use crate::render::{row_tiles, Frame, RenderOptions, RenderStats};
use crate::scene::Scene;

/// About how many pixels the CPU reference renders per tile: enough rows to keep every core
/// busy, few enough to bound memory and to move a progress bar every second or so.
const CPU_TILE_PIXELS: u32 = 1 << 18;

/// The GPU's render, or with [`Fallback::Reference`] and a scene the GPU refuses
/// ([`fallback_notice`]), the reference's, with the notice. The GPU refuses before its first
/// tile, so nothing has reached `on_tile` yet and the reference starts from the top.
pub(super) fn or_reference<T, E: From<GpuError>>(
    fallback: Fallback,
    on_tile: &mut T,
    gpu: impl FnOnce(&mut T) -> Result<RenderStats, Attempt<E>>,
    reference: impl FnOnce(&mut T) -> Result<RenderStats, E>,
) -> Result<(RenderStats, Option<String>), E> {
    match gpu(on_tile) {
        Ok(stats) => Ok((stats, None)),
        Err(Attempt::Tile(e)) => Err(e),
        Err(Attempt::Gpu(e)) => match fallback_notice(&e).filter(|_| fallback == Fallback::Reference) {
            Some(notice) => Ok((reference(on_tile)?, Some(notice))),
            None => Err(e.into()),
        },
    }
}

/// A GPU render's failure, told apart from the caller's own.
pub(super) enum Attempt<E> {
    Gpu(GpuError),
    Tile(E),
}

impl<E> From<GpuError> for Attempt<E> {
    fn from(e: GpuError) -> Self {
        Attempt::Gpu(e)
    }
}

/// The f64 reference over image rows `first .. first + rows`, in tiles.
pub(super) fn reference_band<E>(
    scene: &Scene,
    options: &RenderOptions,
    (first, rows): (u32, u32),
    mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
) -> Result<RenderStats, E> {
    let reference = Reference::new(scene, options);
    let mut stats = RenderStats::default();
    // Samples are kept until the tile is filtered: fewer rows per tile the more there are.
    let samples = options.sampling.map_or(1, |s| s.count());
    for (offset, rows) in row_tiles(rows, CPU_TILE_PIXELS / options.width / samples) {
        let first_row = first + offset;
        on_tile(first_row, reference.rows(first_row, rows))?;
        stats.tiles += 1;
    }
    stats.counted = Some(reference.stats());
    stats.grid_bounds = reference.grid().map(|g| g.grid.bounds).filter(|b| !b.is_empty());
    Ok(stats)
}
