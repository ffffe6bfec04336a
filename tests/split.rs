//! Float outputs and renders split across machines, through the binary as a job array runs
//! it: EXR files against the f64 reference's floats, `--tile K/N` in N processes stitched
//! back byte for byte, stitch's refusals, and batch shards against one batch run.

mod common;

use common::bin::{channel, check, raycaster, raycaster_in, raycaster_owned, read_exr, scene, stderr};
use raycaster::render::RenderOptions;
use std::path::{Path, PathBuf};
use std::process::Output;

/// The 23-row test image splits into bands of 7, 8 and 8 rows (⌊K·23/3⌋ = 0, 7, 15, 23).
const W: u32 = 41;
const H: u32 = 23;

/// The three EXR outputs of a render against the f64 reference's float frame. `tolerance`
/// 0 means bit for bit; misses hold +∞ depth and a zero normal either way. Returns whether
/// the image had misses and negative depths.
fn assert_exr_matches_reference(dir: &Path, scene_name: &str, backend: &str, tolerance: f32) -> (bool, bool) {
    let (color, normals, depth) = (dir.join("c.exr"), dir.join("n.exr"), dir.join("d.exr"));
    check(raycaster(&[
        "-input",
        &scene(scene_name),
        "-size",
        &W.to_string(),
        &H.to_string(),
        "-output",
        color.to_str().unwrap(),
        "-normals",
        normals.to_str().unwrap(),
        "-depth",
        "1",
        "2",
        depth.to_str().unwrap(),
        "--backend",
        backend,
    ]));
    let loaded = raycaster::scene::load_scene(&common::scenes_dir().join(scene_name)).unwrap();
    let reference = raycaster::cpu::render(&loaded, &RenderOptions::all(W, H));
    let n = (W * H) as usize;
    let close = |a: f32, b: f32| if tolerance == 0.0 { a.to_bits() == b.to_bits() } else { (a - b).abs() <= tolerance };

    let (w, h, c) = read_exr(&color);
    assert_eq!((w, h), (W as usize, H as usize));
    let (r, g, b) = (channel(&c, "R"), channel(&c, "G"), channel(&c, "B"));
    for k in 0..n {
        let want = reference.color[k];
        assert!(
            close(r[k], want[0]) && close(g[k], want[1]) && close(b[k], want[2]),
            "colour pixel {k}: {:?} against {want:?}",
            [r[k], g[k], b[k]]
        );
    }
    let (_, _, c) = read_exr(&normals);
    let (x, y, z) = (channel(&c, "R"), channel(&c, "G"), channel(&c, "B"));
    let (_, _, c) = read_exr(&depth);
    let t = channel(&c, "Z");
    let (mut hits, mut misses) = (0, 0);
    for k in 0..n {
        if reference.hit[k] {
            hits += 1;
            let want = reference.normal[k];
            assert!(
                close(x[k], want[0]) && close(y[k], want[1]) && close(z[k], want[2]),
                "normal {k}: {:?} against {want:?}",
                [x[k], y[k], z[k]]
            );
            // Relative: t is a world distance.
            let dt = (t[k] - reference.depth[k]).abs() / reference.depth[k].abs().max(1.0);
            assert!(if tolerance == 0.0 { t[k] == reference.depth[k] } else { dt <= tolerance }, "depth {k}");
        } else {
            misses += 1;
            assert_eq!([x[k], y[k], z[k]], [0.0; 3], "normal of miss {k}");
            assert_eq!(t[k], f32::INFINITY, "depth of miss {k}");
        }
    }
    assert!(hits > n / 4, "the scene shows hits ({hits} of {n})");
    (misses > 0, t.iter().any(|&t| t < 0.0))
}

/// The CPU backend writes the reference's own floats: equal bit for bit.
#[test]
fn exr_holds_the_reference_floats_exactly_with_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    // Misses (+∞) and negative depths (spheres behind an orthographic camera).
    assert_eq!(assert_exr_matches_reference(dir.path(), "ortho_behind_camera.txt", "cpu", 0.0), (true, true));
    assert_exr_matches_reference(dir.path(), "mesh_octahedron.txt", "cpu", 0.0);
}

/// The GPU's f32 kernel against the f64 reference, within f32 rounding.
#[test]
fn exr_from_the_gpu_is_the_reference_within_f32_tolerance() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    assert_exr_matches_reference(dir.path(), "ortho_behind_camera.txt", "gpu", 1e-4);
    // Not the octahedron: at this size pixel centres lie on its edges, where f32 and f64
    // may pick either face (same depth, another normal).
    assert_exr_matches_reference(dir.path(), "plane_and_sphere_perspective.txt", "gpu", 1e-4);
}

