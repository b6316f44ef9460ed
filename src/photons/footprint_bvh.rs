//! A bounding-volume hierarchy over per-photon footprint boxes: the range query of the
//! footprint estimators.
//!
//! Why boxes of footprints rather than points: a query must find every photon whose footprint
//! (grown by the view footprint's reach) covers a point. A tree over photon *positions* must
//! search within the largest footprint radius around the point, so it returns every photon in
//! that ball, and the ball's content grows with the photon count while the footprints shrink.
//! A tree over each photon's own footprint box returns only photons whose box overlaps the query
//! box, which stays near `--overlap` photons whatever their number.
//!
//! Why our own builder rather than Embree's `rtcBuildBVH`: the tree is small and simple
//! (axis-aligned boxes, no ray traversal), a linear BVH (Karras 2012: Morton-sorted centres, split
//! at the highest differing bit) builds in one sort plus a linear pass in safe Rust, and keeping
//! it out of `src/embree` keeps the FFI surface (the only unsafe code) as it is.

use crate::photons::cover::OFF_PLANE_TOLERANCE;
use crate::photons::map::Photon;
use crate::photons::prism::Prism;
use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;
use wide::f32x4;

mod packet;
pub use packet::{PacketBoxes, PACKET_SIZE};

/// The box of every offset `v` from photon `p` at which its kernel may be non-zero: its ellipse
/// `|M v| < 1` thickened by [`OFF_PLANE_TOLERANCE`] along its normal (a slanted elliptic
/// cylinder). With `N` the rows `m[0]`, `m[1]`, `n / (t r)`, the cylinder is `N^-1` of the unit
/// disc times `[-1, 1]`, so its half-extent on axis `i` is
/// `sqrt(N^-1[i][0]^2 + N^-1[i][1]^2) + |N^-1[i][2]|`, exactly, whatever the rows. Rounded
/// outwards; a degenerate photon gets the box of the ball `|v| <= 1.1 r` (and one with
/// non-finite data a non-finite box, which the BVH never returns).
pub fn footprint_box(p: &Photon) -> Aabb {
    let r = p.radius as f64;
    let t = OFF_PLANE_TOLERANCE as f64 * r;
    let rows = DMat3::from_cols(
        p.m[0].as_dvec3(),
        p.m[1].as_dvec3(),
        p.normal.as_dvec3() / t,
    )
    .transpose();
    let inv = rows.inverse();
    let half = if rows.determinant().abs() > 0.0 && inv.is_finite() {
        // inv's columns are the images of the unit vectors of disc and segment.
        let (c0, c1, c2) = (inv.x_axis, inv.y_axis, inv.z_axis);
        (c0 * c0 + c1 * c1).map(f64::sqrt) + c2.abs()
    } else {
        DVec3::splat(1.1 * r)
    };
    let c = p.position;
    let half =
        (half * (1.0 + 1e-5)).as_vec3() + Vec3::splat(c.abs().max_element() * 4.0 * f32::EPSILON);
    Aabb {
        min: c - half,
        max: c + half,
    }
}

/// Photons per leaf at most (the lanes of [`crate::photons::cover::CoverTable::leaf`]).
pub const LEAF_SIZE: usize = 16;

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// The box of centre `c` and half-extents `h`.
    pub fn centred(c: [f32; 3], h: [f32; 3]) -> Aabb {
        let (c, h) = (Vec3::from(c), Vec3::from(h));
        Aabb {
            min: c - h,
            max: c + h,
        }
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Whether the boxes share a point (closed boxes: touching counts).
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }
}

/// A node: its bounds and either a range of leaf items (`count > 0`) or two children, the left
/// one directly after it and the right one at `index`.
#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: Aabb,
    index: u32,
    count: u32,
}

/// Four children of a node, their boxes side by side (a structure of arrays) so that a query
/// tests all four in one SIMD comparison. `entry[k]` is child `k`: a leaf, `first <<
/// COUNT_BITS | count` (`count` in `1..=LEAF_SIZE`), an inner node, `index << COUNT_BITS`, or
/// none, [`NO_CHILD`] (with an empty box). Children are in the binary tree's left-to-right order, so a
/// depth-first walk meets the leaves in leaf order.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct WideNode {
    min: [[f32; 4]; 3],
    max: [[f32; 4]; 3],
    entry: [u64; 4],
}

