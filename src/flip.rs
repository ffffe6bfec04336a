//! NVIDIA's ꟻLIP (Andersson et al., "FLIP: A Difference Evaluator for Alternating Images",
//! HPG 2020), the LDR version: how visible the difference between two 8-bit sRGB images is
//! to a viewer flipping between them, per pixel, from 0 (none) to 1. `raycaster grade`
//! judges a student's images with it.
//!
//! A port to Rust of NVIDIA's C++ implementation (`FLIP::image<float>::FLIP`, as the
//! `nv-flip` crate builds it), operation for operation in `f32`: the C++ library compiled into
//! the binary would link libstdc++ and need a C++ compiler for every target the students'
//! laptops run (CI checks Windows and macOS builds without one). `tests/flip.rs` holds this
//! port to the C++ one (`nv-flip`, a dev-dependency) on the course's images.
//!
//! The steps: both images to YCxCz (an opponent space); each blurred by the contrast
//! sensitivity of the eye at `ppd` pixels per degree; the blurred colours' HyAB distance in
//! Hunt-adjusted L*a*b*, compressed to [0, 1] (the colour error); edges and points (first
//! and second derivatives of a Gaussian) of the luminance compared (the feature error); the
//! colour error raised to `1 − feature error`.
//!
//! The C++ code carries this notice, kept here for the port:
//!
//! Copyright (c) 2020-2022, NVIDIA CORPORATION & AFFILIATES. All rights reserved.
//!
//! Redistribution and use in source and binary forms, with or without modification, are
//! permitted provided that the following conditions are met:
//! 1. Redistributions of source code must retain the above copyright notice, this list of
//!    conditions and the following disclaimer.
//! 2. Redistributions in binary form must reproduce the above copyright notice, this list
//!    of conditions and the following disclaimer in the documentation and/or other
//!    materials provided with the distribution.
//! 3. Neither the name of the copyright holder nor the names of its contributors may be used
//!    to endorse or promote products derived from this software without specific prior
//!    written permission.
//!
//! THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS" AND ANY
//! EXPRESS OR IMPLIED WARRANTIES, INCLUDING, BUT NOT LIMITED TO, THE IMPLIED WARRANTIES OF
//! MERCHANTABILITY AND FITNESS FOR A PARTICULAR PURPOSE ARE DISCLAIMED. IN NO EVENT SHALL
//! THE COPYRIGHT HOLDER OR CONTRIBUTORS BE LIABLE FOR ANY DIRECT, INDIRECT, INCIDENTAL,
//! SPECIAL, EXEMPLARY, OR CONSEQUENTIAL DAMAGES (INCLUDING, BUT NOT LIMITED TO, PROCUREMENT
//! OF SUBSTITUTE GOODS OR SERVICES; LOSS OF USE, DATA, OR PROFITS; OR BUSINESS INTERRUPTION)
//! HOWEVER CAUSED AND ON ANY THEORY OF LIABILITY, WHETHER IN CONTRACT, STRICT LIABILITY, OR
//! TORT (INCLUDING NEGLIGENCE OR OTHERWISE) ARISING IN ANY WAY OUT OF THE USE OF THIS
//! SOFTWARE, EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.
//!
//! SPDX-FileCopyrightText: Copyright (c) 2020-2022 NVIDIA CORPORATION & AFFILIATES
//! SPDX-License-Identifier: BSD-3-Clause

// The constants are spelled as NVIDIA's source spells them (more digits than an f32 holds),
// so that the two can be read side by side.
#![allow(clippy::excessive_precision)]

mod magma;

use image::RgbImage;
use rayon::prelude::*;
use std::f32::consts::PI;

pub use magma::MAGMA;

/// A 0.7 m wide 4K monitor seen from 0.7 m, ꟻLIP's default viewing condition (and
/// `nv_flip::DEFAULT_PIXELS_PER_DEGREE`).
pub const DEFAULT_PIXELS_PER_DEGREE: f32 = 67.0;

/// The error of each pixel, 0 to 1, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorMap {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

impl ErrorMap {
    /// The mean error: the single number ꟻLIP's authors recommend.
    pub fn mean(&self) -> f64 {
        self.values.iter().map(|&v| v as f64).sum::<f64>() / self.values.len().max(1) as f64
    }

    /// The error that a fraction `p` (0 to 1) of the pixels do not exceed: the nearest rank
    /// of the sorted errors (exact, where `nv-flip`'s pool interpolates in a histogram).
    pub fn percentile(&self, p: f64) -> f32 {
        if self.values.is_empty() {
            return 0.0;
        }
        let mut sorted = self.values.clone();
        sorted.sort_by(f32::total_cmp);
        let rank = (p.clamp(0.0, 1.0) * sorted.len() as f64).ceil() as usize;
        sorted[rank.clamp(1, sorted.len()) - 1]
    }

