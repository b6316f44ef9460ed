//! The exact view footprint (`GatherQuery::exact`, `geometry::disc_integral::quad`): the
//! quadrilateral's closed form against a brute-force quadrature, and power conservation over
//! the footprints of a perspective camera's pixels on a plane, where first-order parallelograms
//! overlap and leave gaps.

mod common;
use common::{floor_photon, integrate_between_cuts, render_stats};

use glam::{DVec2, DVec3};
use photondiff::estimate::integrated::IntegratedEstimate;
use photondiff::estimate::{ExactFootprint, GatherCounts, GatherQuery, RadianceEstimator};
use photondiff::geometry::disc_integral::quad::{classify_quad, quad_mean, QuadOverlap};
use photondiff::photons::footprint::Guards;
use photondiff::photons::map::{PathClass, Photon, PhotonMap};
use photondiff::scene::camera::Camera;
use proptest::prelude::*;
use std::f64::consts::PI;

/// The mean of `(1 - |u|^2)+` over the convex polygon `v` by Fubini, independently of the
/// divergence theorem: for each `x` the exact integral over the `y`-interval inside both the
/// polygon and the disc; over `x`, composite Gauss-Legendre between the kinks (vertices, and
/// where the sides cross the circle), in a variable that smooths the ends.
fn quadrature(v: &[DVec2; 4], panels: usize) -> f64 {
    let sides: Vec<(DVec2, DVec2)> = (0..4).map(|k| (v[k], v[(k + 1) % 4])).collect();
    let inner = |x: f64| -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &(p, q) in &sides {
            let (a, b) = if p.x <= q.x { (p, q) } else { (q, p) };
            if x < a.x || x > b.x || a.x == b.x {
                continue;
            }
            let y = a.y + (x - a.x) * (b.y - a.y) / (b.x - a.x);
            lo = lo.min(y);
            hi = hi.max(y);
        }
        let w = (1.0 - x * x).max(0.0).sqrt();
        let (y0, y1) = (lo.max(-w), hi.min(w));
        if y0 >= y1 {
            return 0.0;
        }
        (1.0 - x * x) * (y1 - y0) - (y1.powi(3) - y0.powi(3)) / 3.0
    };
    let xmin = v
        .iter()
        .map(|p| p.x)
        .fold(f64::INFINITY, f64::min)
        .max(-1.0);
    let xmax = v
        .iter()
        .map(|p| p.x)
        .fold(f64::NEG_INFINITY, f64::max)
        .min(1.0);
    if xmin >= xmax {
        return 0.0;
    }
    let mut cuts = vec![xmin, xmax];
    for &(p, q) in &sides {
        cuts.push(p.x);
        // Where the side p + t (q - p) crosses the circle.
        let e = q - p;
        let (aa, bb, cc) = (e.dot(e), 2.0 * p.dot(e), p.dot(p) - 1.0);
        let d = bb * bb - 4.0 * aa * cc;
        if d > 0.0 {
            for t in [(-bb - d.sqrt()) / (2.0 * aa), (-bb + d.sqrt()) / (2.0 * aa)] {
                if (0.0..=1.0).contains(&t) {
                    cuts.push(p.x + t * e.x);
                }
            }
        }
    }
    cuts.retain(|&c| c >= xmin && c <= xmax);
    cuts.sort_by(f64::total_cmp);
    let sum = common::integrate_between_cuts(&cuts, panels, inner);
    let area = 0.5
        * (0..4)
            .map(|k| (v[k] - v[0]).perp_dot(v[(k + 1) % 4] - v[0]))
            .sum::<f64>()
            .abs();
    sum / area
}

