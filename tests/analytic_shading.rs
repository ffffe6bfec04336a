//! Assignment 4's shading against answers worked out without the renderer's ray tree, on the
//! f64 reference and on the GPU:
//!
//! - the shadow a directional light casts of a sphere on a plane is the analytic ellipse
//!   (the points whose line towards the light passes within the radius of the centre);
//! - a point light falls off as `C / (a0 + a1·d + a2·d²)`, and a shadow ray towards it ends
//!   at the light (a sphere beyond the light casts nothing);
//! - a transparent sphere of index 1.0 bends nothing: what is seen through it is what is
//!   seen without it, times its `transparentColor` once per surface crossed;
//! - a mirror floor shows the scene seen from the camera mirrored in the floor, flipped left
//!   to right, times its `reflectiveColor`.
//!
//! The first two are pure geometry. The last two are built from renders of simpler scenes
//! (no secondary rays: assignment 2's shading, which the course's images settle) by the f64
//! reference only, so the GPU is never its own oracle. Every comparison is in 8-bit levels
//! (`floor(255·v)`, docs/SPEC.md §5) under the project's contract: at most one checked pixel
//! in 1000 more than one level off.

mod common;

use glam::DVec3;
use raycaster::render::{Frame, RenderOptions, Shading};
use raycaster::scene::{parse_scene, Scene};
use std::path::Path;

const SIZE: u32 = 160;

fn scene(text: &str) -> Scene {
    parse_scene(text, Path::new("analytic.txt")).expect("the test's scene parses")
}

fn options(shading: Shading) -> RenderOptions {
    RenderOptions { shading, ..RenderOptions::all(SIZE, SIZE) }
}

/// The scene rendered by every backend: the f64 reference, and the GPU kernel.
fn renders(scene: &Scene, options: &RenderOptions) -> Vec<(&'static str, Frame)> {
    let mut frames = vec![("reference", raycaster::cpu::render(scene, options))];
    if let Some(gpu) = common::gpu() {
        frames.push(("gpu", gpu.render(scene, options).expect("the GPU renders the scene")));
    }
    frames
}

fn level(v: f64) -> i64 {
    (255.0 * v.clamp(0.0, 1.0)).floor() as i64
}

/// Counts the checked pixels whose colour is more than one level off `expected` (`None`:
/// the pixel is not checked) in some channel, and fails beyond one in 1000.
fn assert_matches(what: &str, frame: &Frame, expected: impl Fn(usize) -> Option<DVec3>) {
    let (mut checked, mut off, mut first) = (0usize, 0usize, None);
    for k in 0..frame.color.len() {
        let Some(want) = expected(k) else { continue };
        checked += 1;
        let got = frame.color[k];
        if (0..3).any(|c| (level(got[c] as f64) - level(want[c])).abs() > 1) {
            off += 1;
            first.get_or_insert((k, got, want));
        }
    }
    assert!(checked > frame.color.len() / 4, "{what}: only {checked} pixels checked");
    assert!(off <= checked / 1000, "{what}: {off} of {checked} pixels more than 1 level off; first {first:?}");
}

/// A camera looking straight down at the plane y = 0 from above, `VIEW` units wide, with
/// the image's up towards −z: pixel k sees the plane at the point this returns (docs/SPEC.md
/// §3: columns from the left, rows from the bottom, sampled at their centres;
/// `horizontal = direction × up` = +x).
const VIEW: f64 = 8.0;
const TOP_VIEW: &str = "OrthographicCamera { center 0 10 0 direction 0 -1 0 up 0 0 -1 size 8 }";

fn floor_point(k: usize) -> DVec3 {
    let (column, row_from_top) = ((k % SIZE as usize) as f64, (k / SIZE as usize) as f64);
    let x = (column + 0.5) / SIZE as f64;
    let y = (SIZE as f64 - 1.0 - row_from_top + 0.5) / SIZE as f64;
    DVec3::new((x - 0.5) * VIEW, 0.0, -(y - 0.5) * VIEW)
}

