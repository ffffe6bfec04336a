//! How the mouse moves the camera of the live view: orbit, pan and zoom around a point of
//! interest (docs/SPEC.md §9); `bench`'s moving frames orbit the same way.
//!
//! The moves are the course's (assignment 3's `camera_additions.txt`: `rotateCamera`,
//! `truckCamera`, `dollyCamera`): the camera turns about its own `up` vector as the scene
//! file gives it and about its horizontal axis, never flipping over the pole. Where the
//! course turns about the world's origin, we turn about a pivot on the line of sight, so
//! that what the camera looks at stays at the centre of the image. Panning and zooming are
//! the window's alone (feature `gui`).

use glam::{DMat3, DVec3};
use raycaster::scene::{Camera, Projection, Scene};

/// Radians of orbit per pixel the mouse moves (the course's `GLCanvas::motion`).
pub const RADIANS_PER_PIXEL: f64 = 0.005;

/// How much one notch of the wheel (or 100 pixels of a right-button drag) brings the camera
/// closer: the distance to the pivot, or an orthographic camera's `size`, times this.
#[cfg(feature = "gui")]
pub const ZOOM_PER_NOTCH: f64 = 0.8;

/// The closest the direction comes to the up vector, in radians: the course's 0.01, which
/// keeps `up × direction`, and with it the camera's frame, defined.
const POLE_MARGIN: f64 = 0.01;

/// A camera that the mouse moves, and the point it moves around.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    camera: Camera,
    pivot: DVec3,
}

impl Orbit {
    /// Orbits around the point of the line of sight nearest to `target` (the middle of the
    /// scene's bounds), or one unit ahead when that lies behind the camera.
    pub fn around(camera: Camera, target: DVec3) -> Orbit {
        let direction = camera.frame().direction;
        let ahead = (target - camera.center).dot(direction);
        let distance = if ahead.is_finite() && ahead > 0.0 { ahead } else { 1.0 };
        Orbit { camera, pivot: camera.center + distance * direction }
    }

    /// Orbits `scene`'s camera around the middle of the scene's bounds ([`Orbit::around`]);
    /// with a plane, whose bounds are unbounded, the world's origin, the course's centre of
    /// rotation.
    pub fn of_scene(scene: &Scene) -> Orbit {
        let target = scene.bounds().bounds().filter(|b| !b.is_empty()).map_or(DVec3::ZERO, |b| (b.min + b.max) / 2.0);
        Orbit::around(scene.camera, target)
    }

    pub fn camera(&self) -> Camera {
        self.camera
    }

    #[cfg(test)]
    pub fn pivot(&self) -> DVec3 {
        self.pivot
    }

