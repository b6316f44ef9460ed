//! One walk of the footprint BVH for a packet of up to sixteen query boxes (a 4 x 4 block of
//! pixels' gathers): each node is fetched and tested once for the packet, and each leaf is
//! handed over with the set of queries whose boxes meet it.
//!
//! Why: at 1,280,000 caustic photons a gather's own walk pops about a hundred stack entries,
//! and the walks of neighbouring pixels visit nearly the same nodes. The packet walk keeps, for
//! every entry on its stack, the mask of the queries whose boxes meet every box on the way down
//! (a child's mask is its parent's and the queries that meet the child's box), which is the
//! very test a query's own walk makes at each level: each query meets the same leaves in the
//! same (leaf) order as it would alone, so its photons are found in the same order.

use super::{Aabb, FootprintBvh, WideNode, COUNT_BITS, NO_CHILD};
use glam::Vec3;
use wide::{f32x16, f32x4};

/// Queries a packet holds at most: the lanes of one `f32x16`.
pub const PACKET_SIZE: usize = 16;

/// Up to [`PACKET_SIZE`] query boxes side by side, lane `j` for query `j`, and their union.
pub struct PacketBoxes {
    min: [f32x16; 3],
    max: [f32x16; 3],
    union: Aabb,
    /// Bit `j` set where query `j` takes part.
    live: u32,
}

impl PacketBoxes {
    /// The packet of `boxes` (at most [`PACKET_SIZE`]) in which only the queries of the mask
    /// `live` take part (the others, left out, meet nothing).
    pub fn new(boxes: &[Aabb], live: u32) -> Self {
        assert!(
            boxes.len() <= PACKET_SIZE,
            "a packet holds at most 16 queries"
        );
        let live = live & ((1u64 << boxes.len()) - 1) as u32;
        let mut min = [[f32::INFINITY; PACKET_SIZE]; 3];
        let mut max = [[f32::NEG_INFINITY; PACKET_SIZE]; 3];
        let mut union = Aabb::EMPTY;
        for (j, b) in boxes.iter().enumerate() {
            if live & 1 << j == 0 {
                continue;
            }
            union = union.union(b);
            for axis in 0..3 {
                min[axis][j] = b.min[axis];
                max[axis][j] = b.max[axis];
            }
        }
        PacketBoxes {
            min: min.map(f32x16::from),
            max: max.map(f32x16::from),
            union,
            live,
        }
    }

    /// The queries (a mask) whose boxes share a point with child `k` of `node`: the test of
    /// [`WideNode::overlapping_children`], one query a lane.
    #[inline]
    fn meeting_child(&self, node: &WideNode, k: usize) -> u32 {
        let mut hit = f32x16::splat(f32::from_bits(u32::MAX));
        for axis in 0..3 {
            hit &= f32x16::splat(node.min[axis][k]).simd_le(self.max[axis]);
            hit &= self.min[axis].simd_le(f32x16::splat(node.max[axis][k]));
        }
        hit.to_bitmask() & self.live
    }
}

impl FootprintBvh {
    /// Calls `visit(first, count, queries)` with the slots of every leaf whose bounds overlap
    /// the box of at least one query of `packet`, in leaf order, and the mask of those queries:
    /// query `j` is in the mask of exactly the leaves that
    /// [`FootprintBvh::leaves_overlapping`] visits for its box alone.
    #[inline]
    pub fn leaves_meeting_packet(
        &self,
        packet: &PacketBoxes,
        mut visit: impl FnMut(usize, usize, u32),
    ) {
        if self.nodes.is_empty() || packet.live == 0 {
            return;
        }
        let lanes = |v: Vec3| [f32x4::splat(v.x), f32x4::splat(v.y), f32x4::splat(v.z)];
        // The union first, four children at once: most children that miss it are settled there.
        let union = [lanes(packet.union.min), lanes(packet.union.max)];
        // As deep as a lone query's stack (`leaves_meeting`), each entry with its mask.
        let mut stack = [(0u64, 0u32); 1 + 3 * 48];
        stack[0] = (0, packet.live);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (entry, mask) = stack[top];
            let count = (entry & ((1 << COUNT_BITS) - 1)) as usize;
            if count > 0 {
                visit((entry >> COUNT_BITS) as usize, count, mask);
                continue;
            }
            let node = &self.nodes[(entry >> COUNT_BITS) as usize];
            // Children pushed last first, so that child 0 is taken first: leaf order.
            let mut hit = node.overlapping_children(&union);
            while hit != 0 {
                let k = 31 - hit.leading_zeros();
                hit &= !(1 << k);
                let child = node.entry[k as usize];
                if child == NO_CHILD {
                    continue;
                }
                let meets = mask & packet.meeting_child(node, k as usize);
                if meets != 0 {
                    stack[top] = (child, meets);
                    top += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::strategies::f32_in;
    use proptest::prelude::*;

    fn boxes_of(seed: &[(f32, f32, f32, f32)]) -> Vec<Aabb> {
        seed.iter()
            .map(|&(x, y, z, h)| Aabb::centred([x, y, z], [h, h * 0.5, h * 2.0]))
            .collect()
    }

    proptest! {
        /// Each query of a packet meets the leaves its own walk meets, in the same order,
        /// whether the packet's boxes lie together or apart, and whichever take part.
        #[test]
        fn a_packet_walk_meets_what_each_query_meets_alone(
            items in prop::collection::vec((f32_in(0.0, 10.0), f32_in(0.0, 10.0), f32_in(0.0, 1.0), f32_in(0.01, 0.5)), 1..400),
            queries in prop::collection::vec((f32_in(0.0, 10.0), f32_in(0.0, 10.0), f32_in(0.0, 1.0), f32_in(0.0, 1.5)), 1..=16),
            live in any::<u32>(),
        ) {
            let (bvh, _) = FootprintBvh::new(&boxes_of(&items));
            let boxes = boxes_of(&queries);
            let packet = PacketBoxes::new(&boxes, live);
            let mut seen = vec![Vec::new(); boxes.len()];
            let mut empty_masks = 0;
            bvh.leaves_meeting_packet(&packet, |first, count, mask| {
                empty_masks += u32::from(mask == 0);
                for (j, seen) in seen.iter_mut().enumerate() {
                    if mask & 1 << j != 0 {
                        seen.push((first, count));
                    }
                }
            });
            prop_assert_eq!(empty_masks, 0);
            for (j, b) in boxes.iter().enumerate() {
                let mut alone = Vec::new();
                if live & 1 << j != 0 {
                    bvh.leaves_overlapping(b, |first, count| alone.push((first, count)));
                }
                prop_assert_eq!(&seen[j], &alone, "query {}", j);
            }
        }
    }

    #[test]
    fn an_empty_packet_or_tree_visits_nothing() {
        let (bvh, _) = FootprintBvh::new(&boxes_of(&[(1.0, 1.0, 0.0, 0.5)]));
        let boxes = boxes_of(&[(1.0, 1.0, 0.0, 0.5)]);
        let mut visits = 0;
        bvh.leaves_meeting_packet(&PacketBoxes::new(&boxes, 0), |_, _, _| visits += 1);
        FootprintBvh::new(&[])
            .0
            .leaves_meeting_packet(&PacketBoxes::new(&boxes, 1), |_, _, _| visits += 1);
        assert_eq!(visits, 0);
        bvh.leaves_meeting_packet(&PacketBoxes::new(&boxes, 1), |_, _, _| visits += 1);
        assert_eq!(visits, 1);
    }
}
