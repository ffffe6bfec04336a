//! Scene front end through its public API: the course scenes, every block and option, the
//! error locations, deep nesting, and property tests that no input makes it panic.

use glam::{DMat4, DVec3};
use proptest::prelude::*;
use raycaster::scene::{
    load_obj, load_scene, obj_file_names, parse_obj, parse_scene, parse_scene_with, Light, Location, Material,
    ObjFiles, Object, PointLight, Projection, Scene, SceneError, Shape, MAX_NESTING,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;

mod common;

// ---------------------------------------------------------------------------------------
// helpers

/// The course's `a2/` folder, or `None` in a bare clone (the test then skips, with one notice
/// per test binary: see [`common::corpus`]).
fn course_dir() -> Option<PathBuf> {
    common::corpus().map(|corpus| corpus.join("a2"))
}

fn course_scene(a2: &Path, name: &str) -> Scene {
    load_scene(&a2.join(name)).unwrap_or_else(|e| panic!("{e}"))
}

/// One-line blocks, so the body of a test scene starts on line 4.
const CAMERA: &str = "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }";
const LIGHTS: &str = "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }";
const MATERIALS: &str = "Materials { numMaterials 2 Material { diffuseColor 1 0 0 } Material { } }";

fn with_header(body: &[&str]) -> String {
    let mut lines = vec![CAMERA, LIGHTS, MATERIALS];
    lines.extend_from_slice(body);
    lines.join("\n")
}

fn parse(text: &str) -> Scene {
    parse_scene(text, Path::new("test.txt")).unwrap_or_else(|e| panic!("{e}"))
}

fn parse_err(text: &str) -> SceneError {
    match parse_scene(text, Path::new("test.txt")) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

/// Asserts the error's exact location and that its message contains `needle`.
fn assert_error_at(text: &str, line: u32, col: u32, needle: &str) -> SceneError {
    let error = parse_err(text);
    assert_eq!(error.location, Some(Location { line, col }), "{error}");
    assert!(error.message.contains(needle), "`{needle}` not in: {error}");
    error
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).abs().max_element() < 1e-12
}

fn only_object(scene: &Scene) -> &Object {
    assert_eq!(scene.root.len(), 1);
    &scene.root[0]
}

fn transform_of(object: &Object) -> (DMat4, &Object) {
    match &object.shape {
        Shape::Transform { matrix, child } => (*matrix, child),
        other => panic!("expected a Transform, got {other:?}"),
    }
}

/// The material of every leaf, in file order.
fn leaf_materials(objects: &[Object]) -> Vec<u32> {
    let mut out = Vec::new();
    for object in objects {
        match &object.shape {
            Shape::Group(children) => out.extend(leaf_materials(children)),
            Shape::Transform { child, .. } => out.extend(leaf_materials(std::slice::from_ref(&**child))),
            Shape::Sphere { material, .. }
            | Shape::Plane { material, .. }
            | Shape::Triangle { material, .. }
            | Shape::Mesh { material, .. } => out.push(*material),
        }
    }
    out
}

fn count_lines_starting(path: &Path, prefix: &str) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().filter(|l| l.starts_with(prefix)).count()
}

/// Runs `f` on a thread with a 2 MiB stack (the default for spawned threads), so a stack
/// overflow there proves the parser needs more than an ordinary thread has.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new().stack_size(2 << 20).spawn(f).unwrap().join().unwrap()
}

// ---------------------------------------------------------------------------------------
// the course scenes

#[test]
fn all_sixteen_course_scenes_parse() {
    let Some(a2) = course_dir() else { return };
    let mut names: Vec<_> = std::fs::read_dir(&a2)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with("scene2_") && n.ends_with(".txt"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 16);
    for name in &names {
        let scene = course_scene(&a2, name);
        assert!(orthonormal(scene.camera.frame()), "{name}");
        assert!(!scene.lights.is_empty(), "{name}");
        assert!(!scene.root.is_empty(), "{name}");
        assert!(scene.warnings.is_empty(), "{name}: {:?}", scene.warnings);
        assert!(leaf_materials(&scene.root).iter().all(|&m| (m as usize) < scene.materials.len()), "{name}");
    }
}

#[test]
fn scene2_01_values() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_01_diffuse.txt");
    let camera = scene.camera;
    assert_eq!(camera.projection, Projection::Orthographic { size: 5.0 });
    assert_eq!(camera.center, DVec3::new(0.0, 0.0, 10.0));
    assert_eq!(camera.direction, DVec3::new(0.0, 0.0, -1.0));
    assert_eq!(camera.up, DVec3::Y);
    assert_eq!(camera.location, Location { line: 2, col: 1 });
    assert_eq!(scene.lights.len(), 1);
    assert_eq!(dir_of(&scene.lights[0]), DVec3::new(-0.5, -0.5, -1.0));
    assert_eq!(scene.lights[0].color(), DVec3::ONE);
    assert_eq!(scene.background.color, DVec3::new(0.2, 0.0, 0.6));
    assert_eq!(scene.background.ambient, DVec3::ZERO);
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(scene.materials[0].diffuse, DVec3::X);
    let sphere = only_object(&scene);
    assert!(matches!(sphere.shape, Shape::Sphere { center: DVec3::ZERO, radius: 1.0, material: 0 }));
    assert_eq!(sphere.location, Location { line: 32, col: 5 });
}

#[test]
fn scene2_03_blocks_in_another_order() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_03_colored_lights.txt");
    assert_eq!(scene.lights.len(), 3);
    assert_eq!(dir_of(&scene.lights[1]), DVec3::new(-0.5, -1.0, 0.0));
    assert_eq!(scene.lights[1].color(), DVec3::new(0.0, 0.0, 0.8));
    assert_eq!(scene.background.color, DVec3::ONE);
    assert_eq!(scene.background.ambient, DVec3::splat(0.2));
    assert_eq!(scene.camera.direction, DVec3::new(0.0, -1.0, -1.0));
    assert_eq!(scene.camera.projection, Projection::Orthographic { size: 2.5 });
}

#[test]
fn scene2_04_perspective_and_material_indices() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_04_perspective.txt");
    assert_eq!(scene.camera.projection, Projection::Perspective { angle: 30f64.to_radians() });
    assert_eq!(scene.materials.len(), 3);
    assert_eq!(scene.materials[2].diffuse, DVec3::Z);
    assert_eq!(leaf_materials(&scene.root), vec![0, 1, 1, 2, 2]);
    assert!(matches!(scene.root[2].shape, Shape::Sphere { radius: 0.75, .. }));
    if let Shape::Sphere { center, .. } = scene.root[2].shape {
        assert_eq!(center, DVec3::new(-1.0, -1.0, 1.0));
    }
}

#[test]
fn scene2_05_inside_sphere() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_05_inside_sphere.txt");
    assert_eq!(scene.camera.projection, Projection::Perspective { angle: 45f64.to_radians() });
    let radii: Vec<f64> = scene
        .root
        .iter()
        .map(|o| match o.shape {
            Shape::Sphere { radius, .. } => radius,
            _ => panic!("not a sphere"),
        })
        .collect();
    assert_eq!(radii, vec![6.0, 1.0, 1.0]);
    assert!(matches!(scene.root[0].shape, Shape::Sphere { center: DVec3 { z: 5.0, .. }, .. }));
    assert_eq!(scene.background.color, DVec3::ZERO);
}