/// Where the ray from `origin` along unit `direction` meets the sphere, if it does at a
/// positive distance: the nearer root of the quadratic.
fn sphere_hits(origin: DVec3, direction: DVec3, centre: DVec3, radius: f64) -> Vec<f64> {
    let oc = origin - centre;
    let b = oc.dot(direction);
    let discriminant = b * b - (oc.length_squared() - radius * radius);
    if discriminant < 0.0 {
        return vec![];
    }
    let root = discriminant.sqrt();
    [-b - root, -b + root].into_iter().filter(|&t| t > 0.0).collect()
}

/// The sphere's shadow on the floor under a directional light is the set of points whose
/// line towards the light passes within `radius` of the centre: an ellipse, stretched by
/// 1/cos of the light's angle to the normal. Lit points get ambient + diffuse·(N·L), shadowed
/// ones the ambient alone. Pixels whose centre lies within 1/16 of a pixel of the ellipse's
/// edge, and those that see the sphere, are not checked.
#[test]
fn a_spheres_shadow_on_a_plane_is_the_analytic_ellipse() {
    let text = format!(
        "{TOP_VIEW}
         Lights {{ numLights 1 DirectionalLight {{ direction -1 -1 -0.5 color 0.7 0.7 0.7 }} }}
         Background {{ color 0 0 0 ambientLight 0.2 0.2 0.2 }}
         Materials {{ numMaterials 2
           PhongMaterial {{ diffuseColor 0.8 0.6 0.4 }}
           PhongMaterial {{ diffuseColor 0.2 0.4 0.9 specularColor 1 1 1 exponent 30 }} }}
         Group {{ numObjects 2 MaterialIndex 0 Plane {{ normal 0 1 0 offset 0 }}
           MaterialIndex 1 Sphere {{ center 0 1.5 0 radius 0.6 }} }}"
    );
    let (centre, radius) = (DVec3::new(0.0, 1.5, 0.0), 0.6);
    let to_light = DVec3::new(1.0, 1.0, 0.5).normalize();
    let diffuse = DVec3::new(0.8, 0.6, 0.4);
    let (lit, shadowed) = (diffuse * 0.2 + diffuse * 0.7 * to_light.y, diffuse * 0.2);
    let pixel_width = VIEW / SIZE as f64;
    let expected = |k: usize| {
        let p = floor_point(k);
        if (p.x * p.x + p.z * p.z).sqrt() < radius + pixel_width {
            return None; // the sphere itself, seen from above
        }
        let from_centre = centre - p;
        let miss_distance = (from_centre - from_centre.dot(to_light) * to_light).length();
        if (miss_distance - radius).abs() < pixel_width / 16.0 {
            return None; // within rounding of the edge
        }
        Some(if miss_distance < radius { shadowed } else { lit })
    };
    let in_shadow = (0..(SIZE * SIZE) as usize).filter(|&k| expected(k) == Some(shadowed)).count();
    // π·0.6·0.9 square units at 0.05² per pixel, less the edge: the test sees a real shadow.
    assert!(in_shadow > 500, "{in_shadow} shadowed pixels checked");
    let shading = Shading { shadows: true, ..Shading::default() };
    for (backend, frame) in renders(&scene(&text), &options(shading)) {
        assert_matches(&format!("{backend}, shadow ellipse"), &frame, expected);
    }
}

