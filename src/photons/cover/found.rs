//! What a footprint query keeps of each photon it finds: its slot alone, or with the view
//! footprint in the photon's filter space, which the cover test computes on the way, so that
//! an estimator need not read the photon's numbers again.

use super::{Lanes, LANES};
use glam::Vec2;

/// What a query keeps of each photon it finds: its slot alone (`u32`), or with the view
/// footprint in its filter space ([`InFilterSpace`]).
///
/// Slots alone are every photon that [`super::may_cover`] the footprint, whichever way it faces:
/// their estimators read the photon anyway and test its surface with it (testing
/// [`super::same_side`] in the cover test too cost `pd` 4% of its render stage). Records in
/// filter space are kept only of photons that also face the query's way: an estimator that
/// reads them needs nothing else of the photon until its kernel's share is known.
pub trait Found: Sized {
    /// Whether only photons facing the query's way ([`super::same_side`]) are found.
    const ON_SURFACE: bool;
    /// What the records of one leaf read, taken out of the lanes once a leaf and query.
    type Rows;
    /// What the records of a leaf read of `filter`, the footprint in its photons' filter spaces
    /// as the cover test computed it for the query (`s.x, s.y, a.x, a.y, b.x, b.y`, a photon a
    /// lane).
    fn rows(filter: &[Lanes; 6]) -> Self::Rows;
    /// The record of the photon in `slot`, lane `k` of its leaf's `rows`.
    fn new(slot: u32, rows: &Self::Rows, k: usize) -> Self;
}

impl Found for u32 {
    const ON_SURFACE: bool = false;
    type Rows = ();
    #[inline(always)]
    fn rows(_: &[Lanes; 6]) {}
    #[inline(always)]
    fn new(slot: u32, _: &(), _: usize) -> Self {
        slot
    }
}

/// A photon found that faces the query's way and lies on its surface slab (its slot): the
/// cover test has then made [`crate::estimate::on_query_surface`]'s test, in the same `f32`
/// operations, so an estimator that reads the photon anyway need not make it again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OnSurface(pub u32);

impl Found for OnSurface {
    const ON_SURFACE: bool = true;
    type Rows = ();
    #[inline(always)]
    fn rows(_: &[Lanes; 6]) {}
    #[inline(always)]
    fn new(slot: u32, _: &(), _: usize) -> Self {
        OnSurface(slot)
    }
}

/// A photon found, with the view footprint in its filter space: the parallelogram
/// `s + alpha a + beta b`, `|alpha|, |beta| <= 1/2` (`s = M (x - x_p)`, `a = M f0`,
/// `b = M f1`), as [`super::may_cover`] computes them in `f32` (and the estimators would again:
/// `glam`'s `dot` sums in the same order, so the numbers are equal bit for bit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InFilterSpace {
    /// The photon's slot in the map.
    pub slot: u32,
    /// The footprint's centre.
    pub s: Vec2,
    /// Its first edge.
    pub a: Vec2,
    /// Its second edge.
    pub b: Vec2,
}

impl Found for InFilterSpace {
    const ON_SURFACE: bool = true;
    type Rows = [[f32; LANES]; 6];
    #[inline(always)]
    fn rows(filter: &[Lanes; 6]) -> Self::Rows {
        filter.map(|l| l.to_array())
    }
    #[inline(always)]
    fn new(slot: u32, r: &Self::Rows, k: usize) -> Self {
        InFilterSpace {
            slot,
            s: Vec2::new(r[0][k], r[1][k]),
            a: Vec2::new(r[2][k], r[3][k]),
            b: Vec2::new(r[4][k], r[5][k]),
        }
    }
}
