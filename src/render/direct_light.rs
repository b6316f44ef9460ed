//! Direct light at diffuse hits: shadow rays to point and spot lights, stratified samples on
//! quad area lights, traced as 16-wide packets.

use crate::embree::{self, Ray, PACKET_WIDTH};
use crate::geometry::surface::facing;
use crate::render::camera_path::DiffuseVertex;
use crate::scene::{Light, Scene};
use crate::util::rng::Rng;
use glam::DVec3;
use std::f64::consts::FRAC_1_PI;

/// A shadow ray and what it carries if unblocked.
#[derive(Debug, Clone, Copy)]
struct ShadowQuery {
    ray: Ray,
    contribution: DVec3,
    sample: usize,
}

/// Computes direct light for batches of diffuse vertices.
pub struct DirectLight<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Samples per quad light per vertex, in a `strata x strata` grid.
    pub area_strata: u32,
    /// Offset of shadow ray origins off the surface.
    pub epsilon: f64,
}

impl DirectLight<'_> {
    /// Adds the direct light reflected towards the camera at each vertex into
    /// `radiance[vertex.sample]`; returns the number of shadow rays traced. `rng` draws the
    /// positions within the area-light strata.
    pub fn add(&self, vertices: &[DiffuseVertex], rng: &mut Rng, radiance: &mut [DVec3]) -> u64 {
        let mut queries = Vec::with_capacity(vertices.len() * self.scene.lights.len());
        for v in vertices {
            self.queries(v, rng, &mut queries);
        }
        let mut blocked = [false; PACKET_WIDTH];
        let mut rays = [Ray::new(DVec3::ZERO, DVec3::X); PACKET_WIDTH];
        for chunk in queries.chunks(PACKET_WIDTH) {
            for (ray, q) in rays.iter_mut().zip(chunk) {
                *ray = q.ray;
            }
            self.embree
                .occluded16(&rays[..chunk.len()], true, &mut blocked);
            for (q, &b) in chunk.iter().zip(&blocked) {
                if !b {
                    radiance[q.sample] += q.contribution;
                }
            }
        }
        queries.len() as u64
    }

    fn queries(&self, v: &DiffuseVertex, rng: &mut Rng, out: &mut Vec<ShadowQuery>) {
        let d = v.ray.d;
        let ng = facing(v.hit.geometric_normal, d);
        let ns = if v.hit.shading_normal.dot(ng) > 0.0 {
            v.hit.shading_normal
        } else {
            -v.hit.shading_normal
        };
        let origin = v.hit.position + ng * self.epsilon;
        let brdf = v.weight * v.albedo * FRAC_1_PI;
        let mut push = |target: DVec3, radiance_factor: DVec3, tfar_scale: f64| {
            let to = target - origin;
            let dist = to.length();
            let w = to / dist;
            let cos = ns.dot(w);
            if cos <= 0.0 || ng.dot(w) <= 0.0 || dist.is_nan() || dist <= 0.0 {
                return;
            }
            out.push(ShadowQuery {
                ray: Ray::segment(origin, w, dist * tfar_scale),
                contribution: brdf * radiance_factor * (cos / (dist * dist)),
                sample: v.sample,
            });
        };
        for light in &self.scene.lights {
            match *light {
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    let w = (origin - position).normalize_or_zero();
                    let intensity = light.intensity_towards(w);
                    if intensity != DVec3::ZERO {
                        push(position, intensity, 1.0);
                    }
                }
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                } => {
                    let cross = edge_u.cross(edge_v);
                    let area = cross.length();
                    let normal = cross / area;
                    let s = self.area_strata.max(1);
                    let per_sample = area / (s * s) as f64;
                    for i in 0..s {
                        for j in 0..s {
                            let a = (i as f64 + rng.uniform()) / s as f64;
                            let b = (j as f64 + rng.uniform()) / s as f64;
                            let y = corner + edge_u * a + edge_v * b;
                            let cos_light = (origin - y).normalize_or_zero().dot(normal);
                            if cos_light > 0.0 {
                                // Stop short of the light's own quad.
                                push(y, radiance * (cos_light * per_sample), 1.0 - 1e-4);
                            }
                        }
                    }
                }
            }
        }
    }
}
