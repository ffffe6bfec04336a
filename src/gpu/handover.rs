//! Hand-over: the pixels the kernel marks for the reference (its driver cut their loops
//! short, [`KernelConfig::loop_canary`](super::KernelConfig::loop_canary); or beyond the f32
//! kernel's reach: a texture blended beyond its reach there, [`super::texture_range`], or
//! a reflected or refracted ray leaving its surface grazing it), rendered again by the f64
//! reference before the caller sees the tile.

use super::error::GpuError;
use super::layout::{Handover, PixelLayout};
use super::readback::ReadTile;
use super::stats::HandedOver;
use crate::cpu::Reference;
use crate::render::{RayStats, RenderOptions};
use crate::scene::Scene;
use std::cell::OnceCell;

/// The references that render handed-over pixels again, each built once per band, when
/// its first pixel comes (with `-grid`, building one builds the grid): one for the pixels
/// cut short, whose counts `-stats` adds, one for those beyond the kernel's reach.
pub(super) struct RenderAgain<'s> {
    /// The scene, where the kernel may hand pixels over; `None` where it never does.
    scene: Option<&'s Scene>,
    options: &'s RenderOptions,
    layout: PixelLayout,
    cut_short: OnceCell<Reference<'s>>,
    beyond_reach: OnceCell<Reference<'s>>,
}

impl<'s> RenderAgain<'s> {
    pub fn new(scene: Option<&'s Scene>, options: &'s RenderOptions, layout: PixelLayout) -> RenderAgain<'s> {
        RenderAgain { scene, options, layout, cut_short: OnceCell::new(), beyond_reach: OnceCell::new() }
    }

    /// Shows the caller the tile of `rows` rows from `first_row` mapped in `readable`
    /// (`bytes` of it), its pixels handed over rendered again by the reference, then gives
    /// the buffer back to the device; returns how many were, by why.
    pub fn show_tile<E: From<GpuError>>(
        &self,
        readable: &wgpu::Buffer,
        bytes: u64,
        (first_row, rows): (u32, u32),
        on_tile: &mut impl FnMut(&ReadTile) -> Result<(), E>,
    ) -> Result<HandedOver, E> {
        let range = readable.slice(..bytes);
        let mut handed = HandedOver::default();
        let result = {
            let view = range.get_mapped_range().map_err(|e| GpuError::Readback(e.to_string()))?;
            let mapped: &[u32] = bytemuck::cast_slice(&view);
            let patched = self.scene.and_then(|scene| self.rerender_handed_over(scene, first_row, mapped));
            if let Some((_, counts)) = &patched {
                handed = *counts;
            }
            let words = patched.as_ref().map_or(mapped, |(words, _)| &words[..]);
            on_tile(&ReadTile {
                first_row,
                rows,
                width: self.options.width,
                layout: self.layout,
                options: self.options,
                words,
            })
        };
        readable.unmap();
        result.map(|()| handed)
    }

    /// The tile's words with every pixel the kernel handed over replaced by the
    /// reference's, and how many those were, by why; `None` when none was.
    fn rerender_handed_over(&self, scene: &'s Scene, first_row: u32, words: &[u32]) -> Option<(Vec<u32>, HandedOver)> {
        if !self.layout.hands_over_any(words) {
            return None;
        }
        let stride = self.layout.words() as usize;
        let width = self.options.width as usize;
        let (mut cut, mut beyond) = (Vec::new(), Vec::new());
        for k in 0..words.len() / stride {
            match self.layout.handover(&words[k * stride..]) {
                Some(Handover::LoopsCut) => cut.push(k),
                Some(Handover::BeyondReach) => beyond.push(k),
                None => {}
            }
        }
        if cut.is_empty() && beyond.is_empty() {
            return None;
        }
        let mut out = words.to_vec();
        let render_again = |reference: &OnceCell<Reference<'s>>, marked: &[usize], out: &mut [u32]| {
            if marked.is_empty() {
                return;
            }
            let pixels: Vec<(u32, u32)> =
                marked.iter().map(|&k| ((k % width) as u32, first_row + (k / width) as u32)).collect();
            let rendered = reference.get_or_init(|| Reference::new(scene, self.options)).pixels(&pixels);
            for (n, &k) in marked.iter().enumerate() {
                self.layout.encode(&rendered.pixel(n), &mut out[k * stride..(k + 1) * stride]);
            }
        };
        render_again(&self.cut_short, &cut, &mut out);
        render_again(&self.beyond_reach, &beyond, &mut out);
        Some((out, HandedOver { loops_cut: cut.len() as u64, beyond_reach: beyond.len() as u64 }))
    }

    /// `-stats` of a whole render: what the kernel counted, and the reference's counts
    /// for the pixels cut short. The kernel counted the pixels beyond a texture's reach
    /// itself, having traced them to the end, and not those cut short.
    pub fn add_counts(&self, mut counted: RayStats, kernel: RayStats) -> RayStats {
        counted.add(&kernel);
        if let Some(reference) = self.cut_short.get() {
            counted.add(&reference.stats());
        }
        counted
    }
}