/// [`WideNode::entry`] of a missing child.
const NO_CHILD: u64 = u64::MAX;

// A leaf's count fits the entry's low `COUNT_BITS` bits.
const _: () = assert!(LEAF_SIZE < 1 << COUNT_BITS);

/// Low bits of [`WideNode::entry`] that hold a leaf's count.
const COUNT_BITS: u32 = 5;

impl WideNode {
    const EMPTY: WideNode = WideNode {
        min: [[f32::INFINITY; 4]; 3],
        max: [[f32::NEG_INFINITY; 4]; 3],
        entry: [NO_CHILD; 4],
    };

    fn set_bounds(&mut self, k: usize, b: &Aabb) {
        for axis in 0..3 {
            self.min[axis][k] = b.min[axis];
            self.max[axis][k] = b.max[axis];
        }
    }

    /// Bit `k` set where child `k`'s box shares a point with `q` (`q`: the query's min and max
    /// per axis, in every lane).
    #[inline]
    fn overlapping_children(&self, q: &[[f32x4; 3]; 2]) -> u32 {
        let [lo, hi] = q;
        let mut hit = f32x4::splat(f32::from_bits(u32::MAX));
        for (axis, (lo, hi)) in lo.iter().zip(hi).enumerate() {
            hit &= f32x4::from(self.min[axis]).simd_le(*hi);
            hit &= lo.simd_le(f32x4::from(self.max[axis]));
        }
        hit.to_bitmask()
    }
}

/// A BVH over boxes, each tagged with the `u32` it was given at (its index in the input).
///
/// Built binary (a linear BVH), then collapsed to four children a node: a query descends half
/// as many levels and tests a node's four boxes at once. Same leaves, visited in the same
/// order.
///
/// The leaves hold slots `0..len`, numbered in leaf order; [`FootprintBvh::new`] gives the
/// order beside the tree (which input item each slot holds), for the caller to lay its items
/// out in. The tree keeps neither the items' boxes nor that order: a photon map holds what its
/// queries test of each photon in its own slot order ([`crate::photons::cover::CoverTable`]),
/// and the boxes and indices kept here besides were 28 bytes a photon never read.
pub struct FootprintBvh {
    nodes: Vec<WideNode>,
    /// Number of items (slots).
    len: usize,
}

/// Spreads the low 21 bits of `v` to every third bit.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

