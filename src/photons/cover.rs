//! The exact test behind footprint range queries: whether a photon's kernel may be non-zero
//! anywhere in a view footprint ([`may_cover`]), and the same test on a BVH leaf's photons (up
//! to sixteen) at once in SIMD lanes ([`CoverTable`]).
//!
//! Why a table beside the photons: a query tests about four photons for every one it keeps (box
//! against box lets through the corners and, for needle-shaped footprints, most of the box), and
//! testing them one at a time from the 80-byte photons was a sixth of the default render. The
//! table holds only what the test reads, in leaf slots, so a leaf's photons load as sixteen
//! lanes (`f32x16`: one AVX-512 register here, two AVX halves elsewhere; a leaf of sixteen costs
//! about what a leaf of eight did, and the tree is half as large: at 1,280,000 photons the render
//! stage fell 7-9%, at 20,000 it did not move).

use crate::photons::footprint_bvh::LEAF_SIZE;
use crate::photons::map::Photon;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wide::f32x16;

mod found;
pub use found::{Found, InFilterSpace, OnSurface};

/// How far off its tangent plane a query point may lie and still see a photon, as a fraction of
/// the photon's radius (`estimate::on_query_surface`).
pub const OFF_PLANE_TOLERANCE: f32 = 0.1;

/// Photons stored on a surface facing another way than the query's (the other side of a thin
/// wall, a sharp edge) do not contribute: the cosine between the normals must exceed this.
pub const MIN_NORMAL_COSINE: f32 = 0.7;

/// Whether photon normal `n_p` agrees with the query normal `n_x`.
#[inline]
pub fn same_side(n_p: Vec3, n_x: Vec3) -> bool {
    n_p.dot(n_x) > MIN_NORMAL_COSINE
}

/// Rounding slack of the filter-space tests (in units of the kernel's radius).
const SLACK: f32 = 1e-4;

/// Edges shorter than this (squared, in filter space) give no separating axis.
const MIN_EDGE_SQUARED: f32 = 1e-30;

/// Whether photon `p`'s kernel, seen from a query point at offset `v = x - x_p` on its surface
/// slab, may be non-zero somewhere in the view footprint `x + alpha f0 + beta f1`,
/// `|alpha|, |beta| <= 1/2`, given as `f = [M f0, M f1]` in the photon's filter space: the
/// parallelogram `s + alpha a + beta b` (`s = M v`) and the unit disc are not separated along
/// `s`'s direction (the bounding circle), nor along either edge's normal (separating axes).
/// Exact in `M` (no assumption on its rows); a small slack covers rounding.
///
/// Written without divisions or square roots, as the SIMD test is, so that both give the same
/// answer. With `c = 1 + SLACK`: the circle test `|s| > c + |a +- b|max / 2` is
/// `|s|^2 - c^2 - D/4 > c sqrt(D)` (`D` the larger of `|a + b|^2`, `|a - b|^2`), both sides
/// squared where the left is positive; the axis test along edge `e` (other edge `o`),
/// `|perp(e) s| / |e| > c + |perp(e) o| / (2 |e|)`, is multiplied through by `|e|` and squared
/// the same way. (Rounding moves the answer by far less than the slack. Without the three
/// square roots a photon and query, whose unit is not pipelined as the multipliers are, the
/// render stage of `integrated` and `pd` at 1,280,000 photons fell 1-2%, with the same photons
/// found and the same images.)
#[inline]
pub fn may_cover(p: &Photon, v: Vec3, f: [Vec3; 2]) -> bool {
    if p.normal.dot(v).abs() > OFF_PLANE_TOLERANCE * p.radius {
        return false;
    }
    let s = Vec2::new(p.m[0].dot(v), p.m[1].dot(v));
    let a = Vec2::new(p.m[0].dot(f[0]), p.m[1].dot(f[0]));
    let b = Vec2::new(p.m[0].dot(f[1]), p.m[1].dot(f[1]));
    let (p0, p1) = (a.x + b.x, a.y + b.y);
    let (d0, d1) = (a.x - b.x, a.y - b.y);
    let reach2 = (p0 * p0 + p1 * p1).max(d0 * d0 + d1 * d1);
    let beyond = (s.x * s.x + s.y * s.y) - C2 - 0.25 * reach2;
    if beyond > 0.0 && beyond * beyond > C2 * reach2 {
        return false;
    }
    // perp_dot(x, y) = x0 y1 - x1 y0.
    let cross = (a.x * b.y - a.y * b.x).abs();
    for e in [a, b] {
        let len2 = e.x * e.x + e.y * e.y;
        let beyond = (e.x * s.y - e.y * s.x).abs() - 0.5 * cross;
        if len2 > MIN_EDGE_SQUARED && beyond > 0.0 && beyond * beyond > C2 * len2 {
            return false;
        }
    }
    true
}