/// A random convex quadrilateral: a parallelogram of size `10^log_size` (edge `a`, edge `b` at
/// `shear` from it, `aspect` times as long) with each corner moved by up to `warp` of the
/// shorter edge (a perspective view's trapezoids and more), centred `reach` times the distance
/// at which it stops touching the disc.
fn quad(log_size: std::ops::Range<f64>) -> impl Strategy<Value = [DVec2; 4]> {
    (
        log_size,
        0.05f64..1.0,
        0.0..2.0 * PI,
        0.2f64..PI - 0.2,
        0.0f64..1.1,
        0.0..2.0 * PI,
        prop::array::uniform8(-1.0f64..1.0),
    )
        .prop_map(|(log_size, aspect, theta, shear, reach, dir, warp)| {
            let la = 10f64.powf(log_size);
            let a = DVec2::from_angle(theta) * la;
            let b = DVec2::from_angle(theta + shear) * la * aspect;
            // Moves within 15% of the narrowest width keep it convex.
            let width = a.perp_dot(b).abs() / la.max(la * aspect);
            let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
            let mut v = [DVec2::ZERO; 4];
            for (k, (x, y)) in corners.into_iter().enumerate() {
                let moved = DVec2::new(warp[2 * k], warp[2 * k + 1]) * 0.15 * width;
                v[k] = a * x + b * y + moved;
            }
            let radius = v.iter().map(|p| p.length()).fold(0.0, f64::max);
            let s = DVec2::from_angle(dir) * reach * (1.0 + radius);
            v.map(|p| p + s)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1500))]

    #[test]
    fn the_quadrilaterals_closed_form_equals_quadrature(
        v in prop_oneof![
            quad(-3.0..-1.0), // photon much larger than the pixel
            quad(-1.0..0.7),  // comparable
            quad(0.7..3.0),   // photon much smaller than the pixel
        ]
    ) {
        let m = quad_mean(v);
        prop_assert!(m.is_some(), "{:?}: {:?}", v, classify_quad(v));
        let m = m.unwrap();
        let q = quadrature(&v, 64);
        prop_assert!(m.is_finite() && m >= 0.0);
        // The general formula's rounding over the area: about 1e-16 of its side terms, and the
        // arcs' angle (a quarter of the argument of a product of eight complex factors of
        // modulus about 1, each a few ulps off) a few 2^-52 whatever the size. A 0.0012-wide
        // quadrilateral 8.5e-4 outside the disc (General: too close for the bounding-circle
        // test) gave 1.25e-17 over its area 3.9e-7, 3.2e-11, over the size term's 3.0e-11
        // (kept in the regressions file). A helper's f64 replica of the formula against 40-digit
        // arithmetic, 1.5M draws: the worst at 0.03-0.10 of this bound.
        let size = v.iter().map(|p| (*p - v[0]).length()).fold(0.0, f64::max);
        let area = 0.5 * (v[2] - v[0]).perp_dot(v[3] - v[1]).abs();
        let rounding = (1e-14 * size.min(1.0) + 4.0 * f64::EPSILON) / area;
        prop_assert!(
            (m - q).abs() <= 1e-9 * q + rounding,
            "closed form {} vs quadrature {} ({:?})", m, q, classify_quad(v)
        );
        // Either direction around it.
        let reversed = quad_mean([v[0], v[3], v[2], v[1]]).unwrap();
        prop_assert!((reversed - m).abs() <= 1e-12 + 1e-12 * m);
    }
}

#[test]
fn folded_and_crossed_quadrilaterals_are_not_taken() {
    let crossed = [
        DVec2::new(0.0, 0.0),
        DVec2::new(0.5, 0.5),
        DVec2::new(0.5, 0.0),
        DVec2::new(0.0, 0.5),
    ];
    assert_eq!(classify_quad(crossed), QuadOverlap::NotConvex);
    let dented = [
        DVec2::new(0.0, 0.0),
        DVec2::new(0.5, 0.0),
        DVec2::new(0.1, 0.1),
        DVec2::new(0.0, 0.5),
    ];
    assert_eq!(classify_quad(dented), QuadOverlap::NotConvex);
    assert_eq!(quad_mean(dented), None);
}

/// A 160 x 120 pinhole looking obliquely down at the floor `y = 0`.
fn oblique_camera() -> Camera {
    Camera::look_at(
        DVec3::new(0.3, 2.0, 3.0),
        DVec3::ZERO,
        DVec3::Y,
        40.0,
        160,
        120,
    )
    .unwrap()
}

