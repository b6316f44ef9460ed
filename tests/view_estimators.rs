//! The view footprint in the estimate: multi-sampled and coplanar intersection-weighted photon
//! differentials against the photon-differential estimate, polygon intersection properties, and
//! finite, non-negative images from every estimator on the canonical scene.

mod common;

use glam::{DVec2, DVec3, Vec3};
use photondiff::embree::{Device, Ray};
use photondiff::estimate::coplanar::CoplanarEstimate;
use photondiff::estimate::multisampled::MultiSampledEstimate;
use photondiff::estimate::{
    photon_kernel, ExactFootprint, GatherCounts, GatherQuery, PhotonDifferentialEstimate,
    RadianceEstimator,
};
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::geometry::polygon::{area_centroid, convex_hull, intersect_convex};
use photondiff::geometry::surface::transfer_to;
use photondiff::photons::map::PhotonMap;
use photondiff::photons::options::PhotonOptions;
use photondiff::render::stats::Stats;
use photondiff::render::trace_photon_maps;
use photondiff::render::{render, RenderOptions};
use photondiff::scene::file::load_scene;
use photondiff::scene::Scene;
use proptest::prelude::*;
use std::f64::consts::FRAC_1_PI;
use std::path::Path;

fn canonical() -> Scene {
    load_scene(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/caustic-sphere.toml"
    )))
    .unwrap()
}

/// The canonical caustic map, and gather queries at floor pixels in and around the caustic with
/// their view footprints (scaled by `footprint_scale`).
fn caustic_queries(footprint_scale: f64) -> (PhotonMap, Vec<GatherQuery>) {
    let scene = canonical();
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let map = common::caustic_map(&scene, &embree, 5000);
    let camera = &scene.camera;
    let mut queries = Vec::new();
    for y in (250..330).step_by(7) {
        for x in (330..450).step_by(9) {
            let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5, 1.0);
            let hit = embree.intersect(&Ray::new(ray.p, ray.d)).unwrap();
            if hit.geom_id != 0 {
                continue; // the sphere
            }
            let at = transfer_to(&ray, &hit);
            queries.push(GatherQuery {
                position: hit.position,
                normal: DVec3::Y,
                albedo: DVec3::splat(0.75),
                footprint: at.dp.map(|f| f * footprint_scale),
                exact: None,
            });
        }
    }
    assert!(queries.len() > 100);
    (map, queries)
}

#[test]
fn multisampled_with_one_sample_equals_the_photon_differential_estimate() {
    let (map, queries) = caustic_queries(1.0);
    let pd = PhotonDifferentialEstimate { map: &map };
    let ms = MultiSampledEstimate::new(&map, 1);
    let mut c = GatherCounts::default();
    let mut lit = 0;
    for q in &queries {
        let (a, b) = (pd.radiance(q, &mut c), ms.radiance(q, &mut c));
        assert!(
            (a - b).length() <= 1e-5 * a.length().max(1e-6),
            "{a} vs {b}"
        );
        lit += usize::from(a.x > 0.0);
    }
    assert!(
        lit > queries.len() / 4,
        "only {lit} of {} queries lit",
        queries.len()
    );
}

/// The pixel-area average of the photon-differential estimate, by brute force: `n x n` point
/// estimates over the view footprint.
fn brute_force_average(pd: &PhotonDifferentialEstimate, q: &GatherQuery, n: usize) -> DVec3 {
    let mut sum = DVec3::ZERO;
    let mut c = GatherCounts::default();
    for i in 0..n {
        for j in 0..n {
            let a = (i as f64 + 0.5) / n as f64 - 0.5;
            let b = (j as f64 + 0.5) / n as f64 - 0.5;
            let point = GatherQuery {
                position: q.position + q.footprint[0] * a + q.footprint[1] * b,
                ..*q
            };
            sum += pd.radiance(&point, &mut c);
        }
    }
    sum / (n * n) as f64
}

