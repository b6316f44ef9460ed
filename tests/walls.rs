//! Footprints at walls and edges (`photons::walls`): the wall found at its distance at the foot
//! of a wall and at a convex edge, none diagonally off a box's outer corner, in the open, under
//! an overhang or over a gentle crease; the mirror photon's kernel the photon's mirrored; and the
//! estimate at the foot of a wall against a point light's analytic irradiance, which without
//! the probes is far too dark.

use glam::DVec3;
use photondiff::embree::Device;
use photondiff::estimate::{
    GatherCounts, GatherQuery, PhotonDifferentialEstimate, RadianceEstimator,
};
use photondiff::photons::emission::Emitter;
use photondiff::photons::footprint::Footprint;
use photondiff::photons::map::{PathClass, PhotonMap};
use photondiff::photons::options::PhotonOptions;
use photondiff::photons::trace::{PhotonTracer, StopRule};
use photondiff::photons::walls::{nearest_walls, Wall, Walls};
use photondiff::scene::file::parse_scene;
use photondiff::scene::Scene;
use std::f64::consts::PI;
use std::path::Path;

const HEADER: &str = r#"
[camera]
eye = [0.0, 5.0, 5.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov_y = 40.0
width = 16
height = 16

[materials.white]
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[[lights]]
type = "point"
position = [0.0, 2.0, 0.0]
intensity = [10.0, 10.0, 10.0]

# The floor, y = 0.
[[shapes]]
type = "quad"
corner = [-5.0, 0.0, 5.0]
edge_u = [10.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -10.0]
material = "white"
"#;

/// A wall standing on the floor at x = 1 (facing the light), 2 high.
const WALL: &str = r#"
[[shapes]]
type = "quad"
corner = [1.0, 0.0, 5.0]
edge_u = [0.0, 0.0, -10.0]
edge_v = [0.0, 2.0, 0.0]
material = "white"
"#;

/// The over-an-edge stress scene's kind of box, [1, 3] x [0, 0.5] x [-2, 2]: its top and four
/// sides (it stands on the floor).
const BOX: &str = r#"
[[shapes]]
type = "quad"
corner = [1.0, 0.5, 2.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -4.0]
material = "white"

[[shapes]]
type = "quad"
corner = [1.0, 0.0, 2.0]
edge_u = [0.0, 0.0, -4.0]
edge_v = [0.0, 0.5, 0.0]
material = "white"

[[shapes]]
type = "quad"
corner = [3.0, 0.0, 2.0]
edge_u = [0.0, 0.0, -4.0]
edge_v = [0.0, 0.5, 0.0]
material = "white"

[[shapes]]
type = "quad"
corner = [1.0, 0.0, 2.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.5, 0.0]
material = "white"

[[shapes]]
type = "quad"
corner = [1.0, 0.0, -2.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.5, 0.0]
material = "white"
"#;

fn scene_of(parts: &[&str]) -> Scene {
    parse_scene(&parts.concat(), Path::new(".")).unwrap()
}

/// A round footprint of radius `r` on the floor, its filter axes along x and z.
fn round(r: f64) -> Footprint {
    Footprint {
        m: [DVec3::X / r, DVec3::Z / r],
        area: r * r,
        radius: r,
    }
}

/// The wall near `at`, probed; the screen of [`Walls`] must give the same answer (it skips
/// only the probes that could not stop).
fn wall_near(scene: &Scene, at: DVec3, normal: DVec3, r: f64) -> Option<Wall> {
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let probed = nearest_walls(&embree, at, normal, &round(r), scene.ray_epsilon());
    let screened = Walls::new(&embree).nearest(at, normal, &round(r), scene.ray_epsilon());
    assert_eq!(probed, screened, "at {at}, radius {r}");
    let nearest =
        nearest_walls(&embree, at, normal, &round(r), scene.ray_epsilon()).map(|w| w.first);
    assert_eq!(nearest, probed.map(|p| p.first));
    nearest
}

/// Whether the screen of [`Walls`] probes a photon at `at` on the floor.
fn screened_in(scene: &Scene, at: DVec3, r: f64) -> bool {
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    Walls::new(&embree).may_stop(at, DVec3::Y, &round(r), scene.ray_epsilon())
}

#[test]
fn the_screen_probes_only_near_geometry_that_could_be_a_wall() {
    // The floor alone is flat and level with the photon: never a wall.
    assert!(!screened_in(
        &scene_of(&[HEADER]),
        DVec3::new(0.3, 0.0, -0.2),
        2.0
    ));
    // The canonical scene's sphere resting on the floor (centre (0, 1, 0), radius 1): photons
    // in the caustic, about 1.4 from where it touches the floor, are not probed; one under it is.
    let sphere = r#"
[[shapes]]
type = "sphere"
center = [0.0, 1.0, 0.0]
radius = 1.0
material = "white"
"#;
    let scene = scene_of(&[HEADER, sphere]);
    assert!(!screened_in(&scene, DVec3::new(1.3, 0.0, 0.3), 0.05));
    assert!(screened_in(&scene, DVec3::new(0.2, 0.0, 0.0), 0.05));
    // The reach counts: 0.05 from a sphere's bound the photon is probed when its footprint
    // is wider than that, not when it is narrower. (The sphere's bound: distance 1 + 0.05
    // from its centre, on the floor.)
    let x = ((1.05f64).powi(2) - 1.0).sqrt();
    assert!(!screened_in(&scene, DVec3::new(x, 0.0, 0.0), 0.02));
    assert!(screened_in(&scene, DVec3::new(x, 0.0, 0.0), 0.08));
    // A wall standing on the floor is steep: probed within reach, not beyond.
    let scene = scene_of(&[HEADER, WALL]);
    assert!(screened_in(&scene, DVec3::new(0.5, 0.0, 0.0), 0.4));
    // (The wall's bound is the sphere through its corners, centre (1, 1, 0), radius sqrt(26);
    // from (-4.5, 0, 0) its surface is 0.49 away, beyond the reach of a footprint of 0.1.)
    assert!(!screened_in(&scene, DVec3::new(-4.5, 0.0, 0.0), 0.1));
    assert!(screened_in(&scene, DVec3::new(-4.5, 0.0, 0.0), 0.4));
}

fn assert_wall(wall: Option<Wall>, normal: DVec3, distance: f64, what: &str) {
    let wall = wall.unwrap_or_else(|| panic!("{what}: no wall found"));
    assert!(
        (wall.normal - normal).length() < 1e-9 && (wall.distance - distance).abs() < 1e-6,
        "{what}: {wall:?}, expected {normal} at {distance}"
    );
}

#[test]
fn a_photon_in_the_open_has_no_wall() {
    let scene = scene_of(&[HEADER]);
    for r in [0.01, 0.5, 2.0] {
        assert_eq!(
            wall_near(&scene, DVec3::new(0.3, 0.0, -0.2), DVec3::Y, r),
            None
        );
    }
}

#[test]
fn a_wall_is_found_at_its_distance_and_mirrors_the_photon_and_its_footprint() {
    let scene = scene_of(&[HEADER, WALL]);
    let r = 0.4;
    for d in [0.01, 0.1, 0.2, 0.3, 0.35] {
        let at = DVec3::new(1.0 - d, 0.0, 0.0);
        assert_wall(wall_near(&scene, at, DVec3::Y, r), DVec3::X, d, "wall");
        // The photon's normal may face either way: the probes go to both sides.
        assert_wall(wall_near(&scene, at, -DVec3::Y, r), DVec3::X, d, "flipped");
    }
    // Beyond its reach the wall is not seen.
    assert_eq!(
        wall_near(&scene, DVec3::new(0.5, 0.0, 0.0), DVec3::Y, r),
        None
    );
    // The mirror: across x = 1, with its footprint's rows mirrored, its kernel the photon's
    // kernel mirrored.
    let at = DVec3::new(0.8, 0.0, 0.1);
    let wall = wall_near(&scene, at, DVec3::Y, r).unwrap();
    let mirror = wall.reflect_point(at, at);
    assert!(
        (mirror - DVec3::new(1.2, 0.0, 0.1)).length() < 1e-6,
        "{mirror}"
    );
    let f = Footprint {
        m: [DVec3::new(2.0, 0.0, 1.0), DVec3::new(-0.5, 0.0, 3.0)],
        area: 1.0 / 6.5,
        radius: 0.6,
    };
    let g = wall.reflect_footprint(&f);
    for x in [DVec3::new(1.1, 0.0, 0.3), DVec3::new(0.9, 0.0, -0.2)] {
        let seen = |m: [DVec3; 2], v: DVec3| (m[0].dot(v), m[1].dot(v));
        let (a, b) = seen(f.m, x - at);
        let (c, d) = seen(g.m, wall.reflect_point(at, x) - mirror);
        assert!((a - c).abs() < 1e-9 && (b - d).abs() < 1e-9);
    }
}

#[test]
fn a_convex_edge_and_the_foot_of_a_box_are_walls() {
    let scene = scene_of(&[HEADER, BOX]);
    let r = 0.4;
    for d in [0.01, 0.1, 0.2, 0.3] {
        // On the top, d inside its rim at x = 1: the probes below the top meet the box's side
        // from inside; the footprint's part beyond the rim is in the air.
        let top = DVec3::new(1.0 + d, 0.5, 0.0);
        assert_wall(wall_near(&scene, top, DVec3::Y, r), -DVec3::X, d, "top");
        // On the floor, d from the box's side.
        let foot = DVec3::new(1.0 - d, 0.0, 0.0);
        assert_wall(wall_near(&scene, foot, DVec3::Y, r), DVec3::X, d, "foot");
    }
    // Beside the box's outer corner (diagonally off it) the faces' lines run on past the faces:
    // a mirror across either would land on open floor, so there is none.
    let corner = DVec3::new(0.9, 0.0, 2.05);
    assert_eq!(wall_near(&scene, corner, DVec3::Y, r), None);
    // Off the corner along one face, that face is the wall.
    let beside = DVec3::new(0.9, 0.0, 1.9);
    assert_wall(
        wall_near(&scene, beside, DVec3::Y, r),
        DVec3::X,
        0.1,
        "beside",
    );
    // There the box's other face, square to the first, is no second wall: its line runs past
    // it, so it is not a corner the photon's surface lies in.
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let pair = nearest_walls(&embree, beside, DVec3::Y, &round(r), scene.ray_epsilon());
    assert_eq!(
        pair.map(|p| (p.second, p.images().count())),
        Some((None, 1))
    );
    // On the box's top, near its corner, both rims: three images.
    let top_corner = DVec3::new(1.1, 0.5, 1.8);
    let pair = nearest_walls(
        &embree,
        top_corner,
        DVec3::Y,
        &round(r),
        scene.ray_epsilon(),
    )
    .expect("the top's rims");
    assert_wall(Some(pair.first), -DVec3::X, 0.1, "the top's nearer rim");
    assert_wall(pair.second, DVec3::Z, 0.2, "the top's other rim");
}

#[test]
fn beyond_the_screens_limit_every_photon_is_probed() {
    // Tiny flat tiles far from the photon, flat like the floor: none could stop a probe, but
    // past `Walls::MAX_SCREENED` geometries the screen is not scanned.
    let tile = |k: usize| {
        format!(
            "[[shapes]]\ntype = \"quad\"\ncorner = [{}, 0.0, -4.9]\nedge_u = [0.01, 0.0, 0.0]\nedge_v = [0.0, 0.0, -0.01]\nmaterial = \"white\"\n",
            -4.9 + 0.02 * k as f64
        )
    };
    for (count, probed) in [
        (Walls::MAX_SCREENED - 1, false),
        (Walls::MAX_SCREENED, true),
    ] {
        let tiles: Vec<String> = (0..count).map(tile).collect();
        let parts: Vec<&str> = std::iter::once(HEADER)
            .chain(tiles.iter().map(String::as_str))
            .collect();
        let scene = scene_of(&parts);
        let at = DVec3::new(0.3, 0.0, 0.2);
        assert_eq!(
            screened_in(&scene, at, 0.1),
            probed,
            "{count} tiles and the floor"
        );
    }
}

#[test]
fn overhangs_and_gentle_creases_are_not_walls() {
    let overhang = r#"
[materials.glass]
type = "glass"
ior = 1.5

# A sphere resting on the floor: the floor under its bottom is seen through it.
[[shapes]]
type = "sphere"
center = [0.0, 1.0, 0.0]
radius = 1.0
material = "glass"

# A slab hovering above the floor.
[[shapes]]
type = "quad"
corner = [2.0, 0.05, 1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -2.0]
material = "white"
"#;
    let scene = scene_of(&[HEADER, overhang]);
    for at in [
        DVec3::new(0.1, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 0.05),
        DVec3::new(2.5, 0.0, 0.0),
        DVec3::new(1.8, 0.0, 0.0),
    ] {
        assert_eq!(wall_near(&scene, at, DVec3::Y, 0.4), None, "at {at}");
    }
    // The floor bends up by 10 degrees at x = 0: gathers on the ramp still see the photon.
    let t = 10f64.to_radians();
    let ramp = format!(
        r#"
[[shapes]]
type = "quad"
corner = [0.0, 0.0, 5.0]
edge_u = [{}, {}, 0.0]
edge_v = [0.0, 0.0, -10.0]
material = "white"
"#,
        3.0 * t.cos(),
        3.0 * t.sin()
    );
    let floor_left = HEADER.replace("edge_u = [10.0, 0.0, 0.0]", "edge_u = [5.0, 0.0, 0.0]");
    let scene = scene_of(&[&floor_left, &ramp]);
    assert_eq!(
        wall_near(&scene, DVec3::new(-0.1, 0.0, 0.0), DVec3::Y, 0.4),
        None
    );
}

/// The direct-light photon map of the floor beside the wall: 400,000 emissions at overlap 128
/// give footprints about 0.07 in radius at the wall.
fn wall_map(light: DVec3, probe_walls: bool) -> (PhotonMap, u64) {
    direct_map(&[WALL], light, 128.0, probe_walls)
}

/// The direct-light photon map of 400,000 emissions from a point light at `light` over the
/// floor with the shapes `walls`, at `overlap`; and the photons stored.
fn direct_map(walls: &[&str], light: DVec3, overlap: f64, probe_walls: bool) -> (PhotonMap, u64) {
    let header = HEADER.replace(
        "position = [0.0, 2.0, 0.0]",
        &format!("position = [{}, {}, {}]", light.x, light.y, light.z),
    );
    let scene = scene_of(&[&[header.as_str()], walls].concat());
    let device = Device::new().unwrap();
    let embree = scene.build_embree(&device).unwrap();
    let options = PhotonOptions {
        global_photons: 400_000,
        overlap,
        probe_walls,
        ..PhotonOptions::default()
    };
    let tracer = PhotonTracer::new(&scene, &embree, &options);
    let emitter = Emitter::global(&scene, options.global_photons, options.overlap, 1);
    let (map, counts) = tracer
        .build_map(
            &emitter,
            PathClass::Direct,
            StopRule::Emitted(options.global_photons),
            &indicatif::ProgressBar::hidden(),
        )
        .unwrap();
    (map, counts.stored)
}

/// The mean of the photon estimate along a row of floor points `d` from the foot of the wall,
/// over the analytic irradiance there.
fn at_the_wall(map: &PhotonMap, light: DVec3, d: f64) -> f64 {
    let points: Vec<DVec3> = (0..41)
        .map(|k| DVec3::new(1.0 - d, 0.0, -0.5 + k as f64 / 40.0))
        .collect();
    relative_estimate(map, light, &points)
}

/// The mean over floor points `points` of the photon estimate over the analytic irradiance
/// of the point light (intensity 10) at `light`.
fn relative_estimate(map: &PhotonMap, light: DVec3, points: &[DVec3]) -> f64 {
    let estimate = PhotonDifferentialEstimate { map };
    let mut gathers = GatherCounts::default();
    let mut sum = 0.0;
    for &x in points {
        let d2 = (x - light).length_squared();
        let analytic = 10.0 * (light.y / d2.sqrt()) / d2;
        // Albedo pi turns the reflected radiance (albedo / pi) E into the irradiance E.
        let query = GatherQuery {
            position: x,
            normal: DVec3::Y,
            albedo: DVec3::splat(PI),
            footprint: [DVec3::ZERO; 2],
            exact: None,
        };
        sum += estimate.radiance(&query, &mut gathers).x / analytic;
    }
    sum / points.len() as f64
}

#[test]
fn the_estimate_at_the_foot_of_a_wall_matches_the_light_and_mirrors_add_no_power() {
    let light = DVec3::new(0.0, 2.0, 0.0);
    let ((with, stored), (without, stored_without)) =
        (wall_map(light, true), wall_map(light, false));
    // Within a footprint's radius of the wall: before, the band was dark, down to half at the
    // wall (the mirror is exact there for even light; the light's slope is what is left).
    for d in [0.005, 0.02] {
        let (w, wo) = (
            at_the_wall(&with, light, d),
            at_the_wall(&without, light, d),
        );
        assert!((w - 1.0).abs() < 0.03, "d {d}: with the probes x{w}");
        assert!(wo < 0.85, "d {d}: without the probes x{wo}");
    }
    // Away from the wall nothing changes (but the order in which the photons are summed).
    let (w, wo) = (
        at_the_wall(&with, light, 0.5),
        at_the_wall(&without, light, 0.5),
    );
    assert!((w - wo).abs() < 1e-6, "{w} vs {wo}");
    // The same photons, and a mirror for each photon near the wall (and the floor's far edges)
    // that carries no power of its own in the statistics.
    assert_eq!(stored, stored_without);
    let mirrors = with.guards.mirrored;
    assert!(
        mirrors > 1000 && with.len() as u64 == stored + mirrors,
        "{mirrors}"
    );
    assert_eq!(without.guards.mirrored, 0);
    let (a, b) = (with.total_power(), without.total_power());
    assert!(((a - b) / b).abs().max_element() < 1e-9, "{a} vs {b}");
}

#[test]
fn light_that_falls_towards_a_wall_is_right_at_its_foot() {
    // A light low over the floor beside the wall: the irradiance falls by a factor of about
    // three from below the light to the wall, and the footprints are about 0.02 in radius. The
    // mirrors stand for light as it is across the wall; the slope over a footprint is a few
    // percent here.
    let light = DVec3::new(0.7, 0.3, 0.0);
    let (with, _) = wall_map(light, true);
    let (without, _) = wall_map(light, false);
    let (w, wo) = (
        at_the_wall(&with, light, 0.005),
        at_the_wall(&without, light, 0.005),
    );
    assert!((w - 1.0).abs() < 0.02, "with the probes x{w}");
    assert!(wo < 0.8, "without the probes x{wo}");
}

/// A second wall on the floor at z = -1, facing +z, meeting [`WALL`] (x = 1) in an inner
/// corner at (1, 0, -1).
const SECOND_WALL: &str = r#"
[[shapes]]
type = "quad"
corner = [-5.0, 0.0, -1.0]
edge_u = [6.0, 0.0, 0.0]
edge_v = [0.0, 2.0, 0.0]
material = "white"
"#;

#[test]
fn an_inner_corner_has_two_walls_and_three_images() {
    let device = Device::new().unwrap();
    let scene = scene_of(&[HEADER, WALL, SECOND_WALL]);
    let embree = scene.build_embree(&device).unwrap();
    let at = DVec3::new(0.9, 0.0, -0.8);
    let pair = Walls::new(&embree)
        .nearest(at, DVec3::Y, &round(0.4), scene.ray_epsilon())
        .expect("walls in the corner");
    assert_wall(Some(pair.first), DVec3::X, 0.1, "the nearer wall");
    assert_wall(pair.second, -DVec3::Z, 0.2, "the wall square to it");
    // The images: across x = 1, across z = -1, and the half turn about the corner.
    let images: Vec<DVec3> = pair.images().map(|i| i.point(at, at)).collect();
    let expected = [
        DVec3::new(1.1, 0.0, -0.8),
        DVec3::new(0.9, 0.0, -1.2),
        DVec3::new(1.1, 0.0, -1.2),
    ];
    for (image, expected) in images.iter().zip(expected) {
        // (The walls' distances come from Embree's single-precision hits.)
        assert!(image.distance(expected) < 1e-6, "{image} vs {expected}");
    }
    assert_eq!(images.len(), 3);
    // Along one wall, away from the corner, one wall and one image.
    let pair = nearest_walls(
        &embree,
        DVec3::new(0.9, 0.0, 1.0),
        DVec3::Y,
        &round(0.4),
        1e-4,
    )
    .expect("the wall");
    assert_eq!((pair.second, pair.images().count()), (None, 1));
    // A wedge of 30 degrees (a wall from (1, 0, 0) along (-0.5, 0, -0.866)) keeps the nearer
    // wall's mirror only.
    let wedge = r#"
[[shapes]]
type = "quad"
corner = [1.0, 0.0, 0.0]
edge_u = [-3.0, 0.0, -5.196152422706632]
edge_v = [0.0, 2.0, 0.0]
material = "white"
"#;
    let scene = scene_of(&[HEADER, WALL, wedge]);
    let embree = scene.build_embree(&device).unwrap();
    let pair = nearest_walls(
        &embree,
        DVec3::new(0.97, 0.0, -0.2),
        DVec3::Y,
        &round(0.4),
        1e-4,
    )
    .expect("walls in the wedge");
    assert_wall(Some(pair.first), DVec3::X, 0.03, "the wedge's nearer wall");
    assert_eq!((pair.second, pair.images().count()), (None, 1));
}

/// The photon estimate in the corner of [`WALL`] and [`SECOND_WALL`] under a light near
/// above it, at (0.8, 2, -0.8), over the analytic irradiance: the mean over a 5 x 5 grid of
/// points within 0.002 to 0.03 of both walls, from a map of wide footprints (overlap 1024,
/// about 0.2 in radius: the noise of an estimate falls as the overlap's square root). The
/// light is at the walls' height, so the floor beyond them is dark (a gather does not test
/// visibility, and light beyond a thin wall would leak through it). Near above the corner,
/// the light's slope over a footprint is about 1%: the mirrors stand for the light as it is on
/// the seen side, and with the light at (0, 2, 0) that slope alone put the corner at x1.12.
fn in_the_corner(probe_walls: bool) -> f64 {
    let light = DVec3::new(0.8, 2.0, -0.8);
    let (map, _) = direct_map(&[WALL, SECOND_WALL], light, 1024.0, probe_walls);
    let steps = [0.002, 0.009, 0.016, 0.023, 0.03];
    let points: Vec<DVec3> = steps
        .iter()
        .flat_map(|dx| steps.map(|dz| DVec3::new(1.0 - dx, 0.0, -1.0 + dz)))
        .collect();
    relative_estimate(&map, light, &points)
}

#[test]
fn the_estimate_in_an_inner_corner_matches_the_light() {
    let (with, without) = (in_the_corner(true), in_the_corner(false));
    // Without mirrors a quarter of each kernel is seen at the corner itself; with one wall's
    // mirror a half; with the three images all of it.
    assert!((with - 1.0).abs() < 0.04, "with the images x{with}");
    assert!(without < 0.5, "without x{without}");
}
