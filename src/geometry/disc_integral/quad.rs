//! The integral of `1 - |u|^2` over the unit disc ∩ a convex quadrilateral: the exact view
//! footprint of a pixel seen on a plane through a pinhole, of which the parallelogram of
//! [`super`] is the first-order approximation.
//!
//! Why it is needed: a pinhole maps a pixel onto a plane as a perspective quadrilateral, and
//! neighbouring pixels' quadrilaterals share their corners, so they tile the plane. The
//! parallelograms of first-order ray differentials do not: each is centred on its own pixel's
//! centre ray with its own edges, and neighbours overlap or leave gaps by a second-order sliver
//! (~0.3% of a pixel on the focal caustic's floor). Light concentrated in that sliver (a caustic's
//! focus on a pixel boundary) is counted twice or not at all.
//!
//! The derivation is the parallelogram's (the flux of `F(u) = (1/2 - |u|^2/4) u` through the
//! sides of the fan triangles, see [`super`]); only the sides are given by their ends: the side
//! from `p` to `q` of a counter-clockwise polygon has tangent `tau = (q - p) / |q - p|`, outward
//! distance `h = p x tau` (the right normal's component) and runs over `t in [p . tau, q . tau]`.
//! The fast paths are the parallelogram's too: inside the disc the polygon moments (about the
//! vertices' centroid, which keeps them exact for small quadrilaterals far from the origin),
//! the disc inside (every `h >= 1`), a separating side (some `h <= -1`).

use super::moment::first_moment;
use super::rows::Rows;
use super::{one_arc_flux, one_arc_flux_clipped, side, Clipped, Lane, ONE_ARC_MAX_CIRCUMRADIUS};
use crate::geometry::disc_integral::rows::Wide;
use glam::DVec2;

pub use super::quad_frame::QuadFrame;

/// What [`classify_quad`] settles for a quadrilateral.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum QuadOverlap {
    /// No overlap with the disc's interior: the mean is 0.
    None,
    /// The mean of `(1 - |u|^2)+` over the quadrilateral, in closed form (the quadrilateral
    /// inside the disc, or so small that the kernel is its value at the centre).
    Mean(f64),
    /// The disc lies inside the quadrilateral: the mean is `(pi / 2) / area`, and the kernel's
    /// mass sits about the disc's centre (what a weight over the quadrilateral needs to know,
    /// `estimate::ExactFootprint::weight_in_filter_space`).
    DiscInside(f64),
    /// Needs the general formula ([`general_quad`]) on these vertices (counter-clockwise).
    General([DVec2; 4]),
    /// Not a convex quadrilateral of usable width (crossed, folded or nearly flat): the caller
    /// falls back to the parallelogram, whose thin case [`super::classify`] handles.
    NotConvex,
}

/// The four sides of the counter-clockwise quadrilateral `(x[k], y[k])` as [`side`] takes them,
/// `(h, t0, t1)` each, their unit tangents, and its area.
#[inline(always)]
fn quad_sides<T: Lane>(x: [T; 4], y: [T; 4]) -> QuadSides<T> {
    let mut sides = [(T::splat(0.0), T::splat(0.0), T::splat(0.0)); 4];
    let mut tangents = [(T::splat(0.0), T::splat(0.0)); 4];
    let mut twice_area = T::splat(0.0);
    for k in 0..4 {
        let (px, py, qx, qy) = (x[k], y[k], x[(k + 1) % 4], y[(k + 1) % 4]);
        let (ex, ey) = (qx - px, qy - py);
        let l = (ex * ex + ey * ey).sqrt();
        let inv = T::splat(1.0) / l;
        // t1 = q . tau = p . tau + l.
        let t0 = (px * ex + py * ey) * inv;
        sides[k] = ((px * ey - py * ex) * inv, t0, t0 + l);
        tangents[k] = (ex * inv, ey * inv);
        // Relative to the first vertex: no cancellation for a small quadrilateral far away.
        twice_area = twice_area + (px - x[0]) * (qy - y[0]) - (qx - x[0]) * (py - y[0]);
    }
    (sides, tangents, T::splat(0.5) * twice_area)
}

