//! Which of eight placements need the general formula, found in SIMD lanes.
//!
//! A gather at a million photons holds dozens of photons, and most of their parallelograms or
//! quadrilaterals cross the circle: [`super::classify`] and [`QuadFrame::classify`] then run
//! every test they have, one photon at a time, only to answer "the general formula", and that
//! scalar work was most of `integrated`'s per-photon cost. Here the same tests run for
//! [`LANES`] placements at once, with the same operations in the same order (glam's `dot`,
//! `perp_dot` and vector products written out), so a lane they mark gets exactly the answer
//! the scalar classification gives (tested bit for bit); every other lane is left to it.
//! Quadrilaterals (the exact view footprints) are also settled here where the disc lies inside
//! one or one inside the disc: at 1.28M caustic photons, photons smaller than the pixel, a third
//! of `integrated`'s photons were one of those, and the scalar classification had to run every
//! test to say so.

use super::quad_frame::QuadFrame;
use super::rows::{Wide, LANES};
use super::{MIN_WIDTH, POINT_SIZE};
use glam::DVec2;
use std::f64::consts::{FRAC_PI_2, PI};

/// [`LANES`] placements in filter space as columns: centres `s`, edge vectors `a` and `b`.
#[derive(Debug, Clone, Copy)]
pub struct Placements {
    /// Centres (`x`, `y`).
    pub s: [Wide; 2],
    /// First edge vectors.
    pub a: [Wide; 2],
    /// Second edge vectors.
    pub b: [Wide; 2],
}

/// What [`super::classify`] answers for a chunk's parallelograms, lane by lane.
#[derive(Debug, Clone, Copy)]
pub struct ParallelogramLanes {
    /// Bit `k` set where lane `k` needs the general formula with its own numbers
    /// ([`super::Overlap::General`] with the lane's `s`, `a`, `b`: not thickened).
    pub general: u32,
    /// Bit `k` set where lane `k` is settled in closed form: its mean is `means[k]`
    /// ([`super::Overlap::Mean`], or 0 for [`super::Overlap::None`]).
    pub settled: u32,
    /// The settled lanes' means.
    pub means: [f64; LANES],
}

/// [`super::classify`] for [`LANES`] parallelograms at once, but for those it would thicken
/// (neither bit set: rare, left to it).
pub fn classify_parallelograms(p: &Placements) -> ParallelogramLanes {
    let [s0, s1] = p.s;
    let [a0, a1] = p.a;
    let [b0, b1] = p.b;
    let size2 = (a0 * a0 + a1 * a1) + (b0 * b0 + b1 * b1);
    let ss = s0 * s0 + s1 * s1;
    // The scalar tests in their order: each lane takes the first that holds.
    let mut left = size2.is_finite() & ss.is_finite();
    let mut settled = !left;
    let mut means = Wide::ZERO;
    let mut settle = |holds: Wide, mean: Wide, left: &mut Wide| {
        let here = holds & *left;
        means = here.bitselect(mean, means);
        settled |= here;
        *left &= !here;
    };
    settle(ss.simd_gt(Wide::splat(2.0) + size2), Wide::ZERO, &mut left);
    let point = size2.simd_lt(Wide::splat(POINT_SIZE * POINT_SIZE));
    settle(point, (Wide::ONE - ss).max(Wide::ZERO), &mut left);
    // The vertices' largest squared distance: inside the disc if at most 1.
    let (sa, sb) = (s0 * a0 + s1 * a1, s0 * b0 + s1 * b1);
    let ab = Wide::splat(0.5) * (a0 * b0 + a1 * b1);
    let base = ss + Wide::splat(0.25) * size2;
    let far = base + ((sa + sb).abs() + ab).max((sa - sb).abs() - ab);
    let inside_mean = Wide::ONE - ss - size2 / Wide::splat(12.0);
    settle(far.simd_le(Wide::ONE), inside_mean, &mut left);
    // Beyond 1 + R from the centre.
    let length2 = |x: Wide, y: Wide| x * x + y * y;
    let r2 = Wide::splat(0.25) * length2(a0 + b0, a1 + b1).max(length2(a0 - b0, a1 - b1));
    let beyond = ss - Wide::ONE - r2;
    let apart = beyond.simd_ge(Wide::ZERO) & (beyond * beyond).simd_ge(Wide::splat(4.0) * r2);
    settle(apart, Wide::ZERO, &mut left);
    // Too thin: thickened by the scalar classification.
    let cross = a0 * b1 - a1 * b0;
    let (aa, bb) = (a0 * a0 + a1 * a1, b0 * b0 + b1 * b1);
    let min_width2 = Wide::splat(MIN_WIDTH * MIN_WIDTH) * size2.min(Wide::ONE) * aa.max(bb);
    left &= (cross * cross).simd_ge(min_width2);
    let area = cross.abs();
    let mut general = area.simd_lt(Wide::splat(PI)) & left;
    left &= !general;
    // The disc inside, or a side's line between them: from the sides' signed distances (two
    // square roots and six divisions, where a lane is still left: few are).
    if left.any() {
        let (la, lb) = (length2(a0, a1).sqrt(), length2(b0, b1).sqrt());
        let ca = (s0 * a1 - s1 * a0) / la;
        let cb = (s0 * b1 - s1 * b0) / lb;
        let half_area = Wide::splat(0.5) * area;
        let (ma, mb) = (half_area / la - ca.abs(), half_area / lb - cb.abs());
        let holds = ma.simd_ge(Wide::ONE) & mb.simd_ge(Wide::ONE);
        settle(holds, Wide::splat(FRAC_PI_2) / area, &mut left);
        let separated = ma.simd_le(-Wide::ONE) | mb.simd_le(-Wide::ONE);
        settle(separated, Wide::ZERO, &mut left);
    }
    general |= left;
    ParallelogramLanes {
        general: general.to_bitmask(),
        settled: settled.to_bitmask(),
        means: means.to_array(),
    }
}

