//! Render statistics: time per stage and rays by kind, printed as a summary and written as JSON.

use crate::estimate::GatherCounts;
use crate::photons::footprint::Guards;
use crate::photons::map::PathClass;
use crate::render::passes::PassReport;
use crate::scene::mesh_file::MeshReport;
use serde::Serialize;
use std::time::Instant;

/// Rays traced, by kind. Counted per tile and summed, so counting costs no shared atomics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct RayCounts {
    /// Primary rays from the camera.
    pub camera: u64,
    /// Rays continuing a camera path after a mirror or glass surface.
    pub specular: u64,
    /// Shadow (occlusion) rays towards light samples.
    pub shadow: u64,
}

impl RayCounts {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.specular + self.shadow
    }

    /// Adds `other` into `self`.
    pub fn add(&mut self, other: &RayCounts) {
        self.camera += other.camera;
        self.specular += other.specular;
        self.shadow += other.shadow;
    }
}

/// One timed stage of a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stage {
    /// Name, e.g. "load scene".
    pub name: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Statistics of one run.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Stats {
    /// The Embree backend that traced the rays, e.g. "Embree 4.3.3" (empty when not recorded).
    pub embree: String,
    /// Timed stages in order.
    pub stages: Vec<Stage>,
    /// Rays by kind.
    pub rays: RayCounts,
    /// Rays Embree could not take (NaN, infinite, huge) and that were treated as misses.
    pub invalid_rays: u64,
    /// Camera paths cut by the specular depth limit.
    pub paths_cut_at_max_depth: u64,
    /// Pixels rendered on the edge grid (on a geometric edge), summed over passes.
    pub edge_pixels: u64,
    /// Threads used for rendering.
    pub threads: usize,
    /// The photon maps traced.
    pub photon_maps: Vec<MapStats>,
    /// Photon map gathers.
    pub gathers: GatherCounts,
    /// Light paths traced by the light-tracing reference.
    pub light_paths: u64,
    /// Rays traced by the light-tracing reference (path segments and camera connections).
    pub light_rays: u64,
    /// The reference's estimated relative noise over its lit pixels, from its two halves.
    pub reference_noise: f64,
    /// `photondiff reference`'s relative noise per region of the image, from its halves
    /// (absent from other commands' statistics).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub reference_regions: Vec<RegionNoise>,
    /// Progressive passes: how many, why they stopped, the noise estimate (absent for the
    /// light tracer).
    pub progressive: Option<PassReport>,
    /// What loading the scene's mesh files dropped or repaired, over all meshes.
    pub mesh_repairs: MeshReport,
    /// Memory: the meshes, Embree's BVH and the process's peak.
    pub memory: MemoryStats,
}

/// A reference's relative noise over one region of its image ([`Stats::reference_regions`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionNoise {
    /// The region: "floor", "caustic", "contour" or "shadow" (`reference::metrics::Regions`).
    pub name: String,
    /// Its pixels.
    pub pixels: u64,
    /// `sqrt(mean((A - B)^2) / 4) / mean(R)` over them; `None` (JSON `null`) for an empty region.
    pub relative_noise: Option<f64>,
}

/// Where the memory went (bytes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct MemoryStats {
    /// Triangles in memory (each instanced mesh counted once).
    pub triangles: u64,
    /// Triangles placed in the scene (each instance counted): what the rays see.
    pub placed_triangles: u64,
    /// Mesh buffers (positions, normals, indices), shared between the scene and Embree.
    pub mesh_bytes: u64,
    /// What Embree has allocated after the build (its BVH), from its memory monitor: blocks
    /// reserved, some never written (so never resident): see `bvh_resident_bytes`.
    pub bvh_bytes: u64,
    /// The most Embree had allocated at once during the build (the BVH and the builder's
    /// temporaries), from its memory monitor.
    pub bvh_build_peak_bytes: u64,
    /// Resident memory the build added and kept (the BVH as the process holds it): the
    /// process's resident memory after the build less before it.
    pub bvh_resident_bytes: u64,
    /// The most resident memory the build added at once (the BVH and the builder's
    /// temporaries); `None` (JSON `null`) where the kernel's peak could not be restarted.
    pub bvh_build_resident_peak_bytes: Option<u64>,
    /// How Embree built the BVH (quality, compact, robust).
    pub bvh: crate::embree::BvhSettings,
    /// The process's peak resident memory (`VmHWM`) at the end of the run.
    pub peak_resident_bytes: u64,
    /// `peak_resident_bytes / triangles`.
    pub peak_bytes_per_triangle: f64,
}

