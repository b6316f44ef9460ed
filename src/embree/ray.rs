//! Rays as the renderer hands them to Embree, and their validation.

use glam::DVec3;

/// Largest coordinate magnitude Embree's assertions accept (about 1.844e18), with a margin.
const MAX_COMPONENT: f64 = 1.0e18;

/// A ray segment `origin + t * direction`, `t` in `[tnear, tfar]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: DVec3,
    /// Direction; need not be normalised (distances are then in units of its length).
    pub direction: DVec3,
    /// Start of the segment, `>= 0`.
    pub tnear: f64,
    /// End of the segment, `>= tnear`; may be `f64::INFINITY`.
    pub tfar: f64,
}

impl Ray {
    /// A ray from `origin` along `direction` over `[0, inf)`.
    pub fn new(origin: DVec3, direction: DVec3) -> Self {
        Ray {
            origin,
            direction,
            tnear: 0.0,
            tfar: f64::INFINITY,
        }
    }

    /// A segment from `origin` along `direction` over `[0, tfar]`.
    pub fn segment(origin: DVec3, direction: DVec3, tfar: f64) -> Self {
        Ray {
            origin,
            direction,
            tnear: 0.0,
            tfar,
        }
    }

    /// Whether Embree can take this ray without tripping one of its assertions (which abort the
    /// process in Debian's build): finite components below ~1.8e18 in magnitude, a non-zero
    /// direction, `0 <= tnear <= tfar` and `tfar` not NaN (infinite is fine).
    pub fn is_valid(&self) -> bool {
        let finite = |v: DVec3| v.is_finite() && v.abs().max_element() < MAX_COMPONENT;
        finite(self.origin)
            && finite(self.direction)
            && self.direction != DVec3::ZERO
            && self.tnear.is_finite()
            && self.tnear >= 0.0
            && !self.tfar.is_nan()
            && self.tfar >= self.tnear
    }

    /// `tfar` as Embree's f32, with infinities kept.
    pub(super) fn tfar_f32(&self) -> f32 {
        if self.tfar >= f32::MAX as f64 {
            f32::INFINITY
        } else {
            self.tfar as f32
        }
    }
}
