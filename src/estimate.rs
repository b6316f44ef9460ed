//! Radiance estimates from photon maps, behind one interface: every estimator answers the
//! radiance reflected towards the camera at a diffuse hit, given the hit's view footprint.

use crate::photon_map::PhotonMap;
use glam::{DVec3, Vec3};
use serde::Serialize;
use std::f64::consts::FRAC_1_PI;

/// A diffuse hit as the estimators see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GatherQuery {
    /// The hit point.
    pub position: DVec3,
    /// Unit geometric normal facing the viewer.
    pub normal: DVec3,
    /// Diffuse albedo (the BRDF is `albedo / pi`).
    pub albedo: DVec3,
    /// The camera ray's footprint at the hit: the parallelogram `x +- f[0]/2 +- f[1]/2`.
    pub footprint: [DVec3; 2],
}

/// What gathering cost, for the statistics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct GatherCounts {
    /// Estimates computed.
    pub gathers: u64,
    /// Photons returned by the map queries.
    pub photons_found: u64,
    /// Photons that contributed (inside their kernel's support, on the right side).
    pub photons_used: u64,
}

impl GatherCounts {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &GatherCounts) {
        self.gathers += other.gathers;
        self.photons_found += other.photons_found;
        self.photons_used += other.photons_used;
    }
}

/// A radiance estimate from a photon map.
pub trait RadianceEstimator: Sync {
    /// Radiance reflected towards the camera at `query`.
    fn radiance(&self, query: &GatherQuery, counts: &mut GatherCounts) -> DVec3;
}

/// Photons stored on a surface facing another way than the query's (the other side of a thin
/// wall, a sharp edge) do not contribute: the cosine between the normals must exceed this.
pub const MIN_NORMAL_COSINE: f32 = 0.7;

/// Whether photon normal `n_p` agrees with the query normal.
#[inline]
fn same_side(n_p: Vec3, n_x: Vec3) -> bool {
    n_p.dot(n_x) > MIN_NORMAL_COSINE
}

/// The regular estimate (Jensen): the `k` nearest photons within `max_radius`, an Epanechnikov
/// kernel normalised over the disc through the farthest of them (or of `max_radius` when fewer
/// than `k` are found). Photons farther than a tenth of the radius off the query's tangent
/// plane (a flattened sphere) or facing another way are left out.
pub struct JensenEstimate<'a> {
    /// The map.
    pub map: &'a PhotonMap,
    /// Number of nearest photons.
    pub k: usize,
    /// Largest gather radius.
    pub max_radius: f64,
}

impl RadianceEstimator for JensenEstimate<'_> {
    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        counts.gathers += 1;
        let mut found = Vec::with_capacity(self.k);
        self.map
            .nearest(q.position, self.k, self.max_radius, &mut found);
        counts.photons_found += found.len() as u64;
        if found.is_empty() {
            return DVec3::ZERO;
        }
        let r2 = if found.len() < self.k {
            (self.max_radius * self.max_radius) as f32
        } else {
            found[found.len() - 1].0.max(1e-12)
        };
        let x = q.position.as_vec3();
        let n = q.normal.as_vec3();
        let thickness = 0.1 * r2.sqrt();
        let mut sum = Vec3::ZERO;
        for &(d2, i) in &found {
            let p = &self.map.photons[i as usize];
            if !same_side(p.normal, n) || n.dot(p.position - x).abs() > thickness || d2 >= r2 {
                continue;
            }
            counts.photons_used += 1;
            sum += p.power * (1.0 - d2 / r2);
        }
        // (2 / pi) / r^2 normalises the kernel over the disc; albedo / pi is the BRDF.
        let kernel = std::f64::consts::FRAC_2_PI / r2 as f64;
        q.albedo * FRAC_1_PI * sum.as_dvec3() * kernel
    }
}

thread_local! {
    /// The photon indices of a gather, reused across gathers on one thread.
    static FOUND: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The photon-differential estimate (Schjoth et al.): every photon within the map's largest
/// footprint radius, each kernel evaluated in its own filter space,
/// `sum f_r Phi_p / A_p K(|M_p (x - x_p)|)`, Epanechnikov over the unit disc, so that each
/// photon contributes exactly its power when integrated over the surface.
pub struct PhotonDifferentialEstimate<'a> {
    /// The map.
    pub map: &'a PhotonMap,
}

/// Whether photon `p`, at offset `v = x - x_p` from a query of normal `n_x`, lies on the query's
/// surface: facing the same way, and off the photon's tangent plane by at most a tenth of its
/// radius. Shared by every footprint-based estimator.
#[inline]
pub fn on_query_surface(p: &crate::photon_map::Photon, v: Vec3, n_x: Vec3) -> bool {
    same_side(p.normal, n_x) && p.normal.dot(v).abs() <= 0.1 * p.radius
}

/// `Phi_p / A_p K(|M_p v|)` for a photon at offset `v = x - x_p`, or `None` outside its
/// support or on the wrong side.
#[inline]
pub fn photon_kernel(p: &crate::photon_map::Photon, v: Vec3, n_x: Vec3) -> Option<Vec3> {
    if !on_query_surface(p, v, n_x) {
        return None;
    }
    let s0 = p.m[0].dot(v);
    let s1 = p.m[1].dot(v);
    let r2 = s0 * s0 + s1 * s1;
    (r2 < 1.0).then(|| p.power * (p.inv_area * std::f32::consts::FRAC_2_PI * (1.0 - r2)))
}

impl RadianceEstimator for PhotonDifferentialEstimate<'_> {
    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        counts.gathers += 1;
        FOUND.with(|found| {
            let found = &mut *found.borrow_mut();
            self.map.reaching(q.position, 0.0, found);
            counts.photons_found += found.len() as u64;
            let x = q.position.as_vec3();
            let n = q.normal.as_vec3();
            let mut sum = Vec3::ZERO;
            for &i in found.iter() {
                let p = &self.map.photons[i as usize];
                if let Some(c) = photon_kernel(p, x - p.position, n) {
                    counts.photons_used += 1;
                    sum += c;
                }
            }
            q.albedo * FRAC_1_PI * sum.as_dvec3()
        })
    }
}
