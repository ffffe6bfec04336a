//! The grid the kernel draws for `-visualize_grid` (shaders/voxels.wgsl): the course's
//! occupancy of docs/SPEC.md §7, worked out from the parsed scene in f64 world space by the
//! section's rules, so that the picture shows the cells the reference's picture shows (the
//! kernel's own `-grid`, [`super::flatten::GpuGrid`], places every primitive by its f32 box
//! and a wider margin: right for finding hits, not the course's occupancy).
//!
//! - an untransformed sphere: the handout's rule, the cells whose centre lies within its
//!   radius plus half the cell's diagonal ([`Footprint::Sphere`]);
//! - a sphere under a Transform: the box of its ellipsoid;
//! - a triangle, and each triangle of a mesh: the box of its transformed vertices;
//! - planes: in no cell.
//!
//! The kernel needs only how many items each cell holds: cell `x + nx·(y + ny·z)` gets
//! `ranges` entry `[0, count]`, and no references.

use super::flatten::GpuGrid;
use crate::clock::Instant;
use crate::grid::{Footprint, Grid, GridSize};
use crate::scene::{for_each_leaf, Bounds, Scene, Shape};
use glam::{DMat4, DVec3};

/// The voxel grid of `scene` at `size`, its corner moved by `-camera_center` as the
/// kernel's coordinates are (docs/SPEC.md §3; gpu::flatten).
pub fn voxel_grid(scene: &Scene, size: GridSize, camera_center: DVec3) -> GpuGrid {
    let start = Instant::now();
    let footprints = footprints(scene);
    let bounds = footprints.iter().fold(Bounds::EMPTY, |all, f| all.union(&f.bounds()));
    let grid = Grid::new(bounds, size, &footprints);
    let [nx, ny, nz] = grid.size();
    let mut ranges = Vec::with_capacity(grid.cell_count());
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                ranges.push([0, grid.items([x, y, z]).len() as u32]);
            }
        }
    }
    let relative = |v: DVec3| (v - camera_center).as_vec3().to_array();
    GpuGrid {
        size: [size.nx, size.ny, size.nz],
        bounds: match grid.bounds.is_empty() {
            true => Bounds::EMPTY,
            false => Bounds { min: grid.bounds.min - camera_center, max: grid.bounds.max - camera_center },
        },
        min: if grid.bounds.is_empty() { [0.0; 3] } else { relative(grid.bounds.min) },
        cell: grid.cell_extent().as_vec3().to_array(),
        ranges,
        refs: Vec::new(),
        build_ms: start.elapsed().as_secs_f64() * 1e3,
    }
}

/// Every sphere, triangle and mesh triangle of `scene`, in world space, by the rules of the
/// module's documentation.
fn footprints(scene: &Scene) -> Vec<Footprint> {
    let mut out = Vec::new();
    for_each_leaf(&scene.root, &DMat4::IDENTITY, &mut |leaf| {
        let to_world = leaf.transform.map(|_| leaf.to_world);
        let box_of = |vertices: [DVec3; 3]| {
            Footprint::Box(Bounds::of_points(vertices.map(|v| to_world.map_or(v, |m| m.transform_point3(v)))))
        };
        match &leaf.object.shape {
            &Shape::Sphere { center, radius, .. } => out.push(match to_world {
                None => Footprint::Sphere { center, radius },
                Some(m) => Footprint::Box(Bounds::ellipsoid(
                    &(m * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius))),
                )),
            }),
            Shape::Triangle { vertices, .. } => out.push(box_of(*vertices)),
            Shape::Mesh { mesh, .. } => out.extend((0..mesh.triangles.len()).map(|k| box_of(mesh.triangle(k)))),
            _ => {}
        }
    });
    out
}
