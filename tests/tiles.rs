//! Tiled rendering and streamed image files give exactly what one whole-frame pass gives.

mod common;

use raycaster::gpu::GpuOptions;
use raycaster::image_io::{color_image, read_image, ImageFile};
use raycaster::render::{Output, RenderOptions};
use raycaster::scene::load_scene;

fn scene() -> raycaster::scene::Scene {
    load_scene(&common::scenes_dir().join("ellipsoids.txt")).unwrap()
}

/// Tiles of 3 rows (the last one shorter) against one tile: identical float buffers.
#[test]
fn gpu_tiles_equal_one_pass() {
    if common::gpu().is_none() {
        return;
    }
    let options = RenderOptions::all(37, 23);
    let whole = common::gpu().unwrap().render(&scene(), &options).unwrap();
    let small =
        common::gpu().unwrap().on_same_device(GpuOptions { max_tile_bytes: 37 * 3 * 32, ..GpuOptions::default() });
    let mut tiles = 0;
    let mut rows_seen = Vec::new();
    small
        .render_tiles(&scene(), &options, |first_row, tile| {
            tiles += 1;
            rows_seen.push((first_row, tile.height));
            Ok::<(), raycaster::gpu::GpuError>(())
        })
        .unwrap();
    assert_eq!(tiles, 8, "{rows_seen:?}");
    assert_eq!(rows_seen.last(), Some(&(21, 2)));
    assert_eq!(small.render(&scene(), &options).unwrap(), whole);
}

/// A tile the caller aims for (`GpuOptions::tile_bytes`, which `RAYCASTER_TILE_MIB` sets)
/// replaces the adapter's, whatever its kind: 256×1024 colour floats (4 MiB) render in four
/// tiles of 1 MiB or in one of 4 MiB, to the same floats.
#[test]
fn the_tile_aimed_for_replaces_the_adapters() {
    let Some(gpu) = common::gpu() else { return };
    let options = RenderOptions { outputs: Output::Color.into(), ..RenderOptions::all(256, 1024) };
    let render = |mib: u64| {
        let aimed = gpu.on_same_device(GpuOptions { tile_bytes: Some(mib << 20), ..GpuOptions::default() });
        let mut frame = raycaster::render::Frame::new(&options);
        let prepared = aimed.prepare(&scene(), &options, false).unwrap();
        let stats = prepared
            .render(|tile| {
                tile.decode_into(&mut frame);
                Ok::<(), raycaster::gpu::GpuError>(())
            })
            .unwrap();
        (stats.tiles, frame)
    };
    let (small_tiles, small) = render(1);
    let (large_tiles, large) = render(4);
    assert_eq!((small_tiles, large_tiles), (4, 1));
    assert_eq!(small, large);
    assert!(small.hit.iter().any(|&hit| hit), "the scene is in view");
}

/// 8-bit colour tiles written into their rows of one whole image (the bench's warm 8-bit
/// frame) give the image the host quantises from the same scene's float render: tiles of
/// 3 rows, the last shorter, each landing at its own rows.
#[test]
fn rgb8_tiles_written_into_one_image_make_the_whole_image() {
    let Some(gpu) = common::gpu() else { return };
    let options = RenderOptions { outputs: Output::Color.into(), ..RenderOptions::all(37, 23) };
    let small = gpu.on_same_device(GpuOptions { max_tile_bytes: 37 * 3 * 4, ..GpuOptions::default() });
    let mut rgb = vec![0u8; 37 * 23 * 3];
    let stats = small
        .prepare(&scene(), &options, true)
        .unwrap()
        .render(|tile| {
            tile.color_rgb_into(&mut rgb);
            Ok::<(), raycaster::gpu::GpuError>(())
        })
        .unwrap();
    assert_eq!(stats.tiles, 8);
    let floats = gpu.render(&scene(), &options).unwrap();
    assert_eq!(rgb, color_image(&floats).into_raw());
    assert!(rgb.iter().any(|&c| c > 0), "the scene is lit in view");
}

