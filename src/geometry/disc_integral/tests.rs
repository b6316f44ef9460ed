//! Tests of the closed form against exact values, and of its fast paths and forms against
//! each other.
use super::*;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

fn general_f64(s: DVec2, a: DVec2, b: DVec2) -> f64 {
    general(s.x, s.y, a.x, a.y, b.x, b.y).0
}

/// Checks the general formula, and the mean with its fast paths, against `expected`.
fn check(s: DVec2, a: DVec2, b: DVec2, expected: f64) {
    let area = a.perp_dot(b).abs();
    for (s, a, b) in [(s, a, b), (s, b, a), (s, -a, b), (s, a, -b)] {
        let g = general_f64(s, a, b);
        assert!((g - expected).abs() < 1e-12, "general {g} vs {expected}");
        let m = mean(s, a, b) * area;
        assert!((m - expected).abs() < 1e-12, "mean {m} vs {expected}");
    }
}

#[test]
fn whole_half_quarter_and_no_disc() {
    let big = |w: f64| (DVec2::new(w, 0.0), DVec2::new(0.0, w));
    let (a, b) = big(100.0);
    check(DVec2::ZERO, a, b, FRAC_PI_2);
    check(DVec2::new(0.0, 50.0), a, b, FRAC_PI_4);
    check(DVec2::new(50.0, 50.0), a, b, FRAC_PI_4 / 2.0);
    check(DVec2::new(-51.0, 0.0), a, b, 0.0);
    // Tangent: the square circumscribing the disc, and a square touching it from outside.
    let (a, b) = big(2.0);
    check(DVec2::ZERO, a, b, FRAC_PI_2);
    check(DVec2::new(2.0, 0.0), a, b, 0.0);
    check(DVec2::new(2.0, 2.0), a, b, 0.0);
    // Rotated and sheared, far outside and all around.
    let (a, b) = (DVec2::new(30.0, 10.0), DVec2::new(-5.0, 40.0));
    check(DVec2::new(3.0, -2.0), a, b, FRAC_PI_2);
    check(DVec2::new(300.0, -2.0), a, b, 0.0);
}

#[test]
fn a_strip_through_the_disc() {
    // Integral over |x| < h of (4/3)(1 - x^2)^(3/2).
    let antiderivative =
        |x: f64| (x * (5.0 - 2.0 * x * x) * (1.0 - x * x).sqrt() + 3.0 * x.asin()) / 8.0;
    for h in [0.01, 0.3, 0.7, 0.999, 1.0] {
        let expected = 4.0 / 3.0 * 2.0 * antiderivative(h);
        check(
            DVec2::ZERO,
            DVec2::new(2.0 * h, 0.0),
            DVec2::new(0.0, 5.0),
            expected,
        );
        // The same strip, rotated.
        let r = DVec2::from_angle(0.7);
        check(
            DVec2::ZERO,
            r.rotate(DVec2::new(2.0 * h, 0.0)),
            r.rotate(DVec2::new(0.0, 5.0)),
            expected,
        );
    }
    assert!((4.0 / 3.0 * 2.0 * antiderivative(1.0) - FRAC_PI_2).abs() < 1e-15);
}

#[test]
fn inside_the_disc_the_polygon_moments_hold() {
    let (s, a, b) = (
        DVec2::new(0.2, -0.1),
        DVec2::new(0.3, 0.1),
        DVec2::new(-0.2, 0.4),
    );
    let area = a.perp_dot(b).abs();
    let expected =
        area * (1.0 - s.length_squared() - (a.length_squared() + b.length_squared()) / 12.0);
    assert!(matches!(classify(s, a, b), Overlap::Mean(_)));
    check(s, a, b, expected);
}

#[test]
fn closed_forms_and_general_formula_agree_at_their_boundaries() {
    // Parallelograms just inside (closed form) and just crossing (general formula).
    for scale in [0.999, 1.001] {
        let r = DVec2::from_angle(0.3);
        let (a, b) = (
            r.rotate(DVec2::new(1.2, 0.0)),
            r.rotate(DVec2::new(0.0, 0.8)) * scale,
        );
        let s = DVec2::new(0.0, 0.0);
        let g = general_f64(s, a, b) / a.perp_dot(b).abs();
        assert!(
            (mean(s, a, b) - g).abs() < 1e-13,
            "{} vs {g}",
            mean(s, a, b)
        );
    }
    let m_in = mean(
        DVec2::ZERO,
        DVec2::new(1.2, 0.0),
        DVec2::new(0.0, 1.6 * 0.9999),
    );
    let m_out = mean(
        DVec2::ZERO,
        DVec2::new(1.2, 0.0),
        DVec2::new(0.0, 1.6 * 1.0001),
    );
    assert!((m_in - m_out).abs() < 1e-3, "{m_in} {m_out}");
}