#[test]
fn scene2_06_plane_and_scene2_07_triangles() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_06_plane.txt");
    assert_eq!(scene.root.len(), 6);
    assert!(matches!(scene.root[5].shape, Shape::Plane { normal: DVec3::Y, offset: -2.0, material: 3 }));

    let scene = course_scene(&a2, "scene2_07_sphere_triangles.txt");
    match &scene.root[2].shape {
        Shape::Triangle { vertices, material } => {
            assert_eq!(
                *vertices,
                [DVec3::new(-2.0, -0.2, 0.0), DVec3::new(2.0, -0.2, 0.0), DVec3::new(0.0, -2.0, 0.0)]
            );
            assert_eq!(*material, 2);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn course_meshes_have_one_triangle_per_face_line() {
    let Some(a2) = course_dir() else { return };
    for (scene_name, obj_name) in [
        ("scene2_08_cube.txt", "cube.obj"),
        ("scene2_09_bunny_200.txt", "bunny_200.obj"),
        ("scene2_10_bunny_1k.txt", "bunny_1k.obj"),
    ] {
        let scene = course_scene(&a2, scene_name);
        let mut object = only_object(&scene);
        while let Shape::Transform { child, .. } = &object.shape {
            object = child;
        }
        let Shape::Mesh { mesh, material: 0 } = &object.shape else { panic!("{scene_name}: {object:?}") };
        let obj_path = a2.join(obj_name);
        assert_eq!(mesh.triangles.len(), count_lines_starting(&obj_path, "f "), "{scene_name}");
        assert_eq!(mesh.positions.len(), count_lines_starting(&obj_path, "v "), "{scene_name}");
    }
    let bunny = course_scene(&a2, "scene2_10_bunny_1k.txt");
    assert_eq!(bunny.camera.center, DVec3::new(0.0, 0.8, 5.0));
    let (matrix, _) = transform_of(only_object(&bunny));
    // UniformScale 5 then (applied first) Translate 0.03 -0.0666 0.
    let p = matrix.transform_point3(DVec3::ZERO);
    assert!(close(p, DVec3::new(0.15, -0.333, 0.0)), "{p}");
}

#[test]
fn scene2_12_rotation_and_scene2_13_order() {
    let Some(a2) = course_dir() else { return };
    let (matrix, _) = transform_of(only_object(&course_scene(&a2, "scene2_12_rotated_sphere.txt")));
    let s = 0.5f64.sqrt();
    assert!(close(matrix.transform_point3(DVec3::X), DVec3::new(s, s, 0.0)));

    // ZRotate 45 Scale 1 0.2 1: the squash happens first, then the rotation.
    let (matrix, _) = transform_of(only_object(&course_scene(&a2, "scene2_13_rotated_squashed_sphere.txt")));
    assert!(close(matrix.transform_point3(DVec3::Y), DVec3::new(-0.2 * s, 0.2 * s, 0.0)));
}

#[test]
fn scene2_14_nested_groups_share_one_mesh() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_14_axes_cube.txt");
    assert_eq!(scene.camera.direction, DVec3::new(-0.16, -0.12, -0.5));
    assert_eq!(scene.root.len(), 2);
    let Shape::Group(axes) = &scene.root[0].shape else { panic!() };
    assert_eq!(axes.len(), 3);
    assert_eq!(leaf_materials(&scene.root), vec![0, 1, 2, 3]);
    let mut meshes = Vec::new();
    for object in axes.iter().chain(&scene.root[1..]) {
        let (_, child) = transform_of(object);
        let Shape::Mesh { mesh, .. } = &child.shape else { panic!() };
        meshes.push(Arc::clone(mesh));
    }
    assert!(meshes.iter().all(|m| Arc::ptr_eq(m, &meshes[0])));
    assert_eq!(meshes[0].triangles.len(), 12);
    // The x axis: Translate 5 0 0 · Scale 5 0.2 0.2 stretches the cube's corner (1,1,1).
    let (x_axis, _) = transform_of(&axes[0]);
    assert!(close(x_axis.transform_point3(DVec3::ONE), DVec3::new(10.0, 0.2, 0.2)));
}

#[test]
fn scene2_15_and_16_transforms_and_materials() {
    let Some(a2) = course_dir() else { return };
    let scene = course_scene(&a2, "scene2_15_crazy_transforms.txt");
    assert_eq!(leaf_materials(&scene.root), vec![0, 1]);
    let (outer, group) = transform_of(only_object(&scene));
    let Shape::Group(children) = &group.shape else { panic!() };
    assert_eq!(children.len(), 2);
    // UniformScale 0.5 · XRotate 20 · Translate -3 0 0 keeps x of the origin's image at -1.5.
    assert!((outer.transform_point3(DVec3::ZERO).x + 1.5).abs() < 1e-12);

    let scene = course_scene(&a2, "scene2_16_t_scale.txt");
    assert_eq!(scene.root.len(), 6);
    assert_eq!(leaf_materials(&scene.root), vec![3, 0, 1, 2, 4, 5]);
    assert_eq!(scene.camera.projection, Projection::Orthographic { size: 5.5 });
}

#[test]
fn large_meshes_load_including_crlf() {
    let Some(corpus) = common::corpus() else { return };
    let meshes = corpus.join("meshes");
    let bunny = load_obj(&meshes.join("bunny_40k.obj")).unwrap();
    assert_eq!(bunny.triangles.len(), 40_000);
    assert_eq!(bunny.positions.len(), 20_002);
    let teapot = load_obj(&meshes.join("teapot_high.obj")).unwrap(); // CRLF line ends
    assert_eq!(teapot.triangles.len(), 44_400);
    assert_eq!(teapot.positions.len(), 23_040);
}

// ---------------------------------------------------------------------------------------
// blocks and options

#[test]
fn perspective_camera_angle_is_stored_in_radians() {
    let scene = parse("PerspectiveCamera { up 0 1 0 angle 90 center 1 2 3 direction 0 0 -2 }");
    assert_eq!(scene.camera.projection, Projection::Perspective { angle: std::f64::consts::FRAC_PI_2 });
    assert_eq!(scene.camera.center, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.camera.direction, DVec3::new(0.0, 0.0, -2.0));
}

#[test]
fn c_style_numbers_and_comments_and_glued_braces() {
    let scene = parse(
        "# a comment line\nOrthographicCamera{center -.5 +2. 1e-3 direction 0 0 -1 up 0 1 0 size 5}# trailing\n\
         Lights{numLights 0}Background{color 1E1 0 0}",
    );
    assert_eq!(scene.camera.center, DVec3::new(-0.5, 2.0, 0.001));
    assert_eq!(scene.background.color, DVec3::new(10.0, 0.0, 0.0));
}

#[test]
fn no_lights_means_flat_ambient_with_a_warning() {
    let scene = parse(CAMERA);
    assert!(scene.lights.is_empty() && scene.root.is_empty() && scene.materials.is_empty());
    assert_eq!(scene.background.ambient, DVec3::ONE);
    assert_eq!(scene.background.color, DVec3::splat(0.5));
    assert_eq!(scene.warnings.len(), 1);
    // No Lights block: the warning is about the file as a whole, as "no camera" is.
    assert_eq!(scene.warnings[0].to_string(), "test.txt: warning: no lights: ambient light set to 1 1 1 (flat colour)");

    let scene = parse(&format!("{CAMERA} Lights {{ numLights 0 }} Background {{ ambientLight 0.2 0.3 0.4 }}"));
    assert_eq!(scene.background.ambient, DVec3::ONE);
    // An empty Lights block: the warning points at it.
    let lights_col = CAMERA.chars().count() as u32 + 2;
    assert_eq!(scene.warnings[0].location, Some(Location { line: 1, col: lights_col }));
    assert!(scene.warnings[0].message.contains("ambientLight 0.2 0.3 0.4"), "{:?}", scene.warnings);

    // With lights, the file's ambient light stays.
    let scene = parse(&format!("{CAMERA} {LIGHTS} Background {{ ambientLight 0.2 0.3 0.4 }}"));
    assert_eq!(scene.background.ambient, DVec3::new(0.2, 0.3, 0.4));
    assert!(scene.warnings.is_empty());
}

#[test]
fn lights_and_background_fields() {
    let scene = parse(&format!(
        "{CAMERA} Lights {{ numLights 2 DirectionalLight {{ color 1 0 0 direction 1 2 3 }} \
         DirectionalLight {{ direction 0 -1 0 color 0 0 1 }} }} Background {{ ambientLight 0.1 0.1 0.1 color 0 1 0 }}"
    ));
    assert_eq!(scene.lights.len(), 2);
    assert_eq!(dir_of(&scene.lights[0]), DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.lights[0].color(), DVec3::X);
    assert_eq!(scene.lights[1].color(), DVec3::Z);
    assert_eq!(scene.background.color, DVec3::Y);
    assert_eq!(scene.background.ambient, DVec3::splat(0.1));
    // Background fields are optional: the defaults stay.
    let scene = parse(&format!("{CAMERA} {LIGHTS} Background {{ }}"));
    assert_eq!(scene.background.color, DVec3::splat(0.5));
    assert_eq!(scene.background.ambient, DVec3::ZERO);
}

/// The direction of a light the test knows to be directional.
fn dir_of(light: &raycaster::scene::Light) -> DVec3 {
    light.directional().expect("a DirectionalLight").direction
}

#[test]
fn materials_default_colour_and_phong_terms_without_warning() {
    // `Material` is a synonym of `PhongMaterial` (GRAMMAR.md A3): the same fields.
    let scene = parse(&format!(
        "{CAMERA} {LIGHTS} Materials {{ numMaterials 3 Material {{ }} \
         PhongMaterial {{ diffuseColor 0.1 0.2 0.3 specularColor 1 0.5 0.25 exponent 20 reflectiveColor 0.4 0 0 \
         transparentColor 0 0.6 0 indexOfRefraction 1.5 }} Material {{ }} }}"
    ));
    // Every term as written; what a file leaves out takes the course parser's defaults
    // (GRAMMAR.md, A3 and A4): diffuse 1 1 1, exponent 1, index 1, the colours 0 0 0.
    let defaults = Material {
        diffuse: DVec3::ONE,
        specular: DVec3::ZERO,
        exponent: 1.0,
        reflective: DVec3::ZERO,
        transparent: DVec3::ZERO,
        index_of_refraction: 1.0,
    };
    let phong = Material {
        diffuse: DVec3::new(0.1, 0.2, 0.3),
        specular: DVec3::new(1.0, 0.5, 0.25),
        exponent: 20.0,
        reflective: DVec3::new(0.4, 0.0, 0.0),
        transparent: DVec3::new(0.0, 0.6, 0.0),
        index_of_refraction: 1.5,
    };
    assert_eq!(scene.materials, vec![defaults, phong, defaults]);
    // The reference shades every term now: nothing to warn about.
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // Each material's keyword is where the GPU's refusal points.
    let first = format!("{CAMERA} {LIGHTS} Materials {{ numMaterials 3 ").chars().count() as u32 + 1;
    assert_eq!(scene.material_locations[0], Location { line: 1, col: first });
    assert_eq!(scene.material_locations.len(), 3);
    // `Material` takes every PhongMaterial field.
    let synonym = parse(&format!(
        "{CAMERA} {LIGHTS} Materials {{ numMaterials 1 Material {{ diffuseColor 0.1 0.2 0.3 specularColor 1 0.5 0.25 \
         exponent 20 reflectiveColor 0.4 0 0 transparentColor 0 0.6 0 indexOfRefraction 1.5 }} }}"
    ));
    assert_eq!(synonym.materials, vec![phong]);
}

#[test]
fn point_lights_in_file_order_with_default_attenuation() {
    let scene = parse(&format!(
        "{CAMERA} Lights {{ numLights 3 PointLight {{ position 1 2 3 color 0.5 0.5 0.5 }} \
         DirectionalLight {{ direction 0 -1 0 color 0 0 1 }} \
         PointLight {{ attenuation 0 0.2 0.05 color 1 0 0 position -1 0 0 }} }}"
    ));
    let col = format!("{CAMERA} Lights {{ numLights 3 ").chars().count() as u32 + 1;
    assert_eq!(
        scene.lights[0],
        Light::Point(PointLight {
            position: DVec3::new(1.0, 2.0, 3.0),
            color: DVec3::splat(0.5),
            attenuation: DVec3::new(1.0, 0.0, 0.0),
            location: Location { line: 1, col },
        })
    );
    assert_eq!(dir_of(&scene.lights[1]), DVec3::NEG_Y);
    match scene.lights[2] {
        Light::Point(light) => {
            assert_eq!(light.attenuation, DVec3::new(0.0, 0.2, 0.05));
            assert_eq!(light.position, DVec3::NEG_X);
        }
        other => panic!("expected a PointLight, found {other:?}"),
    }
}

#[test]
fn point_light_errors_are_located() {
    let head = format!("{CAMERA} Lights {{ numLights 1 PointLight {{ position 0 0 0 color 1 1 1 ");
    let at = head.chars().count() as u32;
    // The first coefficient's place, after `attenuation `.
    let col = at + "attenuation ".len() as u32 + 1;
    for (rest, message) in [
        ("attenuation 0 0 0 } }", "attenuation must be three coefficients ≥ 0, not all 0, found 0 0 0"),
        ("attenuation 1 -0.5 0 } }", "attenuation must be three coefficients ≥ 0, not all 0, found 1 -0.5 0"),
    ] {
        let error = assert_error_at(&format!("{head}{rest}"), 1, col, message);
        assert_eq!(error.to_string(), format!("test.txt:1:{col}: {message}"));
    }
    let error = parse_err(&format!("{CAMERA} Lights {{ numLights 1 PointLight {{ color 1 1 1 }} }}"));
    assert!(error.message.contains("PointLight is missing `position`"), "{error}");
    let error = parse_err(&format!("{CAMERA} Lights {{ numLights 1 SpotLight {{ }} }}"));
    assert!(error.message.contains("DirectionalLight or PointLight"), "{error}");
}

#[test]
fn objects_fields_in_any_order() {
    let scene = parse(&with_header(&[
        "Group { numObjects 4 MaterialIndex 1",
        "Sphere { radius 2 center 1 2 3 }",
        "Plane { offset -1 normal 0 0 2 }",
        "Triangle { vertex2 0 1 0 vertex0 0 0 0 vertex1 1 0 0 }",
        "Group { numObjects 0 }",
        "}",
    ]));
    assert_eq!(scene.root.len(), 4);
    assert!(matches!(
        scene.root[0].shape,
        Shape::Sphere { center: DVec3 { x: 1.0, y: 2.0, z: 3.0 }, radius: 2.0, material: 1 }
    ));
    assert!(matches!(scene.root[1].shape, Shape::Plane { normal: DVec3 { z: 2.0, .. }, offset: -1.0, material: 1 }));
    assert!(matches!(
        scene.root[2].shape,
        Shape::Triangle { vertices: [DVec3::ZERO, DVec3::X, DVec3::Y], material: 1 }
    ));
    assert!(matches!(&scene.root[3].shape, Shape::Group(children) if children.is_empty()));
    assert_eq!(scene.root[1].location, Location { line: 6, col: 1 });
}

#[test]
fn material_index_follows_file_order_across_groups() {
    let scene = parse(&with_header(&[
        "Group { numObjects 3",
        "  Group { numObjects 1 MaterialIndex 1 Sphere { center 0 0 0 radius 1 } }",
        "  Sphere { center 0 0 0 radius 1 }",
        "  Transform { Translate 1 0 0 Group { numObjects 2 Sphere { center 0 0 0 radius 1 } MaterialIndex 0 Sphere { center 0 0 0 radius 1 } } }",
        "}",
    ]));
    assert_eq!(leaf_materials(&scene.root), vec![1, 1, 1, 0]);
}

#[test]
fn materials_block_after_the_group_is_checked_at_the_end() {
    let scene = parse(&format!(
        "{CAMERA}\nGroup {{ numObjects 1 MaterialIndex 1 Sphere {{ center 0 0 0 radius 1 }} }}\n{MATERIALS}"
    ));
    assert_eq!(leaf_materials(&scene.root), vec![1]);
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects 1 MaterialIndex 2 Sphere {{ center 0 0 0 radius 1 }} }}\n{MATERIALS}"),
        2,
        36,
        "MaterialIndex 2 out of range: numMaterials is 2",
    );
}

