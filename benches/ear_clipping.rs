//! Ear clipping of large concave polygons: `triangulate` (a linked ring, reflex flags and a
//! grid of corners) beside the reference it replaced (every remaining corner tested against
//! every ear), alternated in one run, median of 5, on two shapes of 1,024 to 16,384 corners
//! (the most ear clipping takes, `MAX_EAR_CLIPPED`): a star (every other corner reflex) and a
//! comb (long teeth: each ear's bounds hold a tooth's corners). Both must give the same
//! triangles. Then an OBJ of 40 stars of 16,384 corners through `load_mesh`, which took 22 s
//! (stop 67's sweep).
//!
//! Run: `cargo bench --bench ear_clipping`.

mod common;
#[path = "../src/scene/mesh_file/ear_clip_reference.rs"]
mod ear_clip_reference;

use glam::DVec2;
use photondiff::scene::mesh_file::load_mesh;
use photondiff::scene::mesh_file::triangulate::{triangulate, Scratch, Shape, MAX_EAR_CLIPPED};
use std::io::Write;
use std::time::Instant;

use common::median;

const REPEATS: usize = 5;

/// A star of `n` corners, alternately at radius 1 and 0.9, counter-clockwise.
fn star(n: usize) -> Vec<DVec2> {
    (0..n)
        .map(|i| {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            let r = if i % 2 == 0 { 1.0 } else { 0.9 };
            DVec2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

/// A comb of at most `n` corners (teeth 10 long on a base), counter-clockwise.
fn comb(n: usize) -> Vec<DVec2> {
    let teeth = (n - 2) / 4;
    let mut p = vec![DVec2::new(0.0, -1.0), DVec2::new(teeth as f64, -1.0)];
    for k in (0..teeth).rev() {
        let x = k as f64;
        p.extend([(x + 1.0, 10.0), (x + 0.5, 10.0), (x + 0.5, 0.0), (x, 0.0)].map(DVec2::from));
    }
    p
}

/// `triangulate`'s triangles of `points` (in the plane z = 0), and its time.
fn clipped(points: &[DVec2], scratch: &mut Scratch) -> (Vec<[usize; 3]>, f64) {
    let mut out = Vec::with_capacity(points.len());
    let start = Instant::now();
    let shape = triangulate(
        points.len(),
        |i| [points[i].x as f32, points[i].y as f32, 0.0],
        scratch,
        |t| out.push(t),
    );
    let seconds = start.elapsed().as_secs_f64();
    assert_eq!(shape, Shape::Concave);
    (out, seconds)
}

fn main() {
    println!("ear clipping, median of {REPEATS} (alternated): photondiff against the reference");
    println!(
        "{:<6} {:>7} {:>14} {:>14} {:>7}",
        "shape", "corners", "reference s", "photondiff s", "ratio"
    );
    let mut scratch = Scratch::default();
    let mut at_limit = Vec::new();
    for (name, shape) in [("star", star as fn(usize) -> Vec<DVec2>), ("comb", comb)] {
        for n in [1024, 4096, MAX_EAR_CLIPPED] {
            // The positions as `triangulate` sees them (rounded to f32).
            let points: Vec<DVec2> = shape(n).iter().map(|p| p.as_vec2().as_dvec2()).collect();
            let (mut old, mut new) = (Vec::new(), Vec::new());
            for _ in 0..REPEATS {
                let start = Instant::now();
                let (reference, whole) = ear_clip_reference::ear_clip(&points);
                old.push(start.elapsed().as_secs_f64());
                let (ours, seconds) = clipped(&points, &mut scratch);
                new.push(seconds);
                assert!(whole);
                assert_eq!(ours, reference, "{name} of {n} corners");
            }
            let (old, new) = (median(old), median(new));
            println!(
                "{name:<6} {:>7} {old:>14.5} {new:>14.5} {:>7.1}",
                points.len(),
                old / new
            );
            if n == MAX_EAR_CLIPPED {
                at_limit.push((name, new));
            }
        }
    }
    // 40 stars of the most corners ear clipping takes, as an OBJ file.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-meshes");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("stars.obj");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    let n = MAX_EAR_CLIPPED;
    for k in 0..40 {
        for p in star(n) {
            writeln!(w, "v {} {} {}", p.x, p.y, k).unwrap();
        }
        write!(w, "f").unwrap();
        (1..=n).for_each(|i| write!(w, " {}", k * n + i).unwrap());
        writeln!(w).unwrap();
    }
    w.flush().unwrap();
    drop(w);
    let start = Instant::now();
    let mesh = load_mesh(&path).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    assert_eq!(mesh.triangles.len(), 40 * (n - 2));
    println!(
        "load_mesh of 40 stars of {n} corners ({:.1} MB OBJ): {seconds:.3} s",
        std::fs::metadata(&path).unwrap().len() as f64 / 1e6
    );
    for (name, s) in at_limit {
        println!(
            "{name} at {n} corners: {:.1} us a corner",
            s / n as f64 * 1e6
        );
    }
}
