//! The photon-differential estimate (Schjoth et al. 2007): each photon's kernel in its own
//! filter space, at the single point the camera ray hits.

use super::{photon_kernel, GatherCounts, GatherQuery, RadianceEstimator};
use crate::photons::map::{FootprintQuery, PhotonMap};
use glam::{DVec3, Vec3};
use std::f64::consts::FRAC_1_PI;

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

impl RadianceEstimator for PhotonDifferentialEstimate<'_> {
    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        counts.gathers += 1;
        FOUND.with(|found| {
            let found = &mut *found.borrow_mut();
            let point = FootprintQuery {
                x: q.position,
                footprint: [DVec3::ZERO; 2],
                normal: q.normal,
            };
            self.map.covering(&point, found);
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