fn transformed_point(transforms: &str, p: DVec3) -> DVec3 {
    let scene = parse(&with_header(&[
        "Group { numObjects 1 MaterialIndex 0",
        &format!("Transform {{ {transforms} Sphere {{ center 0 0 0 radius 1 }} }}"),
        "}",
    ]));
    let (matrix, child) = transform_of(only_object(&scene));
    assert!(matches!(child.shape, Shape::Sphere { .. }));
    matrix.transform_point3(p)
}

#[test]
fn first_listed_transform_is_applied_last() {
    assert!(close(transformed_point("Translate 1 0 0 Scale 2 2 2", DVec3::X), DVec3::new(3.0, 0.0, 0.0)));
    assert!(close(transformed_point("Scale 2 2 2 Translate 1 0 0", DVec3::X), DVec3::new(4.0, 0.0, 0.0)));
    assert!(close(transformed_point("UniformScale 3", DVec3::ONE), DVec3::splat(3.0)));
    assert!(close(transformed_point("", DVec3::ONE), DVec3::ONE));
}

#[test]
fn matrix_pre_multiplies() {
    // M = Matrix · Translate: the translation acts first, then the matrix doubles it.
    let doubling = "Matrix { 2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1 }";
    assert!(close(transformed_point(&format!("Translate 1 0 0 {doubling}"), DVec3::ZERO), DVec3::new(2.0, 0.0, 0.0)));
    assert!(close(transformed_point(&format!("{doubling} Translate 1 0 0"), DVec3::ZERO), DVec3::new(2.0, 0.0, 0.0)));
    // Row-major (the last column is the translation), applied after the Scale listed before it.
    let shift = "Matrix { 1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1 }";
    assert!(close(transformed_point(&format!("Scale 2 2 2 {shift}"), DVec3::ONE), DVec3::new(7.0, 8.0, 9.0)));
}

