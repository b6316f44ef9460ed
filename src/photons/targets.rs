//! The bounding spheres of the specular (mirror and glass) meshes: caustic photons are aimed at
//! them when they leave the lights ([`crate::photons::emission`]), and global photons may be
//! aimed at them when they leave a diffuse surface ([`DiffuseAim`]).

use crate::geometry::sampling::{sample_cone, sample_cosine};
use crate::scene::Scene;
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, PI};

/// A bounding sphere of a specular mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
}

/// The cone from `from` around a target: its axis and the cosine of its half-angle (-1, every
/// direction, from inside the sphere).
pub fn cone(from: DVec3, target: &Target) -> (DVec3, f64) {
    let to = target.center - from;
    let d = to.length();
    if d <= target.radius * (1.0 + 1e-9) {
        return (DVec3::Y, -1.0); // inside the sphere: every direction
    }
    let sin = target.radius / d;
    (to / d, (1.0 - sin * sin).sqrt())
}

/// Solid angle of a cone of half-angle cosine `cos_max`.
pub fn cone_solid_angle(cos_max: f64) -> f64 {
    2.0 * PI * (1.0 - cos_max)
}

/// The bounding sphere of every specular mesh of `scene`, in the scene's mesh order (beyond
/// [`MAX_TARGETS`] of them, spheres around groups of them, `grouped`). An instance's sphere
/// is its mesh's sphere, moved and grown by the transform's largest stretch; each mesh's
/// positions are read once.
pub fn specular_targets(scene: &Scene) -> Vec<Target> {
    let mut local: Vec<(&std::sync::Arc<crate::embree::TriangleMesh>, Target)> = Vec::new();
    let mut targets: Vec<Target> = Vec::new();
    for m in scene.meshes.iter().filter(|m| m.material.is_specular()) {
        let sphere = match local
            .iter()
            .find(|(u, _)| std::sync::Arc::ptr_eq(u, &m.mesh))
        {
            Some((_, t)) => *t,
            None => {
                let t = bounding_sphere(&m.mesh.positions);
                local.push((&m.mesh, t));
                t
            }
        };
        targets.push(match m.transform {
            None => sphere,
            Some(to_world) => Target {
                center: to_world.transform_point3(sphere.center),
                radius: sphere.radius * largest_stretch(to_world.matrix3),
            },
        });
    }
    grouped(targets, MAX_TARGETS)
}

/// The most targets aimed at: beyond it, nearby targets are aimed at together, through the
/// sphere around them. A target costs every aimed emission and bounce a cone test: 20,000
/// instanced glass cubes took 18.1 s to trace their photons, 1.3-1.4 s grouped into 128
/// spheres (alternated in one run; the image within the noise between two seeds). 128 keeps
/// the production scene's 100 instances each its own target.
pub const MAX_TARGETS: usize = 128;

/// `targets`, or when there are more than `max`, `max` spheres around groups of them: the
/// group with the most targets is split at the median of its centres along their widest
/// axis until there are `max` groups. Every target lies inside its group's sphere, so aiming
/// at the groups reaches all that aiming at the targets did (the emitted power follows the
/// density drawn with, so the maps stand for the same light; more photons miss).
fn grouped(targets: Vec<Target>, max: usize) -> Vec<Target> {
    if targets.len() <= max {
        return targets;
    }
    let mut groups = vec![targets];
    while groups.len() < max {
        let (k, _) = groups
            .iter()
            .enumerate()
            .max_by_key(|(_, g)| g.len())
            .expect("a group");
        let mut group = groups.swap_remove(k);
        let (lo, hi) = group.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), t| (lo.min(t.center), hi.max(t.center)),
        );
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        group.sort_by(|a, b| a.center[axis].total_cmp(&b.center[axis]));
        let right = group.split_off(group.len() / 2);
        groups.push(group);
        groups.push(right);
    }
    groups.iter().map(|g| around(g)).collect()
}

/// The sphere around `targets` (about their boxes' centre), a hair larger.
fn around(targets: &[Target]) -> Target {
    let (lo, hi) = targets.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), t| (lo.min(t.center - t.radius), hi.max(t.center + t.radius)),
    );
    let center = (lo + hi) * 0.5;
    let radius = targets
        .iter()
        .map(|t| (t.center - center).length() + t.radius)
        .fold(0.0, f64::max);
    Target {
        center,
        radius: radius * (1.0 + 1e-9),
    }
}

