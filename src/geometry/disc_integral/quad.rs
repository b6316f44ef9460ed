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
use super::{one_arc_flux, side, Lane, ONE_ARC_MAX_CIRCUMRADIUS, POINT_SIZE};
use crate::geometry::disc_integral::rows::Wide;
use glam::DVec2;
use std::f64::consts::{FRAC_PI_2, PI};

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

/// A quadrilateral given in the coordinates `(alpha, beta)` of a basis `(a, b)`, prepared once
/// so that its mean over many placements `s + alpha a + beta b` (one per photon, each photon's
/// filter space giving its own `s`, `a`, `b`) costs about what a parallelogram's does: the
/// polygon moments of the inside case are area means of `alpha`, `beta`, `alpha^2`,
/// `alpha beta`, `beta^2`, which the linear map does not change.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuadFrame {
    alpha: [f64; 4],
    beta: [f64; 4],
    /// Mean of the vertices' coordinates.
    centre: DVec2,
    /// The largest squared distance of a vertex from `centre`.
    spread2: f64,
    /// Area means of `alpha`, `beta`, `alpha^2`, `alpha beta`, `beta^2`.
    moments: [f64; 5],
    /// Signed area in `(alpha, beta)` (positive counter-clockwise).
    area: f64,
    /// Area means about `centre` (`w = (alpha, beta) - centre`) of `w_a`, `w_b`, `w_a^2`,
    /// `w_a w_b`, `w_b^2`, `w_a^3`, `w_a^2 w_b`, `w_a w_b^2`, `w_b^3`: where the kernel's mass
    /// lies when the quadrilateral is inside the disc ([`QuadFrame::kernel_centroid`]).
    centred: [f64; 9],
}

impl QuadFrame {
    /// The quadrilateral with these vertices (in order, either direction), or `None` unless it
    /// is strictly convex with finite coordinates.
    pub fn new(v: [DVec2; 4]) -> Option<Self> {
        if !v.iter().all(|p| p.is_finite()) {
            return None;
        }
        let centre = (v[0] + v[1] + v[2] + v[3]) * 0.25;
        // About the centre: exact for any placement of the quadrilateral.
        let w = v.map(|p| p - centre);
        let cross = |k: usize| w[k].perp_dot(w[(k + 1) % 4]);
        let area = 0.5 * (0..4).map(cross).sum::<f64>();
        let turns =
            (0..4).map(|k| (w[(k + 1) % 4] - w[k]).perp_dot(w[(k + 2) % 4] - w[(k + 1) % 4]));
        if area == 0.0 || area.is_nan() || !turns.into_iter().all(|t| t * area > 0.0) {
            return None;
        }
        // Polygon moments by Green's theorem, fan triangle (0, p, q) by fan triangle; each
        // sum's constant denominator and the area divided out once at the end (the divisions
        // were most of the cost of a frame, prepared once per gather).
        let mut sums = [0.0; 9];
        for k in 0..4 {
            let (p, q) = (w[k], w[(k + 1) % 4]);
            let c = cross(k);
            sums[0] += c * (p.x + q.x);
            sums[1] += c * (p.y + q.y);
            sums[2] += c * (p.x * p.x + p.x * q.x + q.x * q.x);
            sums[3] += c * (p.x * q.y + 2.0 * p.x * p.y + 2.0 * q.x * q.y + q.x * p.y);
            sums[4] += c * (p.y * p.y + p.y * q.y + q.y * q.y);
            let cubic = |p: f64, q: f64| p * p * p + p * p * q + p * q * q + q * q * q;
            // x^2 y (and, with the roles swapped, x y^2).
            let mixed = |px: f64, py: f64, qx: f64, qy: f64| {
                3.0 * px * px * py
                    + px * px * qy
                    + 2.0 * px * qx * (py + qy)
                    + qx * qx * py
                    + 3.0 * qx * qx * qy
            };
            sums[5] += c * cubic(p.x, q.x);
            sums[6] += c * mixed(p.x, p.y, q.x, q.y);
            sums[7] += c * mixed(p.y, p.x, q.y, q.x);
            sums[8] += c * cubic(p.y, q.y);
        }
        let inv_area = 1.0 / area;
        let denominators = [6.0, 6.0, 12.0, 24.0, 12.0, 20.0, 60.0, 60.0, 20.0];
        let centred: [f64; 9] =
            std::array::from_fn(|k| sums[k] * (inv_area * (1.0 / denominators[k])));
        // Moments about the origin from those about the centre.
        let [mx, my, mxx, mxy, myy, ..] = centred;
        let (cx, cy) = (centre.x, centre.y);
        Some(QuadFrame {
            alpha: v.map(|p| p.x),
            beta: v.map(|p| p.y),
            centre,
            spread2: w.iter().map(|w| w.length_squared()).fold(0.0, f64::max),
            moments: [
                cx + mx,
                cy + my,
                mxx + 2.0 * cx * mx + cx * cx,
                mxy + cx * my + cy * mx + cx * cy,
                myy + 2.0 * cy * my + cy * cy,
            ],
            area,
            centred,
        })
    }

    /// The mean of the vertices' coordinates, about which [`QuadFrame::centred_moments`] are
    /// taken.
    pub fn centre(&self) -> DVec2 {
        self.centre
    }

    /// Area means about [`QuadFrame::centre`] (`w = (alpha, beta) - centre`) of `w_a`, `w_b`,
    /// `w_a^2`, `w_a w_b`, `w_b^2`, `w_a^3`, `w_a^2 w_b`, `w_a w_b^2`, `w_b^3`.
    pub fn centred_moments(&self) -> [f64; 9] {
        self.centred
    }

