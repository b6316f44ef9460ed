//! Mesh files: Wavefront OBJ (through `tobj`) and PLY, ASCII or binary (through `ply-rs`).
//! Every loaded mesh is validated: a malformed mesh is an error naming the file, never a mesh
//! that Embree silently drops parts of.

use crate::embree::TriangleMesh;
use std::path::Path;

/// Loads the mesh in `path`, choosing the format by extension (`.obj` or `.ply`).
/// Errors are messages that name the file.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mesh = match ext.as_deref() {
        Some("obj") => load_obj(path),
        Some("ply") => load_ply(path),
        _ => Err("unsupported mesh format (expected a .obj or .ply file)".to_string()),
    }
    .map_err(|e| format!("{}: {e}", path.display()))?;
    if mesh.triangles.is_empty() {
        return Err(format!("{}: the mesh has no triangles", path.display()));
    }
    mesh.validate()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(mesh)
}

fn triples(flat: &[f32]) -> Vec<[f32; 3]> {
    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

fn load_obj(path: &Path) -> Result<TriangleMesh, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials (.mtl) are not used: photondiff assigns materials in the scene file.
    let (models, _materials) =
        tobj::load_obj(path, &options).map_err(|e| format!("cannot read OBJ: {e}"))?;
    let mut mesh = TriangleMesh::default();
    let mut all_have_normals = true;
    let mut normals = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        let positions = triples(&m.positions);
        if m.normals.len() == m.positions.len() {
            normals.extend(triples(&m.normals));
        } else {
            all_have_normals = false;
        }
        mesh.positions.extend(positions);
        for tri in m.indices.chunks(3) {
            if tri.len() != 3 {
                return Err(format!("model '{}' has an incomplete face", model.name));
            }
            mesh.triangles
                .push([base + tri[0], base + tri[1], base + tri[2]]);
        }
    }
    if all_have_normals && !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    Ok(mesh)
}

fn load_ply(path: &Path) -> Result<TriangleMesh, String> {
    use ply_rs::ply::{DefaultElement, Property};
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let mut reader = std::io::BufReader::new(file);
    let parser = ply_rs::parser::Parser::<DefaultElement>::new();
    // ply-rs can panic on some malformed files; a bad file must be an error, not a crash.
    let ply = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        parser.read_ply(&mut reader)
    }))
    .map_err(|_| "malformed PLY file".to_string())?
    .map_err(|e| format!("cannot parse PLY: {e}"))?;

    let scalar = |p: Option<&Property>| -> Option<f64> {
        Some(match p? {
            Property::Float(v) => *v as f64,
            Property::Double(v) => *v,
            Property::Char(v) => *v as f64,
            Property::UChar(v) => *v as f64,
            Property::Short(v) => *v as f64,
            Property::UShort(v) => *v as f64,
            Property::Int(v) => *v as f64,
            Property::UInt(v) => *v as f64,
            _ => return None,
        })
    };
    let list = |p: &Property| -> Option<Vec<i64>> {
        Some(match p {
            Property::ListChar(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListUChar(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListShort(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListUShort(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListInt(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListUInt(v) => v.iter().map(|&i| i as i64).collect(),
            _ => return None,
        })
    };

    let vertices = ply
        .payload
        .get("vertex")
        .ok_or("PLY file has no 'vertex' element")?;
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    for (i, v) in vertices.iter().enumerate() {
        let xyz = ["x", "y", "z"].map(|k| scalar(v.get(k)));
        let [Some(x), Some(y), Some(z)] = xyz else {
            return Err(format!("vertex {i} lacks a numeric x, y or z"));
        };
        mesh.positions.push([x as f32, y as f32, z as f32]);
        if let [Some(nx), Some(ny), Some(nz)] = ["nx", "ny", "nz"].map(|k| scalar(v.get(k))) {
            normals.push([nx as f32, ny as f32, nz as f32]);
        }
    }
    if normals.len() == mesh.positions.len() && !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    let faces = ply
        .payload
        .get("face")
        .ok_or("PLY file has no 'face' element")?;
    for (i, face) in faces.iter().enumerate() {
        let indices = face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"))
            .and_then(list)
            .ok_or_else(|| format!("face {i} has no integer 'vertex_indices' list"))?;
        if indices.len() < 3 {
            return Err(format!("face {i} has {} vertices", indices.len()));
        }
        let to_u32 = |k: i64| {
            u32::try_from(k).map_err(|_| format!("face {i} has a negative vertex index {k}"))
        };
        // Fan triangulation of convex polygons.
        let first = to_u32(indices[0])?;
        for w in indices[1..].windows(2) {
            mesh.triangles.push([first, to_u32(w[0])?, to_u32(w[1])?]);
        }
    }
    Ok(mesh)
}
