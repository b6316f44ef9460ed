//! Photon emission from point, spot and quad lights, with the emission differentials of
//! photon differentials (Schjoth et al. 2007).
//!
//! Footprint convention (see [`crate::photons::footprint`]): differentials are *radius* vectors. A light
//! emitting `N` photons into solid angle `Omega` gives each a beam whose elliptical cross-section
//! covers `overlap * Omega / N` steradians: `|dD/du| = |dD/dv| = sqrt(overlap Omega / (pi N))`,
//! orthogonal to the direction, `dP = 0`. A quad light of area `A` gives each photon a disc of
//! area `overlap * A / N` along the light's edges and a round beam over the directions it
//! samples (the hemisphere, `2 pi`, as light leaving a diffuse surface; a caustic photon its
//! target's cone seen from the light's centre): a photon stands for a share of the light's
//! directions as well as of its area, and a parallel beam (`dD = 0`) is focused by a glass
//! sphere to a footprint a hundredth of a point light's, fireflies in the photon-differential
//! estimates. `overlap` is the number of
//! footprints expected to cover a point (1 tiles the surface exactly; more trades blur for
//! noise, as `k` does in the regular estimate).
//!
//! Global photons sample every light in proportion to the power it sends towards the scene, a
//! point light's only in the cone that holds the scene ([`scene_cone`]; [`Emitter::global_aimed`]
//! sends a share of a point or spot light's towards the specular objects, weighted by the
//! mixture's density). Caustic photons are aimed at
//! the bounding spheres of the specular meshes (a projection map): each light-sphere pair gets a
//! share of the photons proportional to the power the light sends into the sphere's cone, and
//! each photon's power is divided by the density it was drawn with, so that photons stand for
//! exactly the emission they sample.

use crate::geometry::differential::RayDifferential;
use crate::geometry::sampling::{r2, sample_cone, sample_cosine, tangent_frame, Cone};
use crate::photons::targets::{cone, cone_solid_angle, specular_targets, Target};
use crate::scene::{Light, Scene};
use crate::util::rng::Rng;
use glam::DVec3;
use std::f64::consts::PI;

pub mod batch;
pub mod scene_cone;

/// One emitted photon before it is traced: its ray differential and its power as if it were
/// the only photon emitted (the tracer divides by the number of emissions).
#[derive(Debug, Clone, Copy)]
pub struct Emission {
    /// Origin, direction and emission differentials.
    pub ray: RayDifferential,
    /// Power for a single emission (W, RGB).
    pub power: DVec3,
}

/// An emission as the photon tracer starts it: its round beam (direction differentials
/// `spread` times [`tangent_frame`] of the direction) is left for
/// [`Launch::complete`], or for the path's first hit, to spell out. Most global photons leave
/// the scene without meeting anything and never need it, and the tangent frame (a division and
/// a square root on the emission's dependency chain) was about 5% of the global map's tracing
/// time on the canonical scene.
#[derive(Debug, Clone, Copy)]
pub struct Launch {
    /// The emission; its direction differentials are zero where `spread` is given.
    pub emission: Emission,
    /// The angular radius of the round beam not yet in `emission.ray.dd`.
    pub spread: Option<f64>,
}

impl Launch {
    /// The emission with its beam spelled out.
    #[inline]
    pub fn complete(self) -> Emission {
        let mut e = self.emission;
        if let Some(spread) = self.spread {
            e.ray.dd = round_beam(e.ray.d, spread);
        }
        e
    }
}

/// The direction differentials of a round beam of angular radius `spread` along `d`. Any
/// orthonormal pair serves a round beam, but a global photon's footprint after a diffuse
/// bounce adds this pair to the bounce's, vector by vector, so the pair's orientation is part
/// of the result: `tangent_frame`, as always.
#[inline]
pub fn round_beam(d: DVec3, spread: f64) -> [DVec3; 2] {
    let (t1, t2) = tangent_frame(d);
    [t1 * spread, t2 * spread]
}

pub(crate) fn mean(c: DVec3) -> f64 {
    (c.x + c.y + c.z) / 3.0
}

