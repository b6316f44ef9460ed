//! Photon maps: stored photons with their footprints, in a BVH over footprint boxes for range
//! queries ([`crate::photons::footprint_bvh`]) and a kd-tree (kiddo, built on first use) for
//! k-nearest queries.

use crate::photons::cover::{CoverQuery, CoverTable, Found};
use crate::photons::footprint::{Footprint, Guards};
use crate::photons::footprint_bvh::{footprint_box, Aabb, FootprintBvh, PacketBoxes, PACKET_SIZE};
use crate::photons::prism::Prism;
use glam::{DVec3, Vec3};
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;
use std::num::NonZero;
use std::sync::OnceLock;

/// A stored photon: what its estimates need and no more.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Photon {
    /// Where it was stored.
    pub position: Vec3,
    /// Unit surface normal at the hit, facing the side the photon came from.
    pub normal: Vec3,
    /// Unit direction it travelled in when it arrived.
    pub direction: Vec3,
    /// Power (W, RGB).
    pub power: Vec3,
    /// Rows of its filter matrix `M` (world space).
    pub m: [Vec3; 2],
    /// `1 / A`, `A = |a x b|` (see [`crate::photons::footprint`]).
    pub inv_area: f32,
    /// Its footprint's circumradius (long semi-axis).
    pub radius: f32,
}

impl Photon {
    /// A photon at `position` with `footprint`.
    pub fn new(
        position: DVec3,
        normal: DVec3,
        direction: DVec3,
        power: DVec3,
        footprint: &Footprint,
    ) -> Self {
        Photon {
            position: position.as_vec3(),
            normal: normal.as_vec3(),
            direction: direction.as_vec3(),
            power: power.as_vec3(),
            m: footprint.m.map(|r| r.as_vec3()),
            inv_area: (1.0 / footprint.area) as f32,
            radius: footprint.radius as f32,
        }
    }
}

/// Which paths a map holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum PathClass {
    /// Light -> diffuse (L D): direct light, for tests; rendering uses shadow rays instead.
    Direct,
    /// Light -> one or more specular bounces -> first diffuse hit (L S+ D).
    Caustic,
    /// After at least one diffuse bounce (L (S|D)* D D).
    Global,
    /// Every diffuse hit of a light path, the first too (L (S|D)* D): all the light leaving
    /// diffuse surfaces, which final gathering reads ([`crate::photons::radiance_map`]).
    AllDiffuse,
}

impl PathClass {
    /// Its name in messages and statistics.
    pub fn name(self) -> &'static str {
        match self {
            PathClass::Direct => "direct",
            PathClass::Caustic => "caustic",
            PathClass::Global => "global",
            PathClass::AllDiffuse => "global (all diffuse hits, for final gathering)",
        }
    }
}

/// Bytes [`PhotonMap::new`] adds a photon to the photons it is given, at most at once: the
/// footprint boxes (24) and the tree's build while the boxes are held, then the columns (84),
/// the leaf order (4) and the tree's nodes (about 4). The map's build checks this much is left
/// before it starts.
pub const BUILD_BYTES_PER_PHOTON: u64 = 100;

