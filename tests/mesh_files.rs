//! Meshes as modelling tools write them: each case accepted (with what it loads into) or
//! refused (with its exact message).

use photondiff::scene::mesh_file::{load_mesh, load_mesh_with_report, LoadedMesh};
use std::process::Command;

/// Writes `content` to a file called `name` in a temporary folder and loads it; errors come
/// back without the folder.
fn load(name: &str, content: &[u8]) -> Result<LoadedMesh, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, content).unwrap();
    load_mesh_with_report(&path).map_err(|e| e.replace(&format!("{}/", dir.path().display()), ""))
}

fn ok(name: &str, content: &str) -> LoadedMesh {
    load(name, content.as_bytes()).unwrap()
}

fn err(name: &str, content: &[u8]) -> String {
    load(name, content).unwrap_err()
}

const PLY_TRIANGLE_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
    property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
    end_header\n";

#[test]
fn ply_polygons_are_fan_triangulated_and_normals_kept() {
    let m = ok(
        "quad.ply",
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n4 0 1 2 3\n",
    );
    assert_eq!(m.mesh.positions.len(), 4);
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.mesh.normals.unwrap()[2], [0.0, 0.0, 1.0]);
    assert_eq!((m.report.faces, m.report.polygons), (1, 1));
}

/// An element's values may wrap onto the next line (a long face list); only an element that
/// begins mid-line is refused (`broken_ascii_ply_files_name_the_element_and_line`).
#[test]
fn ascii_ply_values_may_wrap_onto_the_next_line() {
    let m = ok(
        "wrapped.ply",
        &format!("{PLY_TRIANGLE_HEADER}0 0\n0\n1 0 0\n0 1\n   0\n3 0\n1\n2\n"),
    );
    assert_eq!(
        m.mesh.positions,
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn obj_models_are_merged_with_their_normals() {
    let m = ok(
        "two.obj",
        "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n\
         o b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4//1 5//1 6//1\n",
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [3, 4, 5]]);
    assert_eq!(m.mesh.positions.len(), 6);
    let normals = m.mesh.normals.expect("per-vertex normals");
    assert!(normals.iter().all(|n| *n == [0.0, 0.0, 1.0]));
}

#[test]
fn obj_materials_groups_and_smoothing_are_ignored_even_when_the_mtl_is_missing_or_broken() {
    let obj = "# Blender\nmtllib missing.mtl\no Cube\ng side\ns 1\nusemtl Material.001\n\
               v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\ns off\nf 1/1 2/2 3/3\n";
    let m = ok("model.obj", obj);
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
    // The same with a malformed .mtl beside it.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("missing.mtl"),
        "newmtl\nKd one two\n\x00\x01",
    )
    .unwrap();
    std::fs::write(dir.path().join("model.obj"), obj).unwrap();
    let mesh = load_mesh(&dir.path().join("model.obj")).unwrap();
    assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn obj_negative_indices_crlf_bom_and_continuations() {
    let m = ok(
        "rel.obj",
        "\u{feff}v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf -3 -2 -1\r\nv 1 1 0\r\nf 2 \\\r\n 4 3\r\n",
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [1, 3, 2]]);
    // Relative normal indices too; lines and points are skipped, not refused.
    let m = ok(
        "reln.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//-1 -2//-1 -1//-1\nl 1 2\np 3\n",
    );
    assert_eq!(m.mesh.normals.unwrap(), vec![[0.0, 0.0, 1.0]; 3]);
    assert_eq!(m.report.skipped_lines_points, 2);
}

