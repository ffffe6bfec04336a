//! The f64 reference against values worked out by hand, and its any-hit query against its
//! closest hit.

mod common;

use glam::DVec3;
use raycaster::camera::{PrimaryRays, Ray};
use raycaster::render::{RenderOptions, Shading};
use raycaster::scene::{parse_scene, Scene};
use std::path::Path;

fn scene(text: &str) -> Scene {
    parse_scene(text, Path::new("inline.txt")).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance
}

const LIT_SPHERE: &str = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
Lights { numLights 1 DirectionalLight { direction -1 -2 -3 color 0.9 0.8 0.7 } }
Background { color 0.1 0.2 0.3 ambientLight 0.2 0.3 0.4 }
Materials { numMaterials 1 Material { diffuseColor 0.5 0.6 0.7 } }
Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }
";

/// The centre pixel of an odd-sized image looks straight at the sphere's pole, whose normal
/// is +z: colour = ambient·c + (L·N)·light·c with L = −normalise(direction).
#[test]
fn centre_of_a_lit_sphere() {
    let frame = raycaster::cpu::render(&scene(LIT_SPHERE), &RenderOptions::all(101, 101));
    let centre = 50 * 101 + 50;
    let l_dot_n = 3.0 / 14f64.sqrt();
    let c = DVec3::new(0.5, 0.6, 0.7);
    let expected = DVec3::new(0.2, 0.3, 0.4) * c + l_dot_n * DVec3::new(0.9, 0.8, 0.7) * c;
    for k in 0..3 {
        assert!(
            close(frame.color[centre][k] as f64, expected[k], 1e-6),
            "channel {k}: {:?} vs {expected}",
            frame.color[centre]
        );
    }
    assert_eq!(frame.normal[centre], [0.0, 0.0, 1.0]);
    // The orthographic ray starts on the image plane z = 10 and meets the pole at z = 1.
    assert!(close(frame.depth[centre] as f64, 9.0, 1e-6));
    // A corner pixel misses: background colour, no normal.
    assert!(!frame.hit[0]);
    assert_eq!(frame.color[0], [0.1, 0.2, 0.3]);
}

/// A perspective camera 10 units from a unit sphere sees its front at distance 9, and
/// the depth image maps t = 9 with -depth 8 10 to grey (10 − 9)/(10 − 8) = ½ → 127.
#[test]
fn depth_of_a_known_hit() {
    let s = scene(
        "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }
         Materials { numMaterials 1 Material { } }
         Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }",
    );
    let frame = raycaster::cpu::render(&s, &RenderOptions::all(3, 3));
    assert!(close(frame.depth[4] as f64, 9.0, 1e-9), "{}", frame.depth[4]);
    let image = raycaster::image_io::depth_image(&frame, 8.0, 10.0);
    assert_eq!(image.get_pixel(1, 1).0, [127, 127, 127]);
}

/// `Scale 2 1 1` on a unit sphere gives the ellipsoid x²/4 + y² + z² = 1. A ray along −z
/// through x = 1 meets it at z = √¾, where the inverse-transpose normal is
/// normalise(M⁻ᵀ·n_object) = normalise((¼, 0, √¾)) (the gradient (x/4, y, z)).
#[test]
fn normal_of_a_non_uniformly_scaled_sphere() {
    let s = scene(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
         Materials { numMaterials 1 Material { } }
         Group { numObjects 1 MaterialIndex 0 Transform { Scale 2 1 1 Sphere { center 0 0 0 radius 1 } } }",
    );
    let ray = Ray::new(DVec3::new(1.0, 0.0, 10.0), DVec3::new(0.0, 0.0, -1.0), f64::NEG_INFINITY);
    let hit = raycaster::cpu::trace(&s, &ray).expect("the ray hits");
    let z = 0.75f64.sqrt();
    let expected = DVec3::new(0.25, 0.0, z).normalize();
    assert!(close(hit.t, 10.0 - z, 1e-12), "t = {}", hit.t);
    assert!((hit.normal - expected).length() < 1e-12, "{} vs {expected}", hit.normal);
}

