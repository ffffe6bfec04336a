//! Supersampling and filters (the course's assignment 7; docs/SPEC.md §8): where a pixel's
//! samples lie, and how the samples of a pixel and its neighbours make its value.
//!
//! Sample positions are pixel-local, in [0, 1)², x to the right and y **up** (the camera's
//! j runs from the bottom, docs/SPEC.md §3). Random and jittered positions come from a
//! counter-based hash of (pixel, sample, seed), the same function in the reference (here)
//! and in the kernel (`shaders/sampling.wgsl`), so a render is reproducible from its seed
//! and both backends cast the very same rays.

/// How the samples of a pixel are placed (`-random_samples`, `-uniform_samples`,
/// `-jittered_samples`); the number is the samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampler {
    Random(u32),
    /// A √n × √n grid of cell centres (n a perfect square).
    Uniform(u32),
    /// A √n × √n grid of cells, one hashed position in each (n a perfect square).
    Jittered(u32),
}

/// How samples become a pixel (`-box_filter`, `-tent_filter`, `-gaussian_filter`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// Weight 1 where |dx| ≤ r and |dy| ≤ r, else 0.
    Box(f64),
    /// A cone: `max(0, 1 − d/r)`, d the Euclidean distance.
    Tent(f64),
    /// `exp(−d²/2σ²)`, not cut at 2σ: the support radius (reaching 2σ) crops it by pixels,
    /// as the course's picture `filter7_01f` shows (its corners, past 2σ, are not black).
    Gaussian(f64),
}

/// A render's sampling: the sampler, the filter and the seed of the hashed positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    pub sampler: Sampler,
    pub filter: Filter,
    pub seed: u32,
}

/// Samples per pixel the command line accepts (a 36-sample render of the largest image is
/// already 10¹⁰ rays; a typo of 10⁶ would never end).
pub const MAX_SAMPLES: u32 = 1024;

/// The default filter of a sampler given without one: the box of radius ½, the plain
/// average of the pixel's own samples.
pub const DEFAULT_FILTER: Filter = Filter::Box(0.5);

impl Sampler {
    /// Samples per pixel.
    pub fn count(self) -> u32 {
        match self {
            Sampler::Random(n) | Sampler::Uniform(n) | Sampler::Jittered(n) => n,
        }
    }

    /// The grid side √n of the regular patterns (1 for the random one, which has none).
    pub fn side(self) -> u32 {
        match self {
            Sampler::Random(_) => 1,
            Sampler::Uniform(n) | Sampler::Jittered(n) => n.isqrt(),
        }
    }

    /// The kernel's `SAMPLER` override value.
    pub fn kind(self) -> u32 {
        match self {
            Sampler::Uniform(_) => 0,
            Sampler::Random(_) => 1,
            Sampler::Jittered(_) => 2,
        }
    }

    /// The course's flag.
    pub fn flag(self) -> &'static str {
        match self {
            Sampler::Random(_) => "-random_samples",
            Sampler::Uniform(_) => "-uniform_samples",
            Sampler::Jittered(_) => "-jittered_samples",
        }
    }

    /// Position of sample `k` of pixel (i from the left, j from the bottom), pixel-local in
    /// [0, 1)², y up (docs/SPEC.md §8). Samples are ordered row by row of their grid from the
    /// bottom: k = b·m + a with column a and row b of an m × m grid.
    pub fn position(self, i: u32, j: u32, k: u32, seed: u32) -> (f64, f64) {
        match self {
            Sampler::Uniform(_) => {
                let m = self.side();
                let (a, b) = (k % m, k / m);
                ((a as f64 + 0.5) / m as f64, (b as f64 + 0.5) / m as f64)
            }
            Sampler::Random(_) => {
                let (u, v) = hash_pair(i, j, k, seed);
                (unit(u), unit(v))
            }
            Sampler::Jittered(_) => {
                let m = self.side();
                let (a, b) = (k % m, k / m);
                let (u, v) = hash_pair(i, j, k, seed);
                ((a as f64 + unit(u)) / m as f64, (b as f64 + unit(v)) / m as f64)
            }
        }
    }
}

