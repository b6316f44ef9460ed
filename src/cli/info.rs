//! `photondiff info FILE`: what a mesh or scene file holds, what loading it dropped or
//! repaired, and the memory its meshes take.

use photondiff::embree::{BvhSettings, TriangleMesh};
use photondiff::scene::file::load_scene;
use photondiff::scene::mesh_file::{load_mesh_with_report, MeshReport};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(clap::Args)]
pub struct InfoArgs {
    /// A mesh (.obj, .ply) or a scene file (.toml).
    file: PathBuf,
}

/// Runs `photondiff info`.
pub fn run(args: &InfoArgs) -> Result<(), String> {
    let ext = args
        .file
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let name = args.file.display();
    match std::fs::metadata(&args.file) {
        Err(e) => return Err(format!("{name}: cannot read: {e}")),
        Ok(m) if m.is_dir() => return Err(format!("{name}: is a folder")),
        Ok(_) => {}
    }
    if !matches!(ext.as_deref(), Some("toml" | "obj" | "ply")) {
        return Err(format!(
            "{name}: expected a scene (.toml) or a mesh (.obj, .ply) file"
        ));
    }
    let is_scene = ext.as_deref() == Some("toml");
    let mut out = String::new();
    if is_scene {
        let scene = load_scene(&args.file).map_err(|e| e.to_string())?;
        super::warn_about_scene(&args.file, &scene);
        let c = &scene.camera;
        out += &format!(
            "{}: scene, {} x {} pixels, {} light{}, {} mesh{}\n",
            args.file.display(),
            c.width,
            c.height,
            scene.lights.len(),
            if scene.lights.len() == 1 { "" } else { "s" },
            scene.meshes.len(),
            if scene.meshes.len() == 1 { "" } else { "es" },
        );
        for (i, m) in scene.meshes.iter().enumerate() {
            out += &format!("{}:\n", m.name);
            // An instanced mesh is described once; its other instances only say where they are.
            let first = scene.meshes[..i]
                .iter()
                .all(|o| !Arc::ptr_eq(&o.mesh, &m.mesh));
            if first {
                out += &describe(&m.mesh, &m.report);
            }
            if let Some(t) = m.transform {
                out += &format!(
                    "  transform  linear {:?}, translation {:?}\n",
                    t.matrix3.to_cols_array(),
                    t.translation.to_array()
                );
            }
        }
        // Only the bounds of the union are wanted: the 2 corners of each mesh's world box.
        let mut all = TriangleMesh::default();
        for [lo, hi] in scene.mesh_bounds() {
            all.positions
                .extend([lo, hi].map(|p| p.as_vec3().to_array()));
        }
        let bytes = scene.mesh_bytes();
        let triangles = scene.triangle_count();
        let placed = scene.placed_triangle_count();
        let instanced = if placed == triangles {
            String::new()
        } else {
            format!(" unique, {placed} placed (instances counted)")
        };
        out += &format!(
            "total:\n  triangles  {triangles}{instanced}\n  bounds     {}\n  dropped    {}\n  repaired   {}\n  memory     {}\n  BVH        {}\n",
            show_bounds(&all),
            dropped(&scene.mesh_report()),
            repaired(&scene.mesh_report()),
            memory(bytes),
            default_bvh(triangles),
        );
    } else {
        let loaded = load_mesh_with_report(&args.file)?;
        out += &format!("{}: mesh\n", args.file.display());
        out += &describe(&loaded.mesh, &loaded.report);
    }
    out += MEMORY_NOTE;
    out!("{}", out.trim_end_matches('\n'));
    Ok(())
}

fn describe(mesh: &TriangleMesh, report: &MeshReport) -> String {
    let mut s = format!(
        "  vertices   {}\n  triangles  {}",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    if report.faces > 0 {
        s += &format!(
            " (from {} faces; {} polygons triangulated, {} of them concave)",
            report.faces, report.polygons, report.concave_polygons
        );
        if report.crossing_polygons > 0 {
            s.pop(); // the closing parenthesis
            s += &format!(", {} crossing themselves)", report.crossing_polygons);
        }
    }
    s += &format!(
        "\n  normals    {}\n  bounds     {}\n  dropped    {}\n  repaired   {}\n",
        if mesh.normals.is_some() {
            "per vertex (interpolated)"
        } else {
            "none (flat)"
        },
        show_bounds(mesh),
        dropped(report),
        repaired(report),
    );
    if report.against_normals > 0 {
        s += &format!(
            "  against    {} triangles wind against all three of their vertex normals (glass \
             there is inside out)\n",
            report.against_normals
        );
    }
    if report.skipped_lines_points > 0 {
        s += &format!(
            "  skipped    {} lines and points (not surfaces)\n",
            report.skipped_lines_points
        );
    }
    if report.short_faces > 0 {
        s += &format!(
            "  skipped    {} faces of fewer than three vertices (not surfaces)\n",
            report.short_faces
        );
    }
    s += &format!("  memory     {}\n", memory(mesh.bytes()));
    s
}

fn dropped(r: &MeshReport) -> String {
    format!(
        "{} degenerate (zero-area) triangles, {} vertices no triangle uses",
        r.degenerate_triangles, r.unused_vertices
    )
}

fn repaired(r: &MeshReport) -> String {
    format!("{} zero or non-finite vertex normals", r.repaired_normals)
}

fn memory(bytes: u64) -> String {
    format!(
        "{bytes} bytes ({:.1} MiB) of mesh buffers",
        bytes as f64 / (1u64 << 20) as f64
    )
}

/// The BVH `render`, `photons` and `reference` build for a scene of `triangles` unique
/// triangles unless told otherwise, and the option that changes it.
fn default_bvh(triangles: u64) -> String {
    let bvh = BvhSettings::for_triangles(triangles);
    let why = if bvh.compact {
        "by default from 4,000,000 unique triangles; --no-bvh-compact for Embree's ordinary \
         BVH, about twice the memory"
    } else {
        "by default under 4,000,000 unique triangles; --bvh-compact for about half the memory"
    };
    format!("{bvh} ({why})")
}

/// How `memory` is estimated, printed once after the figures.
const MEMORY_NOTE: &str = "memory: 12 bytes per position, per normal and per triangle (three \
    32-bit indices); Embree reads these buffers in place when rendering and adds its BVH\n";

/// The two corners of the mesh's bounding box (none for an empty mesh).
fn bounds(mesh: &TriangleMesh) -> Vec<[f32; 3]> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if mesh.positions.is_empty() {
        Vec::new()
    } else {
        vec![lo, hi]
    }
}

fn show_bounds(mesh: &TriangleMesh) -> String {
    match bounds(mesh).as_slice() {
        [lo, hi] => format!(
            "[{}, {}, {}] .. [{}, {}, {}] (size {} x {} x {})",
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2],
            hi[0] - lo[0],
            hi[1] - lo[1],
            hi[2] - lo[2]
        ),
        _ => "empty".to_string(),
    }
}
