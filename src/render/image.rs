//! The rendering loop: camera rays (with differentials) in 16-wide packets over tiles in
//! parallel, camera paths through specular surfaces, and radiance at the diffuse hits.
//!
//! Each pixel's value depends only on the scene, the options and the pixel (its random stream is
//! seeded by the run's seed and the pixel index), so an image is bit-identical whatever the
//! number of threads.

use crate::embree::{self, Hit, Ray, PACKET_WIDTH};
use crate::estimate::{
    ExactFootprint, FootprintRequest, GatherCounts, GatherQuery, RadianceEstimator,
};
use crate::geometry::surface::facing;
use crate::render::camera_path::{DiffuseVertex, PathTally, ViewPaths};
use crate::render::direct_light::DirectLight;
use crate::render::edges::{edge_pixels, EdgeMask};
use crate::render::film::Film;
use crate::render::split::Window;
use crate::render::stats::{RayCounts, Stats};
use crate::scene::Scene;
use crate::util::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;

/// Side of the square tiles rendered as units of parallel work.
pub const TILE_SIZE: u32 = 16;

/// Settings of a render. `RenderOptions::default()` gives the documented defaults; the `with_*`
/// methods change one setting each.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Camera rays per pixel along each axis (N x N on a regular grid, box-filtered). Default 1.
    pub view_grid: u32,
    /// Cells per axis of a pixel on a geometric edge ([`crate::render::edges`]): such a pixel
    /// is rendered on an N x N grid (when N exceeds `view_grid`), each cell with its own
    /// footprint, final gathering spending the pixel's rays over its cells. Default 1 (off).
    pub edge_grid: u32,
    /// Maximum number of specular bounces of a camera path. Default 10.
    pub max_depth: u32,
    /// Glass surfaces met after this many mirror or glass bounces take one branch, reflected or
    /// refracted with Fresnel's probability, instead of both ([`ViewPaths::split_depth`]).
    /// Default `None`: every glass surface splits the path in two.
    pub split_depth: Option<u32>,
    /// Area-light samples per diffuse hit, per light, along each axis (stratified). Default 4.
    pub area_strata: u32,
    /// Shadow rays to each point and spot light at a camera ray's first diffuse hit (seen
    /// directly, not through a mirror or glass), along each axis: `N x N` points spread over
    /// the ray's footprint there ([`crate::render::direct_light`]). Default 1 (the hit alone).
    pub footprint_strata: u32,
    /// Seed of all random streams. Default 0.
    pub seed: u64,
    /// Worker threads; 0 uses every core. Default 0.
    pub threads: usize,
    /// Whether to report progress on standard error (`util::progress`: bars on a terminal,
    /// lines elsewhere). Default false.
    pub progress: bool,
    /// Where in its cell of the view grid each camera ray passes, in `[0, 1)^2` of the cell.
    /// Default `[0.5, 0.5]`: the centre. Progressive passes move it from pass to pass
    /// ([`crate::render::passes`]).
    pub jitter: [f64; 2],
    /// The part of the image to render (whole render tiles, see [`crate::render::split`]);
    /// `None`, the default, renders all of it.
    pub window: Option<Window>,
    /// The edge pixels found beforehand ([`EdgeMask`]: a progressive run finds them once for
    /// all its passes); `None`, the default, finds them tile by tile (when `edge_grid` exceeds
    /// `view_grid`). Tiles outside the mask's window find their own.
    pub edges: Option<EdgeMask>,
}

/// A camera sample: `(pixel index in tile, x, y, cells per axis, cell [x0, y0, x1, y1])`.
type Sample = (usize, f64, f64, u32, [f64; 4]);

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            view_grid: 1,
            edge_grid: 1,
            max_depth: 10,
            split_depth: None,
            area_strata: 4,
            footprint_strata: 1,
            seed: 0,
            threads: 0,
            progress: false,
            jitter: [0.5, 0.5],
            window: None,
            edges: None,
        }
    }
}

impl RenderOptions {
    /// The grid an edge pixel is rendered on: [`RenderOptions::edge_grid`] where it is finer
    /// than the view grid, else 1 (edge pixels are not told apart).
    pub fn edge_grid_used(&self) -> u32 {
        if self.edge_grid > self.view_grid {
            self.edge_grid
        } else {
            1
        }
    }