/// A point light half a unit above the floor, a sphere above and beside it. The floor gets
/// `C·diffuse·(N·L) / (a0 + a1·d + a2·d²)` plus the ambient term everywhere the segment to
/// the light is clear. The sphere lies beyond the light for a patch of the floor (the line
/// from there through the light goes on to meet it): that patch is lit, since a shadow ray
/// towards a point light ends at the light.
#[test]
fn point_light_falls_off_by_its_attenuation_and_shadow_rays_end_at_it() {
    let text = format!(
        "{TOP_VIEW}
         Lights {{ numLights 1 PointLight {{ position 1.5 0.5 0 color 1 0.8 0.6 attenuation 0.5 0.4 0.9 }} }}
         Background {{ color 0 0 0 ambientLight 0.1 0.1 0.1 }}
         Materials {{ numMaterials 2
           PhongMaterial {{ diffuseColor 0.9 0.9 0.9 }}
           PhongMaterial {{ diffuseColor 0.5 0.5 0.5 }} }}
         Group {{ numObjects 2 MaterialIndex 0 Plane {{ normal 0 1 0 offset 0 }}
           MaterialIndex 1 Sphere {{ center 0 1.5 0 radius 0.8 }} }}"
    );
    let (light, colour) = (DVec3::new(1.5, 0.5, 0.0), DVec3::new(1.0, 0.8, 0.6));
    let (centre, radius) = (DVec3::new(0.0, 1.5, 0.0), 0.8);
    let diffuse = DVec3::splat(0.9);
    let pixel_width = VIEW / SIZE as f64;
    let beyond_the_light = |k: usize| {
        let p = floor_point(k);
        let d = (light - p).length();
        sphere_hits(p, (light - p) / d, centre, radius).iter().any(|&t| t > d)
    };
    let expected = |k: usize| {
        let p = floor_point(k);
        if (p.x * p.x + p.z * p.z).sqrt() < radius + pixel_width {
            return None; // the sphere itself, seen from above
        }
        let d = (light - p).length();
        let blocked = sphere_hits(p, (light - p) / d, centre, radius).iter().any(|&t| t < d);
        let lit = (colour * diffuse) * ((light.y - p.y) / d) / (0.5 + 0.4 * d + 0.9 * d * d);
        Some(diffuse * 0.1 + if blocked { DVec3::ZERO } else { lit })
    };
    let behind = (0..(SIZE * SIZE) as usize).filter(|&k| expected(k).is_some() && beyond_the_light(k)).count();
    assert!(behind > 300, "only {behind} checked pixels have the sphere beyond the light");
    let shading = Shading { shadows: true, ..Shading::default() };
    for (backend, frame) in renders(&scene(&text), &options(shading)) {
        assert_matches(&format!("{backend}, point light"), &frame, expected);
    }
}

const BEHIND: &str = "
  MaterialIndex 0 Plane { normal 0 1 0 offset -1 }
  MaterialIndex 1 Sphere { center -1.2 0 -4 radius 1 }
  MaterialIndex 2 Sphere { center 1.3 0.3 -5 radius 1.3 }
  MaterialIndex 3 Transform { Translate 0.2 -0.5 -3.2 YRotate 30 Scale 0.5 0.5 0.5
    TriangleMesh { obj_file none } }";

fn three_colours_and(material: &str, camera: &str, objects: &str, count: usize) -> Scene {
    let cube = "Triangle { vertex0 -1 -1 1 vertex1 1 -1 1 vertex2 1 1 1 }
                Triangle { vertex0 -1 -1 1 vertex1 1 1 1 vertex2 -1 1 1 }";
    scene(&format!(
        "{camera}
         Lights {{ numLights 2
           DirectionalLight {{ direction -0.3 -1 -0.5 color 0.7 0.7 0.7 }}
           DirectionalLight {{ direction 0.5 -0.4 -1 color 0.3 0.25 0.2 }} }}
         Background {{ color 0.2 0.1 0.5 ambientLight 0.1 0.1 0.1 }}
         Materials {{ numMaterials 5
           PhongMaterial {{ diffuseColor 0.9 0.9 0.9 }}
           PhongMaterial {{ diffuseColor 1 0.2 0.1 }}
           PhongMaterial {{ diffuseColor 0.1 0.9 0.3 }}
           PhongMaterial {{ diffuseColor 0.2 0.3 1 }}
           {material} }}
         Group {{ numObjects {count} {} }}",
        objects.replace("TriangleMesh { obj_file none }", &format!("Group {{ numObjects 2 {cube} }}"))
    ))
}

