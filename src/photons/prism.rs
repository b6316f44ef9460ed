//! The prism over a view footprint, for footprint queries of the photon map's BVH: a node's
//! box apart from it holds no photon the footprint meets.

use glam::DVec3;
use wide::f32x4;

/// The prism over a parallelogram `c +- f[0]/2 +- f[1]/2` along its normal: the points `y` with
/// `|d_k . (y - c)| <= 1/2` (`d_0`, `d_1` the dual vectors of `f[0]`, `f[1]` in their plane),
/// in every SIMD lane.
///
/// Why: a view footprint seen obliquely, or through the rim of a glass sphere, is a long thin
/// parallelogram askew to the axes, and its bounding box can be a thousand times its area (a
/// needle 57 units long across the canonical floor held every photon of the map). A photon's
/// support that meets the footprint meets its prism, so a box apart from the prism holds none.
pub struct Prism {
    axes: [[f32x4; 3]; 2],
    offsets: [f32x4; 2],
}

/// How many times a footprint's area its bounding box's largest face must be for the query to
/// test the prism ([`Prism::over`]).
pub const THIN: f64 = 4.0;

/// Relative rounding allowed for in [`Prism::apart`] (single precision, a few steps).
const PRISM_ROUNDING: f32 = 8.0 * f32::EPSILON;

impl Prism {
    /// The prism over `c +- f[0]/2 +- f[1]/2` where it is worth testing: where the
    /// parallelogram's bounding box has a face more than [`THIN`] times its area (a footprint
    /// near the axes gains nothing from it, and the test costs a quarter of a node's).
    /// `None` there, and when the parallelogram is degenerate (its edges parallel or zero) or
    /// not finite.
    #[inline]
    pub fn over(c: DVec3, f: &[DVec3; 2]) -> Option<Prism> {
        let n = f[0].cross(f[1]);
        let den = n.length_squared();
        let scale = f[0].length_squared() * f[1].length_squared();
        if !(den > 1e-12 * scale && den.is_finite() && c.is_finite()) {
            return None;
        }
        let e = f[0].abs() + f[1].abs();
        let face = (e.x * e.y).max(e.y * e.z).max(e.x * e.z);
        // face <= THIN |n|, without the square root.
        if face * face <= THIN * THIN * den {
            return None;
        }
        let d = [f[1].cross(n) / den, n.cross(f[0]) / den];
        if !(d[0].is_finite() && d[1].is_finite()) {
            return None;
        }
        let lanes = |v: DVec3| {
            let v = v.as_vec3();
            [f32x4::splat(v.x), f32x4::splat(v.y), f32x4::splat(v.z)]
        };
        Some(Prism {
            axes: d.map(lanes),
            offsets: d.map(|d| f32x4::splat(d.dot(c) as f32)),
        })
    }

