//! The safe layer over Intel Embree 3 — the only module of photondiff that contains `unsafe`.
//!
//! Everything above this module sees safe types:
//! - [`Device`]: an Embree device whose error callback turns Embree errors into [`EmbreeError`];
//! - [`SceneBuilder`] takes triangle meshes (shared buffers) and commits them into an immutable,
//!   `Send + Sync` [`Scene`];
//! - [`Scene::intersect`] / [`Scene::occluded`] for single rays and [`Scene::intersect16`] /
//!   [`Scene::occluded16`] for 16-wide packets, answering `Option<Hit>` / `bool`.
//!
//! Debian's Embree keeps its internal assertions, so a ray with a NaN or infinite component (or one
//! beyond ~1.8e18, or a negative `tnear`) would abort the whole process. Every ray is therefore
//! validated here first ([`Ray::is_valid`]); an invalid ray is counted ([`Scene::invalid_rays`]) and
//! answered as a miss.
//!
//! Embree 4 differs from Embree 3 mainly in the arguments of `rtcIntersect1`/`rtcOccluded1`
//! (optional argument structs instead of a context): all of those calls live in `query.rs`, so a
//! second backend replaces that file and the bindings, nothing above this module.

mod device;
mod ffi;
mod hit;
mod query;
mod ray;
mod scene;

pub use device::{Device, EmbreeError};
pub use hit::Hit;
pub use query::RawRays;
pub use ray::Ray;
pub use scene::{Scene, SceneBuilder, TriangleMesh};

/// Width of the ray packets traced by [`Scene::intersect16`] and [`Scene::occluded16`].
pub const PACKET_WIDTH: usize = 16;
