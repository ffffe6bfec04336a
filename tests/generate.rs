//! Generated meshes (`raycaster::scene::generate`) and the hard-case scenes of
//! `scenes/hard/`: the meshes are closed, outward, exact and round-trip through OBJ; every
//! hard scene loads (the singular one fails where its comment says), and the exact
//! arithmetic claimed in the scenes' comments holds in f64.

mod common;

use glam::DVec3;
use raycaster::camera::PrimaryRays;
use raycaster::scene::generate::{grid, icosphere, write_obj};
use raycaster::scene::{load_obj, Location, Mesh, Object, Projection, Scene, Shape};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

// ---------------------------------------------------------------------------------------
// helpers

use common::hard::{hard_dir, load_hard, load_hard_ok, tokens};

/// All leaves of the tree (Transforms and Groups looked through).
fn leaves(objects: &[Object]) -> Vec<&Shape> {
    let mut out = Vec::new();
    let mut stack: Vec<&Object> = objects.iter().rev().collect();
    while let Some(object) = stack.pop() {
        match &object.shape {
            Shape::Group(children) => stack.extend(children.iter().rev()),
            Shape::Transform { child, .. } => stack.push(child),
            shape => out.push(shape),
        }
    }
    out
}

fn meshes(scene: &Scene) -> Vec<Arc<Mesh>> {
    leaves(&scene.root)
        .into_iter()
        .filter_map(|s| match s {
            Shape::Mesh { mesh, .. } => Some(mesh.clone()),
            _ => None,
        })
        .collect()
}

fn triangles(scene: &Scene) -> Vec<[DVec3; 3]> {
    leaves(&scene.root)
        .into_iter()
        .filter_map(|s| match s {
            Shape::Triangle { vertices, .. } => Some(*vertices),
            _ => None,
        })
        .collect()
}

fn face_normal(t: &[DVec3; 3]) -> DVec3 {
    (t[1] - t[0]).cross(t[2] - t[0])
}

/// Directed edges of a mesh, each mapped to how often it occurs.
fn directed_edges(mesh: &Mesh) -> HashMap<(u32, u32), u32> {
    let mut edges = HashMap::new();
    for &[a, b, c] in &mesh.triangles {
        for edge in [(a, b), (b, c), (c, a)] {
            *edges.entry(edge).or_insert(0) += 1;
        }
    }
    edges
}

/// A pixel (i, j) and the (x, y) where its ray crosses z = 0.
type Centre = ((u32, u32), (f64, f64));

