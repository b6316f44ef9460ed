//! The run's output files: refused before any work where they would land on one another, on
//! an input or somewhere unwritable; their folders made, and removed again when the run fails.

use super::{is_stdout, OUTPUT_ON_STDOUT};
use std::path::{Path, PathBuf};

/// The folders [`create_parent`] made in this run, in the order made (outermost first).
static CREATED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Removes the folders this run made for its outputs that are still empty, innermost first:
/// for a run that failed (a refused `reference -o o/new/x.exr` left `o/new/` behind).
pub fn remove_created_folders() {
    let created = std::mem::take(&mut *CREATED.lock().unwrap_or_else(|e| e.into_inner()));
    for dir in created.iter().rev() {
        // Only an empty folder goes: whatever was written into it stays.
        let _ = std::fs::remove_dir(dir);
    }
}

/// Creates the folder that will hold `path`, if it has one, remembering the folders it made
/// ([`remove_created_folders`]).
pub fn create_parent(path: &Path) -> Result<(), String> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            let missing: Vec<PathBuf> = dir
                .ancestors()
                .take_while(|a| !a.as_os_str().is_empty() && !a.exists())
                .map(Path::to_path_buf)
                .collect();
            make_folder(dir)?;
            let mut created = CREATED.lock().unwrap_or_else(|e| e.into_inner());
            created.extend(missing.into_iter().rev());
            Ok(())
        }
        _ => Ok(()),
    }
}

/// `create_dir_all`, with an error that names a file in the way.
fn make_folder(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| {
        // The nearest part of the folder that exists, when it is a file ("File exists"
        // said nothing of which).
        let file = dir.ancestors().find(|a| a.exists()).filter(|a| !a.is_dir());
        match file {
            Some(f) if f == dir => format!("{}: is a file, not a folder", dir.display()),
            Some(f) => format!(
                "{}: cannot create folder: {} is a file",
                dir.display(),
                f.display()
            ),
            None => format!("{}: cannot create folder: {e}", dir.display()),
        }
    })
}

/// The path as the file system will resolve it, for comparing paths: absolute, and through
/// the symbolic links of the part that exists (`a/../b.exr` and `./b.exr` are one file).
pub(super) fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    // A link to a file not yet written is where the writer will go: `--png p.png`, a link to
    // `out.exr`, wrote the preview over the image.
    let path = &photondiff::util::atomic::follow_links(path).unwrap_or_else(|_| path.into());
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (absolute.parent(), absolute.file_name()) {
        (Some(dir), Some(name)) => std::fs::canonicalize(dir)
            .map(|d| d.join(name))
            .unwrap_or(absolute.clone()),
        _ => absolute,
    }
}

/// The PNG preview of an image written to `exr`: `--png` where given, else `exr` with `.png`,
/// but none where `exr` is a device or pipe (`-o /dev/null` wrote its preview to a file
/// `/dev/null.png`, a pipe's beside the pipe).
pub fn preview_path(exr: &Path, png: Option<&Path>) -> Option<PathBuf> {
    match png {
        Some(png) => Some(png.to_path_buf()),
        None => {
            let special = std::fs::metadata(exr).is_ok_and(|m| !m.is_file() && !m.is_dir());
            (!special).then(|| exr.with_extension("png"))
        }
    }
}

/// Refuses an image name whose extension says the other format: the EXR (`-o`) named `.png`
/// or the PNG preview (`--png`) named `.exr` (the file would hold the other format's bytes
/// under a name that promises this one).
pub fn check_image_names(exr: &Path, png: &Path) -> Result<(), String> {
    let ext = |p: &Path| {
        p.extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
    };
    if ext(exr).as_deref() == Some("png") {
        return Err(format!(
            "-o {}: the image is written as OpenEXR; give it a .exr name (the PNG preview goes \
             to --png)",
            exr.display()
        ));
    }
    if ext(png).as_deref() == Some("exr") {
        return Err(format!(
            "--png {}: the preview is written as PNG; give it a .png name",
            png.display()
        ));
    }
    Ok(())
}

/// Refuses, before any work, outputs that would land on one another or on an input: each
/// output, named by its option (`("-o", path)`), must be a file of its own, and none may be
/// one of `inputs` (the scene, parts being merged), which the run would otherwise overwrite
/// with its result.
pub fn check_outputs(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), String> {
    if outputs.iter().any(|(_, path)| is_stdout(path)) {
        OUTPUT_ON_STDOUT.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    for (k, (flag, path)) in outputs.iter().enumerate() {
        let here = resolved(path);
        for (other, other_path) in &outputs[..k] {
            if resolved(other_path) == here {
                return Err(format!(
                    "{flag} and {other} name the same file ({}): each output needs its own",
                    path.display()
                ));
            }
        }
        for (what, input) in inputs {
            if resolved(input) == here {
                return Err(format!(
                    "{flag} names the {what} ({}): the run would overwrite it",
                    path.display()
                ));
            }
        }
        if here.is_dir() {
            return Err(format!("{flag}: {} is a folder", path.display()));
        }
        probe_writable(path).map_err(|e| format!("{flag}: {e}"))?;
    }
    Ok(())
}

/// Makes sure `path` can be written before the work that writes it (a render writing to
/// `/proc` failed only after it was done): creates its folder and a scratch file beside it
/// (removed at once). A device or pipe that exists (`/dev/null`) is written in place and
/// needs no probe.
fn probe_writable(path: &Path) -> Result<(), String> {
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return Ok(());
    }
    // Where the file will be written: through a link (one to a file not yet written too), as
    // the writer goes.
    let target = photondiff::util::atomic::follow_links(path)
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    let path = target.as_path();
    create_parent(path)?;
    let probe = photondiff::util::atomic::scratch_beside(path, "probe");
    std::fs::File::create(&probe).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_on_each_other_or_on_an_input_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, "x").unwrap();
        let exr = dir.path().join("a.exr");
        let png = dir.path().join("a.png");
        assert_eq!(
            check_outputs(&[("-o", &exr), ("--png", &png)], &[("scene", &scene)]),
            Ok(())
        );
        // The same file spelt another way.
        let again = dir.path().join("sub/../a.exr");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        assert_eq!(
            check_outputs(&[("-o", &exr), ("--png", &again)], &[]),
            Err(format!(
                "--png and -o name the same file ({}): each output needs its own",
                again.display()
            ))
        );
        assert_eq!(
            check_outputs(&[("-o", &scene)], &[("scene", &scene)]),
            Err(format!(
                "-o names the scene ({}): the run would overwrite it",
                scene.display()
            ))
        );
        assert_eq!(
            check_outputs(&[("-o", dir.path())], &[]),
            Err(format!("-o: {} is a folder", dir.path().display()))
        );
        // Unwritable before any work (it failed after the render); no scratch file is left.
        let proc_file = Path::new("/proc/x.exr");
        let e = check_outputs(&[("-o", proc_file)], &[]).unwrap_err();
        assert!(e.starts_with("-o: /proc/x.exr: cannot write: "), "{e}");
        assert_eq!(
            check_outputs(&[("-o", Path::new("/dev/null"))], &[]),
            Ok(())
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