/// `part` over `whole`, within `[0, 1]`; 1 where there is nothing to scale.
fn share_of(part: f64, whole: f64) -> f64 {
    if whole > 0.0 && part.is_finite() && part > 0.0 {
        (part / whole).min(1.0)
    } else {
        1.0
    }
}

/// One way photons leave a light: the light, and for caustic photons the target sphere.
#[derive(Debug, Clone, Copy)]
struct Source {
    light: Light,
    /// The light's index in the scene's lights: two lights alike (one light split in two, at
    /// one place) are two lights, and each one's density counts its own cones alone (compared
    /// by value, each counted the other's too, and both carried half their light).
    light_index: usize,
    /// For caustic photons, the target; `None` for global photons.
    target: Option<Target>,
    /// Probability of choosing this source.
    probability: f64,
    /// Angular radius of the round beam each emission is given (direction differentials).
    spread: f64,
    /// For quad lights, the radius of the emission differentials along the light's edges (each
    /// emission's share of the light's area); 0 for point and spot lights.
    position_spread: f64,
    /// For point and spot lights, the cone directions are drawn from (the light's, or the
    /// target's as seen from the light), kept with its tangent frame; `None` for quad lights,
    /// whose cones start at each emission's point.
    cone: Option<Cone>,
}

/// Draws emissions for one photon map.
pub struct Emitter {
    sources: Vec<Source>,
    cdf: Vec<f64>,
    shift: [f64; 2],
    random: bool,
    /// For an aimed global emitter ([`Emitter::global_aimed`]): `sqrt(overlap / (pi N))`, from
    /// which each emission's spread follows its density; `None` for the others.
    mixture_spread: Option<f64>,
    /// The share of the lights' whole emission that these emissions stand for
    /// ([`Emitter::share`]).
    share: f64,
}

impl Emitter {
    /// Emission of global photons: every light in proportion to the power it sends towards the
    /// scene, a point light's drawn only in the directions that can meet it
    /// ([`scene_cone::global_cones`]); `photons` is the number expected (it sizes the
    /// differentials).
    pub fn global(scene: &Scene, photons: usize, overlap: f64, seed: u64) -> Self {
        Self::global_in(
            scene,
            &scene_cone::global_cones(scene),
            photons,
            overlap,
            seed,
        )
    }

    /// [`Emitter::global`] with the lights' cones and powers `cones` already found
    /// ([`scene_cone::global_cones`]: it reads every mesh's vertices for the scene's box).
    fn global_in(
        scene: &Scene,
        cones: &[(Option<Cone>, f64)],
        photons: usize,
        overlap: f64,
        seed: u64,
    ) -> Self {
        let weights: Vec<f64> = cones.iter().map(|&(_, w)| w).collect();
        let total: f64 = weights.iter().sum();
        let whole: f64 = scene.lights.iter().map(light_power).sum();
        let share = share_of(total, whole);
        let sources = scene
            .lights
            .iter()
            .zip(&weights)
            .enumerate()
            .filter(|(_, (_, &w))| w > 0.0)
            .map(|(light_index, (light, &w))| {
                let p = w / total;
                // The emissions a light's whole emission would take for the same photons
                // (`share` of them are drawn): a narrowed cone holds the photons as densely per
                // steradian as the whole sphere did, so their beams keep their width.
                let n = (photons as f64 * p * share).max(1.0);
                // A quad light's emissions leave its surface over the hemisphere, as light
                // leaving a diffuse surface does.
                let solid_angle = match (*light, cones[light_index].0) {
                    (Light::Quad { .. }, _) => 2.0 * PI,
                    (_, Some(cone)) => cone.solid_angle(),
                    (_, None) => 4.0 * PI,
                };
                Source {
                    light: *light,
                    light_index,
                    target: None,
                    probability: p,
                    spread: (overlap * solid_angle / (PI * n)).sqrt(),
                    position_spread: position_spread(light, overlap, n),
                    cone: cones[light_index].0,
                }
            })
            .collect();
        let mut emitter = Self::new(sources, seed);
        emitter.share = share;
        emitter
    }

