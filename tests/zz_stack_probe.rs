use raycaster::scene::parse_scene;
use std::path::Path;
#[test]
fn probe() {
    let mut text = String::from("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\nGroup { numObjects 1\n");
    text.push_str(&"Transform { Translate 0 0 0\n".repeat(100_000));
    for kb in [64usize, 128, 256, 512, 768, 1024, 1536, 2048, 3072, 4096, 6144, 8192] {
        let t = text.clone();
        let ok = std::process::Command::new(std::env::current_exe().unwrap()).arg("--exact").arg("child").env("KB", kb.to_string()).output().unwrap().status.success();
        let _ = t;
        println!("{kb} KiB: {}", if ok { "ok" } else { "overflow" });
    }
}
#[test]
fn child() {
    let Ok(kb) = std::env::var("KB") else { return };
    let kb: usize = kb.parse().unwrap();
    let kind = std::env::var("KIND").unwrap_or_default();
    let mut text = String::from("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\nGroup { numObjects 1\n");
    if kind == "g" { text.push_str(&"Group { numObjects 1\n".repeat(100_000)); } else { text.push_str(&"Transform { Translate 0 0 0\n".repeat(100_000)); }
    std::thread::Builder::new().stack_size(kb << 10).spawn(move || { let _ = parse_scene(&text, Path::new("x")); }).unwrap().join().unwrap();
}
