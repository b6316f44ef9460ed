//! Photon tracing: emission from the lights with emission differentials ([`emission`]), light
//! paths through the scene ([`light_path`]), the photons they store ([`trace`]), each with its
//! footprint ([`footprint`]), gathered into photon maps ([`map`]) with a BVH over footprint boxes
//! ([`footprint_bvh`]) and an exact test of what a footprint may cover ([`cover`]).

pub mod cover;
pub mod emission;
pub mod file;
pub mod footprint;
pub mod footprint_bvh;
pub mod light_path;
pub mod map;
pub mod trace;

use map::PhotonMap;

/// The caustic and global photon maps of a scene.
pub struct PhotonMaps {
    /// Light -> specular+ -> diffuse.
    pub caustic: PhotonMap,
    /// After at least one diffuse bounce.
    pub global: PhotonMap,
}