/// A variant of offset_base.txt: file, the Transform step wrapping its objects, and how
/// the camera centre moves.
type Variant = (&'static str, &'static [&'static str], fn(DVec3) -> DVec3);

/// The 64 × 64 orthographic camera shared by the pixel-exact scenes: checks that the ray of
/// pixel (i, j) starts exactly at (i − 31.5, j − 31.5, 10) along (0, 0, −1), and returns
/// the rays' (x, y) by pixel.
fn pixel_centres_64(scene: &Scene) -> Vec<Centre> {
    assert_eq!(scene.camera.projection, Projection::Orthographic { size: 64.0 });
    let rays = PrimaryRays::for_camera(&scene.camera, 64, 64);
    let mut out = Vec::with_capacity(64 * 64);
    for j in 0..64 {
        for i in 0..64 {
            let ray = rays.ray(i, j);
            assert_eq!(ray.direction, DVec3::new(0.0, 0.0, -1.0));
            assert_eq!(ray.origin, DVec3::new(f64::from(i) - 31.5, f64::from(j) - 31.5, 10.0), "pixel ({i}, {j})");
            out.push(((i, j), (ray.origin.x, ray.origin.y)));
        }
    }
    out
}

/// Whether the point p lies on the closed segment a–b (in the xy projection), exactly.
/// Exact for the small quarter-integer coordinates used here.
fn on_segment_2d(p: (f64, f64), a: DVec3, b: DVec3) -> bool {
    let cross = (b.x - a.x) * (p.1 - a.y) - (b.y - a.y) * (p.0 - a.x);
    cross == 0.0 && p.0 >= a.x.min(b.x) && p.0 <= a.x.max(b.x) && p.1 >= a.y.min(b.y) && p.1 <= a.y.max(b.y)
}

/// How many of the 64 × 64 pixel centres lie (in x, y) on a triangle's outline.
fn centres_on_outline(centres: &[Centre], t: &[DVec3; 3]) -> usize {
    centres
        .iter()
        .filter(|(_, p)| {
            on_segment_2d(*p, t[0], t[1]) || on_segment_2d(*p, t[1], t[2]) || on_segment_2d(*p, t[2], t[0])
        })
        .count()
}

// ---------------------------------------------------------------------------------------
// generate::icosphere

#[test]
fn icosphere_counts_and_no_duplicate_vertices() {
    for s in 0..=5u32 {
        let mesh = icosphere(DVec3::ZERO, 1.0, s);
        assert_eq!(mesh.triangles.len(), 20 * 4usize.pow(s), "s = {s}");
        assert_eq!(mesh.positions.len(), 10 * 4usize.pow(s) + 2, "s = {s}");
        let distinct: HashSet<[u64; 3]> =
            mesh.positions.iter().map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]).collect();
        assert_eq!(distinct.len(), mesh.positions.len(), "duplicate vertices at s = {s}");
        // Every vertex is used.
        let used: HashSet<u32> = mesh.triangles.iter().flatten().copied().collect();
        assert_eq!(used.len(), mesh.positions.len());
    }
    assert_eq!(icosphere(DVec3::ZERO, 1.0, 5).path, Path::new("generated:icosphere(center 0 0 0, radius 1, 5)"));
}

#[test]
fn icosphere_is_closed_with_opposite_edge_directions() {
    for s in 0..=4u32 {
        let mesh = icosphere(DVec3::new(0.5, -2.0, 3.0), 2.5, s);
        let edges = directed_edges(&mesh);
        for (&(a, b), &count) in &edges {
            assert_ne!(a, b, "degenerate edge");
            assert_eq!(count, 1, "directed edge {a}->{b} used {count} times (s = {s})");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no opposite (s = {s})");
        }
        // Euler: V − E + F = 2 for a closed genus-0 surface (each undirected edge twice).
        let (v, e, f) = (mesh.positions.len() as i64, edges.len() as i64 / 2, mesh.triangles.len() as i64);
        assert_eq!(v - e + f, 2, "s = {s}");
    }
}

#[test]
fn icosphere_vertices_on_the_sphere_and_normals_outward() {
    for (center, radius) in
        [(DVec3::ZERO, 1.0), (DVec3::new(1e3, -7.25, 0.1), 0.003), (DVec3::new(-3.0, 4.0, 5.0), 250.0)]
    {
        for s in [0u32, 1, 3, 5] {
            let mesh = icosphere(center, radius, s);
            // 1e-12 relative to the radius, plus the rounding of the coordinates themselves
            // when the centre is far from the origin compared with the radius.
            let tolerance = 1e-12 * radius + 4.0 * f64::EPSILON * center.abs().max_element();
            for p in &mesh.positions {
                let error = ((*p - center).length() - radius).abs();
                assert!(error <= tolerance, "vertex {p} off the sphere by {error:e}");
            }
            for k in 0..mesh.triangles.len() {
                let t = mesh.triangle(k);
                let centroid = (t[0] + t[1] + t[2]) / 3.0;
                let n = face_normal(&t);
                assert!(n.dot(centroid - center) > 0.0, "triangle {k} faces inward (s = {s})");
                // Faces are nearly tangent: the normal is within a few degrees of radial.
                assert!(n.normalize().dot((centroid - center).normalize()) > 0.9);
            }
        }
    }
}

