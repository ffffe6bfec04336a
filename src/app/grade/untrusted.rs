//! Reading what a student made (their folder of images, their program's outputs): every
//! component of a path opened without following a link, a file opened without blocking
//! (a FIFO would hang a plain `open`) and taken only if it is a regular file, at most as many
//! bytes read as the request needs, and an image's header checked against the size expected
//! before its pixels are decoded (a 0.5 MB PNG may claim 13000×13000).

use image::RgbImage;
use std::fs::File;
use std::io::{Cursor, Read};
use std::path::{Component, Path};

/// Why a path is not one a student's file may have: absolute, or leaving its folder.
pub fn outside_reason(relative: &Path) -> Option<&'static str> {
    if relative.has_root() || relative.components().any(|c| matches!(c, Component::Prefix(_))) {
        return Some("is absolute");
    }
    relative.components().any(|c| c == Component::ParentDir).then_some("leaves the folder (..)")
}

/// `relative` under `base`, its `..` taken lexically; `None` where it climbs above `base`.
pub fn lexically_beneath(base: &Path, relative: &Path) -> Option<std::path::PathBuf> {
    let mut parts: Vec<Component> = Vec::new();
    for part in relative.components() {
        match part {
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::Normal(_) => parts.push(part),
            Component::CurDir => {}
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(parts.iter().fold(base.to_path_buf(), |path, part| path.join(part)))
}

/// The regular file `relative` names under `base`, no component of it a link. `Err`
/// starts with `no file` when nothing is there.
pub fn open_beneath(base: &Path, relative: &Path) -> Result<File, String> {
    if let Some(why) = outside_reason(relative) {
        return Err(format!("{}: {why}", relative.display()));
    }
    let file = open_no_links(base, relative)?;
    let metadata = file.metadata().map_err(|e| format!("{}: {e}", relative.display()))?;
    if !metadata.is_file() {
        return Err(format!("{}: not a regular file", relative.display()));
    }
    Ok(file)
}

#[cfg(unix)]
fn open_no_links(base: &Path, relative: &Path) -> Result<File, String> {
    use std::ffi::CString;
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::ffi::OsStrExt;
    let named = |e: std::io::Error| match e.raw_os_error() {
        Some(libc::ENOENT) => format!("no file {}", relative.display()),
        Some(libc::ELOOP) => format!("{}: a link, not followed", relative.display()),
        Some(libc::ENOTDIR) => format!("{}: a link or a file where a folder should be", relative.display()),
        _ => format!("{}: {e}", relative.display()),
    };
    let mut folder: OwnedFd = File::open(base).map_err(|e| format!("{}: {e}", base.display()))?.into();
    let parts: Vec<_> = relative.components().filter(|c| *c != Component::CurDir).collect();
    let Some((last, folders)) = parts.split_last() else {
        return Err(format!("{}: names no file", relative.display()));
    };
    let open_at = |folder: &OwnedFd, name: &std::ffi::OsStr, flags: i32| -> Result<OwnedFd, String> {
        let name = CString::new(name.as_bytes()).map_err(|_| format!("{}: a NUL in the name", relative.display()))?;
        use std::os::fd::AsRawFd;
        // SAFETY: a valid descriptor and a NUL-terminated name; the result is checked.
        let fd = unsafe { libc::openat(folder.as_raw_fd(), name.as_ptr(), flags | libc::O_NOFOLLOW | libc::O_CLOEXEC) };
        if fd < 0 {
            return Err(named(std::io::Error::last_os_error()));
        }
        // SAFETY: a descriptor just opened, owned by nothing else.
        Ok(unsafe { OwnedFd::from_raw_fd(fd) })
    };
    for part in folders {
        folder = open_at(&folder, part.as_os_str(), libc::O_RDONLY | libc::O_DIRECTORY)?;
    }
    open_at(&folder, last.as_os_str(), libc::O_RDONLY | libc::O_NONBLOCK).map(File::from)
}

#[cfg(not(unix))]
fn open_no_links(base: &Path, relative: &Path) -> Result<File, String> {
    let mut path = base.to_path_buf();
    for part in relative.components() {
        path.push(part);
        match std::fs::symlink_metadata(&path) {
            Err(_) => return Err(format!("no file {}", relative.display())),
            Ok(m) if m.file_type().is_symlink() => return Err(format!("{}: a link, not followed", relative.display())),
            Ok(_) => {}
        }
    }
    File::open(&path).map_err(|e| format!("{}: {e}", relative.display()))
}

/// All of `file`, refused past `max` bytes (without reading more than one byte past).
pub fn read_at_most(file: File, max: u64) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    file.take(max + 1).read_to_end(&mut bytes).map_err(|e| e.to_string())?;
    if bytes.len() as u64 > max {
        return Err(format!("larger than {max} bytes"));
    }
    Ok(bytes)
}

/// The most bytes an image file of `width × height` may take: its pixels four bytes each
/// (RGBA, uncompressed) and room for headers, chunks and a poor compressor.
pub fn image_file_bound(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * 4 + (1 << 20)
}

/// The image `name` (its extension says TGA or PNG, else its first bytes do) in `bytes`, as
/// 8-bit RGB, if its header says `expected`'s size; its pixels are not decoded otherwise.
pub fn decode_image(bytes: &[u8], name: &Path, expected: (u32, u32)) -> Result<RgbImage, String> {
    let reader = || -> Result<image::ImageReader<Cursor<&[u8]>>, String> {
        let mut reader = image::ImageReader::new(Cursor::new(bytes));
        match image::ImageFormat::from_path(name) {
            Ok(format) => reader.set_format(format),
            Err(_) => reader = reader.with_guessed_format().map_err(|e| e.to_string())?,
        }
        Ok(reader)
    };
    let unreadable = |e: image::ImageError| format!("unreadable: {e}");
    let (width, height) = reader()?.into_dimensions().map_err(unreadable)?;
    if (width, height) != expected {
        return Err(format!("is {width}×{height}, ours {}×{}", expected.0, expected.1));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(width);
    limits.max_image_height = Some(height);
    limits.max_alloc = Some(image_file_bound(width, height) * 2);
    let mut reader = reader()?;
    reader.limits(limits);
    Ok(reader.decode().map_err(unreadable)?.to_rgb8())
}

/// The image `relative` names under `base`, read as [`decode_image`] reads it, its format
/// told by `named`'s extension (the name the command line gave it).
pub fn read_image(base: &Path, relative: &Path, named: &Path, expected: (u32, u32)) -> Result<RgbImage, String> {
    let file = open_beneath(base, relative)?;
    let bytes = read_at_most(file, image_file_bound(expected.0, expected.1))
        .map_err(|why| format!("unreadable: {why} (an image of {}×{} needs less)", expected.0, expected.1))?;
    decode_image(&bytes, named, expected)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_outside_the_folder_are_refused() {
        assert_eq!(outside_reason(Path::new("/etc/passwd")), Some("is absolute"));
        assert_eq!(outside_reason(Path::new("out/../../x.tga")), Some("leaves the folder (..)"));
        assert_eq!(outside_reason(Path::new("out/./x.tga")), None);
        let beneath = |r: &str| lexically_beneath(Path::new("/a/b"), Path::new(r));
        assert_eq!(beneath("work/../s.txt"), Some("/a/b/s.txt".into()));
        assert_eq!(beneath("work/../../s.txt"), None);
    }

    #[cfg(unix)]
    #[test]
    fn links_fifos_and_folders_are_not_opened() {
        let dir = tempfile::tempdir().unwrap();
        let secret = dir.path().join("secret.txt");
        std::fs::write(&secret, b"teacher").unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        std::fs::write(dir.path().join("sub/ok.tga"), b"x").unwrap();
        std::os::unix::fs::symlink(&secret, dir.path().join("link.tga")).unwrap();
        std::os::unix::fs::symlink(dir.path().join("sub"), dir.path().join("linked")).unwrap();
        let fifo = std::ffi::CString::new(dir.path().join("fifo.tga").to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
        let open = |name: &str| open_beneath(dir.path(), Path::new(name)).map(|_| ()).unwrap_err();
        assert!(open("link.tga").contains("a link, not followed"));
        assert!(open("linked/ok.tga").contains("where a folder should be"), "{}", open("linked/ok.tga"));
        assert!(open("fifo.tga").contains("not a regular file"), "a FIFO is refused without blocking");
        assert!(open("sub").contains("not a regular file"));
        assert!(open("none.tga").starts_with("no file none.tga"));
        assert!(open_beneath(dir.path(), Path::new("sub/ok.tga")).is_ok());
    }

    /// A PNG whose header claims 13000×13000 is refused before its pixels are decoded; one of
    /// the size expected is read.
    #[test]
    fn a_header_of_another_size_is_refused_before_decoding() {
        let mut png = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut png, 4000, 4000);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_compression(png::Compression::High);
            let mut writer = encoder.write_header().unwrap();
            writer.write_image_data(&vec![0; 4000 * 4000 * 3]).unwrap();
        }
        assert!(png.len() < 100_000, "{} bytes", png.len());
        let why = decode_image(&png, Path::new("x.png"), (200, 200)).unwrap_err();
        assert_eq!(why, "is 4000×4000, ours 200×200");
        let mut small = Cursor::new(Vec::new());
        RgbImage::from_pixel(3, 2, image::Rgb([1, 2, 3])).write_to(&mut small, image::ImageFormat::Tga).unwrap();
        let read = decode_image(small.get_ref(), Path::new("x.tga"), (3, 2)).unwrap();
        assert_eq!(read.get_pixel(2, 1).0, [1, 2, 3]);
        assert_eq!(read_at_most(File::open("Cargo.toml").unwrap(), 10).unwrap_err(), "larger than 10 bytes");
    }
}
