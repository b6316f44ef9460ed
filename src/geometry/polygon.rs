//! Convex polygons in the plane: area and centroid, and robust intersection (clipping one convex
//! polygon by another). Used by the coplanar intersection-weighted estimate.
//!
//! Robustness: inputs may be given in either orientation and may hold duplicate or collinear
//! vertices; touching edges, one polygon inside the other, zero-area and disjoint polygons all
//! give a finite answer (an empty or zero-area intersection where there is no overlap).

use glam::DVec2;

mod unit_square;
pub use unit_square::{clip_to_unit_square, UnitPolygon};

/// Twice the signed area of a polygon (positive when counter-clockwise).
fn twice_signed_area(points: &[DVec2]) -> f64 {
    let n = points.len();
    (0..n)
        .map(|i| points[i].perp_dot(points[(i + 1) % n]))
        .sum()
}

/// Area (non-negative) and centroid of a simple polygon. A polygon of zero area has the mean of
/// its vertices as centroid (and the origin when it has none).
pub fn area_centroid(points: &[DVec2]) -> (f64, DVec2) {
    if points.is_empty() {
        return (0.0, DVec2::ZERO);
    }
    // Relative to the first vertex, for precision far from the origin.
    let o = points[0];
    let mut a2 = 0.0;
    let mut c = DVec2::ZERO;
    // Edge by edge, the last closing the polygon (pairs by iterator: an index modulo the
    // length costs a division a vertex).
    for (&p, &q) in points.iter().zip(points[1..].iter().chain(&points[..1])) {
        let (p, q) = (p - o, q - o);
        let cross = p.perp_dot(q);
        a2 += cross;
        c += (p + q) * cross;
    }
    let mean = || points.iter().copied().sum::<DVec2>() / points.len() as f64;
    if a2.abs() <= 1e-300 || !a2.is_finite() {
        return (0.0, mean());
    }
    let centroid = o + c / (3.0 * a2);
    if !centroid.is_finite() {
        return (0.0, mean());
    }
    (0.5 * a2.abs(), centroid)
}

/// `points` counter-clockwise, without consecutive duplicates, into `out`.
fn normalise_into(points: &[DVec2], out: &mut Vec<DVec2>) {
    out.clear();
    for &p in points {
        if out.last() != Some(&p) {
            out.push(p);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    if twice_signed_area(out) < 0.0 {
        out.reverse();
    }
}

/// Buffers reused across intersections, so that clipping allocates nothing once warm.
#[derive(Debug, Default, Clone)]
pub struct ClipScratch {
    clip: Vec<DVec2>,
    current: Vec<DVec2>,
    next: Vec<DVec2>,
}

/// The intersection of two convex polygons (vertices in order, either orientation), as a convex
/// counter-clockwise polygon; empty when they do not overlap.
pub fn intersect_convex(subject: &[DVec2], clip: &[DVec2]) -> Vec<DVec2> {
    intersect_convex_with(subject, clip, &mut ClipScratch::default()).to_vec()
}

/// [`intersect_convex`] with reusable buffers; the result lives in `scratch`.
pub fn intersect_convex_with<'s>(
    subject: &[DVec2],
    clip: &[DVec2],
    scratch: &'s mut ClipScratch,
) -> &'s [DVec2] {
    let ClipScratch {
        clip: clip_buf,
        current,
        next,
    } = scratch;
    normalise_into(clip, clip_buf);
    normalise_into(subject, current);
    let clip = &*clip_buf;
    if clip.len() < 3 || current.len() < 3 || twice_signed_area(clip) <= 0.0 {
        current.clear();
        return current;
    }
    // Scale of the inputs, for a tolerance on "inside" that is relative, not absolute.
    let scale = clip
        .iter()
        .chain(current.iter())
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max)
        .max(1e-300);
    for i in 0..clip.len() {
        let a = clip[i];
        let b = clip[(i + 1) % clip.len()];
        let edge = b - a;
        let len = edge.length();
        if len <= 1e-15 * scale {
            continue; // a degenerate edge clips nothing
        }
        // Signed distance to the edge's line, positive inside (left of a counter-clockwise edge).
        let side = |p: DVec2| edge.perp_dot(p - a) / len;
        let tol = 1e-12 * scale;
        next.clear();
        let current_ref: &Vec<DVec2> = current;
        for j in 0..current_ref.len() {
            let p = current_ref[j];
            let q = current_ref[(j + 1) % current_ref.len()];
            let (dp, dq) = (side(p), side(q));
            let (p_in, q_in) = (dp >= -tol, dq >= -tol);
            if p_in {
                next.push(p);
            }
            if p_in != q_in && (dp - dq).abs() > 0.0 {
                let t = (dp / (dp - dq)).clamp(0.0, 1.0);
                next.push(p + (q - p) * t);
            }
        }
        std::mem::swap(current, next);
        if current.len() < 3 {
            current.clear();
            return current;
        }
    }
    normalise_into(current, next);
    std::mem::swap(current, next);
    current
}

