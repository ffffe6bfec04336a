//! `-grid`, `-visualize_grid` and `-stats` (the course's assignments 5 and 6; docs/SPEC.md
//! §7): the 3D-DDA against a brute-force walk of every cell, the reference's nearest hits
//! and shadow answers with and without the grid, a voxel picture against occupancy worked
//! out here, the statistics against counts predicted from the scene, and the course's
//! command lines of both assignments run as written.

mod common;

use common::bin::{path_str, raycaster, raycaster_in, stderr};
use glam::DVec3;
use raycaster::camera::{PrimaryRays, Ray};
use raycaster::cpu::ReferenceScene;
use raycaster::gpu::Acceleration;
use raycaster::grid::{Grid, GridSize};
use raycaster::render::{RenderOptions, Shading};
use raycaster::scene::{load_scene, parse_scene, Bounds, Scene};
use std::path::Path;

/// Deterministic random inputs ([`common::splitmix64`]), so that a failure replays.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        common::splitmix64(&mut self.0)
    }

    /// Uniform in `lo..hi`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    fn vector(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.uniform(lo, hi), self.uniform(lo, hi), self.uniform(lo, hi))
    }

    /// Uniform in the box `lo..hi`.
    fn point_in(&mut self, lo: DVec3, hi: DVec3) -> DVec3 {
        DVec3::new(self.uniform(lo.x, hi.x), self.uniform(lo.y, hi.y), self.uniform(lo.z, hi.z))
    }

    fn cells(&mut self, most: u64) -> u32 {
        1 + (self.next() % most) as u32
    }
}

/// The part of the line `o + t·d` inside the box `lo..hi` within `t_min..t_max`, by the slab
/// test, or `None`: written here rather than taken from the library, as the brute force.
fn slab(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
    let (mut near, mut far) = (t_min, t_max);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near <= far).then_some((near, far))
}

/// Amanatides and Woo's march visits exactly the cells a brute-force test of every cell
/// finds the ray inside for more than a sliver, in order of entry, with the same entry and
/// exit t; and no cell it visits is one the ray misses. Random grids (1 to 7 cells an axis,
/// flat boxes included by their widening), origins inside and outside, axis-aligned and
/// general directions, finite and infinite intervals.
#[test]
fn dda_visits_the_cells_brute_force_finds() {
    let mut rng = Rng(7);
    for case in 0..3000 {
        let lo = rng.vector(-3.0, 3.0);
        let bounds = Bounds { min: lo, max: lo + rng.vector(0.2, 4.0) };
        let size = GridSize { nx: rng.cells(7), ny: rng.cells(7), nz: rng.cells(7) };
        let grid = Grid::new(bounds, size, &[]);
        let origin = rng.vector(-8.0, 8.0);
        let mut direction = rng.vector(-1.0, 1.0);
        if case % 5 == 0 {
            // Axis-aligned rays, where two of the three t_next never come.
            let axis = case / 5 % 3;
            direction = DVec3::ZERO;
            direction[axis] = if case % 2 == 0 { 1.0 } else { -1.0 };
        }
        let t_min = if case % 3 == 0 { f64::NEG_INFINITY } else { 0.0 };
        let t_max = if case % 4 == 0 { rng.uniform(0.0, 12.0) } else { f64::INFINITY };
        let visits: Vec<_> = grid.march(origin, direction, t_min, t_max).collect();

        let cell = grid.cell_extent();
        let sliver = 1e-7 * (1.0 + origin.length()) / direction.length();
        let mut expected = Vec::new();
        for k in 0..size.nz as usize {
            for j in 0..size.ny as usize {
                for i in 0..size.nx as usize {
                    let c = DVec3::new(i as f64, j as f64, k as f64);
                    let (clo, chi) = (grid.bounds.min + c * cell, grid.bounds.min + (c + 1.0) * cell);
                    if let Some((t0, t1)) = slab(origin, direction, clo, chi, t_min, t_max) {
                        expected.push(([i, j, k], t0, t1));
                    }
                }
            }
        }
        for visit in &visits {
            let found = expected.iter().find(|e| e.0 == visit.cell);
            let &(_, t0, t1) = found.unwrap_or_else(|| panic!("case {case}: visited {:?}, not on the ray", visit.cell));
            assert!((visit.t_enter - t0).abs() <= sliver, "case {case}: {visit:?} enters at {t0}");
            assert!((visit.t_exit - t1).abs() <= sliver, "case {case}: {visit:?} leaves at {t1}");
        }
        let mut inside: Vec<_> = expected.iter().filter(|e| e.2 - e.1 > sliver).collect();
        inside.sort_by(|a, b| a.1.total_cmp(&b.1));
        let visited: Vec<_> = visits.iter().filter(|v| v.t_exit - v.t_enter > sliver).map(|v| v.cell).collect();
        assert_eq!(visited, inside.iter().map(|e| e.0).collect::<Vec<_>>(), "case {case}");
        for pair in visits.windows(2) {
            assert_eq!(pair[0].t_exit, pair[1].t_enter, "case {case}: cells follow one another");
        }
    }
}

