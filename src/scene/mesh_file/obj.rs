//! Wavefront OBJ, streamed line by line (no whole-file string): `v`, `vn` and `f` are read;
//! texture coordinates, groups, smoothing groups and materials are ignored (materials come
//! from the scene file, so a missing or broken `mtllib` does not matter); lines and points are
//! skipped. Faces may be n-gons (triangulated in their plane, concave ones by ear clipping) and
//! use negative (relative) indices. CRLF line ends, a UTF-8 byte-order mark and `\`
//! continuation lines are accepted. Errors name the line.

use super::repair::bad_position;
use super::triangulate::{triangulate, Scratch, Shape};
use super::{make_room_in_mesh, shown, MeshReport};
use crate::embree::{advise_huge_pages, TriangleMesh};
use crate::util::reserve;
use std::collections::HashMap;
use std::io::BufRead;
use std::path::Path;

/// Loads the OBJ file at `path`, telling `read` the bytes read so far every few megabytes.
pub fn load(path: &Path, read: &dyn Fn(u64)) -> Result<(TriangleMesh, MeshReport), String> {
    let file = crate::util::input::open(path).map_err(|e| format!("cannot read OBJ: {e}"))?;
    let file = crate::util::input::Counted::new(file, read);
    parse(std::io::BufReader::with_capacity(1 << 16, file))
}

/// `first_normal` of a vertex no face has used yet.
const UNUSED: u32 = u32::MAX;
/// `first_normal` of a vertex used by a corner without a normal.
const NO_NORMAL: u32 = u32::MAX - 1;
/// Marks an output index as a split vertex (a position used with a second normal), numbered
/// after all the file's positions once their count is known.
const SPLIT: u32 = 1 << 31;

/// Statements that are valid OBJ but carry nothing the renderer uses.
const IGNORED: &[&[u8]] = &[
    b"vt",
    b"vp",
    b"o",
    b"g",
    b"s",
    b"mg",
    b"usemtl",
    b"mtllib",
    b"usemap",
    b"maplib",
    b"lod",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"shadow_obj",
    b"trace_obj",
    b"ctech",
    b"stech",
    b"cstype",
    b"deg",
    b"bmat",
    b"step",
    b"curv",
    b"curv2",
    b"surf",
    b"parm",
    b"trim",
    b"hole",
    b"scrv",
    b"sp",
    b"end",
    b"con",
    b"call",
    b"csh",
];

#[derive(Default)]
struct Builder {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    /// Per position: the normal index its first corner used (or `UNUSED`, `NO_NORMAL`).
    first_normal: Vec<u32>,
    /// (position, normal) pairs met after a different first one: their split vertex.
    splits: HashMap<(u32, u32), u32>,
    split_vertices: Vec<(u32, u32)>,
    corners_without_normal: bool,
    triangles: Vec<[u32; 3]>,
    /// Per corner of the current face: (output index, position index).
    face: Vec<(u32, u32)>,
    scratch: Scratch,
    report: MeshReport,
}

fn number(token: &[u8]) -> Result<f32, String> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse::<f32>().ok())
        .ok_or_else(|| format!("'{}' is not a number", shown(token)))
}

fn three_numbers<'a>(
    keyword: &str,
    what: &str,
    tokens: &mut impl Iterator<Item = &'a [u8]>,
) -> Result<[f32; 3], String> {
    let mut v = [0.0; 3];
    for c in &mut v {
        let token = tokens
            .next()
            .ok_or_else(|| format!("'{keyword}' needs 3 numbers ({what})"))?;
        *c = number(token)?;
    }
    Ok(v)
}

/// Resolves a 1-based or negative (relative) OBJ index against `count` elements so far.
fn resolve(token: &[u8], count: usize, what: &str, plural: &str) -> Result<u32, String> {
    let index: i64 = std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("'{}' is not a {what} index", shown(token)))?;
    let resolved = match index {
        i if i > 0 => i - 1,
        i if i < 0 => count as i64 + i,
        _ => {
            return Err(format!(
                "{what} index 0 is invalid (OBJ indices start at 1)"
            ))
        }
    };
    if resolved < 0 || resolved >= count as i64 {
        return Err(format!(
            "{what} index {index} is out of range ({count} {} so far)",
            if count == 1 { what } else { plural }
        ));
    }
    Ok(resolved as u32)
}

