//! Footprints that run into a wall or off an edge: a mirror photon beyond the wall gives back
//! the part of the footprint no gather sees (the reflection method of kernel density
//! estimation).
//!
//! Why: a photon stored beside a wall (the floor at the foot of a box) or near the end of its
//! surface (the box's top, near its rim) has a footprint of which part lies under the wall or in
//! the air, where no gather ever looks. That part of its power is lost, and every estimate within
//! a footprint's radius of a wall or an edge is too dark: half as bright at the wall itself, in
//! the limit of many photons. Progressive passes narrow the dark band only as fast as the
//! footprints' radius shrinks (`N^((alpha - 1) / 2)`, slower than the noise falls): on the
//! over-an-edge stress scene, where the caustic peaks at the foot of a box, it was most of the
//! caustic's error after 64 passes (README, "Photon maps", "Walls and edges").
//!
//! Spreading the photon's power over the share of its footprint that is seen conserves the power
//! but not where it lands: at the wall of an evenly lit floor it gives 0.75 of the light, not
//! 0.5 or 1 (every photon near the wall is brightened by its own share, and the wall's foot sees
//! only photons on one side). Mirroring the photon across the wall's line gives exactly 1 there:
//! with the mirror, every photon's kernel is whole on the seen side, as if the floor went on past
//! the wall with the same light. The mirror photon sits behind the wall (or in the air beyond
//! the rim), where no gather looks; the part of its footprint on the seen side is exactly the part
//! of the photon's footprint beyond the line, so the power gathered is the photon's.
//!
//! Where the wall is: [`PROBES`] rays in the footprint's plane, in the directions of the centres
//! of [`SECTORS`] equal sectors of its filter space's unit disc, each from two points:
//! - just above the surface (the scene's ray offset): it meets a wall standing on the surface,
//!   the foot of the box, and passes under anything that only overhangs it;
//! - a depth `h` below it, inside a closed solid: it meets the solid's own faces where the
//!   surface ends at a convex edge, the rim of the box's top. `h` is how far off its plane a
//!   gather still sees a photon ([`OFF_PLANE_TOLERANCE`] times the footprint's radius): a
//!   surface that bends away more slowly still holds the gathers that see the photon.
//!
//! A probe stops only at a face steeper than 45 degrees to the photon's plane (`MAX_COS`).
//! Each ray runs to the footprint's boundary in its direction (its direction is the footprint's
//! radius vector there, so it ends at `t = 1`). The face the nearest stop met (nearest to the
//! photon across the face's line) gives the line: where its plane meets the photon's plane. A
//! ray from that probe's origin straight to where the mirror would go must meet the wall too:
//! beside a box's outer corner a face's line runs on past the face, and the mirror would land
//! on open floor. If it does not, the next nearest line is tried (of `CHECKED`), else the
//! photon is not mirrored. In an inner corner, where a second checked wall stands square to the
//! first, the photon gets three images (across either wall and across both: the reflection
//! method in a quadrant); a wedge of another angle keeps the nearer wall's mirror only. Sixteen
//! probes are one Embree packet per photon, the checks one more call for the few that stop.

mod mirror;
mod screen;

pub use mirror::{Image, Wall, WallPair, MAX_SQUARE_COS};
pub use screen::Walls;

use crate::embree::{self, Ray, PACKET_WIDTH};
use crate::photons::cover::OFF_PLANE_TOLERANCE;
use crate::photons::footprint::Footprint;
use glam::DVec3;

/// Sectors of the footprint probed, each by a ray above and a ray below the surface.
pub const SECTORS: usize = 8;

/// Rays per photon: one packet.
pub const PROBES: usize = 2 * SECTORS;

const _: () = assert!(PROBES == PACKET_WIDTH);

/// `(cos, sin)` of the sectors' centre angles, `(k + 1/2) 45` degrees: constants rather than
/// eight `sin_cos` calls for every photon.
const SECTOR_CENTRES: [(f64, f64); SECTORS] = {
    const C: f64 = 0.923_879_532_511_286_7; // cos 22.5 degrees
    const S: f64 = 0.382_683_432_365_089_8; // sin 22.5 degrees
    [
        (C, S),
        (S, C),
        (-S, C),
        (-C, S),
        (-C, -S),
        (-S, -C),
        (S, -C),
        (C, -S),
    ]
};

/// Walls of different lines checked for a photon, nearest first (see [`nearest_walls`]).
const CHECKED: usize = 3;

