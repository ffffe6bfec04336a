//! Meshes made by code, for tests and benchmarks: meshes too large to commit (a geodesic
//! sphere of 20 480 triangles, a 64 × 64 grid) are generated where they are needed, and
//! [`write_obj`] stores them so that [`load_obj`](super::load_obj) reads back exactly the
//! same numbers.

use super::model::Mesh;
use glam::DVec3;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

/// The most subdivisions [`icosphere`] accepts: 10·4^14 + 2 vertices still fit `u32`
/// indices (and would take tens of GiB; anything near this is a mistake).
pub const MAX_ICOSPHERE_SUBDIVISIONS: u32 = 14;

/// A geodesic sphere: an icosahedron subdivided `subdivisions` times, every vertex
/// projected onto the sphere (`center + radius · unit direction`).
///
/// - `20·4^s` triangles and `10·4^s + 2` vertices, with no duplicate vertices (each edge's
///   midpoint is made once, through a cache keyed by the edge's two vertex indices);
/// - closed: every edge is shared by exactly two triangles, which use it in opposite
///   directions;
/// - wound counter-clockwise seen from outside, so every face normal
///   `(v1 − v0) × (v2 − v0)` points away from `center`.
///
/// Subdivision splits each triangle `(a, b, c)` into `(a, ab, ca)`, `(b, bc, ab)`,
/// `(c, ca, bc)`, `(ab, bc, ca)`, where `ab` is the midpoint of `a` and `b` pushed out onto
/// the unit sphere. Directions are kept on the unit sphere throughout and scaled to
/// `radius` and moved to `center` at the end.
///
/// `path` is set to `generated:icosphere(center x y z, radius r, s)`.
///
/// # Panics
/// If `radius` is not finite and positive, `center` is not finite, or `subdivisions`
/// exceeds [`MAX_ICOSPHERE_SUBDIVISIONS`].
pub fn icosphere(center: DVec3, radius: f64, subdivisions: u32) -> Mesh {
    assert!(radius.is_finite() && radius > 0.0, "icosphere radius must be finite and positive, got {radius}");
    assert!(center.is_finite(), "icosphere center must be finite, got {center}");
    assert!(
        subdivisions <= MAX_ICOSPHERE_SUBDIVISIONS,
        "icosphere subdivisions {subdivisions} exceed {MAX_ICOSPHERE_SUBDIVISIONS}"
    );

    // The 12 vertices of an icosahedron: cyclic permutations of (0, ±1, ±φ).
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut directions: Vec<DVec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .into_iter()
    .map(|(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    // Counter-clockwise seen from outside.
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];

    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(triangles.len() * 3 / 2);
        let mut midpoint = |a: u32, b: u32, directions: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let m = (directions[a as usize] + directions[b as usize]).normalize();
                directions.push(m);
                (directions.len() - 1) as u32
            })
        };
        let mut finer = Vec::with_capacity(triangles.len() * 4);
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut directions);
            let bc = midpoint(b, c, &mut directions);
            let ca = midpoint(c, a, &mut directions);
            finer.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = finer;
    }

    let positions = directions.into_iter().map(|u| center + radius * u).collect();
    let path = format!(
        "generated:icosphere(center {} {} {}, radius {}, {})",
        center.x, center.y, center.z, radius, subdivisions
    );
    Mesh { path: PathBuf::from(path), positions, triangles, vertex_locations: Vec::new() }
}

