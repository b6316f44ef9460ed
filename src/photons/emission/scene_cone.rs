//! Global photons only where they can land: a point light outside the scene's bounding box
//! sends most of its light past the scene (the canonical scene's light, above a floor 12
//! units across, about two thirds of it), and every such emission was drawn, traced to a miss
//! and counted. Drawn from the narrowest cone that holds the box instead, and carrying the
//! power of that cone alone, the emissions stand for the same light on everything the light
//! can reach: directions outside the cone meet nothing.
//!
//! The tracer's cap on a map's emissions ([`crate::photons::trace::emission_cap`]) shrinks by
//! the same share ([`super::Emitter::share`]), so that a pass draws as many emissions that
//! can reach the scene as before, and stores as many photons, without the ones that could
//! not.

use super::{light_cone, light_power, mean};
use crate::geometry::sampling::Cone;
use crate::scene::{Light, Scene};
use glam::DVec3;

/// Each of `scene`'s lights' cone for global photons, and the power (mean over channels, W)
/// it sends into it: a point light's narrowed to [`scene_cone`] where that is narrower than a
/// hemisphere; a spot's own cone and a quad light's hemisphere (no cone) as they are.
pub fn global_cones(scene: &Scene) -> Vec<(Option<Cone>, f64)> {
    let bounds = scene.bounds();
    scene
        .lights
        .iter()
        .map(|light| match (*light, bounds) {
            (
                Light::Point {
                    position,
                    intensity,
                },
                Some(b),
            ) => match scene_cone(position, b) {
                Some(c) => (Some(c), c.solid_angle() * mean(intensity)),
                None => (light_cone(light, None), light_power(light)),
            },
            _ => (light_cone(light, None), light_power(light)),
        })
        .collect()
}

/// The narrowest of a few cones from `position` that holds the box `[lo, hi]` (every ray from
/// `position` that meets the box lies in it), or `None` where none of them is narrower than a
/// hemisphere (`position` inside the box, or beside it). The candidate axes: the mean of the
/// directions to the box's corners, the direction to its centre, and each coordinate axis
/// along which `position` lies outside the box, towards it. A cone of half-angle below 90
/// degrees is convex, so holding the box's eight corners it holds the box.
pub fn scene_cone(position: DVec3, [lo, hi]: [DVec3; 2]) -> Option<Cone> {
    let corners: [DVec3; 8] = std::array::from_fn(|i| {
        let pick = |axis: usize| {
            if (i >> axis) & 1 == 0 {
                lo[axis]
            } else {
                hi[axis]
            }
        };
        (DVec3::new(pick(0), pick(1), pick(2)) - position).normalize_or_zero()
    });
    if corners.iter().any(|c| *c == DVec3::ZERO || !c.is_finite()) {
        return None;
    }
    let mut axes = vec![
        corners.iter().copied().sum::<DVec3>().normalize_or_zero(),
        ((lo + hi) * 0.5 - position).normalize_or_zero(),
    ];
    for axis in 0..3 {
        let mut towards = DVec3::ZERO;
        if position[axis] > hi[axis] {
            towards[axis] = -1.0;
        } else if position[axis] < lo[axis] {
            towards[axis] = 1.0;
        }
        axes.push(towards);
    }
    let (axis, cos_max) = axes
        .into_iter()
        .filter(|a| *a != DVec3::ZERO)
        .map(|a| (a, corners.iter().map(|c| c.dot(a)).fold(1.0, f64::min)))
        .max_by(|x, y| x.1.total_cmp(&y.1))?;
    // A little wider than the corners: their directions are rounded, and a cone drawn from
    // must not lose a sliver of the box.
    let cos_max = cos_max - 1e-9;
    (cos_max > 1e-3).then(|| Cone::new(axis, cos_max))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> [DVec3; 2] {
        [DVec3::splat(-1.0), DVec3::splat(1.0)]
    }

    #[test]
    fn the_cone_holds_every_point_of_the_box() {
        let mut rng = crate::util::rng::Rng::new(7, 0);
        for position in [
            DVec3::new(0.0, 5.0, 0.0),
            DVec3::new(-4.0, 4.0, -1.0),
            DVec3::new(3.0, 1.5, 0.2),
            DVec3::new(10.0, -20.0, 30.0),
        ] {
            let cone = scene_cone(position, unit_box()).expect("outside the box: a cone");
            for _ in 0..20_000 {
                let p = DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0;
                let d = (p - position).normalize();
                assert!(d.dot(cone.axis) >= cone.cos_max, "{position} {p}");
            }
        }
    }

    #[test]
    fn straight_above_a_square_the_cone_reaches_its_corners() {
        // Height 4 above the middle of a square of half-side 6 (a slab 1e-6 thick): the cone
        // points down, out to the corners, cos = 4 / sqrt(16 + 72).
        let b = [DVec3::new(-6.0, 0.0, -6.0), DVec3::new(6.0, 1e-6, 6.0)];
        let cone = scene_cone(DVec3::new(0.0, 4.0, 0.0), b).unwrap();
        assert!((cone.axis - DVec3::NEG_Y).length() < 1e-12, "{}", cone.axis);
        let exact = 4.0 / 88f64.sqrt();
        assert!(
            (cone.cos_max - exact).abs() < 1e-6,
            "{} {exact}",
            cone.cos_max
        );
    }

    #[test]
    fn inside_or_beside_the_box_there_is_no_cone() {
        assert!(scene_cone(DVec3::ZERO, unit_box()).is_none());
        assert!(scene_cone(DVec3::new(0.5, 0.9, -0.9), unit_box()).is_none());
        // Just outside a face: the box fills almost a hemisphere.
        assert!(scene_cone(DVec3::new(0.0, 1.0 + 1e-9, 0.0), unit_box()).is_none());
        // On a corner.
        assert!(scene_cone(DVec3::ONE, unit_box()).is_none());
    }
}
