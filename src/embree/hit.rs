//! What a query returns: the hit point, its normals and the shading normal's derivatives.

use glam::DVec3;

/// A ray-triangle hit, with the surface data the renderer needs for shading and for propagating
/// ray differentials.
///
/// Barycentrics follow Embree: the hit point is `p0 + u (p1 - p0) + v (p2 - p0)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (in units of the ray direction's length).
    pub t: f64,
    /// Index of the mesh (Embree geometry id, in the order the meshes were added).
    pub geom_id: u32,
    /// Index of the triangle within its mesh.
    pub prim_id: u32,
    /// Barycentric coordinate `u` (weight of the triangle's second vertex).
    pub u: f64,
    /// Barycentric coordinate `v` (weight of the triangle's third vertex).
    pub v: f64,
    /// The hit point, computed on the triangle from the barycentrics.
    pub position: DVec3,
    /// Unit geometric normal, `(p1 - p0) x (p2 - p0)` normalised (not flipped towards the ray).
    pub geometric_normal: DVec3,
    /// Unit interpolated shading normal (the geometric normal where the mesh has no normals),
    /// on the same side as the geometric normal.
    pub shading_normal: DVec3,
    /// Derivative of the unit shading normal with respect to `u`.
    pub dn_du: DVec3,
    /// Derivative of the unit shading normal with respect to `v`.
    pub dn_dv: DVec3,
    /// `dP/du = p1 - p0`.
    pub dp_du: DVec3,
    /// `dP/dv = p2 - p0`.
    pub dp_dv: DVec3,
}

impl Hit {
    /// Barycentric differentials `(du, dv)` of a position differential `dp` lying in the
    /// triangle's plane (the component along the normal is ignored).
    pub fn barycentric_differential(&self, dp: DVec3) -> (f64, f64) {
        let n = self.geometric_normal;
        let denom = self.dp_du.cross(self.dp_dv).dot(n);
        let du = dp.cross(self.dp_dv).dot(n) / denom;
        let dv = self.dp_du.cross(dp).dot(n) / denom;
        (du, dv)
    }

    /// Differential of the unit shading normal caused by a position differential `dp` on the
    /// surface: `dn = dn/du du + dn/dv dv`.
    pub fn normal_differential(&self, dp: DVec3) -> DVec3 {
        let (du, dv) = self.barycentric_differential(dp);
        self.dn_du * du + self.dn_dv * dv
    }
}