/// The course's A6 scenes that this branch parses (13 to 18 use the solid textures of
/// another branch), with the grid of their command lines.
const A6_GRIDS: [(&str, [u32; 3]); 12] = [
    ("scene6_01_sphere.txt", [10, 10, 10]),
    ("scene6_02_sphere_triangles.txt", [10, 10, 10]),
    ("scene6_03_sphere_plane.txt", [10, 10, 10]),
    ("scene6_04_bunny_mesh_200.txt", [10, 10, 7]),
    ("scene6_05_bunny_mesh_1k.txt", [15, 15, 12]),
    ("scene6_06_bunny_mesh_5k.txt", [20, 20, 15]),
    ("scene6_07_bunny_mesh_40k.txt", [40, 40, 33]),
    ("scene6_08_scale_translate.txt", [15, 15, 15]),
    ("scene6_09_rotated_triangles.txt", [15, 15, 9]),
    ("scene6_10_nested_transformations.txt", [30, 30, 30]),
    ("scene6_11_mirrored_floor.txt", [40, 10, 40]),
    ("scene6_12_faceted_gem.txt", [20, 20, 20]),
];

fn size_of([nx, ny, nz]: [u32; 3]) -> GridSize {
    GridSize { nx, ny, nz }
}

/// Every A6 scene rendered by the reference with shadows and 5 bounces, with and without
/// its grid: the same image, float for float (the grid changes which primitives are tested,
/// never which hit is nearest nor whether a light is blocked). The 40 000-triangle bunny at
/// 24², the rest at 64²: without a grid the reference tests every triangle.
#[test]
fn the_grid_changes_no_pixel_of_the_reference() {
    let Some(corpus) = common::corpus() else { return };
    for (name, cells) in A6_GRIDS {
        let scene = load_scene(&corpus.join("a6").join(name)).unwrap();
        let side = if name.contains("40k") { 24 } else { 64 };
        let shading = Shading { shadows: true, shade_back: true, bounces: 5, weight: 0.01, ..Shading::default() };
        let plain = RenderOptions { shading, ..RenderOptions::all(side, side) };
        let gridded = RenderOptions { grid: Some(size_of(cells)), ..plain };
        let without = raycaster::cpu::render(&scene, &plain);
        let with = raycaster::cpu::render(&scene, &gridded);
        let differ = (0..without.hit.len()).filter(|&k| without.pixel(k) != with.pixel(k)).count();
        assert_eq!(differ, 0, "{name}: {differ} pixels differ with -grid {cells:?}");
    }
}

/// Random rays, from anywhere (inside the grid too) in any direction, through the scenes
/// of `scenes/` and the A6 scenes at coarse, fine and lopsided grids: the same nearest hit
/// (t, primitive and triangle) and the same shadow answer over a random interval.
#[test]
fn random_rays_find_the_same_hits_through_any_grid() {
    let mut scenes: Vec<Scene> =
        ["transforms_all.txt", "nested_transforms.txt", "mesh_octahedron.txt", "triangles.txt"]
            .iter()
            .map(|name| load_scene(&common::scenes_dir().join(name)).unwrap())
            .collect();
    if let Some(corpus) = common::corpus() {
        for (name, _) in &A6_GRIDS[..6] {
            scenes.push(load_scene(&corpus.join("a6").join(name)).unwrap());
        }
    }
    let mut rng = Rng(11);
    for scene in &scenes {
        let plain = ReferenceScene::new(scene);
        let extent = scene_box(scene);
        for cells in [[1, 1, 1], [4, 4, 4], [13, 2, 7]] {
            let gridded = ReferenceScene::with_grid(scene, size_of(cells));
            for _ in 0..3000 {
                let (lo, hi) = (extent.min - 1.0, extent.max + 1.0);
                let origin = rng.point_in(lo, hi);
                let target = rng.point_in(lo, hi);
                let ray = Ray::new(origin, (target - origin).normalize(), 0.0);
                let what = format!("{}, grid {cells:?}, {ray:?}", scene.path.display());
                assert_eq!(plain.closest_hit(&ray), gridded.closest_hit(&ray), "{what}");
                let shadow = Ray { t_max: rng.uniform(0.0, 2.0 * (hi - lo).length()), ..ray };
                assert_eq!(plain.occluded(&shadow), gridded.occluded(&shadow), "{what}, to {}", shadow.t_max);
            }
        }
    }
}

/// A box around the scene's bounded primitives (each one's own box carried by its
/// transform), where the random rays start and aim.
fn scene_box(scene: &Scene) -> Bounds {
    let mut all = Bounds::EMPTY;
    raycaster::scene::for_each_leaf(&scene.root, &glam::DMat4::IDENTITY, &mut |leaf| {
        if let Some(own) = leaf.object.bounds().bounds() {
            all = all.union(&transformed(&own, &leaf.to_world));
        }
    });
    all
}

