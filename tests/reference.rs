//! The f64 reference against values worked out by hand.

use glam::DVec3;
use raycaster::camera::{PrimaryRays, Ray};
use raycaster::render::RenderOptions;
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
    let ray = Ray { origin: DVec3::new(1.0, 0.0, 10.0), direction: DVec3::new(0.0, 0.0, -1.0) };
    let hit = raycaster::cpu::trace(&s, &ray, f64::NEG_INFINITY).expect("the ray hits");
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
    options.shade_back = true;
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
    let ray = Ray { origin: DVec3::new(0.0, 0.0, 10.0), direction: DVec3::new(0.0, 0.0, -1.0) };
    let hit = raycaster::cpu::trace(&s, &ray, f64::NEG_INFINITY).unwrap();
    // Object normal +z; M⁻ᵀ = diag(−1, 1, 1) leaves +z as it is.
    assert_eq!(hit.normal, DVec3::new(0.0, 0.0, 1.0));
}