/// `-v`'s split of a binned render in 18 tiles holds together: the kernel's thread (its
/// specialising within it) took no longer than preparing, which waits for it; the caller
/// waited for tiles no longer than the render took; every later tile filled its own lists,
/// and a render of one tile fills none.
#[test]
fn the_split_of_a_render_holds_together() {
    use raycaster::gpu::Acceleration;
    let Some(gpu) = common::gpu() else { return };
    let (width, height) = (61, 53);
    let options = RenderOptions::all(width, height);
    for (tile_bytes, tiles) in [(width as u64 * 3 * 32, 18), (u64::MAX, 1)] {
        let gpu = gpu.on_same_device(binned(tile_bytes));
        let start = std::time::Instant::now();
        let prepared = gpu.prepare(&lattice(), &options, false).unwrap();
        let stats = prepared.render(|_| Ok::<(), raycaster::gpu::GpuError>(())).unwrap();
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        assert_eq!((stats.tiles, stats.acceleration), (tiles, Acceleration::Bins));
        assert!(stats.specialise_ms <= stats.compile_ms && stats.compile_ms <= stats.prepare_ms, "{stats:?}");
        assert!(stats.prepare_ms + stats.waited_ms <= wall_ms, "{stats:?} in {wall_ms} ms");
        assert_eq!(stats.lists_ms > 0.0, tiles > 1, "{stats:?}");
    }
}

/// However many tiles are in flight (`GpuOptions::tile_slots`, which `RAYCASTER_TILE_SLOTS`
/// sets), a binned render in 18 tiles hands them over top first, each once, and makes the
/// floats of one tile holding every bin, whether the host maps the kernel's buffers or each
/// tile is copied for it (as on a discrete GPU); with 4 in flight, a caller that stops at the
/// fifth tile gets its own error back, and no tile after it.
#[test]
fn tiles_in_flight_change_no_pixel_and_stop_where_the_caller_says() {
    let Some(gpu) = common::gpu() else { return };
    let (width, height) = (61, 53);
    let options = RenderOptions::all(width, height);
    let whole = gpu.on_same_device(binned(u64::MAX)).render(&lattice(), &options).unwrap();
    let in_flight = |slots, mapped_buffers| {
        gpu.on_same_device(GpuOptions { tile_slots: slots, mapped_buffers, ..binned(width as u64 * 3 * 32) })
    };
    for (slots, mapped) in [(1, true), (2, true), (3, true), (8, true), (3, false)] {
        let gpu = in_flight(slots, mapped);
        let mut frame = raycaster::render::Frame::new(&options);
        let mut first_rows = Vec::new();
        let prepared = gpu.prepare(&lattice(), &options, false).unwrap();
        let stats = prepared
            .render(|tile| {
                first_rows.push(tile.first_row);
                tile.decode_into(&mut frame);
                Ok::<(), raycaster::gpu::GpuError>(())
            })
            .unwrap();
        assert_eq!(stats.tiles, 18, "{slots} in flight");
        assert_eq!(first_rows, (0..18).map(|k| 3 * k).collect::<Vec<u32>>(), "{slots} in flight");
        assert!(frame == whole, "{slots} in flight: other floats");
    }
    let mut handed = 0;
    let stopped = in_flight(4, true).prepare(&lattice(), &options, false).unwrap().render(|_| {
        handed += 1;
        match handed {
            5 => Err(raycaster::gpu::GpuError::Readback("stopped by the test".into())),
            _ => Ok(()),
        }
    });
    assert!(matches!(stopped, Err(raycaster::gpu::GpuError::Readback(why)) if why == "stopped by the test"));
    assert_eq!(handed, 5);
}

/// The awaited path a browser takes (one tile after another, each map awaited) gives the
/// same floats as the threaded one, here driven by pollster, with tiles of 3 rows.
#[test]
fn awaited_tiles_equal_threaded_ones() {
    if common::gpu().is_none() {
        return;
    }
    let options = RenderOptions::all(37, 23);
    let small =
        common::gpu().unwrap().on_same_device(GpuOptions { max_tile_bytes: 37 * 3 * 32, ..GpuOptions::default() });
    let prepared = small.prepare(&scene(), &options, false).unwrap();
    let mut frame = raycaster::render::Frame::new(&options);
    let stats = pollster::block_on(prepared.render_async(|tile| {
        frame.paste(tile.first_row, &tile.to_frame());
        Ok::<(), raycaster::gpu::GpuError>(())
    }))
    .unwrap();
    assert_eq!(stats.tiles, 8);
    assert_eq!(frame, small.render(&scene(), &options).unwrap());
}

