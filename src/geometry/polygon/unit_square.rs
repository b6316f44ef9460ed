//! Convex polygons against the square `[-1/2, 1/2]^2`, where the coplanar estimate maps each
//! view footprint, and the ellipse polygons it clips there settled without building them: in
//! closed form where they lie inside the square or hold it whole, from the pieces of the two
//! boundaries ([`boundary`]) where they cross it.

use super::{area_centroid, unit_circle, ClipScratch};
use glam::DVec2;

mod boundary;

/// Area and centroid of the part of the convex polygon `subject` (vertices in order, either
/// orientation) inside the square `[-1/2, 1/2]^2`: [`super::intersect_convex`] with that
/// square and [`area_centroid`], for the coplanar estimate, which maps each view footprint
/// onto this square.
///
/// Why its own clipper: the square's sides are axis-aligned, so a vertex's side is a comparison
/// of one coordinate, with no square root and no normalisation of the clip polygon; a polygon
/// whose bounding box lies inside the square is not clipped at all, and one is clipped only by
/// the sides its bounding box crosses (clipping by any other keeps every vertex, in order).
/// (The general clipper took two thirds of the coplanar estimate's render stage.)
pub fn clip_to_unit_square(subject: &[DVec2], scratch: &mut ClipScratch) -> (f64, DVec2) {
    let (lo, hi) = subject.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    if lo.min_element() >= -0.5 && hi.max_element() <= 0.5 {
        return area_centroid(subject);
    }
    if lo.x > 0.5 || lo.y > 0.5 || hi.x < -0.5 || hi.y < -0.5 || !(lo.is_finite() && hi.is_finite())
    {
        return (0.0, DVec2::ZERO);
    }
    clip_by_sides(
        subject,
        [hi.x > 0.5, lo.x < -0.5, hi.y > 0.5, lo.y < -0.5],
        scratch,
    )
}

/// [`clip_to_unit_square`] by the sides `crossed` marks (`x <= 1/2`, `x >= -1/2`, `y <= 1/2`,
/// `y >= -1/2`): a side whose line the polygon does not cross may be marked or not (clipping by
/// it keeps every vertex, in order), so any box that holds the polygon may choose them.
fn clip_by_sides(subject: &[DVec2], crossed: [bool; 4], scratch: &mut ClipScratch) -> (f64, DVec2) {
    let ClipScratch { current, next, .. } = scratch;
    current.clear();
    current.extend_from_slice(subject);
    let sides = [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)];
    for (axis, sign) in sides
        .into_iter()
        .zip(crossed)
        .filter_map(|(s, c)| c.then_some(s))
    {
        // Coordinate `axis` times `sign` at most 1/2.
        next.clear();
        // Edge by edge, the last closing the polygon (pairs by iterator: an index modulo the
        // length costs a division a vertex).
        let distance = |p: DVec2| 0.5 - sign * p[axis];
        let mut dp = distance(current[0]);
        for (&p, &q) in current.iter().zip(current[1..].iter().chain(&current[..1])) {
            let dq = distance(q);
            if dp >= 0.0 {
                next.push(p);
            }
            if (dp >= 0.0) != (dq >= 0.0) {
                let t = (dp / (dp - dq)).clamp(0.0, 1.0);
                next.push(p + (q - p) * t);
            }
            dp = dq;
        }
        std::mem::swap(current, next);
        if current.len() < 3 {
            return (0.0, DVec2::ZERO);
        }
    }
    area_centroid(current)
}

/// The regular polygon of `n` vertices inscribed in the unit circle ([`unit_circle`]), whose
/// affine images `centre + x a + y b` stand for the ellipses `centre + cos(t) a + sin(t) b`,
/// with the numbers that settle most of them against the unit square in closed form.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitPolygon {
    vertices: Vec<DVec2>,
    /// Its area, `n/2 sin(2 pi/n)`: an image's is this times `|a x b|`.
    area: f64,
    /// The square of its inradius, `cos(pi/n)^2`: the image of the disc of this radius lies
    /// inside the image of the polygon.
    inradius2: f64,
    /// Its edges, from which an image crossing the square's sides is clipped without building
    /// it.
    edges: boundary::Edges,
}

impl UnitPolygon {
    /// The polygon of `n` vertices (at least 3).
    pub fn new(n: usize) -> Self {
        let vertices = unit_circle(n);
        let n = vertices.len() as f64;
        let angle = std::f64::consts::TAU / n;
        UnitPolygon {
            area: 0.5 * n * angle.sin(),
            inradius2: (0.5 * angle).cos().powi(2),
            edges: boundary::Edges::new(&vertices),
            vertices,
        }
    }

