//! Polygons to triangles: a fan when the polygon is convex, ear clipping in the polygon's own
//! plane when it is not (a fan would cover area outside a concave polygon). Triangles keep the
//! polygon's winding.

use super::ear_clip::{ear_clip, Ring};
use crate::util::reserve;
use glam::{DVec2, DVec3};

/// Concave polygons with more vertices than this are refused: ear clipping's worst case is
/// quadratic in the vertex count (testing every corner against every ear took 0.5 s at 16,384
/// vertices and 4.5 s at 65,536; the grid of `mesh_file::ear_clip` takes 0.015-0.025 s at
/// 16,384 on a star and a comb, but a polygon can still make it test most corners at every
/// ear). Convex ones of any size are fanned. (They were fanned above 4,096 whether convex or
/// not, which covered area outside a concave outline without a word.)
pub const MAX_EAR_CLIPPED: usize = 16_384;

/// What triangulating one polygon found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// A triangle, or a convex polygon (fanned from its first vertex).
    Convex,
    /// A concave polygon, ear-clipped.
    Concave,
    /// A polygon that crosses itself (it does not turn once around, or ear clipping found no
    /// ear): triangulated anyway, which may cover area the outline does not, or some twice.
    Crossing,
    /// A concave polygon of more than [`MAX_EAR_CLIPPED`] vertices: no triangle was emitted.
    TooLarge,
}

impl Shape {
    /// The error for a polygon of `n` vertices that triangulated as [`Shape::TooLarge`].
    pub fn too_large(n: usize) -> String {
        format!(
            "a concave polygon of {n} vertices: ear clipping takes at most {MAX_EAR_CLIPPED} \
             (its time grows as the square of the count); split or triangulate it first"
        )
    }
}

/// Triangulates the polygon of `n` corners whose positions `point(i)` gives, in order, calling
/// `emit` with each triangle's corner numbers (`0..n`). `scratch` is reused between calls so
/// that no polygon allocates.
pub fn triangulate(
    n: usize,
    point: impl Fn(usize) -> [f32; 3],
    scratch: &mut Scratch,
    mut emit: impl FnMut([usize; 3]),
) -> Shape {
    if n == 3 {
        emit([0, 1, 2]);
        return Shape::Convex;
    }
    let at = |i: usize| DVec3::from(point(i).map(f64::from));
    // Newell's normal: robust for non-planar and for polygons with collinear corners.
    let mut normal = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (at(i), at((i + 1) % n));
        normal += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    // A polygon whose lobes turn opposite ways (a bow tie) has a Newell normal of about
    // zero: its plane is then that of its first corners (it crosses itself, as the winding
    // below finds; projected along a zero normal it fell on a line).
    if normal.length() <= 1e-9 * extent_squared(n, &at) {
        let first = (2..n)
            .map(|k| (at(1) - at(0)).cross(at(k) - at(0)))
            .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()));
        if let Some(c) = first.filter(|c| *c != DVec3::ZERO) {
            normal = c;
        }
    }
    // Project along the normal's largest component, oriented so the polygon turns
    // counter-clockwise in 2D.
    let a = normal.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let (u, v) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let flip = normal[axis] < 0.0;
    scratch.points.clear();
    scratch.points.extend((0..n).map(|i| {
        let p = at(i);
        DVec2::new(p[u], if flip { -p[v] } else { p[v] })
    }));
    let pts = &scratch.points;
    let turn = |i: usize| {
        let (a, b, c) = (pts[(i + n - 1) % n], pts[i], pts[(i + 1) % n]);
        (b - a).perp_dot(c - b)
    };
    // Convex but for the positions' rounding to f32: a fine circle's corners turn by less
    // than its points' rounding moves them, so some seem to turn back.
    let reach = pts
        .iter()
        .fold(0.0_f64, |m, p| m.max(p.abs().max_element()));
    let rounding = |i: usize| {
        let (a, b, c) = (pts[(i + n - 1) % n], pts[i], pts[(i + 1) % n]);
        8.0 * f64::from(f32::EPSILON) * reach * ((b - a).length() + (c - b).length())
    };
    let convex = normal != DVec3::ZERO && (0..n).all(|i| turn(i) >= -rounding(i));
    // Turning one way at every corner and still crossing itself takes five corners and two
    // turns around (a pentagram); a fan covers its middle twice.
    if convex {
        for i in 1..n - 1 {
            emit([0, i, i + 1]);
        }
        return match n < 5 || winds_once(pts) != Some(false) {
            true => Shape::Convex,
            false => Shape::Crossing,
        };
    }
    if n > MAX_EAR_CLIPPED {
        return Shape::TooLarge;
    }
    let once = winds_once(&scratch.points);
    if ear_clip(&scratch.points, &mut scratch.ring, &mut emit) && once != Some(false) {
        Shape::Concave
    } else {
        Shape::Crossing
    }
}

