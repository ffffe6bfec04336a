//! The any-hit query against the closest hit: `occluded(ray)` must say "something is hit"
//! exactly when `closest_hit(ray)` finds a hit, and with a far limit `T`, exactly when the
//! nearest hit has `t < T` (the interval is open: a hit at `T` itself does not count).

use raycaster::camera::{PrimaryRays, Ray};
use raycaster::cpu::ReferenceScene;
use raycaster::scene::{Light, Scene};

/// How many of the rays checked were occluded and how many were not, so that a caller can
/// tell a check that saw both answers from a vacuous one.
#[derive(Clone, Copy, Debug, Default)]
pub struct Tally {
    pub occluded: usize,
    pub clear: usize,
}

impl Tally {
    pub fn add(&mut self, other: Tally) {
        self.occluded += other.occluded;
        self.clear += other.clear;
    }
}

/// Checks every primary ray of a `width × height` image of `scene`, and from each hit the
/// rays a shader will cast there: towards each light (a shadow ray, ending at a point light),
/// and onwards through the surface (a refracted ray's simplest case). Each ray is checked with no far limit,
/// and those that hit also with the far limit at, just beyond and just before the nearest
/// hit, and a unit on either side. The first disagreement is returned as the error.
pub fn check_scene(scene: &Scene, width: u32, height: u32) -> Result<Tally, String> {
    let prepared = ReferenceScene::new(scene);
    let camera = PrimaryRays::for_camera(&scene.camera, width, height);
    let mut tally = Tally::default();
    for j in 0..height {
        for i in 0..width {
            let primary = camera.ray(i, j);
            let Some(hit) = check_ray(&prepared, &primary, &mut tally)? else { continue };
            let surface = prepared.surface_at(&hit, &primary);
            // A secondary ray starts a little beyond its own surface, as shaders will do it.
            let t_min = 1e-6 * surface.point.abs().max_element().max(1.0);
            let onwards = Ray::new(surface.point, primary.direction, t_min);
            check_ray(&prepared, &onwards, &mut tally)?;
            for light in &scene.lights {
                let shadow = match light {
                    Light::Directional(light) => Ray::new(surface.point, -light.direction, t_min),
                    // Towards a point light only up to the light: the ray's own far limit.
                    Light::Point(light) => {
                        let offset = light.position - surface.point;
                        let Some(direction) = offset.try_normalize() else { continue };
                        Ray { t_max: offset.length(), ..Ray::new(surface.point, direction, t_min) }
                    }
                };
                check_ray(&prepared, &shadow, &mut tally)?;
            }
        }
    }
    Ok(tally)
}

/// Checks one ray (as given, and with the far limits above); returns its closest hit.
fn check_ray(prepared: &ReferenceScene, ray: &Ray, tally: &mut Tally) -> Result<Option<raycaster::cpu::Hit>, String> {
    let closest = prepared.closest_hit(ray);
    let mut far_limits = vec![ray.t_max];
    if let Some(hit) = closest {
        far_limits.extend([hit.t, hit.t.next_up(), hit.t.next_down(), hit.t + 1.0, hit.t - 1.0]);
    }
    for t_max in far_limits {
        let limited = Ray { t_max, ..*ray };
        let expected = closest.is_some_and(|hit| hit.t < t_max);
        let occluded = prepared.occluded(&limited);
        if occluded != expected {
            return Err(format!(
                "occluded = {occluded} but the closest hit is {:?}, for the ray {limited:?}",
                closest.map(|hit| hit.t)
            ));
        }
        if occluded {
            tally.occluded += 1;
        } else {
            tally.clear += 1;
        }
    }
    Ok(closest)
}