#[test]
fn icosphere5_geometry_quoted_in_the_closed_mesh_scenes() {
    let mesh = icosphere(DVec3::ZERO, 1.0, 5);
    let mut nearest_plane = f64::INFINITY;
    for k in 0..mesh.triangles.len() {
        let t = mesh.triangle(k);
        nearest_plane = nearest_plane.min(face_normal(&t).normalize().dot(t[0]));
    }
    // closed_mesh_*.txt: every face plane is at least 0.99971 from the centre.
    assert!(nearest_plane > 0.99971 && nearest_plane < 0.99972, "{nearest_plane}");
}

// ---------------------------------------------------------------------------------------
// generate::grid

#[test]
fn grid_counts_positions_and_winding() {
    let (x0, y0, dx, dy, nx, ny, z) = (-31.5, -31.5, 1.0, 1.0, 63, 63, 0.0);
    let mesh = grid(x0, y0, dx, dy, nx, ny, z);
    assert_eq!(mesh.positions.len(), 64 * 64);
    assert_eq!(mesh.triangles.len(), 2 * 63 * 63);
    for j in 0..=ny {
        for i in 0..=nx {
            let p = mesh.positions[(j * (nx + 1) + i) as usize];
            assert_eq!(p, DVec3::new(x0 + f64::from(i) * dx, y0 + f64::from(j) * dy, z));
        }
    }
    for (nx, ny, dx, dy) in [(1, 1, 1.0, 1.0), (5, 3, 0.25, 2.0), (64, 63, 1.0, 1.0), (7, 1, 1e-3, 1e3)] {
        let mesh = grid(-1.0, 2.0, dx, dy, nx, ny, -4.0);
        assert_eq!(mesh.positions.len(), ((nx + 1) * (ny + 1)) as usize);
        assert_eq!(mesh.triangles.len(), (2 * nx * ny) as usize);
        let mut area = 0.0;
        for k in 0..mesh.triangles.len() {
            let n = face_normal(&mesh.triangle(k));
            assert!(n.z > 0.0 && n.x == 0.0 && n.y == 0.0, "triangle {k}: normal {n}");
            area += n.z / 2.0;
        }
        let expected = f64::from(nx) * dx * f64::from(ny) * dy;
        assert!((area - expected).abs() <= 1e-12 * expected, "{area} vs {expected}");
        // Interior edges are shared by two triangles in opposite directions; boundary
        // edges (2·nx + 2·ny of them) by one.
        let edges = directed_edges(&mesh);
        let boundary = edges.keys().filter(|&&(a, b)| !edges.contains_key(&(b, a))).count();
        assert!(edges.values().all(|&c| c == 1));
        assert_eq!(boundary as u32, 2 * nx + 2 * ny);
    }
    // The documented numbering: cell c = j·nx + i gives 2c = (v00, v10, v11), 2c+1 = (v00, v11, v01).
    let mesh = grid(0.0, 0.0, 1.0, 1.0, 3, 2, 0.0);
    let v = |i: u32, j: u32| j * 4 + i;
    let c = 3 + 2; // cell (2, 1)
    assert_eq!(mesh.triangles[2 * c], [v(2, 1), v(3, 1), v(3, 2)]);
    assert_eq!(mesh.triangles[2 * c + 1], [v(2, 1), v(3, 2), v(2, 2)]);
    assert_eq!(mesh.path, Path::new("generated:grid(0, 0, 1, 1, 3, 2, 0)"));
    assert_eq!(grid(0.0, 0.0, 1.0, 1.0, 0, 4, 0.0).triangles.len(), 0);
}

// ---------------------------------------------------------------------------------------
// generate::write_obj

fn assert_same_mesh(a: &Mesh, b: &Mesh) {
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.positions.len(), b.positions.len());
    for (p, q) in a.positions.iter().zip(&b.positions) {
        assert_eq!(p.to_array().map(f64::to_bits), q.to_array().map(f64::to_bits), "{p} vs {q}");
    }
}