/// PCG's output hash of one word (Jarzynski & Olano, "Hash Functions for GPU Rendering",
/// JCGT 2020, `pcg`): a permutation of u32, well mixed in every bit.
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The two hashed words of sample `k` of pixel (i, j) under `seed`: chained `pcg`, each
/// input added to the hash of the ones before (docs/SPEC.md §8).
pub fn hash_pair(i: u32, j: u32, k: u32, seed: u32) -> (u32, u32) {
    let h = pcg(pcg(pcg(pcg(seed).wrapping_add(i)).wrapping_add(j)).wrapping_add(k));
    (h, pcg(h))
}

/// A hashed word as a number in [0, 1): its top 24 bits times 2⁻²⁴, exact in f32 and f64.
pub fn unit(u: u32) -> f64 {
    (u >> 8) as f64 * (1.0 / 16_777_216.0)
}

impl Filter {
    /// Weight of a sample at (dx, dy) pixels from the output pixel's centre. Not
    /// normalised: pixels divide by the sum of their weights.
    pub fn weight(self, dx: f64, dy: f64) -> f64 {
        match self {
            Filter::Box(r) => {
                if dx.abs() <= r && dy.abs() <= r {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent(r) => (1.0 - (dx * dx + dy * dy).sqrt() / r).max(0.0),
            Filter::Gaussian(sigma) => (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp(),
        }
    }

    /// The course's `getSupportRadius`: the pixels i ± R, j ± R whose samples can weigh,
    /// the least R such that every sample with a weight lies in them: a sample of pixel
    /// i + R lies up to R + ½ from the centre, so R = ⌈extent − ½⌉ (at least 0), with
    /// extent r for the box and the tent and 2σ for the gaussian.
    pub fn support_radius(self) -> u32 {
        let extent = match self {
            Filter::Box(r) | Filter::Tent(r) => r,
            Filter::Gaussian(sigma) => 2.0 * sigma,
        };
        (extent - 0.5).ceil().max(0.0) as u32
    }

    /// The course's flag.
    pub fn flag(self) -> &'static str {
        match self {
            Filter::Box(_) => "-box_filter",
            Filter::Tent(_) => "-tent_filter",
            Filter::Gaussian(_) => "-gaussian_filter",
        }
    }

    /// The kernel's `FILTER` override value.
    pub fn kind(self) -> u32 {
        match self {
            Filter::Box(_) => 0,
            Filter::Tent(_) => 1,
            Filter::Gaussian(_) => 2,
        }
    }

    /// The filter's parameter: the radius, or σ.
    pub fn parameter(self) -> f64 {
        match self {
            Filter::Box(r) | Filter::Tent(r) | Filter::Gaussian(r) => r,
        }
    }
}

impl Sampling {
    /// Samples per pixel.
    pub fn count(&self) -> u32 {
        self.sampler.count()
    }

    /// The filter's support radius in pixels.
    pub fn radius(&self) -> u32 {
        self.filter.support_radius()
    }

    /// Position of sample `k` of pixel (i, j), pixel-local.
    pub fn position(&self, i: u32, j: u32, k: u32) -> (f64, f64) {
        self.sampler.position(i, j, k, self.seed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over a dense grid of the plane, each filter's weights, normalised by their sum,
    /// integrate to one; the raw integral is the filter's area (box 4r², tent πr²/3,
    /// gaussian 2πσ²(1 − e⁻²)).
    #[test]
    fn weights_integrate_to_their_area_and_normalise_to_one() {
        let cases = [
            (Filter::Box(0.5), 1.0),
            (Filter::Box(1.7), 4.0 * 1.7 * 1.7),
            (Filter::Tent(1.5), std::f64::consts::PI * 1.5 * 1.5 / 3.0),
            (Filter::Gaussian(0.6), 2.0 * std::f64::consts::PI * 0.36),
        ];
        let step = 1.0 / 512.0;
        for (filter, area) in cases {
            // The box and the tent vanish past their support; the gaussian by 6σ.
            let reach = (filter.support_radius() as f64 + 0.5)
                .max(6.0 * filter.parameter() * f64::from(matches!(filter, Filter::Gaussian(_))));
            let n = (2.0 * reach / step) as i64;
            let mut sum = 0.0;
            for a in 0..n {
                for b in 0..n {
                    let (x, y) = (-reach + (a as f64 + 0.5) * step, -reach + (b as f64 + 0.5) * step);
                    sum += filter.weight(x, y) * step * step;
                }
            }
            assert!((sum - area).abs() < 2e-3 * area.max(1.0), "{filter:?}: {sum} against {area}");
            // Normalised (what a pixel does: Σw·c/Σw), a constant colour comes back whole.
            let mut normalised = 0.0;
            for a in 0..n {
                for b in 0..n {
                    let (x, y) = (-reach + (a as f64 + 0.5) * step, -reach + (b as f64 + 0.5) * step);
                    normalised += filter.weight(x, y) * step * step / sum;
                }
            }
            assert!((normalised - 1.0).abs() < 1e-9, "{filter:?}");
        }
    }

    /// No weight of the box or the tent lies outside the support radius: a sample of pixel
    /// i + R + 1 is more than the filter's extent from the centre (the gaussian reaches 2σ
    /// within it, and is cropped there).
    #[test]
    fn support_radius_holds_every_weight() {
        for filter in [Filter::Box(0.5), Filter::Box(2.3), Filter::Tent(1.7), Filter::Tent(0.5)] {
            let r = filter.support_radius() as f64;
            for k in 0..1000 {
                let t = k as f64 / 1000.0;
                // Just past pixel i + R: offset R + ½ + ε.
                let dx = r + 0.5 + 1e-9 + t;
                assert_eq!(filter.weight(dx, 0.0), 0.0, "{filter:?}");
            }
        }
        assert_eq!(Filter::Box(0.5).support_radius(), 0);
        assert_eq!(Filter::Tent(1.7).support_radius(), 2);
        assert_eq!(Filter::Gaussian(1.7).support_radius(), 3);
        assert_eq!(Filter::Gaussian(0.4).support_radius(), 1);
        assert_eq!(Filter::Tent(0.5).support_radius(), 0);
    }

    #[test]
    fn positions_lie_in_the_pixel_and_regular_ones_in_their_cells() {
        for sampler in [Sampler::Random(36), Sampler::Uniform(36), Sampler::Jittered(36), Sampler::Uniform(1)] {
            for k in 0..sampler.count() {
                let (x, y) = sampler.position(3, 5, k, 7);
                assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y), "{sampler:?} {k}");
                if !matches!(sampler, Sampler::Random(_)) {
                    let m = sampler.side();
                    let cell = ((x * m as f64).floor() as u32, (y * m as f64).floor() as u32);
                    assert_eq!(cell, (k % m, k / m), "{sampler:?} {k}");
                }
            }
        }
        assert_eq!(Sampler::Uniform(1).position(0, 0, 0, 0), (0.5, 0.5));
        assert_eq!(Sampler::Uniform(4).position(0, 0, 3, 0), (0.75, 0.75));
        // The seed changes hashed positions, not regular ones.
        assert_ne!(Sampler::Random(4).position(1, 1, 0, 0), Sampler::Random(4).position(1, 1, 0, 1));
        assert_eq!(Sampler::Uniform(4).position(1, 1, 2, 0), Sampler::Uniform(4).position(1, 1, 2, 9));
    }

    /// `pcg` against values computed by hand from its definition.
    #[test]
    fn pcg_known_values() {
        assert_eq!(pcg(0), 129_708_002);
        assert_ne!(pcg(1), pcg(0));
    }
}