/// A backslash that ends a comment is the comment's: the line after it stands (a Windows path
/// in an exporter's comment swallowed the first vertex, and every face moved by one).
#[test]
fn obj_a_comment_ending_in_a_backslash_does_not_continue() {
    let m = ok(
        "comment.obj",
        "# exported from C:\\models\\\nv 0 0 0\nv 1 0 0 # a corner \\\nv 0 1 0\nf 1 2 \\\n 3\n\
         v 5 5 5 \\\n  \n",
    );
    // The last vertex, continued onto a blank line, is read (and dropped: no face uses it).
    assert_eq!(m.report.unused_vertices, 1);
    assert_eq!(
        m.mesh.positions,
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
}

/// A scene's mesh given as a named pipe is refused at once: the scene's hash read it a second
/// time, which waited for a writer for ever.
#[test]
fn a_scene_mesh_that_is_a_named_pipe_is_refused_not_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.obj");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n\
         width = 8\nheight = 8\n[materials.m]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"pipe.obj\"\nmaterial = \"m\"\n",
    )
    .unwrap();
    // One writer, as a shell's pipe gives; without the check the second read never returned.
    let writer = fifo.clone();
    std::thread::spawn(move || {
        let _ = std::fs::write(writer, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    });
    let (send, receive) = std::sync::mpsc::channel();
    let path = scene.clone();
    std::thread::spawn(move || {
        let loaded = photondiff::scene::file::load_scene_hashed(&path, |_, _| {});
        let _ = send.send(loaded.map(|_| ()).map_err(|e| e.to_string()));
    });
    let result = receive
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("loading the scene hung on its named pipe");
    assert_eq!(
        result.unwrap_err(),
        format!(
            "{}: shapes[0].file: {}: is a named pipe: a scene's mesh file is read twice (loaded, then hashed for \
             the scene's content hash), which a pipe cannot give; write it to a file",
            scene.display(),
            fifo.display()
        )
    );
}

/// Exporters write edges and loose vertices as faces of two, one or no vertices: they are not
/// surfaces, so they are skipped and counted (a whole mesh was refused for one of them).
#[test]
fn faces_of_fewer_than_three_vertices_are_skipped_and_counted() {
    let m = ok(
        "short.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2\nf 1 2 3\nf 4\nf\nf 1 3 4\n",
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!((m.report.faces, m.report.short_faces), (2, 3));
    assert_eq!(
        m.report.warning().unwrap(),
        "skipped 3 faces of fewer than three vertices (not surfaces)"
    );
    let h = PLY_TRIANGLE_HEADER.replace("face 1", "face 4");
    let m = ok(
        "short.ply",
        &format!("{h}0 0 0\n1 0 0\n0 1 0\n2 0 1\n3 0 1 2\n1 2\n0\n"),
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!((m.report.faces, m.report.short_faces), (1, 3));
    // Nothing but short faces is no mesh.
    assert_eq!(
        err("lines.obj", b"v 0 0 0\nv 1 0 0\nf 1 2\n"),
        "lines.obj: the mesh has no triangles"
    );
}

/// Classic Mac OS ended lines with a lone carriage return: each is a line of its own, and
/// errors count lines the same way.
#[test]
fn obj_lines_may_end_in_a_lone_carriage_return() {
    let m = ok(
        "cr.obj",
        "# old\rv 0 0 0\rv 1 0 0\r\nv 0 1 0\rf 1 \\\r2 3\r",
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(
        err("cr.obj", b"v 0 0 0\rv 1 0 0\r\rv x 0 0\r"),
        "cr.obj: line 4: 'x' is not a number"
    );
}

#[test]
fn obj_concave_ngons_are_ear_clipped_in_their_plane() {
    // An L-shaped hexagon (area 3) in the plane x = 1, starting at its reflex corner: a fan
    // from the first corner would cover the notch. Seen from +x it turns counter-clockwise.
    let m = ok(
        "l.obj",
        "v 1 1 1\nv 1 1 2\nv 1 0 2\nv 1 0 0\nv 1 2 0\nv 1 2 1\nf 1 2 3 4 5 6\n",
    );
    assert_eq!(m.mesh.triangles.len(), 4);
    assert_eq!((m.report.polygons, m.report.concave_polygons), (1, 1));
    let mut total = 0.0;
    for t in &m.mesh.triangles {
        let [a, b, c] = t.map(|k| glam::DVec3::from(m.mesh.positions[k as usize].map(f64::from)));
        let n = (b - a).cross(c - a);
        assert!(
            n.x > 0.0 && n.y == 0.0 && n.z == 0.0,
            "{t:?} turns the wrong way"
        );
        // Every triangle lies inside the L: its centroid is not in the notch y, z in (1, 2).
        let g = (a + b + c) / 3.0;
        assert!(!(g.y > 1.0 && g.z > 1.0), "{t:?} covers the notch");
        total += n.x / 2.0;
    }
    assert!((total - 3.0).abs() < 1e-12);
}

#[test]
fn obj_vertices_split_where_a_position_has_two_normals() {
    // A crease: vertices 1 and 2 are shared by two faces with different normals.
    let m = ok(
        "crease.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvn 0 1 0\n\
         f 1//1 2//1 3//1\nf 1//2 4//2 2//2\n",
    );
    assert_eq!(m.mesh.positions.len(), 6);
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [4, 3, 5]]);
    let n = m.mesh.normals.unwrap();
    assert_eq!(n[4], [0.0, 1.0, 0.0]);
    assert_eq!(m.mesh.positions[4], [0.0, 0.0, 0.0]);
    assert_eq!(m.mesh.positions[5], [1.0, 0.0, 0.0]);
    // Vertex 4 (index 3) is used only with normal 2.
    assert_eq!(n[3], [0.0, 1.0, 0.0]);
}

#[test]
fn one_degenerate_triangle_is_dropped_and_counted() {
    let m = ok(
        "flat.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\nf 2 3 4\n",
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 3], [1, 2, 3]]);
    assert_eq!(m.report.degenerate_triangles, 1);
    assert_eq!(
        m.report.warning().unwrap(),
        "dropped 1 degenerate (zero-area) triangle (the first: [0.0, 0.0, 0.0] [1.0, 0.0, 0.0] [2.0, 0.0, 0.0])"
    );
    // A mesh of nothing but degenerate triangles is refused.
    let e = err(
        "line.ply",
        format!("{PLY_TRIANGLE_HEADER}0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n").as_bytes(),
    );
    assert_eq!(
        e,
        "line.ply: the mesh has no triangles: all 1 are degenerate (zero area)"
    );
}

