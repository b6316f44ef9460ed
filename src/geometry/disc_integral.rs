//! The integral of the Epanechnikov profile `1 - |u|^2` over the intersection of the unit disc
//! `D` with a parallelogram `P = {s + alpha a + beta b : alpha, beta in [-1/2, 1/2]}`, in closed
//! form. The footprint-integrated estimate (`estimate::integrated`) needs it once per photon:
//! `P` is the pixel's view footprint mapped into the photon's filter space.
//!
//! # Derivation
//!
//! With `F(u) = (1/2 - |u|^2/4) u` one has `div F = 2 (1/2 - |u|^2/4) + u . grad(-|u|^2/4)
//! = 1 - |u|^2/2 - |u|^2/2 = 1 - |u|^2`, so by the divergence theorem the integral over a region
//! is the outward flux of `F` through its boundary. `F` is radial, `F(u) = g(|u|) u`, so it has
//! no flux through any segment on a line through the origin. That makes a fan decomposition
//! cheap: a convex polygon with counter-clockwise vertices `p_k` is, up to sign, the sum of the
//! triangles `(0, p_k, p_k+1)`, and so is its intersection with `D` (intersection distributes
//! over the signed sum). A triangle `T` with a vertex at the origin is star-shaped from it, so
//! `T ∩ D` is bounded by its two radial sides (no flux), by the part of the side `p_k p_k+1`
//! inside `D`, and by arcs of the unit circle where that side runs outside `D`:
//!
//! - on the side's line, with outward normal `n` (the right normal of the direction of travel),
//!   signed distance `h = p . n` of the line from the origin and arc length `t` from the foot of
//!   the perpendicular, `u = h n + t tau`, `|u|^2 = h^2 + t^2` and `F . n = (1/2 - |u|^2/4) h`,
//!   so the piece `[t0, t1]` contributes
//!   `h ((1/2 - h^2/4)(t1 - t0) - (t1^3 - t0^3)/12)`;
//!   the part of the side inside `D` is its `t`-range clipped to `[-w, w]`, `w = sqrt(1 - h^2)`
//!   (empty when `|h| >= 1`);
//! - on the unit circle `F . n = (1/2 - 1/4) |u| = 1/4`, so an arc of signed angle `phi`
//!   contributes `phi / 4`. The arcs replace the side's pieces `[t0, t0']` and `[t1', t1]`
//!   outside `D` (`t0'`, `t1'` the clipped ends), and the angle a piece `[ta, tb]` subtends is
//!   `arg((h - i ta)(h + i tb))`. Each such angle lies in `(-pi/2, pi/2)`, so the two of a side
//!   combine into one `atan2` of the product of the four complex factors.
//!
//! Summed over the four sides this is the integral, for every configuration at once: `P` inside
//! `D` (no clipping, no arcs), `D` inside `P` (all `|h| >= 1`: the arcs sum to `2 pi`, giving
//! `pi / 2`, the integral over the whole disc), disjoint (the arcs cancel to 0), tangent (a clip
//! range of zero length). The whole disc gives `pi / 2`, and `(2 / pi)(1 - r^2)` integrates to 1.
//!
//! # Precision and fast paths
//!
//! The fan sum cancels: for a small `P` each side contributes about `|P|` while the sum is about
//! `|P|^2`. [`classify`] therefore settles the common cases exactly before the general formula:
//! `P` inside `D` has the polygon-moment closed form
//! `mean over P of (1 - |u|^2) = 1 - |s|^2 - (|a|^2 + |b|^2) / 12` (the second moment of a
//! parallelogram about its centre; no division by the area), `D` inside `P` gives
//! `(pi / 2) / area`, and a side line that separates `P` from `D` gives 0. The general formula
//! runs in `f64` (its absolute error is about `1e-16` times the side contributions), with
//! nearly flat parallelograms thickened to a width of at least [`MIN_WIDTH`] times their size
//! (changing the mean by about that fraction), and parallelograms smaller than [`POINT_SIZE`]
//! evaluated at their centre: the limit of the mean as the footprint vanishes is the kernel at
//! the centre, which is the photon-differential estimate.

use glam::DVec2;

