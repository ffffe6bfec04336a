//! Rows of 8-bit RGB pixels on their way into a file: bytes, or the words a kernel packs
//! them in. The writers reorder either straight into their file's layout (TGA's BGR, PNG's
//! RGB), so a tile read back from the device crosses the host's memory once, not once to
//! RGB and again to the file's order (docs/performance.md, "The file writers").

/// 8-bit RGB pixels, one after another.
#[derive(Clone, Copy, Debug)]
pub enum RgbRows<'a> {
    /// Three bytes a pixel: red, green, blue.
    Bytes(&'a [u8]),
    /// One little-endian word a pixel, `r | g << 8 | b << 16` (the top byte unused).
    Packed(PackedRgb<'a>),
}

/// Pixels packed one to a word, among other words: pixel `p` is `words[p * stride]`.
#[derive(Clone, Copy, Debug)]
pub struct PackedRgb<'a> {
    words: &'a [u32],
    stride: usize,
    pixels: usize,
}

impl<'a> PackedRgb<'a> {
    /// `pixels` pixels, the first `words[0]`, each `stride` words after the one before.
    ///
    /// # Panics
    /// If `stride` is 0 or the last pixel lies beyond `words`.
    pub fn new(words: &'a [u32], stride: usize, pixels: usize) -> PackedRgb<'a> {
        assert!(stride > 0, "a pixel takes at least one word");
        assert!(pixels == 0 || (pixels - 1) * stride < words.len(), "the pixels lie within the words");
        PackedRgb { words, stride, pixels }
    }
}

impl RgbRows<'_> {
    /// How many pixels the rows hold.
    pub fn pixels(&self) -> usize {
        match self {
            RgbRows::Bytes(bytes) => bytes.len() / 3,
            RgbRows::Packed(packed) => packed.pixels,
        }
    }

    /// Pixels `first ..` as bytes red, green, blue, filling `out` (three bytes a pixel).
    pub fn rgb_into(&self, first: usize, out: &mut [u8]) {
        self.convert_into(first, out, [0, 1, 2]);
    }

    /// Pixels `first ..` as bytes blue, green, red (TGA's order), filling `out`.
    pub fn bgr_into(&self, first: usize, out: &mut [u8]) {
        self.convert_into(first, out, [2, 1, 0]);
    }

    /// Every pixel as bytes red, green, blue.
    pub fn to_vec(&self) -> Vec<u8> {
        let mut out = vec![0; 3 * self.pixels()];
        self.rgb_into(0, &mut out);
        out
    }

    /// Pixels `first ..` into `out`, byte `k` of each taken from the pixel's channel
    /// `order[k]` (0 red, 1 green, 2 blue).
    fn convert_into(&self, first: usize, out: &mut [u8], order: [usize; 3]) {
        assert_eq!(out.len() % 3, 0, "three bytes a pixel");
        let count = out.len() / 3;
        assert!(first + count <= self.pixels(), "the pixels lie within the rows");
        match self {
            RgbRows::Bytes(bytes) => {
                let from = bytes[3 * first..3 * (first + count)].as_chunks::<3>().0;
                for (t, f) in out.as_chunks_mut::<3>().0.iter_mut().zip(from) {
                    *t = [f[order[0]], f[order[1]], f[order[2]]];
                }
            }
            RgbRows::Packed(PackedRgb { words, stride: 1, .. }) => {
                packed_into(&words[first..first + count], out, order);
            }
            RgbRows::Packed(PackedRgb { words, stride, .. }) => {
                let from = words[first * stride..].iter().step_by(*stride);
                for (t, w) in out.as_chunks_mut::<3>().0.iter_mut().zip(from) {
                    let c = w.to_le_bytes();
                    *t = [c[order[0]], c[order[1]], c[order[2]]];
                }
            }
        }
    }
}

