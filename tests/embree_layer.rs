//! The Embree layer: known hits, packets against single rays, invalid rays, mesh validation.

use glam::DVec3;
use photondiff::embree::{
    Device, EmbreeError, Hit, RawRays, Ray, Scene, SceneBuilder, TriangleMesh,
};
use photondiff::scene::shapes;
use photondiff::util::rng::Rng;

fn scene() -> Scene {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device);
    // Geometry 0: the square [-1, 1]^2 at z = 0, facing +z.
    let id = builder
        .add_mesh(shapes::quad(
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        ))
        .unwrap();
    assert_eq!(id, 0);
    // Geometry 1: a unit sphere at (0, 0, 3).
    let id = builder
        .add_mesh(shapes::sphere(DVec3::new(0.0, 0.0, 3.0), 1.0, 256))
        .unwrap();
    assert_eq!(id, 1);
    builder.commit().unwrap()
}

#[test]
fn known_hit_distances_and_primitive_ids() {
    let scene = scene();
    let down = DVec3::new(0.0, 0.0, -1.0);
    // (0.5, -0.5) lies in the quad's first triangle (v0 v1 v2), (-0.5, 0.5) in its second.
    let hit = scene
        .intersect(&Ray::new(DVec3::new(0.5, -0.5, 1.5), down))
        .unwrap();
    assert_eq!((hit.geom_id, hit.prim_id), (0, 0));
    assert!((hit.t - 1.5).abs() < 1e-6, "{}", hit.t);
    assert!(hit.position.abs_diff_eq(DVec3::new(0.5, -0.5, 0.0), 1e-6));
    assert!(hit.geometric_normal.abs_diff_eq(DVec3::Z, 1e-12));
    let hit = scene
        .intersect(&Ray::new(DVec3::new(-0.5, 0.5, 1.5), down))
        .unwrap();
    assert_eq!((hit.geom_id, hit.prim_id), (0, 1));
    // The sphere's top, 10 - 4 = 6 away along -z.
    let hit = scene
        .intersect(&Ray::new(DVec3::new(0.0, 0.0, 10.0), down))
        .unwrap();
    assert_eq!(hit.geom_id, 1);
    assert!((hit.t - 6.0).abs() < 1e-6, "{}", hit.t);
    assert!(hit.shading_normal.abs_diff_eq(DVec3::Z, 1e-6));
    // Off-centre: the interpolated normal is the sphere's normal, the facet's is not quite.
    let origin = DVec3::new(0.3, 0.2, 10.0);
    let hit = scene.intersect(&Ray::new(origin, down)).unwrap();
    let exact_t = 10.0 - 3.0 - (1.0f64 - 0.13).sqrt();
    // The facets lie inside the sphere by at most twice the sagitta of a 1/256 turn.
    let sagitta = 1.0 - (std::f64::consts::PI / 256.0).cos();
    assert!(
        (hit.t - exact_t).abs() < 2.0 * sagitta,
        "{} vs {exact_t}",
        hit.t
    );
    let exact_n = (hit.position - DVec3::new(0.0, 0.0, 3.0)).normalize();
    assert!((hit.shading_normal - exact_n).length() < 1e-4);
    // A segment that stops short misses; occlusion agrees.
    let short = Ray::segment(DVec3::new(0.5, -0.5, 1.5), down, 1.4);
    assert!(scene.intersect(&short).is_none());
    assert!(!scene.occluded(&short));
    assert!(scene.occluded(&Ray::segment(DVec3::new(0.5, -0.5, 1.5), down, 1.6)));
    assert!(scene
        .intersect(&Ray::new(DVec3::new(5.0, 5.0, 1.0), down))
        .is_none());
}

fn random_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed, 0);
    (0..n)
        .map(|_| {
            let origin = DVec3::new(rng.uniform() * 4.0 - 2.0, rng.uniform() * 4.0 - 2.0, 8.0);
            let target = DVec3::new(rng.uniform() * 3.0 - 1.5, rng.uniform() * 3.0 - 1.5, 0.0);
            Ray::new(origin, (target - origin).normalize())
        })
        .collect()
}

fn same(a: &Option<Hit>, b: &Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            a.geom_id == b.geom_id && a.prim_id == b.prim_id && (a.t - b.t).abs() < 1e-5
        }
        _ => false,
    }
}