impl MemoryStats {
    /// The memory of `scene`'s meshes and of the BVH Embree built for it on `device` with
    /// `bvh`, `mark` taken just before the build; the peak resident memory is left for
    /// [`Self::record_peak`] at the end of the run.
    pub fn after_build(
        scene: &crate::scene::Scene,
        device: &crate::embree::Device,
        bvh: crate::embree::BvhSettings,
        mark: crate::util::memory::ResidentMark,
    ) -> Self {
        let embree = device.memory();
        Self {
            triangles: scene.triangle_count(),
            placed_triangles: scene.placed_triangle_count(),
            mesh_bytes: scene.mesh_bytes(),
            bvh_bytes: embree.current,
            bvh_build_peak_bytes: embree.peak,
            bvh_resident_bytes: mark.added(),
            bvh_build_resident_peak_bytes: mark.most_added(),
            bvh,
            ..Self::default()
        }
    }

    /// The statistics' memory line (without its indent): the peak, per triangle, and where it
    /// went.
    pub fn summary(&self) -> String {
        let mb = |b: u64| b as f64 / 1e6;
        let build_peak = match self.bvh_build_resident_peak_bytes {
            Some(b) => format!("{:.1} MB resident, ", mb(b)),
            None => String::new(),
        };
        format!(
            "memory: peak resident {:.1} MB ({:.0} bytes/triangle over {} unique triangles, \
             {} placed); meshes {:.1} MB, Embree BVH {:.1} MB resident, {:.1} MB allocated ({}; \
             build peak {build_peak}{:.1} MB allocated)",
            mb(self.peak_resident_bytes),
            self.peak_bytes_per_triangle,
            self.triangles,
            self.placed_triangles,
            mb(self.mesh_bytes),
            mb(self.bvh_resident_bytes),
            mb(self.bvh_bytes),
            self.bvh,
            mb(self.bvh_build_peak_bytes)
        )
    }

    /// Records the process's peak resident memory now (call at the end of the run).
    pub fn record_peak(&mut self) {
        self.peak_resident_bytes = crate::util::memory::peak_resident_bytes();
        self.peak_bytes_per_triangle = if self.triangles > 0 {
            self.peak_resident_bytes as f64 / self.triangles as f64
        } else {
            0.0
        };
    }
}

/// How one photon map was made.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapStats {
    /// Which paths it holds.
    pub class: PathClass,
    /// Emissions traced.
    pub emitted: u64,
    /// Photons stored.
    pub stored: u64,
    /// Rays traced for it.
    pub rays: u64,
    /// Total stored power (mean over channels, W).
    pub power: f64,
    /// Guarded footprints.
    pub guards: Guards,
    /// Photons asked for.
    pub asked: u64,
    /// Whether emission stopped at its cap ([`crate::photons::trace::emission_cap`]), or a
    /// caustic map early with none stored ([`crate::photons::trace::emission_stopped`]), with
    /// fewer photons stored than asked for.
    pub cap_reached: bool,
}

impl MapStats {
    /// Whether emission stopped before its cap, with none stored
    /// ([`crate::photons::trace::EMPTY_CAUSTIC_SHARE`]).
    fn stopped_early(&self) -> bool {
        // Only a caustic map stops before its cap, and only with none stored.
        self.cap_reached
            && self.class == crate::photons::map::PathClass::Caustic
            && self.stored == 0
    }

    /// Why the cap came first: "rarely" only where fewer than half the photons were stored (a
    /// map 97% full was told its scene rarely stores such photons); nearer to full, how many
    /// emissions a stored photon took, against the cap's emissions a photon.
    fn why_short(&self) -> String {
        if self.stored == 0 || self.stored.saturating_mul(2) < self.asked {
            return "this scene rarely stores such photons".into();
        }
        let per_stored = self.emitted as f64 / self.stored as f64;
        let per_asked = self.emitted as f64 / self.asked.max(1) as f64;
        format!(
            "this scene stores one such photon in {per_stored:.1} emissions, the cap allows \
             {per_asked:.1}"
        )
    }

    /// What to tell the user when the map holds fewer photons than asked for, if it does.
    pub fn shortfall(&self) -> Option<String> {
        self.cap_reached.then(|| {
            format!(
                "{} map: {} of {} photons stored: emission stopped {} {} emissions; {}",
                self.class.name(),
                self.stored,
                self.asked,
                match self.stopped_early() {
                    true => "with none stored after",
                    false => "at its cap of",
                },
                self.emitted,
                self.why_short(),
            )
        })
    }
}

impl Stats {
    /// Empty statistics of a run on this build's Embree ([`crate::embree::BACKEND`]).
    pub fn of_this_build() -> Self {
        Self {
            embree: crate::embree::BACKEND.to_string(),
            ..Self::default()
        }
    }