/// A flat grid of `nx × ny` cells in the plane `z = z`.
///
/// Vertex `(i, j)`, for `i` in `0..=nx` and `j` in `0..=ny`, is at
/// `(x0 + i·dx, y0 + j·dy, z)`, computed exactly that way (so half-integer `x0`, `y0` with
/// unit steps give exact half-integer coordinates), and has index `j·(nx + 1) + i`.
///
/// Cell `(i, j)` (corners `v00 = (i, j)`, `v10 = (i+1, j)`, `v11 = (i+1, j+1)`,
/// `v01 = (i, j+1)`) is cell number `c = j·nx + i` (row by row from the bottom) and gives
/// triangles `2c = (v00, v10, v11)` (lower right) and `2c + 1 = (v00, v11, v01)` (upper
/// left). Every cell is split along the **same** diagonal, from `v00` to `v11` (no
/// alternation), so every interior vertex is shared by six triangles. With positive `dx`
/// and `dy` the triangles are counter-clockwise seen from +z (normal `+z`).
///
/// `path` is set to `generated:grid(x0, y0, dx, dy, nx, ny, z)`.
///
/// # Panics
/// If `(nx + 1)·(ny + 1)` vertices do not fit `u32` indices.
pub fn grid(x0: f64, y0: f64, dx: f64, dy: f64, nx: u32, ny: u32, z: f64) -> Mesh {
    let columns = u64::from(nx) + 1;
    let vertex_count = columns * (u64::from(ny) + 1);
    assert!(vertex_count <= u64::from(u32::MAX), "grid of {nx} x {ny} cells has too many vertices for u32 indices");

    let mut positions = Vec::with_capacity(vertex_count as usize);
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push(DVec3::new(x0 + f64::from(i) * dx, y0 + f64::from(j) * dy, z));
        }
    }
    let index = |i: u32, j: u32| j * (nx + 1) + i;
    let mut triangles = Vec::with_capacity(2 * nx as usize * ny as usize);
    for j in 0..ny {
        for i in 0..nx {
            let (v00, v10, v11, v01) = (index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
            triangles.push([v00, v10, v11]);
            triangles.push([v00, v11, v01]);
        }
    }
    let path = format!("generated:grid({x0}, {y0}, {dx}, {dy}, {nx}, {ny}, {z})");
    Mesh { path: PathBuf::from(path), positions, triangles, vertex_locations: Vec::new() }
}

/// Writes `mesh` as an OBJ file: a `#` comment naming `mesh.path`, then one
/// `v x y z` line per position and one `f a b c` line (1-based) per triangle.
///
/// Numbers are written with Rust's `{:?}` (the shortest decimal that reads back as the same
/// `f64`, e.g. `0.1`, `-0.0`, `1e-7`, `1.7976931348623157e308`), which the OBJ reader
/// accepts, so [`load_obj`](super::load_obj) gives back bit-identical positions and the
/// same triangles.
///
/// # Errors
/// An `InvalidInput` error (and no file) if a position is NaN or infinite (OBJ has no
/// spelling the reader accepts for them) or a triangle refers to a vertex that does not
/// exist; otherwise any error from creating or writing the file.
pub fn write_obj(mesh: &Mesh, path: &Path) -> io::Result<()> {
    let invalid = |message: String| io::Error::new(io::ErrorKind::InvalidInput, message);
    if let Some((k, p)) = mesh.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(invalid(format!("vertex {} of {} is not finite: {p}", k + 1, mesh.path.display())));
    }
    let count = mesh.positions.len();
    if let Some((k, t)) = mesh.triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= count)) {
        return Err(invalid(format!(
            "triangle {} of {} refers to a missing vertex: {t:?} with {count} vertices",
            k + 1,
            mesh.path.display()
        )));
    }

    let mut text = String::with_capacity(32 * count + 24 * mesh.triangles.len() + 64);
    // A path with a line break would end the comment early; keep the comment on one line.
    let name = mesh.path.display().to_string().replace(['\r', '\n'], " ");
    let _ = writeln!(text, "# {name}");
    let _ = writeln!(text, "# {} vertices, {} triangles", count, mesh.triangles.len());
    for p in &mesh.positions {
        let _ = writeln!(text, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for [a, b, c] in &mesh.triangles {
        let _ = writeln!(text, "f {} {} {}", u64::from(*a) + 1, u64::from(*b) + 1, u64::from(*c) + 1);
    }
    let mut file = io::BufWriter::new(std::fs::File::create(path)?);
    file.write_all(text.as_bytes())?;
    file.flush()
}
