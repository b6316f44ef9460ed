//! The BVH options every command that traces rays takes (`render`, `photons`, `reference`),
//! and the build behind a progress bar.

use photondiff::embree::{self, BvhQuality, BvhSettings, Device};
use photondiff::scene::Scene;
use std::path::Path;

// The options' help, `info` and the README say "4,000,000" in words.
const _: () = assert!(embree::COMPACT_FROM_TRIANGLES == 4_000_000);

/// How Embree builds the scene's BVH: the trade between build time, memory and tracing speed
/// (README, "Memory and large meshes"). Images do not depend on it.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct BvhArgs {
    /// Embree's BVH build quality: `medium` (the default: binned SAH), `high` (spatial splits:
    /// a build two to three times longer, for long renders of large meshes) or `low` (fastest
    /// build, slower tracing).
    #[arg(long, value_enum, default_value_t = BvhQuality::Medium)]
    bvh_quality: BvhQuality,
    /// Embree's compact BVH (`RTC_SCENE_FLAG_COMPACT`): half the BVH's memory at its build's
    /// peak, 10-30% slower tracing. Without this or --no-bvh-compact, scenes of 4,000,000
    /// unique triangles and more get it, smaller ones do not.
    #[arg(long, overrides_with = "no_bvh_compact")]
    bvh_compact: bool,
    /// Embree's ordinary BVH even for scenes of 4,000,000 unique triangles and more: faster
    /// tracing for about twice the memory (see --bvh-compact). Of the two, the last given wins
    /// (a wrapper script's default can be overridden).
    #[arg(long, overrides_with = "bvh_compact")]
    no_bvh_compact: bool,
    /// Embree's robust traversal (`RTC_SCENE_FLAG_ROBUST`): no hits missed on edges and
    /// vertices through traversal shortcuts, somewhat slower tracing.
    #[arg(long)]
    bvh_robust: bool,
}

impl BvhArgs {
    /// Whether `--bvh-robust` was given: a BVH option that can change an image (hits on
    /// edges), recorded in a render's attributes so that `merge` refuses parts that differ
    /// (as the compact BVH is where it can change hits: [`embree::COMPACT_CHANGES_HITS`]).
    pub fn robust(&self) -> bool {
        self.bvh_robust
    }

    /// The settings these options ask for, for a scene of `triangles` unique triangles (which
    /// decides whether the BVH is compact where neither flag says:
    /// [`BvhSettings::for_triangles`]).
    pub fn settings(&self, triangles: u64) -> BvhSettings {
        let compact = match (self.bvh_compact, self.no_bvh_compact) {
            (true, _) => true,
            (_, true) => false,
            _ => BvhSettings::for_triangles(triangles).compact,
        };
        BvhSettings {
            quality: self.bvh_quality,
            compact,
            robust: self.bvh_robust,
        }
    }

    /// Builds `scene`'s BVH (read from `path`) as these options ask ([`build_bvh`]) on at
    /// most `threads` threads (the command's `--threads`; 0 for every core); the device, the
    /// scene and the settings it was built with.
    pub fn build(
        &self,
        scene: &Scene,
        path: &Path,
        threads: usize,
        progress: bool,
    ) -> Result<(Device, embree::Scene, BvhSettings), String> {
        let settings = self.settings(scene.triangle_count());
        let (device, built) = build_bvh(scene, path, settings, threads, progress)?;
        Ok((device, built, settings))
    }
}

/// Builds `scene`'s BVH (read from `path`) with `settings` on a new Embree device of at most
/// `threads` build threads, its progress a bar (`BVH`) when `progress`: a large mesh's build
/// takes seconds to minutes.
fn build_bvh(
    scene: &Scene,
    path: &Path,
    settings: BvhSettings,
    threads: usize,
    progress: bool,
) -> Result<(Device, embree::Scene), String> {
    let device = Device::with_threads(threads).map_err(|e| e.to_string())?;
    let bar = photondiff::util::progress::bar(progress, 1000, "BVH");
    let report = bar.clone();
    // Embree's threads report at once, not always in order: the bar only moves on.
    let built = scene.build_embree_reporting(&device, settings, move |f| {
        let step = (f * 1000.0) as u64;
        if step > report.position() {
            report.set_position(step);
        }
    });
    bar.finish_and_clear();
    let built = built.map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((device, built))
}