impl Builder {
    fn statement(&mut self, line: &[u8]) -> Result<(), String> {
        // A comment runs from '#' to the line's end, after a statement too (`f 1 2 3 # top`).
        let line = line.split(|&b| b == b'#').next().unwrap_or(line);
        let mut tokens = line
            .split(|b| b.is_ascii_whitespace())
            .filter(|t| !t.is_empty());
        let Some(keyword) = tokens.next() else {
            return Ok(());
        };
        match keyword {
            b"v" => {
                let p = three_numbers("v", "x y z", &mut tokens)?;
                // What may follow: w, or a colour r g b (and w), numbers all.
                for (k, token) in tokens.enumerate() {
                    number(token)?;
                    if k == 4 {
                        return Err("'v' takes at most 7 numbers (x y z, a colour r g b, w)".into());
                    }
                }
                if let Some(why) = bad_position(&p) {
                    return Err(format!("vertex {} {why}", self.positions.len() + 1));
                }
                if self.positions.len() >= SPLIT as usize - 1 {
                    return Err("too many vertices".into());
                }
                make_room_in_mesh(&mut self.positions, 1, "vertices read")?;
                reserve::make_room(&mut self.first_normal, 1, "vertices read")?;
                self.positions.push(p);
                self.first_normal.push(UNUSED);
            }
            // Zero or NaN normals are repaired later, as modelling tools write them.
            b"vn" => {
                let n = three_numbers("vn", "x y z", &mut tokens)?;
                if let Some(token) = tokens.next() {
                    return Err(format!("'vn' takes 3 numbers, then '{}'", shown(token)));
                }
                make_room_in_mesh(&mut self.normals, 1, "normals read")?;
                self.normals.push(n);
            }
            b"f" | b"fo" => self.face(tokens)?,
            b"l" | b"p" => self.report.skipped_lines_points += 1,
            _ if IGNORED.contains(&keyword) => {}
            _ => return Err(format!("unknown OBJ statement '{}'", shown(keyword))),
        }
        Ok(())
    }

    fn face<'a>(&mut self, tokens: impl Iterator<Item = &'a [u8]>) -> Result<(), String> {
        self.face.clear();
        for token in tokens {
            let mut parts = token.split(|&b| b == b'/');
            let v = resolve(
                parts.next().unwrap_or(b""),
                self.positions.len(),
                "vertex",
                "vertices",
            )?;
            let _texture = parts.next();
            let n = match parts.next() {
                Some(t) if !t.is_empty() => resolve(t, self.normals.len(), "normal", "normals")?,
                _ => NO_NORMAL,
            };
            let out = self.vertex(v, n);
            reserve::make_room(&mut self.face, 1, "corners of the face read")?;
            self.face.push((out, v));
        }
        let n = self.face.len();
        if n < 3 {
            self.report.short_faces += 1;
            return Ok(());
        }
        make_room_in_mesh(&mut self.triangles, n - 2, "triangles read")?;
        self.scratch.make_room(n)?;
        let (face, positions, triangles) = (&self.face, &self.positions, &mut self.triangles);
        let shape = triangulate(
            n,
            |i| positions[face[i].1 as usize],
            &mut self.scratch,
            |t| triangles.push(t.map(|i| face[i].0)),
        );
        if shape == Shape::TooLarge {
            return Err(Shape::too_large(n));
        }
        self.report.faces += 1;
        if n > 3 {
            self.report.polygons += 1;
            self.report.concave_polygons +=
                matches!(shape, Shape::Concave | Shape::Crossing) as u64;
            self.report.crossing_polygons += (shape == Shape::Crossing) as u64;
        }
        Ok(())
    }

    /// The output vertex of a corner with position `v` and normal `n` (or `NO_NORMAL`): the
    /// position itself unless it was first used with another normal (a crease), then a split
    /// vertex shared by every corner with the same pair.
    fn vertex(&mut self, v: u32, n: u32) -> u32 {
        self.corners_without_normal |= n == NO_NORMAL;
        let first = &mut self.first_normal[v as usize];
        if *first == UNUSED {
            *first = n;
        }
        if *first == n {
            return v;
        }
        let next = self.split_vertices.len() as u32;
        let k = *self.splits.entry((v, n)).or_insert(next);
        if k == next {
            self.split_vertices.push((v, n));
        }
        SPLIT | k
    }

    fn finish(mut self) -> Result<(TriangleMesh, MeshReport), String> {
        let base = self.positions.len();
        if base + self.split_vertices.len() >= SPLIT as usize {
            return Err("too many vertices".into());
        }
        for t in self.triangles.iter_mut().flatten() {
            if *t & SPLIT != 0 {
                *t = base as u32 + (*t & !SPLIT);
            }
        }
        let normals = if self.corners_without_normal || self.triangles.is_empty() {
            None
        } else {
            let raw = std::mem::take(&mut self.normals);
            let mut normals = Vec::with_capacity(base + self.split_vertices.len());
            advise_huge_pages(&mut normals);
            // A vertex no face uses gets any valid normal: it is never shaded.
            normals.extend(self.first_normal.iter().map(|&k| match k {
                UNUSED | NO_NORMAL => [0.0, 0.0, 1.0],
                k => raw[k as usize],
            }));
            normals.extend(self.split_vertices.iter().map(|&(_, n)| raw[n as usize]));
            Some(normals)
        };
        drop(std::mem::take(&mut self.first_normal));
        drop(std::mem::take(&mut self.splits));
        let mut positions = self.positions;
        positions.reserve_exact(self.split_vertices.len());
        for &(v, _) in &self.split_vertices {
            positions.push(positions[v as usize]);
        }
        positions.shrink_to_fit();
        self.triangles.shrink_to_fit();
        let mesh = TriangleMesh {
            positions,
            normals,
            triangles: self.triangles,
        };
        Ok((mesh, self.report))
    }
}

