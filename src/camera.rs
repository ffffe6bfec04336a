//! Primary rays (docs/SPEC.md §3): where pixel (i, j) looks from and in which direction.
//!
//! The CPU reference calls [`PrimaryRays::ray`] per pixel in f64 (its `primary_ray` stage);
//! the GPU backend uploads the same `direction`, `horizontal` and `up` (in f32, with the
//! scene moved so that `center` is the origin) and the kernel repeats the arithmetic.

use crate::scene::{Camera, Projection};
use glam::DVec3;

/// A camera resolved for one image size: everything a pixel's ray depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimaryRays {
    pub center: DVec3,
    /// The camera's unit direction for orthographic rays; for perspective ones, the vector
    /// from the eye to the centre of the image plane, the unit direction times
    /// `D = 1/tan(angle/2)`.
    pub direction: DVec3,
    /// `horizontal` and `up` already scaled so that the screen coordinate −½…½ across the
    /// longer image side spans the camera's extent (`size` for orthographic, `2` at
    /// distance `D = 1/tan(angle/2)` for perspective).
    pub horizontal: DVec3,
    pub up: DVec3,
    pub orthographic: bool,
    pub width: u32,
    pub height: u32,
}

/// A ray `origin + t·direction` and the open interval `t_min < t < t_max` in which a hit
/// counts (pbrt's `Ray` with its `tMax`): the interval belongs to the ray, not to the
/// camera, because the rays still to come (towards a light, reflected, refracted) each
/// need their own — a shadow ray stops at its light, a primary ray at the first hit.
///
/// `direction` need not be unit length: primary rays have unit directions (in world space,
/// so that `t` is a distance), but the reference carries a ray into a Transform's object
/// space as `(M⁻¹·o, M⁻¹·d)` without renormalising, so that `t`, and with it the interval,
/// stays the world `t` (docs/SPEC.md §4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub direction: DVec3,
    pub t_min: f64,
    pub t_max: f64,
}

impl Ray {
    /// A ray that counts every hit with `t > t_min`.
    pub fn new(origin: DVec3, direction: DVec3, t_min: f64) -> Ray {
        Ray { origin, direction, t_min, t_max: f64::INFINITY }
    }

    /// The point at parameter `t`, `origin + t·direction`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.direction
    }
}

impl PrimaryRays {
    /// The ratio R of the scene's distance from the camera to a pixel's footprint there
    /// (gpu::precision's contract), for primitives whose points reach at most `farthest`
    /// (the largest camera-relative coordinate) from the camera. About 2⁻²⁴·R is the
    /// kernel's rounding error, in pixels, wherever it lands a ray or an edge.
    pub fn resolution(&self, farthest: f64) -> f64 {
        let longer_side = f64::from(self.width.max(self.height));
        if self.orthographic {
            // The rays start up to size/√2 from the camera; the primitives lie where they lie.
            let size = self.horizontal.length();
            farthest.max(size / std::f64::consts::SQRT_2) * longer_side / size
        } else {
            // At distance d a pixel spans d·2/(W·D): R = W·D/2 wherever the primitive is.
            longer_side * self.direction.length() / 2.0
        }
    }

    /// Resolves `camera` for a `width × height` image. Cannot fail: a [`Camera`] always has
    /// a frame (validated when the scene was read).
    pub fn for_camera(camera: &Camera, width: u32, height: u32) -> PrimaryRays {
        let basis = camera.frame();
        let (orthographic, extent, direction) = match camera.projection {
            Projection::Orthographic { size } => (true, size, basis.direction),
            // Seed notes: the image plane sits at D = 1/tan(angle/2) and spans −1…1.
            Projection::Perspective { angle } => (false, 2.0, basis.direction / (angle / 2.0).tan()),
        };
        PrimaryRays {
            center: camera.center,
            direction,
            horizontal: basis.horizontal * extent,
            up: basis.up * extent,
            orthographic,
            width,
            height,
        }
    }

    /// Screen coordinates of the centre of pixel (i from the left, j from the bottom),
    /// each in −½…½ along the longer side; the shorter side is cropped symmetrically so that
    /// pixels stay square (docs/SPEC.md §3).
    pub fn screen(&self, i: u32, j: u32) -> (f64, f64) {
        self.screen_at(i, j, (0.5, 0.5))
    }

    /// Screen coordinates of the point `(sx, sy)` (pixel-local, in [0, 1)², y up) of pixel
    /// (i, j): a sample's (docs/SPEC.md §8). The centre is (½, ½).
    pub fn screen_at(&self, i: u32, j: u32, (sx, sy): (f64, f64)) -> (f64, f64) {
        let longer = self.width.max(self.height) as f64;
        let x = (i as f64 + sx - self.width as f64 / 2.0) / longer;
        let y = (j as f64 + sy - self.height as f64 / 2.0) / longer;
        (x, y)
    }

    /// The ray through pixel (i from the left, j from the bottom), with the camera's
    /// interval (docs/SPEC.md §3): an orthographic ray comes from infinitely far behind the
    /// image plane (`t_min = −∞`, so objects behind the plane are seen, at negative t); a
    /// perspective ray starts at the eye (`t_min = 0`). Neither has a far limit.
    pub fn ray(&self, i: u32, j: u32) -> Ray {
        self.ray_at(i, j, (0.5, 0.5))
    }

    /// The ray through the point `position` (pixel-local, y up) of pixel (i, j): a
    /// sample's ray (docs/SPEC.md §8); [`PrimaryRays::ray`] at the centre.
    pub fn ray_at(&self, i: u32, j: u32, position: (f64, f64)) -> Ray {
        let (x, y) = self.screen_at(i, j, position);
        self.ray_through(x, y)
    }

    /// The ray through the centre of cell `k` (column k mod m, row k div m) of an m × m grid
    /// over pixel (i, j): a uniform sample's (docs/SPEC.md §8). Its screen coordinates come
    /// from whole numbers, x = ((2i − W)·m + 2a + 1) / (2·m·longer), rounded once, so that
    /// mirrored samples get exactly mirrored rays and a sample on a symmetric edge stays on it.
    pub fn grid_ray(&self, i: u32, j: u32, k: u32, m: u32) -> Ray {
        let scale = 2.0 * m as f64 * self.width.max(self.height) as f64;
        let whole = |pixel: u32, cell: u32, side: u32| {
            ((2 * pixel as i64 - side as i64) * m as i64 + 2 * cell as i64 + 1) as f64
        };
        self.ray_through(whole(i, k % m, self.width) / scale, whole(j, k / m, self.height) / scale)
    }

    /// The ray through screen coordinates (x, y) (docs/SPEC.md §3).
    fn ray_through(&self, x: f64, y: f64) -> Ray {
        let offset = x * self.horizontal + y * self.up;
        if self.orthographic {
            Ray::new(self.center + offset, self.direction, f64::NEG_INFINITY)
        } else {
            Ray::new(self.center, (self.direction + offset).normalize(), 0.0)
        }
    }
}