#[test]
fn rotations_are_right_handed_in_degrees() {
    assert!(close(transformed_point("XRotate 90", DVec3::Y), DVec3::Z));
    assert!(close(transformed_point("YRotate 90", DVec3::Z), DVec3::X));
    assert!(close(transformed_point("ZRotate 90", DVec3::X), DVec3::Y));
    // The axis is normalised.
    assert!(close(transformed_point("Rotate { 0 0 2 90 }", DVec3::X), DVec3::Y));
    assert!(close(transformed_point("Rotate { 1 1 1 120 }", DVec3::X), DVec3::Y));
}

#[test]
fn nested_transforms_multiply_outer_times_inner() {
    let scene = parse(&with_header(&[
        "Group { numObjects 1 MaterialIndex 0",
        "Transform { Translate 1 0 0 Transform { Scale 2 2 2 Sphere { center 0 0 0 radius 1 } } }",
        "}",
    ]));
    let (outer, inner) = transform_of(only_object(&scene));
    let (inner, _) = transform_of(inner);
    assert!(close((outer * inner).transform_point3(DVec3::X), DVec3::new(3.0, 0.0, 0.0)));
}

#[test]
fn thin_scales_are_not_singular() {
    assert!(close(transformed_point("Scale 1 0.0001 1", DVec3::ONE), DVec3::new(1.0, 0.0001, 1.0)));
}

#[test]
fn triangle_mesh_paths_fans_and_sharing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("quad.obj"),
        "# quad\r\nv 0 0 0\r\nvt 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0 1\r\nf 1/1/1 2/1/1 3//1 -1\r\n",
    )
    .unwrap();
    let scene_path = dir.path().join("scene.txt");
    std::fs::write(
        &scene_path,
        with_header(&[
            "Group { numObjects 3 MaterialIndex 0",
            "TriangleMesh { obj_file quad.obj }",
            "TriangleMesh { obj_file ./quad.obj }",
            // Not next to the scene: found relative to the working directory (the package root).
            "TriangleMesh { obj_file scenes/box.obj }",
            "}",
        ]),
    )
    .unwrap();
    let scene = load_scene(&scene_path).unwrap();
    let meshes: Vec<&Arc<_>> = scene
        .root
        .iter()
        .map(|o| match &o.shape {
            Shape::Mesh { mesh, .. } => mesh,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(meshes[0].triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(meshes[0].positions[3], DVec3::Y);
    assert!(Arc::ptr_eq(meshes[0], meshes[1]));
    assert_eq!(meshes[2].triangles.len(), 12);
}

#[test]
fn parse_obj_directly() {
    let mesh = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\n", Path::new("x.obj")).unwrap();
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(mesh.path, Path::new("x.obj"));
}

// ---------------------------------------------------------------------------------------
// errors and their locations

#[test]
fn display_is_file_line_col_message() {
    let error = parse_err(&with_header(&["Foo { }"]));
    assert_eq!(
        error.to_string(),
        "test.txt:4:1: unknown block `Foo`, expected one of OrthographicCamera, PerspectiveCamera, \
         Lights, Background, Materials, Group"
    );
    let error = parse_err("Lights { numLights 0 }");
    assert_eq!(error.location, None);
    assert_eq!(error.to_string(), "test.txt: no camera: expected an OrthographicCamera or PerspectiveCamera block");
    let boxed: Box<dyn std::error::Error> = Box::new(error);
    assert!(boxed.to_string().starts_with("test.txt: "));
}

#[test]
fn unknown_field_is_named_with_the_expected_ones() {
    let error = assert_error_at(
        &with_header(&["Group { numObjects 1", "MaterialIndex 0", "Sphere { centre 0 0 0 radius 1 }", "}"]),
        6,
        10,
        "unknown field `centre` in Sphere",
    );
    assert!(error.message.contains("center, radius"), "{error}");
    assert_error_at(&with_header(&["Background { color 1 1 1 colour 1 1 1 }"]), 4, 26, "unknown field `colour`");
}

#[test]
fn unknown_object_and_light_and_material() {
    assert_error_at(&with_header(&["Group { numObjects 1", "  Cube { }", "}"]), 5, 3, "unknown object `Cube`");
    assert_error_at(&format!("{CAMERA}\nLights {{ numLights 1 SpotLight {{ }} }}"), 2, 22, "unknown light `SpotLight`");
    assert_error_at(
        &format!("{CAMERA}\nMaterials {{ numMaterials 1 Metal {{ }} }}"),
        2,
        28,
        "unknown material `Metal`",
    );
    assert_error_at(
        &with_header(&[
            "Group { numObjects 1 MaterialIndex 0",
            "Transform { Shear 1 Sphere { center 0 0 0 radius 1 } } }",
        ]),
        5,
        13,
        "unknown transformation `Shear`",
    );
}

#[test]
fn missing_open_brace() {
    let error = assert_error_at(
        &with_header(&["Group { numObjects 1", "MaterialIndex 0", "Sphere center 0 0 0 radius 1 }", "}"]),
        6,
        8,
        "expected `{` after Sphere, found `center`",
    );
    assert_eq!(error.to_string(), "test.txt:6:8: expected `{` after Sphere, found `center`");
}

#[test]
fn bad_numbers() {
    let sphere = |radius: &str| {
        with_header(&[
            "Group { numObjects 1 MaterialIndex 0",
            &format!("Sphere {{ center 0 0 0 radius {radius} }}"),
            "}",
        ])
    };
    for bad in ["1x", "nan", "inf", "-inf", "1e999", "0x10", "1,5", "."] {
        let error = assert_error_at(&sphere(bad), 5, 30, "expected a number, found");
        assert_eq!(error.message, format!("expected a number, found `{bad}`"));
    }
    assert_error_at(&sphere("}"), 5, 30, "expected a number, found `}`");
    assert_error_at("OrthographicCamera { center 0 NaN 1", 1, 31, "expected a number, found `NaN`");
}

#[test]
fn counts_are_exact_non_negative_integers() {
    // Fewer objects than declared: at the closing brace.
    assert_error_at(
        &with_header(&[
            "Group { numObjects 3",
            "MaterialIndex 0",
            "Sphere { center 0 0 0 radius 1 }",
            "Plane { normal 0 1 0 offset 0 }",
            "}",
        ]),
        8,
        1,
        "Group declares numObjects 3 but has 2 objects",
    );
    // More: at the first extra object.
    assert_error_at(
        &with_header(&[
            "Group { numObjects 1",
            "MaterialIndex 0",
            "Sphere { center 0 0 0 radius 1 }",
            "  Plane { normal 0 1 0 offset 0 }",
            "}",
        ]),
        7,
        3,
        "Group declares numObjects 1 but has at least 2 objects",
    );
    assert_error_at(
        &format!("{CAMERA}\nLights {{ numLights 2 }}"),
        2,
        22,
        "Lights declares numLights 2 but has 0 lights",
    );
    assert_error_at(
        &format!("{CAMERA}\nMaterials {{ numMaterials 0 Material {{ }} }}"),
        2,
        28,
        "Materials declares numMaterials 0 but has at least 1 materials",
    );
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects 3.5 }}"),
        2,
        20,
        "expected a non-negative integer, found `3.5`",
    );
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects -1 }}"),
        2,
        20,
        "expected a non-negative integer, found `-1`",
    );
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects 99999999999999999999999 }}"),
        2,
        20,
        "expected a non-negative integer",
    );
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ MaterialIndex 0 }}"),
        2,
        9,
        "expected `numObjects` after `Group {`, found `MaterialIndex`",
    );
}

