//! Ray differential transfer, reflection and refraction against central finite differences of
//! traced rays: on an exact sphere in double precision, and through Embree on a tessellated
//! glass sphere with interpolated normals (including total internal reflection).

use glam::DVec3;
use photondiff::embree::{Device, Ray, Scene, SceneBuilder};
use photondiff::geometry::differential::{RayDifferential, Refraction, SurfaceFrame};
use photondiff::scene::shapes;

/// A two-parameter family of rays: origin `p0 + u a + v b`, direction `normalize(d0 + u c + v e)`,
/// with its exact differentials at `(0, 0)`.
#[derive(Clone, Copy)]
struct Family {
    p0: DVec3,
    a: DVec3,
    b: DVec3,
    d0: DVec3,
    c: DVec3,
    e: DVec3,
}

impl Family {
    fn ray(&self, u: f64, v: f64) -> RayDifferential {
        let d = self.d0 + self.c * u + self.e * v;
        let len = d.length();
        let unit = d / len;
        let dd = |w: DVec3| (w - unit * unit.dot(w)) / len;
        RayDifferential {
            p: self.p0 + self.a * u + self.b * v,
            d: unit,
            dp: [self.a, self.b],
            dd: [dd(self.c), dd(self.e)],
        }
    }
}

/// Central finite differences of every stage of `trace` (positions and directions), compared with
/// the differentials `trace` propagated. `tol` is relative to the derivative's size.
fn check_against_finite_differences(
    family: &Family,
    h: f64,
    tol: f64,
    trace: impl Fn(RayDifferential) -> Vec<RayDifferential>,
) -> usize {
    let centre = trace(family.ray(0.0, 0.0));
    assert!(!centre.is_empty());
    for k in 0..2 {
        let (du, dv) = if k == 0 { (h, 0.0) } else { (0.0, h) };
        let plus = trace(family.ray(du, dv));
        let minus = trace(family.ray(-du, -dv));
        assert_eq!(plus.len(), centre.len(), "neighbours took another path");
        assert_eq!(minus.len(), centre.len(), "neighbours took another path");
        for (stage, ((c, p), m)) in centre.iter().zip(&plus).zip(&minus).enumerate() {
            let fd_p = (p.p - m.p) / (2.0 * h);
            let fd_d = (p.d - m.d) / (2.0 * h);
            let scale = fd_p.length().max(c.dp[k].length()).max(1e-3);
            assert!(
                (fd_p - c.dp[k]).length() <= tol * scale,
                "stage {stage} dP/d{k}: differential {:?}, finite difference {fd_p:?}",
                c.dp[k]
            );
            let scale = fd_d.length().max(c.dd[k].length()).max(1e-3);
            assert!(
                (fd_d - c.dd[k]).length() <= tol * scale,
                "stage {stage} dD/d{k}: differential {:?}, finite difference {fd_d:?}",
                c.dd[k]
            );
        }
    }
    centre.len()
}

const CENTRE: DVec3 = DVec3::new(0.0, 1.0, 0.0);
const IOR: f64 = 1.5;

/// Exact ray-sphere intersection (the far root when starting inside).
fn sphere_t(ray: &RayDifferential, radius: f64) -> Option<f64> {
    let oc = ray.p - CENTRE;
    let b = oc.dot(ray.d);
    let c = oc.dot(oc) - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let (t0, t1) = (-b - disc.sqrt(), -b + disc.sqrt());
    [t0, t1].into_iter().find(|&t| t > 1e-9)
}

/// The exact sphere's frame: `n = (x - c) / r`, `dn = dx / r`.
fn exact_frame(at: &RayDifferential, radius: f64) -> SurfaceFrame {
    SurfaceFrame {
        n: (at.p - CENTRE) / radius,
        dn: at.dp.map(|dp| dp / radius),
    }
}

/// Into the sphere, across it, and out (or reflected back in by total internal reflection).
fn through_exact_sphere(ray: RayDifferential, radius: f64, bounces: usize) -> Vec<RayDifferential> {
    let mut stages = Vec::new();
    let mut ray = ray;
    let mut inside = false;
    for _ in 0..bounces {
        let Some(t) = sphere_t(&ray, radius) else {
            break;
        };
        let frame = exact_frame(
            &ray.transfer(t, (ray.p + ray.d * t - CENTRE) / radius),
            radius,
        );
        let at = ray.transfer(t, frame.n);
        stages.push(at);
        let (n_from, n_to) = if inside { (IOR, 1.0) } else { (1.0, IOR) };
        ray = match at.refract(&frame, n_from, n_to) {
            Refraction::Transmitted(r) => {
                inside = !inside;
                r
            }
            Refraction::TotalInternalReflection(r) => r,
        };
        stages.push(ray);
    }
    stages
}

fn camera_like_family() -> Family {
    Family {
        p0: DVec3::new(0.3, 4.0, 5.0),
        a: DVec3::new(0.01, 0.0, 0.002),
        b: DVec3::new(0.0, 0.008, -0.001),
        d0: DVec3::new(-0.25, -3.1, -5.0),
        c: DVec3::new(0.004, 0.001, 0.0),
        e: DVec3::new(-0.001, 0.003, 0.002),
    }
}