/// What [`quad_sides`] gives: sides `(h, t0, t1)`, unit tangents, area.
type QuadSides<T> = ([(T, T, T); 4], [(T, T); 4], T);

/// `(integral over Q ∩ D of (1 - |u|^2), area of Q)` for the convex counter-clockwise
/// quadrilateral `Q` with vertices `(x[k], y[k])`, four `atan2`s (any size).
#[inline(always)]
pub fn general_quad<T: Lane>(x: [T; 4], y: [T; 4]) -> (T, T) {
    let (e, _, area) = quad_sides(x, y);
    let integral = e
        .iter()
        .fold(T::splat(0.0), |sum, &(h, t0, t1)| sum + side(h, t0, t1));
    (integral, area)
}

/// [`general_quad`] with one `atan2` (as [`super::general_one_arc`]), for quadrilaterals whose
/// vertices lie within [`ONE_ARC_MAX_CIRCUMRADIUS`] of their centroid ([`quad_takes_one_arc`]).
#[inline(always)]
pub fn general_quad_one_arc<T: Lane>(x: [T; 4], y: [T; 4]) -> (T, T) {
    let (e, _, area) = quad_sides(x, y);
    (one_arc_flux(e), area)
}

/// Positive where the quadrilateral takes [`general_quad_one_arc`].
#[inline(always)]
pub fn quad_takes_one_arc<T: Lane>(x: [T; 4], y: [T; 4]) -> T {
    let quarter = T::splat(0.25);
    let (cx, cy) = (
        (x[0] + x[1] + x[2] + x[3]) * quarter,
        (y[0] + y[1] + y[2] + y[3]) * quarter,
    );
    let mut r2 = T::splat(0.0);
    for k in 0..4 {
        let (dx, dy) = (x[k] - cx, y[k] - cy);
        r2 = r2.max(dx * dx + dy * dy);
    }
    T::splat(ONE_ARC_MAX_CIRCUMRADIUS * ONE_ARC_MAX_CIRCUMRADIUS) - r2
}

/// [`general_quad_one_arc`], or [`general_quad`] where it does not serve, for one
/// counter-clockwise quadrilateral.
pub fn general_quad_either(v: [DVec2; 4]) -> (f64, f64) {
    let (x, y) = (v.map(|p| p.x), v.map(|p| p.y));
    if quad_takes_one_arc(x, y) >= 0.0 {
        general_quad_one_arc(x, y)
    } else {
        general_quad(x, y)
    }
}

/// Settles the quadrilateral with vertices `v` (in order, either direction) where a closed form
/// does and prepares the rest: [`QuadFrame::classify`] in the unit basis.
pub fn classify_quad(v: [DVec2; 4]) -> QuadOverlap {
    match QuadFrame::new(v) {
        Some(frame) => frame.classify(DVec2::ZERO, DVec2::X, DVec2::Y),
        None if v.iter().all(|p| p.is_finite()) => QuadOverlap::NotConvex,
        None => QuadOverlap::None,
    }
}

/// The mean of `(1 - |u|^2)+` over the quadrilateral with vertices `v` in order (either
/// direction), or `None` where it is not a usable convex quadrilateral
/// ([`QuadOverlap::NotConvex`]).
pub fn quad_mean(v: [DVec2; 4]) -> Option<f64> {
    match classify_quad(v) {
        QuadOverlap::None => Some(0.0),
        QuadOverlap::Mean(m) | QuadOverlap::DiscInside(m) => Some(m),
        QuadOverlap::General(v) => {
            let (integral, area) = general_quad_either(v);
            Some((integral / area).max(0.0))
        }
        QuadOverlap::NotConvex => None,
    }
}

/// Quadrilaterals for the general formula: rows of the four vertices' `x`, then their `y`, then
/// a weight `k0 + kx u_x + ky u_y` over the quadrilateral (`[1, 0, 0]`: none).
pub type QuadBatch = Rows<11>;