/// Orthographic rays come from infinity: a sphere behind the image plane is visible, at
/// negative t. Camera at z = 0 looking down −z; a unit sphere at z = 5 is first met at z = 6,
/// t = −6. A perspective camera in the same place sees nothing.
#[test]
fn orthographic_camera_sees_behind_its_image_plane() {
    let body = "Materials { numMaterials 1 Material { } }
                Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 5 radius 1 } }";
    let ortho = scene(&format!("OrthographicCamera {{ center 0 0 0 direction 0 0 -1 up 0 1 0 size 4 }} {body}"));
    let frame = raycaster::cpu::render(&ortho, &RenderOptions::all(1, 1));
    assert!(frame.hit[0]);
    assert!(close(frame.depth[0] as f64, -6.0, 1e-9), "{}", frame.depth[0]);
    let persp = scene(&format!("PerspectiveCamera {{ center 0 0 0 direction 0 0 -1 up 0 1 0 angle 30 }} {body}"));
    assert!(!raycaster::cpu::render(&persp, &RenderOptions::all(1, 1)).hit[0]);
}

/// Back faces: from inside a sphere every hit faces away from the viewer; it is black
/// without -shade_back and lit with the flipped normal with it.
#[test]
fn back_faces_black_unless_shade_back() {
    let s = scene(
        "PerspectiveCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 angle 30 }
         Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
         Materials { numMaterials 1 Material { diffuseColor 1 0.5 0.25 } }
         Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 5 } }",
    );
    let mut options = RenderOptions::all(1, 1);
    assert_eq!(raycaster::cpu::render(&s, &options).color[0], [0.0, 0.0, 0.0]);
    options.shading.shade_back = true;
    // Flipped normal (0,0,1) against L = (0,0,1): full light.
    assert_eq!(raycaster::cpu::render(&s, &options).color[0], [1.0, 0.5, 0.25]);
}

/// A non-square image keeps square pixels: the longer side spans `size`, so at 4×2 with
/// size 4 the pixel centres are 1 unit apart and the rows sit at y = ±0.5.
#[test]
fn non_square_images_crop_the_shorter_side() {
    let s = scene(
        "OrthographicCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 size 4 }
         Group { numObjects 0 }",
    );
    let rays = PrimaryRays::for_camera(&s.camera, 4, 2);
    assert_eq!(rays.ray(0, 0).origin, DVec3::new(-1.5, -0.5, 0.0));
    assert_eq!(rays.ray(3, 1).origin, DVec3::new(1.5, 0.5, 0.0));
}

/// A triangle under a mirroring transform keeps the normal of docs/SPEC.md §4, normalise(M⁻ᵀ·n).
#[test]
fn mirrored_triangle_normal_follows_the_inverse_transpose() {
    let s = scene(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
         Materials { numMaterials 1 Material { } }
         Group { numObjects 1 MaterialIndex 0
           Transform { Scale -1 1 1 Triangle { vertex0 -1 -1 0 vertex1 1 -1 0 vertex2 0 1 0 } } }",
    );
    let ray = Ray::new(DVec3::new(0.0, 0.0, 10.0), DVec3::new(0.0, 0.0, -1.0), f64::NEG_INFINITY);
    let hit = raycaster::cpu::trace(&s, &ray).unwrap();
    // Object normal +z; M⁻ᵀ = diag(−1, 1, 1) leaves +z as it is.
    assert_eq!(hit.normal, DVec3::new(0.0, 0.0, 1.0));
}

const UNIT_SPHERE: &str = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
Materials { numMaterials 1 Material { } }
Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }
";

/// The ray along −z from z = 10 through the unit sphere's centre meets it at t = 9 and
/// t = 11. The ray's own interval, open at both ends, decides which of them counts.
#[test]
fn a_ray_counts_only_hits_inside_its_interval() {
    let s = scene(UNIT_SPHERE);
    let down = |t_min: f64, t_max: f64| Ray { t_max, ..Ray::new(DVec3::new(0.0, 0.0, 10.0), -DVec3::Z, t_min) };
    let t = |ray: Ray| raycaster::cpu::trace(&s, &ray).map(|surface| surface.t);
    assert_eq!(t(down(f64::NEG_INFINITY, f64::INFINITY)), Some(9.0));
    assert_eq!(t(down(9.0, f64::INFINITY)), Some(11.0), "a hit at t_min itself does not count");
    assert_eq!(t(down(f64::NEG_INFINITY, 9.0)), None, "nor one at t_max");
    assert_eq!(t(down(f64::NEG_INFINITY, 9.5)), Some(9.0));
    assert_eq!(t(down(9.5, 10.5)), None, "both hits outside");
    assert_eq!(t(down(11.0, f64::INFINITY)), None);
}

