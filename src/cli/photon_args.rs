//! The photon-map options `render` and `photons` both take, checked in one place: a map that
//! `photons` writes for `render --photon-maps` is made with the same options as `render` would
//! make it, and each option is refused with the same words by both.

use photondiff::photons::options::PhotonOptions;
use photondiff::render::defaults::RenderDefaults;

/// What the photon maps hold and how wide their footprints are. Every default is the
/// estimator's ([`RenderDefaults`]).
#[derive(clap::Args, Debug, Clone)]
pub struct PhotonArgs {
    /// Photons stored in the global map (indirect light; in a render, each pass's); emission
    /// stops at 4 emissions per photon asked for, and the statistics say if fewer were stored
    /// (a warning too when N is given here; a default count is an "up to" count). Default
    /// 50,000 for `integrated` (the default estimator), 100,000 (the thesis's count) for the
    /// others.
    #[arg(long = "photons", value_name = "N", value_parser = super::photon_count)]
    pub global_photons: Option<usize>,
    /// Photons stored in the caustic map (in a render, each pass's). Default 60,000 for
    /// `integrated` (the default estimator) and 20,000 (the thesis's count) for the others.
    #[arg(long, value_name = "N", value_parser = super::photon_count)]
    pub caustic_photons: Option<usize>,
    /// Photon footprint size, as the expected number of footprints covering a point.
    #[arg(long, value_name = "X", default_value_t = 32.0)]
    pub overlap: f64,
    /// Share of the global photons' diffuse bounces aimed at the mirror and glass objects
    /// (the rest follow the cosine lobe; powers are weighted so the map's expected value is
    /// unchanged): in [0, 1), 0 aims none. It carries the light that goes floor -> glass ->
    /// floor in an open scene with many more photons. A third of the share also aims the
    /// global photons' emissions from point and spot lights at those objects (light that
    /// reaches a surface through glass and goes on from there: a caustic's reflection off a
    /// wall). Default 0.15 for `integrated` (the default estimator), 0 for the others (the
    /// thesis's photon maps).
    #[arg(long, value_name = "P")]
    pub global_aim: Option<f64>,
    /// Whether each photon's footprint is probed for walls and edges (16 rays a photon), and a
    /// mirror photon added beyond the nearest, which gives back the part of the footprint no
    /// gather sees: without it, light within a footprint's radius of a wall (the floor at the
    /// foot of a box) or of an edge (the box's top) is too dark, by half at the wall. Default
    /// true for `integrated` (the default estimator), false for the others (the thesis's photon
    /// maps).
    #[arg(long, value_name = "BOOL", action = clap::ArgAction::Set)]
    pub probe_walls: Option<bool>,
}

impl PhotonArgs {
    /// The photon options these ask for over the estimator's `defaults`, with `seed`; an error
    /// naming the option where one is out of its range. Needs no scene, so that a command
    /// refuses a bad option before it spends seconds loading a large one.
    pub fn options(&self, defaults: &RenderDefaults, seed: u64) -> Result<PhotonOptions, String> {
        if !(self.overlap.is_finite() && self.overlap > 0.0) {
            return Err(format!(
                "--overlap must be a positive number, got {}",
                super::shown(self.overlap)
            ));
        }
        let global_aim = self.global_aim.unwrap_or(defaults.global_aim);
        if !(0.0..1.0).contains(&global_aim) {
            return Err(format!(
                "--global-aim must be at least 0 and less than 1, got {}",
                super::shown(global_aim)
            ));
        }
        Ok(PhotonOptions {
            global_photons: self.global_photons.unwrap_or(defaults.global_photons),
            caustic_photons: self.caustic_photons.unwrap_or(defaults.caustic_photons),
            overlap: self.overlap,
            seed,
            global_aim,
            probe_walls: self.probe_walls.unwrap_or(defaults.probe_walls),
            ..PhotonOptions::default()
        })
    }
}