#[test]
fn transfer_reflection_refraction_match_finite_differences_on_an_exact_sphere() {
    let family = camera_like_family();
    // Mirror: one reflection off the outside.
    let stages = check_against_finite_differences(&family, 1e-5, 1e-5, |ray| {
        let t = sphere_t(&ray, 1.0).unwrap();
        let frame = exact_frame(
            &ray.transfer(t, (ray.p + ray.d * t - CENTRE).normalize()),
            1.0,
        );
        let at = ray.transfer(t, frame.n);
        vec![at, at.reflect(&frame)]
    });
    assert_eq!(stages, 2);
    // Glass: in, across, out.
    let stages = check_against_finite_differences(&family, 1e-5, 1e-5, |ray| {
        through_exact_sphere(ray, 1.0, 2)
    });
    assert_eq!(stages, 4);
}

#[test]
fn total_internal_reflection_matches_finite_differences() {
    // A ray inside the glass meeting the surface beyond the critical angle (asin(1/1.5) = 41.8 deg).
    let family = Family {
        p0: CENTRE + DVec3::new(0.0, -0.9, 0.0),
        a: DVec3::new(0.01, 0.0, 0.0),
        b: DVec3::new(0.0, 0.0, 0.01),
        d0: DVec3::new(1.0, 0.05, 0.02),
        c: DVec3::new(0.0, 0.01, 0.0),
        e: DVec3::new(0.0, 0.0, 0.01),
    };
    let trace = |ray: RayDifferential| {
        let t = sphere_t(&ray, 1.0).unwrap();
        let frame = exact_frame(
            &ray.transfer(t, (ray.p + ray.d * t - CENTRE).normalize()),
            1.0,
        );
        let at = ray.transfer(t, frame.n);
        match at.refract(&frame, IOR, 1.0) {
            Refraction::TotalInternalReflection(r) => vec![at, r],
            Refraction::Transmitted(_) => panic!("expected total internal reflection"),
        }
    };
    check_against_finite_differences(&family, 1e-5, 1e-5, trace);
}

fn embree_sphere(segments: u32) -> Scene {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device);
    builder
        .add_mesh(shapes::sphere(CENTRE, 1.0, segments))
        .unwrap();
    builder.commit().unwrap()
}

/// Through Embree: transfer to each hit, refract with the interpolated normal and its
/// barycentric derivatives, follow total internal reflection, up to `bounces` surfaces.
fn through_tessellated_sphere(
    scene: &Scene,
    ray: RayDifferential,
    bounces: usize,
) -> Vec<RayDifferential> {
    let mut stages = Vec::new();
    let mut ray = ray;
    let mut inside = false;
    for _ in 0..bounces {
        // Start just past the surface the ray leaves.
        let Some(hit) = scene.intersect(&Ray {
            origin: ray.p,
            direction: ray.d,
            tnear: 1e-4,
            tfar: f64::INFINITY,
        }) else {
            break;
        };
        let at = ray.transfer((hit.position - ray.p).dot(ray.d), hit.geometric_normal);
        let frame = SurfaceFrame {
            n: hit.shading_normal,
            dn: at.dp.map(|dp| hit.normal_differential(dp)),
        };
        stages.push(at);
        let (n_from, n_to) = if inside { (IOR, 1.0) } else { (1.0, IOR) };
        ray = match at.refract(&frame, n_from, n_to) {
            Refraction::Transmitted(r) => {
                inside = !inside;
                r
            }
            Refraction::TotalInternalReflection(r) => r,
        };
        stages.push(ray);
    }
    stages
}

#[test]
fn refraction_through_embree_with_interpolated_normals_matches_finite_differences() {
    // A coarse tessellation, so that interpolated normals differ clearly from facet normals:
    // the differentials must follow the interpolated (curved) normals.
    let scene = embree_sphere(48);
    let family = camera_like_family();
    // The Embree layer refines hits in double precision, so a small step keeps every
    // neighbouring ray on the same triangles and the agreement is tight.
    let stages = check_against_finite_differences(&family, 1e-5, 1e-4, |ray| {
        through_tessellated_sphere(&scene, ray, 2)
    });
    assert_eq!(stages, 4);

    // Flat-facet differentials (dn = 0) would be far off: the curvature matters.
    let centre = through_tessellated_sphere(&scene, family.ray(0.0, 0.0), 1);
    let plus = through_tessellated_sphere(&scene, family.ray(2e-3, 0.0), 1);
    let minus = through_tessellated_sphere(&scene, family.ray(-2e-3, 0.0), 1);
    let fd = (plus[1].d - minus[1].d) / 4e-3;
    let at = centre[0];
    let hit_n = (at.p - CENTRE).normalize();
    let flat = at.refract(
        &SurfaceFrame {
            n: hit_n,
            dn: [DVec3::ZERO; 2],
        },
        1.0,
        IOR,
    );
    let Refraction::Transmitted(flat) = flat else {
        panic!()
    };
    assert!((flat.dd[0] - fd).length() > 0.3 * fd.length());
}

