//! The estimator the rendering loop calls at diffuse hits, as the command line names it, over
//! the photon maps.

use super::{
    CoplanarEstimate, IntegratedEstimate, JensenEstimate, MultiSampledEstimate,
    PhotonDifferentialEstimate, RadianceEstimator,
};
use crate::photons::PhotonMaps;

/// Which radiance estimate renders the photon maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum EstimatorKind {
    /// Direct light only: no photon maps.
    Direct,
    /// The regular estimate: k nearest photons, normalised kernel (Jensen).
    Jensen,
    /// The photon-differential estimate: each photon's own footprint (Schjoth et al.).
    Pd,
    /// Coplanar intersection-weighted photon differentials: the view footprint intersected with
    /// each photon's footprint (Pedersen).
    Coplanar,
    /// Multi-sampled photon differentials: each kernel averaged over N x N points of the view
    /// footprint (Pedersen).
    Multisampled,
    /// Footprint-integrated photon differentials: each kernel averaged over the whole view
    /// footprint in closed form (multi-sampled as N grows without bound).
    Integrated,
    /// Not a photon map estimate: the light-tracing reference (`reference::light_tracer`).
    Lighttrace,
}

/// How the photon maps are estimated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EstimatorSettings {
    /// Which estimate.
    pub kind: EstimatorKind,
    /// Nearest photons per `jensen` estimate.
    pub k: usize,
    /// Largest `jensen` gather radius.
    pub max_radius: f64,
    /// Sample grid side of the `multisampled` estimate (1 to 32).
    pub ms_grid: u32,
    /// Vertices of the polygon standing for a photon footprint in the `coplanar` estimate.
    pub ellipse_vertices: usize,
}

// An inherent impl outside `photons`: choosing estimators is this module's concern, and the
// photon maps know nothing of estimators.
impl PhotonMaps {
    /// The estimators over both maps (none for [`EstimatorKind::Direct`]).
    pub fn estimators(&self, settings: &EstimatorSettings) -> Vec<Box<dyn RadianceEstimator + '_>> {
        [&self.caustic, &self.global]
            .into_iter()
            .filter_map(|map| -> Option<Box<dyn RadianceEstimator>> {
                Some(match settings.kind {
                    EstimatorKind::Direct | EstimatorKind::Lighttrace => return None,
                    EstimatorKind::Jensen => Box::new(JensenEstimate {
                        map,
                        k: settings.k,
                        max_radius: settings.max_radius,
                    }),
                    EstimatorKind::Pd => Box::new(PhotonDifferentialEstimate { map }),
                    EstimatorKind::Coplanar => Box::new(CoplanarEstimate {
                        map,
                        ellipse_vertices: settings.ellipse_vertices,
                    }),
                    EstimatorKind::Integrated => Box::new(IntegratedEstimate { map }),
                    EstimatorKind::Multisampled => {
                        Box::new(MultiSampledEstimate::new(map, settings.ms_grid))
                    }
                })
            })
            .collect()
    }
}