impl FootprintBvh {
    /// Builds the hierarchy over `boxes`, and gives the order of its slots: `order[k]` is the
    /// index in `boxes` of the item in slot `k`. Non-finite boxes are left out (never found).
    pub fn new(boxes: &[Aabb]) -> (Self, Vec<u32>) {
        // Morton codes of the box centres over the centres' bounds; ties broken by index, so
        // the tree (and the order of query results) depends only on the input.
        // Every step over all the boxes runs on the worker threads, in order (minima and
        // maxima do not depend on it): on one thread these passes took a third of loading
        // 1.28M photons' maps.
        let finite: Vec<u32> = (0..boxes.len() as u32)
            .into_par_iter()
            .filter(|&i| {
                let b = &boxes[i as usize];
                b.min.is_finite() && b.max.is_finite()
            })
            .collect();
        let (lo, hi) = finite
            .par_iter()
            .map(|&i| {
                let b = &boxes[i as usize];
                let c = 0.5 * (b.min + b.max);
                (c, c)
            })
            .reduce(
                || (Vec3::INFINITY, Vec3::NEG_INFINITY),
                |(lo, hi), (l, h)| (lo.min(l), hi.max(h)),
            );
        let scale = ((1u32 << 21) - 1) as f32 / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
        let mut keyed: Vec<(u64, u32)> = finite
            .par_iter()
            .map(|&i| {
                let b = &boxes[i as usize];
                let q = ((0.5 * (b.min + b.max) - lo) * scale)
                    .clamp(Vec3::ZERO, Vec3::splat(2097151.0));
                let code = spread(q.x as u64) << 2 | spread(q.y as u64) << 1 | spread(q.z as u64);
                (code, i)
            })
            .collect();
        keyed.par_sort_unstable();
        let codes: Vec<u64> = keyed.par_iter().map(|k| k.0).collect();
        let ids: Vec<u32> = keyed.par_iter().map(|k| k.1).collect();
        let boxes: Vec<Aabb> = ids.par_iter().map(|&i| boxes[i as usize]).collect();
        let mut binary = Vec::with_capacity(2 * ids.len() / LEAF_SIZE + 1);
        if !ids.is_empty() {
            build(&boxes, &codes, 0, codes.len(), &mut binary);
        }
        let mut nodes = Vec::with_capacity(binary.len() / 3 + 1);
        if !binary.is_empty() {
            collapse(&binary, 0, &mut nodes);
        }
        let len = ids.len();
        (FootprintBvh { nodes, len }, ids)
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the hierarchy holds no item.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends to `out` (not cleared) the indices in `boxes` of every item whose box overlaps
    /// `query`, in leaf order, for the tree built over `boxes` with slot order `order`.
    pub fn overlapping(&self, boxes: &[Aabb], order: &[u32], query: &Aabb, out: &mut Vec<u32>) {
        self.leaves_overlapping(query, |first, count| {
            for &id in &order[first..first + count] {
                if boxes[id as usize].overlaps(query) {
                    out.push(id);
                }
            }
        });
    }

    /// Calls `visit(first, count)` with the slots of every leaf whose bounds overlap `query`,
    /// in leaf order (`count <= LEAF_SIZE`; slot `k` holds item `order[k]` of the order
    /// [`FootprintBvh::new`] gave).
    #[inline]
    pub fn leaves_overlapping(&self, query: &Aabb, visit: impl FnMut(usize, usize)) {
        self.leaves_meeting(query, None, visit);
    }

    /// [`FootprintBvh::leaves_overlapping`], and where `prism` is given, only the leaves whose
    /// bounds also meet it (the box and the prism are not separated along either of its axes).
    #[inline]
    pub fn leaves_meeting(
        &self,
        query: &Aabb,
        prism: Option<&Prism>,
        mut visit: impl FnMut(usize, usize),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let lanes = |v: Vec3| [f32x4::splat(v.x), f32x4::splat(v.y), f32x4::splat(v.z)];
        let q = [lanes(query.min), lanes(query.max)];
        // The binary tree is at most 63 bit levels plus 32 halvings of equal codes deep, the
        // collapsed one at most 48, and each node leaves at most three children on the stack.
        let mut stack = [0u64; 1 + 3 * 48];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let entry = stack[top];
            let count = (entry & ((1 << COUNT_BITS) - 1)) as usize;
            if count > 0 {
                visit((entry >> COUNT_BITS) as usize, count);
                continue;
            }
            let node = &self.nodes[(entry >> COUNT_BITS) as usize];
            // Children pushed last first, so that child 0 is taken first: leaf order.
            let mut hit = node.overlapping_children(&q);
            if let Some(prism) = prism.filter(|_| hit != 0) {
                hit &= !prism.apart(&node.min, &node.max);
            }
            while hit != 0 {
                let k = 31 - hit.leading_zeros();
                hit &= !(1 << k);
                let child = node.entry[k as usize];
                if child != NO_CHILD {
                    stack[top] = child;
                    top += 1;
                }
            }
        }
    }
}

