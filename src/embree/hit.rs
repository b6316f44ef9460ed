//! What a query returns: the hit point, its normals and the shading normal's derivatives.

use super::ffi;
use super::ray::Ray;
use super::scene::Scene;
use glam::DVec3;

/// A ray-triangle hit, with the surface data the renderer needs for shading and for propagating
/// ray differentials.
///
/// Barycentrics follow Embree: the hit point is `p0 + u (p1 - p0) + v (p2 - p0)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (in units of the ray direction's length).
    pub t: f64,
    /// Index of the mesh or instance (Embree's top-level geometry id, in the order they were
    /// added).
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

    /// [`Hit::normal_differential`] of both position differentials of a ray differential.
    /// Flat triangles (no vertex normals) have none, without the arithmetic.
    pub fn normal_differentials(&self, dp: [DVec3; 2]) -> [DVec3; 2] {
        if self.dn_du == DVec3::ZERO && self.dn_dv == DVec3::ZERO {
            return [DVec3::ZERO; 2];
        }
        [
            self.normal_differential(dp[0]),
            self.normal_differential(dp[1]),
        ]
    }
}

impl Scene {
    /// Completes a hit from Embree's ids, barycentrics and distance with this layer's mesh data.
    /// `inst_id` is Embree's `instID[0]` (the instance geometry hit, or invalid for a mesh
    /// placed directly); the hit's `geom_id` is the top-level geometry either way.
    ///
    /// Embree answers in single precision: on a large triangle its barycentrics place the hit
    /// only to within ~1e-7 of the triangle's size, too coarse for differentials and finite
    /// differences. The hit is therefore refined in double precision against the triangle's
    /// plane in world space (Embree's answer is kept where the ray is parallel to the plane).
    /// An instance's triangle is mapped to world space first: barycentrics survive affine maps,
    /// so positions, their derivatives and the normals (mapped by the inverse transpose) come
    /// out in world space, and so do the differentials built from them.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn make_hit(
        &self,
        ray: &Ray,
        geom_id: u32,
        inst_id: u32,
        prim_id: u32,
        u: f32,
        v: f32,
        t: f32,
    ) -> Hit {
        let geom_id = top_level(geom_id, inst_id);
        let geometry = &self.geometries[geom_id as usize];
        let (u, v) = geometry.barycentrics(u, v);
        complete_hit(
            ray,
            geom_id,
            prim_id,
            u,
            v,
            t,
            geometry.world_triangle(prim_id),
        )
    }
}

/// The geometry a hit belongs to in this layer's numbering: the instance if there is one.
pub(super) fn top_level(geom_id: u32, inst_id: u32) -> u32 {
    if inst_id != ffi::INVALID_GEOMETRY_ID {
        inst_id
    } else {
        geom_id
    }
}

/// [`Scene::make_hit`] once the triangle's world-space vertices and normals are fetched (a
/// packet fetches them for all its lanes first, so that their cache misses overlap).
pub(super) fn complete_hit(
    ray: &Ray,
    geom_id: u32,
    prim_id: u32,
    u: f32,
    v: f32,
    t: f32,
    ([p0, p1, p2], normals): ([DVec3; 3], Option<[DVec3; 3]>),
) -> Hit {
    let dp_du = p1 - p0;
    let dp_dv = p2 - p0;
    let cross = dp_du.cross(dp_dv);
    let geometric_normal = cross.normalize();
    let (mut u, mut v, mut t) = (u as f64, v as f64, t as f64);
    let denom = ray.direction.dot(cross);
    if denom.abs() > 1e-12 * ray.direction.length() * cross.length() {
        let t64 = (p0 - ray.origin).dot(cross) / denom;
        let w = ray.origin + ray.direction * t64 - p0;
        let area = cross.length_squared();
        let u64 = w.cross(dp_dv).dot(cross) / area;
        let v64 = dp_du.cross(w).dot(cross) / area;
        if t64.is_finite() && u64.is_finite() && v64.is_finite() {
            // Stay on the triangle Embree found (rounding can step just outside it).
            u = u64.clamp(0.0, 1.0);
            v = v64.clamp(0.0, 1.0 - u);
            t = t64;
        }
    }
    let (shading_normal, dn_du, dn_dv) = match normals {
        None => (geometric_normal, DVec3::ZERO, DVec3::ZERO),
        Some([n0, n1, n2]) => {
            let unnormalised = n0 * (1.0 - u - v) + n1 * u + n2 * v;
            let length = unnormalised.length();
            let n = unnormalised / length;
            // d(N/|N|) = (dN - (dN . n) n) / |N|
            let project = |dn: DVec3| (dn - n * dn.dot(n)) / length;
            let n = if n.dot(geometric_normal) < 0.0 { -n } else { n };
            let sign = if unnormalised.dot(geometric_normal) < 0.0 {
                -1.0
            } else {
                1.0
            };
            (n, sign * project(n1 - n0), sign * project(n2 - n0))
        }
    };
    Hit {
        t,
        geom_id,
        prim_id,
        u,
        v,
        position: p0 + dp_du * u + dp_dv * v,
        geometric_normal,
        shading_normal,
        dn_du,
        dn_dv,
        dp_du,
        dp_dv,
    }
}