/// A photon map: photons of one [`PathClass`] and the trees over their positions.
pub struct PhotonMap {
    /// The class of paths stored.
    pub class: PathClass,
    /// Each photon's direction of arrival and footprint radius. The map holds its photons in
    /// the order of the footprint BVH's leaves (footprint boxes along a Morton curve), so that a
    /// query reads photons that lie together in memory (in emission order they would be
    /// scattered: at 10^5 photons and more each photon tested was a cache miss, and testing
    /// them took a third of the render), as columns: these, the cover test's table
    /// (position, filter rows, normal) and the fluxes (power, `1 / A`), each number once.
    /// ([`PhotonMap::photon`] puts a photon together again.) A whole [`Photon`] kept besides
    /// made the map 148 bytes a photon rather than 84.
    arrivals: Vec<Arrival>,
    /// Number of emissions the photons' powers are divided by.
    pub emitted: u64,
    /// Guarded footprints.
    pub guards: Guards,
    /// Power of the mirror photons among `photons` ([`crate::photons::walls`]): they stand for
    /// the part of other photons' footprints beyond a wall, not for light of their own.
    pub mirror_power: DVec3,
    /// Largest footprint circumradius in the map.
    pub max_radius: f32,
    /// Over every photon's position, for k-nearest queries: built on the first such query (only
    /// `jensen` asks), so that building a map costs only the footprint BVH.
    tree: OnceLock<ImmutableKdTree<f32, u32, 3, 32>>,
    /// Over every photon's footprint box, for footprint range queries.
    bvh: FootprintBvh,
    /// What the exact cover test reads of each photon, in the same order.
    cover: CoverTable,
    /// Each photon's power and `1 / A`, in the same order: what a gather reads of a photon
    /// once its kernel's share is known, sixteen bytes a photon rather than a whole photon's
    /// eighty (at 1,280,000 photons, multi-sampled 8x8 reading them from the photons spent 6%
    /// of its render stage waiting for them).
    pub flux: Vec<Flux>,
}

/// What a map keeps of a photon beside its cover-test row and its flux.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Arrival {
    /// [`Photon::direction`].
    direction: Vec3,
    /// [`Photon::radius`].
    radius: f32,
}

/// A photon's power and the inverse of its footprint's area (its [`Photon::power`] and
/// [`Photon::inv_area`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flux {
    /// Power (W, RGB).
    pub power: Vec3,
    /// `1 / A`.
    pub inv_area: f32,
}

impl Flux {
    /// Photon `p`'s flux.
    #[inline(always)]
    pub fn of(p: &Photon) -> Self {
        Flux {
            power: p.power,
            inv_area: p.inv_area,
        }
    }
}

impl PhotonMap {
    /// Builds the footprint BVH over `photons`, and the map's columns in its leaf order.
    /// (Photons whose footprint box is not finite are never found, and left out.)
    pub fn new(class: PathClass, photons: Vec<Photon>, emitted: u64, guards: Guards) -> Self {
        let max_radius = photons
            .par_iter()
            .map(|p| p.radius)
            .reduce(|| 0.0, f32::max);
        // Per photon and independent: on the worker threads (in order, so the map is the same).
        let boxes: Vec<Aabb> = photons.par_iter().map(footprint_box).collect();
        let (bvh, order) = FootprintBvh::new(&boxes);
        drop(boxes);
        // Each column gathered straight from the photons in leaf order: the tree's slots are
        // the map's photon indices.
        let cover = CoverTable::new(&photons, &order);
        let (flux, arrivals) = order
            .par_iter()
            .map(|&i| {
                let p = &photons[i as usize];
                let arrival = Arrival {
                    direction: p.direction,
                    radius: p.radius,
                };
                (Flux::of(p), arrival)
            })
            .unzip();
        PhotonMap {
            flux,
            class,
            arrivals,
            emitted,
            guards,
            mirror_power: DVec3::ZERO,
            max_radius,
            tree: OnceLock::new(),
            bvh,
            cover,
        }
    }

    /// Number of photons.
    pub fn len(&self) -> usize {
        self.flux.len()
    }

    /// Whether the map holds no photon.
    pub fn is_empty(&self) -> bool {
        self.flux.is_empty()
    }

    /// Photon `i` (in the map's order), put together from the map's columns: the numbers it
    /// was stored with.
    pub fn photon(&self, i: usize) -> Photon {
        let (position, m) = self.cover.filter_frame(i);
        let (normal, _) = self.cover.surface(i);
        let (flux, arrival) = (&self.flux[i], &self.arrivals[i]);
        Photon {
            position,
            normal,
            direction: arrival.direction,
            power: flux.power,
            m,
            inv_area: flux.inv_area,
            radius: arrival.radius,
        }
    }

