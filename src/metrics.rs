//! How far a render is from the reference, on the float buffers before quantisation and on
//! the 8-bit images after it. Used by the tests, `raycaster compare` and the benchmark.

use crate::image_io::{color_image, depth_image, normals_image};
use crate::render::{Frame, Output};
use image::RgbImage;
use std::fmt::Write as _;

/// How two 8-bit RGB images of one size differ, channel by channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageDiff {
    pub pixels: usize,
    /// Pixels with any channel more than 1 level apart.
    pub off_by_more_than_one: usize,
    /// The largest channel difference.
    pub max: u8,
    /// The mean absolute channel difference over all channels of all pixels.
    pub mean: f64,
}

pub fn image_diff(a: &RgbImage, b: &RgbImage) -> ImageDiff {
    assert_eq!(a.dimensions(), b.dimensions(), "image sizes differ");
    let mut diff = ImageDiff { pixels: (a.width() * a.height()) as usize, ..Default::default() };
    let mut sum = 0u64;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let d = [0, 1, 2].map(|c| p[c].abs_diff(q[c]));
        sum += d.iter().map(|&x| x as u64).sum::<u64>();
        let worst = d.into_iter().max().unwrap_or(0);
        diff.max = diff.max.max(worst);
        diff.off_by_more_than_one += usize::from(worst > 1);
    }
    diff.mean = sum as f64 / (3 * diff.pixels.max(1)) as f64;
    diff
}

/// The errors of one output of a tested frame against the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputErrors {
    /// Which output, and so the unit of the float error: the absolute difference per colour
    /// channel (unclamped linear RGB); the angle between the normals, in radians, where both
    /// frames hit; |Δt| in world units where both hit (`relative_max` is max |Δt|/|t|).
    pub output: Output,
    pub image: ImageDiff,
    /// Pixels one frame hits and the other misses.
    pub hit_mismatches: usize,
    pub float_max: f64,
    pub float_mean: f64,
    /// Depth only: the largest |Δt| / |t_reference|.
    pub relative_max: Option<f64>,
    /// NaN or infinite values in the tested frame's buffer for this output (channels for
    /// colour, pixels the tested frame hits for normals and depth).
    pub non_finite: usize,
}

/// Compares every output both frames hold. `depth_range` is the `-depth MIN MAX` used for
/// the 8-bit depth image.
pub fn compare_frames(test: &Frame, reference: &Frame, depth_range: (f32, f32)) -> Vec<OutputErrors> {
    assert_eq!((test.width, test.height), (reference.width, reference.height), "frame sizes differ");
    let hit_mismatches = test.hit.iter().zip(&reference.hit).filter(|(a, b)| a != b).count();
    let mut errors = Vec::new();
    if !test.color.is_empty() && !reference.color.is_empty() {
        errors.push(color_errors(test, reference, hit_mismatches));
    }
    if !test.normal.is_empty() && !reference.normal.is_empty() {
        errors.push(normal_errors(test, reference, hit_mismatches));
    }
    if !test.depth.is_empty() && !reference.depth.is_empty() {
        errors.push(depth_errors(test, reference, hit_mismatches, depth_range));
    }
    errors
}

fn color_errors(test: &Frame, reference: &Frame, hit_mismatches: usize) -> OutputErrors {
    let mut stats = Stats::default();
    let mut non_finite = 0;
    for (a, b) in test.color.iter().zip(&reference.color) {
        for c in 0..3 {
            non_finite += usize::from(!a[c].is_finite());
            stats.add((a[c] as f64 - b[c] as f64).abs());
        }
    }
    OutputErrors {
        output: Output::Color,
        image: image_diff(&color_image(test), &color_image(reference)),
        hit_mismatches,
        float_max: stats.max,
        float_mean: stats.mean(),
        relative_max: None,
        non_finite,
    }
}

fn normal_errors(test: &Frame, reference: &Frame, hit_mismatches: usize) -> OutputErrors {
    let mut stats = Stats::default();
    for k in both_hit(test, reference) {
        let (a, b) = (glam::Vec3::from(test.normal[k]).as_dvec3(), glam::Vec3::from(reference.normal[k]).as_dvec3());
        if a.is_finite() {
            // atan2(|a×b|, a·b) keeps its precision for tiny angles, where acos does not.
            stats.add(a.cross(b).length().atan2(a.dot(b)));
        }
    }
    OutputErrors {
        output: Output::Normals,
        image: image_diff(&normals_image(test), &normals_image(reference)),
        hit_mismatches,
        float_max: stats.max,
        float_mean: stats.mean(),
        relative_max: None,
        non_finite: hits_where(test, |k| test.normal[k].iter().any(|v| !v.is_finite())),
    }
}

fn depth_errors(test: &Frame, reference: &Frame, hit_mismatches: usize, (min, max): (f32, f32)) -> OutputErrors {
    let mut stats = Stats::default();
    let mut relative_max: f64 = 0.0;
    for k in both_hit(test, reference) {
        let (a, b) = (test.depth[k] as f64, reference.depth[k] as f64);
        if !a.is_finite() {
            continue;
        }
        stats.add((a - b).abs());
        if b != 0.0 {
            relative_max = relative_max.max((a - b).abs() / b.abs());
        }
    }
    OutputErrors {
        output: Output::Depth,
        image: image_diff(&depth_image(test, min, max), &depth_image(reference, min, max)),
        hit_mismatches,
        float_max: stats.max,
        float_mean: stats.mean(),
        relative_max: Some(relative_max),
        non_finite: hits_where(test, |k| !test.depth[k].is_finite()),
    }
}