/// A depth EXR written alone, or beside 8-bit images, takes the distances' bits the kernel
/// packs, not the float frame: it holds the same floats, bit for bit, as the depth EXR of a
/// render that reads floats back (beside a colour EXR), which the tests above hold to the
/// reference; with the CPU, the reference's own. Misses are +∞, and negative depths (spheres
/// behind an orthographic camera) stay negative.
#[test]
fn a_depth_exr_beside_8_bit_images_holds_the_float_renders_depths() {
    let dir = tempfile::tempdir().unwrap();
    // `others`: flags and file names in the test's folder, beside `-depth 1 2 d.exr`.
    let depth_of = |backend: &str, others: &[(&str, &str)]| {
        let depth = dir.path().join("d.exr");
        let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
        let mut args: Vec<String> = ["-input", &scene("ortho_behind_camera.txt"), "-size", &W.to_string()]
            .into_iter()
            .map(String::from)
            .collect();
        args.extend([H.to_string(), "--backend".into(), backend.into(), "-depth".into(), "1".into(), "2".into()]);
        args.push(path("d.exr"));
        args.extend(others.iter().flat_map(|(flag, name)| [flag.to_string(), path(name)]));
        check(raycaster(&args.iter().map(String::as_str).collect::<Vec<_>>()));
        channel(&read_exr(&depth).2, "Z").iter().map(|t| t.to_bits()).collect::<Vec<u32>>()
    };
    let loaded = raycaster::scene::load_scene(&common::scenes_dir().join("ortho_behind_camera.txt")).unwrap();
    let reference = raycaster::cpu::render(&loaded, &RenderOptions::all(W, H));
    let reference_bits: Vec<u32> = (0..(W * H) as usize)
        .map(|k| if reference.hit[k] { reference.depth[k].to_bits() } else { f32::INFINITY.to_bits() })
        .collect();
    assert_eq!(depth_of("cpu", &[]), reference_bits, "the CPU's depth EXR alone");
    let eight_bit = [("-output", "c.png"), ("-normals", "n.tga")];
    assert_eq!(depth_of("cpu", &eight_bit), reference_bits, "the CPU's depth EXR beside 8-bit images");
    if common::gpu().is_none() {
        return;
    }
    let floats = depth_of("gpu", &[("-output", "c.exr")]);
    assert!(floats.contains(&f32::INFINITY.to_bits()), "the view has misses");
    assert!(floats.iter().any(|&t| f32::from_bits(t) < 0.0), "and depths behind the camera");
    assert_eq!(depth_of("gpu", &[]), floats, "the GPU's depth EXR alone");
    assert_eq!(depth_of("gpu", &eight_bit), floats, "the GPU's depth EXR beside 8-bit images");
}

/// An EXR streamed in uneven chunks of rows (not multiples of its 16-row blocks) reads back
/// what was written.
#[test]
fn exr_streamed_in_uneven_chunks_reads_back() {
    use raycaster::image_io::{persist_all, ExrChannels, ExrCompression, ExrFile};
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (5u32, 37u32);
    let values: Vec<f32> = (0..w * h * 3).map(|v| v as f32 * 0.25 - 7.0).collect();
    let path = dir.path().join("s.exr");
    let mut file = ExrFile::create(&path, w, h, ExrChannels::Rgb, ExrCompression::default()).unwrap();
    let row = (w * 3) as usize;
    for (start, end) in [(0, 5), (5, 6), (6, 30), (30, 37)] {
        file.write_rows(&values[start * row..end * row]).unwrap();
    }
    assert!(!path.exists(), "nothing in place before persist");
    persist_all(vec![file.finish().unwrap()]).unwrap();
    let (rw, rh, c) = read_exr(&path);
    assert_eq!((rw, rh), (5, 37));
    for (name, offset) in [("R", 0), ("G", 1), ("B", 2)] {
        let want: Vec<f32> = values.iter().skip(offset).step_by(3).copied().collect();
        assert_eq!(channel(&c, name), &want[..], "{name}");
    }
}

