//! Writes a production-style test scene (no downloads): a finely tessellated, displaced glass
//! ball as a binary little-endian PLY (10.2M triangles by default) and two scene files:
//! `production.toml` sets it on the canonical scene's floor under its point light, so it
//! throws a caustic; `production-instanced.toml` places it 100 times (10 x 10, a third of its
//! size, each turned differently): 1.02e9 triangles placed, one copy in memory.
//!
//! Run: `cargo run --release --example production_scene -- [--segments N] [--out DIR]`
//! (default 3200 segments: 3200 x 1600 rings, 10,233,600 triangles; DIR default
//! `out/production`). Then `photondiff render DIR/production.toml` (README: "Memory and large
//! meshes" for the options and figures).

use glam::DVec3;
use photondiff::embree::TriangleMesh;
use photondiff::scene::mesh_file::ply::write::write_binary;
use std::io::BufWriter;
use std::path::PathBuf;

/// The ball's surface: a unit sphere displaced along its normal by ripples of 2% of its radius.
fn surface(theta: f64, phi: f64) -> DVec3 {
    let n = DVec3::new(
        theta.sin() * phi.cos(),
        theta.cos(),
        -theta.sin() * phi.sin(),
    );
    n * (1.0 + 0.02 * (24.0 * theta).sin() * (24.0 * phi).cos())
}

/// The displaced ball, centred at (0, 1, 0): `segments` around, `segments / 2` rings, flat
/// shaded (no per-vertex normals: the tessellation is finer than a pixel).
fn ball(segments: u32) -> TriangleMesh {
    let rings = segments / 2;
    let centre = DVec3::new(0.0, 1.0, 0.0);
    let f32x3 = |p: DVec3| [p.x as f32, p.y as f32, p.z as f32];
    let vertices = 2 + (rings - 1) as usize * segments as usize;
    let mut positions = Vec::with_capacity(vertices + 1);
    positions.push(f32x3(centre + surface(0.0, 0.0)));
    for ring in 1..rings {
        let theta = std::f64::consts::PI * ring as f64 / rings as f64;
        for s in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * s as f64 / segments as f64;
            positions.push(f32x3(centre + surface(theta, phi)));
        }
    }
    positions.push(f32x3(centre + surface(std::f64::consts::PI, 0.0)));
    let south = 1 + (rings - 1) * segments;
    let at = |ring: u32, s: u32| 1 + (ring - 1) * segments + (s % segments);
    let mut triangles = Vec::with_capacity(2 * segments as usize * (rings - 1) as usize);
    for s in 0..segments {
        triangles.push([0, at(1, s), at(1, s + 1)]);
        for ring in 1..rings - 1 {
            let (a, b) = (at(ring, s), at(ring, s + 1));
            let (c, d) = (at(ring + 1, s), at(ring + 1, s + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
        triangles.push([at(rings - 1, s), south, at(rings - 1, s + 1)]);
    }
    TriangleMesh {
        positions,
        normals: None,
        triangles,
    }
}

fn main() -> Result<(), String> {
    let mut segments = 3200u32;
    let mut out = PathBuf::from("out/production");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--segments" => {
                segments = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .filter(|&s| (8..=65536).contains(&s))
                    .ok_or("--segments needs a number in 8..=65536")?
            }
            "--out" => out = args.next().ok_or("--out needs a directory")?.into(),
            _ => return Err(format!("unknown argument {a} (--segments N, --out DIR)")),
        }
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mesh = ball(segments);
    let ply = out.join("ball.ply");
    let tmp = out.join("ball.ply.tmp");
    let file = std::fs::File::create(&tmp).map_err(|e| format!("{}: {e}", tmp.display()))?;
    write_binary(&mesh, BufWriter::with_capacity(1 << 20, file))
        .map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &ply).map_err(|e| format!("{}: {e}", ply.display()))?;
    let canonical = include_str!("../scenes/caustic-sphere.toml");
    let floor_and_light = canonical
        .split("[[shapes]]\ntype = \"sphere\"")
        .next()
        .ok_or("the canonical scene has no sphere")?;
    let scene = format!(
        "# Written by `cargo run --release --example production_scene -- --segments {segments}`:\n\
         # the canonical scene with its glass sphere replaced by a displaced glass ball of\n\
         # {} triangles (ball.ply).\n{floor_and_light}[[shapes]]\ntype = \"mesh\"\n\
         file = \"ball.ply\"\nmaterial = \"glass\"\n",
        mesh.triangles.len()
    );
    let toml = out.join("production.toml");
    std::fs::write(&toml, scene).map_err(|e| format!("{}: {e}", toml.display()))?;
    // The 100 instances: a 10 x 10 grid of thirds-size balls resting on the floor (the ball
    // file is centred at (0, 1, 0), radius up to 1.02: scaled by 0.33 it dips 0.0066 below).
    let mut instanced = format!(
        "# Written by `cargo run --release --example production_scene -- --segments {segments}`:\n\
         # 100 instances of the displaced glass ball ({} triangles each) on the canonical floor.\n\
         {floor_and_light}[meshes.ball]\nfile = \"ball.ply\"\n",
        mesh.triangles.len()
    );
    for i in 0..100 {
        let (x, z) = ((i % 10) as f64 * 0.75 - 3.4, (i / 10) as f64 * 0.75 - 3.4);
        instanced += &format!(
            "\n[[instances]]\nmesh = \"ball\"\nmaterial = \"glass\"\nscale = 0.33\n\
             rotate = [0.0, {:.1}, 0.0]\ntranslate = [{x:.2}, {:.3}, {z:.2}]\n",
            (i * 37 % 360) as f64,
            0.33 * 0.02
        );
    }
    let toml_instanced = out.join("production-instanced.toml");
    std::fs::write(&toml_instanced, instanced)
        .map_err(|e| format!("{}: {e}", toml_instanced.display()))?;
    println!(
        "wrote {} ({} triangles, {:.0} MB), {} and {}",
        ply.display(),
        mesh.triangles.len(),
        std::fs::metadata(&ply).map(|m| m.len()).unwrap_or(0) as f64 / 1e6,
        toml.display(),
        toml_instanced.display()
    );
    Ok(())
}