/// Where the ray through the image corner nearest `at`'s projection meets the floor `y = 0`.
fn nearest_pixel_corner(camera: &Camera, at: DVec3) -> DVec3 {
    let (px, py) = camera.project(at).unwrap();
    let ray = camera.ray(px.round(), py.round(), 1.0);
    ray.p + ray.d * (-ray.p.y / ray.d.y)
}

/// How a pixel's exact footprint is weighted in `power_over_pixels`.
#[derive(Clone, Copy, PartialEq)]
enum Footprint {
    /// The first-order parallelogram.
    FirstOrder,
    /// The exact quadrilateral, uniform over surface area.
    Exact,
    /// The exact quadrilateral weighted by image area per surface area (what the renderer
    /// gives `integrated`).
    SeenFromTheEye,
}

/// Over the pixels around `photon` on the floor `y = 0`, seen obliquely through a pinhole:
/// the estimate times each pixel's footprint area (the power it stands for over the surface),
/// and the estimate times the pixel's area on the image plane at unit distance (what a light
/// tracer's splats of the photon sum to: its power times the image area per surface area
/// where it lands).
fn power_over_pixels(camera: &Camera, photon: Photon, footprint: Footprint) -> (f64, f64) {
    let map = PhotonMap::new(PathClass::Caustic, vec![photon], 1, Guards::default());
    let estimate = IntegratedEstimate { map: &map };
    let r = photon.radius as f64 * 1.5;
    let corners = [(-r, -r), (r, -r), (r, r), (-r, r)]
        .map(|(x, z)| camera.project(photon.position.as_dvec3() + DVec3::new(x, 0.0, z)));
    let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
    for c in corners {
        let c = DVec2::from(c.expect("in front of the camera"));
        (lo, hi) = (lo.min(c), hi.max(c));
    }
    let (lo, hi) = ((lo - 2.0).floor(), (hi + 2.0).ceil());
    let image_area = (2.0 * camera.tan_half_fov / camera.height as f64).powi(2);
    let mut counts = GatherCounts::default();
    let (mut power, mut splatted) = (0.0, 0.0);
    for y in lo.y as i64..hi.y as i64 {
        for x in lo.x as i64..hi.x as i64 {
            let (x, y) = (x as f64, y as f64);
            let ray = camera.ray(x + 0.5, y + 0.5, 1.0);
            let at = ray.transfer(-ray.p.y / ray.d.y, DVec3::Y);
            let quad = camera
                .rectangle_on_plane([x, y, x + 1.0, y + 1.0], at.p, DVec3::Y)
                .expect("the floor is in front");
            let area = 0.5 * (quad[2] - quad[0]).cross(quad[3] - quad[1]).length();
            let exact = ExactFootprint::new(&quad, at.p, &at.dp).unwrap();
            let q = GatherQuery {
                position: at.p,
                normal: DVec3::Y,
                albedo: DVec3::splat(PI),
                footprint: at.dp,
                exact: match footprint {
                    Footprint::FirstOrder => None,
                    Footprint::Exact => Some(exact),
                    Footprint::SeenFromTheEye => {
                        Some(exact.seen_from(camera.eye, camera.forward, at.p, &at.dp))
                    }
                },
            };
            let l = estimate.radiance(&q, &mut counts).x;
            power += l * area;
            splatted += l * image_area;
        }
    }
    (power, splatted)
}

/// Image area (on the image plane at unit distance) per surface area at `x` on the floor, as
/// the light tracer weighs a splat: `cos / (d^2 cos_camera^3)`.
fn image_area_per_surface_area(camera: &Camera, x: DVec3) -> f64 {
    let to_eye = camera.eye - x;
    let d = to_eye.length();
    let cos_camera = camera.forward.dot(-to_eye / d);
    (to_eye.y / d) / (d * d * cos_camera.powi(3))
}

