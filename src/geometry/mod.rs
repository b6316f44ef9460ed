//! Pure geometry, no scene: ray differentials ([`differential`]), the local surface at a hit
//! ([`surface`]), directions from uniform numbers ([`sampling`]), convex polygons
//! ([`polygon`]) and the Epanechnikov kernel integrated over a parallelogram
//! ([`disc_integral`]).

pub mod differential;
pub mod disc_integral;
pub mod polygon;
pub mod sampling;
pub mod surface;
