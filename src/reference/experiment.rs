//! Rendering methods as the experiments name them (the timing table, the speed-versus-error
//! chart): an estimator with its view and sample grids, rendered from shared photon maps.

use crate::embree;
use crate::estimate::RadianceEstimator;
use crate::estimate::{EstimatorKind, EstimatorSettings};
use crate::photons::trace::PhotonOptions;
use crate::photons::PhotonMaps;
use crate::render::film::Film;
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
}

impl Method {
    /// Regular (photon differentials) with `n x n` camera rays per pixel.
    pub fn regular(n: u32) -> Self {
        Method {
            kind: EstimatorKind::Pd,
            view_grid: n,
            ms_grid: 1,
        }
    }
    /// Jensen's estimate with `n x n` camera rays per pixel.
    pub fn jensen(n: u32) -> Self {
        Method {
            kind: EstimatorKind::Jensen,
            view_grid: n,
            ms_grid: 1,
        }
    }
    /// Coplanar intersection-weighted photon differentials, one camera ray per pixel.
    pub fn coplanar() -> Self {
        Method {
            kind: EstimatorKind::Coplanar,
            view_grid: 1,
            ms_grid: 1,
        }
    }
    /// Multi-sampled photon differentials with `n x n` sample points, one camera ray per pixel.
    pub fn multisampled(n: u32) -> Self {
        Method {
            kind: EstimatorKind::Multisampled,
            view_grid: 1,
            ms_grid: n,
        }
    }

    /// Footprint-integrated photon differentials, one camera ray per pixel.
    pub fn integrated() -> Self {
        Method {
            kind: EstimatorKind::Integrated,
            view_grid: 1,
            ms_grid: 1,
        }
    }

    /// A name for tables and charts.
    pub fn label(&self) -> String {
        let n = self.view_grid;
        match self.kind {
            EstimatorKind::Pd => format!("Regular (photon differentials) {n}x{n}"),
            EstimatorKind::Jensen => format!("Jensen {n}x{n}"),
            EstimatorKind::Coplanar => "Coplanar intersection-weighted".to_string(),
            EstimatorKind::Multisampled => format!("Multi-sampled {0}x{0}", self.ms_grid),
            EstimatorKind::Integrated => "Footprint-integrated".to_string(),
            EstimatorKind::Direct => "Direct light only".to_string(),
            EstimatorKind::Lighttrace => "Light tracing".to_string(),
        }
    }

    /// Renders `scene` with this method from `maps` on `threads` threads (0 = all); returns the
    /// image and the rendering time in seconds (photon tracing excluded).
    pub fn render(
        &self,
        scene: &Scene,
        embree: &embree::Scene,
        maps: &PhotonMaps,
        photon_options: &PhotonOptions,
        threads: usize,
    ) -> Result<(Film, f64), String> {
        let settings = EstimatorSettings {
            kind: self.kind,
            k: 50,
            max_radius: photon_options.limits(scene).max_radius,
            ms_grid: self.ms_grid,
            ellipse_vertices: 16,
        };
        let estimators = maps.estimators(&settings);
        let refs: Vec<&dyn RadianceEstimator> = estimators.iter().map(|e| e.as_ref()).collect();
        let options = RenderOptions::default()
            .with_view_grid(self.view_grid)
            .with_threads(threads);
        let mut stats = Stats::default();
        let film = render(scene, embree, &refs, &options, &mut stats)?;
        Ok((film, stats.seconds("render")))
    }
}
