//! Pixels on a geometric edge: where the rays through a pixel's four corners first meet
//! different surfaces (an object's outline against what lies behind it, two walls meeting), or
//! one mesh whose normal turns by more than [`CREASE_COSINE`] allows between them (a crease, a
//! mesh's outline against itself). But not a mirror or glass mesh rippled finer than the pixel
//! ([`finer_than_the_pixel`]: three or more facets among the four corners, and no jump in
//! distance): a finely displaced glass mesh turns its normal within almost every pixel it
//! covers, and its pixels are no edges but texture, which the path goes on through. (Flagged
//! as creases, 58% of the production scene's pixels were edges; a long `integrated` run, whose
//! edge grid of 8 renders each edge pixel as 64 cells, took 17 times as long a pass.) A crease
//! between two facets shows two, and stays an edge.
//!
//! Such a pixel sees two surfaces, but its one camera ray finds one of them, and an estimate
//! that integrates over the ray's footprint (`integrated`, final gathering's disc) spreads that
//! surface's light over the whole pixel, including the part another surface hides. In the
//! closed scene (`scenes/cornell-glass.toml`) that made the floor in front of the glass sphere's
//! foot 20-60% too bright: its caustic is brightest where the sphere hides it. Rendering the
//! edge pixels alone on a finer grid of cells, each with its own smaller footprint, confines
//! each cell's estimate to what it sees, for about one extra ray per pixel (the corners) plus
//! the cells of the few edge pixels.

use crate::embree::{self, Hit, Ray, PACKET_WIDTH};
use crate::render::image::TILE_SIZE;
use crate::render::split::Window;
use crate::scene::Scene;
use glam::DVec3;

/// Corner rays meeting one mesh see one surface while their geometric normals agree within
/// this cosine (about 26 degrees): finer than any crease worth the name, coarser than the
/// facets of a tessellated curve (a 64-segment sphere's neighbours differ by under 6 degrees).
pub const CREASE_COSINE: f64 = 0.9;

/// Corner rays meeting one rippled mirror or glass mesh ([`finer_than_the_pixel`]) see one
/// surface while their distances differ by at most this fraction of the nearer: a continuous
/// surface one pixel's angle across (about 1.5 mrad for 40 degrees over 480 rows) changes its
/// distance by more only where it is within about a degree of grazing; the mesh's outline
/// against itself (a ring's far side behind its near one) jumps by its thickness.
pub const SPECULAR_JUMP: f64 = 0.1;

/// Corner rays' normals closer than this cosine (about 0.26 degrees) lie on one facet: the
/// triangles of one flat face agree to their vertices' rounding.
const SAME_FACET_COSINE: f64 = 0.99999;

/// What a corner ray meets first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CornerHit {
    /// The mesh.
    pub geom_id: u32,
    /// Its geometric normal there.
    pub normal: DVec3,
    /// The ray's distance to it.
    pub distance: f64,
    /// Whether its material is a mirror or glass.
    pub specular: bool,
}

impl CornerHit {
    /// The corner hit `hit` of a ray of `scene`.
    pub fn of(scene: &Scene, hit: &Hit) -> Self {
        CornerHit {
            geom_id: hit.geom_id,
            normal: hit.geometric_normal,
            distance: hit.t,
            specular: scene.material(hit.geom_id).is_specular(),
        }
    }
}

/// Whether two corner rays' first hits lie on one smooth surface: the same mesh, with normals
/// within [`CREASE_COSINE`].
pub fn same_surface(a: Option<CornerHit>, b: Option<CornerHit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => a.geom_id == b.geom_id && a.normal.dot(b.normal) >= CREASE_COSINE,
        _ => false,
    }
}

/// Whether a pixel's four corner rays meet one mirror or glass mesh rippled finer than the
/// pixel: the same specular mesh at every corner, no two distances apart by more than
/// [`SPECULAR_JUMP`] of the nearer, and three or more facets among the corners' normals (a
/// crease between two faces shows two).
pub fn finer_than_the_pixel(corners: &[Option<CornerHit>; 4]) -> bool {
    let Some(hits) = corners.iter().copied().collect::<Option<Vec<CornerHit>>>() else {
        return false;
    };
    let one_mesh = hits
        .iter()
        .all(|h| h.specular && h.geom_id == hits[0].geom_id);
    let continuous = hits.iter().all(|a| {
        hits.iter()
            .all(|b| (a.distance - b.distance).abs() <= SPECULAR_JUMP * a.distance.min(b.distance))
    });
    let mut facets: Vec<DVec3> = Vec::with_capacity(4);
    for h in &hits {
        if !facets.iter().any(|n| n.dot(h.normal) >= SAME_FACET_COSINE) {
            facets.push(h.normal);
        }
    }
    one_mesh && continuous && facets.len() >= 3
}