/// What a light tracer's splats of `photon`'s light sum to: the mean of
/// [`image_area_per_surface_area`] under its kernel (in its filter space: 64 angles, radii by
/// [`integrate_between_cuts`]), times its power.
fn splatted_power(camera: &Camera, photon: &Photon) -> f64 {
    // The kernel's axes on the floor: e_j with m_i . e_j = delta_ij (x and z components).
    let (m0, m1) = (photon.m[0].as_dvec3(), photon.m[1].as_dvec3());
    let det = m0.x * m1.z - m0.z * m1.x;
    let e0 = DVec3::new(m1.z, 0.0, -m1.x) / det;
    let e1 = DVec3::new(-m0.z, 0.0, m0.x) / det;
    let mean = integrate_between_cuts(&[0.0, 1.0], 8, |r| {
        let ring: f64 = (0..64)
            .map(|k| {
                let phi = (k as f64 + 0.5) / 64.0 * 2.0 * PI;
                let x = photon.position.as_dvec3() + (e0 * phi.cos() + e1 * phi.sin()) * r;
                image_area_per_surface_area(camera, x)
            })
            .sum::<f64>()
            / 64.0;
        // The kernel (2/pi)(1 - r^2) over the ring's length 2 pi r.
        4.0 * (1.0 - r * r) * r * ring
    });
    photon.power.x as f64 * mean
}

/// A 2.5 W photon on the floor at `at` (or on the pixel corner nearest it: where slivers of
/// neighbouring first-order parallelograms overlap), of radius `10^log_radius` and the given
/// aspect, its long axis at `angle`.
fn photon_near(
    camera: &Camera,
    log_radius: f64,
    aspect: f64,
    angle: f64,
    at: (f64, f64),
    on_a_corner: bool,
) -> Photon {
    let mut position = DVec3::new(at.0, 0.0, at.1);
    if on_a_corner {
        position = nearest_pixel_corner(camera, position);
    }
    let radius = 10f64.powf(log_radius);
    let a = DVec3::new(angle.cos(), 0.0, angle.sin()) * radius;
    let b = DVec3::new(-angle.sin(), 0.0, angle.cos()) * radius * aspect;
    floor_photon(position, a, b, 2.5)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A photon anywhere on an obliquely seen floor, from a thousandth of a pixel's footprint
    /// to several footprints across, on pixel corners too:
    /// - uniform over the surface, the estimate times each pixel's exact footprint area sums
    ///   to its power over the pixels (with first-order parallelograms it does not: they
    ///   overlap and leave gaps along pixel boundaries);
    /// - weighted by image area, the pixels hold what a light tracer splats (its power times
    ///   the image area per surface area where it lands): every case of the estimate (the disc
    ///   inside a footprint, crossing it, holding it) reads the weight where its kernel's mass
    ///   lies. (Uniform over the surface, that is up to 1.4% off for small photons and 5e-4
    ///   for the largest.)
    #[test]
    fn over_a_perspective_views_pixels_a_photon_sums_to_its_power_and_to_its_splats(
        log_radius in -4.5f64..-1.0,
        aspect in 0.3f64..1.0,
        angle in 0.0..PI,
        at in (-0.4f64..0.4, -0.4f64..0.4),
        on_a_corner in any::<bool>(),
    ) {
        let camera = oblique_camera();
        let photon = photon_near(&camera, log_radius, aspect, angle, at, on_a_corner);
        let (power, _) = power_over_pixels(&camera, photon, Footprint::Exact);
        prop_assert!((power - 2.5).abs() <= 1e-6 * 2.5, "{} of 2.5 W", power);
        let (_, splatted) = power_over_pixels(&camera, photon, Footprint::SeenFromTheEye);
        let expected = splatted_power(&camera, &photon);
        prop_assert!(
            // The weight is linear over each pixel: its second-order term is ~1e-4 here.
            (splatted - expected).abs() <= 2e-4 * expected,
            "{} against {} ({:+.2e})", splatted, expected, splatted / expected - 1.0
        );
    }
}

