//! The tile loops of a prepared scene. Natively the slots of per-tile buffers (two unless
//! `GpuOptions::tile_slots` says otherwise) take turns: a thread of ours submits a tile into
//! every free slot and waits for the oldest while the caller's thread decodes and writes the
//! tile before, so the host's share of the work overlaps the device's instead of following
//! it. In a browser, which has neither the thread nor a blocking wait,
//! [`PreparedScene::render_async`] renders the tiles one after another and awaits each.

use super::error::GpuError;
use super::handover::RenderAgain;
use super::prepared::PreparedScene;
use super::readback::{map_async, ReadTile};
use crate::render::row_tiles;
use crate::render::RenderStats;
#[cfg(not(target_arch = "wasm32"))]
use std::sync::atomic::Ordering;
#[cfg(not(target_arch = "wasm32"))]
use {super::renderer::GpuRenderer, crate::render::Frame, crate::render::RenderOptions, crate::scene::Scene};

impl PreparedScene<'_> {
    /// Renders every tile, top first, handing each to `on_tile` on the calling thread.
    /// (Not in a browser, which has neither threads nor blocking waits: there
    /// [`PreparedScene::render_async`].)
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render<E: From<GpuError>>(&self, on_tile: impl FnMut(&ReadTile) -> Result<(), E>) -> Result<RenderStats, E> {
        self.render_band(0, self.dispatch.options.height, on_tile)
    }

    /// As [`PreparedScene::render`], for image rows `first .. first + rows` only (a band of
    /// a render split across machines); tiles still carry image row numbers.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn render_band<E: From<GpuError>>(
        &self,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(&ReadTile) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        assert!(first + rows <= self.dispatch.options.height, "the band lies inside the image");
        let tiles: Vec<(u32, u32)> =
            row_tiles(rows, self.dispatch.tile_rows).map(|(offset, n)| (first + offset, n)).collect();
        let mut stats = self.stats;
        let counted = self.counters.zero(self.dispatch.gpu);
        let again = self.render_again();
        let lists_before = self.dispatch.lists_ns.load(Ordering::Relaxed);
        let mut waited = std::time::Duration::ZERO;
        std::thread::scope(|scope| {
            use std::sync::mpsc::sync_channel;
            let (ready_tx, ready_rx) = sync_channel(self.dispatch.slots.len());
            let (free_tx, free_rx) = sync_channel::<usize>(self.dispatch.slots.len());
            for k in 0..self.dispatch.slots.len() {
                free_tx.send(k).expect("the receiver is alive");
            }
            let submitter = tiles.clone();
            scope.spawn(move || {
                let mut next = submitter.into_iter().peekable();
                let mut in_flight = std::collections::VecDeque::new();
                loop {
                    // Every free slot gets the next tile at once, so that the device renders
                    // one tile while this thread waits for the one before; a slot is waited
                    // for only when no tile is in flight. The caller stopped (an error, or
                    // all tiles done): nothing more to submit.
                    while next.peek().is_some() {
                        let free = if in_flight.is_empty() { free_rx.recv().ok() } else { free_rx.try_recv().ok() };
                        let Some(slot) = free else { break };
                        let (first_row, rows) = next.next().expect("peeked");
                        in_flight.push_back((slot, first_row, rows, self.dispatch.submit_tile(slot, first_row, rows)));
                    }
                    let Some((slot, first_row, rows, submission)) = in_flight.pop_front() else { return };
                    let result = self.dispatch.wait_tile(slot, rows, submission);
                    let failed = result.is_err();
                    if ready_tx.send(result.map(|ns| (slot, first_row, rows, ns))).is_err() || failed {
                        return;
                    }
                }
            });
            for _ in &tiles {
                let waiting = std::time::Instant::now();
                let ready = ready_rx.recv();
                waited += waiting.elapsed();
                let (slot, first_row, rows, kernel_ns) = ready.map_err(|e| GpuError::Readback(e.to_string()))??;
                let readable = self.dispatch.slots[slot].buffers.readable();
                let handed =
                    again.show_tile(readable, self.dispatch.tile_bytes(rows), (first_row, rows), &mut on_tile)?;
                handed.count_tile(&mut stats, kernel_ns);
                // The submitter may already have finished; then nobody needs the slot back.
                let _ = free_tx.send(slot);
            }
            Ok::<(), E>(())
        })?;
        stats.waited_ms = waited.as_secs_f64() * 1e3;
        stats.lists_ms = (self.dispatch.lists_ns.load(Ordering::Relaxed) - lists_before) as f64 / 1e6;
        if let Some(counted) = counted {
            stats.counted = Some(again.add_counts(counted, self.counters.read(self.dispatch.gpu)?));
        }
        Ok(stats)
    }

    /// As [`PreparedScene::render`], the tiles one after another on the calling task, each
    /// read back by awaiting its map: the path for a browser, where a map resolves only once
    /// control returns to the page's event loop and no thread can wait for it. The pixels
    /// the kernel hands over are rendered again by the reference, as in
    /// [`PreparedScene::render_band`].
    pub async fn render_async<E: From<GpuError>>(
        &self,
        mut on_tile: impl FnMut(&ReadTile) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let mut stats = self.stats;
        let counted = self.counters.zero(self.dispatch.gpu);
        let again = self.render_again();
        for (first_row, rows) in row_tiles(self.dispatch.options.height, self.dispatch.tile_rows) {
            let submission = self.dispatch.submit_tile(0, first_row, rows);
            let slot = &self.dispatch.slots[0].buffers;
            let bytes = self.dispatch.tile_bytes(rows);
            map_async(&self.dispatch.gpu.device, &slot.readable().slice(..bytes), submission.clone()).await?;
            let kernel_ns = match &slot.timer {
                Some(timer) => Some(timer.elapsed_ns_async(self.dispatch.gpu, submission).await?),
                None => None,
            };
            let handed = again.show_tile(slot.readable(), bytes, (first_row, rows), &mut on_tile)?;
            handed.count_tile(&mut stats, kernel_ns);
        }
        if let Some(counted) = counted {
            stats.counted = Some(again.add_counts(counted, self.counters.read_async(self.dispatch.gpu).await?));
        }
        Ok(stats)
    }

    /// The hand-over of one render (a whole image or a band): the references it builds
    /// render again what the kernel handed over.
    fn render_again(&self) -> RenderAgain<'_> {
        RenderAgain::new(self.fallback.as_ref(), &self.dispatch.options, self.dispatch.layout)
    }
}