/// A triangle wound against all three of its vertex normals is counted and warned about: the
/// winding says which side is outside, so a mesh whose faces were reversed but whose normals
/// were not rendered its glass inside out (an air bubble, no caustic) without a word. A
/// triangle with one normal on its side is not (smoothed normals at a crease may lean over).
#[test]
fn triangles_wound_against_their_vertex_normals_are_counted() {
    let m = ok(
        "against.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 -1\nvn 0.1 0 1\n\
         f 1//1 2//1 3//1\nf 2//1 4//2 3//1\nf 3//1 2//1 1//1\n",
    );
    // Counter-clockwise seen from +z: the first wound against -z normals; the second has one
    // +z normal; the third, wound clockwise (-z), agrees with its -z normals.
    assert_eq!(m.report.against_normals, 1);
    assert_eq!(
        m.report.warning().unwrap(),
        "1 triangle winds against all three of its vertex normals (the winding says which \
         side is outside: glass there is inside out; reverse those faces' winding)"
    );
}

#[test]
fn zero_and_nan_normals_take_the_geometric_normal() {
    let m = ok(
        "n.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn nan 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
    );
    assert_eq!(m.report.repaired_normals, 2);
    assert_eq!(m.mesh.normals.unwrap(), vec![[0.0, 0.0, 1.0]; 3]);
    assert_eq!(
        m.report.warning().unwrap(),
        "replaced 2 zero or non-finite vertex normals by the geometric normal there"
    );
    let m = ok(
        "n.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 0 0 0\n0 1 0 0 0 0\n1 0 0 0 0 -1\n3 0 1 2\n",
    );
    assert_eq!(m.report.repaired_normals, 2);
    assert_eq!(m.mesh.normals.unwrap(), vec![[0.0, 0.0, -1.0]; 3]);
}

#[test]
fn ply_comments_obj_info_crlf_bom_mixed_faces_and_extra_properties() {
    let ply = "\u{feff}ply\r\nformat ascii 1.0\r\ncomment made by a scanner\r\nobj_info num_cols 2\r\n\
         element vertex 5\r\nproperty double x\r\nproperty float confidence\r\nproperty double y\r\n\
         property double z\r\nproperty uchar red\r\nproperty list uchar float extra\r\n\
         element face 2\r\nproperty int flags\r\nproperty list ushort uint vertex_index\r\n\
         property list int short more\r\nelement edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\n\
         end_header\r\n\
         0 0.5 0 0 255 2 1.5 2.5\r\n1 0.5 0 0 255 0\r\n1 0.5 1 0 255 1 3\r\n0 0.5 1 0 255 0\r\n\
         2 0.5 2 0 255 0\r\n\
         7 4 0 1 2 3 2 -1 -2\r\n0 3 3 2 4 0\r\n0 1\r\n";
    let m = ok("mixed.ply", ply);
    assert_eq!(m.mesh.positions[4], [2.0, 2.0, 0.0]);
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 4]]);
    assert_eq!((m.report.faces, m.report.polygons), (2, 1));
}

