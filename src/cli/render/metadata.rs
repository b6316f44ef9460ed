//! The attributes a render writes into its EXR: what was rendered and how, so that an image
//! says where it came from (`photondiff merge` and `report` read them back).

use super::reads::{reads_attribute, Run};
use super::RenderArgs;
use photondiff::estimate::{EstimatorKind, EstimatorSettings};
use photondiff::photons::options::PhotonOptions;
use photondiff::render::passes::PassReport;
use photondiff::render::stats::Stats;
use photondiff::render::RenderOptions;
use photondiff::scene::hash::hex;

/// What a render's settings were, as `photondiff/...` attributes (with its statistics, and the
/// progressive passes' report where there is one): the settings its estimator reads, no more
/// (`--estimator direct` wrote `photons=100000` and `k`, options its command line refuses).
pub(super) fn exr_metadata(
    args: &RenderArgs,
    run: &Run,
    hash: u64,
    options: &RenderOptions,
    photons: &PhotonOptions,
    settings: &EstimatorSettings,
    stats: &Stats,
) -> Vec<(String, String)> {
    let mut metadata: Vec<(String, String)> = [
        ("scene", args.scene.display().to_string()),
        ("scene_hash", hex(hash)),
        ("view_grid", args.view_grid.to_string()),
        // The grid an edge pixel was rendered on: an edge grid no finer than the view grid is off.
        ("edge_grid", options.edge_grid_used().to_string()),
        ("estimator", run.kind.name()),
        ("photons", photons.global_photons.to_string()),
        ("caustic_photons", photons.caustic_photons.to_string()),
        ("k", settings.k.to_string()),
        ("gather_rays", args.gather_rays.to_string()),
        ("gather_near", args.gather_near.to_string()),
        ("ms_grid", settings.ms_grid.to_string()),
        ("coplanar_vertices", settings.ellipse_vertices.to_string()),
        ("overlap", photons.overlap.to_string()),
        ("global_aim", photons.global_aim.to_string()),
        ("probe_walls", photons.probe_walls.to_string()),
        (
            "footprint_shadow_rays",
            options.footprint_strata.to_string(),
        ),
        ("seed", args.seed.to_string()),
        ("embree", photondiff::embree::BACKEND.to_string()),
        ("bvh_robust", args.bvh.robust().to_string()),
        ("max_depth", args.max_depth.to_string()),
        ("area_samples", args.area_samples.to_string()),
        ("threads", stats.threads.to_string()),
        ("render_seconds", format!("{:.6}", stats.seconds("render"))),
        ("stats", serde_json::to_string(stats).unwrap_or_default()),
    ]
    .into_iter()
    .filter(|(name, _)| reads_attribute(run, name))
    .map(|(name, value)| (format!("photondiff/{name}"), value))
    .collect();
    if run.kind == EstimatorKind::Lighttrace {
        metadata.push((
            "photondiff/light_paths".to_string(),
            stats.light_paths.to_string(),
        ));
    }
    // Only where given: images made before the option, which split every path, merge with
    // those made without it.
    if let Some(n) = args
        .split_depth
        .filter(|_| reads_attribute(run, "split_depth"))
    {
        metadata.push(("photondiff/split_depth".to_string(), n.to_string()));
    }
    // Where the compact BVH can change hits (Embree 4), which BVH made the image: parts of
    // both would merge into an image equal to neither, as with `--bvh-robust`.
    if photondiff::embree::COMPACT_CHANGES_HITS {
        metadata.push((
            "photondiff/bvh_compact".to_string(),
            stats.memory.bvh.compact.to_string(),
        ));
    }
    if let Some(p) = &stats.progressive {
        metadata.extend(
            pass_metadata(p)
                .into_iter()
                .filter(|(name, _)| reads_attribute(run, &name["photondiff/".len()..])),
        );
    }
    metadata
}

/// The EXR attributes of a progressive render.
fn pass_metadata(p: &PassReport) -> Vec<(String, String)> {
    let mut attributes: Vec<(String, String)> = [
        ("passes", p.passes.to_string()),
        ("alpha", p.alpha.to_string()),
        ("global_alpha", p.global_alpha.to_string()),
        ("passes_stopped_by", p.stop.name().to_string()),
    ]
    .into_iter()
    .map(|(name, value)| (format!("photondiff/{name}"), value))
    .collect();
    attributes.extend(p.noise.attributes());
    attributes
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reads(kind: EstimatorKind, gather_rays: u32, attribute: &str) -> bool {
        let run = Run {
            kind,
            gather_rays,
            probe_walls: false,
            one_pass: false,
            passes_given: false,
        };
        reads_attribute(&run, attribute)
    }

    /// Each estimator's attributes name the options it reads: `direct` no photon counts,
    /// `lighttrace` no camera grids, `pd` no `k`.
    #[test]
    fn attributes_name_what_the_estimator_reads() {
        use EstimatorKind::*;
        assert!(!reads(Direct, 0, "photons") && reads(Direct, 0, "max_depth"));
        assert!(!reads(Lighttrace, 0, "view_grid") && !reads(Lighttrace, 0, "caustic_photons"));
        assert!(reads(Pd, 0, "photons") && !reads(Pd, 0, "k") && !reads(Pd, 0, "gather_near"));
        assert!(reads(Pd, 16, "gather_near") && reads(Jensen, 0, "k"));
        assert!(reads(Multisampled, 0, "ms_grid") && !reads(Integrated, 0, "ms_grid"));
        assert!(reads(Coplanar, 0, "coplanar_vertices") && reads(Lighttrace, 0, "seed"));
        assert!(!reads(Direct, 0, "alpha") && !reads(Jensen, 0, "overlap"));
        assert!(reads(Jensen, 0, "alpha") && !reads(Jensen, 0, "global_alpha"));
        assert!(reads(Jensen, 4, "global_alpha") && reads(Pd, 0, "global_alpha"));
        assert!(reads(Direct, 0, "passes") && reads(Direct, 0, "noise_whole"));
    }
}