/// Every `--exr-compression` keeps every float bit for bit: NaN, both infinities, both zeros,
/// subnormals and ordinary values, streamed in uneven chunks into an image whose 101 rows
/// fill neither 16-row (ZIP) nor 32-row (PIZ) blocks evenly and span several, so that the
/// compressing threads take turns. The file's header names the method asked for, by the
/// names of OpenEXR's specification. Random bits, which no method shrinks, take the path of
/// blocks stored as they are.
#[test]
fn every_exr_compression_reads_back_the_same_floats() {
    use exr::compression::Compression;
    use raycaster::image_io::{persist_all, ExrChannels, ExrCompression, ExrFile};
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (67u32, 101u32);
    let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, f32::MIN_POSITIVE / 8.0, f32::MAX];
    let ramp = |k: usize| match k % 11 {
        // A smooth ramp, as renders are, and specials between.
        0..=3 => specials[k % specials.len()],
        _ => (k as f32 * 0.37).sin() * 40.0 + k as f32 * 1e-3,
    };
    // SplitMix64's finaliser (Steele, Lea and Flood 2014) of the index: bits without pattern.
    let noise = |k: usize| {
        let mut z = (k as u64).wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        f32::from_bits((z ^ (z >> 31)) as u32)
    };
    let expected = [
        (ExrCompression::None, Compression::Uncompressed),
        (ExrCompression::Rle, Compression::RLE),
        (ExrCompression::Zips, Compression::ZIP1),
        (ExrCompression::Zip, Compression::ZIP16),
        (ExrCompression::Piz, Compression::PIZ),
    ];
    assert_eq!(expected.map(|(c, _)| c), ExrCompression::ALL, "every choice is tested");
    let patterns: [(&str, &dyn Fn(usize) -> f32); 2] = [("ramp", &ramp), ("noise", &noise)];
    for ((compression, method), (pattern, value)) in expected.into_iter().flat_map(|e| patterns.map(|p| (e, p))) {
        for (channels, names) in [(ExrChannels::Rgb, &["R", "G", "B"][..]), (ExrChannels::Depth, &["Z"][..])] {
            let n = channels.count();
            let values: Vec<f32> = (0..(w * h) as usize * n).map(value).collect();
            let path = dir.path().join(format!("{}-{pattern}-{n}.exr", compression.name()));
            let mut file = ExrFile::create(&path, w, h, channels, compression).unwrap();
            let row = w as usize * n;
            for (start, end) in [(0, 1), (1, 40), (40, 41), (41, 101)] {
                file.write_rows(&values[start * row..end * row]).unwrap();
            }
            persist_all(vec![file.finish().unwrap()]).unwrap();
            let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
            assert_eq!(meta.headers[0].compression, method, "{}", compression.name());
            let (rw, rh, c) = read_exr(&path);
            assert_eq!((rw, rh), (w as usize, h as usize));
            for (offset, name) in names.iter().enumerate() {
                let want: Vec<u32> = values.iter().skip(offset).step_by(n).map(|v| v.to_bits()).collect();
                let got: Vec<u32> = channel(&c, name).iter().map(|v| v.to_bits()).collect();
                assert!(got == want, "{} {pattern} channel {name}: floats differ", compression.name());
            }
        }
    }
}

/// `--exr-compression` reaches the files a render writes, and `stitch`'s: PIZ depth from the
/// CPU backend holds the reference's floats bit for bit, and the stitched RLE copy too.
#[test]
fn exr_compression_flag_reaches_render_and_stitch() {
    let dir = tempfile::tempdir().unwrap();
    let depth = dir.path().join("d.exr");
    let input = scene("ortho_behind_camera.txt");
    let (w, h) = (W.to_string(), H.to_string());
    let flags = ["-input", &input, "-size", &w, &h, "--backend", "cpu", "-depth", "1", "2"];
    check(raycaster(&[&flags[..], &[depth.to_str().unwrap(), "--exr-compression", "piz"]].concat()));
    let loaded = raycaster::scene::load_scene(&common::scenes_dir().join("ortho_behind_camera.txt")).unwrap();
    let reference = raycaster::cpu::render(&loaded, &RenderOptions::all(W, H));
    let want: Vec<u32> = (0..reference.hit.len())
        .map(|k| if reference.hit[k] { reference.depth[k] } else { f32::INFINITY }.to_bits())
        .collect();
    let depth_bits =
        |path: &Path| -> Vec<u32> { channel(&read_exr(path).2, "Z").iter().map(|t| t.to_bits()).collect() };
    let method = |path: &Path| exr::meta::MetaData::read_from_file(path, false).unwrap().headers[0].compression;
    assert_eq!(method(&depth), exr::compression::Compression::PIZ);
    assert!(depth_bits(&depth) == want, "PIZ depth differs from the reference");

    let stitched = dir.path().join("s.exr");
    check(raycaster(&[&flags[..], &[stitched.to_str().unwrap(), "--tile", "1/2"]].concat()));
    check(raycaster(&[&flags[..], &[stitched.to_str().unwrap(), "--tile", "0/2"]].concat()));
    let s = stitched.to_str().unwrap();
    check(raycaster(&["stitch", "-depth", "1", "2", s, "--exr-compression", "rle"]));
    assert_eq!(method(&stitched), exr::compression::Compression::RLE);
    assert!(depth_bits(&stitched) == want, "stitched RLE depth differs from the reference");
}

