//! Atomic file output: everything is written to a temporary file in the destination's folder
//! and renamed over the destination only once complete, so a killed or failing job never leaves
//! a file that looks finished (rename within one file system is atomic on POSIX).
//!
//! A destination that is a symbolic link is followed: the file it names is replaced and the
//! link kept. One that exists and is not a regular file (`/dev/null`, a named pipe) is written
//! in place: renaming over it would replace a device node with a file (as root, `-o /dev/null`
//! did).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary file `path` is written to first: hidden, in the same folder (so the rename
/// stays on one file system), unique to this process.
fn temporary(path: &Path) -> PathBuf {
    scratch_beside(path, "tmp")
}

/// A hidden scratch file beside `path`, named after it, this process and `tag`. The name is
/// cut to 200 bytes first: a destination's name may take all 255 bytes a name can, and the
/// scratch's own was refused as "File name too long", an error that blamed the user's name.
pub fn scratch_beside(path: &Path, tag: &str) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut cut = name.len().min(200);
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    path.with_file_name(format!(".{}.{}.{tag}", &name[..cut], std::process::id()))
}

/// Writes `path` atomically with `write`, which receives a buffered writer; on any error the
/// temporary file is removed and `path` is left as it was. Errors name `path`.
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), String> {
    let named = path;
    let cannot = |e: std::io::Error| format!("{}: cannot write: {e}", named.display());
    // Through symbolic links (`metadata` follows them) to what the path names.
    if let Ok(meta) = std::fs::metadata(path) {
        if !meta.is_file() && !meta.is_dir() {
            let file = std::fs::OpenOptions::new().write(true).open(path);
            let mut out = BufWriter::new(file.map_err(cannot)?);
            write(&mut out).map_err(cannot)?;
            return out.flush().map_err(cannot);
        }
    }
    let target = follow_links(path).map_err(cannot)?;
    let path = target.as_path();
    let tmp = temporary(path);
    let result = (|| {
        let mut out = BufWriter::new(File::create(&tmp)?);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        cannot(e)
    })
}

/// Where writing `path` lands: `path` itself, or, for a symbolic link, the file at the end of
/// its chain of links, whether that file exists yet or not (a link to an image not yet
/// rendered is written through, as any other link). A loop of links is an error.
pub fn follow_links(path: &Path) -> std::io::Result<PathBuf> {
    let mut at = path.to_path_buf();
    // Linux's own limit on links followed in one lookup.
    for _ in 0..40 {
        if !at.is_symlink() {
            return Ok(at);
        }
        let to = std::fs::read_link(&at)?;
        at = match at.parent() {
            Some(dir) if to.is_relative() => dir.join(to),
            _ => to,
        };
    }
    Err(std::io::Error::other(
        "a loop of symbolic links (more than 40 followed)",
    ))
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), String> {
    write_with(path, |out| out.write_all(bytes))
}

/// Writes 8-bit RGB pixels (`width` x `height`, row-major) to `path` as a PNG, whatever its
/// name's extension, as [`write_bytes`] writes: whole or not at all.
pub fn write_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<(), String> {
    let mut png = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(
        &mut png,
        rgb,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| format!("{}: cannot write PNG: {e}", path.display()))?;
    write_bytes(path, png.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.bin");
        write_bytes(&path, b"abc").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_the_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.bin");
        std::fs::write(&path, b"old").unwrap();
        let err = write_with(&path, |out| {
            out.write_all(b"partial")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(err.ends_with("cannot write: disk full"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// A name of 255 bytes, the most a name takes, is written (its scratch file's name was
    /// too long).
    #[test]
    fn the_longest_name_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("{}.exr", "é".repeat(125)));
        assert_eq!(path.file_name().unwrap().len(), 254);
        write_bytes(&path, b"long").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"long");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_symbolic_link_is_followed_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.bin");
        std::fs::write(&target, b"old").unwrap();
        let link = dir.path().join("link.bin");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_bytes(&link, b"new").unwrap();
        assert!(link.is_symlink());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // A chain of links, relative, to a file not written yet: written through (it was
        // "No such file or directory" after the work was done).
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        std::os::unix::fs::symlink("sub/chain.bin", dir.path().join("chain.bin")).unwrap();
        std::os::unix::fs::symlink("new.bin", sub.join("chain.bin")).unwrap();
        write_bytes(&dir.path().join("chain.bin"), b"through").unwrap();
        assert_eq!(std::fs::read(sub.join("new.bin")).unwrap(), b"through");
        // A loop is an error naming the path, and nothing is written.
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::os::unix::fs::symlink("b", &a).unwrap();
        std::os::unix::fs::symlink("a", &b).unwrap();
        assert_eq!(
            write_bytes(&a, b"x").unwrap_err(),
            format!(
                "{}: cannot write: a loop of symbolic links (more than 40 followed)",
                a.display()
            )
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 6);
    }

    #[test]
    fn a_named_pipe_is_written_in_place_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let pipe = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo")
            .arg(&pipe)
            .status()
            .unwrap();
        assert!(made.success());
        let reader = {
            let pipe = pipe.clone();
            std::thread::spawn(move || std::fs::read(pipe).unwrap())
        };
        write_bytes(&pipe, b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        let meta = std::fs::symlink_metadata(&pipe).unwrap();
        assert!(std::os::unix::fs::FileTypeExt::is_fifo(&meta.file_type()));
    }

    #[test]
    fn renaming_onto_a_folder_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        std::fs::create_dir(&path).unwrap();
        assert_eq!(
            write_bytes(&path, b"x").unwrap_err(),
            format!(
                "{}: cannot write: Is a directory (os error 21)",
                path.display()
            )
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