/// Builds the binary subtree over items `first..end` (sorted by code) into `nodes`; returns
/// its bounds.
fn build(boxes: &[Aabb], codes: &[u64], first: usize, end: usize, nodes: &mut Vec<Node>) -> Aabb {
    let me = nodes.len();
    nodes.push(Node {
        bounds: Aabb::EMPTY,
        index: first as u32,
        count: (end - first) as u32,
    });
    if end - first <= LEAF_SIZE {
        let bounds = boxes[first..end]
            .iter()
            .fold(Aabb::EMPTY, |a, b| a.union(b));
        nodes[me].bounds = bounds;
        return bounds;
    }
    let split = split_point(codes, first, end);
    let left = build(boxes, codes, first, split, nodes);
    let right_index = nodes.len() as u32;
    let right = build(boxes, codes, split, end, nodes);
    let bounds = left.union(&right);
    nodes[me] = Node {
        bounds,
        index: right_index,
        count: 0,
    };
    bounds
}

/// A binary leaf's [`WideNode::entry`].
fn leaf_entry(node: &Node) -> u64 {
    u64::from(node.index) << COUNT_BITS | u64::from(node.count)
}

/// Appends the wide node of binary node `at` and, before returning, those of its inner
/// children; returns its index. Its children are the binary node's grandchildren, or its
/// children where they are leaves, in left-to-right order; a leaf (a tree of one leaf) is its
/// own only child.
fn collapse(binary: &[Node], at: usize, nodes: &mut Vec<WideNode>) -> usize {
    let me = nodes.len();
    nodes.push(WideNode::EMPTY);
    // At most four children, in a fixed array: a `Vec` here allocated once per node.
    let mut children = [0usize; 4];
    let mut n = 0;
    let mut push = |c: usize| {
        children[n] = c;
        n += 1;
    };
    if binary[at].count > 0 {
        push(at);
    } else {
        for c in [at + 1, binary[at].index as usize] {
            if binary[c].count > 0 {
                push(c);
            } else {
                push(c + 1);
                push(binary[c].index as usize);
            }
        }
    }
    let mut node = WideNode::EMPTY;
    for (k, &c) in children[..n].iter().enumerate() {
        node.set_bounds(k, &binary[c].bounds);
        node.entry[k] = if binary[c].count > 0 {
            leaf_entry(&binary[c])
        } else {
            (collapse(binary, c, nodes) as u64) << COUNT_BITS
        };
    }
    nodes[me] = node;
    me
}