#[test]
fn packets_agree_with_single_rays_and_probes_with_hits() {
    let scene = scene();
    let rays = random_rays(16 * 40 + 5, 3);
    let mut hits = [None; 16];
    let mut blocked = [false; 16];
    let mut normals = [None; 16];
    let mut n_hits = 0;
    for (k, chunk) in rays.chunks(16).enumerate() {
        scene.intersect16(chunk, k % 2 == 0, &mut hits);
        scene.occluded16(chunk, k % 2 == 1, &mut blocked);
        scene.hit_normals16(chunk, k % 2 == 0, &mut normals);
        for (lane, ray) in chunk.iter().enumerate() {
            let single = scene.intersect(ray);
            assert!(same(&single, &hits[lane]), "ray {ray:?}");
            assert_eq!(scene.occluded(ray), blocked[lane]);
            // The probes' answer: the same geometric normal exactly, and the distance Embree's
            // (single precision; a completed hit refines it in double).
            match (&single, normals[lane]) {
                (None, None) => {}
                (Some(h), Some((t, n))) => {
                    assert_eq!(n, h.geometric_normal, "ray {ray:?}");
                    assert!((t - h.t).abs() <= 1e-6 * h.t, "ray {ray:?}: {t} vs {}", h.t);
                }
                (a, b) => panic!("ray {ray:?}: {a:?} vs {b:?}"),
            }
            n_hits += usize::from(single.is_some());
        }
    }
    // The rays were aimed so that both hits and misses occur.
    assert!(n_hits > 100 && n_hits < rays.len() - 100, "{n_hits}");
}

#[test]
fn packets_of_every_width_answer_as_single_rays() {
    // Packets with inactive lanes are traced lane by lane (Embree 3.13.5's 16-wide call costs
    // ~1.5 us per inactive lane): their answers are exactly the single rays', whatever the
    // width and wherever an invalid ray sits; full packets agree as above.
    let scene = scene();
    let rays = random_rays(16 * 16, 11);
    let bad = Ray::new(DVec3::new(f64::NAN, 0.0, 1.0), DVec3::NEG_Z);
    let mut n_hits = 0;
    for width in 1..=16 {
        for coherent in [false, true] {
            let mut packet = rays[(width - 1) * 16..][..width].to_vec();
            let with_bad = width > 2 && coherent;
            if with_bad {
                packet[width / 2] = bad;
            }
            let mut hits = [None; 16];
            let mut blocked = [true; 16];
            scene.intersect16(&packet, coherent, &mut hits);
            scene.occluded16(&packet, coherent, &mut blocked);
            let partial = width < 16 || with_bad;
            for (lane, ray) in packet.iter().enumerate() {
                let single = scene.intersect(ray);
                if partial {
                    assert_eq!(hits[lane], single, "width {width}, lane {lane}");
                } else {
                    assert!(same(&single, &hits[lane]), "width {width}, lane {lane}");
                }
                assert_eq!(blocked[lane], scene.occluded(ray), "width {width}");
                n_hits += usize::from(single.is_some());
            }
        }
    }
    assert!(n_hits > 30 && n_hits < 16 * 17 - 30, "{n_hits}");
}

#[test]
fn raw_throughput_calls_count_what_the_safe_calls_answer() {
    // The benchmarks' raw calls go through the same backend calls without post-processing.
    let scene = scene();
    let rays = random_rays(16 * 20 + 7, 5);
    let raw = RawRays::new(&rays);
    assert_eq!(raw.len(), rays.len());
    let hits = rays.iter().filter(|r| scene.intersect(r).is_some()).count();
    let blocked = rays.iter().filter(|r| scene.occluded(r)).count();
    assert!(hits > 50 && hits < rays.len() - 50, "{hits}");
    assert_eq!(scene.raw_intersect1(&raw), hits);
    assert_eq!(scene.raw_occluded1(&raw), blocked);
    for coherent in [false, true] {
        assert_eq!(scene.raw_intersect16(&raw, coherent), hits);
        assert_eq!(scene.raw_occluded16(&raw, coherent), blocked);
    }
}