/// Parallelograms whose edge vectors satisfy `|a|^2 + |b|^2 < POINT_SIZE^2` are points: the mean
/// of the kernel over them is its value at the centre (the kernel's gradient is at most 2, so
/// this changes the mean by at most `2 POINT_SIZE`).
pub const POINT_SIZE: f64 = 1e-5;

/// Parallelograms narrower than `MIN_WIDTH * min(size, 1)` (width = area / size, size =
/// `sqrt(|a|^2 + |b|^2)`) are thickened to that width before the general formula, whose
/// cancellation error is about `1e-16 / width`.
pub const MIN_WIDTH: f64 = 1e-5;

pub use super::lanes::Lane;

/// A side of a fan triangle `(0, start, end)` ∩ `D`: the side lies on the line at signed
/// distance `h` (outward) from the origin and runs over `t in [t0, t1]`, of which `[u0, u1]` lies
/// inside `D` (clipped to `[-w, w]`, `w = sqrt(1 - h^2)`; `hh = h^2`).
///
/// Clipped once a side for the integral ([`Clipped::parts`]) and the first moment
/// ([`moment::first_moment`]) alike: square roots are the slowest part of the general
/// formula's batches, and `quad::quad_means` took twelve a chunk of lanes where eight do now
/// (its share of the render stage fell by about a quarter).
#[derive(Debug, Clone, Copy)]
pub struct Clipped<T> {
    /// Signed distance of the side's line from the origin.
    pub h: T,
    /// `h^2`.
    pub hh: T,
    /// The side's `t`-range.
    pub t0: T,
    /// Its end.
    pub t1: T,
    /// The part of `[t0, t1]` inside the disc (empty, `u0 = u1`, if none).
    pub u0: T,
    /// Its end.
    pub u1: T,
}

impl<T: Lane> Clipped<T> {
    /// The side on the line at `h` over `[t0, t1]`, clipped to the disc.
    #[inline(always)]
    pub fn new(h: T, t0: T, t1: T) -> Self {
        let hh = h * h;
        let w = (T::splat(1.0) - hh).max(T::splat(0.0)).sqrt();
        Clipped {
            h,
            hh,
            t0,
            t1,
            u0: t0.max(-w).min(w),
            u1: t1.max(-w).min(w),
        }
    }

    /// The flux of `F` through the side's pieces inside `D`, and a complex number `(re, im)`
    /// whose argument is the signed angle of its arcs (the pieces outside `D`), which contribute
    /// `arg / 4`.
    #[inline(always)]
    pub fn parts(&self) -> (T, T, T) {
        let &Clipped {
            h,
            hh,
            t0,
            t1,
            u0,
            u1,
        } = self;
        let half = T::splat(0.5);
        let quarter = T::splat(0.25);
        let line = h
            * ((half - quarter * hh) * (u1 - u0)
                - (u1 - u0) * (u1 * u1 + u1 * u0 + u0 * u0) * T::splat(1.0 / 12.0));
        // The angles of the outside pieces [t0, u0] and [u1, t1], as one complex product.
        let (r1, i1) = (hh + t0 * u0, h * (u0 - t0));
        let (r2, i2) = (hh + u1 * t1, h * (t1 - u1));
        (line, r1 * r2 - i1 * i2, r1 * i2 + i1 * r2)
    }

    /// The flux of `F` through the side: its pieces inside `D` and its arcs.
    #[inline(always)]
    pub fn flux(&self) -> T {
        let (line, re, im) = self.parts();
        line + T::splat(0.25) * im.atan2(re)
    }
}

/// The flux of `F` through one side on the line at `h` over `[t0, t1]` (see [`Clipped`]).
#[inline(always)]
pub(crate) fn side<T: Lane>(h: T, t0: T, t1: T) -> T {
    Clipped::new(h, t0, t1).flux()
}

/// `z`, or `1` where `|re| + |im| < 1e-75`. Such a side's line runs through the origin (`h`
/// about 0) with an end there: its outside pieces lie along rays from the origin and their
/// angle is 0 (to about `h`, below 1e-37), while a factor that small would drive the product
/// of four towards underflow, or make it exactly 0 (whose `atan2` would lose every side's
/// arcs). At most the two sides at one vertex can be that small (the others lie at least the
/// thickened width from the origin).
#[inline(always)]
fn nonzero<T: Lane>(re: T, im: T) -> (T, T) {
    let keep = re.abs() + im.abs() - T::splat(1e-75);
    (
        re.where_positive_else(keep, T::splat(1.0)),
        im.where_positive_else(keep, T::splat(0.0)),
    )
}

