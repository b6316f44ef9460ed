//! Triangle meshes as Embree takes them, checked for what Embree would silently drop.

use glam::DVec3;

/// Vertex coordinates must be smaller than this in magnitude: Debian's Embree asserts on
/// coordinates past about 1.8e18, and a margin below that keeps its bounds arithmetic finite.
pub const MAX_COORDINATE: f32 = 1.0e18;

/// A triangle mesh as Embree takes it: vertex positions, optional per-vertex normals (for
/// interpolated shading normals) and triangles as vertex index triples.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Per-vertex normals (same length as `positions`), or `None` for flat shading.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Triangles, counter-clockwise seen from the side the geometric normal points to.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Makes sure `positions` has one element of spare capacity, zeroed: Embree reads 4 bytes
    /// past the last vertex, and a mesh with this padding is shared with Embree without a copy
    /// (see [`crate::embree::SceneBuilder::add_mesh`]). Loaders that know the vertex count
    /// allocate it upfront.
    pub fn reserve_padding(&mut self) {
        self.positions.reserve(1);
        self.positions.spare_capacity_mut()[0].write([0.0; 3]);
    }

    /// Bytes of the mesh's data: 12 per position, per normal and per triangle (three 32-bit
    /// indices). The PLY loader reserves exactly this (plus the padding position); the OBJ
    /// loader's buffers grow as it reads and may hold up to twice as much.
    pub fn bytes(&self) -> u64 {
        let normals = self.normals.as_ref().map_or(0, Vec::len);
        12 * (self.positions.len() + normals + self.triangles.len()) as u64
    }

    /// Checks what Embree would otherwise silently drop or mis-handle: non-finite or huge
    /// vertices, out-of-range indices, zero-area triangles, mismatched or zero normals.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |p: &[f32; 3]| p.iter().all(|c| c.is_finite() && c.abs() < MAX_COORDINATE);
        // Embree drops such vertices' triangles silently, and a huge one trips its assertions.
        if let Some(i) = self.positions.iter().position(|p| !finite(p)) {
            let p = self.positions[i];
            return Err(if p.iter().all(|c| c.is_finite()) {
                format!(
                    "vertex {i} lies beyond the coordinates Embree takes (|x| < {MAX_COORDINATE:e}): {p:?}"
                )
            } else {
                format!("vertex {i} is not finite: {p:?}")
            });
        }
        if self.positions.len() >= u32::MAX as usize {
            return Err("too many vertices".into());
        }
        if let Some(normals) = &self.normals {
            if normals.len() != self.positions.len() {
                return Err(format!(
                    "{} normals for {} vertices",
                    normals.len(),
                    self.positions.len()
                ));
            }
            if let Some(i) = normals
                .iter()
                .position(|n| !finite(n) || n.iter().all(|c| *c == 0.0))
            {
                return Err(format!(
                    "normal {i} is zero or not finite: {:?}",
                    normals[i]
                ));
            }
        }
        let n = self.positions.len() as u32;
        for (i, tri) in self.triangles.iter().enumerate() {
            if let Some(bad) = tri.iter().find(|&&index| index >= n) {
                return Err(format!(
                    "triangle {i} uses vertex {bad}, but the mesh has {n} vertices"
                ));
            }
            let [a, b, c] = tri.map(|k| DVec3::from(self.positions[k as usize].map(f64::from)));
            let area2 = (b - a).cross(c - a).length();
            let scale = (b - a).length().max((c - a).length()).max(1e-30);
            if area2.is_nan() || area2 <= 1e-12 * scale * scale {
                return Err(format!(
                    "triangle {i} is degenerate (zero area): {:?} {:?} {:?}",
                    // As stored (single precision), without the digits of widening them.
                    self.positions[tri[0] as usize],
                    self.positions[tri[1] as usize],
                    self.positions[tri[2] as usize]
                ));
            }
        }
        Ok(())
    }
}