#[cfg(not(target_arch = "wasm32"))]
impl GpuRenderer {
    /// Renders `scene` into float buffers; see [`crate::image_io`] for images.
    pub fn render(&self, scene: &Scene, options: &RenderOptions) -> Result<Frame, GpuError> {
        let mut frame = Frame::new(options);
        self.render_into(scene, options, &mut frame, || Ok::<(), GpuError>(()))?;
        Ok(frame)
    }

    /// Renders `scene` into `frame`, a whole image's float buffers, each tile decoded straight
    /// into its rows; `after_tile`'s error stops the render there and is returned.
    pub fn render_into<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        frame: &mut Frame,
        mut after_tile: impl FnMut() -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        self.prepare(scene, options, false)?.render(|tile| {
            tile.decode_into(frame);
            after_tile()
        })
    }

    /// Renders `scene` in tiles of full rows, top first, handing each to `on_tile` with its
    /// first image row as soon as it is read back: memory is bounded by the tile.
    pub fn render_tiles<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        self.render_band(scene, options, 0, options.height, on_tile)
    }

    /// As [`GpuRenderer::render_tiles`], for image rows `first .. first + rows` only (a band
    /// of a render split across machines); tiles still carry image row numbers.
    pub fn render_band<E: From<GpuError>>(
        &self,
        scene: &Scene,
        options: &RenderOptions,
        first: u32,
        rows: u32,
        mut on_tile: impl FnMut(u32, Frame) -> Result<(), E>,
    ) -> Result<RenderStats, E> {
        let prepared = self.prepare(scene, options, false)?;
        prepared.render_band(first, rows, |tile| on_tile(tile.first_row, tile.to_frame()))
    }
}
