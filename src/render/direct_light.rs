//! Direct light at diffuse hits: shadow rays to point and spot lights, stratified samples on
//! quad area lights, traced as 16-wide packets.
//!
//! A point light's direct light is a point sample of the pixel's integral: at a shadow's edge
//! the pixel is partly lit and one ray per pass calls it lit or dark, and near a light that
//! grazes a surface the `I cos / d^2` falloff varies steeply across one pixel. Both converge
//! only as fast as the camera jitter of the passes. With `footprint_strata = N > 1` a hit seen
//! directly by the camera sends `N x N` shadow rays instead, from points spread over the
//! camera ray's footprint on the surface (its position differentials: the cell of the view
//! grid around the cell's centre, split into `N x N` sub-cells). The passes fill the sub-cells
//! as they fill the cell: each point sits at the pass's jitter within its sub-cell, mirrored in
//! the far half of each axis (sub-cell `i` of `N` takes `jx` for `2i + 1 < N`, `1 - jx` for
//! `2i + 1 > N`, and `jx` for the middle one of odd `N`), so that every pass's points are
//! symmetric about the cell's centre. A shifted grid's average is off by the shift times the
//! light's gradient, a mirrored one only to second order: near a grazing light, where the
//! light changes by 15% from one pixel to the next, pass 1's jitter put a plain 2 x 2 grid
//! 10% over the pixel's mean, and the running mean of few passes stayed several percent over
//! it (the centred pass 0 was within 0.1%). Over passes each point still covers its sub-cell
//! uniformly (`1 - jx` is as uniform as `jx`), so the passes' mean converges to the box
//! filter as before. The points lie in the hit's
//! tangent plane: exact on flat surfaces, and off a curved one by the footprint's size squared
//! over the curvature radius; on a concave one a point can lie behind the surface, and a
//! blocked ray from it is checked ([`DirectLight::add`]). Hits seen through mirrors and glass keep one ray: their
//! footprints are where the first-order differential is least trustworthy (a caustic's focus,
//! a grazing refraction).

use crate::embree::{self, Ray, PACKET_WIDTH};
use crate::estimate::final_gather::DirectAt;
use crate::geometry::differential::RayDifferential;
use crate::geometry::surface::facing;
use crate::render::camera_path::DiffuseVertex;
use crate::scene::{Light, Scene};
use crate::util::rng::Rng;
use glam::DVec3;
use std::f64::consts::FRAC_1_PI;

/// A shadow ray and what it carries if unblocked.
#[derive(Debug, Clone, Copy)]
struct ShadowQuery {
    ray: Ray,
    contribution: DVec3,
    sample: usize,
    /// For a ray from a footprint point other than the hit: the segment from the hit to that
    /// point (off the surface as the shadow rays are), and the shadow ray and contribution of
    /// the same light sample from the hit itself. A blocked ray whose segment is blocked too
    /// started behind the surface (see [`DirectLight::add`]), and the hit's ray stands in.
    fallback: Option<Fallback>,
}

#[derive(Debug, Clone, Copy)]
struct Fallback {
    segment: Ray,
    ray: Ray,
    contribution: DVec3,
}

/// Computes direct light for batches of diffuse vertices.
pub struct DirectLight<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Samples per quad light per vertex, in a `strata x strata` grid.
    pub area_strata: u32,
    /// Shadow rays per point or spot light at a vertex seen directly, along each axis, over
    /// its footprint (see the module documentation); 1 traces from the hit alone.
    pub footprint_strata: u32,
    /// The camera jitter of this pass within its cell of the view grid.
    pub jitter: [f64; 2],
    /// Offset of shadow ray origins off the surface.
    pub epsilon: f64,
}