    /// Where the weight `(1 - |u|^2)` has its centroid over the quadrilateral `s + alpha a +
    /// beta b`, in `(alpha, beta)`, when the quadrilateral lies inside the disc and `mean` is
    /// that weight's mean over it ([`QuadOverlap::Mean`]): from the area moments up to the
    /// third order, since `(1 - |u|^2) w` is a cubic in `w`.
    #[inline]
    pub fn kernel_centroid(&self, s: DVec2, a: DVec2, b: DVec2, mean: f64) -> DVec2 {
        let [m_a, m_b, m_aa, m_ab, m_bb, m_aaa, m_aab, m_abb, m_bbb] = self.centred;
        // u = c + w_a a + w_b b, c the centre's image.
        let c = s + a * self.centre.x + b * self.centre.y;
        let (k0, ca, cb) = (1.0 - c.length_squared(), 2.0 * c.dot(a), 2.0 * c.dot(b));
        let (aa, ab, bb) = (a.length_squared(), 2.0 * a.dot(b), b.length_squared());
        let along_a = k0 * m_a - ca * m_aa - cb * m_ab - aa * m_aaa - ab * m_aab - bb * m_abb;
        let along_b = k0 * m_b - ca * m_ab - cb * m_bb - aa * m_aab - ab * m_abb - bb * m_bbb;
        if mean > 0.0 {
            self.centre + DVec2::new(along_a, along_b) / mean
        } else {
            self.centre
        }
    }

    /// The area centroid in `(alpha, beta)`.
    pub fn centroid(&self) -> DVec2 {
        DVec2::new(self.moments[0], self.moments[1])
    }

    /// Settles the quadrilateral `s + alpha a + beta b` against the unit disc where a closed
    /// form does (as [`super::classify`] does for parallelograms) and prepares the rest.
    /// Non-finite input gives [`QuadOverlap::None`].
    #[inline]
    pub fn classify(&self, s: DVec2, a: DVec2, b: DVec2) -> QuadOverlap {
        let c = s + a * self.centre.x + b * self.centre.y;
        // A bound on the squared circumradius about c: |alpha a + beta b|^2 <= (alpha^2 +
        // beta^2)(|a|^2 + |b|^2). (The tests below only need an upper bound.)
        let (aa, bb) = (a.length_squared(), b.length_squared());
        let r2 = self.spread2 * (aa + bb);
        let cc = c.length_squared();
        if !(r2.is_finite() && cc.is_finite()) {
            return QuadOverlap::None;
        }
        // The bounding circle about the centre misses the disc: beyond 1 + R, without a
        // square root ((1 + R)^2 <= 2 + 2 R^2). Most photons a gather finds end here.
        if cc > 2.0 + 2.0 * r2 {
            return QuadOverlap::None;
        }
        if 4.0 * r2 < POINT_SIZE * POINT_SIZE {
            return QuadOverlap::Mean((1.0 - cc).max(0.0));
        }
        let v: [DVec2; 4] = std::array::from_fn(|k| s + a * self.alpha[k] + b * self.beta[k]);
        if v.iter().all(|p| p.length_squared() <= 1.0) {
            let [ma, mb, maa, mab, mbb] = self.moments;
            let mean_u2 = s.length_squared()
                + 2.0 * (ma * s.dot(a) + mb * s.dot(b))
                + maa * aa
                + 2.0 * mab * a.dot(b)
                + mbb * bb;
            return QuadOverlap::Mean(1.0 - mean_u2);
        }
        // Beyond 1 + R from the centre: apart, though no side's line may separate them (the
        // disc faces a corner). Without a square root: cc >= (1 + R)^2 = 1 + R^2 + 2 R.
        let beyond = cc - 1.0 - r2;
        if beyond >= 0.0 && beyond * beyond >= 4.0 * r2 {
            return QuadOverlap::None;
        }
        let cross = a.perp_dot(b);
        let area = (cross * self.area).abs();
        // So thin in filter space that the general formula's cancellation would show: the
        // parallelogram, which is thickened, serves (as `super::MIN_WIDTH`; the diameter is
        // at most 2 R): area <= MIN_WIDTH 2 R min(2 R, 1), squared.
        let thin = super::MIN_WIDTH * super::MIN_WIDTH * 4.0 * r2 * (4.0 * r2).min(1.0);
        if area.is_nan() || area * area <= thin {
            return QuadOverlap::NotConvex;
        }
        // Counter-clockwise in filter space.
        let v = if cross * self.area < 0.0 {
            [v[0], v[3], v[2], v[1]]
        } else {
            v
        };
        // The disc inside the quadrilateral (every side's line at least 1 from the centre)
        // needs an area of at least pi; a smaller one crossing the circle is the common case
        // (photons larger than pixels), and the general formula also settles the rare one that
        // a side's line separates from the disc (to 0, up to rounding).
        if area < PI {
            return QuadOverlap::General(v);
        }
        let mut all_outside = true;
        for k in 0..4 {
            let (p, q) = (v[k], v[(k + 1) % 4]);
            let e = q - p;
            let h = p.perp_dot(e) / e.length();
            if h <= -1.0 {
                return QuadOverlap::None;
            }
            all_outside &= h >= 1.0;
        }
        if all_outside {
            return QuadOverlap::DiscInside(FRAC_PI_2 / area);
        }
        QuadOverlap::General(v)
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
    first_moment(&sides, &tangents)
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
        let integral = if quad_takes_one_arc(x, y).simd_ge(Wide::ZERO).all() {
            one_arc_flux(sides)
        } else {
            sides
                .iter()
                .fold(Wide::ZERO, |sum, &(h, t0, t1)| sum + side(h, t0, t1))
        };
        let (mx, my) = first_moment(&sides, &tangents);
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