#[test]
fn vanishing_and_flat_parallelograms() {
    let s = DVec2::new(0.3, 0.4);
    // Below the point size: the kernel at the centre, exactly.
    assert_eq!(mean(s, DVec2::ZERO, DVec2::ZERO), 1.0 - s.length_squared());
    assert_eq!(
        mean(s, DVec2::new(1e-7, 0.0), DVec2::new(0.0, 1e-7)),
        1.0 - s.length_squared()
    );
    assert_eq!(mean(DVec2::new(1.0, 0.0), DVec2::ZERO, DVec2::ZERO), 0.0);
    // A segment through the rim: the mean along it, (1/L) integral of (1 - x^2) over
    // [0.5, 1] for the segment [0.5, 1.5] on the x axis.
    let expected = (0.5 - (1.0 - 0.125) / 3.0) / 1.0;
    for (a, b) in [
        (DVec2::new(1.0, 0.0), DVec2::ZERO),
        (DVec2::ZERO, DVec2::new(1.0, 0.0)),
    ] {
        let m = mean(DVec2::new(1.0, 0.0), a, b);
        assert!((m - expected).abs() < 1e-4, "{m} vs {expected}");
        assert!(m.is_finite());
    }
    // Non-finite footprints contribute nothing.
    assert_eq!(mean(s, DVec2::NAN, DVec2::ZERO), 0.0);
    assert_eq!(mean(s, DVec2::INFINITY, DVec2::X), 0.0);
}

#[test]
fn one_arc_equals_four_arcs() {
    let mut rng = crate::util::rng::Rng::new(11, 0);
    let mut u = || 2.0 * rng.uniform() - 1.0;
    // How many cases had their arcs' sum S in each range: nothing, below pi, above pi,
    // and nearly the whole circle.
    let mut seen = [0; 4];
    for k in 0..40_000 {
        let scale = [0.001, 0.05, 0.3, 0.7, 1.5, 3.0, 30.0, 1000.0][k % 8];
        let (a, b) = (DVec2::new(u(), u()) * scale, DVec2::new(u(), u()) * scale);
        if a.perp_dot(b).abs() < 1e-9 * scale * scale {
            continue;
        }
        // Centres anywhere the parallelogram may cross the circle.
        let s = DVec2::new(u(), u()) * (1.0 + scale);
        let (four, area) = general(s.x, s.y, a.x, a.y, b.x, b.y);
        let (one, area1) = general_one_arc(s.x, s.y, a.x, a.y, b.x, b.y);
        assert_eq!(area, area1);
        assert!((four - one).abs() <= 1e-12, "{s} {a} {b}: {four} vs {one}");
        let whole = four > FRAC_PI_2 - 1e-3;
        seen[if four <= 1e-9 {
            0
        } else if whole {
            3
        } else {
            1 + usize::from(four > FRAC_PI_4)
        }] += 1;
    }
    assert!(seen.iter().all(|&n| n > 200), "{seen:?}");
    // The disc all but inside (S just below 2 pi), and a vertex at the origin (a side's
    // complex number is 0) and just off it.
    for (s, a, b) in [
        (
            DVec2::new(1e-9, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, 3.0),
        ),
        (
            DVec2::new(0.0, -1e-9),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, 2.0),
        ),
        (
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, 2.0),
        ),
    ]
    .into_iter()
    .chain(
        [
            DVec2::ZERO,
            DVec2::splat(1e-200),
            DVec2::new(1e-160, -1e-170),
        ]
        .map(|corner| {
            let (a, b) = (DVec2::new(0.9, 0.0), DVec2::new(0.1, 0.9));
            (corner + 0.5 * (a + b), a, b)
        }),
    ) {
        let four = general(s.x, s.y, a.x, a.y, b.x, b.y).0;
        let one = general_one_arc(s.x, s.y, a.x, a.y, b.x, b.y).0;
        assert!(
            (four - one).abs() < 1e-13 && four > 0.1,
            "{s} {a} {b}: {four} vs {one}"
        );
    }
}

#[test]
fn simd_lanes_equal_the_scalar_formula() {
    let cases = [
        (
            DVec2::new(0.9, 0.1),
            DVec2::new(0.5, 0.1),
            DVec2::new(-0.1, 0.7),
        ),
        (
            DVec2::new(-1.2, 0.3),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.3, 3.0),
        ),
        (
            DVec2::new(0.0, 0.0),
            DVec2::new(5.0, 1.0),
            DVec2::new(-1.0, 6.0),
        ),
        (
            DVec2::new(2.5, 2.5),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
        ),
    ];
    let lanes = |f: fn(&(DVec2, DVec2, DVec2)) -> f64| wide::f64x4::from(cases.map(|c| f(&c)));
    let (integral, area) = general(
        lanes(|c| c.0.x),
        lanes(|c| c.0.y),
        lanes(|c| c.1.x),
        lanes(|c| c.1.y),
        lanes(|c| c.2.x),
        lanes(|c| c.2.y),
    );
    for (k, (s, a, b)) in cases.iter().enumerate() {
        let (i, ar) = general(s.x, s.y, a.x, a.y, b.x, b.y);
        assert!((integral.to_array()[k] - i).abs() < 1e-14, "{k}");
        assert_eq!(area.to_array()[k], ar);
    }
    assert!((integral.to_array()[2] - PI / 2.0).abs() < 1e-14);
}