#[test]
fn write_obj_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let awkward = Mesh {
        path: PathBuf::from("awkward\nname"),
        positions: vec![
            DVec3::new(0.1, -0.0, 1.0 / 3.0),
            DVec3::new(f64::MAX, f64::MIN_POSITIVE, -5e-324),
            DVec3::new(1e-7, 1e16, -123_456_789.123_456_79),
            DVec3::new(std::f64::consts::PI, -std::f64::consts::E, 2f64.sqrt() * 1e300),
        ],
        triangles: vec![[0, 1, 2], [3, 2, 1], [0, 0, 3]],
        vertex_locations: Vec::new(),
    };
    let meshes = [
        icosphere(DVec3::new(0.1, 0.2, 0.3), 0.7, 3),
        icosphere(DVec3::ZERO, 1.0, 5),
        grid(-31.5, -31.5, 1.0, 1.0, 63, 63, 0.0),
        grid(0.1, -0.7, 0.3, 0.01, 9, 4, -1e-3),
        awkward,
    ];
    for (k, mesh) in meshes.iter().enumerate() {
        let path = dir.path().join(format!("m{k}.obj"));
        write_obj(mesh, &path).unwrap();
        let back = load_obj(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_same_mesh(mesh, &back);
        assert_eq!(back.path, path);
    }
}

#[test]
fn write_obj_rejects_what_obj_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.obj");
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mesh = Mesh {
            path: "x".into(),
            positions: vec![DVec3::new(0.0, bad, 0.0)],
            triangles: vec![],
            vertex_locations: vec![],
        };
        assert_eq!(write_obj(&mesh, &path).unwrap_err().kind(), std::io::ErrorKind::InvalidInput);
        assert!(!path.exists());
    }
    let mesh = Mesh {
        path: "x".into(),
        positions: vec![DVec3::ZERO; 3],
        triangles: vec![[0, 1, 3]],
        vertex_locations: vec![],
    };
    assert_eq!(write_obj(&mesh, &path).unwrap_err().kind(), std::io::ErrorKind::InvalidInput);
    assert!(!path.exists());
    assert!(write_obj(&grid(0.0, 0.0, 1.0, 1.0, 1, 1, 0.0), &dir.path().join("no/such/dir.obj")).is_err());
}

// ---------------------------------------------------------------------------------------
// scenes/hard

const SINGULAR: &str = "singular_transform.txt";

fn hard_scene_names() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(hard_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".txt"))
        .collect();
    names.sort();
    names
}

#[test]
fn every_hard_scene_loads_and_is_documented() {
    let readme = std::fs::read_to_string(hard_dir().join("README.md")).unwrap();
    let names = hard_scene_names();
    assert!(names.len() >= 15, "{names:?}");
    for name in &names {
        assert!(readme.contains(&format!("`{name}`")), "README.md does not describe {name}");
        let text = std::fs::read_to_string(hard_dir().join(name)).unwrap();
        assert!(text.starts_with("# "), "{name} should start with a comment saying what it tests");
        if name == SINGULAR {
            continue;
        }
        let (_dir, scene) = load_hard_ok(name);
        assert!(!leaves(&scene.root).is_empty(), "{name}");
    }
}

#[test]
fn singular_transform_fails_where_its_comment_says() {
    let (_, result) = load_hard(SINGULAR);
    let error = result.expect_err("a singular transform must not load");
    assert_eq!(error.location, Some(Location { line: 35, col: 5 }), "{error}");
    assert_eq!(error.message, "singular transform (determinant 0)");
    let text = std::fs::read_to_string(hard_dir().join(SINGULAR)).unwrap();
    assert_eq!(text.lines().nth(34).map(str::trim_start), Some("Transform {"));
    assert!(text.contains("singular_transform.txt:35:5: singular transform (determinant 0)"));
    assert!(text.contains("line 35, column 5"));
    assert!(error.to_string().ends_with("singular_transform.txt:35:5: singular transform (determinant 0)"), "{error}");
}

