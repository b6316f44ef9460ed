//! The footprint-integrated photon-differential estimate: each photon's kernel averaged over the
//! pixel's whole view footprint exactly, the limit of the multi-sampled estimate as its N x N
//! grid grows.
//!
//! Averaging photon `p`'s kernel over the view footprint `V` (the parallelogram
//! `x +- f0/2 +- f1/2`) and changing variables to its filter space `u = M_p (y - x_p)` gives the
//! mean of `K(|u|)` over `V' = M_p (V - x_p)`, the parallelogram of centre `s = M_p (x - x_p)`
//! and edge vectors `a = M_p f0`, `b = M_p f1`:
//!
//! `L = f_r * sum_p Phi_p / A_p * (integral over V' ∩ D of K) / area(V')`
//!
//! with `K = (2/pi)(1 - r^2)` on the unit disc `D`. The integral has a closed form
//! ([`crate::geometry::disc_integral`], with its derivation): most photons are settled there by
//! a closed form of their own (the parallelogram inside the disc, the disc inside the
//! parallelogram, apart); the rest, whose parallelogram crosses the circle, go through the
//! general formula in `f64`, [`LANES`] photons at a time in SIMD lanes ([`parallelogram_means`]).
//!
//! Where the query carries its exact view footprint ([`GatherQuery::exact`]: the pixel's corner
//! rays on the tangent plane of a hit seen directly), `V` is that quadrilateral instead of the
//! first-order parallelogram, integrated by the same flux formula
//! ([`crate::geometry::disc_integral::quad`]): neighbouring pixels' quadrilaterals tile the
//! plane, so light concentrated on a pixel boundary is counted once.
//!
//! That exact footprint also carries the image area each of its parts stands for
//! ([`super::ExactFootprint::seen_from`]: a pixel is a box on the image, and a perspective view
//! maps it onto the surface with a Jacobian varying by a few percent across it), linear over
//! the footprint: each photon's mean is taken with that weight, read at the kernel's centroid
//! in the footprint or, across the circle, integrated with the kernel in the general formula's
//! batch ([`crate::geometry::disc_integral::moment`]).
//!
//! A vanishing view footprint gives the kernel at the centre: the photon-differential estimate
//! (`pd`). The gather asks the map for every photon whose footprint may overlap `V`
//! ([`PhotonMap::covering`]), as the multi-sampled estimate does.

use super::{batch_of_one, ExactFootprint, GatherCounts, GatherQuery, RadianceEstimator};
use crate::geometry::disc_integral::general_lanes::{classify_parallelograms, Placements};
use crate::geometry::disc_integral::quad::{quad_means, QuadBatch, QuadOverlap};
use crate::geometry::disc_integral::rows::{Rows, Wide};
use crate::geometry::disc_integral::{
    classify, general, general_either, general_one_arc, takes_one_arc, Overlap,
};
use crate::photons::cover::OnSurface;
use crate::photons::map::{Flux, FootprintQuery, PacketSearch, PhotonMap};
use glam::{DVec2, DVec3, Vec3};
use std::cell::RefCell;
use std::f64::consts::{FRAC_1_PI, FRAC_2_PI};

/// SIMD width of the general formula's batch.
pub use crate::geometry::disc_integral::rows::LANES;

/// Parallelograms in filter space for the general formula: rows `(s, a, b)`.
pub type ParallelogramBatch = Rows<6>;

impl Rows<6> {
    /// Adds the parallelogram of centre `s` and edge vectors `a`, `b` (non-zero area).
    pub fn push(&mut self, s: DVec2, a: DVec2, b: DVec2) {
        self.push_row([s.x, s.y, a.x, a.y, b.x, b.y]);
    }
}

/// For each parallelogram of `batch`, the mean of `(1 - |u|^2)+` over it by the general formula
/// ([`general_one_arc`], or [`general`] where a lane's parallelogram is too large for it),
/// [`LANES`] at a time in SIMD lanes ([`Wide`]). `out` gets one mean per parallelogram.
pub fn parallelogram_means(batch: &mut ParallelogramBatch, out: &mut Vec<f64>) {
    out.clear();
    let len = batch.len();
    // Padding: unit squares far from the disc.
    for [s0, s1, a0, a1, b0, b1] in batch.chunks([1e6, 0.0, 1.0, 0.0, 0.0, 1.0]) {
        // One atan2 a lane, or four where a parallelogram is too large for that.
        let one_arc = takes_one_arc(a0, a1, b0, b1).simd_ge(Wide::ZERO);
        let (integral, area) = if one_arc.all() {
            general_one_arc(s0, s1, a0, a1, b0, b1)
        } else {
            general(s0, s1, a0, a1, b0, b1)
        };
        out.extend_from_slice(&(integral / area).max(Wide::ZERO).to_array());
    }
    out.truncate(len);
}