/// A vertex may carry w or a colour; a comment may end any line.
#[test]
fn obj_vertex_colours_and_comments_after_statements() {
    let m = ok(
        "c.obj",
        "v 0 0 0 1 # w\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0 0.5 0.5 0.5 1\nvn 0 0 1 # up\n\
         f 1//1 2//1 3//1 # the only face\n# the end\n",
    );
    assert_eq!(
        m.mesh.positions,
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2]]);
    assert_eq!(m.mesh.normals.unwrap(), vec![[0.0, 0.0, 1.0]; 3]);
}

#[test]
fn broken_obj_files_name_the_line() {
    let cases: &[(&str, &str)] = &[
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n",
            "line 4: vertex index 5 is out of range (3 vertices so far)",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n",
            "line 4: vertex index -4 is out of range (3 vertices so far)",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            "line 4: vertex index 0 is invalid (OBJ indices start at 1)",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n",
            "line 4: normal index 1 is out of range (0 normals so far)",
        ),
        ("v 0 0 0\nv 1 zero 0\n", "line 2: 'zero' is not a number"),
        // After x y z: w, or a colour (and w), numbers all (junk was read past).
        ("v 0 0 0 junk\n", "line 1: 'junk' is not a number"),
        (
            "v 0 0 0 1 1 1 1 1\n",
            "line 1: 'v' takes at most 7 numbers (x y z, a colour r g b, w)",
        ),
        (
            "vn 0 0 1 junk\n",
            "line 1: 'vn' takes 3 numbers, then 'junk'",
        ),
        ("v 0 0\n", "line 1: 'v' needs 3 numbers (x y z)"),
        (
            "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
            "line 2: vertex 2 is not finite: [NaN, 0.0, 0.0]",
        ),
        (
            "v 0 0 0\nv 1e30 0 0\n",
            "line 2: vertex 2 is too large (beyond 1e18): [1e30, 0.0, 0.0]",
        ),
        // Past single precision the file's value is infinite when read: said so, not only
        // "not finite" beside an `inf` the file does not hold.
        (
            "v 0 0 0\nv 1e39 0 0\n",
            "line 2: vertex 2 is not finite (infinite, or beyond single precision's 3.4e38): \
             [inf, 0.0, 0.0]",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
            "line 4: 'x' is not a vertex index",
        ),
        (
            "v 0 0 0\nsolid cube\n",
            "line 2: unknown OBJ statement 'solid'",
        ),
        // Binary data read as text: control characters escaped (NUL bytes in a message made
        // a log binary to `grep`).
        (
            "v 1 2 3\n\u{1}\u{0}\u{7f} garbage\n",
            "line 2: unknown OBJ statement '\\u{1}\\u{0}\\u{7f}'",
        ),
        ("# nothing\n", "the mesh has no triangles"),
    ];
    for (obj, message) in cases {
        assert_eq!(
            err("m.obj", obj.as_bytes()),
            format!("m.obj: {message}"),
            "{obj}"
        );
    }
    let e = load_mesh(std::path::Path::new("/nonexistent/x.obj")).unwrap_err();
    assert!(
        e.starts_with("/nonexistent/x.obj: cannot read OBJ: "),
        "{e}"
    );
}

