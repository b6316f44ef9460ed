//! The estimator the rendering loop calls at diffuse hits, as the command line names it, over
//! the photon maps.

use super::final_gather::{DirectAt, NearGather, NEAR_RAYS};
use super::{
    CoplanarEstimate, FinalGather, IntegratedEstimate, JensenEstimate, MultiSampledEstimate,
    PhotonDifferentialEstimate, RadianceEstimator,
};
use crate::embree;
use crate::photons::map::PhotonMap;
use crate::photons::PhotonMaps;
use crate::scene::Scene;

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

impl EstimatorKind {
    /// The estimate's name as the command line takes it (`--estimator NAME`), and as images
    /// and messages give it.
    pub fn name(self) -> String {
        use clap::ValueEnum;
        self.to_possible_value()
            .map_or_else(|| format!("{self:?}"), |v| v.get_name().to_string())
    }

    /// Whether this estimate reads photon maps (every kind but `direct` and `lighttrace`).
    pub fn reads_maps(self) -> bool {
        use EstimatorKind::*;
        // Every kind named in these properties, so that a new one is decided, not defaulted.
        match self {
            Direct | Lighttrace => false,
            Jensen | Pd | Coplanar | Multisampled | Integrated => true,
        }
    }

    /// Whether this estimate reads the photons' footprints (their differentials) without
    /// final gathering: every map estimate but `jensen`'s k nearest photons.
    pub fn reads_footprints(self) -> bool {
        use EstimatorKind::*;
        match self {
            Direct | Lighttrace | Jensen => false,
            Pd | Coplanar | Multisampled | Integrated => true,
        }
    }

    /// Whether its passes converge to the reference (README, "What passes do not mend"):
    /// `multisampled` 8x8 stayed 0.29 from the reference from 1 to 64 passes while its noise
    /// fell to 1.6%, and `coplanar` stopped "at 2%" 255% off; `--target-noise` warns for these.
    pub fn converges_with_passes(self) -> bool {
        use EstimatorKind::*;
        match self {
            Multisampled | Coplanar => false,
            Direct | Lighttrace | Jensen | Pd | Integrated => true,
        }
    }

    /// The estimates over photon maps, in the command line's order: what tests and benchmarks
    /// loop over when they mean every estimator, so that a new one is in them without being
    /// named there.
    pub fn over_maps() -> impl Iterator<Item = EstimatorKind> {
        <Self as clap::ValueEnum>::value_variants()
            .iter()
            .copied()
            .filter(|k| k.reads_maps())
    }
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
    /// Final-gather rays per diffuse hit (0: the global map is seen directly). With final
    /// gathering the photon maps must hold a radiance map.
    pub gather_rays: u32,
    /// Final gathering: a gather ray whose path to its diffuse hit is shorter than this many
    /// radii of the radiance map's disc there goes a bounce further (`--gather-near`; 0 never).
    pub gather_near: f64,
}

impl EstimatorSettings {
    /// `jensen`'s nearest photons when not given (`--k`).
    pub const DEFAULT_K: usize = 50;
    /// `multisampled`'s grid side when not given (`--ms-grid`).
    pub const DEFAULT_MS_GRID: u32 = 8;
    /// `coplanar`'s polygon vertices when not given (`--coplanar-vertices`).
    pub const DEFAULT_ELLIPSE_VERTICES: usize = 16;

    /// Estimate `kind` with every estimator's default and no final gathering; `max_radius`
    /// is the photon maps' largest footprint radius (`PhotonOptions::limits`).
    pub fn new(kind: EstimatorKind, max_radius: f64) -> Self {
        EstimatorSettings {
            kind,
            k: Self::DEFAULT_K,
            max_radius,
            ms_grid: Self::DEFAULT_MS_GRID,
            ellipse_vertices: Self::DEFAULT_ELLIPSE_VERTICES,
            gather_rays: 0,
            gather_near: 0.0,
        }
    }
}

/// What final gathering traces its rays through, besides the maps.
#[derive(Clone, Copy)]
pub struct GatherScene<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its Embree scene.
    pub embree: &'a embree::Scene,
    /// Most mirror and glass bounces of a gather ray (the camera paths' limit).
    pub max_depth: u32,
    /// Seed of the gather directions (the render's).
    pub seed: u64,
    /// Direct light at the hits of gather rays that land close by, which then go a bounce
    /// further ([`crate::estimate::final_gather::NearGather`]).
    pub direct: &'a dyn DirectAt,
}

// An inherent impl outside `photons`: choosing estimators is this module's concern, and the
// photon maps know nothing of estimators.
impl PhotonMaps {
    /// The estimators of a render: [`PhotonMaps::estimators`], or with final gathering
    /// (`settings.gather_rays > 0`) the caustic map's estimator and [`FinalGather`] over the
    /// radiance map, whose absence is then an error.
    pub fn estimators_for<'a>(
        &'a self,
        settings: &EstimatorSettings,
        at: GatherScene<'a>,
    ) -> Result<Vec<Box<dyn RadianceEstimator + 'a>>, String> {
        let mut estimators = self.estimators(settings);
        if settings.gather_rays == 0 || estimators.is_empty() {
            return Ok(estimators);
        }
        let map = self.radiance.as_ref().ok_or(
            "final gathering needs the radiance map, which only traced photon maps hold \
             (not photon-map files)",
        )?;
        estimators.truncate(1);
        estimators.push(Box::new(FinalGather {
            scene: at.scene,
            embree: at.embree,
            map,
            rays: settings.gather_rays,
            max_depth: at.max_depth,
            seed: at.seed,
            epsilon: at.scene.ray_epsilon(),
            near: (settings.gather_near > 0.0).then_some(NearGather {
                direct: at.direct,
                caustic: &self.caustic,
                reach: settings.gather_near,
                rays: NEAR_RAYS,
            }),
        }));
        Ok(estimators)
    }

    /// The estimators over both maps (none for [`EstimatorKind::Direct`]).
    pub fn estimators(&self, settings: &EstimatorSettings) -> Vec<Box<dyn RadianceEstimator + '_>> {
        [&self.caustic, &self.global]
            .into_iter()
            .filter_map(|map| settings.estimator_over(map))
            .collect()
    }
}

impl EstimatorSettings {
    /// The estimate over one photon map (`None` for a kind that reads none). The one place
    /// where an estimator kind becomes its estimator.
    pub fn estimator_over<'a>(
        &self,
        map: &'a PhotonMap,
    ) -> Option<Box<dyn RadianceEstimator + 'a>> {
        Some(match self.kind {
            EstimatorKind::Direct | EstimatorKind::Lighttrace => return None,
            EstimatorKind::Jensen => Box::new(JensenEstimate {
                map,
                k: self.k,
                max_radius: self.max_radius,
            }),
            EstimatorKind::Pd => Box::new(PhotonDifferentialEstimate { map }),
            EstimatorKind::Coplanar => Box::new(CoplanarEstimate {
                map,
                ellipse_vertices: self.ellipse_vertices,
            }),
            EstimatorKind::Integrated => Box::new(IntegratedEstimate { map }),
            EstimatorKind::Multisampled => Box::new(MultiSampledEstimate::new(map, self.ms_grid)),
        })
    }
}