    /// Bit `k` set where the box `min[..][k]..max[..][k]` (four boxes side by side, per axis)
    /// lies apart from the prism: its extent along one of the prism's axes misses
    /// `[-1/2, 1/2]` by more than rounding.
    #[inline]
    pub fn apart(&self, min: &[[f32; 4]; 3], max: &[[f32; 4]; 3]) -> u32 {
        let half = f32x4::splat(0.5);
        let (mut centre, mut extent) = ([f32x4::ZERO; 3], [f32x4::ZERO; 3]);
        for axis in 0..3 {
            let (lo, hi) = (f32x4::from(min[axis]), f32x4::from(max[axis]));
            centre[axis] = half * (lo + hi);
            extent[axis] = half * (hi - lo);
        }
        let mut apart = f32x4::ZERO.simd_gt(f32x4::ONE);
        for (d, offset) in self.axes.iter().zip(self.offsets) {
            let mut at = -offset;
            let mut reach = f32x4::ZERO;
            let mut size = offset.abs();
            for axis in 0..3 {
                at += d[axis] * centre[axis];
                reach += d[axis].abs() * extent[axis];
                size += (d[axis] * centre[axis]).abs();
            }
            let limit = half + reach + f32x4::splat(PRISM_ROUNDING) * (size + reach);
            // Empty boxes (NaN centres) compare false: the box test has them.
            apart |= at.abs().simd_gt(limit);
        }
        apart.to_bitmask()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photons::footprint_bvh::{Aabb, FootprintBvh};
    use proptest::prelude::*;

    fn aabb(c: [f32; 3], h: [f32; 3]) -> Aabb {
        Aabb::centred(c, h)
    }

    proptest! {
        /// With a footprint's prism, the query still visits the leaf of every box that holds a
        /// point of the footprint, and only leaves the box query visits.
        #[test]
        fn the_prism_keeps_every_box_the_footprint_meets(
            items in prop::collection::vec(
                (
                    prop::array::uniform3(crate::util::strategies::f32_in(-10.0, 10.0)),
                    prop::array::uniform3(crate::util::strategies::f32_in(0.0, 1.5)),
                ),
                1..300,
            ),
            c in prop::array::uniform3(-8f64..8.0),
            f0 in prop::array::uniform3(-12f64..12.0),
            f1 in prop::array::uniform3(-12f64..12.0),
            thin in prop::sample::select(vec![1.0f64, 1e-1, 1e-3, 1e-5]),
        ) {
            let boxes: Vec<Aabb> = items.iter().map(|(c, h)| aabb(*c, *h)).collect();
            let (bvh, ids) = FootprintBvh::new(&boxes);
            // Thin footprints: the second edge close to the first.
            let (c, f0) = (DVec3::from(c), DVec3::from(f0));
            let f = [f0, f0 * 0.7 + DVec3::from(f1) * thin];
            let half = 0.5 * (f[0].abs() + f[1].abs());
            let query = Aabb { min: (c - half).as_vec3(), max: (c + half).as_vec3() };
            let prism = Prism::over(c, &f);
            let visited = |prism: Option<&Prism>| {
                let mut slots = Vec::new();
                bvh.leaves_meeting(&query, prism, |first, count| slots.extend(first..first + count));
                slots
            };
            let (all, kept) = (visited(None), visited(prism.as_ref()));
            prop_assert!(kept.iter().all(|s| all.contains(s)));
            for (slot, &id) in ids.iter().enumerate() {
                let b = &boxes[id as usize];
                let meets = (0..=32).any(|i| (0..=32).any(|j| {
                    let y = (c + f[0] * (i as f64 / 32.0 - 0.5) + f[1] * (j as f64 / 32.0 - 0.5)).as_vec3();
                    y.cmpge(b.min).all() && y.cmple(b.max).all()
                }));
                prop_assert!(!meets || kept.contains(&slot), "box {b:?} meets the footprint, slot {slot} not visited");
            }
        }
    }

    /// A needle across a field of boxes, askew to the axes: its bounding box holds nearly all
    /// of them, its prism a few.
    #[test]
    fn a_needle_askew_visits_few_leaves() {
        let mut boxes = Vec::new();
        for i in 0..100 {
            for j in 0..100 {
                boxes.push(aabb(
                    [i as f32 * 0.1, 0.0, j as f32 * 0.1],
                    [0.06, 0.001, 0.06],
                ));
            }
        }
        let (bvh, _) = FootprintBvh::new(&boxes);
        let (c, f) = (
            DVec3::new(5.0, 0.0, 5.0),
            [DVec3::new(9.0, 0.0, 9.0), DVec3::new(0.01, 0.0, -0.01)],
        );
        let half = 0.5 * (f[0].abs() + f[1].abs());
        let query = Aabb {
            min: (c - half).as_vec3(),
            max: (c + half).as_vec3(),
        };
        let count = |prism: Option<&Prism>| {
            let mut n = 0;
            bvh.leaves_meeting(&query, prism, |_, count| n += count);
            n
        };
        let prism = Prism::over(c, &f).expect("a thin footprint gets its prism");
        let (all, kept) = (count(None), count(Some(&prism)));
        assert!(all > 7000, "{all}");
        // The needle crosses about 180 boxes; leaves of 16 boxes (4 x 4 of the field) along
        // it hold some 800, an eighth of what its bounding box visits at most.
        assert!((180..all / 8).contains(&kept), "{kept} of {all}");
        // A square footprint along the axes is not worth the test.
        assert!(Prism::over(c, &[DVec3::X, DVec3::Z]).is_none());
        assert!(Prism::over(c, &[DVec3::X, DVec3::X * 2.0]).is_none());
    }
}