#[test]
fn huge_count_then_end_of_file_is_a_clean_error() {
    for text in [
        format!("{CAMERA}\nGroup {{ numObjects 18446744073709551615"),
        format!("{CAMERA}\nLights {{ numLights 18446744073709551615\n"),
        format!("{CAMERA}\nMaterials {{ numMaterials 18446744073709551615 Material {{ }}"),
    ] {
        let error = parse_err(&text);
        assert!(error.message.starts_with("unexpected end of file, expected"), "{error}");
    }
}

#[test]
fn material_index_errors() {
    assert_error_at(
        &with_header(&["Group { numObjects 1", "MaterialIndex   2", "Sphere { center 0 0 0 radius 1 }", "}"]),
        5,
        17,
        "MaterialIndex 2 out of range: numMaterials is 2",
    );
    assert_error_at(
        &with_header(&["Group { numObjects 1", "MaterialIndex 4294967296", "Sphere { center 0 0 0 radius 1 }", "}"]),
        5,
        15,
        "MaterialIndex 4294967296 out of range",
    );
    assert_error_at(
        &with_header(&["Group { numObjects 2", "  Group { numObjects 0 }", "  Sphere { center 0 0 0 radius 1 }", "}"]),
        6,
        3,
        "Sphere before any MaterialIndex",
    );
    // Without a Materials block every index is out of range.
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects 1 MaterialIndex 0 Sphere {{ center 0 0 0 radius 1 }} }}"),
        2,
        36,
        "MaterialIndex 0 out of range: numMaterials is 0",
    );
}

#[test]
fn singular_and_non_affine_transforms() {
    let transform = |steps: &str| {
        with_header(&[
            "Group { numObjects 1 MaterialIndex 0",
            &format!("  Transform {{ {steps} Sphere {{ center 0 0 0 radius 1 }} }}"),
            "}",
        ])
    };
    let error = assert_error_at(&transform("Scale 1 0 1"), 5, 3, "singular transform");
    assert_eq!(error.message, "singular transform (determinant 0)");
    assert_error_at(&transform("UniformScale 0"), 5, 3, "singular transform (determinant 0)");
    assert_error_at(&transform("Scale 1e-7 1e-7 1"), 5, 3, "singular transform");
    assert_error_at(&transform("Matrix { 1 0 0 0 0 1 0 0 1 1 0 0 0 0 0 1 }"), 5, 3, "singular transform");
    assert_error_at(&transform("Scale 1e300 1e300 1e300 Scale 1e300 1 1"), 5, 3, "non-finite");
    assert_error_at(&transform("UniformScale 1e200"), 5, 3, "non-finite");
    assert_error_at(&transform("UniformScale 1e-200"), 5, 3, "singular transform (determinant 0)");
    assert_error_at(&transform("Matrix { 1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1 }"), 5, 15, "last row must be 0 0 0 1");
    assert_error_at(&transform("Rotate { 0 0 0 45 }"), 5, 24, "Rotate axis must not be the zero vector");
    assert_error_at(
        &with_header(&[
            "Group { numObjects 1 MaterialIndex 0",
            "Transform { Sphere { center 0 0 0 radius 1 } Scale 1 1 1 }",
            "}",
        ]),
        5,
        46,
        "expected `}` after the Transform's object, found `Scale`",
    );
}

#[test]
fn degenerate_camera_and_shapes() {
    assert_error_at(
        "PerspectiveCamera {\n  center 0 0 0\n  direction 0 0 -1\n  up 0 0 2\n  angle 30\n}",
        4,
        3,
        "up (0 0 2) is parallel to direction (0 0 -1)",
    );
    assert_error_at("OrthographicCamera { direction 0 0 0", 1, 32, "direction must not be the zero vector");
    assert_error_at(
        "OrthographicCamera { center 0 0 0 direction 1e-200 0 0 up 0 1 0 size 1 }",
        1,
        56,
        "direction (1e-200 0 0) and up (0 1 0) are too large or too small to normalise",
    );
    assert_error_at("OrthographicCamera { up 0 0 0", 1, 25, "up must not be the zero vector");
    assert_error_at("OrthographicCamera { size 0", 1, 27, "size must be positive");
    assert_error_at("PerspectiveCamera { angle 180", 1, 27, "angle must be between 0 and 180 degrees");
    assert_error_at("PerspectiveCamera { angle -5", 1, 27, "angle must be between 0 and 180 degrees");
    assert_error_at(
        "OrthographicCamera { center 0 0 0 direction 0 0 1 size 5 }",
        1,
        58,
        "OrthographicCamera is missing `up`",
    );
    let object = |text: &str| with_header(&["Group { numObjects 1 MaterialIndex 0", text, "}"]);
    assert_error_at(&object("Sphere { center 0 0 0 radius 0 }"), 5, 30, "radius must be positive, found 0");
    assert_error_at(&object("Sphere { center 0 0 0 radius -1 }"), 5, 30, "radius must be positive, found -1");
    assert_error_at(&object("Plane { normal 0 0 0 offset 1 }"), 5, 16, "plane normal must not be the zero vector");
    assert_error_at(&object("Sphere { center 0 0 0 }"), 5, 23, "Sphere is missing `radius`");
    assert_error_at(
        &object("Triangle { vertex0 0 0 0 vertex1 0 0 0 vertex0 1 1 1 }"),
        5,
        40,
        "duplicate field `vertex0` in Triangle",
    );
    assert_error_at(
        &format!("{CAMERA}\nLights {{ numLights 1 DirectionalLight {{ direction 0 0 0 color 1 1 1 }} }}"),
        2,
        51,
        "light direction must not be the zero vector",
    );
}