#[test]
fn invalid_rays_are_misses_counted_and_never_abort() {
    let scene = scene();
    let good = Ray::new(DVec3::new(0.5, -0.5, 1.5), DVec3::NEG_Z);
    let bad = [
        Ray::new(DVec3::new(f64::NAN, 0.0, 1.0), DVec3::NEG_Z),
        Ray::new(DVec3::ZERO, DVec3::new(0.0, f64::INFINITY, -1.0)),
        Ray::new(DVec3::new(0.0, 0.0, 2e18), DVec3::NEG_Z),
        Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::ZERO),
        Ray {
            tnear: -1.0,
            ..good
        },
        Ray {
            tfar: f64::NAN,
            ..good
        },
        Ray {
            tnear: 2.0,
            tfar: 1.0,
            ..good
        },
    ];
    for ray in &bad {
        assert!(!ray.is_valid(), "{ray:?}");
        assert!(scene.intersect(ray).is_none());
        assert!(!scene.occluded(ray));
    }
    assert_eq!(scene.invalid_rays(), 2 * bad.len() as u64);
    // In a packet, the invalid lanes miss and the valid ones still hit.
    let mut packet = bad.to_vec();
    packet.push(good);
    let mut hits = [None; 16];
    scene.intersect16(&packet, true, &mut hits);
    assert!(hits[..bad.len()].iter().all(Option::is_none));
    assert_eq!(hits[bad.len()].unwrap().prim_id, 0);
    let mut blocked = [true; 16];
    scene.occluded16(&packet, true, &mut blocked);
    assert!(blocked[..bad.len()].iter().all(|b| !b));
    assert!(blocked[bad.len()]);
    assert_eq!(scene.invalid_rays(), 4 * bad.len() as u64);
}

#[test]
fn scenes_are_shared_across_threads() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Scene>();
    let scene = scene();
    let rays = random_rays(2000, 9);
    let expected: Vec<_> = rays.iter().map(|r| scene.intersect(r)).collect();
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                for (ray, e) in rays.iter().zip(&expected) {
                    assert!(same(&scene.intersect(ray), e));
                }
            });
        }
    });
}

#[test]
fn malformed_meshes_are_rejected_with_a_reason() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device);
    let tri = |positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>| TriangleMesh {
        positions,
        normals: None,
        triangles,
    };
    let cases = [
        (
            tri(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, f32::NAN, 0.0]], vec![[0, 1, 2]]),
            "invalid mesh: vertex 2 is not finite: [0.0, NaN, 0.0]",
        ),
        (
            tri(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0e19, 0.0]], vec![[0, 1, 2]]),
            "invalid mesh: vertex 2 lies beyond the coordinates Embree takes (|x| < 1e18): [0.0, 1e19, 0.0]",
        ),
        (
            tri(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 3]]),
            "invalid mesh: triangle 0 uses vertex 3, but the mesh has 3 vertices",
        ),
        (
            tri(vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], vec![[0, 1, 2]]),
            "invalid mesh: triangle 0 is degenerate (zero area): [0.0, 0.0, 0.0] [1.0, 0.0, 0.0] [2.0, 0.0, 0.0]",
        ),
    ];
    for (mesh, message) in cases {
        let err: EmbreeError = builder.add_mesh(mesh).unwrap_err();
        assert_eq!(err.to_string(), message);
    }
}

#[test]
fn the_library_is_the_version_of_the_headers() {
    // BACKEND comes from the headers the bindings were generated from; the device reports the
    // library's own version (and refuses to start on a mismatch).
    let device = Device::new().unwrap();
    let version = device.library_version();
    assert_eq!(format!("Embree {version}"), photondiff::embree::BACKEND);
    assert!(
        version.starts_with(&format!("{}.", photondiff::embree::API_VERSION)),
        "{version}"
    );
}

#[cfg(target_os = "linux")]
#[test]
fn exactly_one_embree_library_is_loaded() {
    // Embree 3 and 4 export the same C symbols: a binary must never load both.
    let _device = Device::new().unwrap();
    let maps = std::fs::read_to_string("/proc/self/maps").unwrap();
    let mut embrees: Vec<&str> = maps
        .lines()
        .filter_map(|line| line.split('/').next_back())
        .filter(|file| file.starts_with("libembree"))
        .collect();
    embrees.sort_unstable();
    embrees.dedup();
    let expected = format!("libembree{}", photondiff::embree::API_VERSION);
    assert_eq!(embrees.len(), 1, "{embrees:?}");
    assert!(embrees[0].starts_with(&expected), "{embrees:?}");
}

