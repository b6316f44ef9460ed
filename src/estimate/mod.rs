//! Radiance estimates from photon maps, behind one interface: every estimator answers the
//! radiance reflected towards the camera at a diffuse hit, given the hit's view footprint.
//!
//! Each estimator is one file: [`jensen`] (k nearest photons), [`pd`] (photon differentials),
//! [`coplanar`], [`multisampled`] and [`integrated`] (photon differentials with the view
//! footprint); [`final_gather`] reads indirect light through gather rays instead of the global
//! map. [`select`] turns the command line's choice into estimators over the photon maps.
//!
//! Adding an estimator: its file here (a type implementing [`RadianceEstimator`]) and its
//! `pub mod` line; its variant of [`EstimatorKind`] (clap lists it in `--help` from the doc
//! comment) and its arm in [`EstimatorSettings::estimator_over`]; its label in
//! `reference::experiment::Method::label`; its line in README's `--estimator` row
//! (`tests/cli_docs.rs` checks). The compiler finds every match that must decide for it:
//! those two, [`EstimatorKind`]'s properties (whether it reads the maps and the footprints,
//! whether its passes converge), its defaults (`render::defaults::RenderDefaults::
//! for_estimator`) and its default passes (`cli/render/checks.rs`). The tests that mean
//! every estimator loop over [`EstimatorKind::over_maps`] and take it unnamed: power conserved
//! (`tests/every_estimator.rs`), no NaN or negative pixel and a packet answered as its gathers
//! one by one (`tests/view_estimators.rs`), random scenes (`tests/fuzz.rs`), the stress scenes
//! against a reference (`tests/stability.rs`), any unit of length (`tests/photon_maps.rs`).
//! Benchmarks name their rows: the timing table's are the thesis's.

pub mod coplanar;
pub mod exact_footprint;
pub mod final_gather;
pub mod integrated;
pub mod jensen;
pub mod multisampled;
pub mod pd;
pub mod select;

pub use coplanar::CoplanarEstimate;
pub use exact_footprint::{ExactFootprint, FootprintRequest};
pub use final_gather::FinalGather;
pub use integrated::IntegratedEstimate;
pub use jensen::JensenEstimate;
pub use multisampled::MultiSampledEstimate;
pub use pd::PhotonDifferentialEstimate;
pub use select::{EstimatorKind, EstimatorSettings};

use crate::photons::cover::OFF_PLANE_TOLERANCE;
pub use crate::photons::cover::{same_side, MIN_NORMAL_COSINE};
use crate::photons::map::{Flux, Photon};
use glam::{DVec3, Vec3};
use serde::Serialize;

/// A diffuse hit as the estimators see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GatherQuery {
    /// The hit point.
    pub position: DVec3,
    /// Unit geometric normal facing the viewer.
    pub normal: DVec3,
    /// Diffuse albedo (the BRDF is `albedo / pi`).
    pub albedo: DVec3,
    /// The camera ray's footprint at the hit: the parallelogram `x +- f[0]/2 +- f[1]/2`.
    pub footprint: [DVec3; 2],
    /// The exact view footprint where it is known: the quadrilateral of the pixel's (or
    /// cell's) corner rays on the hit's tangent plane, for hits seen directly
    /// ([`ExactFootprint`]). Neighbouring pixels on one plane share these corners, so their
    /// footprints tile it; the parallelogram `footprint` is their first-order approximation.
    /// Only estimators that integrate the view footprint read it.
    pub exact: Option<ExactFootprint>,
}

/// What gathering cost, for the statistics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct GatherCounts {
    /// Estimates computed.
    pub gathers: u64,
    /// Photons returned by the map queries.
    pub photons_found: u64,
    /// Photons that contributed (inside their kernel's support, on the right side).
    pub photons_used: u64,
    /// Final-gather estimates computed (not counted in `gathers`, which are photon-map
    /// queries).
    pub final_gathers: u64,
    /// Rays traced by final gathering (each segment through mirrors and glass counts).
    pub gather_rays: u64,
    /// Gather rays that landed close by and went a bounce further (`--gather-near`).
    pub near_gathers: u64,
    /// Gathers (counted in `gathers`) that integrated over the exact view footprint
    /// ([`GatherQuery::exact`]) rather than its first-order parallelogram.
    pub exact_footprints: u64,
}

