//! Preparing exact footprints many at a time: every step written once over [`Lane`], run on one
//! footprint (`f64`) by [`ExactFootprint::new`] and [`ExactFootprint::seen_from`], and on eight
//! in SIMD lanes by [`ExactFootprint::prepare_many`] (a packet's directly seen hits), so that
//! the two agree bit for bit. Alone, a footprint's preparation cost ~115 ns, a fifth of what
//! `integrated` adds to a render over `pd`.

use super::ExactFootprint;
use crate::geometry::disc_integral::quad_frame::{FrameNumbers, QuadFrame};
use crate::geometry::disc_integral::rows::{Wide, LANES};
use crate::geometry::lanes::{dot, splat3, sub, Lane, V3};
use crate::scene::camera::Camera;
use glam::DVec3;

/// How many numbers a request gives the lanes: the cell's screen coordinates (4), the plane's
/// point and normal, the query point and the footprint's two edges (3 each).
const COLUMNS: usize = 4 + 5 * 3;

/// What a gather's exact footprint is prepared from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootprintRequest {
    /// The image's cell `[x0, y0, x1, y1]` (continuous pixel coordinates).
    pub cell: [f64; 4],
    /// A point of the plane the cell's corner rays meet (the hit).
    pub point: DVec3,
    /// The plane's normal.
    pub normal: DVec3,
    /// The query point (where the cell's centre ray meets the plane, to first order).
    pub x: DVec3,
    /// The first-order footprint's edge vectors.
    pub footprint: [DVec3; 2],
}

impl ExactFootprint {
    /// For each request, [`Camera::rectangle_on_plane`], [`ExactFootprint::new`] and
    /// [`ExactFootprint::seen_from`] from `camera`, [`LANES`] requests at a time in SIMD
    /// lanes: `out` gets one footprint (or `None`, as those would give) per request, equal to
    /// theirs bit for bit.
    pub fn prepare_many(
        camera: &Camera,
        requests: &[FootprintRequest],
        out: &mut Vec<Option<ExactFootprint>>,
    ) {
        out.clear();
        for chunk in requests.chunks(LANES) {
            // Columns of the chunk's numbers, padded with copies of its first request.
            let mut columns = [[0.0; LANES]; COLUMNS];
            for k in 0..LANES {
                let r = chunk.get(k).unwrap_or(&chunk[0]);
                let (sx, sy) = camera.screen_rectangle(r.cell);
                let row = [
                    sx[0],
                    sx[1],
                    sy[0],
                    sy[1],
                    r.point.x,
                    r.point.y,
                    r.point.z,
                    r.normal.x,
                    r.normal.y,
                    r.normal.z,
                    r.x.x,
                    r.x.y,
                    r.x.z,
                    r.footprint[0].x,
                    r.footprint[0].y,
                    r.footprint[0].z,
                    r.footprint[1].x,
                    r.footprint[1].y,
                    r.footprint[1].z,
                ];
                for (column, value) in columns.iter_mut().zip(row) {
                    column[k] = value;
                }
            }
            let c = columns.map(Wide::from);
            let v3 = |i: usize| [c[i], c[i + 1], c[i + 2]];
            let (x, f) = (v3(10), [v3(13), v3(16)]);
            let (corners, t) = camera.corners_on_plane([c[0], c[1]], [c[2], c[3]], v3(4), v3(7));
            let basis = Basis::of(corners, x, f);
            let numbers = FrameNumbers::of(basis.alpha, basis.beta);
            let weights = Weights::of(
                splat3(camera.eye),
                splat3(camera.forward),
                x,
                f,
                [numbers.moments[0], numbers.moments[1]],
                numbers.centre,
                numbers.centred,
            );
            let t = t.map(|t| t.to_array());
            out.extend((0..chunk.len()).map(|k| {
                if !t.iter().all(|t| t[k] > 0.0 && t[k].is_finite()) {
                    return None;
                }
                let basis = basis.lane(k);
                let grow = basis.grow()?;
                let frame = QuadFrame::from_numbers(basis.alpha, basis.beta, &numbers.lane(k))?;
                Some(ExactFootprint::uniform(frame, grow).weighted(&weights.lane(k)))
            }));
        }
    }
}

/// A quadrilateral's corners in the basis of the first-order parallelogram's edges, with what
/// [`Basis::grow`] checks.
pub(super) struct Basis<T> {
    pub alpha: [T; 4],
    pub beta: [T; 4],
    /// The Gram determinant of the edges, and the least it may be (`1e-12 |f0|^2 |f1|^2`).
    det: T,
    least: T,
}

impl<T: Lane> Basis<T> {
    /// The coordinates of `corners` in the basis `(f[0], f[1])` about `x`, from the Gram
    /// system.
    #[inline(always)]
    pub fn of(corners: [V3<T>; 4], x: V3<T>, f: [V3<T>; 2]) -> Self {
        let (g00, g01, g11) = (dot(f[0], f[0]), dot(f[0], f[1]), dot(f[1], f[1]));
        let det = g00 * g11 - g01 * g01;
        let inv_det = T::splat(1.0) / det;
        let mut alpha = [T::splat(0.0); 4];
        let mut beta = [T::splat(0.0); 4];
        for (k, c) in corners.into_iter().enumerate() {
            let w = sub(c, x);
            let (b0, b1) = (dot(w, f[0]), dot(w, f[1]));
            alpha[k] = (g11 * b0 - g01 * b1) * inv_det;
            beta[k] = (g00 * b1 - g01 * b0) * inv_det;
        }
        Basis {
            alpha,
            beta,
            det,
            least: T::splat(1e-12) * g00 * g11,
        }
    }
}

