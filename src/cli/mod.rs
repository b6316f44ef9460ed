//! The subcommands of the command line, one file each, and what they share.

pub mod compare;
pub mod info;
pub mod merge;
pub mod pass_range;
pub mod photons;
pub mod reference;
pub mod render;
pub mod report;

use std::path::Path;

/// The most worker threads `--threads` takes: far beyond any machine this runs on, and low
/// enough that asking for a typo's worth (100000) is refused in one line instead of the
/// operating system failing thread after thread.
pub const MAX_THREADS: usize = 1024;

/// Checks `--threads` (0 = one per core).
pub fn check_threads(threads: usize) -> Result<usize, String> {
    if threads > MAX_THREADS {
        return Err(format!(
            "--threads must be at most {MAX_THREADS} (0 = one per core), got {threads}"
        ));
    }
    Ok(threads)
}

/// Creates the folder that will hold `path`, if it has one.
pub fn create_parent(path: &Path) -> Result<(), String> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => std::fs::create_dir_all(dir)
            .map_err(|e| format!("{}: cannot create folder: {e}", dir.display())),
        _ => Ok(()),
    }
}