/// The largest squared distance between the polygon's first corner and another: the scale a
/// zero normal is judged against.
fn extent_squared(n: usize, at: &impl Fn(usize) -> DVec3) -> f64 {
    (1..n).fold(0.0, |m, i| m.max((at(i) - at(0)).length_squared()))
}

/// Whether the outline `pts` turns once around (as a simple polygon, a keyhole's slit
/// included, does): the sum of its turning angles is `2 pi`. `None` where that cannot be told:
/// an edge doubles back on the one before (a turn of `pi`, as like one way as the other), or
/// every edge has zero length. Zero-length edges are skipped.
fn winds_once(pts: &[DVec2]) -> Option<bool> {
    let n = pts.len();
    let edges = (0..n)
        .map(|i| pts[(i + 1) % n] - pts[i])
        .filter(|e| *e != DVec2::ZERO);
    let (mut total, mut first, mut last) = (0.0, None, None::<DVec2>);
    for e in edges {
        if let Some(prev) = last {
            total += turn_angle(prev, e)?;
        }
        first = first.or(Some(e));
        last = Some(e);
    }
    total += turn_angle(last?, first?)?;
    Some((total - std::f64::consts::TAU).abs() < 0.5)
}

/// The angle from direction `a` to direction `b`, in `(-pi, pi)`; `None` for a reversal.
fn turn_angle(a: DVec2, b: DVec2) -> Option<f64> {
    let angle = a.perp_dot(b).atan2(a.dot(b));
    (angle.abs() < std::f64::consts::PI - 1e-9).then_some(angle)
}

/// Buffers reused across polygons.
#[derive(Debug, Default)]
pub struct Scratch {
    points: Vec<DVec2>,
    ring: Ring,
}