/// Outputs of one render, in every format between them: `(flag words, file name)`.
fn output_flags(dir: &Path, names: [&str; 3]) -> Vec<String> {
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    vec![
        "-output".into(),
        p(names[0]),
        "-normals".into(),
        p(names[1]),
        "-depth".into(),
        "2".into(),
        "9".into(),
        p(names[2]),
    ]
}

/// Renders `scene` whole into `whole/`, and in `n` processes with `--tile K/n` into
/// `split/`, then stitches; every file must equal the single render's byte for byte.
fn split_equals_single(scene_name: &str, backend: &str, names: [&str; 3], n: u32) {
    let root = tempfile::tempdir().unwrap();
    let (whole, split) = (root.path().join("whole"), root.path().join("split"));
    std::fs::create_dir_all(&whole).unwrap();
    std::fs::create_dir_all(&split).unwrap();
    let input = scene(scene_name);
    let size = [W.to_string(), H.to_string()];
    let common_flags = ["-input", &input, "-size", &size[0], &size[1], "--backend", backend, "-shade_back"];
    let run = |dir: &Path, extra: &[&str]| {
        let mut args: Vec<String> = common_flags.iter().map(|s| s.to_string()).collect();
        args.extend(output_flags(dir, names));
        args.extend(extra.iter().map(|s| s.to_string()));
        check(raycaster_owned(&args))
    };
    run(&whole, &[]);
    for k in 0..n {
        run(&split, &["--tile", &format!("{k}/{n}")]);
    }
    // Band K holds rows ⌊K·H/N⌋ .. ⌊(K+1)·H/N⌋.
    for k in 0..n {
        let part = split.join(format!("{}.part-{k}-of-{n}", names[0]));
        let text = String::from_utf8_lossy(&std::fs::read(&part).unwrap()).into_owned();
        let (first, end) = (k * H / n, (k + 1) * H / n);
        assert!(text.contains(&format!("\nrows {first} {}\n", end - first)), "{}: {text:.200}", part.display());
    }
    assert!(!split.join(names[0]).exists(), "a tile render writes no image");
    let mut args = vec!["stitch".to_string()];
    args.extend(output_flags(&split, names));
    args.extend(["-input", &input, "-size", &size[0], &size[1]].map(String::from));
    check(raycaster_owned(&args));
    for name in names {
        let (a, b) = (std::fs::read(whole.join(name)).unwrap(), std::fs::read(split.join(name)).unwrap());
        assert!(a == b, "{name}: stitched file differs from the single render ({} vs {} bytes)", b.len(), a.len());
    }
    let left = common::bin::file_names(&split);
    assert_eq!(left.len(), 3, "parts are deleted after a successful stitch: {left:?}");
}

#[test]
fn three_processes_stitch_to_the_single_render_cpu() {
    // Every format for every kind between the two runs.
    split_equals_single("plane_and_sphere_perspective.txt", "cpu", ["c.tga", "n.png", "d.exr"], 3);
    split_equals_single("mesh_octahedron.txt", "cpu", ["c.exr", "n.tga", "d.png"], 3);
    split_equals_single("mesh_octahedron.txt", "cpu", ["c.png", "n.exr", "d.tga"], 1);
}

#[test]
fn three_processes_stitch_to_the_single_render_gpu() {
    if common::gpu().is_none() {
        return;
    }
    split_equals_single("plane_and_sphere_perspective.txt", "gpu", ["c.tga", "n.png", "d.exr"], 3);
    split_equals_single("mesh_octahedron.txt", "gpu", ["c.exr", "n.tga", "d.png"], 3);
}

