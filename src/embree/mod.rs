//! The safe layer over Intel Embree (3 or 4) — the only module of photondiff that contains `unsafe`.
//!
//! Everything above this module sees safe types:
//! - [`Device`]: an Embree device whose error callback turns Embree errors into [`EmbreeError`];
//! - [`SceneBuilder`] takes triangle meshes (shared buffers, not copied) and instances of them
//!   (one BVH per mesh) and commits them into an immutable,
//!   `Send + Sync` [`Scene`];
//! - [`Scene::intersect`] / [`Scene::occluded`] for single rays and [`Scene::intersect16`] /
//!   [`Scene::occluded16`] for 16-wide packets, answering `Option<Hit>` / `bool`.
//! - [`advise_huge_pages`]: the kernel's advice for the large mesh buffers Embree shares.
//!
//! Debian's Embree keeps its internal assertions, so a ray with a NaN or infinite component (or one
//! beyond ~1.8e18, or a negative `tnear`) would abort the whole process. Every ray is therefore
//! validated here first ([`Ray::is_valid`]); an invalid ray is counted ([`Scene::invalid_rays`]) and
//! answered as a miss.
//!
//! Two backends, chosen by build.rs from what is installed (Embree 4 first, then Embree 3; the
//! features `embree3` / `embree4` force one): the bindings come from the installed headers, and
//! everything that differs between the two APIs (the arguments of the traversal calls) lives in
//! `v3.rs` / `v4.rs`. Nothing above this module sees which one is in use, except [`BACKEND`].

#[cfg(embree_api = "3")]
use v3 as api;
#[cfg(embree_api = "4")]
use v4 as api;

mod bounds;
mod bvh;
mod device;
mod ffi;
mod hit;
mod mesh;
mod pages;
mod query;
mod ray;
mod scene;
#[cfg(embree_api = "3")]
mod v3;
#[cfg(embree_api = "4")]
mod v4;

pub use bounds::GeometryBounds;
pub use bvh::{BvhQuality, BvhSettings, COMPACT_CHANGES_HITS, COMPACT_FROM_TRIANGLES};
pub use device::{Device, EmbreeError, EmbreeMemory};
pub use hit::Hit;
pub use mesh::{TriangleMesh, MAX_COORDINATE};
pub use pages::{advise_huge_pages, has_huge_page_advice, HUGE_PAGES_FROM_BYTES};
pub use query::RawRays;
pub use ray::Ray;
pub use scene::{Scene, SceneBuilder};

/// Width of the ray packets traced by [`Scene::intersect16`] and [`Scene::occluded16`].
pub const PACKET_WIDTH: usize = 16;

/// The Embree this build uses, e.g. "Embree 4.3.3": the version of the headers the bindings were
/// generated from. [`Device::new`] refuses a library of any other version.
pub const BACKEND: &str = concat!("Embree ", env!("PHOTONDIFF_EMBREE_VERSION"));

/// The Embree API major version this build uses (3 or 4).
#[cfg(embree_api = "3")]
pub const API_VERSION: u32 = 3;
/// The Embree API major version this build uses (3 or 4).
#[cfg(embree_api = "4")]
pub const API_VERSION: u32 = 4;
