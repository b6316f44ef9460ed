//! Mesh loading speed and memory: a generated 1.44M-triangle sphere (with per-vertex normals)
//! as binary little-endian PLY, read by photondiff's loader beside the ply-rs path it replaced,
//! and as OBJ beside tobj, alternated in one run (median). Peak memory is measured in a fresh
//! child process per loader: resident memory before the load against the peak (VmHWM in
//! /proc/self/status), beside the bytes of the final buffers.
//!
//! Run: `cargo bench --bench mesh_load` (the files go to target/bench-meshes/, made once).

use glam::DVec3;
use photondiff::embree::TriangleMesh;
use photondiff::scene::mesh_file::load_mesh;
use photondiff::scene::mesh_file::ply::write::write_binary;
use photondiff::scene::shapes::sphere;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Sphere segments: 1200 around, 600 rings: 1,437,600 triangles, 718,802 vertices.
const SEGMENTS: u32 = 1200;
const REPEATS: usize = 5;

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// A field of /proc/self/status in bytes.
fn status(field: &str) -> u64 {
    let text = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    text.lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().trim_end_matches(" kB").parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// The generated files (made once): binary PLY and OBJ of the same mesh.
fn files() -> (PathBuf, PathBuf) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-meshes");
    std::fs::create_dir_all(&dir).unwrap();
    let ply = dir.join(format!("sphere-{SEGMENTS}.ply"));
    let obj = dir.join(format!("sphere-{SEGMENTS}.obj"));
    if !ply.exists() || !obj.exists() {
        let mesh = sphere(DVec3::ZERO, 1.0, SEGMENTS);
        let tmp = ply.with_extension("tmp");
        write_binary(&mesh, BufWriter::new(std::fs::File::create(&tmp).unwrap())).unwrap();
        std::fs::rename(&tmp, &ply).unwrap();
        let mut w = BufWriter::new(std::fs::File::create(&tmp).unwrap());
        for p in &mesh.positions {
            writeln!(w, "v {} {} {}", p[0], p[1], p[2]).unwrap();
        }
        for n in mesh.normals.as_ref().unwrap() {
            writeln!(w, "vn {} {} {}", n[0], n[1], n[2]).unwrap();
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|k| k + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
        }
        w.flush().unwrap();
        drop(w);
        std::fs::rename(&tmp, &obj).unwrap();
    }
    (ply, obj)
}

type Loader = fn(&Path) -> TriangleMesh;

fn loaders() -> [(&'static str, Loader); 4] {
    [
        ("photondiff PLY", |p| load_mesh(p).unwrap()),
        ("ply-rs 0.1 (old path)", old::load_ply),
        ("photondiff OBJ", |p| load_mesh(p).unwrap()),
        ("tobj 4 (old path)", old::load_obj),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // Child: one load, then its memory figures on stdout.
    if let Some(i) = args.iter().position(|a| a == "--peak") {
        let (which, path): (usize, &str) = (args[i + 1].parse().unwrap(), &args[i + 2]);
        let before = status("VmRSS");
        let mesh = loaders()[which].1(Path::new(path));
        let peak = status("VmHWM");
        println!(
            "{} {} {}",
            peak.saturating_sub(before),
            mesh.bytes(),
            mesh.triangles.len()
        );
        return;
    }
    let (ply, obj) = files();
    let size = |p: &Path| std::fs::metadata(p).unwrap().len() as f64;
    let path_of = |which: usize| if which < 2 { &ply } else { &obj };
    println!(
        "\n## Mesh loading: a {}-triangle sphere with normals, one thread, median of {REPEATS}\n",
        load_mesh(&ply).unwrap().triangles.len()
    );
    println!(
        "binary PLY {:.1} MB, OBJ {:.1} MB\n",
        size(&ply) / 1e6,
        size(&obj) / 1e6
    );
    let mut times = vec![Vec::new(); 4];
    for round in 0..REPEATS {
        for (which, (_, load)) in loaders().iter().enumerate() {
            // The old paths are slow: three runs of them are plenty.
            if which % 2 == 1 && round >= 3 {
                continue;
            }
            let start = Instant::now();
            let mesh = load(path_of(which));
            times[which].push(start.elapsed().as_secs_f64());
            assert!(mesh.triangles.len() > 1_000_000);
        }
    }
    let exe = std::env::current_exe().unwrap();
    println!("| loader | file | s | MB/s | peak during load (MB) | final buffers (MB) | peak / final | peak bytes per triangle |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut rates = Vec::new();
    for (which, (name, _)) in loaders().iter().enumerate() {
        let path = path_of(which);
        let t = median(times[which].clone());
        let out = Command::new(&exe)
            .arg("--peak")
            .arg(which.to_string())
            .arg(path)
            .output()
            .unwrap();
        let figures: Vec<f64> = String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        let (peak, bytes, triangles) = (figures[0], figures[1], figures[2]);
        rates.push(size(path) / t / 1e6);
        println!(
            "| {name} | {} | {t:.3} | {:.0} | {:.1} | {:.1} | {:.2} | {:.1} |",
            path.extension().unwrap().to_string_lossy(),
            size(path) / t / 1e6,
            peak / 1e6,
            bytes / 1e6,
            peak / bytes,
            peak / triangles
        );
    }
    println!(
        "\nphotondiff / old path, same run: binary PLY {:.1}x, OBJ {:.1}x",
        rates[0] / rates[1],
        rates[2] / rates[3]
    );
}

/// The loaders photondiff used before its own (src/scene/mesh_file.rs until then), kept here
/// for the comparison only.
mod old {
    use photondiff::embree::TriangleMesh;
    use std::path::Path;

    fn triples(flat: &[f32]) -> Vec<[f32; 3]> {
        flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
    }

    pub fn load_obj(path: &Path) -> TriangleMesh {
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _) = tobj::load_obj(path, &options).unwrap();
        let mut mesh = TriangleMesh::default();
        let mut normals = Vec::new();
        for model in &models {
            let m = &model.mesh;
            let base = mesh.positions.len() as u32;
            normals.extend(triples(&m.normals));
            mesh.positions.extend(triples(&m.positions));
            for t in m.indices.chunks(3) {
                mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
            }
        }
        mesh.normals = Some(normals);
        mesh
    }

    pub fn load_ply(path: &Path) -> TriangleMesh {
        use ply_rs::ply::{DefaultElement, Property};
        let mut reader = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let ply = ply_rs::parser::Parser::<DefaultElement>::new()
            .read_ply(&mut reader)
            .unwrap();
        let scalar = |p: Option<&Property>| match p {
            Some(Property::Float(v)) => *v,
            _ => panic!("float properties expected"),
        };
        let mut mesh = TriangleMesh::default();
        let mut normals = Vec::new();
        for v in &ply.payload["vertex"] {
            mesh.positions
                .push(["x", "y", "z"].map(|k| scalar(v.get(k))));
            normals.push(["nx", "ny", "nz"].map(|k| scalar(v.get(k))));
        }
        mesh.normals = Some(normals);
        for face in &ply.payload["face"] {
            let Some(Property::ListInt(i)) = face.get("vertex_indices") else {
                panic!("int indices expected");
            };
            let first = i[0] as u32;
            for w in i[1..].windows(2) {
                mesh.triangles.push([first, w[0] as u32, w[1] as u32]);
            }
        }
        mesh
    }
}
