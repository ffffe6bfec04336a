//! The checks of a parsed command line that look at the file system, after parsing and
//! before anything is rendered: an output that names a folder, and two outputs that name
//! one file. A failure is a bad command line like a parsing error: one line naming the
//! flag, status 2, no file touched.

use crate::app::args::{flag_of, Command, Judged, OutputPaths, UsageError};
use raycaster::image_io::ImageFormat;
use std::path::{Path, PathBuf};

/// Checks the image files `command` names.
pub fn check(command: &Command) -> Result<(), UsageError> {
    match command {
        Command::Render(args) => {
            image_names(&args.files)?;
            distinct_files(&args.files)
        }
        // compare writes no file, so two outputs may name one.
        Command::Compare { args, .. } => image_names(&args.files),
        Command::Stitch(args) => image_names(&args.files),
        Command::Grade(args) => {
            has_commands(&args.assignment, "grade")?;
            if let Judged::Images(dir) = &args.judged {
                if !dir.is_dir() {
                    return Err(UsageError(format!("--images {}: not a folder", dir.display())));
                }
            }
            args.html.as_deref().map_or(Ok(()), html_name)
        }
        Command::Gallery(args) => {
            if !args.corpus.is_dir() {
                return Err(UsageError(format!("gallery {}: not a folder", args.corpus.display())));
            }
            html_name(&args.html)
        }
        Command::Batch { .. } | Command::Bench(_) | Command::Selftest | Command::Help | Command::Version => Ok(()),
    }
}

/// An assignment's folder, with the `commands.txt` that says what to render.
fn has_commands(folder: &Path, verb: &str) -> Result<(), UsageError> {
    if !folder.join("commands.txt").is_file() {
        return Err(UsageError(format!(
            "{verb} {}: no commands.txt there; give an assignment's folder, such as ../shared/mit6837/a4",
            folder.display()
        )));
    }
    Ok(())
}

/// `--html FILE` names a file, not a folder.
fn html_name(path: &Path) -> Result<(), UsageError> {
    if names_a_folder(path) {
        return Err(UsageError(format!(
            "--html {}: names a folder; give a file name, such as {}",
            path.display(),
            path.join("report.html").display()
        )));
    }
    Ok(())
}

/// Each output names an image file: not a folder, and with an extension that says which
/// format. The extension is checked here rather than while parsing so that a folder
/// (which has none) is called a folder.
fn image_names(files: &OutputPaths) -> Result<(), UsageError> {
    for (output, path) in files.named() {
        let flag = flag_of(output);
        if names_a_folder(path) {
            return Err(UsageError(format!(
                "{flag} {}: names a folder; give an image file name, such as {}",
                path.display(),
                path.join("image.tga").display()
            )));
        }
        if ImageFormat::from_path(path).is_none() {
            return Err(UsageError(format!(
                "{flag} {}: unsupported image format, use .tga, .png or .exr",
                path.display()
            )));
        }
    }
    Ok(())
}

/// An output path that is an existing folder, or ends with a separator as folder names do.
fn names_a_folder(path: &Path) -> bool {
    path.is_dir() || path.as_os_str().to_string_lossy().ends_with(std::path::is_separator)
}

/// Refuses two outputs naming one file: one image would silently replace the other.
fn distinct_files(files: &OutputPaths) -> Result<(), UsageError> {
    let named = files.named();
    for (k, &(first_output, first)) in named.iter().enumerate() {
        if let Some((output, path)) = named[k + 1..].iter().find(|(_, path)| same_file(first, path)) {
            return Err(UsageError(format!(
                "{} {} and {} {} name the same file: one image would replace the other",
                flag_of(first_output),
                first.display(),
                flag_of(*output),
                path.display()
            )));
        }
    }
    Ok(())
}

/// Whether two output paths name one file: equal as written, or once their folders are
/// resolved (`a.tga`, `./a.tga` and `out/../a.tga` are one file).
fn same_file(a: &Path, b: &Path) -> bool {
    a == b || resolved(a).is_some_and(|a| resolved(b) == Some(a))
}

fn resolved(path: &Path) -> Option<PathBuf> {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(folder.canonicalize().ok()?.join(path.file_name()?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::cli::parse_args;

    fn checked(line: &str) -> Result<(), UsageError> {
        check(&parse_args(line.split_whitespace()).expect(line))
    }

    /// Two outputs naming one file are refused, however the name is spelled; compare writes
    /// no file, so it does not mind.
    #[test]
    fn outputs_must_name_distinct_files() {
        let err = checked("-input s -size 1 1 -normals a.tga -depth 0 1 ./a.tga").unwrap_err();
        assert_eq!(err.0, "-normals a.tga and -depth ./a.tga name the same file: one image would replace the other");
        // Unit tests run in the package root, which has a src folder.
        assert!(checked("-input s -size 1 1 -output a.tga -normals src/../a.tga").unwrap_err().0.contains("same file"));
        assert!(checked("-input s -size 1 1 -output a.tga -normals b.tga -depth 0 1 c.png").is_ok());
        assert!(checked("compare -input s -size 1 1 -output a.tga -normals a.tga").is_ok());
    }

    #[test]
    fn outputs_must_be_image_files() {
        let cases = [
            ("-input s -size 1 1 -output o.bmp", "-output o.bmp: unsupported image format"),
            (
                "-input s -size 1 1 -output src",
                "-output src: names a folder; give an image file name, such as src/image.tga",
            ),
            ("-input s -size 1 1 -normals out/", "-normals out/: names a folder"),
            ("stitch -depth 0 1 d.txt", "-depth d.txt: unsupported image format"),
            ("compare -input s -size 1 1 -output src", "names a folder"),
        ];
        for (line, needle) in cases {
            let err = checked(line).expect_err(line);
            assert!(err.0.contains(needle), "{line}: {err}");
        }
    }
}
