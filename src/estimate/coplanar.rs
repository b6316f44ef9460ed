//! The coplanar intersection-weighted photon-differential estimate (Pedersen 2011): the
//! photon's footprint and the pixel's view footprint are projected into the query's tangent
//! plane, reconstructed as convex polygons and intersected; the photon's kernel, evaluated at
//! the intersection's centroid, is weighted by the intersection's coverage of the view footprint:
//! `sum f_r Phi_p / A_p K(|M_p (c - x_p)|) w`.

use crate::estimate::{batch_of_one, kernel, GatherCounts, GatherQuery, RadianceEstimator};
use crate::geometry::polygon::{area_centroid, intersect_convex, ClipScratch, UnitPolygon};
use crate::geometry::sampling::tangent_frame;
use crate::photons::cover::OnSurface;
use crate::photons::map::{FootprintQuery, PacketSearch, PhotonMap};
use glam::{DVec2, DVec3, Vec3};
use std::cell::RefCell;
use std::f64::consts::FRAC_1_PI;

/// The coplanar intersection-weighted estimate.
pub struct CoplanarEstimate<'a> {
    /// The map.
    pub map: &'a PhotonMap,
    /// Vertices of the polygon that stands for a photon's elliptical footprint (at least 3).
    pub ellipse_vertices: usize,
}

/// Coverage `w` (intersection area over the view footprint's area) and centroid (in the plane's
/// 2D coordinates) of a photon footprint polygon against the view footprint polygon.
pub fn coverage(photon: &[DVec2], view: &[DVec2]) -> (f64, DVec2) {
    let (view_area, view_centroid) = area_centroid(view);
    if view_area <= 0.0 {
        return (0.0, view_centroid);
    }
    let (area, centroid) = area_centroid(&intersect_convex(photon, view));
    ((area / view_area).clamp(0.0, 1.0), centroid)
}

/// Buffers reused across gathers on one thread.
#[derive(Default)]
struct Scratch {
    /// A packet's footprints and the photons found for each.
    search: PacketSearch<OnSurface>,
    unit: Option<UnitPolygon>,
    polygon: Vec<DVec2>,
    clip: ClipScratch,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl CoplanarEstimate<'_> {
    /// The estimate at `q` over the photons `found` for its footprint, each photon's ellipse
    /// an image of `unit`.
    fn gather(
        &self,
        q: &GatherQuery,
        found: &[OnSurface],
        unit: &UnitPolygon,
        polygon: &mut Vec<DVec2>,
        clip: &mut ClipScratch,
        counts: &mut GatherCounts,
    ) -> DVec3 {
        counts.gathers += 1;
        counts.photons_found += found.len() as u64;
        let (t1, t2) = tangent_frame(q.normal);
        let to_2d = |v: DVec3| DVec2::new(v.dot(t1), v.dot(t2));
        let (u, v) = (to_2d(q.footprint[0]), to_2d(q.footprint[1]));
        // The plane's coordinates in the view footprint's, `p = alpha u + beta v`: the footprint
        // is the square `[-1/2, 1/2]^2` there, an affine map keeps ratios of areas and
        // centroids, so the coverage is the clipped area itself ([`coverage`] over the
        // footprint's polygon is the definition it is tested against).
        let det = u.perp_dot(v);
        let view_area = det.abs();
        // (By the reciprocal: three divisions a photon were a tenth of its gather.)
        let inv_det = 1.0 / det;
        let to_square = |p: DVec2| DVec2::new(p.perp_dot(v), u.perp_dot(p)) * inv_det;
        let x = q.position.as_vec3();
        let mut sum = Vec3::ZERO;
        // Found on the query's surface (the cover test made `on_query_surface`'s test at `x`);
        // everything else read of a photon comes from the cover test's table, whose leaf the
        // test has just loaded, and the flux table.
        for &OnSurface(i) in found {
            let i = i as usize;
            let (position, m) = self.map.filter_frame(i);
            // `photon_kernel` at offset `v` from the photon, from those tables: the slab test
            // (the normal's was made at `x` and does not depend on the point) and the kernel.
            let kernel_at = |v: Vec3| {
                let (normal, slab) = self.map.surface(i);
                if normal.dot(v).abs() > slab {
                    return None;
                }
                let (s0, s1) = (m[0].dot(v), m[1].dot(v));
                kernel(&self.map.flux[i], s0 * s0 + s1 * s1)
            };
            let contribution = if view_area > 0.0 && view_area.is_finite() {
                let centre = to_2d(position.as_dvec3() - q.position);
                // The footprint's semi-axis vectors: M's rows are axis / sigma. (The cover test
                // found only ellipses that meet the footprint's parallelogram, up to its slack.)
                let axis = |m: Vec3| to_square(to_2d((m * m.length_squared().recip()).as_dvec3()));
                let (w, c) =
                    unit.in_unit_square(to_square(centre), axis(m[0]), axis(m[1]), polygon, clip);
                let w = w.clamp(0.0, 1.0);
                if w <= 0.0 {
                    continue;
                }
                let c = u * c.x + v * c.y;
                let c = q.position + t1 * c.x + t2 * c.y;
                kernel_at(c.as_vec3() - position).map(|k| k * w as f32)
            } else {
                // A degenerate view footprint is a point: the plain photon-differential
                // estimate.
                kernel_at(x - position)
            };
            if let Some(c) = contribution {
                counts.photons_used += 1;
                sum += c;
            }
        }
        q.albedo * FRAC_1_PI * sum.as_dvec3()
    }
}