impl DirectLight<'_> {
    /// Adds the direct light reflected towards the camera at each vertex into
    /// `radiance[vertex.sample]`; returns the number of shadow rays traced. `rng` draws the
    /// positions within the area-light strata.
    ///
    /// A footprint's points lie in the hit's tangent plane, which on a concave surface (inside
    /// a bowl, where two walls meet) runs behind the surface: such a point's shadow ray is
    /// blocked by the surface itself (inside a closed diffuse sphere the default render's
    /// direct light read 0.72 of the exact answer, and a box's corners were dark lines). So a
    /// blocked ray from a footprint point is looked at again: if the segment from the hit to its
    /// point is blocked as well, the point is behind a surface, and the same light sample is
    /// taken from the hit instead. Only blocked rays cost more: their segment, and where it is
    /// blocked, the ray from the hit.
    pub fn add(&self, vertices: &[DiffuseVertex], rng: &mut Rng, radiance: &mut [DVec3]) -> u64 {
        let mut queries = Vec::with_capacity(vertices.len() * self.scene.lights.len());
        for v in vertices {
            self.queries(v, rng, &mut queries);
        }
        let mut retry = Vec::new();
        self.trace(&queries, |q, blocked| match (blocked, q.fallback) {
            (false, _) => radiance[q.sample] += q.contribution,
            (true, Some(f)) => retry.push((q.sample, f)),
            (true, None) => {}
        });
        // The blocked footprint rays' segments (in a shadow, almost all clear), then the
        // stand-ins of those whose segment is blocked.
        let segments: Vec<Ray> = retry.iter().map(|(_, f)| f.segment).collect();
        let mut behind = Vec::new();
        let mut k = 0;
        self.trace_rays(&segments, |blocked| {
            if blocked {
                behind.push(retry[k]);
            }
            k += 1;
        });
        let stand_ins: Vec<Ray> = behind.iter().map(|(_, f)| f.ray).collect();
        let mut k = 0;
        self.trace_rays(&stand_ins, |blocked| {
            let (sample, f) = behind[k];
            if !blocked {
                radiance[sample] += f.contribution;
            }
            k += 1;
        });
        (queries.len() + segments.len() + stand_ins.len()) as u64
    }

    /// Traces the queries' shadow rays in packets, telling `answer` whether each is blocked.
    fn trace(&self, queries: &[ShadowQuery], mut answer: impl FnMut(&ShadowQuery, bool)) {
        let mut blocked = [false; PACKET_WIDTH];
        let mut rays = [Ray::new(DVec3::ZERO, DVec3::X); PACKET_WIDTH];
        for chunk in queries.chunks(PACKET_WIDTH) {
            for (ray, q) in rays.iter_mut().zip(chunk) {
                *ray = q.ray;
            }
            self.embree
                .occluded16(&rays[..chunk.len()], true, &mut blocked);
            for (q, &b) in chunk.iter().zip(&blocked) {
                answer(q, b);
            }
        }
    }

    /// Traces `rays` in packets, telling `answer` in order whether each is blocked.
    fn trace_rays(&self, rays: &[Ray], mut answer: impl FnMut(bool)) {
        let mut blocked = [false; PACKET_WIDTH];
        for chunk in rays.chunks(PACKET_WIDTH) {
            self.embree.occluded16(chunk, true, &mut blocked);
            blocked[..chunk.len()].iter().for_each(|&b| answer(b));
        }
    }

    fn queries(&self, v: &DiffuseVertex, rng: &mut Rng, out: &mut Vec<ShadowQuery>) {
        let d = v.ray.d;
        let ng = facing(v.hit.geometric_normal, d);
        let ns = if v.hit.shading_normal.dot(ng) > 0.0 {
            v.hit.shading_normal
        } else {
            -v.hit.shading_normal
        };
        let brdf = v.weight * v.albedo * FRAC_1_PI;
        let hit = v.hit.position;
        // The shadow ray from `from` to `target` and what it carries, `None` where the light is
        // behind the surface.
        let query = |from: DVec3, target: DVec3, radiance_factor: DVec3, tfar_scale: f64| {
            let origin = from + ng * self.epsilon;
            let to = target - origin;
            let dist = to.length();
            let w = to / dist;
            let cos = ns.dot(w);
            if cos <= 0.0 || ng.dot(w) <= 0.0 || dist.is_nan() || dist <= 0.0 {
                return None;
            }
            let contribution = brdf * radiance_factor * (cos / (dist * dist));
            Some((Ray::segment(origin, w, dist * tfar_scale), contribution))
        };
        // `radiance_at(from)`: the light sample's radiance factor seen from `from`.
        let mut push =
            |from: DVec3, target: DVec3, radiance_at: &dyn Fn(DVec3) -> DVec3, tfar_scale: f64| {
                let Some((ray, contribution)) = query(from, target, radiance_at(from), tfar_scale)
                else {
                    return;
                };
                let fallback = (from != hit)
                    .then(|| {
                        let (a, b) = (hit + ng * self.epsilon, from + ng * self.epsilon);
                        let (to, len) = ((b - a).normalize_or_zero(), (b - a).length());
                        let (ray, contribution) = query(hit, target, radiance_at(hit), tfar_scale)?;
                        (len > 0.0 && len.is_finite()).then_some(Fallback {
                            segment: Ray::segment(a, to, len),
                            ray,
                            contribution,
                        })
                    })
                    .flatten();
                out.push(ShadowQuery {
                    ray,
                    contribution,
                    sample: v.sample,
                    fallback,
                });
            };
        let grid = self.footprint_grid(v);
        let share = 1.0 / (grid.n * grid.n) as f64;
        for light in &self.scene.lights {
            match *light {
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    let intensity = |p: DVec3| {
                        let w = (p + ng * self.epsilon - position).normalize_or_zero();
                        light.intensity_towards(w) * share
                    };
                    for k in 0..grid.n * grid.n {
                        let p = grid.point(k);
                        if intensity(p) != DVec3::ZERO {
                            push(p, position, &intensity, 1.0);
                        }
                    }
                }
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                } => {
                    let cross = edge_u.cross(edge_v);
                    let area = cross.length();
                    let normal = cross / area;
                    // The light's strata take turns over the footprint's points (stratum
                    // (i, j) from point (i mod n, j mod n)), at least one stratum a point: from
                    // the hit alone, a pass's jitter moved a whole pixel's area light off its
                    // centre, and 2 passes were further from the reference than 1 (relRMSE
                    // 0.022 against 0.006 on a floor under a quad light at 96 x 72).
                    let s = self.area_strata.max(grid.n).max(1);
                    let per_sample = area / (s * s) as f64;
                    for i in 0..s {
                        for j in 0..s {
                            let a = (i as f64 + rng.uniform()) / s as f64;
                            let b = (j as f64 + rng.uniform()) / s as f64;
                            let y = corner + edge_u * a + edge_v * b;
                            let from = grid.point(i % grid.n + grid.n * (j % grid.n));
                            let cos_light = |p: DVec3| {
                                (p + ng * self.epsilon - y).normalize_or_zero().dot(normal)
                            };
                            if cos_light(from) > 0.0 {
                                let seen =
                                    |p: DVec3| radiance * (cos_light(p).max(0.0) * per_sample);
                                // Stop short of the light's own quad.
                                push(from, y, &seen, 1.0 - 1e-4);
                            }
                        }
                    }
                }
            }
        }
    }

    /// Where a vertex's shadow rays to point and spot lights start (see [`FootprintGrid`]).
    fn footprint_grid(&self, v: &DiffuseVertex) -> FootprintGrid {
        let n = self.footprint_strata.max(1);
        let [dp0, dp1] = v.ray.dp;
        if n == 1 || v.depth > 0 || !(dp0.is_finite() && dp1.is_finite()) {
            return FootprintGrid {
                centre: v.hit.position,
                dp: [DVec3::ZERO; 2],
                jitter: [0.5, 0.5],
                n: 1,
            };
        }
        FootprintGrid {
            centre: v.ray.cell_centre(v.hit.position, self.jitter),
            dp: [dp0, dp1],
            jitter: self.jitter,
            n,
        }
    }
}