/// Seen through a sphere of index 1.0 whose only term is its `transparentColor` T, the scene
/// behind is unchanged but for T, once entering and once leaving: T² ∗ the image without the
/// sphere. The sphere's outline comes from a render of it alone.
#[test]
fn a_sphere_of_index_one_leaves_what_is_behind_it_unchanged() {
    let camera = "PerspectiveCamera { center 0 1 5 direction 0 -0.2 -1 up 0 1 0 angle 40 }";
    let glass = "PhongMaterial { diffuseColor 0 0 0 transparentColor 0.7 0.6 0.5 indexOfRefraction 1.0 }";
    let sphere = "MaterialIndex 4 Sphere { center 0.1 0.2 -1 radius 1.1 }";
    let with_it = three_colours_and(glass, camera, &format!("{BEHIND} {sphere}"), 5);
    let without = three_colours_and(glass, camera, BEHIND, 4);
    let alone = three_colours_and(glass, camera, sphere, 1);
    let plain = options(Shading::default());
    let (without, outline) = (raycaster::cpu::render(&without, &plain), raycaster::cpu::render(&alone, &plain));
    let through = DVec3::new(0.7, 0.6, 0.5).powf(2.0);
    let seen = |k: usize| DVec3::from_array(without.color[k].map(f64::from));
    let expected = |k: usize| Some(if outline.hit[k] { through * seen(k) } else { seen(k) });
    let covered = outline.hit.iter().filter(|&&h| h).count();
    assert!(covered > (SIZE * SIZE / 8) as usize, "the sphere covers {covered} pixels");
    let shading = Shading { shade_back: true, bounces: 5, weight: 0.01, ..Shading::default() };
    for (backend, frame) in renders(&with_it, &options(shading)) {
        assert_matches(&format!("{backend}, sphere of index 1.0"), &frame, expected);
    }
}

/// A mirror floor y = −1.2, below every object, with `reflectiveColor` R and no other term: where the camera's ray
/// meets the floor first, the pixel is R ∗ what the camera mirrored in the floor sees of the
/// scene without the floor. Mirroring reverses handedness, so the mirrored camera's
/// `horizontal = direction × up` points the other way: its image is flipped left to right
/// (docs/SPEC.md §3: x' = 1 − x). Elsewhere the pixel is the scene without the floor.
#[test]
fn a_mirror_floor_shows_the_mirrored_scene() {
    let camera = "PerspectiveCamera { center 0 1 5 direction 0 -0.35 -1 up 0 1 0 angle 40 }";
    let mirrored = "PerspectiveCamera { center 0 -3.4 5 direction 0 0.35 -1 up 0 -1 0 angle 40 }";
    let mirror = "PhongMaterial { diffuseColor 0 0 0 reflectiveColor 0.9 0.8 0.7 }";
    let objects = BEHIND.replace("MaterialIndex 0 Plane { normal 0 1 0 offset -1 }", "");
    let floor = "MaterialIndex 4 Plane { normal 0 1 0 offset -1.2 }";
    let with_floor = three_colours_and(mirror, camera, &format!("{objects} {floor}"), 4);
    let plain = options(Shading::default());
    let direct = raycaster::cpu::render(&three_colours_and(mirror, camera, &objects, 3), &plain);
    let reflected = raycaster::cpu::render(&three_colours_and(mirror, mirrored, &objects, 3), &plain);
    let floor_seen = raycaster::cpu::render(&three_colours_and(mirror, camera, floor, 1), &plain);
    let reflectance = DVec3::new(0.9, 0.8, 0.7);
    let side = SIZE as usize;
    let expected = |k: usize| {
        let colour = |frame: &Frame, k: usize| DVec3::from_array(frame.color[k].map(f64::from));
        Some(if direct.hit[k] || !floor_seen.hit[k] {
            colour(&direct, k)
        } else {
            let (row, column) = (k / side, k % side);
            reflectance * colour(&reflected, row * side + side - 1 - column)
        })
    };
    let mirrored_objects = (0..side * side)
        .filter(|&k| !direct.hit[k] && floor_seen.hit[k] && reflected.hit[k - k % side + side - 1 - k % side])
        .count();
    assert!(mirrored_objects > (SIZE * SIZE / 20) as usize, "the floor mirrors objects on {mirrored_objects} pixels");
    let shading = Shading { bounces: 1, weight: 0.01, ..Shading::default() };
    for (backend, frame) in renders(&with_floor, &options(shading)) {
        assert_matches(&format!("{backend}, mirror floor"), &frame, expected);
    }
}

