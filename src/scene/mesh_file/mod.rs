//! Mesh files as modelling tools write them: Wavefront OBJ ([`obj`]) and PLY, ASCII or binary
//! ([`ply`]), streamed from disk straight into the final vertex and index buffers.
//!
//! What every tool opens is accepted, and repaired where the renderer needs it ([`repair`]):
//! degenerate triangles, faces of fewer than three vertices and vertices no triangle uses are
//! dropped and zero or non-finite vertex normals replaced, each counted in a [`MeshReport`]
//! (the command line warns once per mesh). Truly broken files (indices out of range, truncated data, non-numbers,
//! non-finite positions) are errors naming the file and the element or line; a header that
//! lies about its counts is refused before anything big is allocated.

mod ear_clip;
#[cfg(test)]
mod ear_clip_reference;
pub mod obj;
pub mod ply;
pub mod repair;
pub mod triangulate;

use crate::embree::{advise_huge_pages, TriangleMesh};
use crate::util::reserve;
use serde::Serialize;
use std::path::Path;

/// What loading a mesh file had to do besides reading it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct MeshReport {
    /// Faces in the file (before triangulation).
    pub faces: u64,
    /// Faces with more than three vertices, triangulated (in their own plane).
    pub polygons: u64,
    /// Of those, the concave ones (triangulated by ear clipping rather than as a fan).
    pub concave_polygons: u64,
    /// Of the concave ones, those that cross themselves (`triangulate::Shape::Crossing`):
    /// triangulated anyway, which may cover area the outline does not (warned about).
    pub crossing_polygons: u64,
    /// Zero-area (or non-finite-area) triangles dropped.
    pub degenerate_triangles: u64,
    /// The vertices of the first dropped triangle, for the warning.
    pub first_degenerate: Option<[[f32; 3]; 3]>,
    /// Zero or non-finite vertex normals replaced by the geometric normal around the vertex.
    pub repaired_normals: u64,
    /// Lines and points (OBJ `l`/`p`) skipped: they are not surfaces.
    pub skipped_lines_points: u64,
    /// Faces of fewer than three vertices skipped: such a face is a line, a point or nothing,
    /// and exporters write them for edges and loose vertices.
    pub short_faces: u64,
    /// Triangles whose winding points away from all three of their vertex normals: the
    /// winding decides which side is outside, so such a mesh's glass is inside out.
    pub against_normals: u64,
    /// Vertices no triangle uses (after degenerate triangles are dropped), dropped: the
    /// scene's size, its ray offsets and footprint limits, come from its vertices.
    pub unused_vertices: u64,
}

impl MeshReport {
    /// One line saying what was dropped or repaired, or `None` when nothing was.
    pub fn warning(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.degenerate_triangles > 0 {
            let mut s = format!(
                "dropped {} degenerate (zero-area) triangle{}",
                self.degenerate_triangles,
                plural(self.degenerate_triangles)
            );
            if let Some([a, b, c]) = self.first_degenerate {
                s += &format!(" (the first: {a:?} {b:?} {c:?})");
            }
            parts.push(s);
        }
        if self.against_normals > 0 {
            let (verb, whose) = match self.against_normals {
                1 => ("winds", "its"),
                _ => ("wind", "their"),
            };
            parts.push(format!(
                "{} triangle{} {verb} against all three of {whose} vertex normals (the winding \
                 says which side is outside: glass there is inside out; reverse those faces' \
                 winding)",
                self.against_normals,
                plural(self.against_normals)
            ));
        }
        if self.crossing_polygons > 0 {
            parts.push(format!(
                "{} polygon{} cross{} {} (triangulated anyway: the triangles may cover \
                 area the outline does not, or some twice; triangulate {} first)",
                self.crossing_polygons,
                plural(self.crossing_polygons),
                if self.crossing_polygons == 1 {
                    "es"
                } else {
                    ""
                },
                if self.crossing_polygons == 1 {
                    "itself"
                } else {
                    "themselves"
                },
                if self.crossing_polygons == 1 {
                    "it"
                } else {
                    "them"
                },
            ));
        }
        if self.short_faces > 0 {
            parts.push(format!(
                "skipped {} face{} of fewer than three vertices (not surfaces)",
                self.short_faces,
                plural(self.short_faces)
            ));
        }
        if self.unused_vertices > 0 {
            parts.push(format!(
                "dropped {} {} no triangle uses",
                self.unused_vertices,
                if self.unused_vertices == 1 {
                    "vertex"
                } else {
                    "vertices"
                }
            ));
        }
        if self.repaired_normals > 0 {
            parts.push(format!(
                "replaced {} zero or non-finite vertex normal{} by the geometric normal there",
                self.repaired_normals,
                plural(self.repaired_normals)
            ));
        }
        (!parts.is_empty()).then(|| parts.join("; "))
    }