/// The parallelogram `centre +- u/2 +- v/2`.
pub fn parallelogram(centre: DVec2, u: DVec2, v: DVec2) -> [DVec2; 4] {
    let (hu, hv) = (u * 0.5, v * 0.5);
    [
        centre - hu - hv,
        centre + hu - hv,
        centre + hu + hv,
        centre - hu + hv,
    ]
}

/// The ellipse `centre + cos(t) a + sin(t) b` as a polygon of `n` vertices (at least 3),
/// inscribed in it.
pub fn ellipse(centre: DVec2, a: DVec2, b: DVec2, n: usize) -> Vec<DVec2> {
    let unit = unit_circle(n);
    let mut out = Vec::new();
    ellipse_into(centre, a, b, &unit, &mut out);
    out
}

/// `(cos, sin)` of `n` (at least 3) equally spaced angles: an ellipse's polygon is then an
/// affine image of it.
pub fn unit_circle(n: usize) -> Vec<DVec2> {
    let n = n.max(3);
    (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            DVec2::new(t.cos(), t.sin())
        })
        .collect()
}

/// The ellipse polygon `centre + c.x a + c.y b` for each `c` of `unit` into `out`.
pub fn ellipse_into(centre: DVec2, a: DVec2, b: DVec2, unit: &[DVec2], out: &mut Vec<DVec2>) {
    out.clear();
    out.extend(unit.iter().map(|c| centre + a * c.x + b * c.y));
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain); collinear points
/// are dropped.
pub fn convex_hull(points: &[DVec2]) -> Vec<DVec2> {
    let mut pts: Vec<DVec2> = points.iter().copied().filter(|p| p.is_finite()).collect();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2 {
                let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
                if (b - a).perp_dot(p - a) <= 0.0 {
                    hull.pop();
                } else {
                    break;
                }
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(c: DVec2, s: f64) -> Vec<DVec2> {
        parallelogram(c, DVec2::X * s, DVec2::Y * s).to_vec()
    }

    #[test]
    fn known_intersections() {
        let a = square(DVec2::ZERO, 2.0);
        let b = square(DVec2::new(1.0, 1.0), 2.0);
        let (area, c) = area_centroid(&intersect_convex(&a, &b));
        assert!((area - 1.0).abs() < 1e-12 && (c - DVec2::splat(0.5)).length() < 1e-12);
        // Touching along an edge: zero area, no NaN.
        let t = square(DVec2::new(2.0, 0.0), 2.0);
        let (area, c) = area_centroid(&intersect_convex(&a, &t));
        assert!(area.abs() < 1e-12 && c.is_finite());
        // Disjoint.
        assert!(intersect_convex(&a, &square(DVec2::new(5.0, 0.0), 1.0)).is_empty());
        // Clockwise input, duplicate and collinear vertices.
        let mut cw = vec![
            DVec2::new(-1.0, -1.0),
            DVec2::new(-1.0, 1.0),
            DVec2::new(-1.0, 1.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, -1.0),
        ];
        let (area, _) = area_centroid(&intersect_convex(&cw, &b));
        assert!((area - 1.0).abs() < 1e-12);
        // A zero-area clip polygon.
        cw = vec![DVec2::ZERO, DVec2::X, DVec2::X * 2.0];
        assert!(intersect_convex(&a, &cw).is_empty());
    }
}
