//! PLY, ASCII or binary (little or big endian), read straight into the final vertex and index
//! buffers: the header's counts are checked against the file's size before anything is
//! allocated, vertices are decoded chunk by chunk into a buffer reserved once, and faces
//! (triangles, quads, any polygon, any integer index and count type) are appended without an
//! allocation per face. Extra properties of any type, and extra elements, are skipped.

mod ascii;
mod binary;
pub mod header;
pub mod write;

use super::repair::bad_position;
use super::triangulate::{triangulate, Scratch, Shape};
use super::{make_room_in_mesh, mesh_buffer, MeshReport};
use crate::embree::TriangleMesh;
use crate::util::reserve;
use header::{Element, Format, Header};
use std::path::Path;

/// Loads the PLY file at `path`, telling `read` the bytes read so far every few megabytes.
pub fn load(path: &Path, read: &dyn Fn(u64)) -> Result<(TriangleMesh, MeshReport), String> {
    let file = crate::util::input::open(path).map_err(|e| format!("cannot read PLY: {e}"))?;
    let file_size = file
        .metadata()
        .map_err(|e| format!("cannot read PLY: {e}"))?
        .len();
    let file = crate::util::input::Counted::new(file, read);
    let mut reader = std::io::BufReader::with_capacity(1 << 16, file);
    let header = header::read(&mut reader)?;
    let data_size = file_size.saturating_sub(header.length);
    let layout = Layout::new(&header)?;
    check_size(&header, data_size)?;
    let vertices = header.elements[layout.vertex].count;
    if vertices >= u32::MAX as u64 {
        return Err(format!("too many vertices ({vertices}) for 32-bit indices"));
    }
    let mut sink = Sink::new(&header, &layout, data_size)?;
    match header.format {
        Format::Ascii => ascii::read(reader, &header, &layout, &mut sink)?,
        Format::BinaryLittleEndian => {
            binary::read::<false, _>(reader, data_size, &header, &layout, &mut sink)?
        }
        Format::BinaryBigEndian => {
            binary::read::<true, _>(reader, data_size, &header, &layout, &mut sink)?
        }
    }
    sink.finish()
}

/// Where the data the renderer uses sits in the elements.
pub(crate) struct Layout {
    /// Index of the `vertex` element.
    pub vertex: usize,
    /// Properties `x`, `y`, `z` of the vertex element.
    pub xyz: [usize; 3],
    /// Properties `nx`, `ny`, `nz`, when all three are there.
    pub normal: Option<[usize; 3]>,
    /// Index of the `face` element.
    pub face: usize,
    /// The index-list property of the face element.
    pub indices: usize,
}

impl Layout {
    fn new(header: &Header) -> Result<Layout, String> {
        let element = |name: &str| {
            header
                .elements
                .iter()
                .position(|e| e.name == name)
                .ok_or_else(|| format!("PLY file has no '{name}' element"))
        };
        let vertex = element("vertex")?;
        let v = &header.elements[vertex];
        let scalar = |name: &str| -> Result<Option<usize>, String> {
            match v.find(name) {
                Some(i) if v.properties[i].list.is_some() => Err(format!(
                    "cannot parse PLY: vertex property '{name}' is a list, not a number"
                )),
                found => Ok(found),
            }
        };
        let mut xyz = [0; 3];
        for (slot, name) in xyz.iter_mut().zip(["x", "y", "z"]) {
            *slot = scalar(name)?
                .ok_or_else(|| format!("cannot parse PLY: the vertex element has no '{name}'"))?;
        }
        let normal = match [scalar("nx")?, scalar("ny")?, scalar("nz")?] {
            [Some(a), Some(b), Some(c)] => Some([a, b, c]),
            _ => None,
        };
        let face = element("face")?;
        let f = &header.elements[face];
        let indices = match (f.find("vertex_indices"), f.find("vertex_index")) {
            (Some(_), Some(_)) => {
                return Err(
                    "cannot parse PLY: the face element has both a 'vertex_indices' and a \
                     'vertex_index' list: which holds the corners is ambiguous"
                        .into(),
                )
            }
            (Some(k), None) | (None, Some(k)) => k,
            (None, None) => {
                return Err(
                    "cannot parse PLY: the face element has no 'vertex_indices' list".into(),
                )
            }
        };
        let p = &f.properties[indices];
        if p.list.is_none() || !p.ty.is_integer() {
            return Err(format!(
                "cannot parse PLY: face property '{}' must be a list of integers, got {}",
                p.name,
                match p.list {
                    Some(_) => format!("a list of {}", p.ty.name()),
                    None => format!("a single {}", p.ty.name()),
                }
            ));
        }
        Ok(Layout {
            vertex,
            xyz,
            normal,
            face,
            indices,
        })
    }
}

