//! The mirror images of a photon at walls: the line where its surface meets a wall or ends
//! ([`Wall`]), the nearest wall and, in an inner corner, a second one square to it
//! ([`WallPair`]), and the images they give ([`Image`]): one across a wall, three in a corner.

use crate::photons::footprint::Footprint;
use glam::DVec3;

/// The line in a photon's plane where its surface meets a wall or ends: the photon's mirror
/// image across it stands for the part of its footprint beyond.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    /// Unit normal of the line within the photon's plane, pointing from the photon to the wall.
    pub normal: DVec3,
    /// Distance from the photon to the line.
    pub distance: f64,
}

impl Wall {
    /// The mirror image of point `x` (in the photon's plane) across the line.
    pub fn reflect_point(&self, photon: DVec3, x: DVec3) -> DVec3 {
        let across = (x - photon).dot(self.normal) - self.distance;
        x - self.normal * (2.0 * across)
    }

    /// The mirror image of direction `v`.
    pub fn reflect_vector(&self, v: DVec3) -> DVec3 {
        v - self.normal * (2.0 * v.dot(self.normal))
    }

    /// The mirror photon's footprint: the kernel `K(|M (x - p)|)` mirrored is
    /// `K(|M R (x - p*)|)` with `R` the reflection, so its filter rows are `R m_k` (`R` is
    /// symmetric); its area and radius are the photon's.
    pub fn reflect_footprint(&self, f: &Footprint) -> Footprint {
        Footprint {
            m: [self.reflect_vector(f.m[0]), self.reflect_vector(f.m[1])],
            ..*f
        }
    }
}

/// The walls of a photon's footprint: the nearest, and a second one square to it where the
/// footprint reaches into an inner corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallPair {
    /// The nearest wall.
    pub first: Wall,
    /// A wall within 6 degrees of square to the first ([`MAX_SQUARE_COS`]), the nearest such.
    pub second: Option<Wall>,
}

impl WallPair {
    /// The photon's mirror images, as maps of points, directions and footprints: across the
    /// first wall; in a corner also across the second, and across both (the half turn about
    /// the corner). With the three images the kernel is whole in the corner's quadrant: each
    /// image gives back the part of the photon's kernel beyond one wall, or beyond both.
    pub fn images(&self) -> impl Iterator<Item = Image> + '_ {
        let first = std::iter::once(Image {
            first: self.first,
            then: None,
        });
        let corner = self.second.into_iter().flat_map(move |second| {
            [
                Image {
                    first: second,
                    then: None,
                },
                Image {
                    first: self.first,
                    then: Some(second),
                },
            ]
        });
        first.chain(corner)
    }
}

/// One mirror image: the reflection across a wall, then across another where there is one
/// (lines in the photon's plane, placed relative to the photon).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Image {
    first: Wall,
    then: Option<Wall>,
}

impl Image {
    /// The image of point `x` (the photon at `photon`).
    pub fn point(&self, photon: DVec3, x: DVec3) -> DVec3 {
        let x = self.first.reflect_point(photon, x);
        self.then.map_or(x, |w| w.reflect_point(photon, x))
    }

    /// The image of direction `v`.
    pub fn vector(&self, v: DVec3) -> DVec3 {
        let v = self.first.reflect_vector(v);
        self.then.map_or(v, |w| w.reflect_vector(v))
    }

    /// The image of footprint `f`.
    pub fn footprint(&self, f: &Footprint) -> Footprint {
        let f = self.first.reflect_footprint(f);
        self.then.map_or(f, |w| w.reflect_footprint(&f))
    }
}

/// Two walls make a corner (three images) when the cosine between their normals is below
/// this: within 6 degrees of square. Wedges of other angles are not tiled by mirror images,
/// and keep the nearer wall's mirror only.
pub const MAX_SQUARE_COS: f64 = 0.1;