/// The box of `b`'s eight corners under `m`.
fn transformed(b: &Bounds, m: &glam::DMat4) -> Bounds {
    if b.is_empty() {
        return *b;
    }
    let corners = (0..8).map(|k| {
        let pick = |bit: usize, a: usize| if k >> bit & 1 == 1 { b.max[a] } else { b.min[a] };
        m.transform_point3(DVec3::new(pick(0, 0), pick(1, 1), pick(2, 2)))
    });
    Bounds::of_points(corners)
}

/// Two spheres seen along −z by an orthographic camera with `-grid 5 5 5 -visualize_grid`:
/// each pixel's hit, depth, normal and colour against the occupancy worked out here with
/// the handout's rule (a cell is occupied when its centre lies within the radius plus half
/// the cell's diagonal of a sphere's centre). The grid spans the union of the spheres'
/// boxes, [−1, 3]³, in cells of 0.8; a pixel sees its column's nearest occupied cell at
/// that cell's front face. Pixels within 10⁻⁶ of a column's edge are left out. Both
/// backends' pictures, the GPU's where there is one.
#[test]
fn a_voxel_picture_shows_the_occupancy_worked_out_here() {
    let text = "OrthographicCamera { center 1 1 10 direction 0 0 -1 up 0 1 0 size 5 }\n\
                Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 0.5 0.5 0.5 } }\n\
                Background { color 0 0 0 ambientLight 0.2 0.2 0.2 }\n\
                Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n\
                Group { numObjects 2 MaterialIndex 0\n\
                  Sphere { center 0 0 0 radius 1 }\n\
                  Sphere { center 2.9 2.9 2.9 radius 0.1 } }\n";
    let scene = parse_scene(text, Path::new("voxels.txt")).unwrap();
    let spheres = [(DVec3::ZERO, 1.0), (DVec3::splat(2.9), 0.1)];
    let (min, cell) = (-1.0, 0.8);
    let half_diagonal = cell * 3f64.sqrt() / 2.0;
    let centre = |c: usize| min + (c as f64 + 0.5) * cell;
    let occupied = |i: usize, j: usize, k: usize| {
        spheres.iter().any(|&(c, r)| {
            let distance = DVec3::new(centre(i), centre(j), centre(k)).distance(c);
            assert!((distance - (r + half_diagonal)).abs() > 1e-6, "a cell centre on the threshold");
            distance <= r + half_diagonal
        })
    };
    let size = 100;
    let options = RenderOptions {
        grid: Some(GridSize { nx: 5, ny: 5, nz: 5 }),
        visualize_grid: true,
        ..RenderOptions::all(size, size)
    };
    let mut frames = vec![("reference", raycaster::cpu::render(&scene, &options))];
    if let Some(gpu) = common::gpu() {
        frames.push(("GPU", gpu.render(&scene, &options).unwrap()));
    }
    for (backend, frame) in frames {
        check_voxel_frame(backend, &frame, &scene, size, &occupied);
    }
}

/// [`a_voxel_picture_shows_the_occupancy_worked_out_here`]'s checks of one backend's frame.
fn check_voxel_frame(
    backend: &str,
    frame: &raycaster::render::Frame,
    scene: &Scene,
    size: u32,
    occupied: &dyn Fn(usize, usize, usize) -> bool,
) {
    let (min, cell, n) = (-1.0, 0.8, 5usize);
    let rays = PrimaryRays::for_camera(&scene.camera, size, size);
    let (mut covered, mut checked) = (0, 0);
    for row in 0..size {
        for i in 0..size {
            let origin = rays.ray(i, size - 1 - row).origin;
            let column = [origin.x, origin.y].map(|x| (x - min) / cell);
            if column.iter().any(|c| (c - c.round()).abs() * cell < 1e-6) {
                continue;
            }
            let k = (row * size + i) as usize;
            let front = column
                .iter()
                .all(|c| (0.0..n as f64).contains(c))
                .then(|| (0..n).rev().find(|&z| occupied(column[0] as usize, column[1] as usize, z)))
                .flatten();
            checked += 1;
            assert_eq!(frame.hit[k], front.is_some(), "{backend}: pixel ({i}, {row}) over column {column:?}");
            let Some(z) = front else { continue };
            covered += 1;
            let face = min + (z + 1) as f64 * cell;
            assert!(
                (frame.depth[k] as f64 - (10.0 - face)).abs() < 1e-5,
                "{backend}: pixel ({i}, {row}): {}",
                frame.depth[k]
            );
            assert_eq!(frame.normal[k], [0.0, 0.0, 1.0]);
            // One item per occupied cell (the spheres share none): magenta, lit head-on.
            assert_eq!(frame.color[k], [0.7, 0.0, 0.7]);
        }
    }
    assert!(covered > 1000 && checked > 9000, "covered {covered} of {checked}");
}