    /// Every photon, in the map's order ([`PhotonMap::photon`]).
    pub fn photons(&self) -> Vec<Photon> {
        (0..self.len())
            .into_par_iter()
            .map(|i| self.photon(i))
            .collect()
    }

    /// Total power of the photons stored (the mirror photons' excluded).
    pub fn total_power(&self) -> DVec3 {
        self.flux.iter().map(|p| p.power.as_dvec3()).sum::<DVec3>() - self.mirror_power
    }

    /// A superset of the photons whose kernel may be non-zero somewhere in the view footprint
    /// of `query`, in map order: in every BVH leaf whose bounds overlap the footprint's
    /// bounding box, the photons that [`crate::photons::cover::may_cover`] it (tested a leaf,
    /// up to sixteen, at a time). `T` is what is kept of each: its index (`u32`), or that and
    /// the footprint in its filter space ([`crate::photons::cover::InFilterSpace`]).
    pub fn covering<T: Found>(&self, query: &FootprintQuery, out: &mut Vec<T>) {
        out.clear();
        let (q, query, prism) = query.prepare();
        // The photons are in leaf order, so a leaf's slots are its photons' indices.
        self.bvh
            .leaves_meeting(&query, prism.as_ref(), |first, count| {
                self.cover.leaf(first, count, &q, out)
            });
    }

    /// Position and filter matrix rows of photon `i` (its [`Photon::position`] and
    /// [`Photon::m`]), read from the cover test's table ([`CoverTable::filter_frame`]).
    #[inline(always)]
    pub fn filter_frame(&self, i: usize) -> (Vec3, [Vec3; 2]) {
        self.cover.filter_frame(i)
    }

    /// Normal of photon `i` and half-thickness of its surface slab
    /// (`OFF_PLANE_TOLERANCE * radius`), read from the cover test's table
    /// ([`CoverTable::surface`]).
    #[inline(always)]
    pub fn surface(&self, i: usize) -> (Vec3, f32) {
        self.cover.surface(i)
    }

    /// [`PhotonMap::covering`] for each of `queries`, into `outs[j]` for query `j` (`outs`
    /// grown to hold them), each the very list `covering` gives. The queries go through the
    /// BVH sixteen at a time in one walk (neighbouring pixels' gathers visit nearly the same
    /// nodes and leaves, and each leaf's lanes are loaded once for them all), but for thin
    /// footprints, which take their prism in a walk of their own.
    pub fn covering_packet<T: Found>(&self, queries: &[FootprintQuery], outs: &mut Vec<Vec<T>>) {
        if outs.len() < queries.len() {
            outs.resize_with(queries.len(), Vec::new);
        }
        let no_query = CoverQuery::new(Vec3::ZERO, [Vec3::ZERO; 2], Vec3::ZERO);
        let mut covers = [no_query; PACKET_SIZE];
        let mut boxes = [Aabb::EMPTY; PACKET_SIZE];
        for (queries, outs) in queries
            .chunks(PACKET_SIZE)
            .zip(outs.chunks_mut(PACKET_SIZE))
        {
            let mut together = 0u32;
            for (j, (query, out)) in queries.iter().zip(outs.iter_mut()).enumerate() {
                out.clear();
                let (q, query, prism) = query.prepare();
                if let Some(prism) = prism {
                    self.bvh
                        .leaves_meeting(&query, Some(&prism), |first, count| {
                            self.cover.leaf(first, count, &q, out)
                        });
                } else {
                    (covers[j], boxes[j]) = (q, query);
                    together |= 1 << j;
                }
            }
            let packet = PacketBoxes::new(&boxes[..queries.len()], together);
            self.bvh
                .leaves_meeting_packet(&packet, |first, count, meeting| {
                    self.cover.leaf_packet(first, count, &covers, meeting, outs)
                });
        }
    }