/// The camera gives its primary rays its interval (docs/SPEC.md §3): from −∞ for the
/// orthographic camera, from 0 (the eye) for the perspective one, and no far limit.
#[test]
fn primary_rays_carry_the_cameras_interval() {
    let body = "Group { numObjects 0 }";
    let ortho = scene(&format!("OrthographicCamera {{ center 0 0 0 direction 0 0 -1 up 0 1 0 size 4 }} {body}"));
    let persp = scene(&format!("PerspectiveCamera {{ center 0 0 0 direction 0 0 -1 up 0 1 0 angle 30 }} {body}"));
    let ray = PrimaryRays::for_camera(&ortho.camera, 3, 3).ray(1, 1);
    assert_eq!((ray.t_min, ray.t_max), (f64::NEG_INFINITY, f64::INFINITY));
    let ray = PrimaryRays::for_camera(&persp.camera, 3, 3).ray(1, 1);
    assert_eq!((ray.t_min, ray.t_max), (0.0, f64::INFINITY));
}

/// A shadow ray from the point (0, 0, 3) towards a light above along +z passes the unit
/// sphere at the origin; one towards a light along −z meets it at t = 2 (z = 1), so it is
/// occluded unless its far limit stops it before: at t_max = 2 (open interval) or 1.5.
#[test]
fn occluded_sees_any_hit_before_the_far_limit() {
    let s = scene(UNIT_SPHERE);
    let prepared = raycaster::cpu::ReferenceScene::new(&s);
    let from = DVec3::new(0.0, 0.0, 3.0);
    assert!(!prepared.occluded(&Ray::new(from, DVec3::Z, 0.0)));
    assert!(prepared.occluded(&Ray::new(from, -DVec3::Z, 0.0)));
    assert!(!prepared.occluded(&Ray { t_max: 2.0, ..Ray::new(from, -DVec3::Z, 0.0) }));
    assert!(!prepared.occluded(&Ray { t_max: 1.5, ..Ray::new(from, -DVec3::Z, 0.0) }));
    assert!(prepared.occluded(&Ray { t_max: 2.5, ..Ray::new(from, -DVec3::Z, 0.0) }));
    // Beyond both crossings (t = 2 and t = 4) nothing is left.
    assert!(!prepared.occluded(&Ray::new(from, -DVec3::Z, 4.0)));
}

/// `Translate 5 0 0` then `Scale 2 1 1` (applied first) makes the unit sphere the ellipsoid
/// (x − 5)²/4 + y² + z² = 1. The ray along −z through x = 6 meets it at z = √¾: in the
/// sphere's own coordinates at ((6 − 5)/2, 0, √¾) = (½, 0, √¾), in the world at (6, 0, √¾),
/// with t = 10 − √¾ and the normal normalise(M⁻ᵀ·(½, 0, √¾)) = normalise((¼, 0, √¾)).
/// The material is the one the file selected for the sphere, the second.
#[test]
fn surface_of_a_transformed_sphere() {
    let s = scene(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
         Materials { numMaterials 2 Material { } Material { diffuseColor 1 0 0 } }
         Group { numObjects 2
           MaterialIndex 0 Plane { normal 0 0 1 offset -5 }
           MaterialIndex 1 Transform { Translate 5 0 0 Scale 2 1 1 Sphere { center 0 0 0 radius 1 } } }",
    );
    let ray = Ray::new(DVec3::new(6.0, 0.0, 10.0), -DVec3::Z, f64::NEG_INFINITY);
    let surface = raycaster::cpu::trace(&s, &ray).expect("the ray hits");
    let z = 0.75f64.sqrt();
    assert!(close(surface.t, 10.0 - z, 1e-12), "t = {}", surface.t);
    assert!((surface.point - DVec3::new(6.0, 0.0, z)).length() < 1e-12, "{}", surface.point);
    assert!((surface.object_point - DVec3::new(0.5, 0.0, z)).length() < 1e-12, "{}", surface.object_point);
    assert!((surface.normal - DVec3::new(0.25, 0.0, z).normalize()).length() < 1e-12, "{}", surface.normal);
    assert_eq!(surface.material, 1);
}