    /// Runs `f`, recording its wall-clock time as stage `name`.
    pub fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let _span = crate::util::trace::span(name.to_string());
        let start = Instant::now();
        let out = f();
        self.stages.push(Stage {
            name: name.to_string(),
            seconds: start.elapsed().as_secs_f64(),
        });
        out
    }

    /// [`Stats::time`] for a stage that recurs (once a pass): its seconds add to the stage of
    /// that name, which keeps its first place among the stages.
    pub fn time_summed<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let mut once = Stats::default();
        let out = once.time(name, f);
        self.absorb_stages(once.stages);
        out
    }

    /// Adds `stages` to this run's, by name.
    fn absorb_stages(&mut self, stages: Vec<Stage>) {
        for stage in stages {
            match self.stages.iter_mut().find(|s| s.name == stage.name) {
                Some(s) => s.seconds += stage.seconds,
                None => self.stages.push(stage),
            }
        }
    }

    /// Seconds spent in stage `name` (0 if absent).
    pub fn seconds(&self, name: &str) -> f64 {
        self.stages
            .iter()
            .filter(|s| s.name == name)
            .map(|s| s.seconds)
            .sum()
    }

    /// Adds one progressive pass's statistics: stages add up by name, counts add up, and photon
    /// maps add up by class (their power too, until [`Stats::finish_passes`] averages it).
    pub fn absorb_pass(&mut self, pass: Stats) {
        self.absorb_stages(pass.stages);
        self.rays.add(&pass.rays);
        self.invalid_rays += pass.invalid_rays;
        self.paths_cut_at_max_depth += pass.paths_cut_at_max_depth;
        self.edge_pixels += pass.edge_pixels;
        self.threads = self.threads.max(pass.threads);
        self.gathers.add(&pass.gathers);
        for map in pass.photon_maps {
            match self.photon_maps.iter_mut().find(|m| m.class == map.class) {
                Some(m) => {
                    m.emitted += map.emitted;
                    m.stored += map.stored;
                    m.rays += map.rays;
                    m.power += map.power;
                    m.guards.add(&map.guards);
                    m.asked += map.asked;
                    m.cap_reached |= map.cap_reached;
                }
                None => self.photon_maps.push(map),
            }
        }
    }

    /// After `passes` passes were absorbed: map powers become the mean over the passes (the
    /// other map counts stay totals).
    pub fn finish_passes(&mut self, passes: u64) {
        for m in &mut self.photon_maps {
            m.power /= passes.max(1) as f64;
        }
    }

    /// A human-readable summary.
    pub fn summary(&self) -> String {
        let mut out = String::from("statistics:\n");
        for s in &self.stages {
            out += &format!("  {:<20} {:>10.3} s\n", s.name, s.seconds);
        }
        if !self.embree.is_empty() {
            out += &format!("  ray queries: {}\n", self.embree);
        }
        if let Some(w) = self.mesh_repairs.warning() {
            out += &format!("  meshes: {w}\n");
        }
        if self.memory.peak_resident_bytes > 0 {
            out += &format!("  {}\n", self.memory.summary());
        }
        let render = self.seconds("render");
        let r = &self.rays;
        out += &format!(
            "  rays: {} camera, {} specular, {} shadow, {} invalid\n",
            r.camera, r.specular, r.shadow, self.invalid_rays
        );
        // Final gathering's rays are traced in the render stage too: left out, a render
        // gathering 64 rays a pixel read 0.10 M rays/s where it traced 0.61 M.
        let traced = r.total() + self.gathers.gather_rays;
        if render > 0.0 && traced > 0 {
            let gathering = match self.gathers.gather_rays {
                0 => String::new(),
                _ => ", final gathering's rays included".to_string(),
            };
            out += &format!(
                "  {:.2} M rays/s over {} threads ({:.2} M camera rays/s{gathering})\n",
                traced as f64 / render / 1e6,
                self.threads,
                r.camera as f64 / render / 1e6
            );
        }
        for m in &self.photon_maps {
            let cap = match (m.cap_reached, m.stopped_early()) {
                (true, true) => {
                    format!(" (of {} asked: emission stopped with none stored)", m.asked)
                }
                (true, false) => format!(" (of {} asked: emission stopped at its cap)", m.asked),
                _ => String::new(),
            };
            out += &format!(
                "  {} map: {} photons stored{cap} from {} emissions ({} rays), power {} W; \
                 guarded footprints: {} clamped small, {} clamped large, {} anisotropy, {} fallback; \
                 {} mirrored at walls and edges\n",
                capitalised(m.class.name()),
                m.stored,
                m.emitted,
                m.rays,
                watts(m.power),
                m.guards.clamped_min,
                m.guards.clamped_max,
                m.guards.clamped_anisotropy,
                m.guards.fallback,
                m.guards.mirrored
            );
        }
        let g = &self.gathers;
        if g.gathers > 0 {
            out += &format!(
                "  {} gathers, {:.1} photons found and {:.1} used per gather, {} over exact view footprints\n",
                g.gathers,
                g.photons_found as f64 / g.gathers as f64,
                g.photons_used as f64 / g.gathers as f64,
                g.exact_footprints
            );
        }
        if g.gather_rays > 0 {
            out += &format!(
                "  final gathering: {} gathers, {} rays ({:.1} per gather), {} gather rays landed close by and went a bounce further\n",
                g.final_gathers,
                g.gather_rays,
                g.gather_rays as f64 / g.final_gathers.max(1) as f64,
                g.near_gathers
            );
        }
        if self.light_paths > 0 {
            out += &format!(
                "  light tracing: {} paths, {} rays, estimated relative noise {:.4} over lit pixels\n",
                self.light_paths, self.light_rays, self.reference_noise
            );
        }
        if let Some(p) = &self.progressive {
            // The footprints' schedule, where there are photon maps (`direct` has none).
            let schedule = if self.photon_maps.is_empty() {
                String::new()
            } else {
                format!(
                    ", alpha {:.3} (global {:.3}), last caustic footprint area factor {:.4}",
                    p.alpha, p.global_alpha, p.last_area_factor
                )
            };
            out += &format!(
                "  progressive: {} ({:.3} s each, stopped by {}){schedule}; noise of the mean {}\n",
                p.describe_passes(),
                p.seconds_per_pass,
                p.stop.words(),
                p.noise.describe()
            );
        }
        if self.edge_pixels > 0 {
            out += &format!(
                "  {} pixels on geometric edges rendered on the edge grid\n",
                self.edge_pixels
            );
        }
        if self.paths_cut_at_max_depth > 0 {
            out += &format!(
                "  {} camera paths cut at the maximum specular depth\n",
                self.paths_cut_at_max_depth
            );
        }
        out
    }
}

