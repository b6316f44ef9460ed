//! Settings of photon tracing: how many photons each map holds, how wide their footprints are
//! and how their paths are drawn. The tracer ([`super::trace`]) reads them; the command line
//! and the render's defaults ([`crate::render::defaults::RenderDefaults`]) fill them in.

use crate::photons::footprint::FootprintLimits;
use crate::photons::map::PathClass;
use crate::scene::Scene;

/// The footprint guards' default radii, as fractions of the scene's extent
/// ([`PhotonOptions::radius_limits`]); progressive passes shrink them.
pub const DEFAULT_RADIUS_LIMITS: (f64, f64) = (1e-5, 0.02);

/// Settings of photon tracing. `PhotonOptions::default()` gives the documented defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct PhotonOptions {
    /// Global photons: photons stored in the global map, as for the caustic map; emission
    /// stops at [`super::trace::GLOBAL_EMISSIONS_PER_PHOTON`] emissions per photon asked for
    /// even if fewer were stored (the statistics and the command line say so). Default
    /// 100,000 (the thesis's count).
    pub global_photons: usize,
    /// Caustic photons: photons stored in the caustic map. Default 20,000 (the thesis's count).
    /// Aimed at the specular objects, they cost about as many emissions.
    pub caustic_photons: usize,
    /// Expected number of footprints covering a point (see [`crate::photons::emission`]). Default 32.
    pub overlap: f64,
    /// The global map's footprint area as a multiple of the caustic map's: its overlap is
    /// `overlap * global_area_scale` and its guards' radii `sqrt(global_area_scale)` times
    /// `radius_limits`. Default 1; progressive passes shrink the two maps on schedules of their
    /// own ([`crate::render::passes`]).
    pub global_area_scale: f64,
    /// Maximum number of surfaces a photon path meets. Default 1024, as the light tracer's
    /// ([`crate::reference::light_tracer`]). Russian roulette ends paths; this only bounds
    /// pathological ones (a closed mirror box), and cuts light: a closed scene of albedo `a`
    /// loses `a^n` of its light at `n` surfaces. At the former 64 a closed sphere of albedo
    /// 0.95 stored 0.963 of its photons' wall meetings (`1 - 0.95^64`), at 1024 all but 2e-23.
    pub max_bounces: u32,
    /// Footprint guards, as fractions of the scene's bounding-box diagonal (for the caustic
    /// map, at most twice the one around the camera, the lights and the specular objects:
    /// [`Scene::footprint_extent`]):
    /// `(min radius, max radius)`. Default `(1e-5, 0.02)`.
    pub radius_limits: (f64, f64),
    /// Largest ratio of a footprint's semi-axes. Default 20.
    pub max_anisotropy: f64,
    /// Seed of every random stream. Default 0.
    pub seed: u64,
    /// Share of the global photons' diffuse bounces aimed at the mirror and glass objects
    /// (their bounding spheres), the rest drawn from the cosine lobe, with powers weighted by
    /// the mixture's density ([`crate::photons::targets::DiffuseAim`]): in `[0, 1)`, 0 draws
    /// every bounce from the cosine lobe. Default 0 (the thesis's photon maps); the default
    /// render uses [`crate::render::defaults::DEFAULT_GLOBAL_AIM`]. A third of the share also
    /// aims the global map's emissions from point and spot lights
    /// ([`PhotonOptions::emission_aim`]). (The final-gathering map and the caustic map, which
    /// ends at its first diffuse hit, are not aimed.)
    pub global_aim: f64,
    /// Whether the global map's photons are stored at every diffuse hit and made into a
    /// radiance map for final gathering ([`crate::photons::radiance_map`]) instead of a photon
    /// map viewed directly. Default false.
    pub radiance_map: bool,
    /// Whether each photon's footprint is probed for walls and edges, and a mirror photon added
    /// beyond the nearest ([`crate::photons::walls`]; one packet of 16 rays a photon); the
    /// radiance map's photons are probed over a disc of its estimates' largest radius
    /// instead ([`crate::photons::trace::PhotonTracer::mirror_samples`]). Default
    /// false (the thesis's photon maps); the default render uses
    /// [`crate::render::defaults::DEFAULT_PROBE_WALLS`].
    pub probe_walls: bool,
}