/// The value of a `-stats` line, by its label.
fn stat(stdout: &str, label: &str) -> u64 {
    let line = stdout.lines().find(|l| l.trim_start().starts_with(label)).unwrap_or_else(|| panic!("{stdout}"));
    line.split_whitespace().nth(label.split_whitespace().count()).unwrap().parse().unwrap()
}

/// `-stats` counts what the scene predicts: one primary ray a pixel, each testing the
/// three primitives; with `-shadows`, one shadow ray per hit pixel per light facing it,
/// each testing up to all three. With a grid, cells are traversed and fewer tests made.
/// The block goes to stdout, nothing else does.
#[test]
fn stats_count_rays_tests_and_cells() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.txt");
    std::fs::write(
        &scene,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 8 }\n\
         Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n\
         Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n\
         Group { numObjects 3 MaterialIndex 0\n\
           Sphere { center -2 0 0 radius 1 }\n\
           Sphere { center 2 0 0 radius 1 }\n\
           Plane { normal 0 0 1 offset -5 } }\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let out = dir.path().join("o.tga");
        let args = [&["-input", path_str(&scene), "-size", "20", "10", "-output", path_str(&out)], extra].concat();
        let result = raycaster(&[&args[..], &["--backend", "cpu"]].concat());
        assert!(result.status.success(), "{}", stderr(&result));
        assert!(result.stderr.is_empty(), "{}", stderr(&result));
        String::from_utf8(result.stdout).unwrap()
    };
    let plain = run(&["-stats"]);
    assert!(plain.contains("num pixels                 200 (20x10)"), "{plain}");
    assert_eq!(stat(&plain, "num non-shadow rays"), 200);
    assert_eq!(stat(&plain, "num shadow rays"), 0);
    assert_eq!(stat(&plain, "total intersections"), 600);
    assert_eq!(stat(&plain, "total cells traversed"), 0);
    // Every pixel hits the plane or a sphere, and the light faces all of them; a shadow ray
    // that finds a blocker stops there, so it tests 1 to 3 primitives.
    let shadows = run(&["-stats", "-shadows"]);
    assert_eq!(stat(&shadows, "num shadow rays"), 200);
    let tests = stat(&shadows, "total intersections") - 600;
    assert!((200..=600).contains(&tests), "{shadows}");

    let gridded = run(&["-stats", "-grid", "8", "2", "2"]);
    assert!(gridded.contains("num grid cells             32 (8x2x2)"), "{gridded}");
    assert_eq!(stat(&gridded, "num non-shadow rays"), 200);
    assert!(stat(&gridded, "total cells traversed") > 0, "{gridded}");
    assert!(stat(&gridded, "total intersections") < 600, "{gridded}");
    assert!(run(&[]).is_empty(), "stdout without -stats");
}

/// `-grid` takes three whole numbers ≥ 1; `-visualize_grid` needs a grid: bad values are a
/// one-line usage error naming the flag, status 2, nothing written.
#[test]
fn grid_flags_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.tga");
    let o = path_str(&out);
    let base = ["-input", "scenes/spheres_ortho.txt", "-size", "5", "5", "-output", o];
    let cases: [(&[&str], &str); 6] = [
        (&["-grid", "0", "5", "5"], "-grid: '0' is not a whole number of cells, 1 or more"),
        (&["-grid", "5", "x", "5"], "-grid: 'x' is not a whole number of cells, 1 or more"),
        (&["-grid", "5", "5"], "-grid expects three numbers of cells: NX NY NZ"),
        (&["-grid", "4096", "4096", "2"], "-grid 4096 4096 2: more than 16777216 cells"),
        (&["-visualize_grid"], "-visualize_grid draws the grid's cells: give -grid NX NY NZ too"),
        (&["--grid=5"], "--grid= is not supported: write --grid NX NY NZ"),
    ];
    for (extra, message) in cases {
        let result = raycaster(&[&base[..], extra].concat());
        assert_eq!(result.status.code(), Some(2), "{extra:?}: {}", stderr(&result));
        let said = stderr(&result);
        assert_eq!(said.lines().count(), 1, "{extra:?}: {said}");
        assert!(said.starts_with(&format!("raycaster: {message}")), "{extra:?}: {said}");
        assert!(!out.exists(), "{extra:?} wrote an image");
    }
    let typo = raycaster(&[&base[..], &["-visualise_grid"]].concat());
    assert!(stderr(&typo).contains("did you mean '-visualize_grid'?"), "{}", stderr(&typo));
    let count =
        raycaster(&[&base[..], &["-grid", "2", "2", "2", "-visualize_grid_count", "--backend", "cpu"]].concat());
    assert!(count.status.success() && out.exists(), "{}", stderr(&count));
}

