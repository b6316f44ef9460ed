//! Rendering an image: the photon pass ([`photon_pass`]), then camera paths through mirrors and
//! glass ([`camera_path`]) to diffuse hits, where direct light ([`direct_light`]) and the photon
//! maps' estimates are summed into the film ([`film`]) by the rendering loop ([`image`]), which
//! splits pixels on geometric edges finer ([`edges`]); every
//! stage is timed and counted in the statistics ([`stats`]). Progressive renders ([`passes`])
//! average independent passes ([`pass_sum`]) and estimate the noise of their mean ([`noise`]).

pub mod camera_path;
pub mod checksum;
pub mod defaults;
pub mod direct_light;
pub mod edges;
pub mod film;
pub mod image;
pub mod merge;
pub mod noise;
pub mod part;
pub mod pass_part;
pub mod pass_sum;
pub mod passes;
pub mod photon_pass;
pub mod split;
pub mod stats;

pub use image::{render, render_image, RenderOptions, RenderedImage, TILE_SIZE};
pub use passes::{Progressive, StopRules};
pub use photon_pass::{load_photon_maps, trace_photon_maps};
pub use split::{TileSplit, Window};
