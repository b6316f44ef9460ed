//! The multi-sampled photon-differential estimate (Pedersen 2011): one camera ray and one
//! photon gather per pixel; each photon's kernel is evaluated at N x N points spread over the
//! pixel's view footprint and averaged.
//!
//! The N x N kernel evaluations are the hot loop. With the sample points
//! `X_ij = x + alpha_i f0 + alpha_j f1` (`alpha_i = (i + 1/2)/N - 1/2`, `f0`, `f1` the view
//! footprint), the filter-space offset of photon `p` is `s + alpha_i a + alpha_j b` with
//! `s = M_p (x - x_p)`, `a = M_p f0`, `b = M_p f1`: six numbers per photon. They are laid out as
//! structure of arrays and evaluated 16 photons at a time in SIMD lanes (`wide::f32x16`: one
//! AVX-512 register where the machine has it, two AVX halves elsewhere), with
//! `r^2 = |u|^2 + beta (2 u.b + beta |b|^2)` for `u = s + alpha a`: two multiply-adds per
//! evaluation. The lanes fill across a packet's gathers ([`RadianceEstimator::radiance_batch`]):
//! at the default photon count a gather holds three or four photons, which alone would leave
//! most of a batch's lanes padding.

use super::{batch_of_one, GatherCounts, GatherQuery, RadianceEstimator};
use crate::photons::cover::InFilterSpace;
use crate::photons::map::{FootprintQuery, PacketSearch, PhotonMap};
use crate::util::blocks::Blocks;
use glam::{DVec3, Vec2, Vec3};
use std::cell::RefCell;
use std::f64::consts::{FRAC_1_PI, FRAC_2_PI};
use wide::f32x16;

/// SIMD width of the batched kernel.
pub const LANES: usize = 16;

/// The batched kernel's lanes.
type Lanes = f32x16;

/// Filter-space data of a batch of photons (`s.x, s.y, a.x, a.y, b.x, b.y` each), kept as
/// columns in blocks of [`LANES`] photons ([`Blocks`]), so that a block loads as one `f32x16`
/// a column.
#[derive(Debug, Clone, Default)]
pub struct KernelBatch(Blocks<f32, LANES, 6>);

impl KernelBatch {
    /// Empties the batch, keeping its storage.
    pub fn clear(&mut self) {
        self.0.clear();
    }

    /// Adds a photon: its filter-space offset `s` and the filter-space footprint axes `a`, `b`.
    #[inline]
    pub fn push(&mut self, s: Vec2, a: Vec2, b: Vec2) {
        self.0.push_row([s.x, s.y, a.x, a.y, b.x, b.y]);
    }

    /// Number of photons.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// The sample offsets `alpha_i = (i + 1/2)/n - 1/2` of an `n x n` grid over a footprint.
pub fn sample_offsets(n: u32) -> Vec<f32> {
    (0..n).map(|i| (i as f32 + 0.5) / n as f32 - 0.5).collect()
}

/// For each photon of `batch`, `sum_ij max(0, 1 - |s + alpha_i a + alpha_j b|^2)` over the grid
/// `offsets`, in SIMD lanes. `out` gets one sum per photon.
pub fn kernel_sums(batch: &mut KernelBatch, offsets: &[f32], out: &mut Vec<f32>) {
    out.clear();
    let len = batch.len();
    let one = Lanes::splat(1.0);
    let zero = Lanes::ZERO;
    // Padding: photons whose kernels are zero everywhere.
    for block in batch.0.padded([1e6, 1e6, 0.0, 0.0, 0.0, 0.0]) {
        let [s0, s1, a0, a1, b0, b1] = block.map(Lanes::from);
        let bb = b0 * b0 + b1 * b1;
        let mut acc = zero;
        for &alpha in offsets {
            let alpha = Lanes::splat(alpha);
            let u0 = a0.mul_add(alpha, s0);
            let u1 = a1.mul_add(alpha, s1);
            let uu = u0 * u0 + u1 * u1;
            let ub2 = (u0 * b0 + u1 * b1) * Lanes::splat(2.0);
            for &beta in offsets {
                let beta = Lanes::splat(beta);
                let r2 = beta.mul_add(bb.mul_add(beta, ub2), uu);
                acc += (one - r2).max(zero);
            }
        }
        out.extend_from_slice(&acc.to_array());
    }
    out.truncate(len);
}

/// The scalar version of [`kernel_sums`], for comparison in benchmarks and tests.
pub fn kernel_sums_scalar(batch: &KernelBatch, offsets: &[f32], out: &mut Vec<f32>) {
    out.clear();
    for k in 0..batch.len() {
        let [s0, s1, a0, a1, b0, b1] = batch.0.row(k);
        let mut acc = 0.0;
        for &alpha in offsets {
            for &beta in offsets {
                let r0 = s0 + alpha * a0 + beta * b0;
                let r1 = s1 + alpha * a1 + beta * b1;
                acc += (1.0 - (r0 * r0 + r1 * r1)).max(0.0);
            }
        }
        out.push(acc);
    }
}

/// Scratch space reused across gathers on one thread.
#[derive(Default)]
struct Scratch {
    /// The packet's footprints and the photons found for them.
    search: PacketSearch<InFilterSpace>,
    /// The photons of `batch`: (query, photon) each.
    used: Vec<(u32, u32)>,
    batch: KernelBatch,
    sums: Vec<f32>,
    /// Per query of a batch, the sum of `Phi / A * sum` over its photons.
    totals: Vec<Vec3>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// The multi-sampled photon-differential estimate with an `grid x grid` sample grid.
pub struct MultiSampledEstimate<'a> {
    /// The map.
    pub map: &'a PhotonMap,
    /// Sample points per footprint side (1 to 32).
    pub grid: u32,
    offsets: Vec<f32>,
}

impl<'a> MultiSampledEstimate<'a> {
    /// The estimate over `map` with `grid x grid` samples per view footprint.
    pub fn new(map: &'a PhotonMap, grid: u32) -> Self {
        let grid = grid.clamp(1, 32);
        MultiSampledEstimate {
            map,
            grid,
            offsets: sample_offsets(grid),
        }
    }
}

impl RadianceEstimator for MultiSampledEstimate<'_> {
    fn integrates_view_footprint(&self) -> bool {
        // One sample is the footprint's centre: a point estimate, like `pd`.
        self.grid > 1
    }