#[test]
fn broken_ascii_ply_files_name_the_element_and_line() {
    let h = PLY_TRIANGLE_HEADER;
    let cases: Vec<(String, &str)> = vec![
        (format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"), "line 13: face 0 uses vertex 7, but the file has 3 vertices"),
        (format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"), "line 13: face 0 uses vertex -1, but the file has 3 vertices"),
        (format!("{h}0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"), "line 11: vertex 1: 'x' is not a number"),
        (format!("{h}0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"), "line 11: vertex 1 is not finite: [NaN, 0.0, 0.0]"),
        (format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n"), "line 13: face 0: '1.5' is not a vertex index"),
        // A negative length was read as an empty face.
        (format!("{h}0 0 0\n1 0 0\n0 1 0\n-2 0 1 2\n"), "line 13: face 0: '-2' is not a list length"),
        (format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1\n"), "the file ends in face 0 of 1: truncated, or the header's counts do not match the data"),
        // A row of another length shifted every value after it (read as a flat quad's corner
        // [1, 0, 1] and a face of the next row's values, without a word).
        (format!("{h}0 0 0\n1 0\n1 0 0 1\n3 0 1 2\n"), "line 12: vertex 2 begins on the line where vertex 1 ended: each element must begin a line (a row of another length than the header says would shift every value after it)"),
        (format!("{h}0 0 0 5\n1 0 0\n0 1 0\n3 0 1 2\n"), "line 10: vertex 1 begins on the line where vertex 0 ended: each element must begin a line (a row of another length than the header says would shift every value after it)"),
        (format!("{h}0 0 0\n1 0 0\n0 1 0 3\n0 1 2\n"), "line 12: face 0 begins on the line where vertex 2 ended: each element must begin a line (a row of another length than the header says would shift every value after it)"),
        (format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n"), "line 14: '3' after the last element: the header's counts do not match the data"),
        (format!("{h}0 0 0\n1 0 0\n"), "the header declares 3 vertex, 1 face: at least 19 bytes of ascii data, but the file has 12 bytes after its header"),
        ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nend_header\n".into(), "cannot parse PLY: the vertex element has no 'z'"),
        (h.replace("element face 1\nproperty list uchar int vertex_indices\n", ""), "PLY file has no 'face' element"),
        (h.replace("list uchar int", "list uchar float"), "cannot parse PLY: face property 'vertex_indices' must be a list of integers, got a list of float"),
        (h.replace("property float z", "property quad z"), "cannot parse PLY: header line 6: unknown property type 'quad'"),
        (h.replace("end_header\n", ""), "cannot parse PLY: header line 9: the header has no end_header line"),
        // A header past 1 MiB (100,000 comments before end_header) says so, not that it has no end.
        (h.replace("end_header\n", &format!("{}end_header\n", "comment 0123456789\n".repeat(100_000))),
         "cannot parse PLY: header line 55189: the header is over 1 MiB without an end_header line (a header that long is not read)"),
        ("this is not a ply file\n".into(), "cannot parse PLY: header line 1: not a PLY file (the first line is not 'ply')"),
        // The same element or property twice: which is the geometry would be a guess.
        (h.replace("element face 1\n", "element vertex 3\nproperty float x\nelement face 1\n"),
         "cannot parse PLY: header line 7: a second element 'vertex'"),
        (h.replace("property float z\n", "property float z\nproperty double x\n"),
         "cannot parse PLY: header line 7: a second property 'x' in element 'vertex'"),
        // Both spellings of the corners' list: which is the geometry would be a guess too.
        (h.replace("end_header\n", "property list uchar int vertex_index\nend_header\n"),
         "cannot parse PLY: the face element has both a 'vertex_indices' and a 'vertex_index' list: which holds the corners is ambiguous"),
        (format!("{h}0 0 0\n1 \u{0}\u{1} 0\n0 1 0\n3 0 1 2\n"), "line 11: vertex 1: '\\u{0}\\u{1}' is not a number"),
    ];
    for (ply, message) in &cases {
        assert_eq!(
            err("m.ply", ply.as_bytes()),
            format!("m.ply: {message}"),
            "{ply}"
        );
    }
}

#[test]
fn the_command_line_warns_once_counts_repairs_and_info_describes_files() {
    let exe = env!("CARGO_BIN_EXE_photondiff");
    let dir = tempfile::tempdir().unwrap();
    // Two degenerate triangles and a zero normal in a fine quad, and a stray vertex far off
    // (vertex 6; vertex 5 only a dropped triangle uses): both go, and the bounds without them.
    std::fs::write(
        dir.path().join("quad.obj"),
        "mtllib gone.mtl\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nv 0 0 0\nv 1000 0 0\nvn 0 1 0\nvn 0 0 0\n\
         f 1//1 2//1 3//1 4//2\nf 1//1 2//1 1//1\nf 5//1 5//1 5//1\n",
    )
    .unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        "[camera]\neye = [0.0, 2.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\n\
         fov_y = 40.0\nwidth = 16\nheight = 12\n\
         [materials.white]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[lights]]\ntype = \"point\"\nposition = [0.0, 4.0, 0.0]\nintensity = [10.0, 10.0, 10.0]\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"quad.obj\"\nmaterial = \"white\"\n",
    )
    .unwrap();
    let stats = dir.path().join("stats.json");
    let out = Command::new(exe)
        .args([
            "render",
            "--quiet",
            // No global photons: this floor alone cannot store any (which would be a warning).
            "--photons",
            "0",
            "--caustic-photons",
            "10",
            "-o",
        ])
        .arg(dir.path().join("img.exr"))
        .arg("--stats-json")
        .arg(&stats)
        .arg(&scene)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert_eq!(
        stderr.trim(),
        format!(
            "photondiff: warning: {}: shapes[0] (mesh quad.obj): dropped 2 degenerate \
             (zero-area) triangles (the first: [-1.0, 0.0, 1.0] [1.0, 0.0, 1.0] [-1.0, 0.0, 1.0]); \
             dropped 2 vertices no triangle uses; replaced 1 zero or non-finite vertex normal by the geometric normal there",
            scene.display()
        )
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(json["mesh_repairs"]["degenerate_triangles"], 2);
    assert_eq!(json["mesh_repairs"]["repaired_normals"], 1);
    assert_eq!(json["mesh_repairs"]["unused_vertices"], 2);

    let out = Command::new(exe).arg("info").arg(&scene).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for line in [
        "shapes[0] (mesh quad.obj):",
        "  vertices   4",
        "  triangles  2 (from 3 faces; 1 polygons triangulated, 0 of them concave)",
        "  bounds     [-1, 0, -1] .. [1, 0, 1] (size 2 x 0 x 2)",
        "  dropped    2 degenerate (zero-area) triangles, 2 vertices no triangle uses",
        "  repaired   1 zero or non-finite vertex normals",
        // 12 bytes x (4 positions + 4 normals + 2 triangles) = 120 bytes.
        "  memory     120 bytes (0.0 MiB) of mesh buffers",
        "  BVH        medium (by default under 4,000,000 unique triangles; --bvh-compact for \
         about half the memory)",
    ] {
        assert!(
            text.lines().any(|l| l.starts_with(line)),
            "no '{line}' in\n{text}"
        );
    }
    let out = Command::new(exe)
        .arg("info")
        .arg(dir.path().join("quad.obj"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("  triangles  2 (from 3 faces"), "{text}");
    let out = Command::new(exe)
        .arg("info")
        .arg(dir.path().join("none.ply"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("photondiff: error: "));
    // A missing file, a folder and another kind of file are named as such (all three said
    // "unsupported mesh format").
    let cases = [
        (
            dir.path().join("none.ply"),
            "cannot read: No such file or directory (os error 2)",
        ),
        (dir.path().to_path_buf(), "is a folder"),
        (
            dir.path().join("quad.obj.txt"),
            "expected a scene (.toml) or a mesh (.obj, .ply) file",
        ),
    ];
    std::fs::write(dir.path().join("quad.obj.txt"), "v 0 0 0\n").unwrap();
    for (path, message) in cases {
        let out = Command::new(exe).arg("info").arg(&path).output().unwrap();
        assert_eq!(out.status.code(), Some(1));
        assert_eq!(
            String::from_utf8_lossy(&out.stderr),
            format!("photondiff: error: {}: {message}\n", path.display())
        );
    }
}

/// A scene's mesh files report their reading: the total is their sizes (a mesh shape's file and
/// an instanced mesh's, once however many times it is placed), the bytes read never go back
/// nor past it, a file of several megabytes reports on the way, and the last report is the
/// whole.
#[test]
fn a_scene_reports_the_bytes_of_its_mesh_files_as_it_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let big = photondiff::scene::shapes::sphere(glam::DVec3::ZERO, 0.3, 1024);
    photondiff::scene::mesh_file::ply::write::write_binary(
        &big,
        std::io::BufWriter::new(std::fs::File::create(dir.path().join("big.ply")).unwrap()),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("small.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let text = "[camera]\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n\
        width = 8\nheight = 8\n\n[materials.grey]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\n\
        [[lights]]\ntype = \"point\"\nposition = [0, 4, 0]\nintensity = [1, 1, 1]\n\n\
        [[shapes]]\ntype = \"mesh\"\nfile = \"big.ply\"\nmaterial = \"grey\"\n\n\
        [meshes.small]\nfile = \"small.obj\"\n\n\
        [[instances]]\nmesh = \"small\"\nmaterial = \"grey\"\ntranslate = [2, 0, 0]\n\n\
        [[instances]]\nmesh = \"small\"\nmaterial = \"grey\"\ntranslate = [-2, 0, 0]\n";
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let size = |name: &str| std::fs::metadata(dir.path().join(name)).unwrap().len();
    let total = size("big.ply") + size("small.obj");
    assert!(size("big.ply") > 2 * photondiff::util::input::REPORT_EVERY);
    let seen = std::cell::RefCell::new(Vec::new());
    let scene = photondiff::scene::file::load_scene_reporting(&path, |done, all| {
        seen.borrow_mut().push((done, all))
    })
    .unwrap();
    assert_eq!(scene.meshes.len(), 3);
    let seen = seen.into_inner();
    assert!(seen.iter().all(|&(_, all)| all == total), "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0].0 <= w[1].0), "{seen:?}");
    assert!(
        seen.iter()
            .any(|&(done, _)| done > 0 && done < size("big.ply")),
        "{seen:?}"
    );
    assert_eq!(seen.last(), Some(&(total, total)));
}

/// A concave polygon past the ear-clipping limit is refused, in OBJ and in PLY (faces before
/// vertices too); it used to be fanned above 4,096 vertices, covering the missing quadrant of
/// an L without a word. At the limit it is clipped and covers the L's area exactly.
#[test]
fn concave_polygons_past_the_ear_clipping_limit_are_refused() {
    use photondiff::scene::mesh_file::triangulate::MAX_EAR_CLIPPED;
    // An L of area 3 whose edges are cut into `n / 6` pieces each.
    let l = |n: usize| -> Vec<[f64; 2]> {
        let c = [
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
            [0.0, 0.0],
        ];
        let per = n / 6;
        (0..6 * per)
            .map(|i| {
                let (a, b) = (c[i / per], c[(i / per + 1) % 6]);
                let t = (i % per) as f64 / per as f64;
                [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]
            })
            .collect()
    };
    let obj = |p: &[[f64; 2]]| {
        let mut text: String = p.iter().map(|[x, y]| format!("v {x} {y} 0\n")).collect();
        text += "f";
        (1..=p.len()).for_each(|i| text += &format!(" {i}"));
        text + "\n"
    };
    let m = ok("l.obj", &obj(&l(MAX_EAR_CLIPPED)));
    let area: f64 = m
        .mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| m.mesh.positions[k as usize].map(f64::from));
            ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / 2.0
        })
        .sum();
    assert!((area - 3.0).abs() < 1e-6, "{area}");
    let p = l(MAX_EAR_CLIPPED + 6);
    let n = p.len();
    let too_large = format!(
        "a concave polygon of {n} vertices: ear clipping takes at most {MAX_EAR_CLIPPED} (its \
         time grows as the square of the count); split or triangulate it first"
    );
    assert_eq!(
        err("l.obj", obj(&p).as_bytes()),
        format!("l.obj: line {}: {too_large}", n + 1)
    );
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement face 1\nproperty list int int vertex_indices\n\
         element vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n{n}"
    );
    (0..n).for_each(|i| ply += &format!(" {i}"));
    ply += "\n";
    p.iter().for_each(|[x, y]| ply += &format!("{x} {y} 0\n"));
    assert_eq!(
        err("l.ply", ply.as_bytes()),
        format!("l.ply: face 0 is {too_large}")
    );
}

/// A face that crosses itself (a bow tie; a pentagram) is triangulated as before but counted
/// and warned about, in OBJ and in PLY: it was fanned without a word, covering area its
/// outline does not (or some twice).
#[test]
fn faces_that_cross_themselves_are_warned_about() {
    let obj = ok(
        "bow.obj",
        "v 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         f 1 2 3 4\nf 5 6 7 8\n",
    );
    assert_eq!(
        (
            obj.report.polygons,
            obj.report.concave_polygons,
            obj.report.crossing_polygons
        ),
        (2, 1, 1)
    );
    assert_eq!(
        obj.report.warning().unwrap(),
        "1 polygon crosses itself (triangulated anyway: the triangles may cover area the \
         outline does not, or some twice; triangulate it first)"
    );
    let pentagram: String = (0..5)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 5.0;
            format!("{} {} 0\n", a.cos(), a.sin())
        })
        .collect();
    let ply = ok(
        "star.ply",
        &format!(
            "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
             property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
             end_header\n{pentagram}5 0 2 4 1 3\n5 0 1 2 3 4\n"
        ),
    );
    assert_eq!((ply.report.polygons, ply.report.crossing_polygons), (2, 1));
    assert!(ply
        .report
        .warning()
        .unwrap()
        .starts_with("1 polygon crosses itself"));
}

/// A large mesh's buffers are advised transparent huge pages as they are reserved, whichever
/// way it comes (binary PLY, OBJ, a scene's sphere): Embree and hit completion read them at
/// random, and in 4 kB pages each such read of a 10M-triangle mesh misses the TLB too.
#[test]
#[cfg(target_os = "linux")]
fn large_meshes_are_read_into_buffers_advised_huge_pages() {
    use photondiff::embree::{has_huge_page_advice, HUGE_PAGES_FROM_BYTES};
    // A grid of n x n vertices: 4.9 MB of positions and 9.8 MB of triangles.
    let n = 640u32;
    let vertices = (n * n) as usize;
    assert!(vertices * 12 >= HUGE_PAGES_FROM_BYTES);
    let grid_triangles = || {
        (0..n - 1).flat_map(move |y| {
            (0..n - 1).flat_map(move |x| {
                let a = y * n + x;
                [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
            })
        })
    };
    let triangles = 2 * (n as usize - 1).pow(2);
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\n\
         property float y\nproperty float z\nelement face {triangles}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
    .into_bytes();
    let mut obj = String::new();
    for y in 0..n {
        for x in 0..n {
            for c in [x as f32, y as f32, 0.0] {
                ply.extend_from_slice(&c.to_le_bytes());
            }
            obj += &format!("v {x} {y} 0\n");
        }
    }
    for t in grid_triangles() {
        ply.push(3);
        for i in t {
            ply.extend_from_slice(&(i as i32).to_le_bytes());
        }
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    for (name, content) in [("grid.ply", ply), ("grid.obj", obj.into_bytes())] {
        let mesh = load(name, &content).unwrap().mesh;
        assert_eq!(
            (mesh.positions.len(), mesh.triangles.len()),
            (vertices, triangles),
            "{name}"
        );
        assert_eq!(mesh.triangles[1], [0, n + 1, n], "{name}");
        assert_eq!(has_huge_page_advice(&mesh.positions), Some(true), "{name}");
        assert_eq!(has_huge_page_advice(&mesh.triangles), Some(true), "{name}");
    }
    let sphere = photondiff::scene::shapes::sphere(glam::DVec3::ZERO, 1.0, 1024);
    assert_eq!(has_huge_page_advice(&sphere.positions), Some(true));
    assert_eq!(has_huge_page_advice(&sphere.triangles), Some(true));
    // That a small buffer is not advised is checked in `embree::pages`'s own test, not here
    // through a small mesh: the allocator hands memory freed by the large meshes above (or by
    // any other test's) to later small buffers, and the advice stays on that memory's mapping
    // (CI saw a 64-segment sphere's triangles in an advised mapping).
}

/// An ASCII PLY element without properties holds no values, however many it claims: skipped at
/// once (10^12 of them, before or after the geometry, took about 80 minutes to read through).
#[test]
fn ascii_ply_elements_without_properties_are_skipped_whatever_their_count() {
    let geometry = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                    element face 1\nproperty list uchar int vertex_indices\n";
    let data = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let junk = "element junk 1000000000000\n";
    for header in [
        format!("ply\nformat ascii 1.0\n{junk}{geometry}end_header\n"),
        format!("ply\nformat ascii 1.0\n{geometry}{junk}end_header\n"),
    ] {
        let m = ok("junk.ply", &format!("{header}{data}"));
        assert_eq!(m.mesh.triangles, vec![[0, 1, 2]], "{header}");
    }
}
