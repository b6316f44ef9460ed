//! Numbers in SIMD lanes or alone behind one trait ([`Lane`]), and 3-vectors of them, so that
//! a formula is written once for one value and for many at a time.

use std::ops::{Add, Div, Mul, Neg, Sub};
use wide::{f64x4, f64x8};

/// Arithmetic in one value ([`f64`]) or four or eight in SIMD lanes ([`f64x4`], [`f64x8`]), so
/// that a scalar and a batched version are one formula (the general formula of
/// [`super::disc_integral`], the exact view footprint's preparation).
pub trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// `x` in every lane.
    fn splat(x: f64) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Lane-wise maximum. Where a lane holds a NaN its answer is unspecified: the SIMD lanes
    /// take the bare instruction, which callers can afford because every lane they keep is
    /// finite (non-finite lanes are masked out or refused first).
    fn max(self, o: Self) -> Self;
    /// Lane-wise minimum, NaN as for [`Lane::max`].
    fn min(self, o: Self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// `atan2(self, x)`.
    fn atan2(self, x: Self) -> Self;
    /// `-self` where `sign` is negative, else `self`.
    fn negate_where_negative(self, sign: Self) -> Self;
    /// `self` where `test` is positive, else `other`.
    fn where_positive_else(self, test: Self, other: Self) -> Self;
}

impl Lane for f64 {
    fn splat(x: f64) -> Self {
        x
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn max(self, o: Self) -> Self {
        f64::max(self, o)
    }
    fn min(self, o: Self) -> Self {
        f64::min(self, o)
    }
    fn abs(self) -> Self {
        f64::abs(self)
    }
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    fn negate_where_negative(self, sign: Self) -> Self {
        if sign < 0.0 {
            -self
        } else {
            self
        }
    }
    fn where_positive_else(self, test: Self, other: Self) -> Self {
        if test > 0.0 {
            self
        } else {
            other
        }
    }
}

/// The SIMD lane types: four lanes (one AVX register) and eight (one AVX-512 register, or
/// two AVX halves where the machine has no AVX-512).
macro_rules! simd_lane {
    ($t:ident) => {
        impl Lane for $t {
            fn splat(x: f64) -> Self {
                $t::splat(x)
            }
            fn sqrt(self) -> Self {
                $t::sqrt(self)
            }
            // The bare instructions: `wide`'s `max` and `min` also mend a NaN lane, a compare
            // and a blend after each, and the general formula's quadrilateral batches take about
            // twenty a chunk of lanes (13% of their time went to the mending).
            fn max(self, o: Self) -> Self {
                $t::fast_max(self, o)
            }
            fn min(self, o: Self) -> Self {
                $t::fast_min(self, o)
            }
            fn abs(self) -> Self {
                $t::abs(self)
            }
            fn atan2(self, x: Self) -> Self {
                $t::atan2(self, x)
            }
            fn negate_where_negative(self, sign: Self) -> Self {
                sign.simd_lt($t::ZERO).bitselect(-self, self)
            }
            fn where_positive_else(self, test: Self, other: Self) -> Self {
                test.simd_gt($t::ZERO).bitselect(self, other)
            }
        }
    };
}
simd_lane!(f64x4);
simd_lane!(f64x8);

/// A 3-vector of lanes: `[x, y, z]`.
pub type V3<T> = [T; 3];

/// `a . b`, in glam's order (`x x' + y y' + z z'`), so that a lane of `f64` equals `DVec3::dot`.
#[inline(always)]
pub fn dot<T: Lane>(a: V3<T>, b: V3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a + b`.
#[inline(always)]
pub fn add<T: Lane>(a: V3<T>, b: V3<T>) -> V3<T> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b`.
#[inline(always)]
pub fn sub<T: Lane>(a: V3<T>, b: V3<T>) -> V3<T> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a k`.
#[inline(always)]
pub fn scale<T: Lane>(a: V3<T>, k: T) -> V3<T> {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// `v` in every lane.
#[inline(always)]
pub fn splat3<T: Lane>(v: glam::DVec3) -> V3<T> {
    [T::splat(v.x), T::splat(v.y), T::splat(v.z)]
}