    fn radiance(&self, q: &GatherQuery, counts: &mut GatherCounts) -> DVec3 {
        batch_of_one(self, q, counts)
    }

    /// Every query's photons in one kernel batch, so that the SIMD lanes fill across the
    /// gathers; each photon's sum is its lane's alone, and each query's total is taken in the
    /// order a lone gather takes it, so the answers equal the gathers' one by one bit for bit.
    fn radiance_batch(
        &self,
        queries: &[GatherQuery],
        _shares: &[f64],
        out: &mut [DVec3],
        counts: &mut GatherCounts,
    ) {
        SCRATCH.with(|scratch| {
            let scratch = &mut *scratch.borrow_mut();
            scratch.batch.clear();
            scratch.used.clear();
            // Each photon found on the query's surface, with the view footprint in its filter
            // space, as the cover test computed them.
            let requests = queries
                .iter()
                .map(|q| FootprintQuery::new(q.position, q.footprint, q.normal));
            let found = scratch.search.run(self.map, requests);
            for (j, found) in found.iter().enumerate() {
                counts.gathers += 1;
                counts.photons_found += found.len() as u64;
                for &InFilterSpace { slot, s, a, b } in found {
                    // No sample point can fall inside the kernel's unit disc.
                    if s.length() > 1.0 + 0.5 * (a.length() + b.length()) || !s.is_finite() {
                        continue;
                    }
                    scratch.batch.push(s, a, b);
                    scratch.used.push((j as u32, slot));
                }
            }
            kernel_sums(&mut scratch.batch, &self.offsets, &mut scratch.sums);
            scratch.totals.clear();
            scratch.totals.resize(queries.len(), Vec3::ZERO);
            for (&(j, i), &sum) in scratch.used.iter().zip(&scratch.sums) {
                if sum > 0.0 {
                    counts.photons_used += 1;
                    let p = &self.map.flux[i as usize];
                    scratch.totals[j as usize] += p.power * (p.inv_area * sum);
                }
            }
            let n2 = (self.grid * self.grid) as f64;
            for ((o, q), total) in out.iter_mut().zip(queries).zip(&scratch.totals) {
                *o = q.albedo * (FRAC_1_PI * FRAC_2_PI / n2) * total.as_dvec3();
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simd_and_scalar_kernel_sums_agree() {
        let mut batch = KernelBatch::default();
        for k in 0..21 {
            let t = k as f32 * 0.37;
            batch.push(
                Vec2::new(t.sin() * 1.2, t.cos() * 0.7),
                Vec2::new(0.3 + 0.1 * t.cos(), 0.2),
                Vec2::new(-0.1, 0.5 * t.sin()),
            );
        }
        let offsets = sample_offsets(7);
        let (mut simd, mut scalar) = (Vec::new(), Vec::new());
        kernel_sums_scalar(&batch, &offsets, &mut scalar);
        kernel_sums(&mut batch, &offsets, &mut simd);
        assert_eq!(simd.len(), 21);
        for (a, b) in simd.iter().zip(&scalar) {
            assert!((a - b).abs() <= 1e-4 * b.abs().max(1.0), "{a} vs {b}");
        }
        assert!(scalar.iter().any(|&s| s > 0.0) && scalar.contains(&0.0));
        // A cleared batch writes over its blocks: three photons after 21 sum as three alone.
        batch.clear();
        for k in 0..3 {
            batch.push(Vec2::splat(0.1 * k as f32), Vec2::X * 0.5, Vec2::Y * 0.5);
        }
        let mut fresh = KernelBatch::default();
        for k in 0..3 {
            fresh.push(Vec2::splat(0.1 * k as f32), Vec2::X * 0.5, Vec2::Y * 0.5);
        }
        let mut again = Vec::new();
        kernel_sums(&mut batch, &offsets, &mut simd);
        kernel_sums(&mut fresh, &offsets, &mut again);
        assert_eq!(simd, again);
        assert_eq!(simd.len(), 3);
    }
}