/// Nested Transforms: `Translate 0 0 -4` around `UniformScale 2 ZRotate 90` around the
/// triangle (0,0,0), (1,0,0), (0,1,0). A point of the triangle is turned a quarter turn
/// about z first, (x, y) → (−y, x), then doubled, then moved to z = −4: the object point
/// (¼, ¼, 0) lands at (−½, ½, −4), where the ray along −z from z = 10 meets it at t = 14.
/// The ray through (½, ½) goes back to the object point (¼, −¼), outside the triangle.
/// The object normal +z stays +z through a turn about z and a uniform scale.
#[test]
fn surface_inside_nested_transforms() {
    let s = scene(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
         Materials { numMaterials 1 Material { } }
         Group { numObjects 1 MaterialIndex 0
           Transform { Translate 0 0 -4
             Transform { UniformScale 2 ZRotate 90
               Triangle { vertex0 0 0 0 vertex1 1 0 0 vertex2 0 1 0 } } } }",
    );
    let ray = |x: f64, y: f64| Ray::new(DVec3::new(x, y, 10.0), -DVec3::Z, f64::NEG_INFINITY);
    assert!(raycaster::cpu::trace(&s, &ray(0.5, 0.5)).is_none());
    let surface = raycaster::cpu::trace(&s, &ray(-0.5, 0.5)).expect("the ray hits");
    assert!(close(surface.t, 14.0, 1e-12), "t = {}", surface.t);
    assert!((surface.point - DVec3::new(-0.5, 0.5, -4.0)).length() < 1e-12, "{}", surface.point);
    assert!((surface.object_point - DVec3::new(0.25, 0.25, 0.0)).length() < 1e-12, "{}", surface.object_point);
    assert!((surface.normal - DVec3::Z).length() < 1e-12, "{}", surface.normal);
}

/// Occlusion agrees with the closest hit on the project's scenes (`scenes/`, `scenes/hard/`)
/// and the course's (`a2/`, when present): every primary ray of a small image, and the
/// shadow and onward rays from each hit (see `common::occlusion`).
#[test]
fn occluded_agrees_with_closest_hit_on_the_scenes() {
    let mut scenes = Vec::new();
    let mut listed = |dir: std::path::PathBuf| {
        let mut paths: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|entry| entry.unwrap().path())
            .filter(|path| path.extension().is_some_and(|ext| ext == "txt") && !path.ends_with("commands.txt"))
            .collect();
        paths.sort();
        scenes.extend(paths);
    };
    listed(common::scenes_dir());
    listed(common::hard::hard_dir());
    if let Some(corpus) = common::corpus() {
        listed(corpus.join("a2"));
    }
    let mut total = common::occlusion::Tally::default();
    let mut checked = 0;
    for path in &scenes {
        let name = path.file_name().unwrap().to_str().unwrap();
        let Some((_meshes, loaded)) = common::hard::load_listed(path) else { continue };
        let tally = common::occlusion::check_scene(&loaded, 16, 16).unwrap_or_else(|e| panic!("{name}: {e}"));
        total.add(tally);
        checked += 1;
    }
    assert!(checked >= 30, "only {checked} scenes loaded");
    assert!(total.occluded > 1000 && total.clear > 1000, "one answer too rare to have been tested: {total:?}");
}

/// A unit sphere's pole (normal +z) seen from above by an orthographic camera (V = +z),
/// lit from 45° (L = (0, 1, 1)/√2): N·L = 1/√2 and the half vector lies halfway, at 22.5°
/// from N, so N·H = cos 22.5° and (N·H)⁸ = ((1 + cos 45°)/2)⁴ = ((2 + √2)/4)⁴.
const SPECULAR_POLE: &str = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
Lights { numLights 1 DirectionalLight { direction 0 -1 -1 color 1 0.8 1 } }
Materials { numMaterials 1 PhongMaterial { diffuseColor 0.2 0.2 0.2 specularColor 0.5 0.25 0 exponent 8 } }
Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }
";