impl Scratch {
    /// Makes room for a polygon of `n` corners, or says it does not fit in the memory the
    /// process may still take: a face of ten million corners takes 160 MB of points in its
    /// plane while it is triangulated (and aborted under a memory limit, unchecked). (The
    /// ring's buffers are for ear clipping alone, at most [`MAX_EAR_CLIPPED`] corners.)
    pub fn make_room(&mut self, n: usize) -> Result<(), String> {
        if self.points.capacity() >= n {
            return Ok(());
        }
        self.points.clear();
        let what = format!("a polygon of {n} corners: its points in its plane");
        reserve::reserve_exact(&mut self.points, n, &what)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(order: &[u32], p: &[[f32; 3]]) -> (Shape, Vec<[u32; 3]>) {
        let mut out = Vec::new();
        let shape = triangulate(
            order.len(),
            |i| p[order[i] as usize],
            &mut Scratch::default(),
            |t| out.push(t.map(|i| order[i])),
        );
        (shape, out)
    }

    fn area(tris: &[[u32; 3]], p: &[[f32; 3]]) -> f64 {
        tris.iter()
            .map(|t| {
                let [a, b, c] = t.map(|k| DVec3::from(p[k as usize].map(f64::from)));
                (b - a).cross(c - a).z / 2.0
            })
            .sum()
    }

    #[test]
    fn convex_quad_is_a_fan() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let (s, out) = run(&[0, 1, 2, 3], &p);
        assert_eq!(s, Shape::Convex);
        assert_eq!(out, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn concave_polygons_are_covered_exactly_with_their_winding() {
        // An L shape (area 3), counter-clockwise seen from +z, starting at the reflex corner so
        // that a fan from the first corner would be wrong.
        let p = [
            [1.0, 1.0, 0.0],
            [1.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
        ];
        // The same polygon clockwise has area -3: both windings must be kept.
        for (order, expected) in [([0u32, 1, 2, 3, 4, 5], 3.0), ([5, 4, 3, 2, 1, 0], -3.0)] {
            let (s, out) = run(&order, &p);
            assert_eq!(s, Shape::Concave);
            assert_eq!(out.len(), 4);
            for t in &out {
                let a = area(&[*t], &p);
                assert!(a * expected > 0.0, "{t:?} has the wrong winding");
            }
            assert!((area(&out, &p) - expected).abs() < 1e-12);
        }
    }

    /// A 4 x 4 square with a 2 x 2 hole joined to its outline by a slit (area 12), its corners
    /// at the slit's ends written twice or named twice: it was fanned over its hole (area 16).
    #[test]
    fn a_keyhole_is_clipped_around_its_hole() {
        let p = [
            [0.0, 0.0, 0.0],
            [4.0, 0.0, 0.0],
            [4.0, 4.0, 0.0],
            [0.0, 4.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 3.0, 0.0],
            [3.0, 3.0, 0.0],
            [3.0, 1.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        for order in [
            [0u32, 1, 2, 3, 8, 9, 5, 6, 7, 4],
            [0, 1, 2, 3, 0, 4, 5, 6, 7, 4],
        ] {
            let (s, out) = run(&order, &p);
            assert_eq!(s, Shape::Concave);
            for t in &out {
                assert!(area(&[*t], &p) > 0.0, "{t:?} has the wrong winding");
            }
            assert!((area(&out, &p) - 12.0).abs() < 1e-12, "{out:?}");
            // No triangle covers the hole's centre.
            let inside = |t: &[u32; 3]| {
                let [a, b, c] =
                    t.map(|k| DVec2::new(p[k as usize][0].into(), p[k as usize][1].into()));
                let q = DVec2::new(2.0, 2.0);
                let s = [(a, b), (b, c), (c, a)].map(|(u, v)| (v - u).perp_dot(q - u));
                s.iter().all(|&x| x > 0.0)
            };
            assert!(!out.iter().any(inside), "{out:?}");
        }
    }

    #[test]
    fn large_concave_polygons_are_clipped_up_to_the_limit_and_refused_beyond() {
        // A star: corners alternately on circles of radius 1 and 0.9 (every other one
        // reflex). `tests/mesh_files.rs` checks an L's area through the loaders.
        let star = |n: usize| -> Vec<[f32; 3]> {
            (0..n)
                .map(|i| {
                    let a = i as f32 / n as f32 * std::f32::consts::TAU;
                    let r = if i % 2 == 0 { 1.0 } else { 0.9 };
                    [r * a.cos(), r * a.sin(), 0.0]
                })
                .collect()
        };
        for (n, shape) in [
            (MAX_EAR_CLIPPED, Shape::Concave),
            (MAX_EAR_CLIPPED + 2, Shape::TooLarge),
        ] {
            let p = star(n);
            let order: Vec<u32> = (0..n as u32).collect();
            let (s, out) = run(&order, &p);
            assert_eq!(
                (s, out.len()),
                (shape, if s == Shape::Concave { n - 2 } else { 0 })
            );
        }
        // Convex ones of any size are fanned, rounding to f32 notwithstanding.
        let circle: Vec<[f32; 3]> = (0..3 * MAX_EAR_CLIPPED)
            .map(|i| {
                let a = i as f32 / (3 * MAX_EAR_CLIPPED) as f32 * std::f32::consts::TAU;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let order: Vec<u32> = (0..circle.len() as u32).collect();
        let (s, out) = run(&order, &circle);
        assert_eq!((s, out.len()), (Shape::Convex, circle.len() - 2));
    }

    /// Polygons that cross themselves are told apart (the loaders warn of them): a bow tie,
    /// whose two lobes turn opposite ways, and a pentagram, which turns one way at every corner
    /// but twice around. Simple ones of the same corner counts are not.
    #[test]
    fn polygons_that_cross_themselves_are_told_apart() {
        let bow_tie = [
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        assert_eq!(run(&[0, 1, 2, 3], &bow_tie).0, Shape::Crossing);
        assert_eq!(run(&[0, 2, 1, 3], &bow_tie).0, Shape::Convex);
        let pentagon: Vec<[f32; 3]> = (0..5)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 5.0;
                [a.cos(), 0.0, a.sin()]
            })
            .collect();
        let (s, out) = run(&[0, 2, 4, 1, 3], &pentagon);
        assert_eq!((s, out.len()), (Shape::Crossing, 3));
        assert_eq!(run(&[0, 1, 2, 3, 4], &pentagon).0, Shape::Convex);
        assert_eq!(run(&[4, 3, 2, 1, 0], &pentagon).0, Shape::Convex);
        // A figure eight of six corners: two squares that meet where the outline crosses.
        let eight = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [2.0, 1.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.5, 2.0, 0.0],
        ];
        let (s, _) = run(&[0, 1, 2, 3, 4, 5], &eight);
        assert_eq!(s, Shape::Concave, "an L-like simple hexagon");
        let crossing = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, -1.0, 0.0],
            [0.0, -1.0, 0.0],
        ];
        assert_eq!(run(&[0, 1, 2, 3, 4, 5], &crossing).0, Shape::Crossing);
    }

    #[test]
    fn collinear_corners_make_no_degenerate_triangle() {
        // A square with an extra corner in the middle of one edge, and a notch.
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 2.0, 0.0],
        ];
        let (_, out) = run(&[0, 1, 2, 3, 4, 5], &p);
        assert!((area(&out, &p) - 3.0).abs() < 1e-12);
        assert!(out.iter().all(|t| area(&[*t], &p) > 0.0), "{out:?}");
    }
}
