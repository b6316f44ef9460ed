//! Analytic shapes tessellated into triangle meshes at load time.

use crate::embree::{advise_huge_pages, TriangleMesh};
use glam::DVec3;

/// Default number of segments around a sphere's equator. With 512 x 256 the glass sphere's
/// interpolated normals deviate from the true normals by far less than a photon footprint, so
/// the tessellated sphere's caustic matches an analytic sphere's.
pub const DEFAULT_SPHERE_SEGMENTS: u32 = 512;

fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The parallelogram `corner + s edge_u + t edge_v` as two triangles, facing `edge_u x edge_v`.
pub fn quad(corner: DVec3, edge_u: DVec3, edge_v: DVec3) -> TriangleMesh {
    let positions = [
        corner,
        corner + edge_u,
        corner + edge_u + edge_v,
        corner + edge_v,
    ]
    .map(f32x3)
    .to_vec();
    TriangleMesh {
        positions,
        normals: None,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// The triangles of a sphere of `segments` (at least 3): `segments` around each of
/// `segments / 2` rings, two per quadrilateral but one at each pole.
pub fn sphere_triangles(segments: u32) -> u64 {
    let (s, rings) = (segments.max(3) as u64, (segments.max(3) / 2).max(2) as u64);
    2 * s * (rings - 1)
}

/// The bytes of a sphere's mesh buffers: 12 a position, 12 a normal, 12 a triangle.
pub fn sphere_bytes(segments: u32) -> u64 {
    let (s, rings) = (segments.max(3) as u64, (segments.max(3) / 2).max(2) as u64);
    let vertices = 2 + s * (rings - 1);
    24 * vertices + 12 * sphere_triangles(segments)
}

/// A sphere as a UV mesh with exact per-vertex normals (for interpolated shading normals),
/// `segments` around (>= 3) and `segments / 2` rings from pole to pole, with triangle fans at
/// the poles so that no triangle is degenerate. Triangles face outwards.
pub fn sphere(center: DVec3, radius: f64, segments: u32) -> TriangleMesh {
    let segments = segments.max(3);
    let rings = (segments / 2).max(2);
    let vertices = 2 + (rings - 1) as usize * segments as usize;
    // Reserved whole (one more position: Embree's padding) and advised huge pages before
    // they are written: a sphere of thousands of segments is a large mesh.
    let mut positions = Vec::with_capacity(vertices + 1);
    let mut normals = Vec::with_capacity(vertices);
    let mut triangles = Vec::with_capacity(sphere_triangles(segments) as usize);
    advise_huge_pages(&mut positions);
    advise_huge_pages(&mut normals);
    advise_huge_pages(&mut triangles);
    let mut push = |n: DVec3| {
        positions.push(f32x3(center + n * radius));
        normals.push(f32x3(n));
    };
    push(DVec3::Y); // north pole: vertex 0
    for ring in 1..rings {
        let theta = std::f64::consts::PI * ring as f64 / rings as f64;
        for s in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * s as f64 / segments as f64;
            push(DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
        }
    }
    push(-DVec3::Y); // south pole
    let south = 1 + (rings - 1) * segments;
    let at = |ring: u32, s: u32| 1 + (ring - 1) * segments + (s % segments);
    for s in 0..segments {
        triangles.push([0, at(1, s), at(1, s + 1)]);
        for ring in 1..rings - 1 {
            let (a, b) = (at(ring, s), at(ring, s + 1));
            let (c, d) = (at(ring + 1, s), at(ring + 1, s + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
        triangles.push([at(rings - 1, s), south, at(rings - 1, s + 1)]);
    }
    TriangleMesh {
        positions,
        normals: Some(normals),
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_is_valid_and_faces_outwards() {
        let center = DVec3::new(0.0, 1.0, 0.0);
        let mesh = sphere(center, 2.0, 16);
        mesh.validate().unwrap();
        for tri in &mesh.triangles {
            let [a, b, c] = tri.map(|k| DVec3::from(mesh.positions[k as usize].map(f64::from)));
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0 - center) > 0.0, "{tri:?}");
        }
    }

    #[test]
    fn sphere_counts_are_those_of_the_mesh() {
        for segments in [3, 4, 7, 16, 513] {
            let mesh = sphere(DVec3::ZERO, 1.0, segments);
            assert_eq!(mesh.triangles.len() as u64, sphere_triangles(segments));
            assert_eq!(
                sphere_bytes(segments),
                24 * mesh.positions.len() as u64 + 12 * mesh.triangles.len() as u64
            );
        }
    }

    #[test]
    fn quad_faces_edge_cross_product() {
        let mesh = quad(DVec3::ZERO, DVec3::X, DVec3::NEG_Z);
        for tri in &mesh.triangles {
            let [a, b, c] = tri.map(|k| DVec3::from(mesh.positions[k as usize].map(f64::from)));
            assert!((b - a)
                .cross(c - a)
                .normalize()
                .abs_diff_eq(DVec3::Y, 1e-12));
        }
    }
}