/// The kernel's grid (shaders/grid.wgsl) against the reference's, on every A6 scene this
/// branch parses, with the course's grid and the heaviest shading of its lines (shadows,
/// 5 bounces): the parity contract, at most 0.1 % of each output's pixels more than one
/// level apart.
#[test]
fn the_gpu_grid_agrees_with_the_reference() {
    let (Some(corpus), Some(gpu)) = (common::corpus(), common::gpu()) else { return };
    let mut report = Vec::new();
    for (name, cells) in A6_GRIDS {
        let scene = load_scene(&corpus.join("a6").join(name)).unwrap();
        let shading = Shading { shadows: true, shade_back: true, bounces: 5, weight: 0.01, ..Shading::default() };
        let options = RenderOptions { shading, grid: Some(size_of(cells)), ..RenderOptions::all(100, 100) };
        let ours = gpu.render(&scene, &options).unwrap_or_else(|e| panic!("{name}: {e}"));
        let reference = raycaster::cpu::render(&scene, &options);
        let range = raycaster::metrics::depth_range_of(&reference);
        for errors in raycaster::metrics::compare_frames(&ours, &reference, range) {
            let off = errors.image.off_by_more_than_one;
            report.push(format!(
                "{name} {}: {off} of {} off by more than 1",
                errors.output.name(),
                errors.image.pixels
            ));
            assert!(off * 1000 <= errors.image.pixels, "{}", report.last().unwrap());
            assert_eq!(errors.non_finite, 0, "{name}");
        }
    }
    println!("{}", report.join("\n"));
}

/// On a driver that ends long loops (lavapipe), marches through a 1×1×1 grid of 40 000
/// triangles, a camera ray's and two shadow rays', outrun the limit: every pixel checks its
/// loops (tests/loop_limit.rs), so the pixels cut short are marked and rendered by the
/// reference. The depth image alone (one march) and all the images with shadows are the
/// reference's, and so are the `-stats` counts: a pixel cut short adds none of the kernel's
/// counts and all of the reference's, and the others walk the one cell's list, every
/// triangle in the reference's order.
#[test]
fn a_march_longer_than_the_loop_limit_is_rendered_by_the_reference() {
    let (Some(corpus), Some(gpu)) = (common::corpus(), common::gpu()) else { return };
    let scene = load_scene(&corpus.join("a6/scene6_07_bunny_mesh_40k.txt")).unwrap();
    let depth_only = RenderOptions {
        outputs: raycaster::render::Output::Depth.into(),
        grid: Some(GridSize { nx: 1, ny: 1, nz: 1 }),
        stats: true,
        ..RenderOptions::all(8, 8)
    };
    let shading = raycaster::render::Shading { shadows: true, ..Default::default() };
    let shadows = RenderOptions { outputs: raycaster::render::Outputs::ALL, shading, ..depth_only };
    for options in [depth_only, shadows] {
        let (ours, stats) = common::render_gpu_tiles(gpu, &scene, &options);
        if gpu.loop_limit().is_some() && options.shading.shadows {
            assert!(stats.pixels_cut_short > 0, "no pixel cut short: the scene no longer tests the limit");
        }
        let renderer = raycaster::cpu::Reference::new(&scene, &options);
        let reference = renderer.rows(0, options.height);
        let range = raycaster::metrics::depth_range_of(&reference);
        for errors in raycaster::metrics::compare_frames(&ours, &reference, range) {
            assert!(errors.image.off_by_more_than_one == 0, "{errors:?}");
        }
        assert_eq!(stats.counted, Some(renderer.stats()), "{} pixels cut short", stats.pixels_cut_short);
    }
}