/// The Blinn–Torrance term at a hand-computed pixel, without and with the specular fix
/// (which multiplies the lobe by N·L).
#[test]
fn specular_term_at_the_pole() {
    let s = scene(SPECULAR_POLE);
    let centre = 50 * 101 + 50;
    let cos_light = 0.5f64.sqrt();
    let lobe = ((2.0 + 2f64.sqrt()) / 4.0).powi(4);
    let light = DVec3::new(1.0, 0.8, 1.0);
    let (diffuse, specular) = (DVec3::splat(0.2), DVec3::new(0.5, 0.25, 0.0));
    for fix in [false, true] {
        let options = RenderOptions {
            shading: Shading { specular_fix: fix, ..Shading::default() },
            ..RenderOptions::all(101, 101)
        };
        let frame = raycaster::cpu::render(&s, &options);
        let weight = if fix { lobe * cos_light } else { lobe };
        let expected = cos_light * light * diffuse + weight * light * specular;
        for k in 0..3 {
            assert!(
                close(frame.color[centre][k] as f64, expected[k], 1e-6),
                "fix {fix}, channel {k}: {:?} vs {expected}",
                frame.color[centre]
            );
        }
    }
}

/// A light just behind the surface's tangent plane (N·L < 0) gives no specular term, with
/// or without the fix, even though the half vector still leans towards N (N·H > 0).
#[test]
fn no_specular_from_behind_the_surface() {
    let s = scene(&SPECULAR_POLE.replace("direction 0 -1 -1", "direction 0 -1 0.2"));
    for fix in [false, true] {
        let options = RenderOptions {
            shading: Shading { specular_fix: fix, ..Shading::default() },
            ..RenderOptions::all(101, 101)
        };
        assert_eq!(raycaster::cpu::render(&s, &options).color[50 * 101 + 50], [0.0, 0.0, 0.0], "fix {fix}");
    }
}

/// A point light 5 units above a plane z = 0 with attenuation 0 0.2 0.05: straight below
/// it d = 5, N·L = 1 and the divisor is 0.2·5 + 0.05·25 = 2.25; 1.6 units aside,
/// d = √(1.6² + 5²), N·L = 5/d and the divisor is 0.2·d + 0.05·d².
#[test]
fn point_light_attenuation() {
    let text = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
Lights { numLights 1 PointLight { position 0 0 5 color 1 1 1 attenuation 0 0.2 0.05 } }
Materials { numMaterials 1 Material { diffuseColor 0.9 0.45 0.225 } }
Group { numObjects 1 MaterialIndex 0 Plane { normal 0 0 1 offset 0 } }
";
    let frame = raycaster::cpu::render(&scene(text), &RenderOptions::all(5, 5));
    let diffuse = DVec3::new(0.9, 0.45, 0.225);
    // Row 2 of 5 is y = 0; columns 2 and 4 are x = 0 and x = 1.6 (pixels 0.8 wide).
    let d = (1.6f64 * 1.6 + 25.0).sqrt();
    for (pixel, expected) in [(2 * 5 + 2, diffuse / 2.25), (2 * 5 + 4, diffuse * (5.0 / d) / (0.2 * d + 0.05 * d * d))]
    {
        for k in 0..3 {
            assert!(
                close(frame.color[pixel][k] as f64, expected[k], 1e-6),
                "pixel {pixel}, channel {k}: {:?} vs {expected}",
                frame.color[pixel]
            );
        }
    }
    // Without `attenuation` (1 0 0) the light does not fall off: 100 units away, straight
    // above, the plane gets the full diffuse colour.
    let far = text.replace("position 0 0 5 color 1 1 1 attenuation 0 0.2 0.05", "position 0 0 100 color 1 1 1");
    let frame = raycaster::cpu::render(&scene(&far), &RenderOptions::all(5, 5));
    for k in 0..3 {
        assert!(close(frame.color[12][k] as f64, diffuse[k], 1e-6), "{:?}", frame.color[12]);
    }
}

