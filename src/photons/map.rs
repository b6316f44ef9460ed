//! Photon maps: stored photons with their footprints, in a kd-tree (kiddo) for range and
//! k-nearest queries.

use crate::photons::footprint::{Footprint, Guards};
use glam::{DVec3, Vec3};
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use std::num::NonZero;

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
}

/// Photons whose footprint radii lie within a factor of two, in a tree of their own: a range
/// query for footprints that may reach a point then only needs this bin's largest radius, not
/// the whole map's.
struct RadiusBin {
    max_radius: f32,
    tree: ImmutableKdTree<f32, u32, 3, 32>,
    /// Map indices of the bin's photons (the tree's items index this).
    indices: Vec<u32>,
}

/// A photon map: photons of one [`PathClass`] and the trees over their positions.
pub struct PhotonMap {
    /// The class of paths stored.
    pub class: PathClass,
    /// The photons, in emission order.
    pub photons: Vec<Photon>,
    /// Number of emissions the photons' powers are divided by.
    pub emitted: u64,
    /// Guarded footprints.
    pub guards: Guards,
    /// Largest footprint circumradius in the map.
    pub max_radius: f32,
    /// Over every photon, for k-nearest queries.
    tree: ImmutableKdTree<f32, u32, 3, 32>,
    /// By footprint radius, for footprint range queries.
    bins: Vec<RadiusBin>,
}

impl PhotonMap {
    /// Builds the tree over `photons`.
    pub fn new(class: PathClass, photons: Vec<Photon>, emitted: u64, guards: Guards) -> Self {
        let points: Vec<[f32; 3]> = photons.iter().map(|p| p.position.to_array()).collect();
        let tree = ImmutableKdTree::new_from_slice(&points);
        let max_radius = photons.iter().map(|p| p.radius).fold(0.0, f32::max);
        let min_radius = photons
            .iter()
            .map(|p| p.radius)
            .fold(f32::INFINITY, f32::min);
        // Bin k holds radii in (min 2^(k-1), min 2^k].
        let mut members: Vec<Vec<u32>> = Vec::new();
        for (i, p) in photons.iter().enumerate() {
            let k = if p.radius > min_radius {
                (p.radius / min_radius).log2().ceil().max(0.0) as usize
            } else {
                0
            };
            if members.len() <= k {
                members.resize(k + 1, Vec::new());
            }
            members[k].push(i as u32);
        }
        let bins = members
            .into_iter()
            .filter(|m| !m.is_empty())
            .map(|indices| {
                let points: Vec<[f32; 3]> = indices
                    .iter()
                    .map(|&i| photons[i as usize].position.to_array())
                    .collect();
                RadiusBin {
                    max_radius: indices
                        .iter()
                        .map(|&i| photons[i as usize].radius)
                        .fold(0.0, f32::max),
                    tree: ImmutableKdTree::new_from_slice(&points),
                    indices,
                }
            })
            .collect();
        PhotonMap {
            class,
            photons,
            emitted,
            guards,
            max_radius,
            tree,
            bins,
        }
    }

    /// Number of photons.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// Whether the map holds no photon.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Total stored power.
    pub fn total_power(&self) -> DVec3 {
        self.photons.iter().map(|p| p.power.as_dvec3()).sum()
    }

    /// Indices (any order) of a superset of the photons whose footprint, grown by `reach`, may
    /// cover `x`: every photon with `|x - x_p| <= radius_p + reach`. Each radius bin is queried
    /// with its own largest radius.
    pub fn reaching(&self, x: DVec3, reach: f64, out: &mut Vec<u32>) {
        out.clear();
        let query = x.as_vec3().to_array();
        for bin in &self.bins {
            let r = bin.max_radius as f64 + reach;
            let r2 = (r * r) as f32;
            out.extend(
                bin.tree
                    .within_unsorted::<SquaredEuclidean>(&query, r2)
                    .into_iter()
                    .map(|n| bin.indices[n.item as usize]),
            );
        }
    }

    /// The (at most) `k` nearest photons within `max_radius` of `x`, nearest first, as
    /// `(squared distance, index)`.
    pub fn nearest(&self, x: DVec3, k: usize, max_radius: f64, out: &mut Vec<(f32, u32)>) {
        out.clear();
        let Some(k) = NonZero::new(k) else { return };
        if self.photons.is_empty() {
            return;
        }
        let r2 = (max_radius * max_radius) as f32;
        out.extend(
            self.tree
                .nearest_n_within::<SquaredEuclidean>(&x.as_vec3().to_array(), r2, k, true)
                .into_iter()
                .map(|n| (n.distance, n.item)),
        );
    }
}