#[test]
fn a_pixel_averages_a_small_photon_over_the_image_not_the_surface() {
    // A photon far smaller than a pixel, at points spread over one pixel's footprint: the
    // pixel's estimate is its power times the image area per surface area where it lies
    // (the light tracer's splat, over the pixel's image area), to 1e-4 of it. Averaged over
    // the surface instead, the far and near sides of the footprint differ by ~2.5% on this
    // oblique view, and the estimate is off by up to ~1.2% (the focal caustic's row beside
    // its focus came out 1.2% too bright that way).
    let camera = oblique_camera();
    let (px, py) = (71.0, 83.0);
    let mut worst_uniform = 0.0f64;
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (px + 0.1 + 0.2 * i as f64, py + 0.1 + 0.2 * j as f64);
            let ray = camera.ray(x, y, 1.0);
            let position = ray.p + ray.d * (-ray.p.y / ray.d.y);
            let photon = floor_photon(position, DVec3::X * 1e-6, DVec3::Z * 1e-6, 2.5);
            let expected = 2.5 * image_area_per_surface_area(&camera, position);
            let (_, seen) = power_over_pixels(&camera, photon, Footprint::SeenFromTheEye);
            let (_, uniform) = power_over_pixels(&camera, photon, Footprint::Exact);
            assert!(
                (seen / expected - 1.0).abs() <= 1e-4,
                "({x}, {y}): {seen} against {expected}"
            );
            worst_uniform = worst_uniform.max((uniform / expected - 1.0).abs());
        }
    }
    assert!(
        worst_uniform > 5e-3,
        "uniform weighting is off by only {worst_uniform:.2e}"
    );
}

#[test]
fn first_order_parallelograms_miscount_a_photon_on_a_pixel_corner() {
    // What the exact footprints mend: a photon far smaller than a pixel on the corner four
    // pixels share is counted by the overlapping first-order parallelograms more than once
    // (or by none where they leave a gap).
    let camera = oblique_camera();
    for k in 0..12 {
        let t = k as f64;
        let at = DVec3::new(0.6 * (0.7 * t).sin(), 0.0, 0.5 * (1.3 * t).cos());
        let position = nearest_pixel_corner(&camera, at);
        let photon = floor_photon(position, DVec3::X * 1e-5, DVec3::Z * 1e-5, 2.5);
        let (exact, _) = power_over_pixels(&camera, photon, Footprint::Exact);
        let (first_order, _) = power_over_pixels(&camera, photon, Footprint::FirstOrder);
        assert!((exact - 2.5).abs() <= 1e-6 * 2.5, "{position}: {exact}");
        assert!(
            (first_order - 2.5).abs() > 0.1 * 2.5,
            "{position}: {first_order}"
        );
    }
}

#[test]
fn every_gather_at_a_directly_seen_hit_takes_the_exact_footprint() {
    // A floor under a point light, seen obliquely: every camera ray's first hit is diffuse
    // and seen directly, so every gather of `integrated` (the default; both maps, every pass,
    // the view grid's cells alike) integrates over the exact footprint, and
    // the estimators that do not read it get none.
    let scene = r#"
[camera]
eye = [0.5, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 48
height = 36

[materials.floor]
type = "diffuse"
albedo = [0.7, 0.7, 0.7]

[[lights]]
type = "point"
position = [0.0, 3.0, 0.0]
intensity = [10.0, 10.0, 10.0]

[[shapes]]
type = "quad"
corner = [-50.0, 0.0, 50.0]
edge_u = [100.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -100.0]
material = "floor"
"#;
    for args in [
        &["--passes", "2"][..],
        &["--passes", "1", "--view-grid", "2"][..],
    ] {
        let json = render_stats(scene, args);
        let (gathers, exact) = (
            json["gathers"]["gathers"].as_u64().unwrap(),
            json["gathers"]["exact_footprints"].as_u64().unwrap(),
        );
        assert!(gathers >= 2 * 48 * 36, "{args:?}: {gathers}");
        assert_eq!(exact, gathers, "{args:?}");
    }
    let json = render_stats(scene, &["--estimator", "multisampled"]);
    assert!(json["gathers"]["gathers"].as_u64().unwrap() > 0);
    assert_eq!(json["gathers"]["exact_footprints"].as_u64().unwrap(), 0);
}