/// Refuses a header whose counts cannot fit in the file, before anything is allocated for
/// them: in a binary file each record takes at least its scalars and list counts, in an ASCII
/// file at least two characters (a digit and a separator) per value.
fn check_size(header: &Header, data_size: u64) -> Result<(), String> {
    let per_record = |e: &Element| -> u128 {
        match header.format {
            Format::Ascii => 2 * e.properties.len() as u128,
            _ => e.min_binary_size() as u128,
        }
    };
    let needed: u128 = header
        .elements
        .iter()
        .map(|e| e.count as u128 * per_record(e))
        .sum();
    // The last ASCII value needs no separator after it.
    let needed = if header.format == Format::Ascii {
        needed.saturating_sub(1)
    } else {
        needed
    };
    if needed > data_size as u128 {
        let counts: Vec<String> = header
            .elements
            .iter()
            .map(|e| format!("{} {}", e.count, e.name))
            .collect();
        return Err(format!(
            "the header declares {}: at least {needed} bytes of {} data, but the file has \
             {data_size} bytes after its header",
            counts.join(", "),
            if header.format == Format::Ascii {
                "ascii"
            } else {
                "binary"
            }
        ));
    }
    Ok(())
}

/// Receives vertices and faces as the readers decode them, into the final buffers.
pub(crate) struct Sink {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    triangles: Vec<[u32; 3]>,
    /// Declared vertex count: every index is checked against it.
    vertex_count: u64,
    /// Polygons met before the vertices (flat: count, then corners), triangulated at the end.
    deferred: Vec<u32>,
    /// Corners of the current polygon.
    pub corners: Vec<u32>,
    scratch: Scratch,
    report: MeshReport,
}

impl Sink {
    /// Buffers for the mesh of `header`, whose data takes `data_size` bytes, reserved once; an
    /// error where they do not fit in the memory the process may still take.
    fn new(header: &Header, layout: &Layout, data_size: u64) -> Result<Sink, String> {
        // The vertex count was checked against the file's size: it is the file's to pay for.
        let vertices = header.elements[layout.vertex].count as usize;
        // Triangles: a face counts only where its record can hold one, so that a header of
        // 60 million empty faces (a byte each, 12 reserved each: 720 MB for a 60 MB file,
        // an abort under a memory limit) reserves what its bytes could hold. Faces of more
        // corners are rarer, and grow the buffer as they come.
        let face = &header.elements[layout.face];
        let list = &face.properties[layout.indices];
        let per_triangle = match header.format {
            Format::Ascii => "3 0 1 2\n".len() as u64,
            _ => list.list.map_or(1, |count| count.size() as u64) + 3 * list.ty.size() as u64,
        };
        let triangles = face.count.min(data_size / per_triangle) as usize;
        // The whole need first, so that the error gives it rather than a buffer's share of it.
        let what = format!("its {vertices} vertices and {} faces", face.count);
        let elements = vertices + 1 + layout.normal.map_or(0, |_| vertices) + triangles;
        reserve::check(elements as u64 * 12, &what)?;
        // One more position: the padding Embree reads past the last vertex.
        let positions = mesh_buffer(vertices + 1, &what)?;
        let normals = match layout.normal {
            Some(_) => Some(mesh_buffer(vertices, &what)?),
            None => None,
        };
        Ok(Sink {
            positions,
            normals,
            triangles: mesh_buffer(triangles, &what)?,
            vertex_count: vertices as u64,
            deferred: Vec::new(),
            corners: Vec::new(),
            scratch: Scratch::default(),
            report: MeshReport::default(),
        })
    }

    /// Adds vertex `i` (in file order).
    #[inline]
    pub fn vertex(&mut self, i: u64, p: [f32; 3], n: Option<[f32; 3]>) -> Result<(), String> {
        if let Some(why) = bad_position(&p) {
            return Err(format!("vertex {i} {why}"));
        }
        self.positions.push(p);
        if let (Some(normals), Some(n)) = (&mut self.normals, n) {
            normals.push(n);
        }
        Ok(())
    }

    /// Checks vertex index `k` of face `face`.
    #[inline]
    pub fn index(&self, face: u64, k: i64) -> Result<u32, String> {
        if k < 0 || k as u64 >= self.vertex_count {
            return Err(format!(
                "face {face} uses vertex {k}, but the file has {} vertices",
                self.vertex_count
            ));
        }
        Ok(k as u32)
    }

