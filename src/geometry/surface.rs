//! The local surface at a hit, oriented against the incoming ray, as the differential formulas
//! need it. Shared by camera paths and photon paths.

use crate::embree::{Hit, Ray};
use crate::geometry::differential::{RayDifferential, SurfaceFrame};
use glam::DVec3;

/// The normal facing the incoming direction `d`, given a normal of either orientation.
pub fn facing(n: DVec3, d: DVec3) -> DVec3 {
    if n.dot(d) > 0.0 {
        -n
    } else {
        n
    }
}

/// The surface at `hit` for a ray differential `at` already transferred to it: the shading
/// frame (normal facing the ray, and its differentials from the barycentric derivatives) and
/// the geometric normal facing the ray. Where the shading normal faces away from the ray (an
/// artefact of interpolated normals at silhouettes) the flat geometric frame is used.
pub fn surface_frame(hit: &Hit, at: &RayDifferential) -> (SurfaceFrame, DVec3) {
    let d = at.d;
    let ng = facing(hit.geometric_normal, d);
    let side = if ng == hit.geometric_normal {
        1.0
    } else {
        -1.0
    };
    let ns = hit.shading_normal * side;
    let frame = if ns.dot(d) < 0.0 {
        SurfaceFrame {
            n: ns,
            dn: {
                let [a, b] = hit.normal_differentials(at.dp);
                [a * side, b * side]
            },
        }
    } else {
        SurfaceFrame {
            n: ng,
            dn: [DVec3::ZERO; 2],
        }
    };
    (frame, ng)
}

/// Transfers `ray` to `hit`. The query ray started a little off the surface the differential
/// left, so the distance is measured from the differential's own origin, and the new origin is
/// the hit point itself (exactly on the surface).
pub fn transfer_to(ray: &RayDifferential, hit: &Hit) -> RayDifferential {
    let mut at = ray.transfer((hit.position - ray.p).dot(ray.d), hit.geometric_normal);
    at.p = hit.position;
    at
}

/// The query ray that continues `ray` from the surface it is leaving. It starts exactly at the
/// differential's origin and skips the first `epsilon` of its length, rather than starting off
/// the surface: the traced ray is then exactly the one the differential describes, which
/// matters near caustic focal points where a shifted ray lands measurably elsewhere.
pub fn continuation(ray: &RayDifferential, epsilon: f64) -> Ray {
    Ray {
        origin: ray.p,
        direction: ray.d,
        tnear: epsilon,
        tfar: f64::INFINITY,
    }
}