#[test]
fn obj_file_errors() {
    let mesh = |path: &str| {
        with_header(&["Group { numObjects 1 MaterialIndex 0", &format!("  TriangleMesh {{ obj_file {path} }}"), "}"])
    };
    assert_error_at(&mesh("no_such_mesh.obj"), 5, 27, "obj_file `no_such_mesh.obj` not found");
    // Refused before reading: /dev/zero would never end.
    assert_error_at(&mesh("/dev/zero"), 5, 27, "is not a regular file");
    assert_error_at(&mesh("/"), 5, 27, "is not a regular file");
    assert_error_at(&mesh("}"), 5, 27, "expected an OBJ file path, found `}`");

    // A bad face index is reported in the OBJ file, naming the index and the vertex count.
    let dir = tempfile::tempdir().unwrap();
    let obj_path = dir.path().join("bad.obj");
    std::fs::write(&obj_path, "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2  7\n").unwrap();
    let scene_path = dir.path().join("scene.txt");
    std::fs::write(&scene_path, mesh("bad.obj")).unwrap();
    let error = load_scene(&scene_path).unwrap_err();
    assert_eq!(error.file, obj_path);
    assert_eq!(error.location, Some(Location { line: 6, col: 8 }));
    assert!(error.message.starts_with("vertex index 7 out of range: the file has 3 vertices"), "{error}");
    assert!(error.message.contains("scene.txt:5:27"), "{error}");
}

/// Meshes held in memory (a browser's files, docs/SPEC.md §10) resolve and fail as on disk:
/// the same scene, and the same located errors, for a mesh present, absent and malformed.
#[test]
fn obj_files_in_memory_parse_as_on_disk() {
    let mesh = |path: &str| {
        with_header(&["Group { numObjects 1 MaterialIndex 0", &format!("  TriangleMesh {{ obj_file {path} }}"), "}"])
    };
    let dir = tempfile::tempdir().unwrap();
    let good = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let bad = "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2  7\n";
    let mut files = std::collections::HashMap::new();
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    for (name, text) in [("meshes/good.obj", good), ("meshes/bad.obj", bad)] {
        std::fs::write(dir.path().join(name), text).unwrap();
        files.insert(dir.path().join(name), text.to_string());
    }
    let scene_path = dir.path().join("scene.txt");
    for name in ["meshes/good.obj", "meshes/bad.obj", "meshes/none.obj"] {
        let text = mesh(name);
        std::fs::write(&scene_path, &text).unwrap();
        let in_memory = parse_scene_with(&text, &scene_path, ObjFiles::Memory(&files));
        match (in_memory, load_scene(&scene_path)) {
            (Ok(memory), Ok(disk)) => assert_eq!(format!("{memory:?}"), format!("{disk:?}"), "{name}"),
            (Err(memory), Err(disk)) => assert_eq!(memory.to_string(), disk.to_string(), "{name}"),
            (memory, disk) => panic!("{name}: in memory {memory:?}, on disk {disk:?}"),
        }
    }
    assert_eq!(obj_file_names(&mesh("meshes/good.obj")), ["meshes/good.obj"]);
    assert_eq!(obj_file_names("# obj_file a.obj\nobj_file b.obj obj_file"), ["b.obj"]);
}

#[test]
fn unexpected_end_of_file() {
    let error = assert_error_at(
        &with_header(&["Group { numObjects 1", "MaterialIndex 0", "Sphere { center 0 0"]),
        6,
        20,
        "unexpected end of file, expected a number",
    );
    assert_eq!(error.message, "unexpected end of file, expected a number");
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects 0 \n  "),
        3,
        3,
        "unexpected end of file, expected `}`, MaterialIndex",
    );
    assert_error_at("Background", 1, 11, "unexpected end of file, expected `{` after Background");
}

#[test]
fn duplicate_top_level_blocks() {
    assert_error_at(
        &format!("{CAMERA}\n{LIGHTS}\n\n  {LIGHTS}"),
        4,
        3,
        "duplicate Lights block (the first one is at 2:1)",
    );
    assert_error_at(
        &format!("{CAMERA}\nPerspectiveCamera {{ }}"),
        2,
        1,
        "duplicate camera block (the first one is at 1:1)",
    );
    assert_error_at(
        &format!("{CAMERA}\nGroup {{ numObjects 0 }} Group {{ numObjects 0 }}"),
        2,
        24,
        "duplicate Group block",
    );
}

#[test]
fn non_utf8_bytes_are_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.txt");
    let mut bytes = CAMERA.as_bytes().to_vec();
    bytes.extend_from_slice(b"\n  \xff\xfe {");
    std::fs::write(&path, bytes).unwrap();
    let error = load_scene(&path).unwrap_err();
    assert_eq!(error.location, Some(Location { line: 2, col: 3 }));
    assert!(error.message.starts_with("unknown block"), "{error}");
}

#[test]
fn unreadable_scene_files() {
    assert_eq!(load_scene(Path::new("/no/such/scene.txt")).unwrap_err().location, None);
    let error = load_scene(Path::new("/dev/zero")).unwrap_err();
    assert!(error.message.contains("not a regular file"), "{error}");
}

// ---------------------------------------------------------------------------------------
// nesting

fn nested_groups(levels: usize) -> String {
    let mut text = format!("{CAMERA}\n{MATERIALS}\n");
    for _ in 0..levels {
        text.push_str("Group { numObjects 1\n");
    }
    text.push_str("MaterialIndex 0 Sphere { center 0 0 0 radius 1 }\n");
    text.push_str(&"}\n".repeat(levels));
    text
}

/// The top-level Group holding `levels - 1` nested Transforms around a sphere.
fn nested_transforms(levels: usize) -> String {
    let mut text = format!("{CAMERA}\n{MATERIALS}\nGroup {{ numObjects 1 MaterialIndex 0\n");
    text.push_str(&"Transform { Translate 0 0 1\n".repeat(levels - 1));
    text.push_str("Sphere { center 0 0 0 radius 1 }\n");
    text.push_str(&"}\n".repeat(levels));
    text
}

fn depth(object: &Object) -> usize {
    let mut depth = 1;
    let mut object = object;
    loop {
        match &object.shape {
            Shape::Group(children) if children.len() == 1 => object = &children[0],
            Shape::Transform { child, .. } => object = child,
            _ => return depth,
        }
        depth += 1;
    }
}

#[test]
fn nesting_up_to_the_limit_parses_and_drops_on_a_small_stack() {
    let deepest = on_small_stack(|| {
        let shallow = parse(&nested_groups(200));
        assert_eq!(depth(only_object(&shallow)), 200); // 199 groups below the root, then the sphere
        let deepest = parse(&nested_groups(MAX_NESTING));
        let levels = depth(only_object(&deepest));
        drop(deepest);
        let transforms = parse(&nested_transforms(MAX_NESTING));
        let (matrix, _) = transform_of(only_object(&transforms));
        let lifted = matrix.transform_point3(DVec3::ZERO);
        (levels, depth(only_object(&transforms)), lifted)
    });
    assert_eq!(deepest, (MAX_NESTING, MAX_NESTING, DVec3::new(0.0, 0.0, 1.0)));
    assert_error_at(&nested_transforms(MAX_NESTING + 1), 1003, 1, "nesting too deep");
}

