//! A regular polygon's affine image clipped to the unit square from the pieces of the two
//! boundaries that bound the intersection, its edges in SIMD lanes, without building either.
//!
//! Why: the coplanar estimate clips millions of ellipse polygons that cross the view square's
//! sides; building each image and clipping it a side at a time (a branch a vertex a side, where
//! the next vertex's side is anyone's guess), then taking its shoelace sums, took most of its
//! render stage at a million photons. By Green's theorem the shoelace sums of the intersection
//! are those of its boundary's pieces taken in any order: the polygon's edges (or their parts)
//! inside the square, and the square's sides (or their parts) inside the polygon. In the regular
//! polygon's frame each side of the square is a line `h - n . u = 0`; every edge is cut to the
//! part all the sides keep at once (eight edges a lane each, no branch), and each side that
//! cuts vertices off crosses the polygon in one chord, between the edges that leave and re-enter
//! its kept half, of which it counts as much as the other sides keep.

use glam::DVec2;
use wide::f64x8;

/// The most vertices handled here (one bit each in a `u64`); a polygon with more is clipped as
/// a polygon.
const MOST_VERTICES: usize = 64;

/// A regular polygon's edges (edge `k` from vertex `k` to vertex `k + 1`) in blocks of eight
/// SIMD lanes, the last padded with edges of no length.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Edges {
    /// Start and end of each edge, x and y: `[px, py, qx, qy]` a block.
    blocks: Vec<[f64x8; 4]>,
    vertices: Vec<DVec2>,
    /// Twice the polygon's area.
    twice_area: f64,
}

/// A side of the square in the polygon's frame: `offset - normal . u`, negative where it cuts.
#[derive(Debug, Clone, Copy, Default)]
struct Side {
    normal: DVec2,
    offset: f64,
    /// The vertices it cuts, one bit each.
    mask: u64,
}

impl Side {
    fn distance(&self, u: DVec2) -> f64 {
        self.offset - self.normal.dot(u)
    }
}

/// Twice the area and three times the moment of the segment `p -> q` against the origin.
fn terms(p: DVec2, q: DVec2) -> (f64, DVec2) {
    let c = p.perp_dot(q);
    (c, (p + q) * c)
}

impl Edges {
    /// The edges of `vertices` (a regular polygon, counter-clockwise).
    pub(super) fn new(vertices: &[DVec2]) -> Self {
        let n = vertices.len();
        // Edge `k`'s ends; past the last edge, the first vertex to itself (no length).
        let ends = |k: usize| match k < n {
            true => (vertices[k], vertices[(k + 1) % n]),
            false => (vertices[0], vertices[0]),
        };
        let column = |block: usize, pick: fn((DVec2, DVec2)) -> f64| {
            f64x8::from(std::array::from_fn::<f64, 8, _>(|lane| {
                pick(ends(block * 8 + lane))
            }))
        };
        let blocks = (0..n.div_ceil(8))
            .map(|b| {
                [
                    column(b, |(p, _)| p.x),
                    column(b, |(p, _)| p.y),
                    column(b, |(_, q)| q.x),
                    column(b, |(_, q)| q.y),
                ]
            })
            .collect();
        Edges {
            blocks,
            vertices: vertices.to_vec(),
            twice_area: (0..n).map(|k| terms(ends(k).0, ends(k).1).0).sum(),
        }
    }