    /// [`Emitter::global`] with a share `aim` (in `[0, 1)`) of each point or spot light's
    /// emissions drawn towards the specular meshes' bounding spheres instead of over the
    /// light's whole cone (shared out among the spheres as [`Emitter::caustic`] shares its
    /// photons). Every emission of such a light then carries the light's intensity over the
    /// mixture's density in its direction, whichever part drew it, so the map stands for the
    /// same light; and its beam is narrower where the mixture draws more densely, as the
    /// emission differentials of a denser emission are. Quad lights, and every light when
    /// `aim` is 0 or the scene has no specular mesh, emit as [`Emitter::global`] does.
    ///
    /// Light that reaches a diffuse surface through glass or a mirror and goes on from there
    /// (a caustic's reflection off a wall, L S+ D D) otherwise rides only on the few global
    /// photons whose isotropic direction happens to meet the specular object.
    pub fn global_aimed(scene: &Scene, photons: usize, overlap: f64, seed: u64, aim: f64) -> Self {
        let cones = scene_cone::global_cones(scene);
        let global = Self::global_in(scene, &cones, photons, overlap, seed);
        let targets = specular_targets(scene);
        if !(aim > 0.0 && aim < 1.0) || targets.is_empty() {
            return global;
        }
        // Each light's weight is the whole emission's (its power `P`) times the share of it
        // these emissions stand for: its aimed part `aim` whole, and its own part `1 - aim`
        // narrowed to the scene's cone (`global_cones`: the power `w` into it). So a light
        // draws as many aimed emissions, and as many that can reach the scene, as it did over
        // its whole sphere, and none that cannot. A light with nothing to aim at keeps `w`.
        let whole: f64 = scene.lights.iter().map(light_power).sum();
        let mut sources: Vec<Source> = Vec::new();
        for s in global.sources {
            let own = cones[s.light_index].1;
            let position = match s.light {
                Light::Point { position, .. } | Light::Spot { position, .. } => position,
                Light::Quad { .. } => {
                    sources.push(Source {
                        probability: own,
                        ..s
                    });
                    continue;
                }
            };
            // Each sphere's share: the power the light sends into its cone.
            let shares: Vec<(Target, f64)> = targets
                .iter()
                .map(|t| {
                    let (omega, intensity) = cone_towards(&s.light, position, t);
                    (*t, omega * intensity)
                })
                .filter(|&(_, w)| w > 0.0)
                .collect();
            let total: f64 = shares.iter().map(|&(_, w)| w).sum();
            if total <= 0.0 {
                sources.push(Source {
                    probability: own,
                    ..s
                });
                continue;
            }
            let power = light_power(&s.light);
            sources.push(Source {
                probability: own * (1.0 - aim),
                ..s
            });
            for (t, w) in shares {
                sources.push(Source {
                    light: s.light,
                    light_index: s.light_index,
                    target: Some(t),
                    probability: power * aim * w / total,
                    spread: 0.0,
                    position_spread: 0.0,
                    cone: light_cone(&s.light, Some(&t)),
                });
            }
        }
        // Weights to probabilities.
        let sum: f64 = sources.iter().map(|s| s.probability).sum();
        for s in &mut sources {
            s.probability /= sum;
        }
        let share = share_of(sum, whole);
        let mut emitter = Self::new(sources, seed);
        // As in `global`: the beams of the emissions the whole lights would take, as wide as
        // they were before the narrowing (its densities are `1 / share` times theirs).
        let whole_emissions = photons.max(1) as f64 * share;
        emitter.mixture_spread = Some((overlap / (PI * whole_emissions)).sqrt());
        emitter.share = share;
        emitter
    }

    /// The share of the lights' whole emission (every light over its whole sphere or
    /// hemisphere, its aimed part kept) that these emissions stand for: below 1 where a point
    /// light's global photons are drawn only towards the scene
    /// ([`scene_cone::global_cones`]), 1 otherwise. A map's cap on its emissions
    /// ([`crate::photons::trace::emission_cap`]) is scaled by it, so that a capped map draws
    /// as many emissions that can reach the scene as a whole light's would, and no others.
    pub fn share(&self) -> f64 {
        self.share
    }

