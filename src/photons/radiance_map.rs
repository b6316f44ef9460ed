//! The radiance map of final gathering: the radiance leaving diffuse surfaces, precomputed at
//! photon positions (Christensen, "Faster photon map global illumination", 1999).
//!
//! Final gathering reads, where each gather ray meets a diffuse surface, all the light leaving
//! it: direct, caustic and indirect. The photons of [`PathClass::AllDiffuse`] (every diffuse
//! hit of every light path) carry exactly that light. Estimating it at each of millions of gather
//! hits from the k nearest photons would cost a k-nearest query each; instead it is estimated once
//! at every [`POINT_STRIDE`]-th photon, and a gather hit takes the value of the nearest such
//! point on its side of the surface: one nearest-point query.
//!
//! The estimate at a point is Jensen's, made without bias: `E = sum of the powers of the k - 1
//! photons nearest it that face its way / (pi r^2)`, `r` the distance of the k-th (or the
//! largest radius, when fewer lie within it: then all found count; never zero,
//! [`k_nearest_radius2`]); radiance `albedo / pi * E`. The photons it reads are the ones that
//! are not points (three in four, their power scaled to all): a point's estimate read from
//! every photon counted the point's own photon (k / (k - 2) = x1.032 of the density at a
//! photon), and since a gather hit takes its nearest point's value, a point in a sparse patch
//! (a large cell, a low estimate from the same photons) was read more often than one in a
//! dense patch (x0.98): a closed sphere's final gathering read x1.012, and x1.016 on the
//! scattered photons of this module's test. Read from photons apart from the points, an
//! estimate does not depend on where the points are. Its blur (a disc of `k` photons) is
//! invisible after gathering: the gather averages many such values over the hemisphere.
//!
//! Beside a wall or an edge a point's disc hangs past the surface, where no photon lands, and
//! `pi r^2` overstates the area its photons' power fell on: a closed cube of albedo 0.8 read
//! 0.984 of its exact mean radiance. With [`crate::photons::options::PhotonOptions::probe_walls`]
//! (the default render's) each photon is probed for walls within the estimates' largest radius,
//! and its mirror images beyond them ([`crate::photons::walls`]) are counted by the estimates,
//! as if the surface went on with the same light: the cube reads 0.998 (16 passes).
//!
//! [`PathClass::AllDiffuse`]: crate::photons::map::PathClass::AllDiffuse

// Photons facing another way than a point (the other side of a thin wall, across an edge) do not
// count, as in the estimators' test.
use crate::photons::cover::MIN_NORMAL_COSINE;
use crate::photons::map::k_nearest_radius2;
use crate::photons::trace::TracedPhoton;
use glam::{DVec3, Vec3};
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::num::NonZero;

/// Photons per radiance estimate.
pub const RADIANCE_NEIGHBOURS: usize = 64;

/// Radiance is precomputed at every this many photons (Christensen uses 4: the estimates of
/// neighbouring photons share most of their photons and barely differ).
pub const POINT_STRIDE: usize = 4;

/// Whether the photon of index `i` is a point radiance is precomputed at (the others are
/// what the estimates read).
pub fn is_point(i: usize) -> bool {
    i.is_multiple_of(POINT_STRIDE)
}

/// Where radiance was precomputed.
#[derive(Debug, Clone, Copy)]
struct RadiancePoint {
    normal: Vec3,
    /// Radiance leaving the surface (W/m^2/sr, RGB), the same in every direction.
    radiance: Vec3,
    /// Squared radius of the photons its estimate used: a gather hit farther than this from
    /// its nearest point is where no photon arrived.
    radius2: f32,
}

/// Radiance leaving diffuse surfaces at photon positions, for final gathering.
pub struct RadianceMap {
    points: Vec<RadiancePoint>,
    tree: Option<ImmutableKdTree<f32, u32, 3, 32>>,
    largest_radius2: f32,
    /// Photons the estimates drew on.
    pub photons: usize,
    /// Mirror images beyond walls and edges of the photons the estimates read
    /// ([`RadianceMap::with_mirrors`]).
    pub mirrors: usize,
    /// Their total power (W, RGB).
    pub power: DVec3,
}