/// The four sides of `P` as [`side`] takes them, `(h, t0, t1)` each, and `P`'s area.
#[inline(always)]
fn sides<T: Lane>(s0: T, s1: T, a0: T, a1: T, b0: T, b1: T) -> ([(T, T, T); 4], T) {
    let half = T::splat(0.5);
    let cross = a0 * b1 - a1 * b0;
    let area = cross.abs();
    // Counter-clockwise: b to the left of a.
    let (b0, b1) = (
        b0.negate_where_negative(cross),
        b1.negate_where_negative(cross),
    );
    let la = (a0 * a0 + a1 * a1).sqrt();
    let lb = (b0 * b0 + b1 * b1).sqrt();
    // Sides along a (at -b/2 forwards, at +b/2 backwards): tangent a/|a|, outward normal its
    // right normal (for the first); the second is the first reflected through the centre.
    let (ta0, ta1) = (a0 / la, a1 / la);
    let c = s0 * ta1 - s1 * ta0;
    let g = s0 * ta0 + s1 * ta1;
    let k = half * (b0 * ta0 + b1 * ta1);
    let wa = half * area / la;
    let hl = half * la;
    // Sides along b (at +a/2 forwards, at -a/2 backwards).
    let (tb0, tb1) = (b0 / lb, b1 / lb);
    let cb = s0 * tb1 - s1 * tb0;
    let gb = s0 * tb0 + s1 * tb1;
    let kb = half * (a0 * tb0 + a1 * tb1);
    let wb = half * area / lb;
    let hb = half * lb;
    (
        [
            (wa + c, g - k - hl, g - k + hl),
            (wa - c, -g - k - hl, -g - k + hl),
            (wb + cb, gb + kb - hb, gb + kb + hb),
            (wb - cb, -gb + kb - hb, -gb + kb + hb),
        ],
        area,
    )
}

/// `(integral over P ∩ D of (1 - |u|^2), area of P)` by the general formula (see the module
/// documentation), for `P` of centre `(s0, s1)` and edge vectors `(a0, a1)`, `(b0, b1)` in
/// either orientation. Needs `a`, `b` of non-zero length and `P` of non-zero area.
#[inline(always)]
pub fn general<T: Lane>(s0: T, s1: T, a0: T, a1: T, b0: T, b1: T) -> (T, T) {
    let ([e0, e1, e2, e3], area) = sides(s0, s1, a0, a1, b0, b1);
    let integral = side(e0.0, e0.1, e0.2)
        + side(e1.0, e1.1, e1.2)
        + side(e2.0, e2.1, e2.2)
        + side(e3.0, e3.1, e3.2);
    (integral, area)
}

/// [`general`] with one `atan2` in place of four, for parallelograms of circumradius up to
/// [`ONE_ARC_MAX_CIRCUMRADIUS`] ([`takes_one_arc`]).
///
/// Why it holds: the arcs of all four sides together are the part of the unit circle inside
/// `P` (the fan's signed arcs cancel outside it), so their angles sum to some `S` in
/// `[0, 2 pi]`, and the argument `theta` (in `(-pi, pi]`) of the product of the four sides'
/// complex numbers is `S` up to a turn. Which turn follows from the sides' distances `h`:
/// - if every `h > 0.9`, `P` holds the disc of radius 0.9 and each side cuts off at most
///   `2 acos 0.9 = 0.90` of the circle, so `S >= 2 pi - 3.61 = 2.68`: `S = theta` when
///   `theta >= 1`, else `theta + 2 pi` (`theta` is then at most rounding above 0);
/// - otherwise one side cuts off at least 0.90, so `S <= 2 pi - 0.90`: `S = theta + 2 pi`
///   when `theta < -0.5` (`theta` is then at most `-0.90`), else `theta` (`theta >= 0` but for
///   rounding).
///
/// The margins are far beyond rounding. A circumradius below 1 always takes the second case
/// with `S < pi` (a set of diameter below 2 meets less than half the circle). Factors that
/// would underflow are set to 1 (`nonzero`); the largest factor, about `(3 R)^8` for
/// circumradius `R`, bounds the circumradius so that the product stays finite.
#[inline(always)]
pub fn general_one_arc<T: Lane>(s0: T, s1: T, a0: T, a1: T, b0: T, b1: T) -> (T, T) {
    let (e, area) = sides(s0, s1, a0, a1, b0, b1);
    (one_arc_flux(e), area)
}