#[test]
fn closed_mesh_scenes_use_the_generated_icosphere() {
    for name in ["closed_mesh_outside.txt", "closed_mesh_inside.txt"] {
        let (_dir, scene) = load_hard_ok(name);
        let meshes = meshes(&scene);
        assert_eq!(meshes.len(), 1);
        assert_same_mesh(&meshes[0], &icosphere(DVec3::ZERO, 1.0, 5));
        assert_eq!(meshes[0].triangles.len(), 20480);
    }
}

/// Case 3: every pixel centre is exactly a grid vertex, (i, j) ↦ vertex 64·j + i.
#[test]
fn grid_vertices_lie_exactly_on_pixel_centres() {
    let (_dir, scene) = load_hard_ok("grid_vertices_on_pixel_centres.txt");
    let mesh = &meshes(&scene)[0];
    assert_eq!((mesh.positions.len(), mesh.triangles.len()), (4096, 7938));
    for ((i, j), (x, y)) in pixel_centres_64(&scene) {
        let vertex = mesh.positions[(64 * j + i) as usize];
        assert_eq!((x, y, 0.0), (vertex.x, vertex.y, vertex.z), "pixel ({i}, {j})");
        let sharing = mesh.triangles.iter().filter(|t| t.contains(&(64 * j + i))).count();
        let on_side = |k: u32| k == 0 || k == 63;
        let expected = match (on_side(i), on_side(j)) {
            (false, false) => 6,
            (true, true) if i == j => 2,
            (true, true) => 1,
            _ => 3,
        };
        assert_eq!(sharing, expected, "vertex ({i}, {j})");
    }
}

/// Case 4: every pixel centre is exactly the midpoint of the horizontal edge from vertex
/// (i, j) to (i + 1, j), shared by triangles 2(64j + i) and 2(64(j − 1) + i) + 1.
#[test]
fn grid_edge_midpoints_lie_exactly_on_pixel_centres() {
    let (_dir, scene) = load_hard_ok("grid_edges_on_pixel_centres.txt");
    let mesh = &meshes(&scene)[0];
    assert_eq!((mesh.positions.len(), mesh.triangles.len()), (4160, 8064));
    for ((i, j), (x, y)) in pixel_centres_64(&scene) {
        let (ka, kb) = (65 * j + i, 65 * j + i + 1);
        let (a, b) = (mesh.positions[ka as usize], mesh.positions[kb as usize]);
        assert_eq!((a.y, b.y), (y, y), "pixel ({i}, {j})");
        assert_eq!((x - a.x, b.x - x), (0.5, 0.5), "pixel ({i}, {j})");
        assert!(mesh.positions.iter().all(|v| (v.x, v.y) != (x, y)), "pixel ({i}, {j}) hits a vertex");
        let sharing: Vec<usize> = (0..mesh.triangles.len())
            .filter(|&k| mesh.triangles[k].contains(&ka) && mesh.triangles[k].contains(&kb))
            .collect();
        let mut expected = Vec::new();
        if j > 0 {
            expected.push(2 * (64 * (j - 1) + i) as usize + 1);
        }
        if j < 63 {
            expected.push(2 * (64 * j + i) as usize);
        }
        expected.sort();
        assert_eq!(sharing, expected, "pixel ({i}, {j})");
    }
}