/// What the radiance map reads of a traced photon: 72 bytes rather than a [`TracedPhoton`]'s
/// 232 (its whole differential), so that the photons are not held whole while the map is
/// built (at 1,000,000 photons the build's peak was 280 bytes a photon).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadianceSample {
    /// Where it was stored.
    pub position: Vec3,
    /// The surface's normal there.
    pub normal: Vec3,
    /// Power for a single emission.
    pub power: DVec3,
    /// Albedo of the surface there.
    pub albedo: DVec3,
}

impl RadianceSample {
    /// What the radiance map reads of `t`.
    pub fn of(t: &TracedPhoton) -> Self {
        RadianceSample {
            position: t.ray.p.as_vec3(),
            normal: t.normal.as_vec3(),
            power: t.power,
            albedo: t.albedo,
        }
    }
}

impl RadianceMap {
    /// Precomputes radiance from `photons` (every diffuse hit, powers for a single emission)
    /// of `emitted` emissions, each estimate gathering within `max_radius` at most.
    pub fn new(photons: &[RadianceSample], emitted: u64, max_radius: f64) -> Self {
        Self::with_mirrors(photons, &[], emitted, max_radius)
    }

    /// [`RadianceMap::new`] with `mirrors`, images beyond the walls and edges near them of the
    /// photons the estimates read (not of the points, [`is_point`]): the estimates count them
    /// (a disc hanging past a wall finds there the light the surface would have had if it
    /// went on), but no estimate is kept at one and their power is not the map's.
    pub fn with_mirrors(
        photons: &[RadianceSample],
        mirrors: &[RadianceSample],
        emitted: u64,
        max_radius: f64,
    ) -> Self {
        let scale = 1.0 / emitted.max(1) as f64;
        if photons.is_empty() {
            return RadianceMap {
                points: Vec::new(),
                tree: None,
                largest_radius2: 0.0,
                photons: 0,
                mirrors: 0,
                power: DVec3::ZERO,
            };
        }
        // The estimates read the photons that are not points, and their mirrors, so that a
        // point's estimate does not depend on where the points are (the module's comment).
        let readers: Vec<usize> = (0..photons.len()).filter(|&i| !is_point(i)).collect();
        let (readers, share) = match readers.is_empty() {
            // A map of one photon: it is its own point and reader.
            true => (vec![0], 1.0),
            false => {
                let share = photons.len() as f64 / readers.len() as f64;
                (readers, share)
            }
        };
        let read = |item: usize| {
            if item < readers.len() {
                &photons[readers[item]]
            } else {
                &mirrors[item - readers.len()]
            }
        };
        let positions: Vec<[f32; 3]> = readers
            .iter()
            .map(|&i| &photons[i])
            .chain(mirrors)
            .map(|p| p.position.to_array())
            .collect();
        let tree: ImmutableKdTree<f32, u32, 3, 32> = ImmutableKdTree::new_from_slice(&positions);
        let k = NonZero::new(RADIANCE_NEIGHBOURS).expect("non-zero");
        let max_r2 = (max_radius * max_radius) as f32;
        let chosen: Vec<usize> = (0..photons.len()).filter(|&i| is_point(i)).collect();
        let points: Vec<RadiancePoint> = chosen
            .par_iter()
            .map(|&i| {
                let here = &photons[i];
                let n = here.normal;
                let at = here.position.to_array();
                let found = tree.nearest_n_within::<SquaredEuclidean>(&at, max_r2, k, true);
                let kth2 = found.last().map_or(max_r2, |f| f.distance);
                let r2 = k_nearest_radius2(found.len(), RADIANCE_NEIGHBOURS, kth2, max_radius);
                // With k found, the k-th lies on the disc's rim: k - 1 photons inside a disc
                // whose radius the k-th sets estimate the density without bias.
                let inside = found.len() - usize::from(found.len() >= RADIANCE_NEIGHBOURS);
                let power: DVec3 = found[..inside]
                    .iter()
                    .map(|f| read(f.item as usize))
                    .filter(|p| p.normal.dot(n) > MIN_NORMAL_COSINE)
                    .map(|p| p.power)
                    .sum();
                let irradiance = power * scale * share / (PI * r2 as f64);
                RadiancePoint {
                    normal: n,
                    radiance: (here.albedo / PI * irradiance).as_vec3(),
                    radius2: r2,
                }
            })
            .collect();
        let largest_radius2 = points.iter().map(|p| p.radius2).fold(0.0, f32::max);
        let at: Vec<[f32; 3]> = chosen
            .iter()
            .map(|&i| photons[i].position.to_array())
            .collect();
        RadianceMap {
            tree: Some(ImmutableKdTree::new_from_slice(&at)),
            points,
            largest_radius2,
            photons: photons.len(),
            mirrors: mirrors.len(),
            power: photons.iter().map(|p| p.power).sum::<DVec3>() * scale,
        }
    }