#[test]
fn nesting_beyond_the_limit_is_an_error_at_the_keyword_that_exceeds_it() {
    assert_error_at(&nested_groups(MAX_NESTING + 1), 1003, 1, "nesting too deep: more than 1000 levels");

    let (groups, transforms) = on_small_stack(|| {
        let groups = parse_err(&format!("{CAMERA}\n{}", "Group { numObjects 1\n".repeat(100_000)));
        let transforms = parse_err(&format!(
            "{CAMERA}\nGroup {{ numObjects 1\n{}",
            "  Transform { Translate 0 0 0\n".repeat(100_000)
        ));
        (groups, transforms)
    });
    assert_eq!(groups.location, Some(Location { line: 1002, col: 1 }), "{groups}");
    assert_eq!(transforms.location, Some(Location { line: 1002, col: 3 }), "{transforms}");
    assert!(transforms.message.starts_with("nesting too deep"), "{transforms}");
}

// ---------------------------------------------------------------------------------------
// robustness

const VOCABULARY: &[&str] = &[
    "{",
    "}",
    "{",
    "}",
    "OrthographicCamera",
    "PerspectiveCamera",
    "Lights",
    "Background",
    "Materials",
    "Group",
    "Material",
    "PhongMaterial",
    "DirectionalLight",
    "numLights",
    "numMaterials",
    "numObjects",
    "MaterialIndex",
    "Sphere",
    "Plane",
    "Triangle",
    "TriangleMesh",
    "Transform",
    "Scale",
    "UniformScale",
    "Translate",
    "XRotate",
    "YRotate",
    "ZRotate",
    "Rotate",
    "Matrix",
    "center",
    "direction",
    "up",
    "size",
    "angle",
    "color",
    "ambientLight",
    "diffuseColor",
    "specularColor",
    "exponent",
    "radius",
    "normal",
    "offset",
    "vertex0",
    "vertex1",
    "vertex2",
    "obj_file",
    "cube.obj",
    "/dev/zero",
    "missing.obj",
    "0",
    "1",
    "1",
    "2",
    "3",
    "-1",
    "0.5",
    "-.16",
    "+2.",
    "1e-3",
    "1e999",
    "-1e308",
    "nan",
    "inf",
    "0x10",
    "3.5",
    "180",
    "18446744073709551616",
    "4294967296",
    "1e-320",
    "#",
    "\n",
];

fn soup(words: Vec<&'static str>) -> String {
    words.join(" ")
}

/// A course scene as words, to mutate.
fn course_words() -> Option<Vec<String>> {
    let text = std::fs::read_to_string(course_dir()?.join("scene2_14_axes_cube.txt")).unwrap();
    Some(text.split_whitespace().map(str::to_string).collect())
}