/// The GPU draws voxels and counts from the command line (`--backend gpu`): status 0,
/// nothing on stderr, the `-stats` block on stdout. Through a grid of spheres, primary rays
/// only, both backends list the same items (the sphere rule, docs/SPEC.md §7) and print the
/// same rays, tests and cells; without a grid, the kernel's flat loops test every primitive
/// for every pixel, as the reference does. The voxel picture is the reference's within the
/// contract.
#[test]
fn the_gpu_counts_and_draws_voxels_from_the_command_line() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = common::scenes_dir().join("spheres_ortho.txt");
    let run = |backend: &str, image: &str, extra: &[&str]| {
        let base = ["-input", path_str(&scene), "-size", "300", "200", "-output", image, "--backend", backend];
        let result = raycaster_in(dir.path(), &[&base[..], extra].concat());
        assert!(result.status.success() && result.stderr.is_empty(), "{extra:?}: {}", stderr(&result));
        String::from_utf8(result.stdout).unwrap()
    };
    let counts = |stdout: &str| {
        ["num non-shadow rays", "num shadow rays", "total intersections", "total cells traversed"]
            .map(|label| stat(stdout, label))
    };
    let gridded = ["-grid", "3", "3", "3", "-stats"];
    let (gpu, cpu) = (run("gpu", "g.tga", &gridded), run("cpu", "c.tga", &gridded));
    assert_eq!(counts(&gpu), counts(&cpu), "{gpu}\n{cpu}");
    assert!(gpu.contains("num grid cells             27 (3x3x3)"), "{gpu}");
    let flat = run("gpu", "g.tga", &["-stats"]);
    assert_eq!(counts(&flat), [60_000, 0, 3 * 60_000, 0], "{flat}");
    assert!(run("gpu", "g.tga", &[]).is_empty(), "stdout without -stats");
    let voxels = ["-grid", "5", "5", "5", "-visualize_grid"];
    run("gpu", "g.tga", &voxels);
    run("cpu", "c.tga", &voxels);
    let read = |name: &str| raycaster::image_io::read_image(&dir.path().join(name)).unwrap();
    let diff = raycaster::metrics::image_diff(&read("g.tga"), &read("c.tga"));
    assert!(diff.off_by_more_than_one * 1000 <= diff.pixels, "{diff:?}");
    // In a batch, each line's block follows its images, on stdout, with the line's counts.
    let lines = format!(
        "-input {0} -size 300 200 -output b1.tga -grid 3 3 3 -stats\n-input {0} -size 30 20 -output b2.tga -stats\n",
        path_str(&scene)
    );
    std::fs::write(dir.path().join("lines.txt"), lines).unwrap();
    let batch = raycaster_in(dir.path(), &["batch", "lines.txt", "--backend", "gpu"]);
    assert!(batch.status.success(), "{}", stderr(&batch));
    let stdout = String::from_utf8(batch.stdout).unwrap();
    let blocks: Vec<&str> = stdout.split("RAY TRACING STATISTICS").skip(1).collect();
    assert_eq!(blocks.len(), 2, "{stdout}");
    assert_eq!(counts(blocks[0]), counts(&gpu), "{stdout}");
    assert_eq!(counts(blocks[1]), [600, 0, 3 * 600, 0], "{stdout}");
    assert!(dir.path().join("b1.tga").exists() && dir.path().join("b2.tga").exists());

    // A grid over nothing (a plane alone): no ray enters a cell, on either backend.
    let plane = dir.path().join("plane.txt");
    std::fs::write(
        &plane,
        "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }\n\
         Materials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n\
         Group { numObjects 1 MaterialIndex 0 Plane { normal 0 1 0 offset -1 } }\n",
    )
    .unwrap();
    for extra in [&[][..], &["-visualize_grid"]] {
        let base =
            ["-input", path_str(&plane), "-size", "20", "20", "-output", "p.tga", "-grid", "2", "2", "2", "-stats"];
        let stdout = |backend: &str| {
            let result = raycaster_in(dir.path(), &[&base[..], extra, &["--backend", backend]].concat());
            assert!(result.status.success(), "{}", stderr(&result));
            counts(&String::from_utf8(result.stdout).unwrap())
        };
        assert_eq!(stdout("gpu"), stdout("cpu"), "{extra:?}");
        assert_eq!(stdout("gpu")[3], 0, "{extra:?}");
    }
}

/// Every line of the course's A5 and A6 `commands.txt`, as written (the default backend),
/// inside a copy of its folder: each exits 0 and writes the image its `-output` names; the
/// lines with `-stats` print the block on stdout. A5's `-gui` lines without `-output` write
/// nothing, as the course's window shows only. Then each file as one `batch`.
#[test]
fn the_course_lines_of_assignments_5_and_6_run() {
    let Some(corpus) = common::corpus() else { return };
    for (folder, expected) in [("a5", 21), ("a6", 44)] {
        let dir = tempfile::tempdir().unwrap();
        common::copy_course_folder(&corpus, folder, dir.path());
        let lines = common::course_commands(&corpus, folder);
        assert_eq!(lines.len(), expected, "{folder}/commands.txt");
        for command in &lines {
            let args: Vec<&str> = command.iter().map(String::as_str).collect();
            let result = raycaster_in(dir.path(), &args);
            assert!(result.status.success(), "{}: {}", command.join(" "), stderr(&result));
            if let Some(k) = command.iter().position(|a| a == "-output") {
                assert!(dir.path().join(&command[k + 1]).exists(), "{}: no image", command.join(" "));
            }
            let stdout = String::from_utf8_lossy(&result.stdout);
            assert_eq!(command.contains(&"-stats".to_string()), stdout.contains("RAY TRACING STATISTICS"));
        }
        // The same lines as one batch: every one renders; what stderr says is only the
        // GPU's refusals (a texture it cannot render faithfully) handed to the reference,
        // and the preview notes.
        let batch = raycaster_in(dir.path(), &["batch", "commands.txt"]);
        let said = stderr(&batch);
        assert!(batch.status.success(), "{folder}: {said}");
        for line in said.lines() {
            let handed_over =
                line.contains(": warning: ") && line.ends_with("rendering with the f64 CPU reference instead");
            assert!(handed_over || line.contains(": note: "), "{folder}: {line}");
        }
    }
}