/// A chunk's quadrilaterals as [`QuadFrame::general_lanes`] finds them.
#[derive(Debug, Clone, Copy)]
pub struct GeneralQuads {
    /// Bit `k` set where lane `k`'s placement needs the general formula.
    pub mask: u32,
    /// Each lane's vertices, counter-clockwise in filter space: `x` of the four, then `y`.
    pub vertices: [[f64; LANES]; 8],
    /// Bit `k` set where lane `k`'s quadrilateral lies inside the disc
    /// ([`super::quad::QuadOverlap::Mean`], its mean in `means[k]`).
    pub inside: u32,
    /// Bit `k` set where the disc lies inside lane `k`'s quadrilateral
    /// ([`super::quad::QuadOverlap::DiscInside`], its mean in `means[k]`).
    pub disc_inside: u32,
    /// The means of the lanes in `inside` and `disc_inside` (others: not read).
    pub means: [f64; LANES],
}

impl GeneralQuads {
    /// Lane `k`'s vertices.
    #[inline]
    pub fn lane(&self, k: usize) -> [DVec2; 4] {
        std::array::from_fn(|j| DVec2::new(self.vertices[j][k], self.vertices[4 + j][k]))
    }
}

impl QuadFrame {
    /// The lanes whose placement `s + alpha a + beta b` [`QuadFrame::classify`] answers
    /// [`super::quad::QuadOverlap::General`], with the vertices it gives them, and those it
    /// answers [`super::quad::QuadOverlap::Mean`] (the quadrilateral inside the disc, but for
    /// a point-sized one) or [`super::quad::QuadOverlap::DiscInside`], with their means. The
    /// rest (apart, point-sized, too thin, not finite) are left to it.
    pub fn general_lanes(&self, p: &Placements) -> GeneralQuads {
        let [s0, s1] = p.s;
        let [a0, a1] = p.a;
        let [b0, b1] = p.b;
        let (alpha, beta) = (self.alpha(), self.beta());
        let [cx, cy] = self.centre().to_array().map(Wide::splat);
        let (c0, c1) = (s0 + a0 * cx + b0 * cy, s1 + a1 * cx + b1 * cy);
        let (aa, bb) = (a0 * a0 + a1 * a1, b0 * b0 + b1 * b1);
        let r2 = Wide::splat(self.spread2()) * (aa + bb);
        let cc = c0 * c0 + c1 * c1;
        let mut general = r2.is_finite() & cc.is_finite();
        general &= !cc.simd_gt(Wide::splat(2.0) + Wide::splat(2.0) * r2);
        let four_r2 = Wide::splat(4.0) * r2;
        general &= !four_r2.simd_lt(Wide::splat(POINT_SIZE * POINT_SIZE));
        let mut x: [Wide; 4] = std::array::from_fn(|k| {
            let (al, be) = (Wide::splat(alpha[k]), Wide::splat(beta[k]));
            s0 + a0 * al + b0 * be
        });
        let mut y: [Wide; 4] = std::array::from_fn(|k| {
            let (al, be) = (Wide::splat(alpha[k]), Wide::splat(beta[k]));
            s1 + a1 * al + b1 * be
        });
        let inside = (0..4).fold(Wide::ZERO.simd_eq(Wide::ZERO), |m, k| {
            m & (x[k] * x[k] + y[k] * y[k]).simd_le(Wide::ONE)
        });
        // Inside the disc: the kernel's mean from the area moments, as `classify` takes it.
        let inside_lanes = general & inside;
        let [ma, mb, maa, mab, mbb] = self.moments().map(Wide::splat);
        let two = Wide::splat(2.0);
        let (sa, sb) = (s0 * a0 + s1 * a1, s0 * b0 + s1 * b1);
        let mean_u2 = (s0 * s0 + s1 * s1)
            + two * (ma * sa + mb * sb)
            + maa * aa
            + two * mab * (a0 * b0 + a1 * b1)
            + mbb * bb;
        let mut means = Wide::ONE - mean_u2;
        general &= !inside;
        let beyond = cc - Wide::ONE - r2;
        general &= !(beyond.simd_ge(Wide::ZERO) & (beyond * beyond).simd_ge(four_r2));
        let cross = a0 * b1 - a1 * b0;
        let signed = cross * Wide::splat(self.signed_area());
        let area = signed.abs();
        let thin = Wide::splat(MIN_WIDTH * MIN_WIDTH * 4.0) * r2 * four_r2.min(Wide::ONE);
        general &= (area * area).simd_gt(thin);
        let small = area.simd_lt(Wide::splat(PI));
        let large = general & !small;
        general &= small;
        // Counter-clockwise in filter space: vertices 1 and 3 swapped where the placement
        // mirrors the quadrilateral.
        let mirrored = signed.simd_lt(Wide::ZERO);
        (x[1], x[3]) = (
            mirrored.bitselect(x[3], x[1]),
            mirrored.bitselect(x[1], x[3]),
        );
        (y[1], y[3]) = (
            mirrored.bitselect(y[3], y[1]),
            mirrored.bitselect(y[1], y[3]),
        );
        // An area of pi or more (photons smaller than the pixel, common at a million photons):
        // every side's line at least 1 from the centre puts the disc inside, one at -1 or
        // beyond leaves them apart (left to `classify`, rare), else the general formula; each
        // side's signed distance as `classify` takes it, whichever order it meets them in.
        let mut disc_inside = large;
        if large.any() {
            let (mut apart, mut all_outside) = (!large, large);
            for k in 0..4 {
                let (ex, ey) = (x[(k + 1) % 4] - x[k], y[(k + 1) % 4] - y[k]);
                let h = (x[k] * ey - y[k] * ex) / (ex * ex + ey * ey).sqrt();
                apart |= h.simd_le(-Wide::ONE);
                all_outside &= h.simd_ge(Wide::ONE);
            }
            general |= large & !apart & !all_outside;
            disc_inside &= !apart & all_outside;
            means = disc_inside.bitselect(Wide::splat(FRAC_PI_2) / area, means);
        }
        let mut vertices = [[0.0; LANES]; 8];
        for (column, v) in vertices.iter_mut().zip(x.iter().chain(&y)) {
            *column = v.to_array();
        }
        GeneralQuads {
            mask: general.to_bitmask(),
            vertices,
            inside: inside_lanes.to_bitmask(),
            disc_inside: disc_inside.to_bitmask(),
            means: means.to_array(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::quad::QuadOverlap;
    use super::super::{classify, Overlap};
    use super::*;

    /// Placements of every kind: inside, crossing, apart, holding the disc, thin, tiny, huge,
    /// mirrored, non-finite.
    fn placements() -> Vec<(DVec2, DVec2, DVec2)> {
        let mut out = Vec::new();
        for k in 0..6000 {
            let t = k as f64;
            let scale = [1e-7, 0.01, 0.3, 1.0, 2.5, 8.0][k % 6];
            let s = DVec2::new((t * 0.37).sin(), (t * 0.53).cos()) * (1.6 * (t * 0.11).sin());
            let a = DVec2::new((t * 0.7).cos(), (t * 0.3).sin()) * scale;
            let mut b = DVec2::new(-(t * 0.29).sin(), (t * 0.41).cos()) * scale * 0.8;
            if k % 7 == 0 {
                // Nearly parallel edges: thin.
                b = a * 0.5 + a.perp() * 1e-9 * (t * 0.13).sin();
            }
            if k % 11 == 0 {
                b = -b;
            }
            out.push((s, a, b));
        }
        out.push((DVec2::new(f64::NAN, 0.0), DVec2::X, DVec2::Y));
        out.push((DVec2::ZERO, DVec2::new(f64::INFINITY, 0.0), DVec2::Y));
        out
    }

    /// A chunk's placements in lanes (padded with far ones).
    fn lanes(chunk: &[(DVec2, DVec2, DVec2)]) -> Placements {
        let column = |f: fn(&(DVec2, DVec2, DVec2)) -> f64| {
            Wide::from(std::array::from_fn(|k| chunk.get(k).map_or(1e6, f)))
        };
        Placements {
            s: [column(|p| p.0.x), column(|p| p.0.y)],
            a: [column(|p| p.1.x), column(|p| p.1.y)],
            b: [column(|p| p.2.x), column(|p| p.2.y)],
        }
    }

    #[test]
    fn parallelograms_in_lanes_are_classified_as_alone() {
        let (mut general, mut settled, mut left) = (0, 0, 0);
        for chunk in placements().chunks(LANES) {
            let lanes = classify_parallelograms(&lanes(chunk));
            for (k, &(s, a, b)) in chunk.iter().enumerate() {
                let scalar = classify(s, a, b);
                match (lanes.general >> k & 1, lanes.settled >> k & 1) {
                    (1, 0) => {
                        general += 1;
                        assert_eq!(scalar, Overlap::General { s, a, b }, "{s} {a} {b}");
                    }
                    (0, 1) => {
                        settled += 1;
                        let mean = lanes.means[k];
                        match scalar {
                            Overlap::None => assert_eq!(mean, 0.0, "{s} {a} {b}"),
                            Overlap::Mean(m) => assert_eq!(mean, m, "{s} {a} {b}"),
                            _ => panic!("{s} {a} {b}: {scalar:?}, settled at {mean}"),
                        }
                    }
                    (0, 0) => {
                        // Only a thickened one is left to the scalar classification.
                        left += 1;
                        let Overlap::General { a: ta, b: tb, .. } = scalar else {
                            panic!("{s} {a} {b}: {scalar:?} left");
                        };
                        assert_ne!((ta, tb), (a, b), "{s} {a} {b}");
                    }
                    _ => panic!("{s} {a} {b}: both"),
                }
            }
        }
        assert!(
            general > 1000 && settled > 1000 && left > 50,
            "{general} {settled} {left}"
        );
    }

    #[test]
    fn quadrilaterals_in_lanes_are_classified_as_alone() {
        let frame = QuadFrame::new([
            DVec2::new(-0.5, -0.45),
            DVec2::new(0.52, -0.5),
            DVec2::new(0.55, 0.5),
            DVec2::new(-0.47, 0.53),
        ])
        .expect("convex");
        let (mut marked, mut large, mut inside, mut disc_inside, mut left) = (0, 0, 0, 0, 0);
        for chunk in placements().chunks(LANES) {
            let found = frame.general_lanes(&lanes(chunk));
            assert_eq!(found.mask & found.inside, 0);
            assert_eq!(found.mask & found.disc_inside, 0);
            assert_eq!(found.inside & found.disc_inside, 0);
            for (k, &(s, a, b)) in chunk.iter().enumerate() {
                let scalar = frame.classify(s, a, b);
                let mean = found.means[k];
                if found.mask >> k & 1 == 1 {
                    marked += 1;
                    let v = found.lane(k);
                    assert_eq!(scalar, QuadOverlap::General(v), "{s} {a} {b}");
                    let area = (a.perp_dot(b) * frame.signed_area()).abs();
                    large += usize::from(area >= PI);
                } else if found.inside >> k & 1 == 1 {
                    inside += 1;
                    assert_eq!(scalar, QuadOverlap::Mean(mean), "{s} {a} {b}");
                } else if found.disc_inside >> k & 1 == 1 {
                    disc_inside += 1;
                    assert_eq!(scalar, QuadOverlap::DiscInside(mean), "{s} {a} {b}");
                } else {
                    // Left to the scalar classification: apart, a point, thin, not finite.
                    left += 1;
                    assert!(
                        !matches!(scalar, QuadOverlap::General(_) | QuadOverlap::DiscInside(_)),
                        "{s} {a} {b}: {scalar:?} left"
                    );
                }
            }
        }
        assert!(
            marked > 1000 && large > 100 && inside > 100 && disc_inside > 100 && left > 100,
            "{marked} {large} {inside} {disc_inside} {left}"
        );
    }
}