/// Lights add up in file order, a point light and a directional one together.
#[test]
fn point_and_directional_lights_add_up() {
    let text = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
Lights { numLights 2
  DirectionalLight { direction 0 0 -1 color 0.25 0 0 }
  PointLight { position 0 0 2 color 0 0.5 0 attenuation 0.5 0 0 } }
Background { ambientLight 0 0 0.125 }
Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }
Group { numObjects 1 MaterialIndex 0 Plane { normal 0 0 1 offset 0 } }
";
    let frame = raycaster::cpu::render(&scene(text), &RenderOptions::all(5, 5));
    // Red from the directional light, green 0.5/0.5 from the point light, blue ambient.
    assert_eq!(frame.color[12], [0.25, 1.0, 0.125]);
}

fn with(options: RenderOptions, shadows: bool, bounces: u32, weight: f64) -> RenderOptions {
    RenderOptions { shading: Shading { shadows, bounces, weight, ..options.shading }, ..options }
}

/// A unit sphere at z = 2 between a plane z = 0 and the light. Straight below it the plane
/// is in shadow with `-shadows` (ambient only) and lit without. A point light at z = 1,
/// below the sphere, is not blocked by it: the shadow ray stops at the light.
#[test]
fn shadow_rays_to_directional_and_point_lights() {
    let text = "
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 8 }
Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 0.5 0.5 0.5 } }
Background { ambientLight 0.25 0.25 0.25 }
Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }
Group { numObjects 2 MaterialIndex 0 Plane { normal 0 0 1 offset 0 }
  Transform { Translate 0 0 2 Transform { Scale 1 1 0.25 Sphere { center 0 0 0 radius 1 } } } }
";
    // 9×9 pixels of 8/9 units: the centre pixel looks at the sphere; the top row's middle
    // pixel (index 4), at x = 0, y = 3.56, misses it and meets the plane, lit from above.
    let options = RenderOptions::all(9, 9);
    let s = scene(text);
    let lit = raycaster::cpu::render(&s, &options);
    let shadowed = raycaster::cpu::render(&s, &with(options, true, 0, 0.0));
    assert_eq!(lit.color[4], [0.75, 0.75, 0.75]);
    assert_eq!(shadowed.color[4], [0.75, 0.75, 0.75], "nothing blocks it");
    // A light coming in at 45° throws the sphere's shadow 2 units aside, onto x = −2: pixel
    // column 4 − 2.25 ≈ 2 (x = −1.78) lies in it.
    let slanted = scene(&text.replace("direction 0 0 -1 color", "direction -1 0 -1 color"));
    let lit = raycaster::cpu::render(&slanted, &options);
    let shadowed = raycaster::cpu::render(&slanted, &with(options, true, 0, 0.0));
    let cos = 0.5f64.sqrt();
    let full = (0.25 + 0.5 * cos) as f32;
    assert!((lit.color[4 * 9 + 2][0] - full).abs() < 1e-6, "{:?}", lit.color[4 * 9 + 2]);
    assert_eq!(shadowed.color[4 * 9 + 2], [0.25, 0.25, 0.25]);
    // A shadow ray to a point light stops at the light.
    let point = |sphere: &str| {
        scene(&format!(
            "OrthographicCamera {{ center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }}
             Lights {{ numLights 1 PointLight {{ position 2 0 1 color 0.5 0.5 0.5 }} }}
             Background {{ ambientLight 0.25 0.25 0.25 }}
             Materials {{ numMaterials 1 Material {{ diffuseColor 1 1 1 }} }}
             Group {{ numObjects 2 MaterialIndex 0 Plane {{ normal 0 0 1 offset 0 }} {sphere} }}"
        ))
    };
    // The centre pixel sees the plane at the origin; the light is at (2, 0, 1), d = √5,
    // N·L = 1/√5. A sphere on the same line but beyond the light, at (4, 0, 2) (outside the
    // picture), blocks nothing; one between them, at (1, 0, 0.5), puts the point in shadow.
    let options = RenderOptions::all(9, 9);
    let lit = (0.25 + 0.5 / 5f64.sqrt()) as f32;
    let beyond = raycaster::cpu::render(&point("Sphere { center 4 0 2 radius 0.5 }"), &with(options, true, 0, 0.0));
    assert!((beyond.color[40][0] - lit).abs() < 1e-6, "{:?}", beyond.color[40]);
    let between = raycaster::cpu::render(&point("Sphere { center 1 0 0.5 radius 0.2 }"), &with(options, true, 0, 0.0));
    assert_eq!(between.color[40], [0.25, 0.25, 0.25]);
}

