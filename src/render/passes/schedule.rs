//! The schedule of progressive passes: what pass `i` depends on besides the run's settings
//! (its seed, its footprints' area factor, its camera jitter), so that any range of passes can
//! be rendered alone ([`super`] has the whole design).

use crate::geometry::sampling::r2;
use crate::photons::options::PhotonOptions;
use crate::util::rng::derive_seed;

/// Default `alpha` of the caustic map's footprint schedule (`--alpha`): its error is mostly
/// bias of first order in the footprint's radius (module documentation).
pub const DEFAULT_ALPHA: f64 = 0.5;

/// Default `alpha` of the global map's footprint schedule (`--global-alpha`): the caustic map's.
/// Global light is smooth in the open, where 2/3 would serve it (the canonical scene's shadow,
/// 5% lower error after 12 passes), but a wall or an edge gives it a bias of first order
/// too, which then dominates (over-an-edge's box foot, lit by the caustic's reflection: its
/// contour's error after 200 passes 0.037 with 2/3, 0.024 with 1/2; README, "Progressive
/// passes").
pub const DEFAULT_GLOBAL_ALPHA: f64 = DEFAULT_ALPHA;

/// The photon options of pass `pass` of a run with `photons` and the footprint schedules
/// `alpha` (caustic) and `global_alpha` (global): the part of [`super::Progressive::pass_settings`]
/// that needs no scene (pass 0's are `photons` themselves).
pub fn pass_photons(
    photons: &PhotonOptions,
    alpha: f64,
    global_alpha: f64,
    pass: u64,
) -> PhotonOptions {
    let s = area_factor(alpha, pass);
    let global = area_factor(global_alpha, pass);
    let (lo, hi) = photons.radius_limits;
    PhotonOptions {
        overlap: photons.overlap * s,
        radius_limits: (lo * s.sqrt(), hi * s.sqrt()),
        global_area_scale: photons.global_area_scale * global / s,
        seed: derive_seed(photons.seed, pass),
        ..photons.clone()
    }
}

/// The footprint area factor of pass `pass`: `prod_{j=1..pass} (j + alpha) / (j + 1)`.
pub fn area_factor(alpha: f64, pass: u64) -> f64 {
    (1..=pass).fold(1.0, |s, j| s * (j as f64 + alpha) / (j as f64 + 1.0))
}

/// The camera jitter of pass `pass` within a view-grid cell (`(0.5, 0.5)` for pass 0).
pub fn jitter(pass: u64) -> [f64; 2] {
    let (u, v) = r2(pass, [0.5, 0.5]);
    [u, v]
}
