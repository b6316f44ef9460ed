//! Which photons to probe for walls: a screen over the scene's geometries' bounds.

use super::{nearest_walls, probe_extent, WallPair, MAX_COS};
use crate::embree::{self, GeometryBounds};
use crate::photons::footprint::Footprint;
use glam::DVec3;

/// The walls of a scene, probed for with [`nearest_walls`] where some geometry could hold one.
///
/// Why a screen: most photons lie in the open, and their probes (one Embree packet each) find
/// nothing; on the canonical scene, whose floor is flat and whose sphere rests on it, that was
/// a twelfth of the default render's photon stage. A probe can stop only at a face of a
/// geometry whose bounding sphere its reach enters, and never at a flat geometry's face when
/// that geometry lies within 45 degrees of the photon's plane (`MAX_COS`): its faces all
/// share its plane's normal. So where no other geometry is that near, the answer is `None`
/// without a ray. With more than [`Walls::MAX_SCREENED`] geometries (instanced scenes) every
/// photon is probed.
pub struct Walls<'a> {
    embree: &'a embree::Scene,
    /// Each geometry's bounds, or `None` when there are too many to scan per photon.
    bounds: Option<Vec<GeometryBounds>>,
}

impl<'a> Walls<'a> {
    /// Geometries scanned per photon at most; beyond, every photon is probed.
    pub const MAX_SCREENED: usize = 64;

    /// The screen over `embree`'s geometries.
    pub fn new(embree: &'a embree::Scene) -> Self {
        let bounds = (embree.mesh_count() <= Self::MAX_SCREENED).then(|| embree.geometry_bounds());
        Walls { embree, bounds }
    }

    /// [`nearest_walls`], answered `None` without probing where no geometry's face could
    /// stop a probe.
    pub fn nearest(
        &self,
        position: DVec3,
        normal: DVec3,
        footprint: &Footprint,
        epsilon: f64,
    ) -> Option<WallPair> {
        if !self.may_stop(position, normal, footprint, epsilon) {
            return None;
        }
        nearest_walls(self.embree, position, normal, footprint, epsilon)
    }

    /// Whether a probe of the photon's (see the module's comment) may meet a face steeper than
    /// 45 degrees to its plane: some geometry's bounding sphere comes within the probes'
    /// reach, and that geometry is not flat within 45 degrees of the plane.
    pub fn may_stop(
        &self,
        position: DVec3,
        normal: DVec3,
        footprint: &Footprint,
        epsilon: f64,
    ) -> bool {
        let Some(bounds) = &self.bounds else {
            return true;
        };
        // A degenerate footprint is not probed at all.
        let Some((axes, depth)) = probe_extent(footprint, epsilon) else {
            return false;
        };
        // The probes reach at most `|axes[0]| + |axes[1]|` along the plane, `depth` off it.
        let reach = axes[0].length() + axes[1].length() + depth;
        bounds.iter().any(|b| {
            let near = position.distance_squared(b.center) <= (b.radius + reach).powi(2);
            let flat_beside = b
                .plane_normal
                .is_some_and(|n| n.dot(normal).abs() >= MAX_COS);
            near && !flat_beside
        })
    }
}