    /// Number of points radiance was precomputed at.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether it holds no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Radiance leaving the diffuse surface at `x` (normal `n`, facing the side looked from):
    /// the nearest point's that faces the same way, if `x` lies within [`LOOKUP_REACH`] times
    /// that point's gather radius, with the squared radius of the photons its estimate drew
    /// on (its blur there); `None` where no such point is near (no photon arrived).
    pub fn lookup(&self, x: DVec3, n: DVec3) -> Option<(DVec3, f64)> {
        let tree = self.tree.as_ref()?;
        let n = n.as_vec3();
        let at = x.as_vec3().to_array();
        let reach2 = LOOKUP_REACH * LOOKUP_REACH;
        let usable = |d2: f32, p: &RadiancePoint| {
            p.normal.dot(n) > MIN_NORMAL_COSINE && d2 <= reach2 * p.radius2
        };
        let found = |p: &RadiancePoint| (p.radiance.as_dvec3(), p.radius2 as f64);
        // The nearest point almost always serves (this is every gather ray's query: a search
        // for several, sorted, within the largest radius of all took 40% of a gathering
        // render); only where it faces the other way or lies too far are the next ones asked.
        let nearest = tree.nearest_one::<SquaredEuclidean>(&at);
        let first = &self.points[nearest.item as usize];
        if usable(nearest.distance, first) {
            return Some(found(first));
        }
        // Beside an edge the nearest points are often the other wall's: a gather hit a pixel
        // from a cube's edge found none of its own wall's among the four nearest in 4% of
        // lookups, and read no light (the map 6% dark along the edges).
        let k = NonZero::new(LOOKUP_FALLBACK).expect("non-zero");
        tree.nearest_n_within::<SquaredEuclidean>(&at, reach2 * self.largest_radius2, k, true)
            .into_iter()
            .map(|f| (f.distance, &self.points[f.item as usize]))
            .find(|&(d2, p)| usable(d2, p))
            .map(|(_, p)| found(p))
    }
}

/// How far from a point, in its gather radii, a gather hit still takes its value. Where
/// photons are sparse (the estimates' discs at the largest radius, as in a closed room at the
/// default photon counts) the nearest point of a surface can lie beyond one radius, most
/// often beside an edge, where the surface stops; at one radius such hits read no light.
pub const LOOKUP_REACH: f32 = 2.0;

