//! Pure geometry, no scene: ray differentials ([`differential`]), the local surface at a hit
//! ([`surface`]), directions from uniform numbers ([`sampling`]) and convex polygons
//! ([`polygon`]).

pub mod differential;
pub mod polygon;
pub mod sampling;
pub mod surface;