    /// Emission of caustic photons towards the bounding spheres of the specular meshes.
    /// Empty when the scene has no specular mesh.
    pub fn caustic(scene: &Scene, photons: usize, overlap: f64, seed: u64) -> Self {
        let targets = specular_targets(scene);
        let mut pairs = Vec::new();
        for (light_index, light) in scene.lights.iter().enumerate() {
            for t in &targets {
                let (w, weight) = match *light {
                    Light::Point { position, .. } | Light::Spot { position, .. } => {
                        cone_towards(light, position, t)
                    }
                    Light::Quad {
                        corner,
                        edge_u,
                        edge_v,
                        radiance,
                    } => {
                        let centre = corner + (edge_u + edge_v) * 0.5;
                        let cross = edge_u.cross(edge_v);
                        // A target wholly behind the light's plane gets none of its light
                        // (every emission towards it was drawn, refused, and counted, up to
                        // the cap: seconds for nothing).
                        if cross.normalize().dot(t.center - corner) <= -t.radius {
                            continue;
                        }
                        let (axis, cos) = cone(centre, t);
                        let facing = axis.dot(cross.normalize()).max(0.05);
                        (
                            cone_solid_angle(cos),
                            mean(radiance) * cross.length() * facing,
                        )
                    }
                };
                pairs.push((*light, light_index, *t, w, w * weight));
            }
        }
        let total: f64 = pairs.iter().map(|p| p.4).sum();
        let sources = pairs
            .into_iter()
            .filter(|p| p.4 > 0.0)
            .map(|(light, light_index, target, omega, weight)| {
                let p = weight / total;
                let n = (photons as f64 * p).max(1.0);
                Source {
                    light,
                    light_index,
                    target: Some(target),
                    probability: p,
                    // A quad light's share of the target's cone is seen from its centre.
                    spread: (overlap * omega / (PI * n)).sqrt(),
                    position_spread: position_spread(&light, overlap, n),
                    cone: aimed_cone(&light, &target),
                }
            })
            .collect();
        Self::new(sources, seed)
    }

    fn new(sources: Vec<Source>, seed: u64) -> Self {
        let mut acc = 0.0;
        let cdf = sources
            .iter()
            .map(|s| {
                acc += s.probability;
                acc
            })
            .collect();
        let mut rng = Rng::new(seed, u64::MAX);
        Emitter {
            sources,
            cdf,
            shift: [rng.uniform(), rng.uniform()],
            random: false,
            mixture_spread: None,
            share: 1.0,
        }
    }

    /// The same emitter drawing plain random emission samples instead of the low-discrepancy
    /// sequence: for splatting estimators (the light tracer), where a lattice of emission points
    /// aliases with the pixel grid into moire patterns.
    pub fn with_random_samples(mut self) -> Self {
        self.random = true;
        self
    }