/// Renders the bands of `c.tga` into `dir` on the CPU with `extra` flags on band `odd`.
fn render_parts(dir: &Path, n: u32, odd: Option<(u32, &[&str])>) {
    let out = dir.join("c.tga");
    for k in 0..n {
        let mut args = vec![
            "-input".to_string(),
            scene("spheres_ortho.txt"),
            "-size".into(),
            W.to_string(),
            H.to_string(),
            "-output".into(),
            out.to_str().unwrap().into(),
            "--backend".into(),
            "cpu".into(),
            "--tile".into(),
            format!("{k}/{n}"),
        ];
        if let Some((_, extra)) = odd.filter(|(band, _)| *band == k) {
            args.extend(extra.iter().map(|s| s.to_string()));
        }
        check(raycaster_owned(&args));
    }
}

fn stitch(dir: &Path, extra: &[&str]) -> Output {
    let out = dir.join("c.tga");
    let mut args = vec!["stitch", "-output", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    raycaster(&args)
}

fn assert_refused(result: &Output, dir: &Path, needles: &[&str]) {
    assert_eq!(result.status.code(), Some(1), "{}", stderr(result));
    for needle in needles {
        assert!(stderr(result).contains(needle), "'{needle}' not in: {}", stderr(result));
    }
    assert!(!dir.join("c.tga").exists(), "a refused stitch writes nothing");
}

#[test]
fn stitch_refuses_missing_parts_and_lists_them() {
    let dir = tempfile::tempdir().unwrap();
    render_parts(dir.path(), 4, None);
    std::fs::remove_file(dir.path().join("c.tga.part-1-of-4")).unwrap();
    std::fs::remove_file(dir.path().join("c.tga.part-3-of-4")).unwrap();
    let result = stitch(dir.path(), &[]);
    assert_refused(&result, dir.path(), &["missing 2 of 4 parts", "c.tga.part-1-of-4", "c.tga.part-3-of-4"]);
    assert!(dir.path().join("c.tga.part-0-of-4").exists(), "a refused stitch keeps the parts");

    let empty = tempfile::tempdir().unwrap();
    assert_refused(&stitch(empty.path(), &[]), empty.path(), &["no part files", "c.tga.part-K-of-N"]);
}

#[test]
fn stitch_refuses_a_part_from_another_render() {
    // Band 1 rendered with -shade_back: other pixels, so another render.
    let dir = tempfile::tempdir().unwrap();
    render_parts(dir.path(), 3, Some((1, &["-shade_back"])));
    assert_refused(&stitch(dir.path(), &[]), dir.path(), &["c.tga.part-1-of-3", "another render", "-shade_back"]);

    // Band 2 of another scene.
    let dir = tempfile::tempdir().unwrap();
    render_parts(dir.path(), 3, None);
    let other = tempfile::tempdir().unwrap();
    let scene_copy = other.path().join("s.txt");
    let text = std::fs::read_to_string(scene("spheres_ortho.txt")).unwrap();
    std::fs::write(&scene_copy, text + "\n# edited\n").unwrap();
    let mut args: Vec<String> =
        ["-input", scene_copy.to_str().unwrap(), "-size", &W.to_string(), &H.to_string(), "--backend", "cpu"]
            .map(String::from)
            .to_vec();
    let out = dir.path().join("c.tga");
    args.extend(["-output", out.to_str().unwrap(), "--tile", "2/3"].map(String::from));
    check(raycaster_owned(&args));
    assert_refused(&stitch(dir.path(), &[]), dir.path(), &["c.tga.part-2-of-3", "another render", "scene"]);

    // A stale part of a 2-way split beside a complete 3-way one.
    let dir = tempfile::tempdir().unwrap();
    render_parts(dir.path(), 3, None);
    let stale = tempfile::tempdir().unwrap();
    render_parts(stale.path(), 2, None);
    std::fs::copy(stale.path().join("c.tga.part-0-of-2"), dir.path().join("c.tga.part-0-of-2")).unwrap();
    assert_refused(&stitch(dir.path(), &[]), dir.path(), &["c.tga.part-0-of-2", "split into"]);

    // What the stitch command states is checked too: size, and scene via -input.
    let dir = tempfile::tempdir().unwrap();
    render_parts(dir.path(), 3, None);
    assert_refused(&stitch(dir.path(), &["-size", "40", "23"]), dir.path(), &["size 41×23 (not 40×23)"]);
    let result = stitch(dir.path(), &["-input", scene_copy.to_str().unwrap()]);
    assert_refused(&result, dir.path(), &["another render than asked for", "scene"]);

    // A truncated part (a job killed while copying it back).
    let part = dir.path().join("c.tga.part-2-of-3");
    let bytes = std::fs::read(&part).unwrap();
    std::fs::write(&part, &bytes[..bytes.len() - 10]).unwrap();
    assert_refused(&stitch(dir.path(), &[]), dir.path(), &["c.tga.part-2-of-3", "truncated"]);
}

#[test]
fn keep_parts_keeps_them() {
    let dir = tempfile::tempdir().unwrap();
    render_parts(dir.path(), 2, None);
    check(stitch(dir.path(), &["--keep-parts"]));
    assert!(dir.path().join("c.tga").exists());
    assert!(dir.path().join("c.tga.part-0-of-2").exists() && dir.path().join("c.tga.part-1-of-2").exists());
}

/// Every file under `dir`, by name, with its bytes.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut list: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            (PathBuf::from(path.file_name().unwrap()), std::fs::read(&path).unwrap())
        })
        .collect();
    list.sort();
    list
}

