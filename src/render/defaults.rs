//! The default render's settings (`integrated`, what `make render` and a bare `photondiff
//! render` give) beside the thesis's estimators' (which keep `PhotonOptions::default()`'s
//! photons and one shadow ray, so that they render as they did): one place for the command
//! line, the benchmarks and the experiments to take them from.

use crate::estimate::EstimatorKind;
use crate::photons::options::PhotonOptions;
use crate::render::passes::StopRules;

/// Passes of the default estimator, `integrated`: chosen so that `make render` stays
/// interactive (README, "Progressive passes").
pub const DEFAULT_PASSES: u64 = 2;

/// Caustic photons per pass of the default estimator, `integrated` (the others default to the
/// thesis's 20,000): the default render's caustic error is mostly its photons' noise and the
/// bias of their footprints, both of which more photons per pass cut. 60,000 keeps the default
/// within 3x Regular 1x1's whole-process time with a margin (stop 31, alternated, median of 9:
/// 2.86x against 3.06x with 70,000, which missed the target in three runs that day; floor 2.99%
/// -> 3.40%, caustic 2.72% -> 3.13%, contour 1.02% -> 1.19%, all far inside their targets;
/// README, "The default"). Cutting the global photons instead would save as much, but
/// final gathering's radiance map takes its photon count from the same default.
pub const DEFAULT_CAUSTIC_PHOTONS: usize = 60_000;

/// Shadow rays per point or spot light, along each axis, over the footprint of a directly seen
/// hit for the default estimator, `integrated` ([`crate::render::direct_light`]; 1 for the
/// others): its two passes otherwise sample a pixel's direct light at two points, and at a
/// shadow's edge, dark and lit within one pixel, that was a large part of the error in the
/// sphere's shadow (README, "The default").
pub const DEFAULT_FOOTPRINT_SHADOW_RAYS: u32 = 2;

/// Cells per axis of a pixel on a geometric edge when final gathering is on (`--edge-grid`,
/// [`crate::render::edges`]; 1, off, without it): a gathering pixel costs tens of gather rays,
/// so splitting the few edge pixels (under 2% of the closed scene's) costs about 4% of the
/// whole, and it takes the closed scene's floor over all its pixels from 6.08% to 5.24% (README,
/// "The closed scene").
pub const DEFAULT_GATHER_EDGE_GRID: u32 = 4;

/// Cells per axis of a pixel on a geometric edge for a long run of the default estimator,
/// `integrated` (`--time-budget`, `--target-noise` or more than [`DEFAULT_PASSES`] passes,
/// without final gathering; 1, off, for the default's two passes and for the other
/// estimators). One camera ray a pass takes the whole pixel's footprint on whichever surface it
/// meets, so a pixel over an occluding edge integrates light the edge hides: a bias no number of
/// passes removes (17% at the worst pixel of `over-an-edge` after 150 passes; README, "Error
/// against time"). The edge pixels are found once a run ([`crate::render::edges::EdgeMask`]),
/// so a long run pays for the edge pixels' cells alone. Every cell of a pass takes the pass's
/// jitter, so an edge pixel is integrated on a shifted grid whose error at the edge depends on
/// the shift: with 4 x 4 cells that error, the same for every seed, made the early passes'
/// error rise and fall by a third on over-an-edge's contour once the global map's noise there
/// was gone (aimed emissions, stop 30); 8 x 8 halves it (README, "Error against time").
pub const LONG_RUN_EDGE_GRID: u32 = 8;

/// Global photons asked for per pass of the default estimator, `integrated` (the others ask for
/// the thesis's 100,000): in an open scene almost every global emission is wasted (the
/// canonical scene stores one in 250 with aimed bounces), and half as many emissions with
/// footprints `sqrt 2` wider serve the sphere's shadow as well (shadow 21.0% -> 21.6%, its mean
/// x0.984 -> x0.999) for 8% less time; a closed scene's global map, seen directly, gets
/// blurrier by as much (README, "The default").
pub const DEFAULT_GLOBAL_PHOTONS: usize = 50_000;