    /// Whether nothing can be emitted (no light, or no target for caustic photons).
    pub fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }

    /// The `index`-th emission (`rng` is that photon's own stream), or `None` when the sample
    /// carries no power (a quad light's back side).
    #[inline]
    pub fn emit(&self, index: u64, rng: &mut Rng) -> Option<Emission> {
        self.launch(index, rng, |l| l.complete())
    }

    /// [`Emitter::emit`] with a round beam left to spell out (the same emission, as
    /// [`Launch::complete`] gives it), handed to `start`; `None` where `emit` answers `None`.
    /// Handed on rather than returned: a returned launch is assembled on the stack from the
    /// branches that draw it and copied from there, a copy that waits for those stores.
    #[inline]
    pub fn launch<R>(
        &self,
        index: u64,
        rng: &mut Rng,
        start: impl FnOnce(&Launch) -> R,
    ) -> Option<R> {
        let (k, _) = self.pick_light(rng);
        self.emit_picked(k, index, rng, start)
    }

    /// Whether this (caustic) emitter can draw direction `d` leaving `from` on `light`: `d` lies
    /// in one of the light's target cones. A light tracer that traces caustic paths with this
    /// emitter skips such directions of its global paths, so that no direction is counted twice.
    pub fn covers(&self, light: usize, from: DVec3, d: DVec3) -> bool {
        self.density(from, light, d) > 0.0
    }

    /// [`Emitter::emit`], with the index of the light the emission left (in the scene's
    /// lights).
    #[inline]
    pub fn emit_from_light(&self, index: u64, rng: &mut Rng) -> Option<(Emission, usize)> {
        // Every light at zero leaves no source (the reference of such a scene panicked here).
        if self.sources.is_empty() {
            return None;
        }
        let (k, light) = self.pick_light(rng);
        Some((self.emit_picked(k, index, rng, |l| l.complete())?, light))
    }

    /// A source, and its light's index in the scene's lights.
    fn pick_light(&self, rng: &mut Rng) -> (usize, usize) {
        let k = self.pick_from(rng.uniform());
        (k, self.sources[k].light_index)
    }

    /// The source the uniform `pick` picks.
    #[inline(always)]
    fn pick_from(&self, pick: f64) -> usize {
        self.cdf
            .iter()
            .position(|&c| pick < c)
            .unwrap_or(self.sources.len() - 1)
    }

    #[inline(always)]
    fn emit_picked<R>(
        &self,
        k: usize,
        index: u64,
        rng: &mut Rng,
        start: impl FnOnce(&Launch) -> R,
    ) -> Option<R> {
        let (u, v) = self.square_sample(index, rng);
        self.emit_drawn(k, (u, v), |cone| cone.sample(u, v), rng, start)
    }

    /// The point of the unit square emission `index` is drawn from (after its light is
    /// picked from `rng`; [`Emitter::draw`] draws a group's the same way).
    #[inline(always)]
    fn square_sample(&self, index: u64, rng: &mut Rng) -> (f64, f64) {
        if self.random {
            (rng.uniform(), rng.uniform())
        } else {
            r2(index, self.shift)
        }
    }

    /// [`Emitter::emit_picked`] once the square's point `(u, v)` is drawn: `direction` gives a
    /// point or spot light's direction from its source's cone (`Cone::sample` at `(u, v)`,
    /// or that sample drawn beforehand, [`batch`]).
    #[inline(always)]
    fn emit_drawn<R>(
        &self,
        k: usize,
        (u, v): (f64, f64),
        direction: impl FnOnce(&Cone) -> DVec3,
        rng: &mut Rng,
        start: impl FnOnce(&Launch) -> R,
    ) -> Option<R> {
        let source = &self.sources[k];
        match source.light {
            Light::Point { position, .. } | Light::Spot { position, .. } => {
                let cone = source.cone.expect("point and spot lights keep their cone");
                let d = direction(&cone);
                if let Some(unit) = self.mixture_spread {
                    return self
                        .emit_mixture(source, position, d, unit)
                        .map(|l| start(&l));
                }
                let power = match source.target {
                    None => {
                        source.light.intensity_towards(d)
                            * (cone.solid_angle() / source.probability)
                    }
                    // A spot lighting part of the target's cone: the directions outside its
                    // own cone carry nothing, and are not traced (they would be stored as
                    // photons of no power, counted among those asked for).
                    Some(_) => {
                        let intensity = source.light.intensity_towards(d);
                        if intensity == DVec3::ZERO {
                            return None;
                        }
                        intensity / self.density(position, source.light_index, d)
                    }
                };
                Some(start(&Launch {
                    emission: Emission {
                        ray: RayDifferential::new(position, d),
                        power,
                    },
                    spread: Some(source.spread),
                }))
            }
            Light::Quad {
                corner,
                edge_u,
                edge_v,
                radiance,
            } => self
                .emit_quad(source, [corner, edge_u, edge_v, radiance], (u, v), rng)
                .map(|l| start(&l)),
        }
    }

    /// An aimed global emitter's emission in direction `d` from the point or spot light
    /// `light` at `position`: power and spread from the mixture's density in `d`.
    fn emit_mixture(
        &self,
        source: &Source,
        position: DVec3,
        d: DVec3,
        unit: f64,
    ) -> Option<Launch> {
        let pdf = self.density(position, source.light_index, d);
        let intensity = source.light.intensity_towards(d);
        // (A spot's aimed share may reach beyond its cone: nothing to trace there.)
        if pdf <= 0.0 || intensity == DVec3::ZERO {
            return None;
        }
        Some(Launch {
            emission: Emission {
                ray: RayDifferential::new(position, d),
                power: intensity / pdf,
            },
            spread: Some(unit / pdf.sqrt()),
        })
    }

    /// The emission of `source`, a quad light `[corner, edge_u, edge_v, radiance]`, at the
    /// point `(u, v)` of its square (out of line: most scenes' lights are points, and a point
    /// light's emission inlined into the tracer's loop stays in registers).
    #[inline(never)]
    fn emit_quad(
        &self,
        source: &Source,
        [corner, edge_u, edge_v, radiance]: [DVec3; 4],
        (u, v): (f64, f64),
        rng: &mut Rng,
    ) -> Option<Launch> {
        let target = source.target;
        let cross = edge_u.cross(edge_v);
        let area = cross.length();
        let n = cross / area;
        let y = corner + edge_u * u + edge_v * v;
        let (a, b) = (rng.uniform(), rng.uniform());
        let (d, power) = match target {
            None => (
                sample_cosine(n, a, b),
                radiance * (PI * area / source.probability),
            ),
            Some(t) => {
                let (axis, cos_max) = cone(y, &t);
                let d = sample_cone(axis, cos_max, a, b);
                let cos_light = d.dot(n);
                if cos_light <= 0.0 {
                    return None;
                }
                let pdf = self.density(y, source.light_index, d) / area;
                (d, radiance * (cos_light / pdf))
            }
        };
        let eu = edge_u.normalize();
        let mut ray = RayDifferential::new(y, d);
        ray.dp = [
            eu * source.position_spread,
            n.cross(eu) * source.position_spread,
        ];
        Some(Launch {
            emission: Emission { ray, power },
            spread: Some(source.spread),
        })
    }

    /// Density (per steradian, times the sources' probabilities) with which this emitter draws
    /// direction `d` leaving `from` on `light`: every cone of the light's sources holding `d`
    /// contributes (a caustic emitter's target cones; an aimed global emitter's also the
    /// light's own cone). A quad light's own emission, from the cosine lobe, has no cone and
    /// is not counted.
    fn density(&self, from: DVec3, light: usize, d: DVec3) -> f64 {
        self.sources
            .iter()
            .filter(|s| s.light_index == light)
            .filter_map(|s| {
                // A point or spot light's cones are fixed (`from` is the light's position); a
                // quad light's target cones start at each emission's point.
                let (axis, cos_max) = match (s.cone, &s.target) {
                    (Some(c), _) => (c.axis, c.cos_max),
                    (None, Some(t)) => cone(from, t),
                    (None, None) => return None,
                };
                // (With a little slack: a direction drawn from a cone can round to just
                // outside it, and its own part must count.)
                let inside = cos_max <= -1.0 || d.dot(axis) >= cos_max - 1e-12;
                inside.then(|| s.probability / cone_solid_angle(cos_max))
            })
            .sum()
    }
}