/// A probe stops at a face more than 45 degrees off the photon's plane (the cosine of the angle
/// between their normals below this) and passes any other: at the creases of a tessellated
/// curved surface, which a probe meets at a grazing angle, the surface continues for the
/// gathers (they accept points a little off a photon's plane), and so does the floor under the
/// bottom of a sphere resting on it, which the camera may see through glass.
pub(crate) const MAX_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// What the probes of a photon with `footprint` span: its radius vectors along the filter
/// matrix's rows (row k is `axis_k / s_k`; each probe's direction is a unit combination of the
/// two, and it runs to `t = 1`), and the depth below the surface of the lower probes (at least
/// `epsilon`, as the upper ones start `epsilon` above it). `None` for a degenerate footprint,
/// which is not probed.
pub(crate) fn probe_extent(footprint: &Footprint, epsilon: f64) -> Option<([DVec3; 2], f64)> {
    let axes = footprint.m.map(|row| row / row.length_squared());
    let depth = (OFF_PLANE_TOLERANCE as f64 * footprint.radius).max(epsilon);
    (axes[0].is_finite() && axes[1].is_finite() && depth.is_finite()).then_some((axes, depth))
}

/// The wall or edge within the footprint of a photon at `position` on a surface of unit normal
/// `normal` (see the module's comment), or `None` when the surface goes on to the footprint's
/// edge all round. `epsilon` is the scene's ray offset: the probes start at least that far off
/// the surface.
pub fn nearest_walls(
    embree: &embree::Scene,
    position: DVec3,
    normal: DVec3,
    footprint: &Footprint,
    epsilon: f64,
) -> Option<WallPair> {
    let (axes, depth) = probe_extent(footprint, epsilon)?;
    let mut rays = [Ray::new(DVec3::ZERO, DVec3::X); PROBES];
    for (k, &(cos, sin)) in SECTOR_CENTRES.iter().enumerate() {
        let direction = axes[0] * cos + axes[1] * sin;
        rays[2 * k] = Ray::segment(position + normal * epsilon, direction, 1.0);
        rays[2 * k + 1] = Ray::segment(position - normal * depth, direction, 1.0);
    }
    let mut hits = [None; PROBES];
    embree.hit_normals16(&rays, false, &mut hits);
    let stops = |ray: &Ray, hit: Option<(f64, DVec3)>| {
        hit.filter(|&(t, face)| face.dot(normal).abs() < MAX_COS && t <= 1.0)
            .map(|(t, face)| (ray.origin, ray.direction * t, face))
    };
    // Each stop's wall, nearest first: the face's line in the photon's plane, its normal
    // turned towards the photon's probe; with the probe's origin (above or below).
    let mut walls: Vec<(Wall, DVec3)> = rays
        .iter()
        .zip(hits)
        .filter_map(|(ray, hit)| stops(ray, hit))
        .map(|(origin, reach, face)| {
            let mut line = (face - normal * face.dot(normal)).normalize();
            if line.dot(reach) < 0.0 {
                line = -line;
            }
            let wall = Wall {
                normal: line,
                distance: reach.dot(line),
            };
            (wall, origin)
        })
        .collect();
    if walls.is_empty() {
        // Most photons: nothing within reach, and no check to make.
        return None;
    }
    walls.sort_by(|a, b| a.0.distance.total_cmp(&b.0.distance));
    // The nearest few walls of different lines, each checked by a ray from its probe's
    // origin straight to where the mirror would be: the wall must stand in its way. Beside a
    // box's outer corner the line of a face runs on past the face, and a mirror across it
    // would land on open floor, brightening it.
    let mut candidates: Vec<(Wall, DVec3)> = Vec::with_capacity(CHECKED);
    for &(wall, origin) in &walls {
        if candidates.len() == CHECKED {
            break;
        }
        if candidates
            .iter()
            .all(|(w, _)| w.normal.dot(wall.normal) < 0.99)
        {
            candidates.push((wall, origin));
        }
    }
    let checks: Vec<Ray> = candidates
        .iter()
        .map(|(w, origin)| Ray::segment(*origin, w.normal * (2.0 * w.distance), 1.0))
        .collect();
    let mut answers = [None; PROBES];
    embree.hit_normals16(&checks, false, &mut answers);
    let mut standing = candidates
        .iter()
        .zip(checks.iter().zip(answers))
        .filter(|(_, (ray, hit))| stops(ray, *hit).is_some())
        .map(|((wall, _), _)| *wall);
    let first = standing.next()?;
    // A second wall square to the first: the footprint reaches into an inner corner (or, on a
    // box's top, over two rims that meet).
    let second = standing.find(|w| w.normal.dot(first.normal).abs() < MAX_SQUARE_COS);
    Some(WallPair { first, second })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sector_centres_are_the_half_sector_angles() {
        for (k, &(cos, sin)) in SECTOR_CENTRES.iter().enumerate() {
            let angle = (k as f64 + 0.5) * std::f64::consts::TAU / SECTORS as f64;
            assert!((cos - angle.cos()).abs() < 1e-15 && (sin - angle.sin()).abs() < 1e-15);
        }
    }
}