/// Case 4b: every pixel centre is exactly the midpoint of the diagonal of cell (i, j),
/// shared by its two triangles.
#[test]
fn grid_diagonal_midpoints_lie_exactly_on_pixel_centres() {
    let (_dir, scene) = load_hard_ok("grid_diagonals_on_pixel_centres.txt");
    let mesh = &meshes(&scene)[0];
    assert_eq!((mesh.positions.len(), mesh.triangles.len()), (4225, 8192));
    for ((i, j), (x, y)) in pixel_centres_64(&scene) {
        let (ka, kb) = (65 * j + i, 65 * (j + 1) + i + 1);
        let (a, b) = (mesh.positions[ka as usize], mesh.positions[kb as usize]);
        assert_eq!((x - a.x, y - a.y, b.x - x, b.y - y), (0.5, 0.5, 0.5, 0.5), "pixel ({i}, {j})");
        let c = (64 * j + i) as usize;
        let sharing: Vec<usize> = (0..mesh.triangles.len())
            .filter(|&k| mesh.triangles[k].contains(&ka) && mesh.triangles[k].contains(&kb))
            .collect();
        assert_eq!(sharing, vec![2 * c, 2 * c + 1], "pixel ({i}, {j})");
    }
}

#[test]
fn edge_on_triangles_are_exactly_edge_on() {
    let (_dir, scene) = load_hard_ok("edge_on_triangles.txt");
    let centres = pixel_centres_64(&scene);
    let tris = triangles(&scene);
    assert_eq!(tris.len(), 6);
    let view = DVec3::new(0.0, 0.0, -1.0);
    // Pixel rays lying in each edge-on triangle's plane and crossing it: A, B, C, D, E.
    let in_plane_crossing = [40, 20, 0, 40, 11];
    for (t, expected) in tris[..5].iter().zip(in_plane_crossing) {
        let n = face_normal(t);
        assert!(n.length() > 0.0);
        assert_eq!(n.dot(view), 0.0, "{t:?} is not exactly edge-on");
        // A ray (x, y) lies in the plane when n · (x, y, 0) = n · v0; it crosses the
        // triangle when (x, y) is on the triangle's xy projection (a segment).
        let lo = t.iter().fold(DVec3::INFINITY, |m, v| m.min(*v));
        let hi = t.iter().fold(DVec3::NEG_INFINITY, |m, v| m.max(*v));
        let count = centres
            .iter()
            .filter(|(_, (x, y))| {
                n.x * x + n.y * y == n.x * t[0].x + n.y * t[0].y
                    && (lo.x..=hi.x).contains(x)
                    && (lo.y..=hi.y).contains(y)
            })
            .count();
        assert_eq!(count, expected, "{t:?}");
    }
    // F faces the camera and no pixel centre lies on its outline.
    let f = &tris[5];
    assert!(face_normal(f).dot(view) < 0.0);
    assert_eq!(centres_on_outline(&centres, f), 0);
}

#[test]
fn degenerate_triangles_are_exactly_degenerate_and_on_pixel_rays() {
    let (_dir, scene) = load_hard_ok("degenerate_triangles.txt");
    let centres = pixel_centres_64(&scene);
    let tris = triangles(&scene);
    assert_eq!(tris.len(), 6);
    // T1 ... T5: zero area, and how many pixel rays meet each (in x, y).
    for (t, expected) in tris[..5].iter().zip([7, 1, 11, 11, 1]) {
        assert_eq!(face_normal(t), DVec3::ZERO, "{t:?}");
        assert_eq!(centres_on_outline(&centres, t), expected, "{t:?}");
    }
    let g = &tris[5];
    assert!(face_normal(g).z > 0.0);
    assert_eq!(centres_on_outline(&centres, g), 0);

    let mesh = &meshes(&scene)[0];
    assert_eq!((mesh.positions.len(), mesh.triangles.len()), (11, 6));
    let mesh_rays = [8, 8, 1, 11, 0];
    for (k, expected) in mesh_rays.into_iter().enumerate() {
        let t = mesh.triangle(k);
        assert_eq!(face_normal(&t), DVec3::ZERO, "mesh triangle {k}");
        assert_eq!(centres_on_outline(&centres, &t), expected, "mesh triangle {k}");
    }
    let good = mesh.triangle(5);
    assert!(face_normal(&good).z > 0.0);
    assert_eq!(centres_on_outline(&centres, &good), 0);
}