/// Consecutive packed pixels into three bytes each: four pixels (four words in) make three
/// words out, so that the stores are whole words, not single bytes.
fn packed_into(words: &[u32], out: &mut [u8], order: [usize; 3]) {
    let shift = order.map(|channel| 8 * channel as u32);
    // The pixel's three bytes in `order`, at the bottom of a word.
    let ordered = |w: u32| (w >> shift[0] & 0xff) | (w >> shift[1] & 0xff) << 8 | (w >> shift[2] & 0xff) << 16;
    let (quads, rest) = words.as_chunks::<4>();
    let (out_quads, out_rest) = out.as_chunks_mut::<12>();
    for (t, w) in out_quads.iter_mut().zip(quads) {
        let [p0, p1, p2, p3] = w.map(ordered);
        t[0..4].copy_from_slice(&(p0 | p1 << 24).to_le_bytes());
        t[4..8].copy_from_slice(&(p1 >> 8 | p2 << 16).to_le_bytes());
        t[8..12].copy_from_slice(&(p2 >> 16 | p3 << 8).to_le_bytes());
    }
    for (t, &w) in out_rest.as_chunks_mut::<3>().0.iter_mut().zip(rest) {
        t.copy_from_slice(&ordered(w).to_le_bytes()[..3]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Words whose four bytes all differ, so any byte taken from the wrong place shows.
    fn words(n: usize) -> Vec<u32> {
        (0..n as u32).map(|i| u32::from_le_bytes([i as u8, (i * 7 + 1) as u8, (i * 13 + 2) as u8, 0xee])).collect()
    }

    /// The pixels as bytes, taken one channel at a time from each word by hand.
    fn by_hand(words: &[u32], order: [usize; 3]) -> Vec<u8> {
        words.iter().flat_map(|w| order.map(|c| (w >> (8 * c)) as u8)).collect()
    }

    #[test]
    fn packed_pixels_become_rgb_and_bgr_bytes_at_every_length_and_start() {
        let all = words(23);
        for first in 0..5 {
            // Lengths around the four-pixel groups, so that every remainder is met.
            for count in 0..all.len() - first {
                let rows = RgbRows::Packed(PackedRgb::new(&all, 1, all.len()));
                let mut rgb = vec![0; 3 * count];
                rows.rgb_into(first, &mut rgb);
                assert_eq!(rgb, by_hand(&all[first..first + count], [0, 1, 2]), "rgb from {first}, {count} pixels");
                let mut bgr = vec![0; 3 * count];
                rows.bgr_into(first, &mut bgr);
                assert_eq!(bgr, by_hand(&all[first..first + count], [2, 1, 0]), "bgr from {first}, {count} pixels");
            }
        }
    }

    #[test]
    fn every_stride_th_word_is_a_pixel() {
        let all = words(3 * 9 + 1);
        let mine: Vec<u32> = all.iter().skip(1).step_by(3).copied().collect();
        let rows = RgbRows::Packed(PackedRgb::new(&all[1..], 3, 9));
        assert_eq!(rows.pixels(), 9);
        assert_eq!(rows.to_vec(), by_hand(&mine, [0, 1, 2]));
        let mut bgr = vec![0; 3 * 4];
        rows.bgr_into(5, &mut bgr);
        assert_eq!(bgr, by_hand(&mine[5..], [2, 1, 0]));
    }

    #[test]
    fn bytes_are_copied_or_swapped() {
        let bytes: Vec<u8> = (0..21).collect();
        let rows = RgbRows::Bytes(&bytes);
        assert_eq!(rows.to_vec(), bytes);
        let mut bgr = vec![0; 6];
        rows.bgr_into(2, &mut bgr);
        assert_eq!(bgr, [8, 7, 6, 11, 10, 9]);
    }

    #[test]
    #[should_panic(expected = "the pixels lie within the words")]
    fn packed_pixels_beyond_their_words_are_refused() {
        PackedRgb::new(&[0; 7], 2, 5);
    }
}
