//! Writing binary PLY, for generated assets (benchmarks, large test scenes): the layout most
//! tools write, `float x y z [nx ny nz]` and `list uchar int vertex_indices`, little endian.

use crate::embree::TriangleMesh;
use std::io::{self, Write};

/// Writes `mesh` as binary little-endian PLY to `out` (buffer it: writes are per element).
pub fn write_binary(mesh: &TriangleMesh, mut out: impl Write) -> io::Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by photondiff\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        mesh.positions.len()
    );
    if mesh.normals.is_some() {
        header += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    header += &format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.triangles.len()
    );
    out.write_all(header.as_bytes())?;
    let mut record = Vec::with_capacity(24);
    for (i, p) in mesh.positions.iter().enumerate() {
        record.clear();
        let normal = mesh.normals.as_ref().map(|n| n[i]);
        for c in p.iter().chain(normal.iter().flatten()) {
            record.extend_from_slice(&c.to_le_bytes());
        }
        out.write_all(&record)?;
    }
    for t in &mesh.triangles {
        record.clear();
        record.push(3);
        for k in t {
            record.extend_from_slice(&(*k as i32).to_le_bytes());
        }
        out.write_all(&record)?;
    }
    out.flush()
}
