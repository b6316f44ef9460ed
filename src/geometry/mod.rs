//! Pure geometry, no scene: ray differentials ([`differential`]), the local surface at a hit
//! ([`surface`]), directions from uniform numbers ([`sampling`]), convex polygons
//! ([`polygon`]), the Epanechnikov kernel integrated over a parallelogram
//! ([`disc_integral`]) and formulas written once for one number and for SIMD lanes ([`lanes`]).

pub mod differential;
pub mod disc_integral;
pub mod lanes;
pub mod polygon;
pub mod sampling;
pub mod surface;
