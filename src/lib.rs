//! photondiff: photon mapping with photon differentials; every ray query goes through Intel
//! Embree over FFI.
//!
//! Flow, one module per concern: scene file ([`scene_file`], [`mesh_io`], [`shapes`]) -> scene
//! ([`scene`], [`camera`]) -> Embree scene ([`embree`]) -> camera paths with ray differentials
//! ([`differential`], [`view_path`]) -> radiance ([`direct`]) -> film ([`film`]) and statistics
//! ([`stats`]), driven by [`render`].

pub mod camera;
pub mod coplanar;
pub mod differential;
pub mod direct;
pub mod embree;
pub mod emission;
pub mod estimate;
pub mod experiment;
pub mod film;
pub mod footprint;
pub mod light_path;
pub mod lighting;
pub mod lighttrace;
pub mod mesh_io;
pub mod metrics;
pub mod multisampled;
pub mod photon_map;
pub mod photon_trace;
pub mod polygon;
pub mod progress;
pub mod reference;
pub mod render;
pub mod rng;
pub mod scene;
pub mod scene_file;
pub mod shapes;
pub mod stability;
pub mod stats;
pub mod surface;
pub mod view_path;