/// `s` with its first letter in upper case.
fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// A power as the summary prints it: four decimals where that shows it, else four significant
/// digits in exponent form (a scene in micrometres stored "0.0000 W", one in light years
/// "1124623596912640000.0000 W").
fn watts(power: f64) -> String {
    if power == 0.0 || (1e-2..1e6).contains(&power.abs()) {
        format!("{power:.4}")
    } else {
        format!("{power:.3e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rate divides every ray the render stage traced by its time: final gathering's too.
    #[test]
    fn the_ray_rate_counts_final_gathering() {
        let mut stats = Stats {
            threads: 2,
            stages: vec![Stage {
                name: "render".into(),
                seconds: 2.0,
            }],
            rays: RayCounts {
                camera: 400_000,
                specular: 100_000,
                shadow: 500_000,
            },
            ..Stats::default()
        };
        let rate = |s: &Stats| {
            s.summary()
                .lines()
                .find(|l| l.contains("M rays/s"))
                .unwrap()
                .trim()
                .to_string()
        };
        assert_eq!(
            rate(&stats),
            "0.50 M rays/s over 2 threads (0.20 M camera rays/s)"
        );
        stats.gathers.gather_rays = 3_000_000;
        stats.gathers.final_gathers = 1000;
        assert_eq!(
            rate(&stats),
            "2.00 M rays/s over 2 threads (0.20 M camera rays/s, final gathering's rays included)"
        );
    }

    /// A map cut short by its cap is told its scene "rarely" stores such photons only where
    /// fewer than half were stored; a nearly full one is given the rates.
    #[test]
    fn a_nearly_full_map_is_not_told_its_scene_rarely_stores_photons() {
        let map = |stored| MapStats {
            class: PathClass::Global,
            emitted: 400_000,
            stored,
            rays: 0,
            power: 0.0,
            guards: Guards::default(),
            asked: 100_000,
            cap_reached: true,
        };
        assert_eq!(
            map(97_000).shortfall().unwrap(),
            "global map: 97000 of 100000 photons stored: emission stopped at its cap of 400000 \
             emissions; this scene stores one such photon in 4.1 emissions, the cap allows 4.0"
        );
        assert!(map(49_999)
            .shortfall()
            .unwrap()
            .ends_with("400000 emissions; this scene rarely stores such photons"));
        assert!(map(0)
            .shortfall()
            .unwrap()
            .ends_with("rarely stores such photons"));
        let full = MapStats {
            cap_reached: false,
            ..map(100_000)
        };
        assert_eq!(full.shortfall(), None);
    }

    #[test]
    fn powers_of_any_size_keep_their_digits() {
        let shown: Vec<String> = [0.0, 12.34567, 0.05, 3.2e-9, 1.1246e18]
            .map(super::watts)
            .into();
        assert_eq!(
            shown,
            ["0.0000", "12.3457", "0.0500", "3.200e-9", "1.125e18"]
        );
    }
}