/// A glass sphere of index 1.0, radius 0.005, seen head-on from 30 units away, lit from the
/// side by a directional light. The camera's ray crosses it without bending and meets the
/// back from inside; there (`-shade_back`) every light on the inner side of the surface is
/// hidden by the sphere itself, which the shadow ray must cross again to leave it: the back
/// gets the ambient term alone, however grazing the light. The kernel moves a shadow ray
/// off the surface along itself by 2⁵ ulps of the point's magnitude (30 here) over the
/// cosine c of its angle to the surface, and the chord through the sphere is 2·r·c: below
/// c ≈ 0.075 the moved ray started beyond the chord, and the kernel lit a stripe of the back
/// that the sphere hides (about 5 % of the disc, up to 8 levels off). A random scene found it
/// (a shadow ray 0.0036 off a sphere of radius 1.36, 27 units from the camera).
///
/// Each pixel is ambient·diffuse twice (front and back, the front's refracted ray carrying
/// the back at full weight) plus the front's Lambert term; rims within a pixel of the
/// outline are not checked. An ellipsoid (the sphere stretched along the view) has the same
/// back, lit by nothing; it is judged against the reference's image.
#[test]
fn a_glass_spheres_back_is_in_its_own_shadow_however_grazing_the_light() {
    const SIDE: f64 = 0.0125;
    let text = |object: &str| {
        format!(
            "OrthographicCamera {{ center 0 0 30 direction 0 0 -1 up 0 1 0 size {SIDE} }}
             Lights {{ numLights 1 DirectionalLight {{ direction -1 0 0 color 0.5 0.5 0.5 }} }}
             Background {{ color 0 0 0 ambientLight 0.2 0.2 0.2 }}
             Materials {{ numMaterials 1
               PhongMaterial {{ diffuseColor 0.9 0.7 0.5 transparentColor 1 1 1 indexOfRefraction 1 }} }}
             Group {{ numObjects 1 MaterialIndex 0 {object} }}"
        )
    };
    let radius = 0.005;
    let sphere = scene(&text(&format!("Sphere {{ center 0 0 0 radius {radius} }}")));
    let diffuse = DVec3::new(0.9, 0.7, 0.5);
    let pixel = SIDE / SIZE as f64;
    let expected = |k: usize| {
        let (column, row_from_top) = ((k % SIZE as usize) as f64, (k / SIZE as usize) as f64);
        let x = ((column + 0.5) / SIZE as f64 - 0.5) * SIDE;
        let y = ((SIZE as f64 - 1.0 - row_from_top + 0.5) / SIZE as f64 - 0.5) * SIDE;
        let rho = (x * x + y * y).sqrt();
        if (rho - radius).abs() < pixel {
            return None; // the outline
        }
        if rho > radius {
            return Some(DVec3::ZERO);
        }
        let front_lambert = (x / radius).max(0.0) * 0.5;
        Some(diffuse * (0.2 + front_lambert) + diffuse * 0.2)
    };
    let grazing_back = (0..(SIZE * SIZE) as usize)
        .filter(|&k| expected(k).is_some_and(|c| c != DVec3::ZERO))
        .filter(|&k| {
            let column = (k % SIZE as usize) as f64;
            let x = ((column + 0.5) / SIZE as f64 - 0.5) * SIDE;
            (-0.075..-0.017).contains(&(x / radius))
        })
        .count();
    // The stripe where the back's cosine to the light is 0.017 to 0.075 (2 to 8 levels).
    assert!(grazing_back > 300, "{grazing_back} pixels in the grazing stripe");
    let shading = Shading { shade_back: true, shadows: true, bounces: 1, ..Shading::default() };
    for (backend, frame) in renders(&sphere, &options(shading)) {
        assert_matches(&format!("{backend}, glass sphere's back"), &frame, expected);
    }

    let ellipsoid = scene(&text(&format!("Transform {{ Scale 1 1 3 Sphere {{ center 0 0 0 radius {radius} }} }}")));
    let reference = raycaster::cpu::render(&ellipsoid, &options(shading));
    let seen = |k: usize| DVec3::from_array(reference.color[k].map(f64::from));
    for (backend, frame) in renders(&ellipsoid, &options(shading)).into_iter().skip(1) {
        assert_matches(&format!("{backend}, glass ellipsoid's back"), &frame, |k| expected(k).map(|_| seen(k)));
    }
}