/// The scalar version of [`parallelogram_means`], for comparison in benchmarks and tests.
pub fn parallelogram_means_scalar(batch: &ParallelogramBatch, out: &mut Vec<f64>) {
    out.clear();
    for k in 0..batch.len() {
        let [s0, s1, a0, a1, b0, b1] = batch.row(k);
        let (integral, area) =
            general_either(DVec2::new(s0, s1), DVec2::new(a0, a1), DVec2::new(b0, b1));
        out.push((integral / area).max(0.0));
    }
}

/// The map's request for query `q`: its parallelogram, grown to hold its exact footprint (the
/// corners as offsets from the query point) where it has one.
#[inline]
fn request(q: &GatherQuery) -> FootprintQuery {
    // Component by component (a growth of 1 where there is none changes nothing): built
    // through `array::map` and a `match`, the request went through the stack in pieces and
    // was read back whole, a stalled load a query (2% of the render stage).
    let g = q.exact.as_ref().map_or(1.0, |e| e.grow);
    let [f0, f1] = q.footprint;
    FootprintQuery::new(q.position, [f0 * g, f1 * g], q.normal)
}

/// Scratch space reused across gathers on one thread.
#[derive(Default)]
struct Scratch {
    /// Each query's [`request`], and the photons found for it.
    search: PacketSearch<OnSurface>,
    /// The parallelograms of `batch`: (query, photon's flux) each. The flux is read when the
    /// photon joins the batch, amid the gather's arithmetic, rather than after the batch, where
    /// each read waited on memory for a large map.
    general: Vec<(u32, Flux)>,
    batch: ParallelogramBatch,
    means: Vec<f64>,
    /// The quadrilaterals of `quads`: (query, photon's flux) each.
    general_quads: Vec<(u32, Flux)>,
    quads: QuadBatch,
    quad_means: Vec<f64>,
    /// Per query of a batch, the sum of `Phi / A * mean` over its photons.
    totals: Vec<Vec3>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// The footprint-integrated estimate over one photon map.
pub struct IntegratedEstimate<'a> {
    /// The map.
    pub map: &'a PhotonMap,
}