/// `(1 + SLACK)^2`, the squared reach of the kernel's support with its slack.
const C2: f32 = (1.0 + SLACK) * (1.0 + SLACK);

/// What [`may_cover`] reads of each photon, as a structure of arrays in the photon map's order
/// (the footprint BVH's leaf slots), padded so that a leaf's lanes load from any slot.
#[derive(Default)]
pub struct CoverTable {
    /// Position, x, y, z.
    position: [Vec<f32>; 3],
    /// Filter matrix rows `m[0]` and `m[1]`, x, y, z each.
    m: [[Vec<f32>; 3]; 2],
    /// Normal, x, y, z.
    normal: [Vec<f32>; 3],
    /// Half-thickness of the slab, `OFF_PLANE_TOLERANCE * radius`.
    slab: Vec<f32>,
}

/// Photons a worker task of [`CoverTable::new`] takes at once.
const BLOCK: usize = 1 << 14;

/// Number of the table's columns.
const COLUMNS: usize = 13;

/// Photon `p`'s entries in the table's columns: position, filter rows, normal, slab.
#[inline]
fn row(p: &Photon) -> [f32; COLUMNS] {
    let [px, py, pz] = p.position.to_array();
    let [m00, m01, m02] = p.m[0].to_array();
    let [m10, m11, m12] = p.m[1].to_array();
    let [nx, ny, nz] = p.normal.to_array();
    let slab = OFF_PLANE_TOLERANCE * p.radius;
    [px, py, pz, m00, m01, m02, m10, m11, m12, nx, ny, nz, slab]
}

/// A view footprint to test photons against: its centre, edges and surface normal, in every
/// lane.
#[derive(Clone, Copy)]
pub struct CoverQuery {
    c: [Lanes; 3],
    f: [[Lanes; 3]; 2],
    n: [Lanes; 3],
}

impl CoverQuery {
    /// The footprint `c +- f[0]/2 +- f[1]/2` on a surface of normal `n`.
    pub fn new(c: Vec3, f: [Vec3; 2], n: Vec3) -> Self {
        let splat = |v: Vec3| [Lanes::splat(v.x), Lanes::splat(v.y), Lanes::splat(v.z)];
        CoverQuery {
            c: splat(c),
            f: [splat(f[0]), splat(f[1])],
            n: splat(n),
        }
    }
}