impl Default for PhotonOptions {
    fn default() -> Self {
        PhotonOptions {
            global_photons: 100_000,
            caustic_photons: 20_000,
            overlap: 32.0,
            global_area_scale: 1.0,
            max_bounces: 1024,
            radius_limits: DEFAULT_RADIUS_LIMITS,
            max_anisotropy: 20.0,
            seed: 0,
            global_aim: 0.0,
            radiance_map: false,
            probe_walls: false,
        }
    }
}

impl PhotonOptions {
    /// The scene-wide footprint limits: `radius_limits` times [`Scene::extent`]; the global
    /// map's before its area scale, and the estimators' largest radius (`jensen`'s over both
    /// maps, the radiance map's points).
    pub fn limits(&self, scene: &Scene) -> FootprintLimits {
        self.limits_over(scene.extent())
    }

    fn limits_over(&self, extent: f64) -> FootprintLimits {
        FootprintLimits {
            min_radius: self.radius_limits.0 * extent,
            max_radius: self.radius_limits.1 * extent,
            max_anisotropy: self.max_anisotropy,
        }
    }

    /// The footprint limits for `scene` of the map of `class`: the caustic (and direct) map's
    /// over [`Scene::footprint_extent`], where the caustics are (a floor reaching far away does
    /// not widen them); the global map's (and the radiance map's) the scene-wide [`Self::limits`]
    /// with radii scaled by `sqrt(global_area_scale)`: its photons land anywhere (a closed room
    /// around the camera and the light is all diffuse, and its footprints clamped to the box
    /// around those two read a closed sphere 2.4% dark).
    pub fn class_limits(&self, scene: &Scene, class: PathClass) -> FootprintLimits {
        match class {
            PathClass::Caustic | PathClass::Direct => self.limits_over(scene.footprint_extent()),
            PathClass::Global | PathClass::AllDiffuse => {
                let limits = self.limits(scene);
                let r = self.global_area_scale.sqrt();
                FootprintLimits {
                    min_radius: limits.min_radius * r,
                    max_radius: limits.max_radius * r,
                    ..limits
                }
            }
        }
    }

    /// The largest radius of the radiance map's estimates ([`crate::photons::radiance_map`]):
    /// the global map's largest footprint radius before any pass shrank it
    /// ([`DEFAULT_RADIUS_LIMITS`] times [`Scene::extent`]), whatever the pass. Its estimates
    /// take a fixed 64 photons, so a largest radius shrinking with the passes did not shrink
    /// their blur: it cut their discs below the spacing of the points they are kept at (every
    /// fourth photon), and gather rays between the discs read no light. In a closed box of
    /// albedo 0.8 the image's mean fell to 0.93 of the exact value at 32 passes and 0.68 at
    /// 576 (0.98 at 2).
    pub fn radiance_max_radius(&self, scene: &Scene) -> f64 {
        DEFAULT_RADIUS_LIMITS.1 * scene.extent()
    }

    /// The share of the global photons' emissions from point and spot lights aimed at the
    /// specular objects ([`crate::photons::emission::Emitter::global_aimed`]): a third of
    /// [`PhotonOptions::global_aim`]; none for the final-gathering map, whose bounces are not
    /// aimed either. Aimed emissions carry the light that reaches a diffuse surface through
    /// glass and goes on from there, but each costs several rays through the glass, so a
    /// smaller share than the bounces' (README, "Photon maps").
    pub fn emission_aim(&self) -> f64 {
        if self.radiance_map {
            0.0
        } else {
            self.global_aim / 3.0
        }
    }

    /// The global map's overlap: `overlap * global_area_scale`.
    pub fn global_overlap(&self) -> f64 {
        self.overlap * self.global_area_scale
    }
}