/// The A6 lines with `-grid` and `-stats` (at 100², their grids and shading), for
/// [`gpu_stats_agree_with_the_reference`]: primary rays alone, then shadows and bounces.
const A6_STATS: [(&str, [u32; 3], Shading); 11] = [
    ("scene6_01_sphere.txt", [10, 10, 10], PRIMARY),
    ("scene6_02_sphere_triangles.txt", [10, 10, 10], PRIMARY),
    ("scene6_03_sphere_plane.txt", [10, 10, 10], PRIMARY),
    ("scene6_04_bunny_mesh_200.txt", [10, 10, 7], PRIMARY),
    ("scene6_07_bunny_mesh_40k.txt", [40, 40, 33], PRIMARY),
    ("scene6_02_sphere_triangles.txt", [10, 10, 10], SHADOWS),
    ("scene6_03_sphere_plane.txt", [10, 10, 10], SHADOWS),
    ("scene6_04_bunny_mesh_200.txt", [10, 10, 7], SHADOWS),
    ("scene6_06_bunny_mesh_5k.txt", [20, 20, 15], SHADOWS),
    ("scene6_11_mirrored_floor.txt", [40, 10, 40], Shading { bounces: 1, ..SHADOWS }),
    ("scene6_12_faceted_gem.txt", [20, 20, 20], Shading { bounces: 5, shade_back: true, ..SHADOWS }),
];

const PRIMARY: Shading = Shading { shade_back: false, specular_fix: false, shadows: false, bounces: 0, weight: 0.01 };
const SHADOWS: Shading = Shading { shadows: true, ..PRIMARY };

/// What a ray-by-ray replay of the reference's primary rays predicts `-stats` counts through
/// a grid whose cell `c` lists `len(c)` items: the planes, then each cell the 3D-DDA enters
/// before the nearest hit (the reference's, in f64), its items. With the reference's own
/// lists it must give the reference's counts; with the kernel's, the kernel's, up to the
/// pixels where f32 and f64 disagree.
fn replay_primary(
    scene: &Scene,
    reference: &ReferenceScene,
    options: &RenderOptions,
    len: &dyn Fn([usize; 3]) -> u64,
) -> (u64, u64) {
    let grid = &reference.grid().unwrap().grid;
    let rays = PrimaryRays::for_camera(&scene.camera, options.width, options.height);
    let planes = scene.primitive_counts().planes as u64;
    let (mut tests, mut cells) = (0, 0);
    for j in 0..options.height {
        for i in 0..options.width {
            let ray = rays.ray(i, j);
            let hit = reference.closest_hit(&ray).map_or(f64::INFINITY, |h| h.t);
            tests += planes;
            for visit in grid.march(ray.origin, ray.direction, ray.t_min, ray.t_max) {
                if hit < visit.t_enter {
                    break;
                }
                cells += 1;
                tests += len(visit.cell);
                if hit <= visit.t_exit {
                    break;
                }
            }
        }
    }
    (tests, cells)
}