    /// Sets [`RenderOptions::view_grid`].
    pub fn with_view_grid(mut self, n: u32) -> Self {
        self.view_grid = n;
        self
    }
    /// Sets [`RenderOptions::edge_grid`].
    pub fn with_edge_grid(mut self, n: u32) -> Self {
        self.edge_grid = n;
        self
    }
    /// Sets [`RenderOptions::max_depth`].
    pub fn with_max_depth(mut self, depth: u32) -> Self {
        self.max_depth = depth;
        self
    }
    /// Sets [`RenderOptions::split_depth`].
    pub fn with_split_depth(mut self, depth: Option<u32>) -> Self {
        self.split_depth = depth;
        self
    }
    /// Sets [`RenderOptions::area_strata`].
    pub fn with_area_strata(mut self, strata: u32) -> Self {
        self.area_strata = strata;
        self
    }
    /// Sets [`RenderOptions::footprint_strata`].
    pub fn with_footprint_strata(mut self, strata: u32) -> Self {
        self.footprint_strata = strata;
        self
    }
    /// Sets [`RenderOptions::seed`].
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }
    /// Sets [`RenderOptions::threads`].
    pub fn with_threads(mut self, threads: usize) -> Self {
        self.threads = threads;
        self
    }
    /// Sets [`RenderOptions::progress`].
    pub fn with_progress(mut self, progress: bool) -> Self {
        self.progress = progress;
        self
    }
    /// Sets [`RenderOptions::edges`].
    pub fn with_edges(mut self, edges: Option<EdgeMask>) -> Self {
        self.edges = edges;
        self
    }

    /// Sets [`RenderOptions::jitter`].
    pub fn with_jitter(mut self, jitter: [f64; 2]) -> Self {
        self.jitter = jitter;
        self
    }
    /// Sets [`RenderOptions::window`].
    pub fn with_window(mut self, window: Option<Window>) -> Self {
        self.window = window;
        self
    }
    /// The size of the film a render with these options makes for a `width` x `height`
    /// camera: the window's, or the whole image's.
    pub fn film_size(&self, width: u32, height: u32) -> (u32, u32) {
        self.window
            .map_or((width, height), |w| (w.width(), w.height()))
    }
}

/// A rendered image and where the first estimator (the caustic map's, as
/// [`crate::photons::PhotonMaps::estimators`] orders them) contributed.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedImage {
    /// The image.
    pub film: Film,
    /// Per pixel (row-major): whether the first estimator returned non-zero radiance for any of
    /// the pixel's camera rays. All false without estimators.
    pub reach: Vec<bool>,
    /// Per pixel: whether any of the pixel's camera rays saw a light's surface (directly or
    /// through mirrors and glass). Its outline swings between passes with the camera's jitter
    /// (a light many times brighter than what it lights), which the noise estimate leaves out.
    pub lights: Vec<bool>,
}

/// What one tile produced.
struct TileResult {
    pixels: Vec<DVec3>,
    reach: Vec<bool>,
    lights: Vec<bool>,
    rays: RayCounts,
    cut_at_max_depth: u64,
    edge_pixels: u64,
    gathers: GatherCounts,
}

impl TileResult {
    /// A tile not rendered (cut short by a stop).
    fn black(tile: Tile) -> Self {
        let n = ((tile.x1 - tile.x0) * (tile.y1 - tile.y0)) as usize;
        TileResult {
            pixels: vec![DVec3::ZERO; n],
            reach: vec![false; n],
            lights: vec![false; n],
            rays: RayCounts::default(),
            cut_at_max_depth: 0,
            edge_pixels: 0,
            gathers: GatherCounts::default(),
        }
    }
}

/// A rectangle of pixels `[x0, x1) x [y0, y1)`.
#[derive(Debug, Clone, Copy)]
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

/// Renders `scene` (already built into `embree`) and records the "render" stage in `stats`.
/// The film is the options' window (the whole image by default), its pixels bit-identical to
/// the same pixels of a whole render. Radiance at each diffuse hit is the direct light plus the sum of the `estimators` (the
/// caustic and global photon map estimates; none for direct light only).
pub fn render(
    scene: &Scene,
    embree: &embree::Scene,
    estimators: &[&dyn RadianceEstimator],
    options: &RenderOptions,
    stats: &mut Stats,
) -> Result<Film, String> {
    render_image(scene, embree, estimators, options, stats).map(|r| r.film)
}

