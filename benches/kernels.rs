//! The estimators' hot loops: batched (SIMD) multi-sampled kernel evaluations beside the scalar
//! version, and convex polygon intersections, measured alternately in one run (median of 7,
//! one thread).
//!
//! Run: `cargo bench --bench kernels`

use glam::{DVec2, Vec2};
use photondiff::estimate::multisampled::{
    kernel_sums, kernel_sums_scalar, sample_offsets, KernelBatch,
};
use photondiff::geometry::polygon::{area_centroid, ellipse, intersect_convex, parallelogram};
use photondiff::util::rng::Rng;
use std::time::Instant;

const REPEATS: usize = 7;

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() {
    let mut rng = Rng::new(3, 0);
    let mut u = || rng.uniform() as f32;
    // 4096 photons near a query, footprints a few tenths of the kernel's radius.
    let mut batch = KernelBatch::default();
    for _ in 0..4096 {
        batch.push(
            Vec2::new(u() * 3.0 - 1.5, u() * 3.0 - 1.5),
            Vec2::new(u() * 0.6 - 0.3, u() * 0.6 - 0.3),
            Vec2::new(u() * 0.6 - 0.3, u() * 0.6 - 0.3),
        );
    }
    println!(
        "\n## Multi-sampled kernel evaluations (4096 photons, one thread, median of {REPEATS})\n"
    );
    println!("| N x N | SIMD M evals/s | scalar M evals/s | SIMD / scalar |");
    println!("|---|---|---|---|");
    let mut out = Vec::new();
    for n in [2u32, 4, 8, 16, 32] {
        let offsets = sample_offsets(n);
        let evals = (batch.len() * (n * n) as usize) as f64;
        let (mut simd, mut scalar) = (Vec::new(), Vec::new());
        let reps = (2_000_000.0 / evals).ceil().max(1.0) as usize;
        for _ in 0..REPEATS {
            let start = Instant::now();
            for _ in 0..reps {
                kernel_sums(&mut batch, &offsets, &mut out);
                std::hint::black_box(&out);
            }
            simd.push(start.elapsed().as_secs_f64() / reps as f64);
            let start = Instant::now();
            for _ in 0..reps {
                kernel_sums_scalar(&batch, &offsets, &mut out);
                std::hint::black_box(&out);
            }
            scalar.push(start.elapsed().as_secs_f64() / reps as f64);
        }
        let (ts, tc) = (median(simd), median(scalar));
        println!(
            "| {n} x {n} | {:.0} | {:.0} | {:.2} |",
            evals / ts / 1e6,
            evals / tc / 1e6,
            tc / ts
        );
    }

    // Polygon intersections: a photon's 16-gon against a view parallelogram, overlapping.
    let mut rng = Rng::new(4, 0);
    let mut v = || rng.uniform();
    let pairs: Vec<(Vec<DVec2>, [DVec2; 4])> = (0..10_000)
        .map(|_| {
            let photon = ellipse(
                DVec2::new(v() - 0.5, v() - 0.5),
                DVec2::new(0.3 + v(), 0.1 * v()),
                DVec2::new(-0.1 * v(), 0.2 + 0.5 * v()),
                16,
            );
            let view = parallelogram(
                DVec2::ZERO,
                DVec2::new(0.5 + v(), 0.1),
                DVec2::new(0.05, 0.4 + v()),
            );
            (photon, view)
        })
        .collect();
    let mut times = Vec::new();
    for _ in 0..REPEATS {
        let start = Instant::now();
        let mut total = 0.0;
        for (p, w) in &pairs {
            total += area_centroid(&intersect_convex(p, w)).0;
        }
        std::hint::black_box(total);
        times.push(start.elapsed().as_secs_f64());
    }
    println!(
        "\nPolygon intersections (16-gon x parallelogram, with area and centroid): {:.0} per second\n",
        pairs.len() as f64 / median(times)
    );
}