#[test]
fn far_sphere_angle_is_one_and_a_quarter_angular_diameters() {
    let (_dir, scene) = load_hard_ok("far_sphere.txt");
    let Projection::Perspective { angle } = scene.camera.projection else { panic!("not perspective") };
    let expected = 2.5 * (1.0f64 / 5000.0).asin();
    assert!(((angle - expected) / expected).abs() < 1e-15, "{angle} vs {expected}");
    // The silhouette at 80 pixels from the centre of a 200-pixel image.
    let radius_px = (1.0f64 / 5000.0).asin().tan() / (angle / 2.0).tan() * 100.0;
    assert!((radius_px - 80.0).abs() < 1e-6, "{radius_px}");
}

/// The top-level blocks of a scene (name, tokens including the name and braces).
fn top_blocks(tokens: &[String]) -> Vec<(String, Vec<String>)> {
    let mut blocks = Vec::new();
    let mut k = 0;
    while k < tokens.len() {
        let start = k;
        let mut depth = 0;
        loop {
            match tokens[k].as_str() {
                "{" => depth += 1,
                "}" => depth -= 1,
                _ => {}
            }
            k += 1;
            if depth == 0 && tokens[k - 1] == "}" {
                break;
            }
        }
        blocks.push((tokens[start].clone(), tokens[start..k].to_vec()));
    }
    blocks
}

/// Case 6: each variant is the base scene with its object list wrapped in one Transform and
/// the camera centre moved the same way; everything else is token for token the same.
#[test]
fn offset_variants_are_the_base_scene_moved() {
    let read = |name: &str| tokens(&std::fs::read_to_string(hard_dir().join(name)).unwrap());
    let base = top_blocks(&read("offset_base.txt"));
    let (_, base_scene) = load_hard_ok("offset_base.txt");
    let variants: [Variant; 3] = [
        ("offset_translated_1e6.txt", &["Translate", "1000000", "1000000", "1000000"], |c| c + DVec3::splat(1e6)),
        ("offset_scaled_1e-4.txt", &["UniformScale", "0.0001"], |c| c * 1e-4),
        ("offset_scaled_1e4.txt", &["UniformScale", "10000"], |c| c * 1e4),
    ];
    for (name, step, map) in variants {
        let blocks = top_blocks(&read(name));
        assert_eq!(blocks.len(), base.len(), "{name}");
        for ((bn, bt), (vn, vt)) in base.iter().zip(&blocks) {
            assert_eq!(bn, vn, "{name}");
            match bn.as_str() {
                "PerspectiveCamera" => {
                    let strip = |t: &[String]| {
                        let c = t.iter().position(|s| s == "center").unwrap();
                        [&t[..c], &t[c + 4..]].concat()
                    };
                    assert_eq!(strip(bt), strip(vt), "{name}: camera differs beyond its centre");
                }
                "Group" => {
                    let mut expected: Vec<String> = ["Group", "{", "numObjects", "1", "Transform", "{"]
                        .iter()
                        .chain(step)
                        .map(|s| s.to_string())
                        .collect();
                    expected.extend(bt.iter().cloned());
                    expected.extend(["}".to_string(), "}".to_string()]);
                    assert_eq!(vt, &expected, "{name}: object list differs");
                }
                _ => assert_eq!(bt, vt, "{name}: {bn} differs"),
            }
        }
        let (_, scene) = load_hard_ok(name);
        let expected = map(base_scene.camera.center);
        let error = (scene.camera.center - expected).abs().max_element();
        assert!(error <= 1e-15 * expected.abs().max_element(), "{name}: centre {} vs {expected}", scene.camera.center);
        assert_eq!(scene.camera.direction, base_scene.camera.direction);
        assert_eq!(scene.camera.projection, base_scene.camera.projection);
        assert_eq!(scene.lights, base_scene.lights);
        let base_mesh = &meshes(&base_scene)[0];
        assert_same_mesh(&meshes(&scene)[0], base_mesh);
        assert!(base_mesh.path.ends_with("box.obj"));
    }
}