impl Rows<11> {
    /// Adds a counter-clockwise convex quadrilateral (as [`QuadOverlap::General`] gives it).
    pub fn push(&mut self, v: [DVec2; 4]) {
        self.push_weighted(v, [1.0, 0.0, 0.0]);
    }

    /// Adds a counter-clockwise convex quadrilateral with the weight `k[0] + k[1] u_x + k[2]
    /// u_y` over it.
    pub fn push_weighted(&mut self, v: [DVec2; 4], k: [f64; 3]) {
        let [p0, p1, p2, p3] = v;
        self.push_row([
            p0.x, p1.x, p2.x, p3.x, p0.y, p1.y, p2.y, p3.y, k[0], k[1], k[2],
        ]);
    }
}

/// The first moment of `(1 - |u|^2)+` over the convex counter-clockwise quadrilateral
/// `(x[k], y[k])` ∩ the unit disc ([`super::moment`]).
#[inline(always)]
pub fn quad_first_moment<T: Lane>(x: [T; 4], y: [T; 4]) -> (T, T) {
    let (sides, tangents, _) = quad_sides(x, y);
    first_moment(&sides.map(|(h, t0, t1)| Clipped::new(h, t0, t1)), &tangents)
}

/// For each quadrilateral of `batch`, the mean of `(1 - |u|^2)+` times its weight over it by
/// the general formula (a linear weight needs the kernel's integral and first moment),
/// [`super::rows::LANES`] at a time in SIMD lanes (as `estimate::integrated::parallelogram_means`).
pub fn quad_means(batch: &mut QuadBatch, out: &mut Vec<f64>) {
    out.clear();
    let len = batch.len();
    // Padding: unit squares far from the disc.
    let far = [
        1e6,
        1e6 + 1.0,
        1e6 + 1.0,
        1e6,
        0.0,
        0.0,
        1.0,
        1.0,
        1.0,
        0.0,
        0.0,
    ];
    for [x0, x1, x2, x3, y0, y1, y2, y3, k0, kx, ky] in batch.chunks(far) {
        let (x, y) = ([x0, x1, x2, x3], [y0, y1, y2, y3]);
        // The sides once, for the integral and the first moment alike.
        let (sides, tangents, area) = quad_sides(x, y);
        let clipped = sides.map(|(h, t0, t1)| Clipped::new(h, t0, t1));
        let integral = if quad_takes_one_arc(x, y).simd_ge(Wide::ZERO).all() {
            one_arc_flux_clipped(&clipped)
        } else {
            clipped.iter().fold(Wide::ZERO, |sum, c| sum + c.flux())
        };
        let (mx, my) = first_moment(&clipped, &tangents);
        let weighted = k0 * integral + kx * mx + ky * my;
        // Where the integral is 0 (tangency, rounding) so is the weighted one.
        let weighted = integral.simd_gt(Wide::ZERO).bitselect(weighted, Wide::ZERO);
        out.extend_from_slice(&(weighted / area).max(Wide::ZERO).to_array());
    }
    out.truncate(len);
}

#[cfg(test)]
mod tests {
    use super::super::{mean, Overlap};
    use super::*;

    fn parallelogram(s: DVec2, a: DVec2, b: DVec2) -> [DVec2; 4] {
        [
            s - a * 0.5 - b * 0.5,
            s + a * 0.5 - b * 0.5,
            s + a * 0.5 + b * 0.5,
            s - a * 0.5 + b * 0.5,
        ]
    }

    #[test]
    fn a_parallelogram_as_a_quadrilateral_has_the_parallelograms_mean() {
        for k in 0..200 {
            let t = k as f64 * 0.173;
            let size = 10f64.powf(-3.0 + 5.0 * ((k * 7) % 200) as f64 / 200.0);
            let s = DVec2::new(t.sin() * 1.3, (1.7 * t).cos() * 1.1) * (1.0 + size * 0.3);
            let a = DVec2::new(1.0 + 0.5 * t.cos(), 0.3) * size;
            let b = DVec2::new(-0.2, 0.8 + 0.4 * (2.0 * t).sin()) * size;
            let expected = mean(s, a, b);
            for v in [parallelogram(s, a, b), parallelogram(s, b, a)] {
                let got = quad_mean(v).expect("convex");
                assert!(
                    // Means are at most 1; near tangency the general formula's cancellation
                    // leaves ~1e-12 where the parallelogram's test settles 0.
                    (got - expected).abs() <= 1e-10,
                    "{got} vs {expected} ({s:?} {a:?} {b:?}: {:?} / {:?})",
                    classify_quad(v),
                    super::super::classify(s, a, b)
                );
            }
        }
    }