impl GatherCounts {
    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &GatherCounts) {
        self.gathers += other.gathers;
        self.photons_found += other.photons_found;
        self.photons_used += other.photons_used;
        self.final_gathers += other.final_gathers;
        self.gather_rays += other.gather_rays;
        self.near_gathers += other.near_gathers;
        self.exact_footprints += other.exact_footprints;
    }
}

/// A radiance estimate from a photon map.
pub trait RadianceEstimator: Sync {
    /// Radiance reflected towards the camera at `query`.
    fn radiance(&self, query: &GatherQuery, counts: &mut GatherCounts) -> DVec3;

    /// Whether the estimate integrates over the view footprint (rather than reading one point).
    /// A jittered camera ray then gathers over its cell's own footprint, centred where the
    /// cell's centre would be: the jitter serves visibility and direct light, and the
    /// footprint stays the box filter's (see `render::passes`).
    fn integrates_view_footprint(&self) -> bool {
        false
    }

    /// Whether the estimate reads [`GatherQuery::exact`]; the render loop prepares the exact
    /// footprint only when some estimator does.
    fn reads_exact_footprint(&self) -> bool {
        false
    }

    /// [`RadianceEstimator::radiance`] for a query that stands for `share` (in `(0, 1]`) of
    /// what a cell of the view grid stands for: 1 for those, less for a cell of a pixel split
    /// finer at a geometric edge (`render::edges`). An estimator that samples (final gathering)
    /// spends that share of its samples; one that reads the maps answers as for any query.
    fn radiance_share(&self, query: &GatherQuery, _share: f64, counts: &mut GatherCounts) -> DVec3 {
        self.radiance(query, counts)
    }

    /// [`RadianceEstimator::radiance_share`] for each of `queries` with its share, into `out`
    /// (as long as `queries`). The render loop asks for a packet's gathers at once, so that an
    /// estimator that evaluates photons in SIMD lanes (`integrated`) fills its lanes across
    /// gathers rather than padding each gather's few photons to a whole batch.
    fn radiance_batch(
        &self,
        queries: &[GatherQuery],
        shares: &[f64],
        out: &mut [DVec3],
        counts: &mut GatherCounts,
    ) {
        debug_assert!(queries.len() == shares.len() && queries.len() == out.len());
        for ((q, &share), o) in queries.iter().zip(shares).zip(out) {
            *o = self.radiance_share(q, share, counts);
        }
    }
}

/// One query's answer through [`RadianceEstimator::radiance_batch`], for the estimators whose
/// batch is their real implementation (a batch of one, share 1).
pub(crate) fn batch_of_one<E: RadianceEstimator + ?Sized>(
    estimator: &E,
    q: &GatherQuery,
    counts: &mut GatherCounts,
) -> DVec3 {
    let mut out = [DVec3::ZERO];
    estimator.radiance_batch(std::slice::from_ref(q), &[1.0], &mut out, counts);
    out[0]
}

/// Whether photon `p`, at offset `v = x - x_p` from a query of normal `n_x`, lies on the query's
/// surface: facing the same way, and off the photon's tangent plane by at most a tenth of its
/// radius. Shared by every footprint-based estimator.
#[inline]
pub fn on_query_surface(p: &Photon, v: Vec3, n_x: Vec3) -> bool {
    same_side(p.normal, n_x) && p.normal.dot(v).abs() <= OFF_PLANE_TOLERANCE * p.radius
}

/// `Phi_p / A_p K(|M_p v|)` for a photon at offset `v = x - x_p`, or `None` outside its
/// support or on the wrong side.
#[inline]
pub fn photon_kernel(p: &Photon, v: Vec3, n_x: Vec3) -> Option<Vec3> {
    if !on_query_surface(p, v, n_x) {
        return None;
    }
    let s0 = p.m[0].dot(v);
    let s1 = p.m[1].dot(v);
    kernel(&Flux::of(p), s0 * s0 + s1 * s1)
}

/// `Phi / A K(r)` for a photon of flux `p` at squared filter-space distance `r2 = |M v|^2`
/// (Epanechnikov, `K = (2/pi)(1 - r^2)`), or `None` outside its support: the one scalar spelling
/// of the kernel (`pd` and `coplanar` evaluate it; `multisampled`'s and `integrated`'s SIMD
/// lanes write it in their own batches).
#[inline(always)]
pub fn kernel(p: &Flux, r2: f32) -> Option<Vec3> {
    (r2 < 1.0).then(|| p.power * (p.inv_area * std::f32::consts::FRAC_2_PI * (1.0 - r2)))
}
