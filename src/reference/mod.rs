//! Measurement rather than rendering: the unbiased light tracer ([`light_tracer`]) and its cached
//! references ([`cache`]), accuracy metrics and image regions ([`metrics`]), image comparison as
//! `photondiff compare` does it ([`channels`], [`compare`], [`error_map`]), the HTML report
//! ([`report`], [`chart`]), the bounds every
//! method must respect ([`stability`]), and methods as the experiments name them
//! ([`experiment`]).

pub mod cache;
pub mod channels;
pub mod chart;
pub mod compare;
pub mod error_map;
pub mod experiment;
pub mod light_tracer;
pub mod metrics;
pub mod report;
mod report_assets;
pub mod report_table;
pub mod stability;