/// Appends the next line of `reader` to `line` with its ending and returns the bytes consumed
/// (0 at the end). A line ends in `\n`, `\r\n` or a lone `\r` (classic Mac OS, whose files
/// were otherwise one long line that said nothing useful).
fn read_line(reader: &mut impl BufRead, line: &mut Vec<u8>) -> std::io::Result<usize> {
    let mut consumed = 0;
    loop {
        let buf = reader.fill_buf()?;
        if buf.is_empty() {
            return Ok(consumed);
        }
        let Some(i) = memchr::memchr2(b'\n', b'\r', buf) else {
            let n = buf.len();
            line.extend_from_slice(buf);
            reader.consume(n);
            consumed += n;
            continue;
        };
        let ending = buf[i];
        line.extend_from_slice(&buf[..=i]);
        reader.consume(i + 1);
        consumed += i + 1;
        if ending == b'\r' && reader.fill_buf()?.first() == Some(&b'\n') {
            line.push(b'\n');
            reader.consume(1);
            consumed += 1;
        }
        return Ok(consumed);
    }
}

/// Parses OBJ text from `reader`, line by line.
pub fn parse(mut reader: impl BufRead) -> Result<(TriangleMesh, MeshReport), String> {
    let mut builder = Builder::default();
    let mut line = Vec::new();
    let mut number = 0usize;
    loop {
        line.clear();
        let start = number + 1;
        // A line ending in a backslash continues on the next one, unless the backslash is in
        // a comment (`# exported from C:\models\` swallowed the vertex after it).
        loop {
            let segment = line.len();
            let n =
                read_line(&mut reader, &mut line).map_err(|e| format!("cannot read OBJ: {e}"))?;
            if n == 0 {
                break;
            }
            number += 1;
            while line.last().is_some_and(|b| b.is_ascii_whitespace()) {
                line.pop();
            }
            if line.last() != Some(&b'\\') || line.get(segment..).is_some_and(|l| l.contains(&b'#'))
            {
                break;
            }
            line.pop();
            line.push(b' ');
        }
        if number < start {
            break; // end of file
        }
        let body = if start == 1 {
            line.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&line)
        } else {
            &line
        };
        builder
            .statement(body)
            .map_err(|e| format!("line {start}: {e}"))?;
    }
    builder.finish()
}