    #[test]
    fn the_fast_paths_agree_with_the_general_formula() {
        // Trapezoids (the shape perspective gives) at every place about the disc.
        for k in 0..400 {
            let t = k as f64 * 0.0917;
            let size = [0.05, 0.4, 1.5, 6.0][k % 4];
            let c = DVec2::new(t.cos(), t.sin()) * (k as f64 / 400.0 * (1.5 + size));
            let v = [
                c + DVec2::new(-0.5, -0.5) * size,
                c + DVec2::new(0.5, -0.4) * size,
                c + DVec2::new(0.6, 0.55) * size,
                c + DVec2::new(-0.45, 0.5) * size,
            ];
            let fast = quad_mean(v).unwrap();
            let (integral, area) = general_quad(v.map(|p| p.x), v.map(|p| p.y));
            let general = (integral / area).max(0.0);
            assert!(
                (fast - general).abs() <= 1e-10,
                "{fast} vs {general} ({:?})",
                classify_quad(v)
            );
            let (one, _) = general_quad_one_arc(v.map(|p| p.x), v.map(|p| p.y));
            assert!(
                (one - integral).abs() <= 1e-12 * area.max(1.0),
                "{one} vs {integral}"
            );
        }
    }

    #[test]
    fn crossed_and_flat_quadrilaterals_are_not_convex_and_bad_input_is_none() {
        let crossed = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
        ];
        assert_eq!(classify_quad(crossed), QuadOverlap::NotConvex);
        // Flat across the circle: the parallelogram's thickening serves; inside the disc the
        // polygon moments hold whatever the width.
        let flat = [
            DVec2::new(0.5, 0.0),
            DVec2::new(1.5, 0.0),
            DVec2::new(1.5, 1e-9),
            DVec2::new(0.5, 1e-9),
        ];
        assert_eq!(classify_quad(flat), QuadOverlap::NotConvex);
        let inside = flat.map(|p| p * 0.5);
        let expected = 1.0 - (0.25f64.powi(3) - 0.75f64.powi(3)) / (3.0 * (0.25 - 0.75));
        match classify_quad(inside) {
            QuadOverlap::Mean(m) => assert!((m - expected).abs() < 1e-12, "{m} vs {expected}"),
            other => panic!("{other:?}"),
        }
        let mut nan = flat;
        nan[2].x = f64::NAN;
        assert_eq!(classify_quad(nan), QuadOverlap::None);
        assert!(matches!(
            super::super::classify(DVec2::ZERO, DVec2::X, DVec2::Y),
            Overlap::Mean(_)
        ));
    }

    /// `(integral, first moment)` of `(1 - |u|^2)+` over the convex polygon `v` by the
    /// midpoint rule on an `n x n` grid over its bounding box.
    fn brute_force(v: [DVec2; 4], n: usize) -> (f64, DVec2) {
        let (lo, hi) = v
            .iter()
            .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(l, h), &p| {
                (l.min(p), h.max(p))
            });
        let cell = (hi - lo) / n as f64;
        let inside = |p: DVec2| (0..4).all(|k| (v[(k + 1) % 4] - v[k]).perp_dot(p - v[k]) >= 0.0);
        let (mut integral, mut moment) = (0.0, DVec2::ZERO);
        for i in 0..n {
            for j in 0..n {
                let p = lo + cell * DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
                let k = (1.0 - p.length_squared()).max(0.0);
                if k > 0.0 && inside(p) {
                    integral += k;
                    moment += p * k;
                }
            }
        }
        let da = cell.x * cell.y;
        (integral * da, moment * da)
    }

    fn trapezoid(c: DVec2, size: f64) -> [DVec2; 4] {
        [
            c + DVec2::new(-0.5, -0.5) * size,
            c + DVec2::new(0.5, -0.4) * size,
            c + DVec2::new(0.6, 0.55) * size,
            c + DVec2::new(-0.45, 0.5) * size,
        ]
    }

    #[test]
    fn the_first_moment_equals_quadrature_across_the_circle() {
        // Trapezoids across the circle, inside it, holding it, and touching it at a corner.
        for k in 0..24 {
            let t = k as f64 * 0.61;
            let size = [0.3, 0.9, 2.5][k % 3];
            let c = DVec2::new(t.cos(), t.sin()) * [0.2, 0.8, 1.1, 1.3][k % 4];
            let v = trapezoid(c, size);
            let (x, y) = (v.map(|p| p.x), v.map(|p| p.y));
            let (mx, my) = quad_first_moment(x, y);
            let (integral, moment) = brute_force(v, 1500);
            let tolerance = 2e-5 * size * size;
            assert!(
                (mx - moment.x).abs() <= tolerance && (my - moment.y).abs() <= tolerance,
                "{k}: ({mx}, {my}) vs {moment} (integral {integral})"
            );
        }
    }

    #[test]
    fn inside_the_disc_the_moments_centroid_is_the_first_moments() {
        // A quadrilateral frame placed by (s, a, b) inside the disc: the kernel's centroid from
        // the frame's area moments equals the general formula's first moment over its
        // integral (tested against quadrature above), mapped back to the frame's coordinates.
        let shape = trapezoid(DVec2::new(0.05, -0.02), 1.0);
        let frame = QuadFrame::new(shape).unwrap();
        for k in 0..20 {
            let t = k as f64 * 0.47;
            let (s, a, b) = (
                DVec2::new(0.3 * t.cos(), 0.25 * t.sin()),
                DVec2::new(0.3 + 0.1 * t.sin(), 0.05) * 0.8,
                DVec2::new(-0.06, 0.25 + 0.1 * t.cos()) * 0.8,
            );
            let QuadOverlap::Mean(mean) = frame.classify(s, a, b) else {
                panic!("{k}: not inside");
            };
            let centroid = frame.kernel_centroid(s, a, b, mean);
            let v = shape.map(|p| s + a * p.x + b * p.y);
            let (integral, _) = general_quad_either(v);
            let (mx, my) = quad_first_moment(v.map(|p| p.x), v.map(|p| p.y));
            let c = DVec2::new(mx, my) / integral - s;
            let det = a.perp_dot(b);
            let expected = DVec2::new(c.perp_dot(b), a.perp_dot(c)) / det;
            assert!(
                (centroid - expected).length() <= 1e-12,
                "{k}: {centroid} vs {expected}"
            );
        }
    }

    #[test]
    fn simd_lanes_equal_the_scalar_formula() {
        let mut batch = QuadBatch::default();
        let mut expected = Vec::new();
        for k in 0..23 {
            let t = k as f64 * 0.37;
            let c = DVec2::new(t.sin() * 1.2, t.cos() * 0.9);
            let s = 0.3 + t;
            let v = [
                c + DVec2::new(-0.5, -0.5) * s,
                c + DVec2::new(0.5, -0.45) * s,
                c + DVec2::new(0.55, 0.5) * s,
                c + DVec2::new(-0.5, 0.45) * s,
            ];
            batch.push(v);
            let (integral, area) = general_quad_either(v);
            expected.push((integral / area).max(0.0));
        }
        let mut simd = Vec::new();
        quad_means(&mut batch, &mut simd);
        assert_eq!(simd.len(), 23);
        for (a, b) in simd.iter().zip(&expected) {
            assert!((a - b).abs() <= 1e-14, "{a} {b}");
        }
        assert!(expected.iter().any(|&m| m > 0.1) && expected.iter().any(|&m| m < 0.1));
    }
}