// Direct light where final gathering traces a gather ray a bounce further.
impl DirectAt for DirectLight<'_> {
    fn reflected(
        &self,
        hit: &embree::Hit,
        ray: &RayDifferential,
        albedo: DVec3,
        rng: &mut Rng,
    ) -> DVec3 {
        let vertex = DiffuseVertex {
            hit: *hit,
            ray: *ray,
            weight: DVec3::ONE,
            albedo,
            sample: 0,
            depth: 1,
        };
        let mut radiance = [DVec3::ZERO];
        self.add(std::slice::from_ref(&vertex), rng, &mut radiance);
        radiance[0]
    }
}

/// The points a vertex's shadow rays to point and spot lights start from: the hit alone
/// (`n = 1`), or for a hit seen directly an `n x n` grid over its footprint, the view-grid
/// cell `c +- dp0/2 +- dp1/2` around the cell's centre `c` split into `n x n` sub-cells, each
/// point at the pass's jitter within its sub-cell, mirrored in the far half of each axis (see
/// the module documentation).
struct FootprintGrid {
    /// The cell's centre.
    centre: DVec3,
    /// The cell's edges (the camera ray's position differentials).
    dp: [DVec3; 2],
    /// The pass's jitter within a sub-cell.
    jitter: [f64; 2],
    /// Points along each axis.
    n: u32,
}