impl RadianceEstimator for CoplanarEstimate<'_> {
    fn integrates_view_footprint(&self) -> bool {
        true
    }

    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        batch_of_one(self, q, counts)
    }

    /// The packet's footprints go through the map together ([`PhotonMap::covering_packet`]:
    /// each finds what it would alone); then each query is gathered in turn.
    fn radiance_batch(
        &self,
        queries: &[GatherQuery],
        _shares: &[f64],
        out: &mut [DVec3],
        counts: &mut GatherCounts,
    ) {
        SCRATCH.with(|scratch| {
            let Scratch {
                search,
                unit,
                polygon,
                clip,
            } = &mut *scratch.borrow_mut();
            let vertices = self.ellipse_vertices.max(3);
            if unit.as_ref().map(|u| u.vertices().len()) != Some(vertices) {
                *unit = None;
            }
            let unit = unit.get_or_insert_with(|| UnitPolygon::new(vertices));
            // Only photons whose kernel may reach the view footprint (the exact disc against
            // parallelogram screen of the footprint estimators): the cube of the footprint's
            // reach let through four times as many, each clipped as a polygon for nothing.
            let requests = queries
                .iter()
                .map(|q| FootprintQuery::new(q.position, q.footprint, q.normal));
            let found = search.run(self.map, requests);
            for ((q, found), o) in queries.iter().zip(found).zip(out) {
                *o = self.gather(q, found, unit, polygon, clip, counts);
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polygon::parallelogram;

    #[test]
    fn identical_footprints_cover_fully_and_disjoint_ones_not_at_all() {
        let view = parallelogram(DVec2::ZERO, DVec2::new(0.3, 0.05), DVec2::new(-0.02, 0.2));
        let (w, c) = coverage(&view, &view);
        assert!((w - 1.0).abs() < 1e-12 && c.length() < 1e-12, "{w} {c}");
        let far = parallelogram(DVec2::new(5.0, 0.0), DVec2::X, DVec2::Y);
        assert_eq!(coverage(&far, &view).0, 0.0);
        let e = crate::geometry::polygon::ellipse(
            DVec2::ZERO,
            DVec2::new(0.1, 0.0),
            DVec2::new(0.0, 0.05),
            32,
        );
        let (w, c) = coverage(&e, &e);
        assert!((w - 1.0).abs() < 1e-12 && c.length() < 1e-12);
    }
}