/// A warm frame (the live view's and the bench's): a scene prepared once renders again and
/// again with its buffers, bins and kernel, each frame the same floats as a fresh render,
/// in tiles of 3 rows and with bins, whose slots then hold other bands than the first.
#[test]
fn a_prepared_scene_renders_the_same_frame_again() {
    if common::gpu().is_none() {
        return;
    }
    let options = RenderOptions::all(37, 23);
    let whole = common::gpu().unwrap().render(&lattice(), &options).unwrap();
    let binned = common::gpu().unwrap().on_same_device(GpuOptions {
        acceleration: raycaster::gpu::Acceleration::Bins,
        max_tile_bytes: 37 * 3 * 32,
        ..GpuOptions::default()
    });
    let prepared = binned.prepare(&lattice(), &options, false).unwrap();
    for frame_number in 0..3 {
        let mut frame = raycaster::render::Frame::new(&options);
        let stats = prepared
            .render(|tile| {
                frame.paste(tile.first_row, &tile.to_frame());
                Ok::<(), raycaster::gpu::GpuError>(())
            })
            .unwrap();
        assert_eq!(stats.tiles, 8);
        assert_eq!(stats.acceleration, raycaster::gpu::Acceleration::Bins);
        assert_eq!(frame, whole, "frame {frame_number}");
    }
}

/// Where the host maps the kernel's buffers (a CPU adapter: the first tile's bin lists
/// written while the kernel compiles, each tile read from the output buffer itself), the
/// tiles hold what copying through staging and readback buffers gives, as on a discrete
/// GPU: floats and 8-bit words, in tiles of a few rows that two slots take in turn, the whole image
/// (slot 0's lists written beforehand) and a band of a split render from row 13 (whose first
/// tile needs other lists than those).
#[test]
fn mapped_buffers_give_what_copies_give() {
    use raycaster::gpu::{Acceleration, GpuRenderer};
    let Some(gpu) = common::gpu() else { return };
    let (width, height) = (61, 53);
    let with = |mapped_buffers| {
        gpu.on_same_device(GpuOptions {
            acceleration: Acceleration::Bins,
            max_tile_bytes: width as u64 * 3 * 32,
            mapped_buffers,
            ..GpuOptions::default()
        })
    };
    let (mapped, copied) = (with(true), with(false));
    assert!(!copied.maps_kernel_buffers());
    let cpu_adapter = gpu.adapter_info().device_type == wgpu::DeviceType::Cpu;
    assert_eq!(mapped.maps_kernel_buffers(), cpu_adapter, "{:?}", gpu.adapter_info());
    let options = RenderOptions::all(width, height);
    // Every tile's words, as floats and as the 8-bit colour, of rows `first .. first + rows`.
    let tiles = |g: &GpuRenderer, packed: bool, (first, rows): (u32, u32)| {
        let mut seen = Vec::new();
        let prepared = g.prepare(&lattice(), &options, packed).unwrap();
        prepared
            .render_band(first, rows, |tile| {
                let pixels = if packed { tile.color_rgb() } else { color_image(&tile.to_frame()).into_raw() };
                seen.push((tile.first_row, tile.rows, pixels));
                Ok::<(), raycaster::gpu::GpuError>(())
            })
            .unwrap();
        seen
    };
    // Both ways share how the first tile's lists are written: the reference checks that.
    let reference = color_image(&raycaster::cpu::render(&lattice(), &options)).into_raw();
    let row_bytes = width as usize * 3;
    for packed in [false, true] {
        for band in [(0, height), (13, 29)] {
            let (m, c) = (tiles(&mapped, packed, band), tiles(&copied, packed, band));
            assert!(m.len() >= 3, "two slots take turns: {} tiles", m.len());
            assert!(m == c, "mapped buffers differ from copies (packed {packed}, rows {band:?})");
            let rgb: Vec<u8> = m.into_iter().flat_map(|(_, _, p)| p).collect();
            let expected = &reference[band.0 as usize * row_bytes..(band.0 + band.1) as usize * row_bytes];
            let off = rgb.iter().zip(expected).filter(|(a, b)| a.abs_diff(**b) > 1).count();
            assert_eq!(off, 0, "channels off the reference by more than a level (packed {packed}, rows {band:?})");
            assert!(expected.chunks(3).any(|p| p != &expected[..3]), "rows {band:?} show more than the background");
        }
    }
}