    /// Adds a triangle of checked indices.
    #[inline]
    pub fn triangle(&mut self, t: [u32; 3]) {
        self.report.faces += 1;
        self.triangles.push(t);
    }

    /// Adds the polygon in `self.corners` (checked indices): a triangle, or an n-gon
    /// triangulated in its plane. A face of fewer than three corners is skipped and counted.
    pub fn polygon(&mut self, face: u64) -> Result<(), String> {
        let n = self.corners.len();
        if n < 3 {
            self.report.short_faces += 1;
            return Ok(());
        }
        self.report.faces += 1;
        if n == 3 {
            self.triangles
                .push([self.corners[0], self.corners[1], self.corners[2]]);
            return Ok(());
        }
        self.report.polygons += 1;
        if (self.positions.len() as u64) < self.vertex_count {
            reserve::make_room(
                &mut self.deferred,
                n + 3,
                "numbers of faces to triangulate read",
            )?;
            // The faces come first in this file: triangulate once the vertices are known.
            // The face's number in two words, its size, its corners.
            self.deferred
                .extend_from_slice(&[face as u32, (face >> 32) as u32, n as u32]);
            self.deferred.extend_from_slice(&self.corners);
            return Ok(());
        }
        let corners = std::mem::take(&mut self.corners);
        let added = self.add_polygon(face, &corners);
        self.corners = corners;
        added
    }

    fn add_polygon(&mut self, face: u64, corners: &[u32]) -> Result<(), String> {
        make_room_in_mesh(&mut self.triangles, corners.len() - 2, "triangles read")?;
        self.scratch.make_room(corners.len())?;
        let (positions, triangles) = (&self.positions, &mut self.triangles);
        let shape = triangulate(
            corners.len(),
            |i| positions[corners[i] as usize],
            &mut self.scratch,
            |t| triangles.push(t.map(|i| corners[i])),
        );
        if shape == Shape::TooLarge {
            return Err(format!(
                "face {face} is {}",
                Shape::too_large(corners.len())
            ));
        }
        self.report.concave_polygons += matches!(shape, Shape::Concave | Shape::Crossing) as u64;
        self.report.crossing_polygons += (shape == Shape::Crossing) as u64;
        Ok(())
    }

    fn finish(mut self) -> Result<(TriangleMesh, MeshReport), String> {
        let deferred = std::mem::take(&mut self.deferred);
        let mut rest = &deferred[..];
        while let [low, high, n, tail @ ..] = rest {
            let (corners, tail) = tail.split_at(*n as usize);
            self.add_polygon(u64::from(*low) | u64::from(*high) << 32, corners)?;
            rest = tail;
        }
        self.triangles.shrink_to_fit();
        let mesh = TriangleMesh {
            positions: self.positions,
            normals: self.normals,
            triangles: self.triangles,
        };
        Ok((mesh, self.report))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The triangles reserved for a header's faces: as many as declared where the data can
    /// hold them, no more than its bytes could hold where it cannot (empty faces).
    #[test]
    fn triangles_are_reserved_for_what_the_data_can_hold() {
        let reserved = |format: &str, faces: u64, data_size: u64| {
            let text = format!(
                "ply\nformat {format} 1.0\nelement vertex 3\nproperty float x\n\
                 property float y\nproperty float z\nelement face {faces}\n\
                 property list uchar int vertex_indices\nend_header\n"
            );
            let header = header::read(&mut std::io::Cursor::new(text.into_bytes())).unwrap();
            let layout = Layout::new(&header).unwrap();
            Sink::new(&header, &layout, data_size)
                .unwrap()
                .triangles
                .capacity()
        };
        // Triangles written in full: 3 vertices of 12 bytes, 1,000 faces of 13.
        let whole = 36 + 1000 * 13;
        assert_eq!(reserved("binary_little_endian", 1000, whole), 1000);
        // 60 million empty faces in 60 MB: 60 MB / 13 bytes, not 60 million.
        let empty = 36 + 60_000_000;
        let got = reserved("binary_little_endian", 60_000_000, empty);
        assert_eq!(got as u64, empty / 13);
        // In ASCII, "3 0 1 2\n" at the least.
        assert_eq!(reserved("ascii", 1000, 1000 * 8), 1000);
        assert_eq!(reserved("ascii", 1000, 2000), 250);
    }
}
