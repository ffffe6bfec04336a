//! The compiled kernels kept between processes (src/gpu/pipeline_cache.rs): written to
//! `$RAYCASTER_CACHE_DIR` when a kernel is compiled, read by the next process, harmless when
//! it is garbage, and not kept when the variable is empty.

mod common;

use std::path::Path;

/// Renders scenes/triangles.txt at 40² on the GPU with `cache` as the cache folder, `-v`;
/// returns stderr and the image's bytes.
fn render(cache: &str, out: &Path) -> (String, Vec<u8>) {
    let image = out.join("o.tga");
    let output = common::bin::command()
        .args(["-input", "scenes/triangles.txt", "-size", "40", "40", "-output"])
        .arg(&image)
        .args(["--backend", "gpu", "-v"])
        .env("RAYCASTER_CACHE_DIR", cache)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    (stderr, std::fs::read(image).unwrap())
}

/// The `-v` line naming the cache, if any.
fn cache_line(stderr: &str) -> Option<&str> {
    stderr.lines().find(|l| l.contains("pipeline cache: "))
}

#[test]
fn compiled_kernels_are_kept_read_again_and_ignored_when_garbage() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let cache_str = cache.to_str().unwrap();
    let (first, image) = render(cache_str, dir.path());
    let Some(line) = cache_line(&first) else {
        // The adapter offers no pipeline cache (not Vulkan): nothing may be written.
        assert!(!cache.exists(), "{first}");
        return;
    };
    assert!(line.contains("(0.0 KiB read"), "a first process reads nothing: {line}");
    let names: Vec<String> =
        std::fs::read_dir(&cache).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    // Beside it, on lavapipe, the kernels dispatched (gpu::ahead's first-dispatches.txt).
    let caches: Vec<&String> = names.iter().filter(|n| *n != "first-dispatches.txt").collect();
    assert_eq!(caches.len(), 1, "one file per adapter, no temporary left: {names:?}");
    assert!(caches[0].starts_with("wgpu_pipeline_cache_vulkan_"), "{names:?}");
    let files = [cache.join(caches[0])];
    let kept = std::fs::metadata(&files[0]).unwrap().len();
    assert!(kept > 0);

    let (second, again) = render(cache_str, dir.path());
    let line = cache_line(&second).unwrap();
    assert!(line.contains(&format!("({:.1} KiB read", kept as f64 / 1024.0)), "the second reads it: {line}");
    assert_eq!(again, image);
    // On lavapipe (Mesa's disk cache on), the one kernel both processes dispatched is listed
    // once, for a later batch's threads to skip (gpu::ahead); elsewhere nothing is.
    let info = common::gpu().unwrap().adapter_info();
    let mesa_switch = ["MESA_SHADER_CACHE_DISABLE", "MESA_GLSL_CACHE_DISABLE"].map(std::env::var_os);
    if mesa_switch.iter().all(Option::is_none) {
        let listed = std::fs::read_to_string(cache.join("first-dispatches.txt")).map_or(0, |t| t.lines().count());
        assert_eq!(listed, usize::from(info.driver.contains("llvmpipe") || info.name.contains("llvmpipe")));
    }

    // A file of garbage (another program's, a disk error): wgpu checks its header and
    // starts empty; the render is the same.
    std::fs::write(&files[0], vec![0x5a; 4096]).unwrap();
    let (third, garbage) = render(cache_str, dir.path());
    assert!(cache_line(&third).is_some(), "{third}");
    assert_eq!(garbage, image);
}

#[test]
fn an_empty_cache_variable_keeps_no_cache() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (stderr, _) = render("", dir.path());
    assert_eq!(cache_line(&stderr), None, "{stderr}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only the image");
}