/// [`render`], also returning where the first estimator contributed.
pub fn render_image(
    scene: &Scene,
    embree: &embree::Scene,
    estimators: &[&dyn RadianceEstimator],
    options: &RenderOptions,
    stats: &mut Stats,
) -> Result<RenderedImage, String> {
    if !(1..=64).contains(&options.view_grid) {
        return Err(format!(
            "view grid must be in 1..=64, got {}",
            options.view_grid
        ));
    }
    if !(1..=64).contains(&options.edge_grid) {
        return Err(format!(
            "edge grid must be in 1..=64, got {}",
            options.edge_grid
        ));
    }
    let (width, height) = (scene.camera.width, scene.camera.height);
    let window = options.window.unwrap_or(Window::full(width, height));
    window.check(width, height)?;
    let tiles: Vec<Tile> = (window.y0 / TILE_SIZE..window.y1.div_ceil(TILE_SIZE))
        .flat_map(|ty| {
            (window.x0 / TILE_SIZE..window.x1.div_ceil(TILE_SIZE)).map(move |tx| Tile {
                x0: tx * TILE_SIZE,
                y0: ty * TILE_SIZE,
                x1: ((tx + 1) * TILE_SIZE).min(width),
                y1: ((ty + 1) * TILE_SIZE).min(height),
            })
        })
        .collect();
    let pool = crate::util::pool::workers(options.threads)?;
    stats.threads = pool.current_num_threads();
    let progress = crate::util::progress::bar(options.progress, tiles.len() as u64, "render");
    let invalid_before = embree.invalid_rays();
    let renderer = TileRenderer::new(scene, embree, estimators, options);
    // The tiles' assembly into the film is part of the stage (it was in none: 5 ms a pass at
    // 640 x 480).
    let (film, reach, lights, results) = stats.time("render", || {
        let results: Vec<TileResult> = pool.install(|| {
            tiles
                .par_iter()
                .map(|tile| {
                    // A stop requested: the tile is left black and the pass dropped (and no
                    // span drawn for it: a dropped pass showed every skipped tile as one).
                    if crate::util::interrupt::cut_short() {
                        progress.inc(1);
                        return TileResult::black(*tile);
                    }
                    let _span = crate::util::trace::span_with("tile", || {
                        serde_json::json!({"x0": tile.x0, "y0": tile.y0, "x1": tile.x1, "y1": tile.y1})
                    });
                    let r = renderer.render_tile(*tile);
                    progress.inc(1);
                    r
                })
                .collect()
        });
        let mut film = Film::new(window.width(), window.height());
        let mut reach = vec![false; film.pixels.len()];
        let mut lights = vec![false; film.pixels.len()];
        for (tile, result) in tiles.iter().zip(&results) {
            let tw = (tile.x1 - tile.x0) as usize;
            for (k, p) in result.pixels.iter().enumerate() {
                let (x, y) = (tile.x0 + (k % tw) as u32, tile.y0 + (k / tw) as u32);
                let i = ((y - window.y0) * window.width() + (x - window.x0)) as usize;
                film.pixels[i] = *p;
                reach[i] = result.reach[k];
                lights[i] = result.lights[k];
            }
        }
        (film, reach, lights, results)
    });
    progress.finish_and_clear();
    for result in &results {
        stats.rays.add(&result.rays);
        stats.paths_cut_at_max_depth += result.cut_at_max_depth;
        stats.edge_pixels += result.edge_pixels;
        stats.gathers.add(&result.gathers);
    }
    stats.invalid_rays += embree.invalid_rays() - invalid_before;
    Ok(RenderedImage {
        film,
        reach,
        lights,
    })
}

/// Renders tiles; shared read-only by all workers.
struct TileRenderer<'a> {
    scene: &'a Scene,
    embree: &'a embree::Scene,
    options: &'a RenderOptions,
    estimators: &'a [&'a dyn RadianceEstimator],
    paths: ViewPaths<'a>,
    direct: DirectLight<'a>,
}

