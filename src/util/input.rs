//! Opening input files: a file read whole (a scene, a mesh, photon maps) must be a file, not a
//! device. `/dev/zero` (or a link to it) never ends: reading it as a scene or photon maps held
//! the process until memory ran out, and a device cannot be a scene anyway. Named pipes are
//! read, as a shell's `<(...)` gives them.

use std::fs::File;
use std::io::{Error, ErrorKind, Read};
use std::os::unix::fs::FileTypeExt;
use std::path::Path;

/// Why `path` cannot be read as a file, if it cannot: a folder or a device (links followed).
pub fn refuse(path: &Path) -> std::io::Result<()> {
    let kind = std::fs::metadata(path)?.file_type();
    let why = if kind.is_dir() {
        "is a folder"
    } else if kind.is_char_device() || kind.is_block_device() || kind.is_socket() {
        "is a device, not a file"
    } else {
        return Ok(());
    };
    Err(Error::new(ErrorKind::InvalidInput, why))
}

/// Bytes a [`Counted`] reader reads between two reports.
pub const REPORT_EVERY: u64 = 1 << 22;

/// A reader that tells `report` how many bytes it has read so far, every [`REPORT_EVERY`]:
/// the progress of a large file's load.
pub struct Counted<'a, R> {
    inner: R,
    read: u64,
    reported: u64,
    report: &'a dyn Fn(u64),
}

impl<'a, R> Counted<'a, R> {
    /// `inner`, counted.
    pub fn new(inner: R, report: &'a dyn Fn(u64)) -> Self {
        Counted {
            inner,
            read: 0,
            reported: 0,
            report,
        }
    }
}

impl<R: Read> Read for Counted<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.read += n as u64;
        if self.read - self.reported >= REPORT_EVERY {
            self.reported = self.read;
            (self.report)(self.read);
        }
        Ok(n)
    }
}

/// [`File::open`] for an input file: refuses folders and devices.
pub fn open(path: &Path) -> std::io::Result<File> {
    refuse(path)?;
    File::open(path)
}

/// [`std::fs::read`] for an input file: refuses folders and devices.
pub fn read(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    open(path)?.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// [`std::fs::read_to_string`] for an input file: refuses folders and devices.
pub fn read_to_string(path: &Path) -> std::io::Result<String> {
    let mut text = String::new();
    open(path)?.read_to_string(&mut text)?;
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_folders_are_refused_with_their_reason() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("scene.toml");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        for path in [Path::new("/dev/zero"), &link] {
            let e = read_to_string(path).unwrap_err();
            assert_eq!(e.to_string(), "is a device, not a file");
        }
        assert_eq!(read(dir.path()).unwrap_err().to_string(), "is a folder");
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "abc").unwrap();
        assert_eq!(read_to_string(&file).unwrap(), "abc");
        assert_eq!(read(&file).unwrap(), b"abc");
        assert_eq!(
            read(&dir.path().join("missing")).unwrap_err().kind(),
            ErrorKind::NotFound
        );
    }
}
