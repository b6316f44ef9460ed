//! Rendering methods as the experiments name them (the timing table, the speed-versus-error
//! chart): an estimator with its view and sample grids, rendered from shared photon maps.

use crate::embree;
use crate::estimate::RadianceEstimator;
use crate::estimate::{EstimatorKind, EstimatorSettings};
use crate::photons::options::PhotonOptions;
use crate::photons::PhotonMaps;
use crate::render::defaults::{RenderDefaults, DEFAULT_PASSES};
use crate::render::film::Film;
use crate::render::image::render_image;
use crate::render::pass_sum::PassSum;
use crate::render::passes::{Progressive, DEFAULT_ALPHA, DEFAULT_GLOBAL_ALPHA};
use crate::render::stats::Stats;
use crate::render::{render, RenderOptions};
use crate::scene::Scene;

/// One rendering method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Method {
    /// The estimate.
    pub kind: EstimatorKind,
    /// Camera rays per pixel along each axis.
    pub view_grid: u32,
    /// Sample grid of the multi-sampled estimate.
    pub ms_grid: u32,
    /// Progressive passes (1: a single render from the shared photon maps).
    pub passes: u64,
    /// The default render's settings (`None`: the shared maps and one shadow ray): when its
    /// photons differ from the shared maps', every pass traces its own maps, pass 0 too, and
    /// their tracing counts as rendering time.
    pub defaults: Option<RenderDefaults>,
}

impl Method {
    /// Estimate `kind` with one camera ray per pixel and its defaults (`multisampled` on its
    /// default grid): what tests and benchmarks take when they mean every estimator
    /// ([`EstimatorKind::over_maps`]).
    pub fn of(kind: EstimatorKind) -> Self {
        Method {
            kind,
            view_grid: 1,
            ms_grid: match kind {
                EstimatorKind::Multisampled => EstimatorSettings::DEFAULT_MS_GRID,
                _ => 1,
            },
            passes: 1,
            defaults: None,
        }
    }

    /// Regular (photon differentials) with `n x n` camera rays per pixel.
    pub fn regular(n: u32) -> Self {
        Method {
            kind: EstimatorKind::Pd,
            view_grid: n,
            ms_grid: 1,
            passes: 1,
            defaults: None,
        }
    }
    /// Jensen's estimate with `n x n` camera rays per pixel.
    pub fn jensen(n: u32) -> Self {
        Method {
            kind: EstimatorKind::Jensen,
            view_grid: n,
            ms_grid: 1,
            passes: 1,
            defaults: None,
        }
    }
    /// Coplanar intersection-weighted photon differentials, one camera ray per pixel.
    pub fn coplanar() -> Self {
        Method {
            kind: EstimatorKind::Coplanar,
            view_grid: 1,
            ms_grid: 1,
            passes: 1,
            defaults: None,
        }
    }
    /// Multi-sampled photon differentials with `n x n` sample points, one camera ray per pixel.
    pub fn multisampled(n: u32) -> Self {
        Method {
            kind: EstimatorKind::Multisampled,
            view_grid: 1,
            ms_grid: n,
            passes: 1,
            defaults: None,
        }
    }

    /// Footprint-integrated photon differentials, one camera ray per pixel.
    pub fn integrated() -> Self {
        Method {
            kind: EstimatorKind::Integrated,
            view_grid: 1,
            ms_grid: 1,
            passes: 1,
            defaults: None,
        }
    }

    /// Footprint-integrated as `photondiff render` does by default: with its default progressive
    /// passes.
    pub fn integrated_default() -> Self {
        Method {
            passes: DEFAULT_PASSES,
            defaults: Some(RenderDefaults::for_estimator(EstimatorKind::Integrated)),
            ..Self::integrated()
        }
    }

    /// A name for tables and charts.
    pub fn label(&self) -> String {
        let n = self.view_grid;
        let name = match self.kind {
            EstimatorKind::Pd => format!("Regular (photon differentials) {n}x{n}"),
            EstimatorKind::Jensen => format!("Jensen {n}x{n}"),
            EstimatorKind::Coplanar => "Coplanar intersection-weighted".to_string(),
            EstimatorKind::Multisampled => format!("Multi-sampled {0}x{0}", self.ms_grid),
            EstimatorKind::Integrated => "Footprint-integrated".to_string(),
            EstimatorKind::Direct => "Direct light only".to_string(),
            EstimatorKind::Lighttrace => "Light tracing".to_string(),
        };
        let name = match self.defaults {
            Some(d) => format!("{name}, {} caustic photons a pass", d.caustic_photons),
            None => name,
        };
        match self.passes {
            1 => name,
            p => format!("{name}, {p} passes"),
        }
    }

    /// Renders `scene` with this method from `maps` on `threads` threads (0 = all); returns the
    /// image and the rendering time in seconds (photon tracing excluded). With passes, pass 0
    /// renders from `maps` and each later pass traces photons of its own, as `photondiff render
    /// --passes` does: that tracing counts as rendering time.
    pub fn render(
        &self,
        scene: &Scene,
        embree: &embree::Scene,
        maps: &PhotonMaps,
        photon_options: &PhotonOptions,
        threads: usize,
    ) -> Result<(Film, f64), String> {
        let settings = EstimatorSettings {
            ms_grid: self.ms_grid,
            ..EstimatorSettings::new(self.kind, photon_options.limits(scene).max_radius)
        };
        let estimators = maps.estimators(&settings);
        let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
        let options = RenderOptions::default()
            .with_view_grid(self.view_grid)
            .with_footprint_strata(self.defaults.map_or(1, |d| d.footprint_strata))
            .with_threads(threads);
        let mut stats = Stats::default();
        let own_photons = self
            .defaults
            .map(|d| d.photons(photon_options.clone()))
            .filter(|own| own != photon_options);
        if self.passes <= 1 && own_photons.is_none() {
            let film = render(scene, embree, &refs, &options, &mut stats)?;
            return Ok((film, stats.seconds("render")));
        }
        let run = Progressive {
            scene,
            embree,
            photons: own_photons
                .clone()
                .unwrap_or_else(|| photon_options.clone()),
            estimator: settings,
            render: options,
            alpha: DEFAULT_ALPHA,
            global_alpha: DEFAULT_GLOBAL_ALPHA,
        };
        let mut sum = PassSum::new(scene.camera.width, scene.camera.height);
        if own_photons.is_some() {
            sum.add(&run.render_pass(0, false, &mut stats)?);
        } else {
            // Pass 0's settings with the shared maps (its estimate equals the single render's).
            let (_, settings, options) = run.pass_settings(0);
            let estimators = maps.estimators(&settings);
            let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
            sum.add(&render_image(scene, embree, &refs, &options, &mut stats)?);
        }
        for pass in 1..self.passes {
            sum.add(&run.render_pass(pass, false, &mut stats)?);
        }
        let seconds = stats.seconds("render") + stats.seconds("trace photons");
        Ok((sum.mean(), seconds))
    }
}