/// One edit of a word list: replace, insert or delete at a position (taken modulo the length).
#[derive(Clone, Debug)]
enum Edit {
    Replace(usize, &'static str),
    Insert(usize, &'static str),
    Delete(usize),
}

fn edit_strategy() -> impl Strategy<Value = Edit> {
    let word = || prop::sample::select(VOCABULARY);
    prop_oneof![
        (any::<usize>(), word()).prop_map(|(i, w)| Edit::Replace(i, w)),
        (any::<usize>(), word()).prop_map(|(i, w)| Edit::Insert(i, w)),
        any::<usize>().prop_map(Edit::Delete),
    ]
}

fn apply(words: &mut Vec<String>, edit: &Edit) {
    let len = words.len().max(1);
    match *edit {
        Edit::Replace(i, w) if !words.is_empty() => words[i % len] = w.to_string(),
        Edit::Insert(i, w) => words.insert(i % (words.len() + 1), w.to_string()),
        Edit::Delete(i) if !words.is_empty() => drop(words.remove(i % len)),
        _ => {}
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_scene(&text, Path::new("bytes.txt"));
        let _ = parse_obj(&text, Path::new("bytes.obj"));
    }

    #[test]
    fn token_soups_never_panic(words in prop::collection::vec(prop::sample::select(VOCABULARY), 0..120)) {
        let _ = parse_scene(&soup(words), &course_dir().unwrap_or_default().join("soup.txt"));
    }

    #[test]
    fn soups_after_a_valid_prefix_never_panic(words in prop::collection::vec(prop::sample::select(VOCABULARY), 0..80)) {
        let text = format!("{}\nGroup {{ numObjects 2 MaterialIndex 0 {}", with_header(&[]), soup(words));
        let result = parse_scene(&text, &course_dir().unwrap_or_default().join("soup.txt"));
        if let Err(error) = result {
            prop_assert!(error.location.is_some() || error.message.contains("camera"));
        }
    }

    #[test]
    fn mutated_course_scenes_never_panic(edits in prop::collection::vec(edit_strategy(), 1..4)) {
        let Some(mut words) = course_words() else { return Ok(()) };
        for edit in &edits {
            apply(&mut words, edit);
        }
        match parse_scene(&words.join(" "), &course_dir().unwrap_or_default().join("mutated.txt")) {
            Ok(scene) => prop_assert!(orthonormal(scene.camera.frame())),
            Err(error) => prop_assert!(error.location.is_some() || error.message.contains("camera")),
        }
    }

    #[test]
    fn obj_soups_never_panic(lines in prop::collection::vec(
        prop::collection::vec(prop::sample::select(&["v", "f", "vn", "1", "-1", "2", "0", "3/1/2", "4//4", "-9", "x", "1e999", "#"][..]), 0..6),
        0..40,
    )) {
        let text: Vec<String> = lines.into_iter().map(|l| l.join(" ")).collect();
        if let Ok(mesh) = parse_obj(&text.join("\r\n"), Path::new("soup.obj")) {
            let n = mesh.positions.len();
            prop_assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
        }
    }
}

/// The camera frame the parser validated: unit, mutually orthogonal axes.
fn orthonormal(frame: &raycaster::scene::CameraBasis) -> bool {
    let unit = |v: glam::DVec3| (v.length() - 1.0).abs() < 1e-12;
    let orthogonal = |a: glam::DVec3, b: glam::DVec3| a.dot(b).abs() < 1e-12;
    unit(frame.direction)
        && unit(frame.up)
        && unit(frame.horizontal)
        && orthogonal(frame.direction, frame.up)
        && orthogonal(frame.direction, frame.horizontal)
        && orthogonal(frame.up, frame.horizontal)
}

// ---------------------------------------------------------------------------------------
// solid textures (GRAMMAR.md A6)

/// A scene whose `Materials` block holds two Phong materials (lines 4 and 5), then the
/// given material lines from line 6 on.
fn with_textures(lines: &[&str]) -> String {
    let count = 2 + lines.len();
    let mut text = vec![
        CAMERA.to_string(),
        LIGHTS.to_string(),
        format!("Materials {{ numMaterials {count}"),
        "PhongMaterial { diffuseColor 1 0 0 }".to_string(),
        "PhongMaterial { diffuseColor 0 0 1 }".to_string(),
    ];
    text.extend(lines.iter().map(|l| l.to_string()));
    text.push("}".to_string());
    text.push("Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1 } }".to_string());
    text.join("\n")
}

/// The 1-based column where `needle` first starts in `line` (ASCII).
fn col(line: &str, needle: &str) -> u32 {
    line.find(needle).unwrap_or_else(|| panic!("`{needle}` not in `{line}`")) as u32 + 1
}

#[test]
fn texture_blocks_read_every_field() {
    use raycaster::scene::TextureKind;
    let text = with_textures(&[
        "Checkerboard { Transform { UniformScale 2 } materialIndex 0 materialIndex 1 }",
        "Noise { materialIndex 1 materialIndex 2 octaves 3 }",
        "Marble { Transform { Translate 1 0 0 XRotate 90 } materialIndex 0 materialIndex 3 \
         octaves 5 frequency 3 amplitude 2 }",
        "Wood { amplitude -1.5 octaves 0 materialIndex 4 materialIndex 0 frequency 7 }",
    ]);
    let scene = parse(&text);
    assert_eq!(scene.materials.len(), 6);
    assert_eq!(scene.textures.len(), 6);
    assert!(scene.texture(0).is_none() && scene.texture(1).is_none());
    let [checker, noise, marble, wood] = [2, 3, 4, 5].map(|k| *scene.texture(k).unwrap());
    assert_eq!((checker.kind, checker.materials), (TextureKind::Checkerboard, [0, 1]));
    assert!(close(checker.to_texture.transform_point3(DVec3::new(1.0, -2.0, 0.5)), DVec3::new(2.0, -4.0, 1.0)));
    assert_eq!((noise.kind, noise.materials, noise.octaves), (TextureKind::Noise, [1, 2], 3));
    assert_eq!(noise.to_texture, DMat4::IDENTITY, "no Transform: identity");
    assert_eq!(
        (marble.kind, marble.materials, marble.octaves, marble.frequency, marble.amplitude),
        (TextureKind::Marble, [0, 3], 5, 3.0, 2.0)
    );
    // First listed, applied last: XRotate 90 takes (0, 0, 1) to (0, −1, 0), then + (1, 0, 0).
    assert!(close(marble.to_texture.transform_point3(DVec3::Z), DVec3::new(1.0, -1.0, 0.0)));
    assert_eq!(
        (wood.kind, wood.materials, wood.octaves, wood.frequency, wood.amplitude),
        (TextureKind::Wood, [4, 0], 0, 7.0, -1.5),
        "fields in any order"
    );
    // Each texture stands in, for the Phong terms, as its first material (resolved through
    // textures): the course's OpenGL preview.
    let red = scene.materials[0];
    assert_eq!([2, 3, 4, 5].map(|k| scene.materials[k]), [red, scene.materials[1], red, red]);
    assert_eq!(scene.material_locations[2], Location { line: 6, col: 1 });
    assert_eq!(scene.material_locations[5], Location { line: 9, col: 1 });
    // A scene without textures keeps no texture list at all.
    assert!(parse(&with_header(&[])).textures.is_empty());
}

#[test]
fn course_texture_scenes_parse() {
    use raycaster::scene::TextureKind::{self, *};
    let Some(corpus) = common::corpus() else { return };
    let a6 = corpus.join("a6");
    let kinds = |name: &str| -> Vec<(usize, TextureKind)> {
        let scene = load_scene(&a6.join(name)).unwrap_or_else(|e| panic!("{e}"));
        (0..scene.materials.len() as u32).filter_map(|k| scene.texture(k).map(|t| (k as usize, t.kind))).collect()
    };
    assert_eq!(kinds("scene6_13_checkerboard.txt"), [(2, Checkerboard), (5, Checkerboard)]);
    assert_eq!(kinds("scene6_15_marble_cubes.txt"), [(2, Noise), (5, Noise), (8, Marble), (11, Marble)]);
    assert_eq!(kinds("scene6_16_wood_cubes.txt").iter().filter(|(_, k)| *k == Wood).count(), 4);
    for name in ["scene6_17_marble_vase.txt", "scene6_18_6.837_logo.txt"] {
        assert!(!kinds(name).is_empty(), "{name}");
    }
    // 6_15's first noise cube sits at (−1.5, 1.5, 0); its texture's Transform (… Translate
    // 1.5 −1.5 0) takes that point to the origin of texture space.
    let scene = load_scene(&a6.join("scene6_15_marble_cubes.txt")).unwrap();
    let noise = scene.texture(2).unwrap();
    assert!(noise.to_texture.transform_point3(DVec3::new(-1.5, 1.5, 0.0)).length() < 1e-12);
    let marble = scene.texture(8).unwrap();
    assert_eq!((marble.octaves, marble.frequency, marble.amplitude, marble.materials), (0, 3.0, 3.0, [6, 7]));
}

#[test]
fn texture_material_indices_must_name_earlier_materials() {
    for (line, needle, message) in [
        ("Checkerboard { materialIndex 0 materialIndex 2 }", "2 }", "materialIndex 2 must name an earlier material"),
        ("Noise { materialIndex 7 materialIndex 0 octaves 1 }", "7", "materialIndex 7 must name an earlier material"),
        ("Checkerboard { materialIndex 0 materialIndex 3 }", "3 }", "this Checkerboard is material 2"),
    ] {
        assert_error_at(&with_textures(&[line]), 6, col(line, needle), message);
    }
    // A texture may name an earlier texture.
    let nested = with_textures(&[
        "Checkerboard { materialIndex 0 materialIndex 1 }",
        "Checkerboard { Transform { UniformScale 4 } materialIndex 2 materialIndex 1 }",
    ]);
    assert_eq!(parse(&nested).texture(3).unwrap().materials, [2, 1]);
}

#[test]
fn texture_block_errors_are_located() {
    let cases: [(&str, &str, &str); 9] = [
        ("Checkerboard { }", "}", "Checkerboard is missing `materialIndex`"),
        ("Noise { materialIndex 0 materialIndex 1 }", "}", "Noise is missing `octaves`"),
        ("Marble { materialIndex 0 materialIndex 1 octaves 2 frequency 3 }", "}", "Marble is missing `amplitude`"),
        ("Wood { materialIndex 0 materialIndex 1 octaves 2 amplitude 3 }", "}", "Wood is missing `frequency`"),
        ("Checkerboard { materialIndex 0 }", "}", "expected a second `materialIndex` in Checkerboard, found `}`"),
        ("Checkerboard { materialIndex 0 materialIndex 1 octaves 2 }", "octaves", "unknown field `octaves`"),
        (
            "Noise { Transform { Sphere } materialIndex 0 materialIndex 1 octaves 1 }",
            "Sphere",
            "unknown transformation",
        ),
        ("Noise { materialIndex 0 materialIndex 1 octaves 65 }", "65", "octaves 65 is more than 64"),
        ("Noise { materialIndex 0 materialIndex 1 octaves -1 }", "-1", "expected a non-negative integer"),
    ];
    for (line, needle, message) in cases {
        assert_error_at(&with_textures(&[line]), 6, col(line, needle), message);
    }
    let twice = "Checkerboard { Transform { } Transform { } materialIndex 0 materialIndex 1 }";
    assert_error_at(&with_textures(&[twice]), 6, col(twice, "Transform { } m"), "duplicate field `Transform`");
    // The error names the file, the line and the column, as every scene error does.
    let shown = parse_err(&with_textures(&["Checkerboard { }"])).to_string();
    assert!(shown.starts_with("test.txt:6:16: "), "{shown}");
}

#[test]
fn texture_nesting_is_bounded() {
    use raycaster::scene::MAX_TEXTURE_NESTING;
    // Material 2 is one texture deep; material 2 + d names material 1 + d, so it is d + 1 deep.
    let chain = |depth: usize| -> Vec<String> {
        let first = "Noise { materialIndex 0 materialIndex 1 octaves 1 }".to_string();
        let rest = (3..2 + depth).map(|k| format!("Noise {{ materialIndex {} materialIndex 0 octaves 1 }}", k - 1));
        std::iter::once(first).chain(rest).collect()
    };
    let lines = chain(MAX_TEXTURE_NESTING);
    let deepest = parse(&with_textures(&lines.iter().map(String::as_str).collect::<Vec<_>>()));
    assert_eq!(deepest.texture(1 + MAX_TEXTURE_NESTING as u32).unwrap().materials, [MAX_TEXTURE_NESTING as u32, 0]);
    let lines = chain(MAX_TEXTURE_NESTING + 1);
    let text = with_textures(&lines.iter().map(String::as_str).collect::<Vec<_>>());
    // The texture one level too deep is on line 6 + MAX_TEXTURE_NESTING.
    assert_error_at(&text, 6 + MAX_TEXTURE_NESTING as u32, 1, "textures nested 9 deep, more than 8");
}