/// The flux through four sides `(h, t0, t1)` of a convex polygon with one `atan2` (see
/// [`general_one_arc`], whose argument holds for any convex quadrilateral).
#[inline(always)]
pub(crate) fn one_arc_flux<T: Lane>(e: [(T, T, T); 4]) -> T {
    one_arc_flux_clipped(&e.map(|(h, t0, t1)| Clipped::new(h, t0, t1)))
}

/// [`one_arc_flux`] of sides already [`Clipped`].
#[inline(always)]
pub(crate) fn one_arc_flux_clipped<T: Lane>(e: &[Clipped<T>; 4]) -> T {
    let mut line = T::splat(0.0);
    let mut min_h = e[0].h;
    let (mut re, mut im) = (T::splat(1.0), T::splat(0.0));
    for side in e {
        let (l, r, i) = side.parts();
        let (r, i) = nonzero(r, i);
        line = line + l;
        min_h = min_h.min(side.h);
        (re, im) = (re * r - im * i, re * i + im * r);
    }
    let theta = im.atan2(re);
    // Positive where a turn is to be added (see above).
    let turn =
        (T::splat(1.0) - theta).where_positive_else(min_h - T::splat(0.9), T::splat(-0.5) - theta);
    let arcs = (theta + T::splat(std::f64::consts::TAU)).where_positive_else(turn, theta);
    line + T::splat(0.25) * arcs
}

/// Parallelograms of circumradius up to this take [`general_one_arc`] (its product of four
/// complex numbers stays below about `1e60`); larger ones take [`general`].
pub const ONE_ARC_MAX_CIRCUMRADIUS: f64 = 1e6;

/// Positive where the parallelogram of edge vectors `a`, `b` takes [`general_one_arc`]: its
/// circumradius, half its longer diagonal, is at most [`ONE_ARC_MAX_CIRCUMRADIUS`].
#[inline(always)]
pub fn takes_one_arc<T: Lane>(a0: T, a1: T, b0: T, b1: T) -> T {
    let (p0, p1, d0, d1) = (a0 + b0, a1 + b1, a0 - b0, a1 - b1);
    let diagonal2 = (p0 * p0 + p1 * p1).max(d0 * d0 + d1 * d1);
    T::splat(4.0 * ONE_ARC_MAX_CIRCUMRADIUS * ONE_ARC_MAX_CIRCUMRADIUS) - diagonal2
}

/// [`general_one_arc`], or [`general`] where it does not serve, for one parallelogram.
pub fn general_either(s: DVec2, a: DVec2, b: DVec2) -> (f64, f64) {
    if takes_one_arc(a.x, a.y, b.x, b.y) >= 0.0 {
        general_one_arc(s.x, s.y, a.x, a.y, b.x, b.y)
    } else {
        general(s.x, s.y, a.x, a.y, b.x, b.y)
    }
}

/// What [`classify`] settles for a parallelogram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Overlap {
    /// No overlap with the disc's interior: the mean is 0.
    None,
    /// The mean of `(1 - |u|^2)+` over the parallelogram, in closed form.
    Mean(f64),
    /// Needs the general formula ([`general`]) with these (possibly thickened) edge vectors:
    /// the mean is its integral over its area.
    General {
        /// Centre.
        s: DVec2,
        /// First edge vector.
        a: DVec2,
        /// Second edge vector.
        b: DVec2,
    },
}