impl CoverTable {
    /// The table of `photons` in the order `order`: slot `k` holds `photons[order[k]]`.
    ///
    /// One pass over the photons, a block of slots per worker task: each 80-byte photon is read
    /// once for all thirteen columns. (A pass per column on one thread read the photons
    /// thirteen times and took about 0.14 s of the 0.45 s that loading 1.28M photons took.)
    pub fn new(photons: &[Photon], order: &[u32]) -> Self {
        let len = order.len();
        // Padding after the last photon: a leaf's lanes always load.
        let n = len + LANES - 1;
        let mut columns: [Vec<f32>; COLUMNS] = std::array::from_fn(|_| vec![0.0; n]);
        // Each column cut into blocks, then the blocks regrouped: block `k` of every column.
        let mut cut: Vec<_> = columns
            .iter_mut()
            .map(|c| c[..len].chunks_mut(BLOCK))
            .collect();
        let blocks: Vec<Vec<&mut [f32]>> = (0..len.div_ceil(BLOCK))
            .map(|_| cut.iter_mut().map(|c| c.next().expect("a block")).collect())
            .collect();
        order
            .par_chunks(BLOCK)
            .zip(blocks)
            .for_each(|(order, mut block)| {
                for (k, &i) in order.iter().enumerate() {
                    for (column, value) in block.iter_mut().zip(row(&photons[i as usize])) {
                        column[k] = value;
                    }
                }
            });
        let [px, py, pz, m00, m01, m02, m10, m11, m12, nx, ny, nz, slab] = columns;
        CoverTable {
            position: [px, py, pz],
            m: [[m00, m01, m02], [m10, m11, m12]],
            normal: [nx, ny, nz],
            slab,
        }
    }

    /// Appends to `out` the slots among `first..first + count` (`count <= 16`, a leaf of the
    /// footprint BVH) that [`may_cover`] the footprint of `q`, in order.
    // Out of line: inlined into the walk's loop it made `pd`'s render 3-4% slower.
    #[inline(never)]
    pub fn leaf<T: Found>(&self, first: usize, count: usize, q: &CoverQuery, out: &mut Vec<T>) {
        let leaf = self.load(first, count);
        push_found(first, &leaf, q, out);
    }

    /// [`CoverTable::leaf`] for each query `j` of `queries` in the mask `queries_meeting`,
    /// into `outs[j]`: the leaf's lanes are loaded once for all of them.
    #[inline]
    pub fn leaf_packet<T: Found>(
        &self,
        first: usize,
        count: usize,
        queries: &[CoverQuery],
        mut queries_meeting: u32,
        outs: &mut [Vec<T>],
    ) {
        let leaf = self.load(first, count);
        while queries_meeting != 0 {
            let j = queries_meeting.trailing_zeros() as usize;
            queries_meeting &= queries_meeting - 1;
            push_found(first, &leaf, &queries[j], &mut outs[j]);
        }
    }

    /// Position and filter matrix rows of the photon in `slot`, as [`Photon::position`] and
    /// [`Photon::m`] hold them (the same `f32`s).
    ///
    /// An estimator reading a photon it has just found reads these: the cover test has just
    /// loaded the leaf's columns. (They are also the map's only copy of these numbers: the map
    /// keeps no whole photon since stop 47. Before, estimators read them here rather than from
    /// the 80-byte photon, which spanned two cache lines and was in main memory for a large
    /// map.)
    #[inline(always)]
    pub fn filter_frame(&self, slot: usize) -> (Vec3, [Vec3; 2]) {
        let at = |c: &[Vec<f32>; 3]| Vec3::new(c[0][slot], c[1][slot], c[2][slot]);
        (at(&self.position), [at(&self.m[0]), at(&self.m[1])])
    }

    /// Normal of the photon in `slot` and half-thickness of its surface slab, as
    /// [`crate::estimate::on_query_surface`] computes them from the photon (the same `f32`s).
    #[inline(always)]
    pub fn surface(&self, slot: usize) -> (Vec3, f32) {
        let n = &self.normal;
        (
            Vec3::new(n[0][slot], n[1][slot], n[2][slot]),
            self.slab[slot],
        )
    }

    /// The lanes of the leaf `first..first + count` (`count <= 16`).
    #[inline(always)]
    fn load(&self, first: usize, count: usize) -> LeafLanes {
        debug_assert!(count <= LANES);
        let load =
            |c: &Vec<f32>| Lanes::from(<[f32; LANES]>::try_from(&c[first..first + LANES]).unwrap());
        let load3 = |c: &[Vec<f32>; 3]| [load(&c[0]), load(&c[1]), load(&c[2])];
        // Lanes past the leaf are padding.
        let lane = Lanes::from(std::array::from_fn::<f32, LANES, _>(|k| k as f32));
        LeafLanes {
            position: load3(&self.position),
            normal: load3(&self.normal),
            m: [load3(&self.m[0]), load3(&self.m[1])],
            slab: load(&self.slab),
            in_leaf: lane.simd_le(Lanes::splat(count as f32 - 0.5)),
        }
    }
}

