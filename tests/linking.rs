//! The binary starts on any Linux machine with a C library: it links nothing else. wgpu
//! opens the Vulkan loader (and through it the driver) at run time, and winit opens X11 and
//! Wayland the same way, so none of them is a link-time dependency; the plot's text is drawn
//! from a font inside the binary, not through fontconfig and FreeType.
//!
//! `cargo test --release` builds `target/release/raycaster`, the binary a release ships:
//! this test reads that one.

/// glibc's own libraries, the kernel's vDSO and the dynamic loader: there on every Linux.
#[cfg(target_os = "linux")]
const ALLOWED: [&str; 9] = [
    "linux-vdso.so",
    "ld-linux",
    "libc.so",
    "libm.so",
    "libgcc_s.so",
    "libpthread.so",
    "libdl.so",
    "librt.so",
    "linux-gate.so",
];

#[cfg(target_os = "linux")]
#[test]
fn the_binary_links_only_the_c_library() {
    let binary = env!("CARGO_BIN_EXE_raycaster");
    let output = std::process::Command::new("ldd")
        .arg(binary)
        .output()
        .unwrap_or_else(|e| panic!("ldd cannot be run ({e}): install libc-bin, which has it"));
    assert!(output.status.success(), "ldd {binary}: {}", String::from_utf8_lossy(&output.stderr));
    let listing = String::from_utf8_lossy(&output.stdout);
    let libraries: Vec<&str> = listing.lines().filter_map(|l| l.split_whitespace().next()).collect();
    let extra: Vec<&&str> =
        libraries.iter().filter(|lib| !ALLOWED.iter().any(|allowed| lib.contains(allowed))).collect();
    assert!(extra.is_empty(), "{binary} links {extra:?} beyond the C library; ldd says:\n{listing}");
    assert!(libraries.iter().any(|lib| lib.starts_with("libc.so")), "ldd listed no libc:\n{listing}");
}