/// Share of the global photons' diffuse bounces aimed at the specular objects for the default
/// estimator, `integrated` (`--global-aim`; 0 for the others, whose photon maps stay the
/// thesis's): in the canonical scene it carries the floor -> sphere -> floor light of the
/// sphere's shadow with some 1,600 photons a pass instead of 250 (README, "Photon maps").
pub const DEFAULT_GLOBAL_AIM: f64 = 0.15;

/// Whether the default render's photons probe their footprints for walls and edges
/// ([`crate::photons::walls`]; `--probe-walls`): on for `integrated`, off for the others,
/// whose photon maps stay the thesis's. It removes the dark band a footprint's radius wide
/// along walls and edges (on the over-an-edge stress scene, most of the caustic's error after
/// 64 passes), for one packet of 16 rays a photon and a mirror photon for those near a wall.
pub const DEFAULT_PROBE_WALLS: bool = true;

/// Where the default render (`integrated`) differs from the thesis's estimators, which keep
/// `PhotonOptions::default()`'s photons and one shadow ray so that they render as they did.
/// The command line, the benchmarks and the experiments take their defaults from here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderDefaults {
    /// Caustic photons per pass.
    pub caustic_photons: usize,
    /// Global photons asked for per pass.
    pub global_photons: usize,
    /// Share of the global photons' diffuse bounces aimed at the specular objects.
    pub global_aim: f64,
    /// Whether photons probe their footprints for walls and edges.
    pub probe_walls: bool,
    /// Footprint shadow rays per point light, along each axis.
    pub footprint_strata: u32,
    /// Edge grid of a long progressive run without final gathering ([`LONG_RUN_EDGE_GRID`]).
    long_run_edge_grid: u32,
}

impl RenderDefaults {
    /// The defaults of a render with `kind`: the default render's for `integrated`, the
    /// thesis's for the others.
    pub fn for_estimator(kind: EstimatorKind) -> Self {
        let thesis = PhotonOptions::default();
        match kind {
            EstimatorKind::Integrated => RenderDefaults {
                caustic_photons: DEFAULT_CAUSTIC_PHOTONS,
                global_photons: DEFAULT_GLOBAL_PHOTONS,
                global_aim: DEFAULT_GLOBAL_AIM,
                probe_walls: DEFAULT_PROBE_WALLS,
                footprint_strata: DEFAULT_FOOTPRINT_SHADOW_RAYS,
                long_run_edge_grid: LONG_RUN_EDGE_GRID,
            },
            // Every kind named, so that a new estimator is given its defaults, not these by
            // default.
            EstimatorKind::Direct
            | EstimatorKind::Jensen
            | EstimatorKind::Pd
            | EstimatorKind::Coplanar
            | EstimatorKind::Multisampled
            | EstimatorKind::Lighttrace => RenderDefaults {
                caustic_photons: thesis.caustic_photons,
                global_photons: thesis.global_photons,
                global_aim: thesis.global_aim,
                probe_walls: thesis.probe_walls,
                footprint_strata: 1,
                long_run_edge_grid: 1,
            },
        }
    }

    /// The edge grid of a render with `gather_rays` gather rays that stops by `stop`:
    /// [`DEFAULT_GATHER_EDGE_GRID`] with final gathering, this estimator's long-run grid
    /// ([`LONG_RUN_EDGE_GRID`] for `integrated`) in a long run ([`StopRules::is_long`]), else 1
    /// (off). `--edge-grid` overrides it.
    pub fn edge_grid(&self, gather_rays: u32, stop: &StopRules) -> u32 {
        if gather_rays > 0 {
            DEFAULT_GATHER_EDGE_GRID
        } else if stop.is_long() {
            self.long_run_edge_grid
        } else {
            1
        }
    }

    /// `photons` with these photon counts, aim and wall probes.
    pub fn photons(&self, photons: PhotonOptions) -> PhotonOptions {
        PhotonOptions {
            caustic_photons: self.caustic_photons,
            global_photons: self.global_photons,
            global_aim: self.global_aim,
            probe_walls: self.probe_walls,
            ..photons
        }
    }
}