/// A leaf's photons as the cover test reads them, one photon a lane.
struct LeafLanes {
    position: [Lanes; 3],
    normal: [Lanes; 3],
    m: [[Lanes; 3]; 2],
    slab: Lanes,
    /// Set in the lanes that hold one of the leaf's photons (the rest are padding).
    in_leaf: Lanes,
}

impl LeafLanes {
    /// Bit `k` set where the leaf's photon `k` [`may_cover`] the footprint of `q` (and faces its
    /// way, for records [`Found::ON_SURFACE`]), and the footprint in the photons' filter
    /// spaces: `s.x, s.y, a.x, a.y, b.x, b.y` in lanes.
    #[inline(always)]
    fn covered<T: Found>(&self, q: &CoverQuery) -> (u32, [Lanes; 6]) {
        let (c, f0, f1) = (q.c, q.f[0], q.f[1]);
        let pos = &self.position;
        let v = [c[0] - pos[0], c[1] - pos[1], c[2] - pos[2]];
        let mut reject = dot(&self.normal, &v).abs().simd_gt(self.slab);
        if T::ON_SURFACE {
            reject |= !dot(&self.normal, &q.n).simd_gt(Lanes::splat(MIN_NORMAL_COSINE));
        }
        let [m0, m1] = &self.m;
        let s = [dot(m0, &v), dot(m1, &v)];
        let a = [dot(m0, &f0), dot(m1, &f0)];
        let b = [dot(m0, &f1), dot(m1, &f1)];
        // `may_cover`'s tests, in its order of operations.
        let (zero, c2) = (Lanes::ZERO, Lanes::splat(C2));
        let (p0, p1) = (a[0] + b[0], a[1] + b[1]);
        let (d0, d1) = (a[0] - b[0], a[1] - b[1]);
        let reach2 = (p0 * p0 + p1 * p1).max(d0 * d0 + d1 * d1);
        let beyond = (s[0] * s[0] + s[1] * s[1]) - c2 - Lanes::splat(0.25) * reach2;
        reject |= beyond.simd_gt(zero) & (beyond * beyond).simd_gt(c2 * reach2);
        let cross = (a[0] * b[1] - a[1] * b[0]).abs();
        for e in [a, b] {
            let len2 = e[0] * e[0] + e[1] * e[1];
            let beyond = (e[0] * s[1] - e[1] * s[0]).abs() - Lanes::splat(0.5) * cross;
            reject |= len2.simd_gt(Lanes::splat(MIN_EDGE_SQUARED))
                & beyond.simd_gt(zero)
                & (beyond * beyond).simd_gt(c2 * len2);
        }
        let bits = (!reject & self.in_leaf).to_bitmask();
        (bits, [s[0], s[1], a[0], a[1], b[0], b[1]])
    }
}

/// Appends to `out` the record of each photon of `leaf` (slots from `first`) that the test for
/// `q` keeps, lowest slot first.
#[inline(always)]
fn push_found<T: Found>(first: usize, leaf: &LeafLanes, q: &CoverQuery, out: &mut Vec<T>) {
    let (mut bits, filter) = leaf.covered::<T>(q);
    if bits == 0 {
        return;
    }
    let rows = T::rows(&filter);
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        out.push(T::new((first + k) as u32, &rows, k));
        bits &= bits - 1;
    }
}

/// Lanes of [`CoverTable::leaf`]: the footprint BVH's largest leaf, one `f32x16`.
const LANES: usize = LEAF_SIZE;
const _: () = assert!(LANES == 16, "a leaf is tested in one f32x16");