    /// Adds `other`'s counts into `self` (keeping the first degenerate triangle seen).
    pub fn add(&mut self, other: &MeshReport) {
        self.faces += other.faces;
        self.polygons += other.polygons;
        self.concave_polygons += other.concave_polygons;
        self.crossing_polygons += other.crossing_polygons;
        self.degenerate_triangles += other.degenerate_triangles;
        self.first_degenerate = self.first_degenerate.or(other.first_degenerate);
        self.repaired_normals += other.repaired_normals;
        self.skipped_lines_points += other.skipped_lines_points;
        self.short_faces += other.short_faces;
        self.against_normals += other.against_normals;
        self.unused_vertices += other.unused_vertices;
    }
}

fn plural(n: u64) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// A mesh read from a file, with what reading it had to repair.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedMesh {
    /// The triangles, valid for Embree.
    pub mesh: TriangleMesh,
    /// What was dropped or repaired.
    pub report: MeshReport,
}

/// Loads the mesh in `path`, choosing the format by extension (`.obj` or `.ply`).
/// Errors are messages that name the file.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, String> {
    load_mesh_with_report(path).map(|m| m.mesh)
}

/// Loads the mesh in `path` and reports what was dropped or repaired.
pub fn load_mesh_with_report(path: &Path) -> Result<LoadedMesh, String> {
    load_mesh_reporting(path, &|_| {})
}

/// [`load_mesh_with_report`], telling `read` the bytes of the file read so far, every
/// [`crate::util::input::REPORT_EVERY`].
pub fn load_mesh_reporting(path: &Path, read: &dyn Fn(u64)) -> Result<LoadedMesh, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let in_file = |e: String| format!("{}: {e}", path.display());
    let (mut mesh, mut report) = match ext.as_deref() {
        Some("obj") => obj::load(path, read),
        Some("ply") => ply::load(path, read),
        _ => Err("unsupported mesh format (expected a .obj or .ply file)".to_string()),
    }
    .map_err(in_file)?;
    repair::repair(&mut mesh, &mut report).map_err(in_file)?;
    if mesh.triangles.is_empty() {
        return Err(in_file(if report.degenerate_triangles > 0 {
            format!(
                "the mesh has no triangles: all {} are degenerate (zero area)",
                report.degenerate_triangles
            )
        } else {
            "the mesh has no triangles".to_string()
        }));
    }
    // The loaders and the repair make every mesh valid; Embree's own check stays the last word.
    mesh.validate().map_err(in_file)?;
    // Embree shares the buffers instead of copying them when the positions are padded.
    mesh.reserve_padding();
    Ok(LoadedMesh { mesh, report })
}

/// A new mesh buffer of room for `n` elements, through [`reserve::reserve_exact`]'s checks,
/// advised huge pages before anything is written to it ([`advise_huge_pages`]).
fn mesh_buffer<T>(n: usize, what: &str) -> Result<Vec<T>, String> {
    let mut v = Vec::new();
    reserve::reserve_exact(&mut v, n, what)?;
    advise_huge_pages(&mut v);
    Ok(v)
}

/// [`reserve::make_room`] for a mesh buffer (positions, normals, triangles): where it takes a
/// new allocation, that is advised huge pages before it is written further
/// ([`advise_huge_pages`]: Embree and hit completion read these buffers at random).
#[inline]
fn make_room_in_mesh<T>(v: &mut Vec<T>, more: usize, what: &str) -> Result<(), String> {
    let before = v.capacity();
    reserve::make_room(v, more, what)?;
    if v.capacity() != before {
        advise_huge_pages(v);
    }
    Ok(())
}

/// A token of a text mesh file as an error message shows it: its first 40 bytes, as text, with
/// control characters escaped (binary data read as text held NUL bytes, which made a log
/// binary to `grep`).
fn shown(token: &[u8]) -> String {
    String::from_utf8_lossy(&token[..token.len().min(40)])
        .chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}