/// Three shards together write exactly what one batch run writes, and each writes only its
/// share: command lines counted without the blank and comment lines.
#[test]
fn batch_shards_write_what_one_batch_writes() {
    let commands = [
        ("spheres_ortho.txt", "a.tga"),
        ("mesh_octahedron.txt", "b.png"),
        ("triangles.txt", "c.exr"),
        ("nested_transforms.txt", "d.tga"),
        ("ellipsoids.txt", "e.png"),
        ("three_lights.txt", "f.tga"),
        ("wide_320x180.txt", "g.tga"),
    ];
    let mut text = String::from("# a comment, then a blank line\n\n");
    for (i, (scene_name, out)) in commands.iter().enumerate() {
        text += &format!("-input {} -size 24 17 -output {out} -depth 1 5 depth_{out}\n", scene(scene_name));
        if i == 2 {
            text += "   \n# another comment\n";
        }
    }
    let root = tempfile::tempdir().unwrap();
    std::fs::write(root.path().join("commands.txt"), &text).unwrap();
    let batch_file = root.path().join("commands.txt");
    let one = root.path().join("one");
    std::fs::create_dir(&one).unwrap();
    check(raycaster_in(&one, &["batch", batch_file.to_str().unwrap(), "--backend", "cpu"]));
    let sharded = root.path().join("sharded");
    std::fs::create_dir(&sharded).unwrap();
    for k in 0..3 {
        let shard_dir = root.path().join(format!("shard{k}"));
        std::fs::create_dir(&shard_dir).unwrap();
        let shard = format!("{k}/3");
        check(raycaster_in(
            &shard_dir,
            &["batch", batch_file.to_str().unwrap(), "--backend", "cpu", "--shard", &shard],
        ));
        let mine: Vec<String> = files(&shard_dir).into_iter().map(|(p, _)| p.to_str().unwrap().to_string()).collect();
        let mut expected: Vec<String> = commands
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 3 == k)
            .flat_map(|(_, (_, out))| [out.to_string(), format!("depth_{out}")])
            .collect();
        expected.sort();
        assert_eq!(mine, expected, "shard {k}");
        for (name, _) in files(&shard_dir) {
            std::fs::rename(shard_dir.join(&name), sharded.join(&name)).unwrap();
        }
    }
    let (a, b) = (files(&one), files(&sharded));
    assert_eq!(a.len(), 14);
    assert_eq!(a.iter().map(|f| &f.0).collect::<Vec<_>>(), b.iter().map(|f| &f.0).collect::<Vec<_>>());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{}: differs", name.display());
    }
}

#[test]
fn tile_and_shard_usage_errors() {
    let cases: [(&[&str], &str); 6] = [
        (&["-input", "s", "-size", "4", "4", "-output", "o.tga", "--tile", "3/3"], "--tile: '3/3'"),
        (&["-input", "s", "-size", "4", "4", "-output", "o.tga", "--tile", "1"], "--tile: '1'"),
        (
            &["-input", "s", "-size", "4", "3", "-output", "o.tga", "--tile", "0/4"],
            "more bands than the image's 3 rows",
        ),
        (&["batch", "f", "--shard", "0/0"], "--shard: '0/0'"),
        (&["stitch"], "nothing to stitch"),
        (&["stitch", "-output", "o.bmp"], "unsupported image format"),
    ];
    for (args, needle) in cases {
        let result = raycaster(args);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {}", stderr(&result));
        assert!(stderr(&result).contains(needle), "{args:?}: {}", stderr(&result));
        assert_eq!(stderr(&result).lines().count(), 1, "{args:?}: one line");
    }
}
