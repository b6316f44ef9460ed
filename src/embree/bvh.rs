//! How Embree builds a scene's BVH: its quality and its compact and robust flags, the trade
//! between build time, memory and tracing speed (README, "Memory and large meshes"). Plain
//! settings; [`super::scene`] hands them to Embree.

/// How much time Embree's BVH build spends on the tree's quality (`RTCBuildQuality`): `high`
/// builds slowest and traces fastest (spatial splits), `low` the reverse.
///
/// `medium` is the default (as it is Embree's): on every scene in `scenes/` it builds two to
/// three times faster than `high` and traces as fast, with the same image; `high`'s spatial
/// splits paid only on the 10M-triangle production mesh, 7% faster rendering for a build twice
/// as long, so they pay for renders that take many times the build (README, "Memory and large
/// meshes").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BvhQuality {
    /// Morton-code build: fastest, for scenes traced with few rays.
    Low,
    /// Binned SAH build without spatial splits (photondiff's default).
    #[default]
    Medium,
    /// SAH build with spatial splits: slowest build, fastest tracing on large meshes.
    High,
}

/// How Embree builds the scene's BVH: the trade between build time, memory and tracing speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BvhSettings {
    /// Build quality (`rtcSetSceneBuildQuality`).
    pub quality: BvhQuality,
    /// `RTC_SCENE_FLAG_COMPACT`: a BVH that takes less memory and traces somewhat slower.
    pub compact: bool,
    /// `RTC_SCENE_FLAG_ROBUST`: traversal without the optimisations that can miss hits on
    /// edges and vertices; somewhat slower.
    pub robust: bool,
}

/// From how many unique triangles a scene's BVH is compact unless told otherwise
/// ([`BvhSettings::for_triangles`]). Embree's ordinary BVH peaks at about 120 bytes a triangle
/// during its build (its leaves hold copies of the vertices, and its build references every
/// triangle once more), the compact one at about 55 (its leaves hold indices): at 10^8
/// triangles that is 12 GB against 6 GB. On a 10M-triangle mesh the compact BVH builds
/// faster and traces 10-30% slower, so a single render takes about as long either way.
pub const COMPACT_FROM_TRIANGLES: u64 = 4_000_000;

/// Whether this backend's compact BVH can answer a ray with another hit than its ordinary
/// BVH: Embree 4's answers about 3 rays in a million with the other triangle of a shared edge
/// (a probe of 10^6 rays through both libraries, stop 59: its 16-wide packets); Embree 3's
/// compact and ordinary BVHs agree bit for bit. Where they can differ, a render records
/// which it used, so that `merge` refuses parts of both.
pub const COMPACT_CHANGES_HITS: bool = super::API_VERSION == 4;

impl BvhSettings {
    /// The default settings for a scene of `triangles` unique triangles: `medium` quality,
    /// compact from [`COMPACT_FROM_TRIANGLES`] on, not robust.
    pub fn for_triangles(triangles: u64) -> Self {
        BvhSettings {
            compact: triangles >= COMPACT_FROM_TRIANGLES,
            ..BvhSettings::default()
        }
    }
}

impl std::fmt::Display for BvhSettings {
    /// As the statistics print it: the quality, then the flags set (`medium, compact`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The name `--bvh-quality` takes.
        use clap::ValueEnum;
        let quality = self
            .quality
            .to_possible_value()
            .expect("no variant is skipped");
        f.write_str(quality.get_name())?;
        for (set, name) in [(self.compact, "compact"), (self.robust, "robust")] {
            if set {
                write!(f, ", {name}")?;
            }
        }
        Ok(())
    }
}