impl IntegratedEstimate<'_> {
    /// Gathers query `q` (number `j` of its batch) over the photons `found` for it
    /// ([`request`]): the photons settled in closed form are summed and returned; those that need
    /// the general formula join the scratch's batches, owned by `j`.
    fn gather(
        &self,
        q: &GatherQuery,
        j: u32,
        found: &[OnSurface],
        scratch: &mut Scratch,
        counts: &mut GatherCounts,
    ) -> Vec3 {
        counts.gathers += 1;
        let f = if q.footprint[0].is_finite() && q.footprint[1].is_finite() {
            q.footprint
        } else {
            [DVec3::ZERO; 2]
        };
        let exact = q.exact.as_ref();
        counts.exact_footprints += u64::from(exact.is_some());
        counts.photons_found += found.len() as u64;
        let mut total = Vec3::ZERO;
        // Found on the query's surface (the cover test made `on_query_surface`'s test), a
        // chunk of lanes at a time: the tests that send a photon to the general formula run
        // in SIMD lanes ([`general_lanes`]), and only the others go through the scalar
        // classification (in the order found either way, so the sums are a lone gather's).
        for chunk in found.chunks(LANES) {
            let lanes = self.placements(q.position, &f, chunk);
            // Each lane's numbers for the scalar steps (lanes past the chunk are padding,
            // never read).
            let columns = |c: [Wide; 2]| c.map(Wide::to_array);
            let (sc, ac, bc) = (columns(lanes.s), columns(lanes.a), columns(lanes.b));
            let at = |c: &[[f64; LANES]; 2], k: usize| DVec2::new(c[0][k], c[1][k]);
            let s: [DVec2; LANES] = std::array::from_fn(|k| at(&sc, k));
            let a: [DVec2; LANES] = std::array::from_fn(|k| at(&ac, k));
            let b: [DVec2; LANES] = std::array::from_fn(|k| at(&bc, k));
            match exact {
                Some(e) => {
                    let general = e.frame.general_lanes(&lanes);
                    let weights = e.weights_in_filter_space(&lanes);
                    for (k, &OnSurface(i)) in chunk.iter().enumerate() {
                        if general.mask >> k & 1 == 1 {
                            let weight = weights.map(|column| column[k]);
                            scratch.quads.push_weighted(general.lane(k), weight);
                            scratch.general_quads.push((j, self.map.flux[i as usize]));
                            continue;
                        }
                        // Settled in the lanes as `settle` would settle them, else by it.
                        let overlap = if general.disc_inside >> k & 1 == 1 {
                            Overlap::Mean(general.means[k] * weights[0][k])
                        } else if general.inside >> k & 1 == 1 {
                            Overlap::Mean(e.weighted_inside(s[k], a[k], b[k], general.means[k]))
                        } else {
                            self.settle(e, (s[k], a[k], b[k]), i, j, scratch)
                        };
                        total += self.closed_form(overlap, i, j, scratch, counts);
                    }
                }
                None => {
                    let settled = classify_parallelograms(&lanes);
                    for (k, &OnSurface(i)) in chunk.iter().enumerate() {
                        let overlap = if settled.general >> k & 1 == 1 {
                            Overlap::General {
                                s: s[k],
                                a: a[k],
                                b: b[k],
                            }
                        } else if settled.settled >> k & 1 == 1 {
                            Overlap::Mean(settled.means[k])
                        } else {
                            classify(s[k], a[k], b[k])
                        };
                        total += self.closed_form(overlap, i, j, scratch, counts);
                    }
                }
            }
        }
        total
    }

    /// The view footprint `x +- f[0]/2 +- f[1]/2` in the filter spaces of the photons in
    /// `chunk` (at most [`LANES`]), a lane each: `s = M (x - x_p)`, `a = M f[0]`, `b = M f[1]`.
    ///
    /// In double precision from the query's own (not f32-rounded) point and footprint: the
    /// filter map scales a pixel by its size over the photon's, so a photon far smaller than
    /// the pixel (a focus) would see f32's rounding of them magnified; so it is placed to
    /// within its stored position's rounding, and footprints sharing a corner split it
    /// exactly. Each photon's position and filter rows come from the cover test's table,
    /// which the test has just read for it; the products are `glam`'s `dot`, in its order.
    #[inline(always)]
    fn placements(&self, x: DVec3, f: &[DVec3; 2], chunk: &[OnSurface]) -> Placements {
        // Position, then the filter rows: nine columns.
        let mut columns = [[0.0; LANES]; 9];
        for (k, &OnSurface(i)) in chunk.iter().enumerate() {
            let (position, [m0, m1]) = self.map.filter_frame(i as usize);
            for (c, v) in [position, m0, m1]
                .iter()
                .flat_map(|v| v.to_array())
                .enumerate()
            {
                columns[c][k] = f64::from(v);
            }
        }
        let [px, py, pz, m00, m01, m02, m10, m11, m12] = columns.map(Wide::from);
        let dot = |m: [Wide; 3], v: [Wide; 3]| m[0] * v[0] + m[1] * v[1] + m[2] * v[2];
        let splat = |v: DVec3| v.to_array().map(Wide::splat);
        let (m0, m1) = ([m00, m01, m02], [m10, m11, m12]);
        let [xx, xy, xz] = splat(x);
        let v = [xx - px, xy - py, xz - pz];
        let filter = |w: [Wide; 3]| [dot(m0, w), dot(m1, w)];
        Placements {
            s: filter(v),
            a: filter(splat(f[0])),
            b: filter(splat(f[1])),
        }
    }

    /// What the scalar classification settles for a photon (slot `i`) placed at `(s, a, b)`
    /// against the exact footprint `e`, for query `j`: `Overlap::None` where the general
    /// formula's batch has taken the photon (a general quadrilateral).
    #[inline(always)]
    fn settle(
        &self,
        e: &ExactFootprint,
        (s, a, b): (DVec2, DVec2, DVec2),
        i: u32,
        j: u32,
        scratch: &mut Scratch,
    ) -> Overlap {
        match e.frame.classify(s, a, b) {
            QuadOverlap::None => Overlap::None,
            // The quadrilateral inside the disc (or a point to it): weighted at the kernel's
            // centroid over it.
            QuadOverlap::Mean(mean) => Overlap::Mean(e.weighted_inside(s, a, b, mean)),
            // The kernel's mass lies about the photon: the image-area weight at its centre
            // (exact for a weight linear over the footprint).
            QuadOverlap::DiscInside(mean) => {
                Overlap::Mean(mean * e.weight_in_filter_space(s, a, b)[0])
            }
            // The weight, linear over the footprint, integrated with the kernel by the
            // general formula's batch (its integral and first moment).
            QuadOverlap::General(vertices) => {
                let k = e.weight_in_filter_space(s, a, b);
                scratch.quads.push_weighted(vertices, k);
                scratch.general_quads.push((j, self.map.flux[i as usize]));
                Overlap::None
            }
            // Too thin or folded: the parallelogram.
            QuadOverlap::NotConvex => classify(s, a, b),
        }
    }

    /// Photon `i`'s contribution where `overlap` is a closed form; a general parallelogram
    /// joins the batch (for query `j`) and contributes later.
    #[inline(always)]
    fn closed_form(
        &self,
        overlap: Overlap,
        i: u32,
        j: u32,
        scratch: &mut Scratch,
        counts: &mut GatherCounts,
    ) -> Vec3 {
        match overlap {
            Overlap::None => Vec3::ZERO,
            Overlap::Mean(mean) => {
                if mean > 0.0 {
                    counts.photons_used += 1;
                    let p = &self.map.flux[i as usize];
                    p.power * (p.inv_area * mean as f32)
                } else {
                    Vec3::ZERO
                }
            }
            Overlap::General { s, a, b } => {
                scratch.batch.push(s, a, b);
                scratch.general.push((j, self.map.flux[i as usize]));
                Vec3::ZERO
            }
        }
    }
}