/// Where to split items `first..end` (sorted by code, at least two): after the last item that
/// shares the range's highest differing bit's zero, or in the middle when all codes are equal.
fn split_point(codes: &[u64], first: usize, end: usize) -> usize {
    let (a, b) = (codes[first], codes[end - 1]);
    if a == b {
        return (first + end) / 2;
    }
    let prefix = (a ^ b).leading_zeros();
    // Binary search for the first code whose bit below the common prefix is set.
    let mut lo = first; // has the bit clear
    let mut hi = end - 1; // has the bit set
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if (a ^ codes[mid]).leading_zeros() > prefix {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photons::footprint::{footprint, FootprintLimits, Guards};
    use crate::util::strategies::f32_in;
    use proptest::prelude::*;

    fn aabb(c: [f32; 3], h: [f32; 3]) -> Aabb {
        Aabb::centred(c, h)
    }

    fn brute(boxes: &[Aabb], q: &Aabb) -> Vec<u32> {
        (0..boxes.len() as u32)
            .filter(|&i| boxes[i as usize].overlaps(q))
            .collect()
    }

    proptest! {
        #[test]
        fn finds_exactly_the_overlapping_boxes(
            items in prop::collection::vec(
                (prop::array::uniform3(f32_in(-10.0, 10.0)), prop::array::uniform3(f32_in(0.0, 1.5))), 0..400),
            queries in prop::collection::vec(
                (prop::array::uniform3(f32_in(-11.0, 11.0)), prop::array::uniform3(f32_in(0.0, 2.0))), 1..20),
            duplicates in 0usize..50,
        ) {
            let mut boxes: Vec<Aabb> = items.iter().map(|(c, h)| aabb(*c, *h)).collect();
            // Equal centres (equal Morton codes) must split too.
            for k in 0..duplicates.min(boxes.len()) {
                boxes.push(boxes[k]);
            }
            let (bvh, order) = FootprintBvh::new(&boxes);
            prop_assert_eq!(bvh.len(), boxes.len());
            for (c, h) in &queries {
                let q = aabb(*c, *h);
                let mut found = Vec::new();
                bvh.overlapping(&boxes, &order, &q, &mut found);
                found.sort_unstable();
                prop_assert_eq!(found, brute(&boxes, &q));
            }
            // Leaves come in leaf order (the order sums over them are taken in), each once.
            let mut slots = Vec::new();
            bvh.leaves_overlapping(&aabb([0.0; 3], [20.0; 3]), |first, count| {
                slots.extend(first..first + count);
            });
            prop_assert_eq!(slots, (0..boxes.len()).collect::<Vec<_>>());
            for (c, h) in &queries {
                let mut last = None;
                bvh.leaves_overlapping(&aabb(*c, *h), |first, count| {
                    assert!((1..=LEAF_SIZE).contains(&count));
                    assert!(last.is_none_or(|l| l < first), "{last:?} then {first}");
                    last = Some(first + count - 1);
                });
            }
        }

        #[test]
        fn footprint_box_holds_the_kernel_support_and_touches_it(
            a in prop::array::uniform3(-1f64..1.0),
            b in prop::array::uniform3(-1f64..1.0),
            n in prop::array::uniform3(-1f64..1.0),
            centre in prop::array::uniform3(-5f64..5.0),
            scale in 0.001f64..1.0,
        ) {
            let n = DVec3::from(n);
            prop_assume!(n.length() > 0.1);
            let n = n.normalize();
            let limits = FootprintLimits { min_radius: 1e-4, max_radius: 10.0, max_anisotropy: 8.0 };
            let f = footprint(
                DVec3::from(a) * scale, DVec3::from(b) * scale, n, &limits, 0.1,
                &mut Guards::default());
            let p = Photon::new(DVec3::from(centre), n, -n, DVec3::ONE, &f);
            let bx = footprint_box(&p);
            // Points of the support's boundary: the ellipse's rim at both slab faces.
            let (t1, t2) = crate::geometry::sampling::tangent_frame(n);
            let mut reached = Vec3::ZERO;
            for k in 0..720 {
                let phi = k as f64 * std::f64::consts::TAU / 720.0;
                // Tangent offset on the ellipse |M w| = 1 along direction phi.
                let d = t1 * phi.cos() + t2 * phi.sin();
                let md = (f.m[0].dot(d).powi(2) + f.m[1].dot(d).powi(2)).sqrt();
                for h in [-1.0, 1.0] {
                    let v = d / md * 0.99999 + n * (h * 0.99999 * OFF_PLANE_TOLERANCE as f64 * f.radius);
                    let x = (DVec3::from(centre) + v).as_vec3();
                    prop_assert!(
                        x.cmpge(bx.min).all() && x.cmple(bx.max).all(),
                        "{x} outside {bx:?}"
                    );
                    reached = reached.max(v.abs().as_vec3());
                }
            }
            // Tight: the sampled rim reaches the box's half-extent within 0.1%.
            let half = 0.5 * (bx.max - bx.min);
            for i in 0..3 {
                prop_assert!(reached[i] >= 0.999 * half[i] - 1e-5, "{reached} vs {half}");
            }
        }
    }

    #[test]
    fn empty_and_non_finite_boxes_are_never_found() {
        let (bvh, order) = FootprintBvh::new(&[]);
        let mut out = Vec::new();
        bvh.overlapping(&[], &order, &aabb([0.0; 3], [1e9; 3]), &mut out);
        assert!(out.is_empty() && bvh.is_empty() && order.is_empty());
        let boxes = [
            aabb([0.0; 3], [1.0; 3]),
            aabb([f32::NAN, 0.0, 0.0], [1.0; 3]),
            aabb([2.0; 3], [0.5; 3]),
        ];
        let (bvh, order) = FootprintBvh::new(&boxes);
        bvh.overlapping(&boxes, &order, &aabb([0.0; 3], [1e9; 3]), &mut out);
        out.sort_unstable();
        assert_eq!(out, vec![0, 2]);
        assert_eq!(bvh.len(), 2);
        assert!(order == [0, 2] || order == [2, 0], "{order:?}");
    }
}