/// What a point or spot light at `position` sends into `target`'s cone: the solid angle of
/// the part of the cone it lights, and its mean intensity there (their product is the power
/// into the cone, what a light-target pair's share of aimed photons is weighed by; the solid
/// angle sizes the photons' beams). `(0, 0)` when the light sends nothing that way.
///
/// A spot's intensity depends on the angle from its axis alone, so the integral runs over
/// that angle, each circle around the axis weighed by the arc of it inside the target's cone
/// (exact for the cone, a midpoint rule in the angle). Reading the intensity on the cone's
/// axis alone dropped a glass object whose centre lay just outside a spot's cone: its lit part
/// had no caustic, without a word.
fn cone_towards(light: &Light, position: DVec3, target: &Target) -> (f64, f64) {
    let (axis, cos_alpha) = cone(position, target);
    let Light::Spot {
        direction,
        cos_cone,
        ..
    } = *light
    else {
        return (
            cone_solid_angle(cos_alpha),
            mean(light.intensity_at_cosine(1.0)),
        );
    };
    let alpha = cos_alpha.clamp(-1.0, 1.0).acos();
    let beta = axis.dot(direction).clamp(-1.0, 1.0).acos();
    let (low, high) = (
        (beta - alpha).max(0.0),
        cos_cone.clamp(-1.0, 1.0).acos().min(beta + alpha),
    );
    if low >= high {
        return (0.0, 0.0);
    }
    // The arc (radians of azimuth) of the circle at `theta` from the spot's axis inside the
    // target's cone: a point at azimuth phi has cos(angle to the cone's axis) =
    // cos(theta) cos(beta) + sin(theta) sin(beta) cos(phi).
    let arc = |theta: f64| {
        let (s, c) = theta.sin_cos();
        let across = s * beta.sin();
        if across <= 1e-300 {
            return if c * beta.cos() >= cos_alpha {
                2.0 * PI
            } else {
                0.0
            };
        }
        2.0 * ((cos_alpha - c * beta.cos()) / across)
            .clamp(-1.0, 1.0)
            .acos()
    };
    const STEPS: usize = 512;
    let step = (high - low) / STEPS as f64;
    let (mut omega, mut power) = (0.0, 0.0);
    for k in 0..STEPS {
        let theta = low + (k as f64 + 0.5) * step;
        let d_omega = arc(theta) * theta.sin() * step;
        let intensity = mean(light.intensity_at_cosine(theta.cos()));
        if intensity > 0.0 {
            omega += d_omega;
            power += intensity * d_omega;
        }
    }
    if power > 0.0 {
        (omega, power / omega)
    } else {
        (0.0, 0.0)
    }
}

