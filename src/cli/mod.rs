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

/// Creates the folder that will hold `path`, if it has one.
pub fn create_parent(path: &Path) -> Result<(), String> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => std::fs::create_dir_all(dir)
            .map_err(|e| format!("{}: cannot create folder: {e}", dir.display())),
        _ => Ok(()),
    }
}