    /// The map in the magma colours, as ꟻLIP shows it: black where nothing differs, through
    /// purple and orange, to pale yellow at 1.
    pub fn magma(&self) -> RgbImage {
        let mut rgb = Vec::with_capacity(self.values.len() * 3);
        for &v in &self.values {
            // The C++ `colorMap`'s index: ⌊v·255 + ½⌋ (wrapped, which 0 ≤ v ≤ 1 never needs).
            let index = ((v * 255.0 + 0.5) as usize).min(255);
            rgb.extend_from_slice(&MAGMA[index]);
        }
        RgbImage::from_raw(self.width, self.height, rgb).expect("one colour per value")
    }
}

/// ꟻLIP's constants (`FLIPConstants` in the C++ code): the colour error's exponent `qc`,
/// the knee `pc` and the value `pt` it maps to, the feature filter's width `w` in degrees,
/// and the feature error's exponent `qf`.
const GQC: f32 = 0.7;
const GPC: f32 = 0.4;
const GPT: f32 = 0.95;
const GW: f32 = 0.082;
const GQF: f32 = 0.5;

/// The contrast sensitivity functions, sums of Gaussians `a·√(π/b)·exp(−π²x²/b)` per channel
/// (Y, Cx, Cz): `a1, b1` for all three, `a2, b2` only for Cz (`GaussianConstants`).
const A1: [f32; 3] = [1.0, 1.0, 34.1];
const B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const A2: [f32; 3] = [0.0, 0.0, 13.5];
const B2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];

/// The D65 white point and its inverse, as the C++ code spells them.
const ILLUMINANT: [f32; 3] = [0.950428545, 1.0, 1.088900371];
const INV_ILLUMINANT: [f32; 3] = [1.052156925, 1.0, 0.918357670];

type Color = [f32; 3];

/// ꟻLIP's error map of `test` against `reference` at `ppd` pixels per degree of the
/// viewer's eye ([`DEFAULT_PIXELS_PER_DEGREE`] unless you know the screen).
///
/// # Panics
///
/// When the two images differ in size: the caller says how that is judged.
pub fn flip(reference: &RgbImage, test: &RgbImage, ppd: f32) -> ErrorMap {
    assert_eq!(reference.dimensions(), test.dimensions(), "ꟻLIP compares images of one size");
    let (width, height) = reference.dimensions();
    let plane = |image: &RgbImage| Plane { width: width as usize, height: height as usize, pixels: ycxcz(image) };
    let (reference, test) = (plane(reference), plane(test));
    let color = color_difference(&reference, &test, ppd);
    let values = feature_difference_and_final_error(&reference, &test, &color, ppd);
    ErrorMap { width, height, values }
}

/// An image of colours, rows from the top; reads past an edge take the edge's pixel, as the
/// C++ convolutions clamp their coordinates.
struct Plane {
    width: usize,
    height: usize,
    pixels: Vec<Color>,
}

impl Plane {
    fn at(&self, x: isize, y: isize) -> Color {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.pixels[y * self.width + x]
    }
}