/// The cone a point or spot light's photons are drawn from: towards `target` if given, else
/// the spot's cone or, for a point light, the whole sphere; `None` for quad lights.
pub(crate) fn light_cone(light: &Light, target: Option<&Target>) -> Option<Cone> {
    let (axis, cos_max) = match (*light, target) {
        (Light::Quad { .. }, _) => return None,
        (Light::Point { position, .. } | Light::Spot { position, .. }, Some(t)) => {
            cone(position, t)
        }
        (
            Light::Spot {
                direction,
                cos_cone,
                ..
            },
            None,
        ) => (direction, cos_cone),
        // Point lights: the equal-area map is smoothest around its axis and squeezes the
        // square's boundary into the opposite pole; lights usually hang above what they light,
        // so the axis points down.
        (Light::Point { .. }, None) => (DVec3::NEG_Y, -1.0),
    };
    Some(Cone::new(axis, cos_max))
}

/// The cone a caustic photon of a point or spot light aimed at `target` is drawn from: the
/// target's, or a spot's own where that is narrower (a narrow spot on a large glass object:
/// drawn from the target's cone, most directions would carry nothing); `None` for quad lights.
fn aimed_cone(light: &Light, target: &Target) -> Option<Cone> {
    let towards = light_cone(light, Some(target))?;
    match (*light, light_cone(light, None)) {
        (Light::Spot { .. }, Some(own)) if own.solid_angle() < towards.solid_angle() => Some(own),
        _ => Some(towards),
    }
}

/// The radius of the emission differentials along a quad light's edges for `n` emissions:
/// each one's share `overlap * A / n` of the light's area `A`; 0 for point and spot lights.
fn position_spread(light: &Light, overlap: f64, n: f64) -> f64 {
    match *light {
        Light::Quad { edge_u, edge_v, .. } => {
            (overlap * edge_u.cross(edge_v).length() / (PI * n)).sqrt()
        }
        _ => 0.0,
    }
}