    /// The mouse moved `(dx, dy)` pixels (y down) with the orbit button held: the camera
    /// turns about its up vector through the pivot by `−dx · RADIANS_PER_PIXEL`, then about
    /// its horizontal axis by `−dy · RADIANS_PER_PIXEL`, as if the mouse dragged the scene.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        let up = self.camera.up.normalize();
        let frame = *self.camera.frame();
        // The course's clamp: the angle between up and direction stays in [0.01, π − 0.01].
        let tilt = up.dot(frame.direction).clamp(-1.0, 1.0).acos();
        let ry = (-dy * RADIANS_PER_PIXEL).clamp(tilt - (std::f64::consts::PI - POLE_MARGIN), tilt - POLE_MARGIN);
        let rotation =
            DMat3::from_axis_angle(up, -dx * RADIANS_PER_PIXEL) * DMat3::from_axis_angle(frame.horizontal, ry);
        let center = self.pivot + rotation * (self.camera.center - self.pivot);
        self.move_to(center, rotation * self.camera.direction);
    }

    /// The mouse moved `(dx, dy)` pixels with the pan button held, in an image `side` pixels
    /// across its longer side: camera and pivot slide along the image plane so that a point
    /// at the pivot's depth stays under the mouse.
    #[cfg(feature = "gui")]
    pub fn pan(&mut self, dx: f64, dy: f64, side: u32) {
        let frame = *self.camera.frame();
        let per_pixel = self.extent_at_pivot() / f64::from(side.max(1));
        let shift = (-dx * frame.horizontal + dy * frame.up) * per_pixel;
        self.pivot += shift;
        self.move_to(self.camera.center + shift, self.camera.direction);
    }

    /// Zooms by `notches` of the wheel (positive: closer): a perspective camera moves along
    /// its line of sight towards the pivot, never reaching it; an orthographic one narrows
    /// its view.
    #[cfg(feature = "gui")]
    pub fn zoom(&mut self, notches: f64) {
        let factor = ZOOM_PER_NOTCH.powf(notches);
        match self.camera.projection {
            Projection::Perspective { .. } => {
                let center = self.pivot + (self.camera.center - self.pivot) * factor;
                self.move_to(center, self.camera.direction);
            }
            Projection::Orthographic { size } => {
                let projection = Projection::Orthographic { size: size * factor };
                self.camera = self.with(projection, self.camera.center, self.camera.direction);
            }
        }
    }

    /// The width of the view at the pivot's depth, in world units.
    #[cfg(feature = "gui")]
    fn extent_at_pivot(&self) -> f64 {
        match self.camera.projection {
            Projection::Orthographic { size } => size,
            Projection::Perspective { angle } => 2.0 * (angle / 2.0).tan() * (self.pivot - self.camera.center).length(),
        }
    }

    fn move_to(&mut self, center: DVec3, direction: DVec3) {
        self.camera = self.with(self.camera.projection, center, direction);
    }

    /// The camera with new fields, or unchanged where they have no frame (a move that would
    /// align the direction with up, which the clamp prevents, or a degenerate float).
    fn with(&self, projection: Projection, center: DVec3, direction: DVec3) -> Camera {
        Camera::new(projection, center, direction, self.camera.up, self.camera.location).unwrap_or(self.camera)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use raycaster::scene::Location;

    fn camera(projection: Projection, center: DVec3) -> Camera {
        Camera::new(projection, center, -center, DVec3::Y, Location::default()).unwrap()
    }

    fn perspective() -> Camera {
        camera(Projection::Perspective { angle: 30f64.to_radians() }, DVec3::new(0.0, 0.0, 10.0))
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn the_pivot_is_the_targets_foot_on_the_line_of_sight() {
        let orbit = Orbit::around(perspective(), DVec3::new(3.0, 1.0, 2.0));
        assert!(close(orbit.pivot(), DVec3::new(0.0, 0.0, 2.0)));
        let behind = Orbit::around(perspective(), DVec3::new(0.0, 0.0, 20.0));
        assert!(close(behind.pivot(), DVec3::new(0.0, 0.0, 9.0)));
    }

    #[test]
    fn a_horizontal_drag_turns_the_camera_about_up_through_the_pivot() {
        let mut orbit = Orbit::around(perspective(), DVec3::ZERO);
        // 100 pixels right: the camera goes 0.5 rad clockwise seen from above (to −x).
        orbit.orbit(100.0, 0.0);
        let c = orbit.camera();
        assert!(close(c.center, DVec3::new(-10.0 * 0.5f64.sin(), 0.0, 10.0 * 0.5f64.cos())));
        assert!(close(c.frame().direction, -c.center.normalize()));
        // Turns about one axis add up: two drags of 50 are one of 100.
        let mut twice = Orbit::around(perspective(), DVec3::ZERO);
        twice.orbit(50.0, 0.0);
        twice.orbit(50.0, 0.0);
        assert!(close(twice.camera().center, c.center));
    }

    #[test]
    fn a_vertical_drag_stops_short_of_the_pole() {
        // Down drags the scene down: the camera rises over it, towards looking straight down.
        for (dy, angle_to_up) in [(10_000.0, std::f64::consts::PI - POLE_MARGIN), (-10_000.0, POLE_MARGIN)] {
            let mut orbit = Orbit::around(perspective(), DVec3::ZERO);
            orbit.orbit(0.0, dy);
            let c = orbit.camera();
            let angle = c.frame().direction.dot(DVec3::Y).acos();
            assert!((angle - angle_to_up).abs() < 1e-9, "{dy}: {angle}");
            assert_eq!(c.center.y > 0.0, dy > 0.0, "{dy}: {}", c.center);
            assert!(((c.center - orbit.pivot()).length() - 10.0).abs() < 1e-9);
        }
    }

    #[cfg(feature = "gui")]
    #[test]
    fn panning_keeps_the_point_at_the_pivots_depth_under_the_mouse() {
        let mut orbit = Orbit::around(perspective(), DVec3::ZERO);
        // The view is 2·tan(15°)·10 wide at the pivot; 200 pixels across: so many units a pixel.
        let per_pixel = 2.0 * 15f64.to_radians().tan() * 10.0 / 200.0;
        orbit.pan(20.0, -10.0, 200);
        let shift = DVec3::new(-20.0 * per_pixel, -10.0 * per_pixel, 0.0);
        assert!(close(orbit.camera().center, DVec3::new(0.0, 0.0, 10.0) + shift));
        assert!(close(orbit.pivot(), shift));
    }

    #[cfg(feature = "gui")]
    #[test]
    fn zooming_moves_a_perspective_camera_and_narrows_an_orthographic_one() {
        let mut orbit = Orbit::around(perspective(), DVec3::ZERO);
        orbit.zoom(2.0);
        assert!(close(orbit.camera().center, DVec3::new(0.0, 0.0, 10.0 * 0.64)));
        let ortho = camera(Projection::Orthographic { size: 5.0 }, DVec3::new(0.0, 0.0, 10.0));
        let mut orbit = Orbit::around(ortho, DVec3::ZERO);
        orbit.zoom(-1.0);
        assert_eq!(orbit.camera().projection, Projection::Orthographic { size: 5.0 / 0.8 });
        assert_eq!(orbit.camera().center, ortho.center);
    }
}