    /// The (at most) `k` nearest photons within `max_radius` of `x`, nearest first, as
    /// `(squared distance, index)`.
    pub fn nearest(&self, x: DVec3, k: usize, max_radius: f64, out: &mut Vec<(f32, u32)>) {
        out.clear();
        let Some(k) = NonZero::new(k) else { return };
        if self.is_empty() {
            return;
        }
        let r2 = (max_radius * max_radius) as f32;
        let tree = self.tree.get_or_init(|| {
            let points: Vec<[f32; 3]> = (0..self.len())
                .map(|i| self.cover.filter_frame(i).0.to_array())
                .collect();
            ImmutableKdTree::new_from_slice(&points)
        });
        out.extend(
            tree.nearest_n_within::<SquaredEuclidean>(&x.as_vec3().to_array(), r2, k, true)
                .into_iter()
                .map(|n| (n.distance, n.item)),
        );
    }
}

/// The squared radius of a k-nearest estimate: the `k`-th photon's squared distance `kth2` when
/// `found` reached `k`, else `max_radius` squared. Kept above zero, where `k` photons share
/// one point, by a part of the largest radius (1e-12 whatever the scene's size blurred every
/// gather of a scene a micrometre across), so that such a point reads bright, not black.
pub fn k_nearest_radius2(found: usize, k: usize, kth2: f32, max_radius: f64) -> f32 {
    let max_r2 = (max_radius * max_radius) as f32;
    if found < k {
        max_r2
    } else {
        kth2.max((1e-12 * max_radius * max_radius) as f32)
    }
}

/// A packet's footprint queries and the photons each finds, kept across packets so that
/// searching allocates nothing once warm: what an estimator that answers a packet of gathers
/// at once ([`crate::estimate::RadianceEstimator::radiance_batch`]) asks the map.
pub struct PacketSearch<T> {
    requests: Vec<FootprintQuery>,
    found: Vec<Vec<T>>,
}

impl<T> Default for PacketSearch<T> {
    fn default() -> Self {
        PacketSearch {
            requests: Vec::new(),
            found: Vec::new(),
        }
    }
}

impl<T: Found> PacketSearch<T> {
    /// What each of `requests` finds in `map` ([`PhotonMap::covering_packet`]): one list per
    /// request, in their order.
    pub fn run(
        &mut self,
        map: &PhotonMap,
        requests: impl IntoIterator<Item = FootprintQuery>,
    ) -> &[Vec<T>] {
        self.requests.clear();
        self.requests.extend(requests);
        map.covering_packet(&self.requests, &mut self.found);
        &self.found[..self.requests.len()]
    }
}

/// A footprint query: the view footprint `x +- footprint[0]/2 +- footprint[1]/2` (zero for a
/// point; non-finite edges count as zero) on a surface of normal `normal` at `x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootprintQuery {
    /// The query point.
    pub x: DVec3,
    /// The footprint's edge vectors.
    pub footprint: [DVec3; 2],
    /// The surface normal at `x` (photons facing another way are not found in filter space:
    /// [`crate::photons::cover::Found`]).
    pub normal: DVec3,
}

impl FootprintQuery {
    /// The footprint `x +- footprint[0]/2 +- footprint[1]/2` on a surface of normal `normal`.
    pub fn new(x: DVec3, footprint: [DVec3; 2], normal: DVec3) -> Self {
        FootprintQuery {
            x,
            footprint,
            normal,
        }
    }