fn ycxcz(image: &RgbImage) -> Vec<Color> {
    image
        .pixels()
        .map(|p| {
            let srgb = [0, 1, 2].map(|c| p[c] as f32 / 255.0);
            xyz_to_ycxcz(linear_rgb_to_xyz(srgb.map(srgb_to_linear)))
        })
        .collect()
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn linear_rgb_to_xyz(rgb: Color) -> Color {
    let rows: [[f32; 3]; 3] = [
        [10135552.0 / 24577794.0, 8788810.0 / 24577794.0, 4435075.0 / 24577794.0],
        [2613072.0 / 12288897.0, 8788810.0 / 12288897.0, 887015.0 / 12288897.0],
        [1425312.0 / 73733382.0, 8788810.0 / 73733382.0, 70074185.0 / 73733382.0],
    ];
    rows.map(|r| r[0] * rgb[0] + r[1] * rgb[1] + r[2] * rgb[2])
}

fn xyz_to_linear_rgb(xyz: Color) -> Color {
    let rows: [[f32; 3]; 3] = [
        [3.241003275, -1.537398934, -0.498615861],
        [-0.969224334, 1.875930071, 0.041554224],
        [0.055639423, -0.204011202, 1.057148933],
    ];
    rows.map(|r| r[0] * xyz[0] + r[1] * xyz[1] + r[2] * xyz[2])
}

fn xyz_to_ycxcz(xyz: Color) -> Color {
    let [x, y, z] = [0, 1, 2].map(|c| xyz[c] * INV_ILLUMINANT[c]);
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn ycxcz_to_xyz(ycxcz: Color) -> Color {
    let y = (ycxcz[0] + 16.0) / 116.0;
    let cx = ycxcz[1] / 500.0;
    let cz = ycxcz[2] / 200.0;
    [(y + cx) * ILLUMINANT[0], y * ILLUMINANT[1], (y - cz) * ILLUMINANT[2]]
}

fn xyz_to_lab(xyz: Color) -> Color {
    let delta = 6.0f32 / 29.0;
    let delta_square = delta * delta;
    let delta_cube = delta * delta_square;
    let factor = 1.0 / (3.0 * delta_square);
    let term = 4.0f32 / 29.0;
    let [x, y, z] = [0, 1, 2].map(|c| xyz[c] * INV_ILLUMINANT[c]).map(|v| {
        if v > delta_cube {
            v.powf(1.0 / 3.0)
        } else {
            factor * v + term
        }
    });
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

/// L*a*b* with a* and b* scaled by lightness (the Hunt effect: colours look less colourful
/// in the dark).
fn hunt(lab: Color) -> Color {
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

/// The HyAB distance: city-block in lightness, Euclidean in the chromatic plane.
fn hyab(a: Color, b: Color) -> f32 {
    (a[0] - b[0]).abs() + ((a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])).sqrt()
}

/// The largest colour distance the compression maps to 1: green against blue.
fn max_distance() -> f32 {
    let lab = |rgb: Color| hunt(xyz_to_lab(linear_rgb_to_xyz(rgb)));
    hyab(lab([0.0, 1.0, 0.0]), lab([0.0, 0.0, 1.0])).powf(GQC)
}

/// `a·√(π/b)·exp(−π²x²/b)` (`Gaussian(x2, a, b)`).
fn csf_gaussian(x2: f32, a: f32, b: f32) -> f32 {
    a * (PI / b).sqrt() * (-(PI * PI) * x2 / b).exp()
}

/// The square root of the weight, so that two separable passes multiply back to it
/// (`GaussianSqrt`): the Cz filter is a sum of two Gaussians, which separates only so.
fn csf_gaussian_sqrt(x2: f32, a: f32, b: f32) -> f32 {
    (a * (PI / b).sqrt()).sqrt() * (-(PI * PI) * x2 / b).exp()
}

/// The spatial filters' radius in pixels: three standard deviations of the widest Gaussian.
fn spatial_radius(ppd: f32) -> isize {
    let widest = B1.into_iter().chain(B2).fold(f32::MIN, f32::max);
    (3.0 * (widest / (2.0 * PI * PI)).sqrt() * ppd).ceil() as isize
}

/// The separable spatial filters (`setSpatialFilters`): `[Y, Cx]` weights, and the two
/// halves of the Cz filter; each tap's weights.
fn spatial_filters(ppd: f32, radius: isize) -> (Vec<[f32; 2]>, Vec<[f32; 2]>) {
    let delta = 1.0 / ppd;
    let (mut ycx, mut cz) = (Vec::new(), Vec::new());
    let (mut sum_ycx, mut sum_cz) = ([0.0f32; 2], [0.0f32; 2]);
    for k in -radius..=radius {
        let ix = k as f32 * delta;
        let x2 = ix * ix;
        let w_ycx = [csf_gaussian(x2, A1[0], B1[0]), csf_gaussian(x2, A1[1], B1[1])];
        let w_cz = [csf_gaussian_sqrt(x2, A1[2], B1[2]), csf_gaussian_sqrt(x2, A2[2], B2[2])];
        sum_ycx = [sum_ycx[0] + w_ycx[0], sum_ycx[1] + w_ycx[1]];
        sum_cz = [sum_cz[0] + w_cz[0], sum_cz[1] + w_cz[1]];
        ycx.push(w_ycx);
        cz.push(w_cz);
    }
    let norm_ycx = [1.0 / sum_ycx[0], 1.0 / sum_ycx[1]];
    let norm_cz = 1.0 / (sum_cz[0] * sum_cz[0] + sum_cz[1] * sum_cz[1]).sqrt();
    let ycx = ycx.into_iter().map(|w| [w[0] * norm_ycx[0], w[1] * norm_ycx[1]]).collect();
    let cz = cz.into_iter().map(|w| [w[0] * norm_cz, w[1] * norm_cz]).collect();
    (ycx, cz)
}

/// Runs `pixel(x, y)` for every pixel, rows in parallel.
fn per_pixel<T: Send>(width: usize, height: usize, pixel: impl Fn(usize, usize) -> T + Sync) -> Vec<T> {
    (0..height).into_par_iter().flat_map_iter(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| pixel(x, y)).collect()
}

/// The colour error of each pixel (`computeColorDifference`): both images blurred by the
/// spatial filters, back to linear RGB (clamped), to Hunt-adjusted L*a*b*, their HyAB
/// distance compressed to [0, 1].
fn color_difference(reference: &Plane, test: &Plane, ppd: f32) -> Vec<f32> {
    let radius = spatial_radius(ppd);
    let (ycx, cz) = spatial_filters(ppd, radius);
    let (w, h) = (reference.width, reference.height);
    // Along rows: [Y·wY, Cx·wCx, Cz·wCz1, Cz·wCz2] of each image.
    let along_x = |plane: &Plane| {
        along_rows(plane, radius, |t, c| [ycx[t][0] * c[0], ycx[t][1] * c[1], cz[t][0] * c[2], cz[t][1] * c[2]])
    };
    let (ref_x, test_x) = (along_x(reference), along_x(test));
    let cmax = max_distance();
    let pccmax = GPC * cmax;
    per_pixel(w, h, |x, y| {
        let down = |plane: &Plane4| {
            let mut sum = [0.0f32; 4];
            for (k, (wy, wz)) in (-radius..=radius).zip(ycx.iter().zip(&cz)) {
                let c = plane.at(x, y as isize + k);
                sum = [sum[0] + wy[0] * c[0], sum[1] + wy[1] * c[1], sum[2] + wz[0] * c[2], sum[3] + wz[1] * c[3]];
            }
            let filtered = [sum[0], sum[1], sum[2] + sum[3]];
            let rgb = xyz_to_linear_rgb(ycxcz_to_xyz(filtered)).map(|v| v.clamp(0.0, 1.0));
            hunt(xyz_to_lab(linear_rgb_to_xyz(rgb)))
        };
        let difference = hyab(down(&ref_x), down(&test_x)).powf(GQC);
        // Errors below pc·cmax take [0, pt]; the rest the short range (pt, 1].
        if difference < pccmax {
            difference * (GPT / pccmax)
        } else {
            GPT + ((difference - pccmax) / (cmax - pccmax)) * (1.0 - GPT)
        }
    })
}

/// The first pass of a separable filter of `radius` over `plane`: at each pixel, the sum over
/// the taps `t` of `weigh(t, the colour t − radius pixels along the row)`, in the taps' order
/// (as the C++ code adds them).
fn along_rows(plane: &Plane, radius: isize, weigh: impl Fn(usize, Color) -> [f32; 4] + Sync) -> Plane4 {
    let (w, h) = (plane.width, plane.height);
    let pixels = per_pixel(w, h, |x, y| {
        let mut sum = [0.0f32; 4];
        for (t, k) in (-radius..=radius).enumerate() {
            let term = weigh(t, plane.at(x as isize + k, y as isize));
            sum = [sum[0] + term[0], sum[1] + term[1], sum[2] + term[2], sum[3] + term[3]];
        }
        sum
    });
    Plane4 { width: w, height: h, pixels }
}

/// Four values per pixel: the first pass of a separable filter.
struct Plane4 {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 4]>,
}

impl Plane4 {
    fn at(&self, x: usize, y: isize) -> [f32; 4] {
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.pixels[y * self.width + x]
    }
}

/// The feature filter's taps (`setFeatureFilter`): a Gaussian of σ = ½·w·ppd pixels
/// (summing to 1), its first derivative (positive and negative weights each summing to
/// ±1) and its second (likewise).
fn feature_filter(ppd: f32) -> (isize, Vec<[f32; 3]>) {
    let sigma = 0.5 * GW * ppd;
    let radius = (3.0 * sigma).ceil() as isize;
    let taps: Vec<[f32; 3]> = (-radius..=radius)
        .map(|k| {
            let x = k as f32;
            let g = (-(x * x) / (2.0 * sigma * sigma)).exp();
            [g, -x * g, (x * x / (sigma * sigma) - 1.0) * g]
        })
        .collect();
    let sum = |c: usize, positive: bool| -> f32 {
        taps.iter().map(|t| t[c]).filter(|&v| if positive { v > 0.0 } else { v <= 0.0 }).map(f32::abs).sum()
    };
    let g_sum: f32 = taps.iter().map(|t| t[0]).sum();
    let (dg_pos, dg_neg, ddg_pos, ddg_neg) = (sum(1, true), sum(1, false), sum(2, true), sum(2, false));
    let taps = taps
        .into_iter()
        .map(|[g, dg, ddg]| {
            [g / g_sum, dg / if dg > 0.0 { dg_pos } else { dg_neg }, ddg / if ddg > 0.0 { ddg_pos } else { ddg_neg }]
        })
        .collect();
    (radius, taps)
}

/// The final error (`computeFeatureDifferenceAndFinalError`): edges (gradient length) and
/// points (second-derivative length) of the luminance, normalised to [0, 1], compared; the
/// colour error raised to `1 − feature error`, so a changed edge or point weighs more.
fn feature_difference_and_final_error(reference: &Plane, test: &Plane, color: &[f32], ppd: f32) -> Vec<f32> {
    let (radius, taps) = feature_filter(ppd);
    let (w, h) = (reference.width, reference.height);
    // Along rows: [first derivative, second derivative, Gaussian] of the normalised Y.
    let along_x = |plane: &Plane| {
        along_rows(plane, radius, |t, c| {
            let luminance = c[0] * (1.0 / 116.0) + 16.0 / 116.0;
            [taps[t][1] * luminance, taps[t][2] * luminance, taps[t][0] * luminance, 0.0]
        })
    };
    let (ref_x, test_x) = (along_x(reference), along_x(test));
    per_pixel(w, h, |x, y| {
        // Down the columns: (edge, point) strength.
        let features = |plane: &Plane4| {
            let [mut dx, mut ddx, mut dy, mut ddy] = [0.0f32; 4];
            for (k, t) in (-radius..=radius).zip(&taps) {
                let c = plane.at(x, y as isize + k);
                dx += t[0] * c[0];
                ddx += t[0] * c[1];
                dy += t[1] * c[2];
                ddy += t[2] * c[2];
            }
            ((dx * dx + dy * dy).sqrt(), (ddx * ddx + ddy * ddy).sqrt())
        };
        let (edge_ref, point_ref) = features(&ref_x);
        let (edge_test, point_test) = features(&test_x);
        let difference = (edge_ref - edge_test).abs().max((point_ref - point_test).abs());
        let feature = ((1.0 / 2.0f32.sqrt()) * difference).powf(GQF);
        color[y * w + x].powf(1.0 - feature)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn filled(width: u32, height: u32, rgb: [u8; 3]) -> RgbImage {
        RgbImage::from_pixel(width, height, image::Rgb(rgb))
    }

    /// An image against itself has no error anywhere.
    #[test]
    fn identical_images_have_no_error() {
        let mut image = filled(20, 12, [30, 120, 200]);
        image.put_pixel(5, 5, image::Rgb([255, 0, 0]));
        let map = flip(&image, &image, DEFAULT_PIXELS_PER_DEGREE);
        assert_eq!((map.width, map.height, map.values.len()), (20, 12, 240));
        assert!(map.values.iter().all(|&v| v == 0.0), "{:?}", map.values);
    }

    /// Green against blue is the largest colour difference: the whole error range.
    #[test]
    fn green_against_blue_is_the_largest_error() {
        let map = flip(&filled(16, 16, [0, 255, 0]), &filled(16, 16, [0, 0, 255]), DEFAULT_PIXELS_PER_DEGREE);
        assert!(map.values.iter().all(|&v| (v - 1.0).abs() < 1e-4), "{:?}", &map.values[..4]);
        // Mid-grey one level brighter everywhere: a small error (0.0299; NVIDIA's code gives
        // the same, tests/flip.rs), a thirtieth of green against blue.
        let map = flip(&filled(16, 16, [128; 3]), &filled(16, 16, [129; 3]), DEFAULT_PIXELS_PER_DEGREE);
        assert!(map.mean() > 0.02 && map.mean() < 0.04, "{}", map.mean());
    }

    #[test]
    fn percentiles_are_nearest_ranks() {
        let map = ErrorMap { width: 10, height: 1, values: (1..=10).map(|k| k as f32 / 10.0).collect() };
        assert_eq!(map.percentile(0.99), 1.0);
        assert_eq!(map.percentile(0.5), 0.5);
        assert_eq!(map.percentile(0.0), 0.1);
        assert!((map.mean() - 0.55).abs() < 1e-6);
    }

    #[test]
    fn the_magma_map_runs_from_black_to_pale_yellow() {
        let map = ErrorMap { width: 2, height: 1, values: vec![0.0, 1.0] };
        let rgb = map.magma();
        assert_eq!(rgb.get_pixel(0, 0).0, MAGMA[0]);
        assert_eq!(rgb.get_pixel(1, 0).0, MAGMA[255]);
        assert!(MAGMA[0].iter().all(|&c| c < 8) && MAGMA[255].iter().all(|&c| c > 180));
    }
}