#[test]
fn multisampled_converges_to_the_pixel_average_of_the_photon_differential_estimate() {
    // Footprints four pixels wide, so that they span many photon footprints.
    let (map, queries) = caustic_queries(4.0);
    let pd = PhotonDifferentialEstimate { map: &map };
    let mut c = GatherCounts::default();
    let mut errors = Vec::new();
    for grid in [1, 4, 32] {
        let ms = MultiSampledEstimate::new(&map, grid);
        let (mut err2, mut ref2) = (0.0, 0.0);
        for q in queries.iter().step_by(3) {
            let reference = brute_force_average(&pd, q, 96).x;
            err2 += (ms.radiance(q, &mut c).x - reference).powi(2);
            ref2 += reference * reference;
        }
        errors.push((err2 / ref2).sqrt());
    }
    assert!(
        errors[0] > 0.05,
        "the test footprints are too small to tell: {errors:?}"
    );
    assert!(errors[1] < errors[0] && errors[2] < errors[1], "{errors:?}");
    assert!(errors[2] < 0.01, "{errors:?}");
}

#[test]
fn coplanar_with_a_tiny_view_footprint_equals_the_photon_differential_estimate() {
    let (map, queries) = caustic_queries(1e-4);
    let pd = PhotonDifferentialEstimate { map: &map };
    let coplanar = CoplanarEstimate {
        map: &map,
        ellipse_vertices: 64,
    };
    let mut c = GatherCounts::default();
    for q in &queries {
        let (a, b) = (pd.radiance(q, &mut c), coplanar.radiance(q, &mut c));
        // The polygon is inscribed in the ellipse: photons near their rim may drop out.
        assert!((a - b).length() <= 0.02 * a.length() + 1e-9, "{a} vs {b}");
    }
}