/// The cover test's SIMD lanes.
type Lanes = f32x16;

fn dot(a: &[Lanes; 3], b: &[Lanes; 3]) -> Lanes {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photons::footprint::{footprint, FootprintLimits, Guards};
    use crate::util::strategies::f32_in;
    use glam::DVec3;
    use proptest::prelude::*;

    fn photon(a: [f64; 3], b: [f64; 3], n: DVec3, centre: DVec3, scale: f64) -> Photon {
        let limits = FootprintLimits {
            min_radius: 1e-3,
            max_radius: 10.0,
            max_anisotropy: 20.0,
        };
        let fp = footprint(
            DVec3::from(a) * scale,
            DVec3::from(b) * scale,
            n,
            &limits,
            0.1,
            &mut Guards::default(),
        );
        Photon::new(centre, n, -n, DVec3::ONE, &fp)
    }

    /// A photon near the origin and a view footprint (centre `v`, axes `f`) near its plane, so
    /// that the slab test passes often.
    fn cover_case() -> impl Strategy<Value = (Photon, Vec3, [Vec3; 2])> {
        (
            prop::array::uniform3(-1f64..1.0),
            prop::array::uniform3(-1f64..1.0),
            prop::array::uniform3(-1f64..1.0)
                .prop_filter("a normal", |n| DVec3::from(*n).length() > 0.1),
            prop::array::uniform3(f32_in(-2.0, 2.0)),
            prop::array::uniform3(f32_in(-2.0, 2.0)),
            prop::array::uniform3(f32_in(-2.0, 2.0)),
            0.01f64..1.0,
            prop::sample::select(vec![0.0f32, 0.01, 0.1, 1.0]),
        )
            .prop_map(|(a, b, n, v, f0, f1, scale, fscale)| {
                let p = photon(a, b, DVec3::from(n).normalize(), DVec3::ZERO, scale);
                let v = Vec3::from(v) * scale as f32;
                let v = v - p.normal * p.normal.dot(v) * 0.95;
                let f = [f0, f1].map(|e| Vec3::from(e) * fscale * scale as f32);
                (p, v, f)
            })
    }

    /// How many of the view footprint's 17 x 17 sample points lie inside the kernel's support
    /// (the estimators' own test).
    fn points_inside(p: &Photon, v: Vec3, f: [Vec3; 2]) -> usize {
        if p.normal.dot(v).abs() > OFF_PLANE_TOLERANCE * p.radius {
            return 0;
        }
        let mut inside = 0;
        for i in 0..=16 {
            for j in 0..=16 {
                let y = v + f[0] * (i as f32 / 16.0 - 0.5) + f[1] * (j as f32 / 16.0 - 0.5);
                if p.m[0].dot(y).powi(2) + p.m[1].dot(y).powi(2) < 1.0 {
                    inside += 1;
                }
            }
        }
        inside
    }

    /// Built a block of slots per task, every slot holds its own photon's numbers (taken in
    /// reverse order), across the blocks' seams and in the last, partial block, and the
    /// padding after it is zero.
    #[test]
    fn every_slot_holds_its_photons_numbers() {
        let n = 2 * BLOCK + 123;
        let photons: Vec<Photon> = (0..n)
            .map(|i| {
                let t = i as f32;
                let mut p = photon(
                    [1.0 + t as f64, 0.5, -0.25],
                    [0.125, -2.0 - t as f64, 4.0],
                    DVec3::Z,
                    DVec3::new(t as f64 * 0.5, -(t as f64), 3.0),
                    0.01 * (1.0 + t as f64),
                );
                p.normal = Vec3::new(t, -t, 1.0 + t);
                p
            })
            .collect();
        let order: Vec<u32> = (0..n as u32).rev().collect();
        let table = CoverTable::new(&photons, &order);
        for (i, p) in photons.iter().rev().enumerate() {
            assert_eq!(table.filter_frame(i), (p.position, p.m), "slot {i}");
            assert_eq!(
                table.surface(i),
                (p.normal, OFF_PLANE_TOLERANCE * p.radius),
                "slot {i}"
            );
        }
        for column in table
            .position
            .iter()
            .chain(&table.normal)
            .chain([&table.slab])
        {
            assert_eq!(column.len(), n + LANES - 1);
            assert!(column[n..].iter().all(|&v| v == 0.0));
        }
    }

    /// The property below says something only where points are inside: the draws must hold
    /// such cases, and cases `may_cover` refuses, in numbers (1,000 draws of a fixed seed
    /// give 144 and 852).
    #[test]
    fn the_cover_draws_hold_covered_and_refused_cases() {
        use proptest::strategy::ValueTree;
        let mut runner = proptest::test_runner::TestRunner::deterministic();
        let (mut covered, mut refused) = (0, 0);
        for _ in 0..1000 {
            let (p, v, f) = cover_case().new_tree(&mut runner).unwrap().current();
            covered += usize::from(points_inside(&p, v, f) > 0);
            refused += usize::from(!may_cover(&p, v, f));
        }
        assert!(
            covered >= 100 && refused >= 200,
            "{covered} covered, {refused} refused"
        );
    }

    proptest! {
        /// Every sample point of the view footprint inside the kernel's support is covered by
        /// `may_cover`.
        #[test]
        fn may_cover_holds_every_covered_footprint((p, v, f) in cover_case()) {
            let inside = points_inside(&p, v, f);
            prop_assert!(may_cover(&p, v, f) || inside == 0, "{inside} points inside, not covered");
        }

        /// The sixteen-lane test answers exactly what `may_cover` answers, photon by photon, for
        /// leaves of every size anywhere in the table (padding lanes never answer).
        #[test]
        fn the_table_answers_what_may_cover_answers(
            photons in prop::collection::vec(
                (prop::array::uniform3(-1f64..1.0), prop::array::uniform3(-1f64..1.0),
                 prop::array::uniform3(-1f64..1.0), prop::array::uniform3(-0.5f64..0.5),
                 0.01f64..1.0),
                1..12),
            c in prop::array::uniform3(f32_in(-0.5, 0.5)),
            f0 in prop::array::uniform3(f32_in(-1.0, 1.0)),
            f1 in prop::array::uniform3(f32_in(-1.0, 1.0)),
            fscale in prop::sample::select(vec![0.0f32, 0.01, 0.1, 1.0]),
            first in 0usize..12,
            count in 0usize..=LANES,
        ) {
            let photons: Vec<Photon> = photons
                .iter()
                .filter(|(_, _, n, _, _)| DVec3::from(*n).length() > 0.1)
                .map(|&(a, b, n, x, s)| {
                    // Flattened towards z = 0 so that the slab test passes often.
                    let x = DVec3::from(x) * DVec3::new(1.0, 1.0, 0.01);
                    photon(a, b, DVec3::from(n).normalize(), x, s)
                })
                .collect();
            prop_assume!(!photons.is_empty());
            let first = first % photons.len();
            let count = count.min(photons.len() - first);
            let (c, f) = (Vec3::from(c) * Vec3::new(1.0, 1.0, 0.01), [Vec3::from(f0) * fscale, Vec3::from(f1) * fscale]);
            let in_order: Vec<u32> = (0..photons.len() as u32).collect();
            let table = CoverTable::new(&photons, &in_order);
            let mut simd: Vec<u32> = Vec::new();
            table.leaf(first, count, &CoverQuery::new(c, f, Vec3::Z), &mut simd);
            let scalar: Vec<u32> = (first..first + count)
                .filter(|&i| may_cover(&photons[i], c - photons[i].position, f))
                .map(|i| i as u32)
                .collect();
            prop_assert_eq!(simd, scalar);
            // What the estimators read of a found photon from the table is the photon's own.
            for (i, p) in photons.iter().enumerate() {
                prop_assert_eq!(table.filter_frame(i), (p.position, p.m));
            }
        }
    }
}