impl RadianceEstimator for IntegratedEstimate<'_> {
    fn integrates_view_footprint(&self) -> bool {
        // The whole footprint, exactly: a jittered pass must gather over its cell's footprint,
        // not one shifted by the jitter (which would shift the image by up to half a pixel per
        // pass and blur the mean into a tent filter).
        true
    }

    fn reads_exact_footprint(&self) -> bool {
        true
    }

    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        batch_of_one(self, q, counts)
    }

    /// Every query's photons first, then the general formula over all of their crossing
    /// photons at once: a gather holds one or two such photons on average, which alone would
    /// fill an eighth to a quarter of a batch's lanes. Each query's sum is taken in the order
    /// a lone gather takes it (closed forms in the order found, then the batches' photons);
    /// a crossing photon's mean can differ from a lone gather's in its last bits only, where
    /// the lanes it shares choose the general formula's four-`atan2` form.
    fn radiance_batch(
        &self,
        queries: &[GatherQuery],
        _shares: &[f64],
        out: &mut [DVec3],
        counts: &mut GatherCounts,
    ) {
        SCRATCH.with(|scratch| {
            let scratch = &mut *scratch.borrow_mut();
            scratch.batch.clear();
            scratch.general.clear();
            scratch.quads.clear();
            scratch.general_quads.clear();
            scratch.totals.clear();
            let mut search = std::mem::take(&mut scratch.search);
            let found = search.run(self.map, queries.iter().map(request));
            for ((j, q), found) in queries.iter().enumerate().zip(found) {
                let total = self.gather(q, j as u32, found, scratch, counts);
                scratch.totals.push(total);
            }
            scratch.search = search;
            parallelogram_means(&mut scratch.batch, &mut scratch.means);
            quad_means(&mut scratch.quads, &mut scratch.quad_means);
            let owners = scratch.general.iter().chain(&scratch.general_quads);
            let means = scratch.means.iter().chain(&scratch.quad_means);
            // A query's photons come in runs: each run is summed in a register and stored
            // once. (Added into `totals` one by one, each addition waited for the store of the
            // one before; summed in runs, the render stage at 1.28M photons is about 1%
            // shorter.) The same additions in the same order.
            let mut run: Option<(u32, Vec3)> = None;
            for (&(j, ref p), &mean) in owners.zip(means) {
                if mean > 0.0 {
                    counts.photons_used += 1;
                    let c = p.power * (p.inv_area * mean as f32);
                    match &mut run {
                        Some((owner, sum)) if *owner == j => *sum += c,
                        _ => {
                            if let Some((owner, sum)) = run {
                                scratch.totals[owner as usize] = sum;
                            }
                            run = Some((j, scratch.totals[j as usize] + c));
                        }
                    }
                }
            }
            if let Some((owner, sum)) = run {
                scratch.totals[owner as usize] = sum;
            }
            for ((o, q), total) in out.iter_mut().zip(queries).zip(&scratch.totals) {
                *o = q.albedo * (FRAC_1_PI * FRAC_2_PI) * total.as_dvec3();
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::disc_integral::mean;

    #[test]
    fn simd_and_scalar_means_agree() {
        let mut batch = ParallelogramBatch::default();
        let mut expected = Vec::new();
        for k in 0..23 {
            let t = k as f64 * 0.37;
            let (s, a, b) = (
                DVec2::new(t.sin() * 1.2, t.cos() * 0.9),
                DVec2::new(0.3 + 0.5 * t.cos(), 0.2) * (1.0 + t),
                DVec2::new(-0.1, 0.5 * t.sin() + 0.6),
            );
            batch.push(s, a, b);
            expected.push(mean(s, a, b));
        }
        let (mut simd, mut scalar) = (Vec::new(), Vec::new());
        parallelogram_means_scalar(&batch, &mut scalar);
        parallelogram_means(&mut batch, &mut simd);
        assert_eq!(simd.len(), 23);
        for ((a, b), c) in simd.iter().zip(&scalar).zip(&expected) {
            assert!(
                (a - b).abs() <= 1e-14 && (a - c).abs() <= 1e-12,
                "{a} {b} {c}"
            );
        }
        assert!(scalar.iter().any(|&s| s > 0.1) && scalar.iter().any(|&s| s < 0.1));
    }
}