impl FootprintGrid {
    /// Point `k` (row-major).
    fn point(&self, k: u32) -> DVec3 {
        let at = |i: u32, jitter: f64| mirrored_stratum(i, self.n, jitter) - 0.5;
        self.centre
            + self.dp[0] * at(k % self.n, self.jitter[0])
            + self.dp[1] * at(k / self.n, self.jitter[1])
    }
}

/// Where in `[0, 1]` the point of stratum `i` of `n` lies for the jitter `jitter` within its
/// stratum, mirrored in the far half: `(i + jitter) / n` for `2i + 1 <= n`, `(i + 1 - jitter)
/// / n` beyond, so that the `n` points are symmetric about 1/2 (for odd `n` all but the middle
/// one, which keeps `jitter`).
fn mirrored_stratum(i: u32, n: u32, jitter: f64) -> f64 {
    let offset = if 2 * i + 1 > n { 1.0 - jitter } else { jitter };
    (i as f64 + offset) / n as f64
}

#[cfg(test)]
mod tests {
    use super::mirrored_stratum;

    #[test]
    fn mirrored_strata_are_symmetric_and_each_covers_its_stratum() {
        for n in 1..=6u32 {
            for jitter in [0.0, 0.13, 0.5, 0.77, 1.0] {
                let points: Vec<f64> = (0..n).map(|i| mirrored_stratum(i, n, jitter)).collect();
                for (i, &u) in points.iter().enumerate() {
                    // Inside its own stratum.
                    assert!(u >= i as f64 / n as f64 && u <= (i + 1) as f64 / n as f64);
                }
                // Symmetric about 1/2 (the middle point of odd n at its own jitter).
                let mean = points.iter().sum::<f64>() / n as f64;
                let middle = if n % 2 == 1 {
                    (jitter - 0.5) / n as f64 / n as f64
                } else {
                    0.0
                };
                assert!((mean - 0.5 - middle).abs() < 1e-15, "n {n} jitter {jitter}");
                for i in 0..(n / 2) as usize {
                    let j = n as usize - 1 - i;
                    assert!((points[i] + points[j] - 1.0).abs() < 1e-15);
                }
            }
        }
        // Over uniform jitters a stratum's point is uniform in it: the far half's offset
        // `1 - jitter` runs over the stratum as `jitter` does.
        assert_eq!(mirrored_stratum(1, 2, 0.25), 0.875);
        assert_eq!(mirrored_stratum(0, 2, 0.25), 0.125);
    }
}
