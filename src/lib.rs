//! photondiff: photon mapping with photon differentials; every ray query goes through Intel
//! Embree over FFI.
//!
//! The folders are the stages, in the order data flows through them:
//!
//! scene file -> [`scene`] -> [`embree`] scene -> [`photons`] (tracing, photon maps) ->
//! [`estimate`] (radiance estimators) -> [`render`] (camera paths, direct light, the rendering
//! loop, film, statistics) -> EXR/PNG.
//!
//! Beside them: [`geometry`] (ray differentials, surface frames, polygons: pure math),
//! [`reference`](mod@reference) (the light tracer, metrics and experiments that measure the renderer) and
//! [`util`] (random numbers, progress). Dependencies run one way: `reference` -> `render` ->
//! `estimate` -> `photons` -> `scene` -> `geometry` -> `embree`, with `util` below all; no module
//! imports one above it. `unsafe` lives in [`embree`] alone. So [`embree`] is second in the
//! data's order and last in the dependencies': it is the safe wrapper the scene builds its
//! Embree scene with (`Scene::build_embree`) and every stage above traces rays through, and it
//! knows nothing of them (its meshes are its own `TriangleMesh`, which the scene holds).

// Standard error through `stderr_line!` (`util::stderr`), which cannot panic.
#![deny(clippy::print_stderr)]

pub mod embree;
pub mod estimate;
pub mod geometry;
pub mod photons;
pub mod reference;
pub mod render;
pub mod scene;
pub mod util;