/// Mean-channel power of a light (W): sets how many global photons it emits.
pub fn light_power(light: &Light) -> f64 {
    match *light {
        Light::Point { intensity, .. } => 4.0 * PI * mean(intensity),
        Light::Spot {
            intensity,
            cos_cone,
            cos_falloff_start,
            ..
        } => cone_solid_angle(0.5 * (cos_cone + cos_falloff_start)) * mean(intensity),
        Light::Quad {
            edge_u,
            edge_v,
            radiance,
            ..
        } => PI * edge_u.cross(edge_v).length() * mean(radiance),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cone_samples_stay_in_the_cone_and_cosine_samples_above_the_surface() {
        let axis = DVec3::new(1.0, 2.0, -0.5).normalize();
        for i in 0..1000 {
            let (u, v) = r2(i, [0.3, 0.7]);
            assert!(sample_cone(axis, 0.9, u, v).dot(axis) >= 0.9 - 1e-12);
            assert!(sample_cosine(axis, u, v).dot(axis) >= -1e-12);
        }
        // Uniform in solid angle: the mean cosine over a full sphere is 0.
        let mean_cos: f64 = (0..100_000)
            .map(|i| {
                let (u, v) = r2(i, [0.1, 0.2]);
                sample_cone(axis, -1.0, u, v).dot(axis)
            })
            .sum::<f64>()
            / 100_000.0;
        assert!(mean_cos.abs() < 1e-3, "{mean_cos}");
    }

    fn spot(direction: DVec3, cone_deg: f64, falloff_deg: f64) -> Light {
        Light::Spot {
            position: DVec3::ZERO,
            direction: direction.normalize(),
            intensity: DVec3::splat(3.0),
            cos_cone: cone_deg.to_radians().cos(),
            cos_falloff_start: falloff_deg.to_radians().cos(),
        }
    }

    /// The lit solid angle and mean intensity of `light` over `target`'s cone by sampling
    /// the cone uniformly (`n` x `n` stratified directions).
    fn sampled(light: &Light, target: &Target, n: u64) -> (f64, f64) {
        let (axis, cos_max) = cone(DVec3::ZERO, target);
        let (mut lit, mut sum) = (0.0, 0.0);
        for i in 0..n * n {
            let (u, v) = (
                ((i % n) as f64 + 0.5) / n as f64,
                ((i / n) as f64 + 0.5) / n as f64,
            );
            let intensity = mean(light.intensity_towards(sample_cone(axis, cos_max, u, v)));
            if intensity > 0.0 {
                lit += 1.0;
                sum += intensity;
            }
        }
        let omega = cone_solid_angle(cos_max);
        (
            omega * lit / (n * n) as f64,
            if lit > 0.0 { sum / lit } else { 0.0 },
        )
    }

    /// What a spot sends into a target's cone, against sampling the cone: a cone wholly lit,
    /// one lit only in part (the target's centre outside the spot's cone, which read 0 and
    /// dropped the caustic), one wholly inside the target's, and one the spot misses.
    #[test]
    fn a_spot_lights_the_part_of_a_target_inside_its_cone() {
        let target = Target {
            center: DVec3::new(0.0, -5.0, 0.0),
            radius: 1.0,
        };
        let half = (1.0f64 / 5.0).asin().to_degrees(); // 11.5 degrees
        let tilted = |deg: f64| {
            let a = deg.to_radians();
            DVec3::new(a.sin(), -a.cos(), 0.0)
        };
        for (light, lit) in [
            (spot(tilted(0.0), 30.0, 25.0), 1.0),
            (spot(tilted(3.0), 30.0, 10.0), 1.0),
            (spot(tilted(half + 2.0), 5.0, 2.0), 0.0),
            (spot(tilted(1.0), 3.0, 1.0), 0.0),
        ] {
            let (omega, intensity) = cone_towards(&light, DVec3::ZERO, &target);
            let (want_omega, want_intensity) = sampled(&light, &target, 600);
            assert!(omega > 0.0);
            assert!(
                (omega / want_omega - 1.0).abs() < 2e-3,
                "{omega} {want_omega}"
            );
            assert!(
                (intensity / want_intensity - 1.0).abs() < 2e-3,
                "{intensity} {want_intensity}"
            );
            if lit == 1.0 {
                let whole = cone_solid_angle((1.0 - 1.0f64 / 25.0).sqrt());
                assert!((omega / whole - 1.0).abs() < 1e-4, "{omega} {whole}");
            }
        }
        // Missed by 1 degree: nothing, rather than a share of photons that all carry nothing.
        let light = spot(tilted(half + 6.0), 5.0, 2.0);
        assert_eq!(cone_towards(&light, DVec3::ZERO, &target), (0.0, 0.0));
        // A point light: the whole cone at its intensity.
        let light = Light::Point {
            position: DVec3::ZERO,
            intensity: DVec3::new(1.0, 2.0, 3.0),
        };
        let (omega, intensity) = cone_towards(&light, DVec3::ZERO, &target);
        assert_eq!(omega, cone_solid_angle(cone(DVec3::ZERO, &target).1));
        assert_eq!(intensity, 2.0);
    }
}