impl Basis<Wide> {
    fn lane(&self, k: usize) -> Basis<f64> {
        let at = |v: Wide| v.to_array()[k];
        Basis {
            alpha: self.alpha.map(at),
            beta: self.beta.map(at),
            det: at(self.det),
            least: at(self.least),
        }
    }
}

impl Basis<f64> {
    /// The least `g >= 1` (a little over, for rounding) such that the parallelogram grown by
    /// `g` holds the quadrilateral, or `None` for a degenerate parallelogram or a
    /// quadrilateral reaching past twice it (`g >= 4`).
    pub fn grow(&self) -> Option<f64> {
        let det = self.det;
        if det.is_nan() || det <= self.least || !det.is_finite() {
            return None;
        }
        let grow = (0..4).fold(1.0f64, |g, k| {
            g.max(2.0 * self.alpha[k].abs().max(self.beta[k].abs()))
        });
        let grow = grow * (1.0 + 1e-4);
        (!grow.is_nan() && grow < 4.0).then_some(grow)
    }
}

/// The image-area weight over a footprint ([`ExactFootprint::seen_from`]), with the depth and
/// mean that decide whether it holds.
pub(super) struct Weights<T> {
    pub depth: T,
    pub mean: T,
    pub weight: [T; 3],
    pub inside: [T; 7],
}

impl<T: Lane> Weights<T> {
    /// Seen from `eye` along `forward`, at the query point `x` with edges `f`, over the
    /// quadrilateral with this area `centroid`, vertex `centre` and moments about it.
    #[inline(always)]
    pub fn of(
        eye: V3<T>,
        forward: V3<T>,
        x: V3<T>,
        f: [V3<T>; 2],
        centroid: [T; 2],
        centre: [T; 2],
        centred: [T; 9],
    ) -> Self {
        let depth = dot(forward, sub(x, eye));
        let scale = T::splat(-3.0) / depth;
        let g = f.map(|f| scale * dot(forward, f));
        let mean = T::splat(1.0) + g[0] * centroid[0] + g[1] * centroid[1];
        let inv_mean = T::splat(1.0) / mean;
        let w = [inv_mean, g[0] * inv_mean, g[1] * inv_mean];
        let [m_a, m_b, m_aa, m_ab, m_bb, m_aaa, m_aab, m_abb, m_bbb] = centred;
        let along = |x: T, y: T| w[1] * x + w[2] * y;
        Weights {
            depth,
            mean,
            weight: w,
            inside: [
                w[0] + w[1] * centre[0] + w[2] * centre[1],
                along(m_a, m_b),
                along(m_aa, m_ab),
                along(m_ab, m_bb),
                along(m_aaa, m_aab),
                along(m_aab, m_abb),
                along(m_abb, m_bbb),
            ],
        }
    }
}

impl Weights<Wide> {
    fn lane(&self, k: usize) -> Weights<f64> {
        let at = |v: Wide| v.to_array()[k];
        Weights {
            depth: at(self.depth),
            mean: at(self.mean),
            weight: self.weight.map(at),
            inside: self.inside.map(at),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::rng::Rng;

    #[test]
    fn footprints_prepared_together_equal_footprints_prepared_alone() {
        // Cells of a view over tilted planes, some seen edge-on or from behind (no footprint),
        // some with degenerate first-order edges, in batches of every length about the lane
        // count (partly filled lanes included).
        let camera = Camera::look_at(
            DVec3::new(0.0, 2.0, 5.0),
            DVec3::ZERO,
            DVec3::Y,
            40.0,
            64,
            48,
        )
        .unwrap();
        let mut rng = Rng::new(11, 0);
        let mut requests = Vec::new();
        for k in 0..45 {
            let (x, y) = (64.0 * rng.uniform(), 48.0 * rng.uniform());
            let ray = camera.ray(x + 0.5, y + 0.5, 1.0);
            let normal = match k % 5 {
                // Edge-on: the plane holds the eye.
                4 => ray.d.cross(DVec3::X).normalize(),
                _ => DVec3::new(rng.uniform() - 0.5, 1.0, rng.uniform() - 0.5).normalize(),
            };
            let t = (3.0 + 3.0 * rng.uniform()) * if k % 7 == 3 { -1.0 } else { 1.0 };
            let at = ray.transfer(t, normal);
            let mut footprint = at.dp;
            if k % 9 == 2 {
                footprint[1] = footprint[0];
            }
            requests.push(FootprintRequest {
                cell: [x, y, x + 1.0, y + 1.0],
                point: at.p,
                normal,
                x: at.p + at.dp[0] * 0.01,
                footprint,
            });
        }
        let alone = |r: &FootprintRequest| {
            camera
                .rectangle_on_plane(r.cell, r.point, r.normal)
                .and_then(|c| ExactFootprint::new(&c, r.x, &r.footprint))
                .map(|e| e.seen_from(camera.eye, camera.forward, r.x, &r.footprint))
        };
        let mut together = Vec::new();
        for len in [0, 1, LANES - 1, LANES, LANES + 1, requests.len()] {
            ExactFootprint::prepare_many(&camera, &requests[..len], &mut together);
            assert_eq!(together.len(), len);
            for (r, e) in requests.iter().zip(&together) {
                assert_eq!(*e, alone(r), "{r:?}");
            }
        }
        let prepared = together.iter().filter(|e| e.is_some()).count();
        // Most weighted by image area (not those seen from behind the eye).
        let weighted = together.iter().flatten().filter(|e| e.weight[1] != 0.0);
        assert!(prepared > 20 && prepared < requests.len(), "{prepared}");
        assert!(weighted.count() > prepared / 2);
    }
}