/// The CPU reference by row ranges equals the whole frame.
#[test]
fn cpu_rows_equal_one_pass() {
    let options = RenderOptions::all(20, 11);
    let whole = raycaster::cpu::render(&scene(), &options);
    let mut pasted = raycaster::render::Frame::new(&options);
    for (first, rows) in [(0, 4), (4, 4), (8, 3)] {
        pasted.paste(first, &raycaster::cpu::render_rows(&scene(), &options, first, rows));
    }
    assert_eq!(pasted, whole);
}

/// An image streamed in uneven chunks of rows reads back identical, in both formats.
#[test]
fn streamed_files_read_back_identical() {
    let image = color_image(&raycaster::cpu::render(&scene(), &RenderOptions::all(31, 17)));
    let dir = tempfile::tempdir().unwrap();
    for name in ["s.tga", "s.png"] {
        let path = dir.path().join(name);
        let mut file = ImageFile::create(&path, 31, 17).unwrap();
        let row = 31 * 3;
        for (start, end) in [(0, 5), (5, 6), (6, 17)] {
            file.write_rows(&image.as_raw()[start * row..end * row]).unwrap();
        }
        raycaster::image_io::persist_all(vec![file.finish().unwrap()]).unwrap();
        assert_eq!(read_image(&path).unwrap(), image, "{name}");
    }
}

/// A TGA written in calls of many rows, each more than one write's worth of reordered rows,
/// and in calls of one row: the `image` crate reads back the pixels given, bottom-left
/// origin and BGR order undone.
#[test]
fn tga_in_large_and_single_row_calls_reads_back_identical() {
    let (w, h) = (301u32, 977u32);
    let pixels: Vec<u8> = (0..w * h * 3).map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.tga");
    let mut file = ImageFile::create(&path, w, h).unwrap();
    let row = (w * 3) as usize;
    for (start, end) in [(0, 1), (1, 600), (600, 601), (601, 977)] {
        file.write_rows(&pixels[start * row..end * row]).unwrap();
    }
    raycaster::image_io::persist_all(vec![file.finish().unwrap()]).unwrap();
    let read = read_image(&path).unwrap();
    assert_eq!(read.dimensions(), (w, h));
    assert!(read.as_raw() == &pixels, "pixels differ");
}