    /// Area and centroid of the image `centre + x a + y b` (`det = a x b`, finite and non-zero)
    /// inside the square's sides that `crossed` marks (`x <= 1/2`, `x >= -1/2`, `y <= 1/2`,
    /// `y >= -1/2`; an unmarked side must not cut the polygon), as `clip_by_sides` gives them
    /// up to rounding; `None` where rounding makes a side cut the polygon's vertices in more than
    /// one run, or the polygon has more than [`MOST_VERTICES`], and it must be clipped.
    pub(super) fn clip(
        &self,
        centre: DVec2,
        a: DVec2,
        b: DVec2,
        det: f64,
        crossed: [bool; 4],
    ) -> Option<(f64, DVec2)> {
        let n = self.vertices.len();
        if n > MOST_VERTICES {
            return None;
        }
        let all = u64::MAX >> (64 - n);
        let mut sides = [Side::default(); 4];
        let mut count = 0;
        let rules = [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)];
        for ((axis, sign), _) in rules.into_iter().zip(crossed).filter(|(_, c)| *c) {
            // `sign (centre + x a + y b)[axis] <= 1/2`.
            sides[count] = Side {
                normal: DVec2::new(a[axis], b[axis]) * sign,
                offset: 0.5 - sign * centre[axis],
                mask: 0,
            };
            count += 1;
        }
        let sides = &mut sides[..count];
        let zero = f64x8::ZERO;
        let (mut a2, mut mx, mut my) = (zero, zero, zero);
        for (block, &[px, py, qx, qy]) in self.blocks.iter().enumerate() {
            // Each edge's part `[t0, t1]` that every side keeps (Liang and Barsky).
            let (mut t0, mut t1, mut gone) = (zero, f64x8::ONE, zero);
            for side in sides.iter_mut() {
                let (nx, ny) = (f64x8::splat(side.normal.x), f64x8::splat(side.normal.y));
                let h = f64x8::splat(side.offset);
                let dp = h - (nx * px + ny * py);
                let dq = h - (nx * qx + ny * qy);
                let (p_cut, q_cut) = (dp.simd_lt(zero), dq.simd_lt(zero));
                side.mask |= u64::from(p_cut.to_bitmask()) << (8 * block);
                let t = dp / (dp - dq);
                gone |= p_cut & q_cut;
                t0 = p_cut.bitselect(t0.max(t), t0);
                t1 = q_cut.bitselect(t1.min(t), t1);
            }
            let kept = t0.simd_lt(t1) & !gone;
            let (ex, ey) = (qx - px, qy - py);
            let (sx, sy) = (px + ex * t0, py + ey * t0);
            let (fx, fy) = (px + ex * t1, py + ey * t1);
            let c = sx * fy - sy * fx;
            a2 += kept.bitselect(c, zero);
            mx += kept.bitselect((sx + fx) * c, zero);
            my += kept.bitselect((sy + fy) * c, zero);
        }
        let (mut a2, mut m) = (
            a2.reduce_add(),
            DVec2::new(mx.reduce_add(), my.reduce_add()),
        );
        // Bit k of `next(m)` is bit k + 1 of m, of `prev(m)` bit k - 1, around the polygon.
        let next = |m: u64| (m >> 1) | ((m & 1) << (n - 1));
        let prev = |m: u64| ((m << 1) & all) | (m >> (n - 1));
        for side in sides.iter_mut() {
            side.mask &= all;
            if side.mask == all {
                return Some((0.0, DVec2::ZERO));
            }
            // A convex polygon's vertices beyond a line are one run around it.
            if side.mask != 0 && (side.mask & !prev(side.mask)).count_ones() != 1 {
                return None;
            }
        }
        let sides = &*sides;
        // Each cutting side's chord, from the edge that leaves its kept half to the one that
        // comes back (counter-clockwise about the kept part), as far as the others keep it.
        for (i, side) in sides.iter().enumerate().filter(|(_, s)| s.mask != 0) {
            let first = (side.mask & !prev(side.mask)).trailing_zeros() as usize;
            let last = (side.mask & !next(side.mask)).trailing_zeros() as usize;
            let on_edge = |k: usize| {
                let (p, q) = (self.vertices[k], self.vertices[(k + 1) % n]);
                let (dp, dq) = (side.distance(p), side.distance(q));
                p + (q - p) * (dp / (dp - dq))
            };
            let (enter, leave) = (on_edge((first + n - 1) % n), on_edge(last));
            let (mut t0, mut t1) = (0.0f64, 1.0f64);
            for (_, other) in sides.iter().enumerate().filter(|&(j, _)| j != i) {
                let (dp, dq) = (other.distance(enter), other.distance(leave));
                if dp < 0.0 && dq < 0.0 {
                    t1 = -1.0;
                } else if dp < 0.0 {
                    t0 = t0.max(dp / (dp - dq));
                } else if dq < 0.0 {
                    t1 = t1.min(dp / (dp - dq));
                }
            }
            if t0 < t1 {
                let chord = leave - enter;
                let (c, cm) = terms(enter + chord * t0, enter + chord * t1);
                a2 += c;
                m += cm;
            }
        }
        // Numbers past overflow (edge vectors near f64's range) are left to the polygon's
        // clipping, which answers them as it answers any polygon.
        if !(a2.is_finite() && m.is_finite()) {
            return None;
        }
        // What rounding leaves of an empty intersection is no area.
        if a2 <= 1e-12 * self.twice_area {
            return Some((0.0, DVec2::ZERO));
        }
        let c = m / (3.0 * a2);
        let centroid = centre + a * c.x + b * c.y;
        centroid
            .is_finite()
            .then_some((0.5 * a2 * det.abs(), centroid))
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::{ellipse, ClipScratch};
    use super::super::clip_to_unit_square;
    use super::*;

    #[test]
    fn the_boundary_pieces_give_the_clipped_polygon() {
        let mut scratch = ClipScratch::default();
        for n in [3, 5, 8, 16, 17, 33, 64] {
            let unit = super::super::UnitPolygon::new(n);
            // Cases by how many of the square's sides cut the polygon's vertices.
            let mut by_sides = [0; 5];
            let mut settled = 0;
            for k in 0..6000 {
                let t = k as f64;
                let scale = [0.1, 0.5, 2.0][k % 3];
                let centre = DVec2::new((t * 0.37).sin(), (t * 0.53).cos()) * (0.3 + scale);
                let a = DVec2::new((t * 0.7).cos(), (t * 0.3).sin()) * scale;
                let b = DVec2::new(-(t * 0.29).sin(), (t * 0.41).cos()) * scale * 0.7;
                let det = a.perp_dot(b);
                if det.abs() < 1e-9 {
                    continue;
                }
                let polygon = ellipse(centre, a, b, n);
                let expected = clip_to_unit_square(&polygon, &mut scratch);
                let Some(got) = unit.edges.clip(centre, a, b, det, [true; 4]) else {
                    continue;
                };
                settled += 1;
                assert!(
                    (got.0 - expected.0).abs() <= 1e-12 * expected.0.max(1.0),
                    "{n}-gon {k}: {got:?} vs {expected:?}"
                );
                if expected.0 > 1e-9 {
                    assert!((got.1 - expected.1).length() <= 1e-9, "{n}-gon {k}");
                }
                let cut = |f: fn(DVec2) -> bool| polygon.iter().any(|&p| f(p)) as usize;
                let sides = cut(|p| p.x > 0.5)
                    + cut(|p| p.x < -0.5)
                    + cut(|p| p.y > 0.5)
                    + cut(|p| p.y < -0.5);
                by_sides[sides] += 1;
            }
            assert!(settled > 5900, "{n}-gon: {settled} of 6000 settled");
            assert!(
                by_sides.iter().all(|&c| c > 50),
                "{n}-gon: by sides cut {by_sides:?}"
            );
        }
    }
}