#[test]
fn geometry_bounds_hold_every_vertex_and_find_flat_geometries() {
    use glam::{DAffine3, DQuat};
    use std::sync::Arc;
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device);
    let square = Arc::new(shapes::quad(
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 2.0, 0.0),
    ));
    let ball = Arc::new(shapes::sphere(DVec3::new(0.0, 0.0, 3.0), 1.0, 64));
    builder.add_mesh(square.clone()).unwrap();
    builder.add_mesh(ball.clone()).unwrap();
    // Both again through a rotation, a non-uniform scale and a translation.
    let placed = DAffine3::from_scale_rotation_translation(
        DVec3::new(2.0, 0.5, 1.5),
        DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1),
        DVec3::new(4.0, -2.0, 1.0),
    );
    builder.add_instance(&square, placed).unwrap();
    builder.add_instance(&ball, placed).unwrap();
    let scene = builder.commit().unwrap();
    let bounds = scene.geometry_bounds();
    assert_eq!(bounds.len(), 4);
    let wide = |v: &[f32; 3]| DVec3::new(v[0].into(), v[1].into(), v[2].into());
    let meshes = [
        (&square, None),
        (&ball, None),
        (&square, Some(placed)),
        (&ball, Some(placed)),
    ];
    for (k, ((mesh, to_world), b)) in meshes.iter().zip(&bounds).enumerate() {
        let world: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|v| to_world.map_or(wide(v), |t| t.transform_point3(wide(v))))
            .collect();
        let farthest = world
            .iter()
            .map(|v| v.distance(b.center))
            .fold(0.0, f64::max);
        assert!(
            farthest <= b.radius,
            "geometry {k}: a vertex at {farthest} > {}",
            b.radius
        );
        match b.plane_normal {
            Some(n) => {
                assert!(k % 2 == 0, "geometry {k}: a sphere is not flat");
                assert!((n.length() - 1.0).abs() < 1e-12);
                for v in &world {
                    assert!(
                        n.dot(*v - world[0]).abs() < 1e-5,
                        "geometry {k}: off its plane"
                    );
                }
            }
            None => assert!(k % 2 == 1, "geometry {k}: the square is flat"),
        }
    }
    // Directly placed, the bounds are tight: the square's half diagonal, the sphere's radius.
    assert!((bounds[0].radius - 2f64.sqrt()).abs() < 1e-6);
    assert!((bounds[0].plane_normal.unwrap().z.abs() - 1.0).abs() < 1e-12);
    assert!(bounds[1].center.distance(DVec3::new(0.0, 0.0, 3.0)) < 1e-6);
    assert!((bounds[1].radius - 1.0).abs() < 1e-6);
}

#[test]
fn the_build_reports_its_progress_in_equal_shares_per_bvh() {
    let device = Device::new().unwrap();
    let seen = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let log = seen.clone();
    let mut builder = SceneBuilder::new(&device).progress(move |f| log.lock().unwrap().push(f));
    // Two instanced meshes (each placed twice) and a mesh of the scene's own: three builds.
    let ball = std::sync::Arc::new(shapes::sphere(DVec3::ZERO, 1.0, 512));
    let small = std::sync::Arc::new(shapes::sphere(DVec3::ZERO, 1.0, 16));
    for (mesh, x) in [(&ball, 0.0), (&ball, 3.0), (&small, 6.0), (&small, 9.0)] {
        let to_world = glam::DAffine3::from_translation(DVec3::new(x, 0.0, 0.0));
        builder.add_instance(mesh, to_world).unwrap();
    }
    builder
        .add_mesh(shapes::sphere(DVec3::new(0.0, 5.0, 0.0), 1.0, 256))
        .unwrap();
    let scene = builder.commit().unwrap();
    assert!(scene
        .intersect(&Ray::new(DVec3::new(3.0, 0.0, -5.0), DVec3::Z))
        .is_some());
    let seen = seen.lock().unwrap();
    assert!(seen.iter().all(|f| (0.0..=1.0).contains(f)), "{seen:?}");
    // Each build ends on its share: a third, two thirds, the whole.
    for end in [1.0 / 3.0, 2.0 / 3.0, 1.0] {
        assert!(
            seen.iter().any(|f| (f - end).abs() < 1e-12),
            "{end} in {seen:?}"
        );
    }
    assert_eq!(seen.last(), Some(&1.0));
    // The 262,144-triangle ball's build reports its way through the first third, not only its end.
    assert!(seen.iter().any(|&f| f > 0.0 && f < 1.0 / 3.0), "{seen:?}");
}