/// Which pixels of the rectangle `[x0, x1) x [y0, y1)` lie on a geometric edge (row-major,
/// `(x1 - x0) * (y1 - y0)` flags), and the corner rays traced to tell.
pub fn edge_pixels(
    scene: &Scene,
    embree: &embree::Scene,
    (x0, y0, x1, y1): (u32, u32, u32, u32),
) -> (Vec<bool>, u64) {
    let camera = &scene.camera;
    let (cw, ch) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let corners: Vec<(f64, f64)> = (0..ch)
        .flat_map(|j| (0..cw).map(move |i| ((x0 as usize + i) as f64, (y0 as usize + j) as f64)))
        .collect();
    let mut surface = Vec::with_capacity(corners.len());
    let mut hits: [Option<Hit>; PACKET_WIDTH] = [None; PACKET_WIDTH];
    let mut rays = [Ray::new(DVec3::ZERO, DVec3::X); PACKET_WIDTH];
    for chunk in corners.chunks(PACKET_WIDTH) {
        for (ray, &(x, y)) in rays.iter_mut().zip(chunk) {
            let d = camera.ray(x, y, 1.0);
            *ray = Ray::new(d.p, d.d);
        }
        embree.intersect16(&rays[..chunk.len()], true, &mut hits);
        surface.extend(
            hits[..chunk.len()]
                .iter()
                .map(|h| h.map(|h| CornerHit::of(scene, &h))),
        );
    }
    let (w, h) = (cw - 1, ch - 1);
    let edges = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c =
                [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)].map(|(i, j)| surface[j * cw + i]);
            (0..4).any(|a| (a + 1..4).any(|b| !same_surface(c[a], c[b])))
                && !finer_than_the_pixel(&c)
        })
        .collect();
    (edges, corners.len() as u64)
}

/// The edge flags of a rectangle of the image (a film: the whole image or a render's window),
/// found once and shared by every pass of a progressive run: the corner rays pass through the
/// pixels' corners, which do not move from pass to pass, so one run needs them once, not once a
/// pass.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeMask {
    /// The part of the image the flags cover.
    window: Window,
    /// Row-major flags over the window.
    flags: std::sync::Arc<[bool]>,
}

impl EdgeMask {
    /// The edge pixels of `window`, bands of [`TILE_SIZE`] rows in parallel, and the corner
    /// rays traced: the flags are [`edge_pixels`]'s, which depend on a pixel's own corners
    /// alone.
    pub fn find(scene: &Scene, embree: &embree::Scene, window: Window) -> (Self, u64) {
        use rayon::prelude::*;
        let Window { x0, y0, x1, y1 } = window;
        let bands: Vec<(Vec<bool>, u64)> = (y0..y1)
            .step_by(TILE_SIZE as usize)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|y| edge_pixels(scene, embree, (x0, y, x1, (y + TILE_SIZE).min(y1))))
            .collect();
        // (Neighbouring bands each trace their shared row of corners: the count is of rays traced.)
        let rays = bands.iter().map(|b| b.1).sum();
        let flags: Vec<bool> = bands.into_iter().flat_map(|(f, _)| f).collect();
        (
            EdgeMask {
                window,
                flags: flags.into(),
            },
            rays,
        )
    }

    /// The flags of the tile `[x0, x1) x [y0, y1)` (row-major), or `None` when the tile is not
    /// inside this mask's window.
    pub fn tile(&self, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> Option<Vec<bool>> {
        let Window {
            x0: rx0,
            y0: ry0,
            x1: rx1,
            y1: ry1,
        } = self.window;
        if x0 < rx0 || y0 < ry0 || x1 > rx1 || y1 > ry1 {
            return None;
        }
        let w = self.window.width() as usize;
        Some(
            (y0..y1)
                .flat_map(|y| {
                    let row = (y - ry0) as usize * w;
                    (x0..x1).map(move |x| row + (x - rx0) as usize)
                })
                .map(|i| self.flags[i])
                .collect(),
        )
    }

    /// How many pixels of the mask lie on an edge.
    pub fn count(&self) -> usize {
        self.flags.iter().filter(|&&e| e).count()
    }
}