/// Settles the cases with a closed form (see the module documentation) and prepares the rest.
/// Non-finite input gives [`Overlap::None`].
#[inline]
pub fn classify(s: DVec2, a: DVec2, b: DVec2) -> Overlap {
    let size2 = a.length_squared() + b.length_squared();
    let ss = s.length_squared();
    if !(size2.is_finite() && ss.is_finite()) {
        return Overlap::None;
    }
    // Far apart, without a square root: the circumradius R has R^2 <= (|a|^2 + |b|^2) / 2 and
    // (1 + R)^2 <= 2 + 2 R^2, so this is beyond 1 + R. Most photons a gather finds end here.
    if ss > 2.0 + size2 {
        return Overlap::None;
    }
    if size2 < POINT_SIZE * POINT_SIZE {
        return Overlap::Mean((1.0 - ss).max(0.0));
    }
    // The vertices' squared distances: |s|^2 + (|a|^2 + |b|^2)/4 +- s.a +- s.b +- a.b/2, the
    // last sign the product of the first two.
    let (sa, sb, ab) = (s.dot(a), s.dot(b), 0.5 * a.dot(b));
    let base = ss + 0.25 * size2;
    let far = base + ((sa + sb).abs() + ab).max((sa - sb).abs() - ab);
    if far <= 1.0 {
        return Overlap::Mean(1.0 - ss - size2 / 12.0);
    }
    // Beyond 1 + R from the centre (R the circumradius): apart, though no side's line may
    // separate them (the disc faces a corner). Without a square root: ss >= (1 + R)^2 =
    // 1 + R^2 + 2 R.
    let r2 = 0.25 * (a + b).length_squared().max((a - b).length_squared());
    let beyond = ss - 1.0 - r2;
    if beyond >= 0.0 && beyond * beyond >= 4.0 * r2 {
        return Overlap::None;
    }
    let (a, b) = thickened(a, b, size2);
    let area = a.perp_dot(b).abs();
    // The disc inside the parallelogram (each side's line at least 1 from the centre) needs an
    // area of at least pi; a smaller one crossing the circle is the common case, and the
    // general formula also settles the rare one that a side's line separates from the disc
    // (to 0, up to rounding).
    if area < std::f64::consts::PI {
        return Overlap::General { s, a, b };
    }
    // Sides' signed distances from the origin: centre distance +- half width, per direction.
    let (la, lb) = (a.length(), b.length());
    let ca = s.perp_dot(a) / la;
    let cb = s.perp_dot(b) / lb;
    let (wa, wb) = (0.5 * area / la, 0.5 * area / lb);
    if wa - ca.abs() >= 1.0 && wb - cb.abs() >= 1.0 {
        return Overlap::Mean(std::f64::consts::FRAC_PI_2 / area);
    }
    if wa - ca.abs() <= -1.0 || wb - cb.abs() <= -1.0 {
        return Overlap::None;
    }
    Overlap::General { s, a, b }
}

/// The mean of `(1 - |u|^2)+` over the parallelogram of centre `s` and edge vectors `a`, `b`
/// (for the Epanechnikov kernel multiply by `2 / pi`): [`classify`], then [`general_either`].
pub fn mean(s: DVec2, a: DVec2, b: DVec2) -> f64 {
    match classify(s, a, b) {
        Overlap::None => 0.0,
        Overlap::Mean(m) => m,
        Overlap::General { s, a, b } => {
            let (integral, area) = general_either(s, a, b);
            (integral / area).max(0.0)
        }
    }
}

/// `a`, `b` with the shorter one moved along the longer one's normal so that the parallelogram
/// is at least [`MIN_WIDTH`] times its size (`sqrt(size2)`, `size2 = |a|^2 + |b|^2`, at most 1)
/// wide across the longer one; unchanged if it already is (tested without a square root: most
/// are).
fn thickened(a: DVec2, b: DVec2, size2: f64) -> (DVec2, DVec2) {
    let cross = a.perp_dot(b);
    let (aa, bb) = (a.length_squared(), b.length_squared());
    if cross * cross >= MIN_WIDTH * MIN_WIDTH * size2.min(1.0) * aa.max(bb) {
        return (a, b);
    }
    let min_width = MIN_WIDTH * size2.sqrt().min(1.0);
    let sign = if cross < 0.0 { -1.0 } else { 1.0 };
    if aa >= bb {
        let la = a.length();
        // perp_dot(a, b + l perp(a)/|a|) = cross + l |a|.
        let lambda = sign * (min_width - cross.abs() / la);
        (a, b + a.perp() / la * lambda)
    } else {
        let lb = b.length();
        // perp_dot(a + l perp(b)/|b|, b) = cross - l |b|.
        let lambda = -sign * (min_width - cross.abs() / lb);
        (a + b.perp() / lb * lambda, b)
    }
}

pub mod general_lanes;
pub mod moment;
pub mod quad;
pub mod quad_frame;
pub mod rows;

#[cfg(test)]
mod tests;