/// How many pixels `frame` hits for which `bad` holds: NaN or infinity are counted wherever
/// the tested frame has a hit, whether or not the reference has one there.
fn hits_where(frame: &Frame, bad: impl Fn(usize) -> bool) -> usize {
    (0..frame.hit.len()).filter(|&k| frame.hit[k] && bad(k)).count()
}

fn both_hit<'a>(a: &'a Frame, b: &'a Frame) -> impl Iterator<Item = usize> + 'a {
    (0..a.hit.len()).filter(move |&k| a.hit[k] && b.hit[k])
}

#[derive(Default)]
struct Stats {
    max: f64,
    sum: f64,
    count: usize,
}

impl Stats {
    fn add(&mut self, x: f64) {
        self.max = self.max.max(x);
        self.sum += x;
        self.count += 1;
    }

    fn mean(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.sum / self.count as f64
        }
    }
}

/// The hit distances' range in `frame` (for a depth image that covers what is visible);
/// the depth ± 1 if every hit has the same depth, (0, 1) if nothing was hit.
pub fn depth_range_of(frame: &Frame) -> (f32, f32) {
    let hits = frame.depth.iter().zip(&frame.hit).filter(|(_, &h)| h).map(|(&t, _)| t);
    let (lo, hi) = hits.fold((f32::MAX, f32::MIN), |(lo, hi), t| (lo.min(t), hi.max(t)));
    if lo < hi {
        (lo, hi)
    } else if lo == hi {
        (lo - 1.0, lo + 1.0)
    } else {
        (0.0, 1.0)
    }
}

/// A Markdown table of `errors`, one row per output.
pub fn errors_table(errors: &[OutputErrors]) -> String {
    let mut table = String::from(
        "| output | pixels >1 level | max level diff | mean level diff | hit/miss | float max | float mean | depth rel. max | NaN/inf |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for e in errors {
        let unit = match e.output {
            Output::Color => "",
            Output::Normals => " rad",
            Output::Depth => " (world)",
        };
        let relative = e.relative_max.map_or("-".to_string(), |r| format!("{r:.2e}"));
        let _ = writeln!(
            table,
            "| {} | {} of {} | {} | {:.4} | {} | {:.2e}{unit} | {:.2e} | {relative} | {} |",
            e.output.name(),
            e.image.off_by_more_than_one,
            e.image.pixels,
            e.image.max,
            e.image.mean,
            e.hit_mismatches,
            e.float_max,
            e.float_mean,
            e.non_finite
        );
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::RenderOptions;

    fn frame_with(hit: [bool; 2], depth: [f32; 2], normal: [[f32; 3]; 2]) -> Frame {
        let mut f = Frame::new(&RenderOptions::all(2, 1));
        f.hit = hit.to_vec();
        f.depth = depth.to_vec();
        f.normal = normal.to_vec();
        f
    }

    #[test]
    fn depth_and_normal_errors_by_hand() {
        let z = [0.0, 0.0, 1.0];
        let tilted = [0.0, (0.01f32).sin(), (0.01f32).cos()];
        let reference = frame_with([true, true], [10.0, 4.0], [z, z]);
        let test = frame_with([true, false], [10.5, 0.0], [tilted, [0.0; 3]]);
        let errors = compare_frames(&test, &reference, (0.0, 20.0));
        let normals = errors.iter().find(|e| e.output == Output::Normals).unwrap();
        let depth = errors.iter().find(|e| e.output == Output::Depth).unwrap();
        assert_eq!(depth.hit_mismatches, 1);
        assert!((depth.float_max - 0.5).abs() < 1e-9);
        assert!((depth.relative_max.unwrap() - 0.05).abs() < 1e-9);
        assert!((normals.float_max - 0.01).abs() < 1e-6, "{}", normals.float_max);
        assert_eq!(normals.non_finite, 0);
    }

    #[test]
    fn nan_is_counted() {
        let reference = frame_with([true, true], [1.0, 1.0], [[0.0, 0.0, 1.0]; 2]);
        let test = frame_with([true, true], [f32::NAN, 1.0], [[f32::NAN, 0.0, 1.0], [0.0, 0.0, 1.0]]);
        let errors = compare_frames(&test, &reference, (0.0, 2.0));
        assert!(errors.iter().filter(|e| e.output != Output::Color).all(|e| e.non_finite == 1), "{errors:?}");
    }

    #[test]
    fn image_diff_counts_levels() {
        let a = RgbImage::from_raw(2, 1, vec![10, 10, 10, 0, 0, 0]).unwrap();
        let b = RgbImage::from_raw(2, 1, vec![11, 10, 10, 0, 5, 0]).unwrap();
        let d = image_diff(&a, &b);
        assert_eq!((d.off_by_more_than_one, d.max), (1, 5));
        assert!((d.mean - 1.0).abs() < 1e-12);
    }
}