#[test]
fn total_internal_reflection_through_embree_matches_finite_differences() {
    let scene = embree_sphere(48);
    // Starts inside, hits the wall beyond the critical angle.
    let family = Family {
        p0: CENTRE + DVec3::new(0.0, -0.9, 0.05),
        a: DVec3::new(0.01, 0.0, 0.0),
        b: DVec3::new(0.0, 0.0, 0.01),
        d0: DVec3::new(1.0, 0.05, 0.02),
        c: DVec3::new(0.0, 0.01, 0.0),
        e: DVec3::new(0.0, 0.0, 0.01),
    };
    let trace = |ray: RayDifferential| {
        let hit = scene.intersect(&Ray::new(ray.p, ray.d)).unwrap();
        let at = ray.transfer((hit.position - ray.p).dot(ray.d), hit.geometric_normal);
        let frame = SurfaceFrame {
            n: hit.shading_normal,
            dn: at.dp.map(|dp| hit.normal_differential(dp)),
        };
        match at.refract(&frame, IOR, 1.0) {
            Refraction::TotalInternalReflection(r) => vec![at, r],
            Refraction::Transmitted(_) => panic!("expected total internal reflection"),
        }
    };
    check_against_finite_differences(&family, 1e-5, 1e-4, trace);
}

/// A sphere mesh of radius 1 at the origin, placed by `to_world` as an Embree instance.
fn instanced_ellipsoid(to_world: glam::DAffine3) -> Scene {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device);
    let mesh = std::sync::Arc::new(shapes::sphere(DVec3::ZERO, 1.0, 48));
    builder.add_instance(&mesh, to_world).unwrap();
    builder.commit().unwrap()
}

/// Rotation, non-uniform scale and translation: an ellipsoid around `CENTRE`.
fn ellipsoid_transform() -> glam::DAffine3 {
    glam::DAffine3::from_translation(CENTRE)
        * glam::DAffine3::from_quat(glam::DQuat::from_euler(glam::EulerRot::ZYX, 0.4, -0.7, 0.3))
        * glam::DAffine3::from_scale(DVec3::new(1.3, 0.7, 1.0))
}

#[test]
fn refraction_through_an_instance_with_non_uniform_scale_matches_finite_differences() {
    // Normals through a non-uniform scale transform by the inverse transpose; positions and
    // their derivatives by the matrix. Differentials built from the instance's hits must match
    // finite differences of traced rays through both surfaces of the ellipsoid.
    let scene = instanced_ellipsoid(ellipsoid_transform());
    let stages = check_against_finite_differences(&camera_like_family(), 1e-5, 1e-4, |ray| {
        through_tessellated_sphere(&scene, ray, 2)
    });
    assert_eq!(stages, 4);
}

#[test]
fn an_instance_hits_as_the_same_mesh_transformed_into_world_space() {
    let to_world = ellipsoid_transform();
    let instanced = instanced_ellipsoid(to_world);
    // The same ellipsoid baked: vertices transformed, normals by the inverse transpose (left
    // unnormalised: the hit normalises after interpolating, so both describe one normal field).
    let mut baked = shapes::sphere(DVec3::ZERO, 1.0, 48);
    let normal_matrix = to_world.matrix3.inverse().transpose();
    for p in &mut baked.positions {
        let w = to_world.transform_point3(DVec3::from(p.map(f64::from)));
        *p = [w.x as f32, w.y as f32, w.z as f32];
    }
    for n in baked.normals.as_mut().unwrap() {
        let w = normal_matrix * DVec3::from(n.map(f64::from));
        *n = [w.x as f32, w.y as f32, w.z as f32];
    }
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device);
    builder.add_mesh(baked).unwrap();
    let baked = builder.commit().unwrap();
    let family = camera_like_family();
    let mut compared = 0;
    for i in -5..=5 {
        for j in -5..=5 {
            let r = family.ray(i as f64 * 3.0, j as f64 * 3.0);
            let ray = Ray {
                origin: r.p,
                direction: r.d,
                tnear: 0.0,
                tfar: f64::INFINITY,
            };
            let (Some(a), Some(b)) = (instanced.intersect(&ray), baked.intersect(&ray)) else {
                assert_eq!(
                    instanced.intersect(&ray).is_some(),
                    baked.intersect(&ray).is_some()
                );
                continue;
            };
            compared += 1;
            assert_eq!(a.prim_id, b.prim_id);
            assert_eq!(a.geom_id, 0);
            // The baked mesh's f32 vertices round differently: agreement to ~1e-6.
            for (x, y, what) in [
                (a.position, b.position, "position"),
                (a.geometric_normal, b.geometric_normal, "geometric normal"),
                (a.shading_normal, b.shading_normal, "shading normal"),
                (a.dp_du, b.dp_du, "dP/du"),
                (a.dp_dv, b.dp_dv, "dP/dv"),
                (a.dn_du, b.dn_du, "dN/du"),
                (a.dn_dv, b.dn_dv, "dN/dv"),
            ] {
                assert!((x - y).length() < 1e-5, "{what}: {x} vs {y}");
            }
        }
    }
    assert!(compared > 30, "only {compared} rays hit");
}
