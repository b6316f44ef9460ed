//! The estimators' hot loops: batched (SIMD) multi-sampled kernel evaluations beside the scalar
//! version, the footprint-integrated kernel (closed forms and the SIMD general formula) beside
//! multi-sampling the same photons, and convex polygon intersections, measured alternately in
//! one run (median of 7, one thread).
//!
//! Run: `cargo bench --bench kernels`

use glam::{DVec2, Vec2};
use photondiff::estimate::integrated::{
    parallelogram_means, parallelogram_means_scalar, ParallelogramBatch,
};
use photondiff::estimate::multisampled::{
    kernel_sums, kernel_sums_scalar, sample_offsets, KernelBatch,
};
use photondiff::geometry::disc_integral::{classify, Overlap};
use photondiff::geometry::polygon::{area_centroid, ellipse, intersect_convex, parallelogram};
use photondiff::util::rng::Rng;
use std::time::Instant;

const REPEATS: usize = 7;

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() {
    let mut batch = KernelBatch::default();
    for (s, a, b) in batch_photons(&mut Rng::new(3, 0)) {
        batch.push(s, a, b);
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

    integrated(&batch_photons(&mut Rng::new(3, 0)));

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

/// 4096 photons near a query, view footprints a few tenths of the kernel's radius (in filter
/// space: centre `s`, edges `a`, `b`).
fn batch_photons(rng: &mut Rng) -> Vec<(Vec2, Vec2, Vec2)> {
    let mut u = || rng.uniform() as f32;
    (0..4096)
        .map(|_| {
            (
                Vec2::new(u() * 3.0 - 1.5, u() * 3.0 - 1.5),
                Vec2::new(u() * 0.6 - 0.3, u() * 0.6 - 0.3),
                Vec2::new(u() * 0.6 - 0.3, u() * 0.6 - 0.3),
            )
        })
        .collect()
}

/// The footprint-integrated kernel per photon: the closed forms of `classify` and the general
/// formula for the rest in SIMD lanes, beside multi-sampling the same photons.
fn integrated(photons: &[(Vec2, Vec2, Vec2)]) {
    let mut ms = KernelBatch::default();
    for &(s, a, b) in photons {
        ms.push(s, a, b);
    }
    let mut general = ParallelogramBatch::default();
    let run = |general: &mut ParallelogramBatch, out: &mut Vec<f64>| -> f64 {
        general.clear();
        let mut sum = 0.0;
        for &(s, a, b) in photons {
            match classify(s.as_dvec2(), a.as_dvec2(), b.as_dvec2()) {
                Overlap::None => {}
                Overlap::Mean(m) => sum += m,
                Overlap::General { s, a, b } => general.push(s, a, b),
            }
        }
        parallelogram_means(general, out);
        sum + out.iter().sum::<f64>()
    };
    let mut out = Vec::new();
    run(&mut general, &mut out);
    let crossing = general.len();
    let settled = photons.len() - crossing;
    let mut general_only = general.clone();
    let reps = 200;
    let n = photons.len() as f64;
    let mut t = [(); 5].map(|_| Vec::new());
    let mut sums = Vec::new();
    let offsets = [sample_offsets(8), sample_offsets(32)];
    for _ in 0..REPEATS {
        let start = Instant::now();
        for _ in 0..reps {
            std::hint::black_box(run(&mut general, &mut out));
        }
        t[0].push(start.elapsed().as_secs_f64() / reps as f64);
        let start = Instant::now();
        for _ in 0..reps {
            parallelogram_means(&mut general_only, &mut out);
            std::hint::black_box(&out);
        }
        t[1].push(start.elapsed().as_secs_f64() / reps as f64);
        let start = Instant::now();
        for _ in 0..reps {
            parallelogram_means_scalar(&general_only, &mut out);
            std::hint::black_box(&out);
        }
        t[2].push(start.elapsed().as_secs_f64() / reps as f64);
        for (k, offsets) in offsets.iter().enumerate() {
            let start = Instant::now();
            for _ in 0..reps {
                kernel_sums(&mut ms, offsets, &mut sums);
                std::hint::black_box(&sums);
            }
            t[3 + k].push(start.elapsed().as_secs_f64() / reps as f64);
        }
    }
    let [all, simd, scalar, ms8, ms32] = t.map(median);
    println!(
        "\n## Footprint-integrated kernel ({} photons as above, one thread, median of {REPEATS})\n",
        photons.len()
    );
    println!(
        "{settled} photons settled by a closed form (inside, containing, apart), {crossing} crossing the circle (general formula).\n"
    );
    println!("| kernel | M photons/s |");
    println!("|---|---|");
    println!(
        "| integrated: closed forms + general formula (SIMD f64x8), all photons | {:.1} |",
        n / all / 1e6
    );
    println!(
        "| integrated: general formula only, SIMD f64x8 (crossing photons) | {:.1} |",
        crossing as f64 / simd / 1e6
    );
    println!(
        "| integrated: general formula only, scalar f64 (crossing photons) | {:.1} |",
        crossing as f64 / scalar / 1e6
    );
    println!(
        "| multi-sampled 8 x 8 (SIMD f32x16), all photons | {:.1} |",
        n / ms8 / 1e6
    );
    println!(
        "| multi-sampled 32 x 32 (SIMD f32x16), all photons | {:.1} |",
        n / ms32 / 1e6
    );
}