/// A mirror plane (reflective 0.5, no diffuse) under an orthographic camera looking
/// straight down: the reflected ray goes straight up and misses, so the pixel is half the
/// background colour with one bounce, black with none, and black when `-weight` prunes a
/// ray of weight |(0.5, 0.5, 0.5)| = 0.866.
#[test]
fn reflection_weighted_by_the_reflective_colour() {
    let s = scene(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
         Background { color 0.2 0.4 0.8 }
         Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
         Materials { numMaterials 1 PhongMaterial { diffuseColor 0 0 0 reflectiveColor 0.5 0.5 0.5 } }
         Group { numObjects 1 MaterialIndex 0 Plane { normal 0 0 1 offset 0 } }",
    );
    let options = RenderOptions::all(1, 1);
    assert_eq!(raycaster::cpu::render(&s, &with(options, false, 0, 0.0)).color[0], [0.0, 0.0, 0.0]);
    assert_eq!(raycaster::cpu::render(&s, &with(options, false, 1, 0.0)).color[0], [0.1, 0.2, 0.4]);
    assert_eq!(raycaster::cpu::render(&s, &with(options, false, 1, 0.86)).color[0], [0.1, 0.2, 0.4]);
    assert_eq!(raycaster::cpu::render(&s, &with(options, false, 1, 0.87)).color[0], [0.0, 0.0, 0.0]);
}

/// Snell's law by hand: from index 1 into 1.5 at 45°, sin θt = sin 45° / 1.5; from 1.5 into
/// 1 at 60°, sin θt would be 1.5 · sin 60° = 1.3 > 1: total internal reflection, no ray.
#[test]
fn refraction_follows_snell_and_total_internal_reflection_spawns_nothing() {
    use raycaster::cpu::refract;
    let d = DVec3::new(1.0, 0.0, -1.0).normalize();
    let t = refract(d, DVec3::Z, 1.0, 1.5).expect("no TIR entering a denser medium");
    let sin_t = 0.5f64.sqrt() / 1.5;
    assert!((t - DVec3::new(sin_t, 0.0, -(1.0 - sin_t * sin_t).sqrt())).length() < 1e-12, "{t}");
    let steep = DVec3::new(60f64.to_radians().sin(), 0.0, -60f64.to_radians().cos());
    assert_eq!(refract(steep, DVec3::Z, 1.5, 1.0), None);
}

/// A fully transparent sphere (transparentColor 1 1 1, no diffuse) of index 1.5 seen dead
/// centre: the ray enters and leaves along the normal, unbent, so the pixel shows the
/// background, after two bounces (in, out), with -shade_back for the hit from inside.
/// With one bounce the refracted ray's first hit is the sphere's far side from inside,
/// which shades black (no diffuse, no further bounce).
#[test]
fn refraction_through_a_sphere_carries_the_index() {
    let s = scene(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
         Background { color 0.2 0.4 0.8 }
         Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }
         Materials { numMaterials 1 PhongMaterial { diffuseColor 0 0 0 transparentColor 1 1 1 indexOfRefraction 1.5 } }
         Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }",
    );
    let options =
        RenderOptions { shading: Shading { shade_back: true, ..Shading::default() }, ..RenderOptions::all(1, 1) };
    assert_eq!(raycaster::cpu::render(&s, &with(options, false, 1, 0.0)).color[0], [0.0, 0.0, 0.0]);
    assert_eq!(raycaster::cpu::render(&s, &with(options, false, 2, 0.0)).color[0], [0.2, 0.4, 0.8]);
}