/// `-stats` on the GPU against the reference, on the A6 lines that count through a grid
/// (docs/SPEC.md §7). Both walk the same 3D-DDA, and with primary rays alone they count the
/// same rays and cells; the tests differ only where the kernel's cells list more (its f32
/// margin), which a replay of the reference's rays over the kernel's own lists predicts
/// exactly ([`replay_primary`], itself checked against the reference's count). Where
/// shadow rays stop at their first blocker, the kernel's wider, kind-ordered lists find it
/// sooner or later: the rays still agree (one per pixel, one shadow ray per lit hit, every
/// bounce), and a pixel whose hit f32 and f64 decide differently may change its shadow rays
/// by one per light; cells and tests are printed.
#[test]
fn gpu_stats_agree_with_the_reference() {
    let (Some(corpus), Some(gpu)) = (common::corpus(), common::gpu()) else { return };
    let mut report = Vec::new();
    for (name, cells, shading) in A6_STATS {
        let scene = load_scene(&corpus.join("a6").join(name)).unwrap();
        let size = size_of(cells);
        let options = RenderOptions { shading, grid: Some(size), stats: true, ..RenderOptions::all(100, 100) };
        let reference = raycaster::cpu::Reference::new(&scene, &options);
        let frame = reference.rows(0, options.height);
        let theirs = reference.stats();
        let (ours_frame, stats) = common::render_gpu_tiles(gpu, &scene, &options);
        let ours = stats.counted.expect("the kernel counted");
        // Pixels where f32 and f64 saw something different: the nearest hit (hit or miss,
        // or t), or the colour by more than a level (a secondary ray's hit, a shadow).
        let differ = (0..frame.hit.len())
            .filter(|&k| {
                let colour = (0..3).any(|c| (frame.color[k][c] - ours_frame.color[k][c]).abs() > 1.0 / 255.0);
                colour
                    || frame.hit[k] != ours_frame.hit[k]
                    || (frame.depth[k] - ours_frame.depth[k]).abs() > 1e-4 * frame.depth[k].abs().max(1.0)
            })
            .count() as u64;
        report
            .push(format!("{name} {cells:?} {shading:?}: reference {theirs:?}, GPU {ours:?}, {differ} pixels differ"));
        // Such a pixel's tree may change: at most 2^(b+1) − 2 reflected and refracted rays
        // and a shadow ray per light for each ray of the tree.
        let tree = (1u64 << (shading.bounces + 1)) - 1;
        let lights = scene.lights.len() as u64;
        let near = |a: u64, b: u64, per_pixel: u64| a.abs_diff(b) <= differ * per_pixel;
        assert!(near(ours.non_shadow_rays, theirs.non_shadow_rays, tree - 1), "{}", report.last().unwrap());
        assert!(near(ours.shadow_rays, theirs.shadow_rays, tree * lights), "{}", report.last().unwrap());
        if shading.shadows {
            continue;
        }
        assert_eq!(ours.non_shadow_rays, 100 * 100);
        let prepared = ReferenceScene::with_grid(&scene, size);
        let grid = &prepared.grid().unwrap().grid;
        let replayed = replay_primary(&scene, &prepared, &options, &|c| grid.items(c).len() as u64);
        assert_eq!(replayed, (theirs.intersections, theirs.cells_traversed), "{name}: the replay of the reference");
        let rays = PrimaryRays::for_camera(&scene.camera, options.width, options.height);
        let buffers = raycaster::gpu::flatten::SceneBuffers::new(
            &scene,
            &rays,
            &raycaster::gpu::GpuOptions::default(),
            false,
            false,
            Some(raycaster::gpu::flatten::GridChoice::Walk(size)),
        );
        let kernel_grid = buffers.grid.unwrap();
        let kernel_len = |[x, y, z]: [usize; 3]| {
            u64::from(kernel_grid.ranges[x + cells[0] as usize * (y + cells[1] as usize * z)][1])
        };
        let predicted = replay_primary(&scene, &prepared, &options, &kernel_len);
        // A pixel whose walk f32 changes can enter at most nx + ny + nz cells, each listing
        // at most the longest list.
        let crossed = u64::from(cells.iter().sum::<u32>());
        let longest = kernel_grid.ranges.iter().map(|r| u64::from(r[1])).max().unwrap_or(0);
        report.push(format!("  predicted for the kernel: {predicted:?}"));
        assert!(ours.cells_traversed.abs_diff(predicted.1) <= differ * crossed, "{}", report.join("\n"));
        assert!(ours.intersections.abs_diff(predicted.0) <= differ * crossed * longest, "{}", report.join("\n"));
    }
    println!("{}", report.join("\n"));
}

/// Without a grid the kernel counts its own work (docs/SPEC.md §7): one ray per pixel and no
/// cell whichever way it finds candidates; in flat loops every triangle for every pixel;
/// through bins or the hierarchy at least one test per pixel that hits something (its hit
/// was tested) and at most every triangle for every ray of a packet (bins trace whole
/// packets of 4 rows).
#[test]
fn gpu_stats_without_a_grid_count_the_kernels_own_tests() {
    let Some(corpus) = common::corpus() else { return };
    if common::gpu().is_none() {
        return;
    }
    let scene = load_scene(&corpus.join("a2/scene2_10_bunny_1k.txt")).unwrap();
    let triangles = scene.primitive_counts().triangles as u64;
    let (width, height) = (64u32, 50u32);
    let options = RenderOptions { stats: true, ..RenderOptions::all(width, height) };
    let pixels = u64::from(width * height);
    let packet_rows = u64::from(height.div_ceil(4) * 4);
    for acceleration in [Acceleration::Flat, Acceleration::Bins, Acceleration::Hierarchy] {
        let gpu = common::gpu_with(acceleration).unwrap();
        let (frame, stats) = common::render_gpu_tiles(&gpu, &scene, &options);
        assert_eq!(stats.acceleration, acceleration);
        let counted = stats.counted.expect("the kernel counted");
        let hits = frame.hit.iter().filter(|&&h| h).count() as u64;
        let what = format!("{acceleration:?}: {counted:?}, {hits} pixels hit");
        assert_eq!((counted.non_shadow_rays, counted.shadow_rays, counted.cells_traversed), (pixels, 0, 0), "{what}");
        match acceleration {
            Acceleration::Flat => assert_eq!(counted.intersections, pixels * triangles, "{what}"),
            _ => {
                assert!(hits > 0 && counted.intersections >= hits, "{what}");
                assert!(counted.intersections <= u64::from(width) * packet_rows * triangles, "{what}");
            }
        }
        println!("{what}");
    }
}