/// The largest factor by which `l` stretches a vector (its largest singular value), from a
/// power iteration on `l^T l` started along every axis, a hair larger for safety.
fn largest_stretch(l: glam::DMat3) -> f64 {
    let gram = l.transpose() * l;
    let mut best: f64 = 0.0;
    for start in [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE] {
        let mut v = start.normalize();
        for _ in 0..64 {
            let w = gram * v;
            let n = w.length();
            if n == 0.0 {
                break;
            }
            v = w / n;
        }
        best = best.max((l * v).length());
    }
    best * (1.0 + 1e-6)
}

fn bounding_sphere(positions: &[[f32; 3]]) -> Target {
    let points = positions.iter().map(|p| DVec3::from(p.map(f64::from)));
    let (lo, hi) = points.clone().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    );
    let center = (lo + hi) * 0.5;
    let radius = points.map(|p| (p - center).length()).fold(0.0, f64::max);
    // A hair larger, so that rays grazing the tessellated surface are inside the cone: by a
    // part of its size and of its place's, as the positions' rounding is. (It was 1e-9 more
    // whatever the size: a sphere 1e-9 across was aimed at as twice its size, and most aimed
    // global photons missed it.)
    let size = radius.max(center.abs().max_element());
    Target {
        center,
        radius: radius * (1.0 + 1e-6) + 1e-9 * size,
    }
}

/// Diffuse bounces of global photons drawn from a mixture: with probability `probability` a
/// direction uniform in the cone towards one of the targets (each equally likely), else the
/// cosine lobe; the photon's power is multiplied by `(cos / pi) / pdf`, the ratio of the cosine
/// density it stands for to the mixture's density, so the map's expected value is unchanged.
///
/// Why: in an open scene light that leaves the floor reaches the glass or mirror object only
/// through the small solid angle it subtends, and the light it sends on (floor -> sphere ->
/// floor, the light in the sphere's shadow) was carried by a few hundred photons of a
/// hundred thousand emissions; aimed bounces carry it with tens of thousands.
#[derive(Debug, Clone, PartialEq)]
pub struct DiffuseAim {
    targets: Vec<Target>,
    probability: f64,
}

/// A diffuse bounce drawn by [`DiffuseAim::sample`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AimedBounce {
    /// The new direction (unit, above the surface).
    pub direction: DVec3,
    /// `(cos / pi) / pdf`: what the photon's power is multiplied by (besides the albedo).
    pub weight: f64,
    /// The mixture's density of `direction` (per steradian).
    pub pdf: f64,
}

impl DiffuseAim {
    /// Aims a share `probability` (in `[0, 1)`) of the bounces at `targets`; `None` when there
    /// is nothing to aim at or nothing to aim.
    pub fn new(targets: Vec<Target>, probability: f64) -> Option<Self> {
        (!targets.is_empty() && probability > 0.0 && probability < 1.0).then_some(DiffuseAim {
            targets,
            probability,
        })
    }

    /// A bounce from `x` with unit normal `n` (the side the photon leaves on) from three
    /// uniform numbers; `None` when the direction falls below the surface (the photon is
    /// absorbed: the cosine density it stands for is zero there).
    pub fn sample(&self, x: DVec3, n: DVec3, u: [f64; 3]) -> Option<AimedBounce> {
        let q = self.probability;
        let direction = if u[0] < q {
            let count = self.targets.len();
            let k = ((u[0] / q * count as f64) as usize).min(count - 1);
            let (axis, cos_max) = cone(x, &self.targets[k]);
            sample_cone(axis, cos_max, u[1], u[2])
        } else {
            sample_cosine(n, u[1], u[2])
        };
        let cos = direction.dot(n);
        if cos <= 0.0 {
            return None;
        }
        let pdf = self.pdf(x, n, direction);
        Some(AimedBounce {
            direction,
            weight: cos * FRAC_1_PI / pdf,
            pdf,
        })
    }

