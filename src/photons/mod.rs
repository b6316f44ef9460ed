//! Photon tracing: emission from the lights with emission differentials ([`emission`]), light
//! paths through the scene ([`light_path`]), the photons they store ([`trace`], with the
//! settings of [`options`]), each with its
//! footprint ([`footprint`]), gathered into photon maps ([`map`]) with a BVH over footprint
//! boxes ([`footprint_bvh`]), queried by a footprint's box and, for thin footprints askew to the
//! axes, its prism ([`prism`]), and an exact test of what a footprint may cover ([`cover`]); for
//! final gathering, radiance precomputed at photons of every diffuse hit ([`radiance_map`]).
//! Footprints that run into a wall or off an edge get a mirror photon beyond it ([`walls`]).

pub mod cover;
pub mod emission;
pub mod file;
pub mod footprint;
pub mod footprint_bvh;
pub mod light_path;
pub mod map;
pub mod options;
pub mod prism;
pub mod radiance_map;
pub mod targets;
pub mod trace;
pub mod walls;

use map::PhotonMap;
use radiance_map::RadianceMap;

/// The caustic and global photon maps of a scene.
pub struct PhotonMaps {
    /// Light -> specular+ -> diffuse.
    pub caustic: PhotonMap,
    /// After at least one diffuse bounce (empty when final gathering reads `radiance`
    /// instead).
    pub global: PhotonMap,
    /// For final gathering: radiance leaving diffuse surfaces, from photons at every diffuse
    /// hit ([`radiance_map`]); `None` without final gathering.
    pub radiance: Option<RadianceMap>,
}