    /// Its vertices, counter-clockwise from `(1, 0)`.
    pub fn vertices(&self) -> &[DVec2] {
        &self.vertices
    }

    /// Area and centroid of the part of its image `centre + x a + y b` inside the square
    /// `[-1/2, 1/2]^2`: what [`clip_to_unit_square`] gives for the image's polygon, without
    /// building it where the ellipse's bounding box lies inside the square (the whole image, of
    /// known area, centred on `centre`: an affine map keeps centroids) or the square's corners
    /// lie inside the image of the inscribed disc (the whole square), nor where it crosses the
    /// square's sides (its edges and the sides cut to each other in SIMD lanes,
    /// `boundary::Edges::clip`). These differ from the clipped polygon's numbers by rounding
    /// only. `polygon` receives the image where it is built (a polygon of more than 64
    /// vertices, or rounding that leaves a side cutting two runs of vertices).
    pub fn in_unit_square(
        &self,
        centre: DVec2,
        a: DVec2,
        b: DVec2,
        polygon: &mut Vec<DVec2>,
        scratch: &mut ClipScratch,
    ) -> (f64, DVec2) {
        let det = a.perp_dot(b);
        // A finite non-zero determinant has finite edge vectors; anything else is clipped as
        // its polygon is.
        if !(det != 0.0 && det.is_finite() && centre.is_finite()) {
            super::ellipse_into(centre, a, b, &self.vertices, polygon);
            return clip_to_unit_square(polygon, scratch);
        }
        // The ellipse's bounding box (half extents |(a.x, b.x)| and |(a.y, b.y)|), which holds
        // its inscribed polygon.
        let extent = DVec2::new(a.x * a.x + b.x * b.x, a.y * a.y + b.y * b.y).map(f64::sqrt);
        let (lo, hi) = (centre - extent, centre + extent);
        if lo.min_element() >= -0.5 && hi.max_element() <= 0.5 {
            return (self.area * det.abs(), centre);
        }
        if lo.x > 0.5 || lo.y > 0.5 || hi.x < -0.5 || hi.y < -0.5 {
            return (0.0, DVec2::ZERO);
        }
        let crossed = [hi.x > 0.5, lo.x < -0.5, hi.y > 0.5, lo.y < -0.5];
        // Only an ellipse whose box crosses all four sides can hold the square. A corner w
        // (about the centre) has preimage (w x b, a x w) / det.
        let holds = |w: DVec2| {
            let (x, y) = (w.perp_dot(b), a.perp_dot(w));
            x * x + y * y <= self.inradius2 * det * det
        };
        let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
        if crossed.iter().all(|&c| c)
            && corners
                .iter()
                .all(|&(x, y)| holds(DVec2::new(x, y) - centre))
        {
            return (1.0, DVec2::ZERO);
        }
        if let Some(clipped) = self.edges.clip(centre, a, b, det, crossed) {
            return clipped;
        }
        super::ellipse_into(centre, a, b, &self.vertices, polygon);
        clip_by_sides(polygon, crossed, scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::super::{ellipse, intersect_convex, parallelogram};
    use super::*;

    fn square(c: DVec2, s: f64) -> Vec<DVec2> {
        parallelogram(c, DVec2::X * s, DVec2::Y * s).to_vec()
    }

    /// Ellipses of every size and place about the square, either orientation: `(centre, a, b)`.
    fn ellipses() -> impl Iterator<Item = (DVec2, DVec2, DVec2)> {
        (0..2000).map(|k| {
            let t = k as f64;
            let centre =
                DVec2::new((t * 0.37).sin(), (t * 0.53).cos()) * (0.2 + (t * 0.11).sin().abs());
            let a = DVec2::new((t * 0.7).cos(), (t * 0.3).sin()) * (0.01 + (t * 0.17).cos().abs());
            let b =
                DVec2::new(-(t * 0.29).sin(), (t * 0.41).cos()) * (0.01 + (t * 0.23).sin().abs());
            (centre, a, b)
        })
    }

    #[test]
    fn clipping_to_the_unit_square_is_intersecting_with_it() {
        let unit = square(DVec2::ZERO, 1.0);
        let mut scratch = ClipScratch::default();
        let mut checked = 0;
        for (k, (centre, a, b)) in ellipses().enumerate() {
            let polygon = ellipse(centre, a, b, 16);
            let (area, c) = clip_to_unit_square(&polygon, &mut scratch);
            let (expected, ec) = area_centroid(&intersect_convex(&polygon, &unit));
            assert!(
                (area - expected).abs() <= 1e-12,
                "{k}: {area} vs {expected}"
            );
            if expected > 1e-9 {
                assert!((c - ec).length() <= 1e-9, "{k}: {c} vs {ec}");
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked} overlapping cases");
        // Inside, outside, and a square that holds the polygon's edge exactly.
        assert_eq!(clip_to_unit_square(&unit, &mut scratch).0, 1.0);
        assert_eq!(
            clip_to_unit_square(&square(DVec2::new(3.0, 0.0), 1.0), &mut scratch).0,
            0.0
        );
    }

    #[test]
    fn an_ellipse_polygon_in_the_square_is_its_clipped_polygon() {
        let mut scratch = ClipScratch::default();
        let mut polygon = Vec::new();
        for n in [3, 5, 16, 33, 65] {
            let unit = UnitPolygon::new(n);
            // How many were settled by each closed form, by the boundary pieces, and clipped.
            let (mut inside, mut holding, mut crossing, mut clipped) = (0, 0, 0, 0);
            let cases = ellipses()
                .map(|(c, a, b)| (c * 0.4, a, b))
                .chain(ellipses().map(|(c, a, b)| (c * 0.3, a * 3.0, b * 3.0)))
                .chain(ellipses().map(|(c, a, b)| (c, a * 0.3, b * 0.3)));
            for (k, (centre, a, b)) in cases.enumerate() {
                let expected = clip_to_unit_square(&ellipse(centre, a, b, n), &mut scratch);
                polygon.clear();
                let got = unit.in_unit_square(centre, a, b, &mut polygon, &mut scratch);
                assert!(
                    (got.0 - expected.0).abs() <= 1e-12 * expected.0.max(1.0),
                    "{n}-gon {k}: {got:?} vs {expected:?}"
                );
                if expected.0 > 1e-9 {
                    assert!((got.1 - expected.1).length() <= 1e-9, "{n}-gon {k}");
                }
                let whole = (got.0 - unit.area * a.perp_dot(b).abs()).abs() <= 1e-12;
                if !polygon.is_empty() {
                    clipped += 1;
                } else if got.0 == 1.0 {
                    holding += 1;
                } else if whole && got.1 == centre {
                    inside += 1;
                } else if got.0 > 0.0 {
                    crossing += 1;
                }
            }
            assert!(
                inside > 100 && holding > 100,
                "{n}-gon: {inside} inside, {holding} holding the square"
            );
            // Past 64 vertices the boundary pieces give way to clipping the polygon.
            if n > 64 {
                assert!(clipped > 100 && crossing == 0, "{n}-gon: {clipped} clipped");
            } else {
                assert!(
                    crossing > 100 && clipped == 0,
                    "{n}-gon: {crossing} {clipped}"
                );
            }
        }
        // A degenerate ellipse (a point, a segment) is clipped as its polygon is: no area.
        let unit = UnitPolygon::new(16);
        for (a, b) in [(DVec2::ZERO, DVec2::ZERO), (DVec2::X, DVec2::X * 2.0)] {
            let got = unit.in_unit_square(DVec2::splat(0.1), a, b, &mut polygon, &mut scratch);
            assert_eq!(got.0, 0.0, "{a} {b}");
        }
        // Edge vectors near f64's range: the area the polygon's clipping gives, bit for bit,
        // and its centroid where there is one.
        for (a, b) in [
            (DVec2::new(1e300, 1e300), DVec2::new(-1e-300, 1e-300)),
            (DVec2::new(1e307, 0.0), DVec2::new(0.0, 1e-307)),
            (DVec2::new(1e200, 1e-200), DVec2::new(-1e-200, 1e200)),
        ] {
            let centre = DVec2::new(0.3, -0.2);
            let expected = clip_to_unit_square(&ellipse(centre, a, b, 16), &mut scratch);
            let got = unit.in_unit_square(centre, a, b, &mut polygon, &mut scratch);
            assert_eq!(
                got.0.to_bits(),
                expected.0.to_bits(),
                "{a} {b}: {got:?} vs {expected:?}"
            );
            if got.0 > 0.0 {
                assert_eq!(got.1, expected.1, "{a} {b}");
            }
        }
    }
}
