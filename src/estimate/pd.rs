//! The photon-differential estimate (Schjoth et al. 2007): each photon's kernel in its own
//! filter space, at the single point the camera ray hits.

use super::{batch_of_one, kernel, GatherCounts, GatherQuery, RadianceEstimator};
use crate::photons::cover::InFilterSpace;
use crate::photons::map::{FootprintQuery, PacketSearch, PhotonMap};
use glam::{DVec3, Vec3};
use std::cell::RefCell;
use std::f64::consts::FRAC_1_PI;

thread_local! {
    /// A packet's points and the photons found for them, with the point in their filter
    /// spaces; reused across packets on one thread.
    static SEARCH: RefCell<PacketSearch<InFilterSpace>> = RefCell::new(PacketSearch::default());
}

/// The photon-differential estimate (Schjoth et al.): every photon whose footprint holds the
/// point (the map's footprint BVH finds them, a packet of points at a time), each kernel
/// evaluated in its own filter space,
/// `sum f_r Phi_p / A_p K(|M_p (x - x_p)|)`, Epanechnikov over the unit disc, so that each
/// photon contributes exactly its power when integrated over the surface.
pub struct PhotonDifferentialEstimate<'a> {
    /// The map.
    pub map: &'a PhotonMap,
}

impl RadianceEstimator for PhotonDifferentialEstimate<'_> {
    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        batch_of_one(self, q, counts)
    }

    /// The packet's points go through the map together ([`PhotonMap::covering_packet`]); each
    /// photon found comes with the point in its filter space, `u = M_p (x - x_p)`, as
    /// [`super::photon_kernel`] computes it, and only if it lies on the query's surface, so the
    /// kernel `Phi_p / A_p (2 / pi) (1 - |u|^2)` needs only the photon's flux.
    fn radiance_batch(
        &self,
        queries: &[GatherQuery],
        _shares: &[f64],
        out: &mut [DVec3],
        counts: &mut GatherCounts,
    ) {
        SEARCH.with(|search| {
            let mut search = search.borrow_mut();
            let points = queries
                .iter()
                .map(|q| FootprintQuery::new(q.position, [DVec3::ZERO; 2], q.normal));
            let found = search.run(self.map, points);
            for ((q, found), o) in queries.iter().zip(found).zip(out) {
                counts.gathers += 1;
                counts.photons_found += found.len() as u64;
                let mut sum = Vec3::ZERO;
                for &InFilterSpace { slot, s, .. } in found {
                    let r2 = s.x * s.x + s.y * s.y;
                    if let Some(k) = kernel(&self.map.flux[slot as usize], r2) {
                        counts.photons_used += 1;
                        sum += k;
                    }
                }
                *o = q.albedo * FRAC_1_PI * sum.as_dvec3();
            }
        })
    }
}