/// PNGs deflated in strips: 1001 rows of 3000 bytes span several strips of 1 MiB and end in
/// a shorter one, and a 1 × 1 image is one strip that both starts and ends the stream; each
/// is streamed in uneven calls. The png crate, checking every chunk's CRC and the zlib
/// stream's Adler-32, reads back the pixels given, and so does the image crate.
#[test]
fn png_in_strips_reads_back_identical_with_checksums_checked() {
    for (w, h) in [(1000u32, 1001u32), (1, 1)] {
        // Flat runs, a gradient and noise: long matches, short ones and literals.
        let pixels: Vec<u8> = (0..w * h * 3)
            .map(|k| match (k / 3 / w) % 3 {
                0 => 40,
                1 => (k % (w * 3) / 12) as u8,
                _ => (k.wrapping_mul(2_654_435_761) >> 13) as u8,
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("strips.png");
        let mut file = ImageFile::create(&path, w, h).unwrap();
        let row = (w * 3) as usize;
        let cuts = [0, 1, 350.min(h as usize), 351.min(h as usize), h as usize];
        for pair in cuts.windows(2) {
            file.write_rows(&pixels[pair[0] * row..pair[1] * row]).unwrap();
        }
        raycaster::image_io::persist_all(vec![file.finish().unwrap()]).unwrap();

        let mut options = png::DecodeOptions::default();
        options.set_ignore_checksums(false);
        let decoder =
            png::Decoder::new_with_options(std::io::BufReader::new(std::fs::File::open(&path).unwrap()), options);
        let mut reader = decoder.read_info().unwrap();
        let mut decoded = vec![0; reader.output_buffer_size().unwrap()];
        let frame = reader.next_frame(&mut decoded).unwrap();
        assert_eq!((frame.width, frame.height, frame.color_type), (w, h, png::ColorType::Rgb));
        assert!(decoded == pixels, "{w}×{h}: the png crate reads other pixels");
        assert!(read_image(&path).unwrap().as_raw() == &pixels, "{w}×{h}: the image crate reads other pixels");
    }
}

/// Pixels packed one to a word as the kernel packs them (`r | g << 8 | b << 16`), every
/// other word another output's and the top byte set, streamed in uneven calls into a TGA
/// (several reordered writes a call) and a PNG (a strip boundary inside a call): the image
/// crate reads back the pixels the words hold, and the files are byte for byte those the
/// same pixels make as bytes.
#[test]
fn packed_pixels_stream_into_files_that_read_back_identical() {
    use raycaster::image_io::{PackedRgb, RgbRows};
    let (w, h) = (301usize, 977usize);
    let pixels: Vec<u8> = (0..w * h * 3).map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    let words: Vec<u32> =
        pixels.chunks_exact(3).flat_map(|p| [u32::from_le_bytes([p[0], p[1], p[2], 0xee]), 0xdead_beef]).collect();
    let dir = tempfile::tempdir().unwrap();
    for name in ["packed.tga", "packed.png"] {
        let write = |path: &std::path::Path, packed: bool| {
            let mut file = ImageFile::create(path, w as u32, h as u32).unwrap();
            for (start, end) in [(0, 1), (1, 600), (600, 601), (601, h)] {
                if packed {
                    let rows = PackedRgb::new(&words[2 * start * w..], 2, (end - start) * w);
                    file.write_pixels(RgbRows::Packed(rows)).unwrap();
                } else {
                    file.write_rows(&pixels[start * w * 3..end * w * 3]).unwrap();
                }
            }
            raycaster::image_io::persist_all(vec![file.finish().unwrap()]).unwrap();
        };
        let (packed, bytes) = (dir.path().join(name), dir.path().join(format!("bytes_{name}")));
        write(&packed, true);
        write(&bytes, false);
        assert!(read_image(&packed).unwrap().as_raw() == &pixels, "{name}: other pixels");
        assert!(std::fs::read(&packed).unwrap() == std::fs::read(&bytes).unwrap(), "{name}: other bytes");
    }
}

/// A file that did not receive all its rows is refused, and nothing is left behind.
#[test]
fn incomplete_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut file = ImageFile::create(&dir.path().join("x.tga"), 4, 4).unwrap();
    file.write_rows(&[0; 4 * 3 * 2]).unwrap();
    assert!(file.finish().is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Each combination of outputs packs a different pixel layout; every one decodes to the
/// same values as the render with all outputs, and leaves the others empty.
#[test]
fn every_output_combination_decodes_the_same() {
    let Some(gpu) = common::gpu() else { return };
    let all = gpu.render(&scene(), &RenderOptions::all(24, 16)).unwrap();
    for mask in 1..8u32 {
        let outputs = Output::ALL.into_iter().enumerate().filter(|(k, _)| mask & 1 << k != 0).map(|(_, o)| o).collect();
        let options = RenderOptions { outputs, ..RenderOptions::all(24, 16) };
        let wants = |output| options.outputs.contains(output);
        let frame = gpu.render(&scene(), &options).unwrap();
        assert_eq!(frame.hit, all.hit, "outputs {mask:03b}");
        assert_eq!(frame.color, if wants(Output::Color) { all.color.clone() } else { vec![] }, "outputs {mask:03b}");
        assert_eq!(
            frame.normal,
            if wants(Output::Normals) { all.normal.clone() } else { vec![] },
            "outputs {mask:03b}"
        );
        assert_eq!(frame.depth, if wants(Output::Depth) { all.depth.clone() } else { vec![] }, "outputs {mask:03b}");
    }
}

/// Tiles cover every row once, top first, the last one shorter; a tile size of 0 means 1.
#[test]
fn row_tiles_cover_the_image() {
    use raycaster::render::row_tiles;
    assert_eq!(row_tiles(10, 4).collect::<Vec<_>>(), vec![(0, 4), (4, 4), (8, 2)]);
    assert_eq!(row_tiles(3, 0).collect::<Vec<_>>(), vec![(0, 1), (1, 1), (2, 1)]);
    assert_eq!(row_tiles(0, 5).count(), 0);
}

/// A scene whose bins' lists change from one bin row to the next: a 9 × 9 lattice of small
/// spheres, each seen in a bin row or two of a 61 × 53 image.
fn lattice() -> raycaster::scene::Scene {
    let mut spheres = Vec::new();
    for y in -4..=4 {
        for x in -4..=4 {
            spheres.push(format!("Sphere {{ center {} {} 0 radius 0.17 }}", x as f64 * 0.5, y as f64 * 0.55));
        }
    }
    let text = format!(
        "OrthographicCamera {{ center 0 0 10 direction 0 0 -1 up 0 1 0 size 5.2 }}
         Lights {{ numLights 1 DirectionalLight {{ direction -0.3 -0.4 -1 color 1 1 1 }} }}
         Background {{ color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }}
         Materials {{ numMaterials 1 Material {{ diffuseColor 0.9 0.5 0.2 }} }}
         Group {{ numObjects {} MaterialIndex 0 {} }}",
        spheres.len(),
        spheres.join("\n")
    );
    raycaster::scene::parse_scene(&text, "lattice.txt".as_ref()).unwrap()
}

/// Options that find candidates through the bins, in tiles of at most `max_tile_bytes`.
fn binned(max_tile_bytes: u64) -> GpuOptions {
    GpuOptions { acceleration: raycaster::gpu::Acceleration::Bins, max_tile_bytes, ..GpuOptions::default() }
}

/// Each tile binds only the bins of its own band of rows, indexed from the band's first bin
/// row (docs/SPEC.md §6): tiles of 3 rows (so bands start inside a bin, and a packet of 4
/// rows inside a tile) and a band of a split render starting at row 13 give what one tile,
/// holding every bin, gives: a band read one bin row off would show another row's spheres.
#[test]
fn gpu_binned_tiles_equal_one_pass() {
    use raycaster::gpu::{Acceleration, GpuRenderer};
    let Some(gpu) = common::gpu() else { return };
    let (width, height) = (61, 53);
    let whole_gpu = gpu.on_same_device(binned(u64::MAX));
    let small = gpu.on_same_device(binned(width as u64 * 3 * 32));
    let sampled = RenderOptions {
        sampling: Some(raycaster::sampling::Sampling {
            sampler: raycaster::sampling::Sampler::Jittered(4),
            filter: raycaster::sampling::Filter::Tent(1.5),
            seed: 3,
        }),
        ..RenderOptions::all(width, height)
    };
    for options in [RenderOptions::all(width, height), sampled] {
        let render = |g: &GpuRenderer| common::render_gpu_tiles(g, &lattice(), &options);
        let (whole, whole_stats) = render(&whole_gpu);
        let (tiled, stats) = render(&small);
        assert_eq!((whole_stats.acceleration, stats.acceleration), (Acceleration::Bins, Acceleration::Bins));
        assert_eq!((whole_stats.tiles, stats.tiles), (1, 18));
        let hits = whole.hit.iter().filter(|&&h| h).count();
        assert!(hits > 500 && hits < 2500, "{hits} pixels hit: the spheres are not where the test wants them");
        assert!(tiled == whole, "tiles of 3 rows differ from one tile (sampling {:?})", options.sampling);
        let prepared = small.prepare(&lattice(), &options, false).unwrap();
        let mut band = whole.clone();
        band.hit.fill(false);
        prepared
            .render_band(13, 29, |tile| {
                band.paste(tile.first_row, &tile.to_frame());
                Ok::<(), raycaster::gpu::GpuError>(())
            })
            .unwrap();
        let rows = (13 * width) as usize..(42 * width) as usize;
        assert_eq!(band.hit[rows.clone()], whole.hit[rows.clone()]);
        assert_eq!(band.color[rows.clone()], whole.color[rows], "rows 13 … 41 alone differ from one tile");
    }
}