    /// What [`PhotonMap::covering`] asks: the cover test's query, the box the BVH is walked
    /// with, and the prism of a thin footprint.
    fn prepare(&self) -> (CoverQuery, Aabb, Option<Prism>) {
        let x = self.x;
        let finite = self.footprint[0].is_finite() && self.footprint[1].is_finite();
        let f = if finite {
            self.footprint
        } else {
            [DVec3::ZERO; 2]
        };
        let n = self.normal.as_vec3();
        let q = CoverQuery::new(x.as_vec3(), [f[0].as_vec3(), f[1].as_vec3()], n);
        // The footprint's own box, not the cube of its reach: seen at a grazing angle a pixel's
        // footprint is long and thin, and its cube let through photons beside it. (A photon it
        // covers lies in the footprint's plane, so their boxes share that point.)
        let half = 0.5 * (f[0].abs() + f[1].abs());
        let query = rounded_out(x - half, x + half);
        // And its prism: a thin footprint askew to the axes has a box far larger than itself.
        let prism = Prism::over(x, &f);
        (q, query, prism)
    }
}

/// The f32 box that holds the f64 box `lo..hi`.
fn rounded_out(lo: DVec3, hi: DVec3) -> Aabb {
    let slack = |v: DVec3| {
        let v = v.as_vec3();
        v.abs() * (2.0 * f32::EPSILON) + Vec3::splat(f32::MIN_POSITIVE)
    };
    Aabb {
        min: lo.as_vec3() - slack(lo),
        max: hi.as_vec3() + slack(hi),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photons::cover::InFilterSpace;
    use crate::photons::footprint::{footprint, FootprintLimits};
    use glam::Vec2;
    use proptest::prelude::*;

    /// Photons on the plane `y = 0` (a few on `x = 0`), with footprints of every size and shape.
    fn map_of(photons: &[([f64; 4], bool)]) -> PhotonMap {
        let limits = FootprintLimits {
            min_radius: 1e-3,
            max_radius: 10.0,
            max_anisotropy: 20.0,
        };
        let photons = photons
            .iter()
            .map(|&([x, z, r, skew], wall)| {
                let n = if wall { DVec3::X } else { DVec3::Y };
                let (a, b) = if wall {
                    (DVec3::Y * r, DVec3::new(0.0, skew, 1.0) * r)
                } else {
                    (DVec3::X * r, DVec3::new(skew, 0.0, 1.0) * r)
                };
                let fp = footprint(a, b, n, &limits, 0.1, &mut Guards::default());
                let at = if wall {
                    DVec3::new(0.0, x, z)
                } else {
                    DVec3::new(x, 0.0, z)
                };
                Photon::new(at, n, -n, DVec3::ONE, &fp)
            })
            .collect();
        PhotonMap::new(PathClass::Caustic, photons, 1, Guards::default())
    }

    /// The map's columns put every photon together again as it was given, each once (in leaf
    /// order), but one whose footprint box is not finite, which is left out; the total power
    /// is theirs.
    #[test]
    fn a_map_gives_back_its_photons() {
        let limits = FootprintLimits {
            min_radius: 1e-3,
            max_radius: 10.0,
            max_anisotropy: 20.0,
        };
        let mut photons: Vec<Photon> = (0..3000)
            .map(|k| {
                let t = k as f64;
                let (a, b) = (DVec3::X * 0.01, DVec3::new(0.3, 0.0, 1.0) * 0.02);
                let fp = footprint(a, b, DVec3::Y, &limits, 0.1, &mut Guards::default());
                let at = DVec3::new((t * 0.37).sin(), 0.0, (t * 0.91).cos());
                let d = DVec3::new(t.cos(), -1.0, t.sin()).normalize();
                Photon::new(at, DVec3::Y, d, DVec3::new(t, 1.0, 2.0 * t), &fp)
            })
            .collect();
        photons[17].position.x = f32::NAN;
        let map = PhotonMap::new(PathClass::Caustic, photons.clone(), 1, Guards::default());
        assert_eq!(map.len(), 2999);
        let mut back = map.photons();
        assert!((0..map.len()).all(|i| map.photon(i) == back[i]));
        back.sort_by(|a, b| a.power.x.total_cmp(&b.power.x));
        photons.remove(17);
        assert!(back == photons, "the photons differ");
        let total: DVec3 = photons.iter().map(|p| p.power.as_dvec3()).sum();
        assert!((map.total_power() - total).length() <= 1e-9 * total.length());
    }

    proptest! {
        /// A packet of queries finds for each query the photons `covering` finds for it alone,
        /// in the same order: footprints near and far apart, points, needles askew to the axes
        /// (which take their prism), non-finite footprints, more queries than a packet holds.
        #[test]
        fn a_packet_of_queries_finds_what_each_finds_alone(
            photons in prop::collection::vec(
                ((0f64..4.0, 0f64..4.0, 0.005f64..0.3, -2f64..2.0), prop::bool::weighted(0.1)),
                1..600,
            ),
            queries in prop::collection::vec(
                (0f64..4.0, 0f64..4.0, 0f64..0.2, -1f64..1.0, 0u8..8),
                1..40,
            ),
        ) {
            let map = map_of(&photons.iter().map(|&((x, z, r, s), w)| ([x, z, r, s], w)).collect::<Vec<_>>());
            let requests: Vec<FootprintQuery> = queries
                .iter()
                .map(|&(x, z, size, turn, kind)| {
                    let at = DVec3::new(x, 0.0, z);
                    let f = match kind {
                        0 => [DVec3::ZERO; 2],
                        1 => [DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Z],
                        // A needle askew: its box is far larger than itself.
                        2 => [DVec3::new(3.0, 0.0, 3.0 * turn), DVec3::new(-0.001, 0.0, 0.001)],
                        _ => [DVec3::new(size, 0.0, size * turn), DVec3::new(-size * turn, 0.0, size)],
                    };
                    // Most on the floor's side; some facing the wall, or askew.
                    let normal = match kind % 4 {
                        0 => DVec3::X,
                        1 => DVec3::new(0.6, 0.8, 0.0),
                        _ => DVec3::Y,
                    };
                    FootprintQuery::new(at, f, normal)
                })
                .collect();
            let mut together: Vec<Vec<u32>> = Vec::new();
            map.covering_packet(&requests, &mut together);
            let mut in_filter_space: Vec<Vec<InFilterSpace>> = Vec::new();
            map.covering_packet(&requests, &mut in_filter_space);
            let (mut alone, mut alone_in_filter_space) = (Vec::new(), Vec::new());
            for (j, query) in requests.iter().enumerate() {
                map.covering(query, &mut alone);
                prop_assert_eq!(&together[j], &alone, "query {}", j);
                map.covering(query, &mut alone_in_filter_space);
                prop_assert_eq!(&in_filter_space[j], &alone_in_filter_space, "query {}", j);
                // The same photons, but those facing another way.
                let slots: Vec<u32> = alone_in_filter_space.iter().map(|f| f.slot).collect();
                let n = query.normal.as_vec3();
                let facing: Vec<u32> = alone
                    .iter()
                    .copied()
                    .filter(|&i| crate::estimate::same_side(map.photon(i as usize).normal, n))
                    .collect();
                prop_assert_eq!(&slots, &facing);
                // The filter-space numbers are the estimators' own.
                let x = query.x.as_vec3();
                let finite = query.footprint.iter().all(|f| f.is_finite());
                let f = query.footprint.map(|f| if finite { f.as_vec3() } else { Vec3::ZERO });
                for found in &alone_in_filter_space {
                    let p = &map.photon(found.slot as usize);
                    let v = x - p.position;
                    prop_assert!(crate::estimate::on_query_surface(p, v, n));
                    prop_assert_eq!(found.s, Vec2::new(p.m[0].dot(v), p.m[1].dot(v)));
                    prop_assert_eq!(found.a, Vec2::new(p.m[0].dot(f[0]), p.m[1].dot(f[0])));
                    prop_assert_eq!(found.b, Vec2::new(p.m[0].dot(f[1]), p.m[1].dot(f[1])));
                }
            }
        }
    }
}
