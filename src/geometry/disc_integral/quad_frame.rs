//! A quadrilateral prepared once for many placements: a pixel's exact view footprint in the
//! coordinates of its first-order parallelogram, placed in each photon's filter space
//! ([`QuadFrame::classify`]).

use super::quad::QuadOverlap;
use super::rows::Wide;
use super::{Lane, POINT_SIZE};
use glam::DVec2;
use std::f64::consts::{FRAC_PI_2, PI};

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
        let (alpha, beta) = (v.map(|p| p.x), v.map(|p| p.y));
        Self::from_numbers(alpha, beta, &FrameNumbers::of(alpha, beta))
    }

    /// The frame of the quadrilateral `(alpha[k], beta[k])` from its numbers
    /// ([`FrameNumbers::of`], computed alone or in SIMD lanes), unless it is not finite or not
    /// strictly convex.
    pub fn from_numbers(
        alpha: [f64; 4],
        beta: [f64; 4],
        numbers: &FrameNumbers<f64>,
    ) -> Option<Self> {
        let &FrameNumbers {
            centre: [cx, cy],
            area,
            turns,
            spread2,
            moments,
            centred,
        } = numbers;
        if !alpha.iter().chain(&beta).all(|c| c.is_finite())
            || area == 0.0
            || area.is_nan()
            || !turns.iter().all(|t| t * area > 0.0)
        {
            return None;
        }
        Some(QuadFrame {
            alpha,
            beta,
            centre: DVec2::new(cx, cy),
            spread2,
            moments,
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

    /// The vertices' `alpha` coordinates.
    pub(super) fn alpha(&self) -> [f64; 4] {
        self.alpha
    }

    /// The vertices' `beta` coordinates.
    pub(super) fn beta(&self) -> [f64; 4] {
        self.beta
    }

    /// The area means of `alpha`, `beta`, `alpha^2`, `alpha beta`, `beta^2` (the inside case's
    /// moments).
    pub(super) fn moments(&self) -> [f64; 5] {
        self.moments
    }

    /// The largest squared distance of a vertex from [`QuadFrame::centre`].
    pub(super) fn spread2(&self) -> f64 {
        self.spread2
    }

    /// The signed area in `(alpha, beta)`.
    pub(super) fn signed_area(&self) -> f64 {
        self.area
    }

    /// The area centroid in `(alpha, beta)`.
    pub fn centroid(&self) -> DVec2 {
        DVec2::new(self.moments[0], self.moments[1])
    }

    /// Settles the quadrilateral `s + alpha a + beta b` against the unit disc where a closed
    /// form does (as [`super::classify`] does for parallelograms) and prepares the rest.
    /// Non-finite input gives [`QuadOverlap::None`].
    #[inline(always)]
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

/// What a [`QuadFrame`] is computed from, in any lane type (one quadrilateral, or one a lane),
/// before the checks that [`QuadFrame::from_numbers`] makes one at a time.
#[derive(Debug, Clone, Copy)]
pub struct FrameNumbers<T> {
    /// Mean of the vertices.
    pub centre: [T; 2],
    /// Signed area.
    pub area: T,
    /// The cross products of consecutive sides, at each vertex: all of the area's sign where
    /// the quadrilateral is strictly convex.
    pub turns: [T; 4],
    /// The largest squared distance of a vertex from the centre.
    pub spread2: T,
    /// Area means about the origin ([`QuadFrame`]'s `moments`).
    pub moments: [T; 5],
    /// Area means about the centre ([`QuadFrame`]'s `centred`).
    pub centred: [T; 9],
}

impl FrameNumbers<Wide> {
    /// Lane `k`'s numbers.
    pub fn lane(&self, k: usize) -> FrameNumbers<f64> {
        let at = |v: Wide| v.to_array()[k];
        FrameNumbers {
            centre: self.centre.map(at),
            area: at(self.area),
            turns: self.turns.map(at),
            spread2: at(self.spread2),
            moments: self.moments.map(at),
            centred: self.centred.map(at),
        }
    }
}

impl<T: Lane> FrameNumbers<T> {
    /// The numbers of the quadrilateral `(x[k], y[k])`. Not checked: a degenerate
    /// quadrilateral gives non-finite numbers, which [`QuadFrame::from_numbers`] refuses.
    #[inline(always)]
    pub fn of(x: [T; 4], y: [T; 4]) -> Self {
        let quarter = T::splat(0.25);
        let (cx, cy) = (
            (x[0] + x[1] + x[2] + x[3]) * quarter,
            (y[0] + y[1] + y[2] + y[3]) * quarter,
        );
        // About the centre: exact for any placement of the quadrilateral.
        let (wx, wy) = (x.map(|x| x - cx), y.map(|y| y - cy));
        let perp = |ax: T, ay: T, bx: T, by: T| ax * by - ay * bx;
        let cross: [T; 4] =
            std::array::from_fn(|k| perp(wx[k], wy[k], wx[(k + 1) % 4], wy[(k + 1) % 4]));
        let area = T::splat(0.5) * (T::splat(0.0) + cross[0] + cross[1] + cross[2] + cross[3]);
        let turns: [T; 4] = std::array::from_fn(|k| {
            let (i, j, l) = ((k + 1) % 4, (k + 2) % 4, k);
            perp(wx[i] - wx[l], wy[i] - wy[l], wx[j] - wx[i], wy[j] - wy[i])
        });
        let centred = centred_moments(wx, wy, cross, area);
        // Moments about the origin from those about the centre.
        let [mx, my, mxx, mxy, myy, ..] = centred;
        let two = T::splat(2.0);
        FrameNumbers {
            centre: [cx, cy],
            area,
            turns,
            spread2: (0..4).fold(T::splat(0.0), |m, k| m.max(wx[k] * wx[k] + wy[k] * wy[k])),
            moments: [
                cx + mx,
                cy + my,
                mxx + two * cx * mx + cx * cx,
                mxy + cx * my + cy * mx + cx * cy,
                myy + two * cy * my + cy * cy,
            ],
            centred,
        }
    }
}

/// The area means about the centre of the quadrilateral `(wx[k], wy[k])` (vertices about its
/// centre, with the cross products `cross[k]` of consecutive vertices and its `area`).
#[inline(always)]
fn centred_moments<T: Lane>(wx: [T; 4], wy: [T; 4], cross: [T; 4], area: T) -> [T; 9] {
    // Polygon moments by Green's theorem, fan triangle (0, p, q) by fan triangle; each sum's
    // constant denominator and the area divided out once at the end (the divisions were most
    // of the cost of a frame, prepared once per gather).
    let (two, three) = (T::splat(2.0), T::splat(3.0));
    let cubic = |p: T, q: T| p * p * p + p * p * q + p * q * q + q * q * q;
    // x^2 y (and, with the roles swapped, x y^2).
    let mixed = |px: T, py: T, qx: T, qy: T| {
        three * px * px * py
            + px * px * qy
            + two * px * qx * (py + qy)
            + qx * qx * py
            + three * qx * qx * qy
    };
    let mut sums = [T::splat(0.0); 9];
    for k in 0..4 {
        let (px, py, qx, qy) = (wx[k], wy[k], wx[(k + 1) % 4], wy[(k + 1) % 4]);
        let c = cross[k];
        sums[0] = sums[0] + c * (px + qx);
        sums[1] = sums[1] + c * (py + qy);
        sums[2] = sums[2] + c * (px * px + px * qx + qx * qx);
        sums[3] = sums[3] + c * (px * qy + two * px * py + two * qx * qy + qx * py);
        sums[4] = sums[4] + c * (py * py + py * qy + qy * qy);
        sums[5] = sums[5] + c * cubic(px, qx);
        sums[6] = sums[6] + c * mixed(px, py, qx, qy);
        sums[7] = sums[7] + c * mixed(py, px, qy, qx);
        sums[8] = sums[8] + c * cubic(py, qy);
    }
    let inv_area = T::splat(1.0) / area;
    let denominators = [6.0, 6.0, 12.0, 24.0, 12.0, 20.0, 60.0, 60.0, 20.0];
    std::array::from_fn(|k| sums[k] * (inv_area * T::splat(1.0 / denominators[k])))
}
