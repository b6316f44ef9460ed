//! The regular photon-map estimate (Jensen): the k nearest photons, a normalised kernel.

use super::{same_side, GatherCounts, GatherQuery, RadianceEstimator};
use crate::photons::map::{k_nearest_radius2, PhotonMap};
use glam::{DVec3, Vec3};
use std::f64::consts::FRAC_1_PI;

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
        let kth2 = found[found.len() - 1].0;
        let r2 = k_nearest_radius2(found.len(), self.k, kth2, self.max_radius);
        let x = q.position.as_vec3();
        let n = q.normal.as_vec3();
        let thickness = 0.1 * r2.sqrt();
        let mut sum = Vec3::ZERO;
        for &(d2, i) in &found {
            let i = i as usize;
            let ((normal, _), (position, _)) = (self.map.surface(i), self.map.filter_frame(i));
            if !same_side(normal, n) || n.dot(position - x).abs() > thickness || d2 >= r2 {
                continue;
            }
            counts.photons_used += 1;
            sum += self.map.flux[i].power * (1.0 - d2 / r2);
        }
        // (2 / pi) / r^2 normalises the kernel over the disc; albedo / pi is the BRDF.
        let kernel = std::f64::consts::FRAC_2_PI / r2 as f64;
        q.albedo * FRAC_1_PI * sum.as_dvec3() * kernel
    }
}
