//! Loading the hard-case scenes of `scenes/hard/`, whose large meshes are generated.

use glam::DVec3;
use raycaster::scene::generate::{grid, icosphere, write_obj};
use raycaster::scene::{load_scene, Mesh, Scene};
use std::path::{Path, PathBuf};

pub fn hard_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard")
}

/// The meshes the hard scenes refer to but that are generated rather than committed,
/// by file name (the calls the scenes' comments name).
pub fn generated_mesh(file_name: &str) -> Option<Mesh> {
    match file_name {
        "icosphere5.obj" => Some(icosphere(DVec3::ZERO, 1.0, 5)),
        "grid_vertices.obj" => Some(grid(-31.5, -31.5, 1.0, 1.0, 63, 63, 0.0)),
        "grid_edges.obj" => Some(grid(-32.0, -31.5, 1.0, 1.0, 64, 63, 0.0)),
        "grid_diagonals.obj" => Some(grid(-32.0, -32.0, 1.0, 1.0, 64, 64, 0.0)),
        _ => None,
    }
}

/// The tokens of a scene file with `#` comments removed.
pub fn tokens(text: &str) -> Vec<String> {
    text.lines().flat_map(|line| line.split('#').next().unwrap_or("").split_whitespace()).map(String::from).collect()
}

/// Loads `scenes/hard/<name>`. When it refers to generated meshes, they are written into a
/// temporary folder next to a copy of the scene, which is loaded from there; the folder is
/// returned so that it lives as long as the caller needs the files.
pub fn load_hard(name: &str) -> (Option<tempfile::TempDir>, Result<Scene, raycaster::scene::SceneError>) {
    let path = hard_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let toks = tokens(&text);
    let generated: Vec<(&str, Mesh)> = toks
        .windows(2)
        .filter(|w| w[0] == "obj_file")
        .filter_map(|w| generated_mesh(&w[1]).map(|m| (w[1].as_str(), m)))
        .collect();
    if generated.is_empty() {
        return (None, load_scene(&path));
    }
    let dir = tempfile::tempdir().unwrap();
    for (file_name, mesh) in &generated {
        // The scene's comment must say how its mesh is made.
        assert!(text.contains(&format!("into {file_name}")), "{name} does not say how {file_name} is generated");
        write_obj(mesh, &dir.path().join(file_name)).unwrap();
    }
    std::fs::copy(&path, dir.path().join(name)).unwrap();
    let scene = load_scene(&dir.path().join(name));
    (Some(dir), scene)
}

pub fn load_hard_ok(name: &str) -> (Option<tempfile::TempDir>, Scene) {
    let (dir, scene) = load_hard(name);
    (dir, scene.unwrap_or_else(|e| panic!("{e}")))
}

/// Any scene of ours or of the course, by path: a hard case through [`load_hard`] (its
/// meshes generated), any other as it is; `None` for the one hard case that must not load.
/// Any other load error fails the test.
pub fn load_listed(path: &std::path::Path) -> Option<(Option<tempfile::TempDir>, Scene)> {
    let name = path.file_name().unwrap().to_str().unwrap();
    let (dir, loaded) = if path.starts_with(hard_dir()) { load_hard(name) } else { (None, load_scene(path)) };
    match loaded {
        Ok(scene) => Some((dir, scene)),
        Err(_) if name == "singular_transform.txt" => None,
        Err(e) => panic!("{e}"),
    }
}
