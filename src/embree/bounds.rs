//! Coarse bounds of a scene's geometries in world space: a bounding sphere each, and the plane
//! of those that are flat. A caller screens work with them (`photons::walls` skips its probes
//! where no geometry that could stop them is near), so they must hold every triangle, and need
//! not be tight.

use super::scene::{Geometry, Scene};
use super::TriangleMesh;
use glam::{DMat3, DVec3};
use std::sync::Arc;

/// One geometry's bounds in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeometryBounds {
    /// Centre of a sphere holding every vertex.
    pub center: DVec3,
    /// Its radius.
    pub radius: f64,
    /// Unit normal of the plane holding every vertex (to a millionth of the geometry's
    /// size), where there is one: then every triangle's normal is parallel to it.
    pub plane_normal: Option<DVec3>,
}

impl Scene {
    /// The bounds of each geometry (meshes placed directly and instances), in geometry order.
    /// One pass over each distinct mesh's vertices; an instance transforms its mesh's bounds.
    pub fn geometry_bounds(&self) -> Vec<GeometryBounds> {
        let mut local: Vec<(*const TriangleMesh, GeometryBounds)> = Vec::new();
        self.geometries
            .iter()
            .map(|g: &Geometry| {
                let key = Arc::as_ptr(&g.mesh);
                let bounds = match local.iter().find(|(k, _)| *k == key) {
                    Some(&(_, b)) => b,
                    None => {
                        let b = mesh_bounds(&g.mesh);
                        local.push((key, b));
                        b
                    }
                };
                match g.placement() {
                    None => bounds,
                    Some((to_world, normal_matrix)) => {
                        transformed(&bounds, to_world, normal_matrix)
                    }
                }
            })
            .collect()
    }
}

/// A mesh's bounds in its own space: the sphere about its box's centre through its farthest
/// vertex, and its plane if every vertex lies on the plane of its first proper triangle.
fn mesh_bounds(mesh: &TriangleMesh) -> GeometryBounds {
    let wide = |v: &[f32; 3]| DVec3::new(v[0].into(), v[1].into(), v[2].into());
    let (lo, hi) = mesh
        .positions
        .iter()
        .map(wide)
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if mesh.positions.is_empty() {
        // Nothing to bound. (Every vertex is finite: `TriangleMesh::validate` saw to it.)
        return GeometryBounds {
            center: DVec3::ZERO,
            radius: 0.0,
            plane_normal: None,
        };
    }
    let center = 0.5 * (lo + hi);
    let radius = mesh
        .positions
        .iter()
        .map(|v| wide(v).distance(center))
        .fold(0.0, f64::max);
    let size = (hi - lo).length();
    let plane_normal = mesh
        .triangles
        .iter()
        .find_map(|t| {
            let [a, b, c] = t.map(|i| wide(&mesh.positions[i as usize]));
            let n = (b - a).cross(c - a);
            (n.length() > 1e-12 * size * size).then(|| (n.normalize(), a))
        })
        .and_then(|(n, a)| {
            let flat = mesh
                .positions
                .iter()
                .all(|v| n.dot(wide(v) - a).abs() <= 1e-6 * size);
            flat.then_some(n)
        });
    GeometryBounds {
        center,
        // Rounding of the f32 vertices' distances.
        radius: radius * (1.0 + 1e-9) + 1e-9 * size,
        plane_normal,
    }
}

/// `bounds` mapped by `x -> to_world(x)`: the sphere's centre mapped and its radius scaled by
/// the linear part's largest stretch (bounded by its Frobenius norm), the plane's normal by
/// the normal matrix.
fn transformed(
    bounds: &GeometryBounds,
    to_world: &glam::DAffine3,
    normal_matrix: &DMat3,
) -> GeometryBounds {
    let m = to_world.matrix3;
    let stretch =
        (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt();
    GeometryBounds {
        center: to_world.transform_point3(bounds.center),
        radius: bounds.radius * stretch,
        plane_normal: bounds
            .plane_normal
            .map(|n| (*normal_matrix * n).normalize())
            .filter(|n| n.is_finite()),
    }
}