/// Points asked for where the nearest does not serve.
const LOOKUP_FALLBACK: usize = 16;

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(position: Vec3) -> RadianceSample {
        RadianceSample {
            position,
            normal: Vec3::Z,
            power: DVec3::ONE,
            albedo: DVec3::splat(0.5),
        }
    }

    /// Where more than k photons share one point the estimate's disc is the floor of
    /// [`k_nearest_radius2`]: the point reads the power of the k - 1 photons inside it (the
    /// k-th is on its rim), scaled from the photons read (three in four: the others are
    /// points) to all, over that disc; bright, not black.
    #[test]
    fn photons_on_one_point_read_bright() {
        let photons = vec![sample(Vec3::new(0.25, 0.5, 0.0)); 3 * RADIANCE_NEIGHBOURS];
        let max_radius = 0.1;
        let map = RadianceMap::new(&photons, 1, max_radius);
        let (radiance, r2) = map
            .lookup(DVec3::new(0.25, 0.5, 0.0), DVec3::Z)
            .expect("the point is where the photons are");
        let floor = (1e-12 * max_radius * max_radius) as f32 as f64;
        assert_eq!(r2, floor);
        let (all, read) = (photons.len() as f64, (photons.len() * 3 / 4) as f64);
        let power = (RADIANCE_NEIGHBOURS - 1) as f64 * all / read;
        let expected = 0.5 / PI * power / (PI * floor);
        assert!(
            ((radiance.x - expected) / expected).abs() < 1e-6,
            "{radiance} against {expected}"
        );
    }

    /// Photons scattered at random (a Poisson-like pattern, as traced photons are) with one
    /// watt per square metre: radiance read at gather hits is `albedo / pi` on average over
    /// eight seeds, within the noise of the estimates (1.0003; single seeds 0.994-1.005). Read
    /// from every photon, the estimates counted their own photon and a gather hit's nearest
    /// point favoured points whose neighbours are far: the same photons read 1.016 (single
    /// seeds 1.009-1.020).
    #[test]
    fn scattered_photons_read_their_irradiance_without_bias() {
        let n = 200_000;
        let mut ratios = Vec::new();
        for seed in 0..8 {
            let mut rng = crate::util::rng::Rng::new(seed, 0);
            let photons: Vec<RadianceSample> = (0..n)
                .map(|_| {
                    let (x, y) = (rng.uniform() as f32, rng.uniform() as f32);
                    let mut s = sample(Vec3::new(x, y, 0.0));
                    s.power = DVec3::splat(1.0 / n as f64);
                    s
                })
                .collect();
            let map = RadianceMap::new(&photons, 1, 1.0);
            // Gather hits on a fine grid away from the edges (where discs hang past them).
            let side = 200;
            let mut sum = 0.0;
            for i in 0..side * side {
                let x = 0.2 + 0.6 * ((i % side) as f64 + 0.5) / side as f64;
                let y = 0.2 + 0.6 * ((i / side) as f64 + 0.5) / side as f64;
                let (radiance, _) = map.lookup(DVec3::new(x, y, 0.0), DVec3::Z).unwrap();
                sum += radiance.x;
            }
            ratios.push(sum / (side * side) as f64 / (0.5 / PI));
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        assert!((mean - 1.0).abs() < 0.004, "{mean} over seeds: {ratios:?}");
    }

    /// Where photons are sparse (each estimate's disc at the largest radius) a gather hit
    /// beside an edge finds a point of its own surface: 2,000 photons scattered over a unit
    /// square, lookups a hundredth from its edges. Taken only within one radius of a point
    /// (and the four nearest asked where the nearest did not serve), 29 of the 396 read no
    /// light; within two, none.
    #[test]
    fn sparse_photons_beside_an_edge_read_light() {
        let n = 2_000;
        let mut rng = crate::util::rng::Rng::new(7, 0);
        let photons: Vec<RadianceSample> = (0..n)
            .map(|_| sample(Vec3::new(rng.uniform() as f32, rng.uniform() as f32, 0.0)))
            .collect();
        let map = RadianceMap::new(&photons, 1, 0.05);
        let mut dark = 0;
        let mut lookups = 0;
        for i in 1..100 {
            let t = i as f64 / 100.0;
            for (x, y) in [(t, 0.01), (t, 0.99), (0.01, t), (0.99, t)] {
                lookups += 1;
                dark += usize::from(map.lookup(DVec3::new(x, y, 0.0), DVec3::Z).is_none());
            }
        }
        assert_eq!((dark, lookups), (0, 396));
    }

    /// A lattice of photons of one watt per square metre reads that irradiance, times
    /// albedo / pi, within the noise of counting a disc's lattice points.
    #[test]
    fn uniform_lattice_reads_its_irradiance() {
        let spacing = 0.01_f32;
        let photons: Vec<RadianceSample> = (0..100 * 100)
            .map(|i| {
                let (x, y) = ((i % 100) as f32, (i / 100) as f32);
                let mut s = sample(Vec3::new(x * spacing, y * spacing, 0.0));
                s.power = DVec3::splat((spacing * spacing) as f64);
                s
            })
            .collect();
        let map = RadianceMap::new(&photons, 1, 1.0);
        let (radiance, _) = map.lookup(DVec3::new(0.5, 0.5, 0.0), DVec3::Z).unwrap();
        let expected = 0.5 / PI;
        assert!(
            ((radiance.x - expected) / expected).abs() < 0.1,
            "{radiance} against {expected}"
        );
    }
}