    /// The mixture's density of direction `d` (unit) leaving `x` with normal `n`.
    pub fn pdf(&self, x: DVec3, n: DVec3, d: DVec3) -> f64 {
        let q = self.probability;
        let cosine = (1.0 - q) * d.dot(n).max(0.0) * FRAC_1_PI;
        let per_target = q / self.targets.len() as f64;
        let aimed: f64 = self
            .targets
            .iter()
            .map(|t| {
                let (axis, cos_max) = cone(x, t);
                if d.dot(axis) >= cos_max {
                    per_target / cone_solid_angle(cos_max)
                } else {
                    0.0
                }
            })
            .sum();
        cosine + aimed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::sampling::r2;

    #[test]
    fn the_largest_stretch_is_the_largest_singular_value() {
        use glam::{DMat3, DQuat};
        let r = DMat3::from_quat(DQuat::from_euler(glam::EulerRot::ZYX, 0.3, -1.1, 0.7));
        let l = r * DMat3::from_diagonal(DVec3::new(0.5, 3.0, -2.0));
        assert!((largest_stretch(l) - 3.0).abs() < 1e-5);
        assert!((largest_stretch(r) - 1.0).abs() < 1e-5);
        // Never less than what any vector is stretched by.
        for i in 0..100 {
            let (u, v) = r2(i, [0.1, 0.2]);
            let d = DVec3::new(u - 0.5, v - 0.5, 0.3).normalize();
            assert!((l * d).length() <= largest_stretch(l));
        }
    }

    /// The weights' mean over many bounces estimates the integral of `cos / pi` over the
    /// hemisphere (1), and of `cos / pi` over the cone towards a target (its analytic
    /// cosine-weighted solid angle), so aimed bounces carry exactly the light cosine bounces do.
    #[test]
    fn aimed_bounces_carry_what_cosine_bounces_carry() {
        let x = DVec3::ZERO;
        let n = DVec3::Y;
        // A sphere straight above: the cone of half-angle theta around the normal holds
        // sin^2(theta) of the cosine-weighted hemisphere.
        let target = Target {
            center: DVec3::new(0.0, 4.0, 0.0),
            radius: 1.0,
        };
        // And one half below the horizon, whose cone the surface cuts.
        let low = Target {
            center: DVec3::new(3.0, 0.5, 0.0),
            radius: 1.0,
        };
        let aim = DiffuseAim::new(vec![target, low], 0.5).expect("aims");
        let count = 400_000;
        let (mut all, mut inside) = (0.0, 0.0);
        let mut rng = crate::util::rng::Rng::new(7, 0);
        for _ in 0..count {
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            if let Some(b) = aim.sample(x, n, u) {
                assert!(b.direction.dot(n) > 0.0 && b.weight > 0.0);
                assert!((b.pdf - aim.pdf(x, n, b.direction)).abs() <= 1e-12 * b.pdf);
                all += b.weight;
                if b.direction.dot(DVec3::Y) >= cone(x, &target).1 {
                    inside += b.weight;
                }
            }
        }
        let (all, inside) = (all / count as f64, inside / count as f64);
        let sin2 = 1.0 / 16.0;
        assert!((all - 1.0).abs() < 0.01, "{all}");
        assert!(
            (inside - sin2).abs() < 0.01 * sin2,
            "{inside} against {sin2}"
        );
    }

    /// Beyond `MAX_TARGETS`, groups: that many spheres, each target inside one of them, and
    /// a few targets kept as they are.
    #[test]
    fn many_targets_are_aimed_at_in_groups_that_hold_them() {
        let mut rng = crate::util::rng::Rng::new(3, 0);
        let targets: Vec<Target> = (0..1000)
            .map(|_| Target {
                center: DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0,
                radius: 0.01 + 0.1 * rng.uniform(),
            })
            .collect();
        let groups = grouped(targets.clone(), MAX_TARGETS);
        assert_eq!(groups.len(), MAX_TARGETS);
        for t in &targets {
            assert!(groups
                .iter()
                .any(|g| (t.center - g.center).length() + t.radius <= g.radius));
        }
        // Grouped, not one sphere round them all: each group is far smaller than the whole.
        let whole = around(&targets);
        assert!(groups.iter().all(|g| g.radius < whole.radius / 2.0));
        assert_eq!(
            grouped(targets[..64].to_vec(), MAX_TARGETS),
            targets[..64].to_vec()
        );
    }

    #[test]
    fn nothing_to_aim_at_is_no_aim() {
        assert!(DiffuseAim::new(Vec::new(), 0.5).is_none());
        let t = Target {
            center: DVec3::Y,
            radius: 0.5,
        };
        assert!(DiffuseAim::new(vec![t], 0.0).is_none());
        assert!(DiffuseAim::new(vec![t], 1.0).is_none());
    }
}