/// A convex polygon from random points (their hull), possibly degenerate.
fn polygon() -> impl Strategy<Value = Vec<DVec2>> {
    prop::collection::vec((-10.0f64..10.0, -10.0f64..10.0), 1..12).prop_map(|pts| {
        convex_hull(
            &pts.into_iter()
                .map(|(x, y)| DVec2::new(x, y))
                .collect::<Vec<_>>(),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn intersection_area_is_bounded_and_symmetric(a in polygon(), b in polygon()) {
        let ab = intersect_convex(&a, &b);
        let ba = intersect_convex(&b, &a);
        let (area_ab, c_ab) = area_centroid(&ab);
        let (area_ba, c_ba) = area_centroid(&ba);
        let (area_a, _) = area_centroid(&a);
        let (area_b, _) = area_centroid(&b);
        prop_assert!(area_ab.is_finite() && c_ab.is_finite() && c_ba.is_finite());
        prop_assert!(ab.iter().chain(&ba).all(|p| p.is_finite()));
        let tol = 1e-9 * (1.0 + area_a + area_b);
        prop_assert!(area_ab <= area_a.min(area_b) + tol, "{} > min({}, {})", area_ab, area_a, area_b);
        prop_assert!((area_ab - area_ba).abs() <= tol);
        if area_ab > 1e-6 {
            prop_assert!((c_ab - c_ba).length() <= 1e-6 * (1.0 + c_ab.length()));
        }
    }

    #[test]
    fn a_polygon_inside_another_is_the_intersection(
        a in polygon(),
        t in 0.0f64..1.0,
        pick in 0usize..12,
        shrink in 0.05f64..1.0,
    ) {
        prop_assume!(a.len() >= 3);
        let (area_a, centroid) = area_centroid(&a);
        prop_assume!(area_a > 1e-6);
        // Shrink `a` towards a point inside it: the copy lies inside `a`.
        let anchor = centroid + (a[pick % a.len()] - centroid) * t * 0.99;
        let inner: Vec<DVec2> = a.iter().map(|&p| anchor + (p - anchor) * shrink).collect();
        let (area_inner, c_inner) = area_centroid(&inner);
        for (x, y) in [(&a, &inner), (&inner, &a)] {
            let (area, c) = area_centroid(&intersect_convex(x, y));
            prop_assert!((area - area_inner).abs() <= 1e-9 * (1.0 + area_a), "{} vs {}", area, area_inner);
            prop_assert!((c - c_inner).length() <= 1e-6 * (1.0 + c_inner.length()));
        }
    }

    #[test]
    fn degenerate_and_disjoint_polygons_give_zero(a in polygon(), dx in 21.0f64..100.0) {
        let moved: Vec<DVec2> = a.iter().map(|p| *p + DVec2::new(dx, 0.0)).collect();
        prop_assert_eq!(area_centroid(&intersect_convex(&a, &moved)).0, 0.0);
        // A segment (zero area) against anything.
        let segment = [DVec2::new(-1.0, -1.0), DVec2::new(1.0, 1.0), DVec2::new(0.0, 0.0)];
        let (area, c) = area_centroid(&intersect_convex(&a, &segment));
        prop_assert!(area == 0.0 && c.is_finite());
    }
}

#[test]
fn no_estimator_produces_nan_infinite_or_negative_radiance() {
    let mut scene = canonical();
    scene.camera = scene.camera.with_resolution(160, 120);
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let mut stats = Stats::default();
    let options = PhotonOptions::default();
    let maps = trace_photon_maps(&scene, &embree, &options, 0, false, &mut stats).unwrap();
    // Every estimate the command line takes, unnamed: a new one is in the test.
    for kind in std::iter::once(EstimatorKind::Direct).chain(EstimatorKind::over_maps()) {
        let settings = EstimatorSettings::new(kind, options.limits(&scene).max_radius);
        let estimators = maps.estimators(&settings);
        let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
        for grid in [1, 2] {
            let film = render(
                &scene,
                &embree,
                &refs,
                &RenderOptions::default().with_view_grid(grid),
                &mut stats,
            )
            .unwrap();
            let bad = film
                .pixels
                .iter()
                .filter(|p| !p.is_finite() || p.min_element() < 0.0)
                .count();
            assert_eq!(bad, 0, "{kind:?}, view grid {grid}: {bad} bad pixels");
            let brightest = film
                .pixels
                .iter()
                .map(|p| p.max_element())
                .fold(0.0, f64::max);
            assert!(brightest > 0.1, "{kind:?}: the image is black");
        }
    }
}

/// The coplanar estimate takes its photons from the footprint estimators' screen
/// ([`PhotonMap::covering`]), not from every photon whose box is near: it must equal the same
/// sum over every photon of the map, also where the query's plane is tilted against the
/// photons' (a curved surface). There the polygon, projected along the query's normal, may
/// meet the view footprint where the kernel (along the photon's) does not reach it; such a
/// photon is screened out, but its kernel at the intersection's centroid is zero anyway.
#[test]
fn coplanar_estimate_equals_its_sum_over_every_photon() {
    use photondiff::estimate::coplanar::coverage;
    use photondiff::estimate::{on_query_surface, photon_kernel};
    use photondiff::geometry::polygon::{ellipse, parallelogram};
    use photondiff::geometry::sampling::tangent_frame;
    let mut lit = 0;
    for scale in [0.2, 1.0, 4.0] {
        let (map, queries) = caustic_queries(scale);
        let coplanar = CoplanarEstimate {
            map: &map,
            ellipse_vertices: 16,
        };
        for (k, q) in queries.iter().enumerate() {
            for degrees in [0.0f64, 3.0, 10.0] {
                let t = degrees.to_radians();
                let turn = if k % 2 == 0 { DVec3::X } else { DVec3::Z };
                let mut q = *q;
                q.normal = (DVec3::Y * t.cos() + turn * t.sin()).normalize();
                // The footprint in the tilted plane.
                q.footprint = q.footprint.map(|f| f - q.normal * f.dot(q.normal));
                let (t1, t2) = tangent_frame(q.normal);
                let to_2d = |v: DVec3| DVec2::new(v.dot(t1), v.dot(t2));
                let view = parallelogram(DVec2::ZERO, to_2d(q.footprint[0]), to_2d(q.footprint[1]));
                let n = q.normal.as_vec3();
                let mut sum = DVec3::ZERO;
                for p in &map.photons() {
                    if !on_query_surface(p, q.position.as_vec3() - p.position, n) {
                        continue;
                    }
                    let axis = |m: glam::Vec3| to_2d((m / m.length_squared()).as_dvec3());
                    let centre = to_2d(p.position.as_dvec3() - q.position);
                    let polygon = ellipse(centre, axis(p.m[0]), axis(p.m[1]), 16);
                    let (w, c) = coverage(&polygon, &view);
                    if w > 0.0 {
                        let c = q.position + t1 * c.x + t2 * c.y;
                        if let Some(k) = photon_kernel(p, c.as_vec3() - p.position, n) {
                            sum += (k * w as f32).as_dvec3();
                        }
                    }
                }
                let expected = q.albedo * std::f64::consts::FRAC_1_PI * sum;
                let got = coplanar.radiance(&q, &mut GatherCounts::default());
                lit += usize::from(expected.length() > 0.0);
                assert!(
                    (got - expected).length() <= 1e-5 * expected.length() + 1e-12,
                    "scale {scale}, tilt {degrees}, query {k}: {got} against {expected}"
                );
            }
        }
    }
    assert!(lit > 300, "{lit}");
}

/// A packet's gathers asked at once (`RadianceEstimator::radiance_batch`, which `integrated`
/// answers by filling its SIMD batches across gathers) give every estimator's one-by-one
/// answers, here bit for bit, and the same counts: with and without exact view footprints, the
/// queries' photons crossing the circle, lying inside it and missing it side by side. (The
/// general formula takes one `atan2` or four for four lanes at once, so in general a crossing
/// photon's mean may differ in its last bits with the company it keeps; not on this data.)
#[test]
fn a_batch_of_gathers_answers_as_the_gathers_one_by_one() {
    let scene = canonical();
    let (map, mut queries) = caustic_queries(1.0);
    // Every other query with the exact footprint of its pixel, as the render loop gives it.
    let camera = &scene.camera;
    let mut exact = 0;
    for q in queries.iter_mut().step_by(2) {
        let (x, y) = camera.project(q.position).unwrap();
        let (x, y) = (x.floor(), y.floor());
        let ray = camera.ray(x + 0.5, y + 0.5, 1.0);
        let t = -ray.p.y / ray.d.y;
        let at = ray.transfer(t, DVec3::Y);
        let corners = camera
            .rectangle_on_plane([x, y, x + 1.0, y + 1.0], at.p, DVec3::Y)
            .unwrap();
        q.position = at.p;
        q.footprint = at.dp;
        q.exact = ExactFootprint::new(&corners, at.p, &at.dp)
            .map(|e| e.seen_from(camera.eye, camera.forward, at.p, &at.dp));
        exact += usize::from(q.exact.is_some());
    }
    assert!(exact > 50, "{exact} exact footprints");
    // Every estimate over photon maps, with its defaults, unnamed: a new one is in the test.
    let estimators: Vec<(EstimatorKind, Box<dyn RadianceEstimator + '_>)> =
        EstimatorKind::over_maps()
            .filter_map(|kind| {
                let settings = EstimatorSettings::new(kind, f64::from(map.max_radius));
                Some((kind, settings.estimator_over(&map)?))
            })
            .collect();
    assert!(estimators.len() >= 5);
    let shares = vec![1.0; queries.len()];
    for (name, estimator) in &estimators {
        let (mut one, mut all) = (GatherCounts::default(), GatherCounts::default());
        let single: Vec<DVec3> = queries
            .iter()
            .map(|q| estimator.radiance_share(q, 1.0, &mut one))
            .collect();
        let mut batch = vec![DVec3::NAN; queries.len()];
        estimator.radiance_batch(&queries, &shares, &mut batch, &mut all);
        assert_eq!(batch, single, "{name:?}");
        assert_eq!(all, one, "{name:?}");
        let lit = single.iter().filter(|l| l.max_element() > 0.0).count();
        // Some queries lie beyond every photon's footprint; `jensen`'s nearest photons,
        // within its largest radius, reach them all.
        let beyond = lit < queries.len() || *name == EstimatorKind::Jensen;
        assert!(lit > 20 && beyond, "{name:?}: {lit} lit");
        // `pd` reads the kernel from the photons' filter-space records: it answers what the
        // kernel summed over every photon of the map (in map order, as found) answers.
        if *name == EstimatorKind::Pd {
            for (q, &answer) in queries.iter().zip(&single) {
                let (x, n) = (q.position.as_vec3(), q.normal.as_vec3());
                let sum: Vec3 = map
                    .photons()
                    .iter()
                    .filter_map(|p| photon_kernel(p, x - p.position, n))
                    .fold(Vec3::ZERO, |a, c| a + c);
                assert_eq!(answer, q.albedo * FRAC_1_PI * sum.as_dvec3());
            }
        }
    }
}