impl<'a> TileRenderer<'a> {
    fn new(
        scene: &'a Scene,
        embree: &'a embree::Scene,
        estimators: &'a [&'a dyn RadianceEstimator],
        options: &'a RenderOptions,
    ) -> Self {
        let epsilon = scene.ray_epsilon();
        TileRenderer {
            scene,
            embree,
            options,
            estimators,
            paths: ViewPaths {
                scene,
                embree,
                max_depth: options.max_depth,
                split_depth: options.split_depth,
                epsilon,
            },
            direct: DirectLight {
                scene,
                embree,
                area_strata: options.area_strata,
                footprint_strata: options.footprint_strata,
                jitter: options.jitter,
                epsilon,
            },
        }
    }

    /// Camera samples of a tile in 4 x 4 pixel blocks, so that each packet of 16 rays is
    /// coherent: `(pixel index in tile, x, y, cells per axis, cell)` in continuous pixel
    /// coordinates, each at the options' jitter within its cell `[x0, y0, x1, y1]`: the view
    /// grid's, or the edge grid's for a pixel flagged in `edge`. (A cell's sides are computed
    /// as `pixel + i / n` on either side, so that neighbouring cells share them exactly.)
    fn samples(&self, tile: Tile, edge: &[bool]) -> Vec<Sample> {
        let [jx, jy] = self.options.jitter;
        let tw = tile.x1 - tile.x0;
        let mut samples = Vec::new();
        for by in (tile.y0..tile.y1).step_by(4) {
            for bx in (tile.x0..tile.x1).step_by(4) {
                for y in by..(by + 4).min(tile.y1) {
                    for x in bx..(bx + 4).min(tile.x1) {
                        let pixel = ((y - tile.y0) * tw + (x - tile.x0)) as usize;
                        let n = if edge.get(pixel) == Some(&true) {
                            self.options.edge_grid.max(self.options.view_grid)
                        } else {
                            self.options.view_grid
                        };
                        let side = |p: u32, i: u32| p as f64 + i as f64 / n as f64;
                        for j in 0..n {
                            for i in 0..n {
                                samples.push((
                                    pixel,
                                    x as f64 + (i as f64 + jx) / n as f64,
                                    y as f64 + (j as f64 + jy) / n as f64,
                                    n,
                                    [side(x, i), side(y, j), side(x, i + 1), side(y, j + 1)],
                                ));
                            }
                        }
                    }
                }
            }
        }
        samples
    }

    fn render_tile(&self, tile: Tile) -> TileResult {
        let camera = &self.scene.camera;
        let view_grid = self.options.view_grid;
        let tw = (tile.x1 - tile.x0) as usize;
        let mut pixels = vec![DVec3::ZERO; tw * (tile.y1 - tile.y0) as usize];
        let mut reach = vec![false; pixels.len()];
        let mut lights = vec![false; pixels.len()];
        let mut tally = PathTally::default();
        let edge = if self.options.edge_grid_used() > 1 {
            let rect = (tile.x0, tile.y0, tile.x1, tile.y1);
            match self.options.edges.as_ref().and_then(|m| m.tile(rect)) {
                Some(edge) => edge,
                None => {
                    let (edge, corner_rays) = edge_pixels(self.scene, self.embree, rect);
                    tally.rays.camera += corner_rays;
                    edge
                }
            }
        } else {
            Vec::new()
        };
        let samples = self.samples(tile, &edge);
        let wants_exact = self.estimators.iter().any(|e| e.reads_exact_footprint());
        let mut gathers = GatherCounts::default();
        let mut vertices: Vec<DiffuseVertex> = Vec::new();
        let mut radiance = [DVec3::ZERO; PACKET_WIDTH];
        let mut hits: [Option<Hit>; PACKET_WIDTH] = [None; PACKET_WIDTH];
        let mut rays = [Ray::new(DVec3::ZERO, DVec3::X); PACKET_WIDTH];
        // A packet's gathers, as estimators that read one point and estimators that
        // integrate the view footprint see them, with their shares, and the answers.
        let (mut queries, mut centred_queries) = (Vec::new(), Vec::new());
        let (mut shares, mut answers) = (Vec::new(), Vec::new());
        // The packet's exact footprints: what each is prepared from, whose it is, the
        // footprints.
        let (mut exact_requests, mut exact_owners, mut exact_footprints) =
            (Vec::new(), Vec::new(), Vec::new());
        // One random stream per tile, seeded by the run's seed and the tile's first pixel:
        // independent of which thread renders the tile.
        let first_pixel = tile.y0 as u64 * camera.width as u64 + tile.x0 as u64;
        let mut rng = Rng::new(self.options.seed, first_pixel);
        for chunk in samples.chunks(PACKET_WIDTH) {
            let differentials: Vec<_> = chunk
                .iter()
                .map(|&(_, x, y, n, _)| camera.ray(x, y, 1.0 / n as f64))
                .collect();
            for (ray, diff) in rays.iter_mut().zip(&differentials) {
                *ray = Ray::new(diff.p, diff.d);
            }
            self.embree
                .intersect16(&rays[..chunk.len()], true, &mut hits);
            tally.rays.camera += chunk.len() as u64;
            vertices.clear();
            radiance.fill(DVec3::ZERO);
            for (lane, diff) in differentials.iter().enumerate() {
                let n = chunk[lane].3;
                self.paths.follow(
                    diff,
                    hits[lane],
                    DVec3::splat(1.0 / (n * n) as f64),
                    0,
                    lane,
                    &mut vertices,
                    &mut radiance[lane],
                    &mut tally,
                    &mut rng,
                );
            }
            // Before direct light is added, a lane's radiance is the light it saw.
            for (lane, &(pixel, ..)) in chunk.iter().enumerate() {
                lights[pixel] |= radiance[lane] != DVec3::ZERO;
            }
            tally.rays.shadow += self.direct.add(&vertices, &mut rng, &mut radiance);
            if !self.estimators.is_empty() && !vertices.is_empty() {
                let [jx, jy] = self.options.jitter;
                queries.clear();
                centred_queries.clear();
                shares.clear();
                exact_requests.clear();
                exact_owners.clear();
                for (j, v) in vertices.iter().enumerate() {
                    let query = GatherQuery {
                        position: v.hit.position,
                        normal: facing(v.hit.geometric_normal, v.ray.d),
                        albedo: v.albedo,
                        footprint: v.ray.dp,
                        exact: None,
                    };
                    // The footprint of the ray's cell, to first order: where the cell's centre
                    // ray would have hit (the hit itself when centred).
                    let centred = GatherQuery {
                        position: v.ray.cell_centre(query.position, [jx, jy]),
                        ..query
                    };
                    // The cell's exact footprint where the hit is seen directly, once for
                    // every estimator that integrates over it: prepared below with the
                    // packet's others.
                    if wants_exact && v.depth == 0 {
                        exact_requests.push(FootprintRequest {
                            cell: chunk[v.sample].4,
                            point: v.hit.position,
                            normal: v.hit.geometric_normal,
                            x: centred.position,
                            footprint: v.ray.dp,
                        });
                        exact_owners.push(j);
                    }
                    queries.push(query);
                    centred_queries.push(centred);
                    // A cell of an edge pixel spends its share of a view cell's effort
                    // (1 for the view grid's own cells).
                    shares.push((view_grid as f64 / chunk[v.sample].3 as f64).powi(2));
                }
                // The exact footprints in SIMD lanes, each weighted by the image area its
                // parts stand for (the pixel filter is a box on the image, not on the surface).
                ExactFootprint::prepare_many(camera, &exact_requests, &mut exact_footprints);
                for (&j, exact) in exact_owners.iter().zip(&exact_footprints) {
                    centred_queries[j].exact = *exact;
                }
                // Every estimator answers the packet's gathers at once; the answers are added
                // in the order vertex by vertex, estimator by estimator.
                answers.resize(self.estimators.len() * vertices.len(), DVec3::ZERO);
                for (estimator, out) in self
                    .estimators
                    .iter()
                    .zip(answers.chunks_mut(vertices.len()))
                {
                    let at = if estimator.integrates_view_footprint() {
                        &centred_queries
                    } else {
                        &queries
                    };
                    estimator.radiance_batch(at, &shares, out, &mut gathers);
                }
                for (j, v) in vertices.iter().enumerate() {
                    for k in 0..self.estimators.len() {
                        let l = answers[k * vertices.len() + j];
                        if k == 0 && l != DVec3::ZERO {
                            reach[chunk[v.sample].0] = true;
                        }
                        radiance[v.sample] += v.weight * l;
                    }
                }
            }
            for (lane, &(pixel, ..)) in chunk.iter().enumerate() {
                pixels[pixel] += radiance[lane];
            }
        }
        TileResult {
            pixels,
            reach,
            lights,
            rays: tally.rays,
            cut_at_max_depth: tally.cut_at_max_depth,
            edge_pixels: edge.iter().filter(|&&e| e).count() as u64,
            gathers,
        }
    }
}
