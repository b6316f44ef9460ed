//! Valid OBJ and PLY files load into the meshes they describe.

use photondiff::scene::mesh_file::load_mesh;

#[test]
fn ply_polygons_are_fan_triangulated_and_normals_kept() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("quad.ply");
    std::fs::write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n4 0 1 2 3\n",
    )
    .unwrap();
    let mesh = load_mesh(&path).unwrap();
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(mesh.normals.unwrap()[2], [0.0, 0.0, 1.0]);
}

#[test]
fn obj_models_are_merged_with_their_normals() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.obj");
    std::fs::write(
        &path,
        "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n\
         o b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4//1 5//1 6//1\n",
    )
    .unwrap();
    let mesh = load_mesh(&path).unwrap();
    assert_eq!(mesh.triangles.len(), 2);
    assert_eq!(mesh.positions.len(), 6);
    let normals = mesh.normals.expect("per-vertex normals");
    assert!(normals.iter().all(|n| *n == [0.0, 0.0, 1.0]));
    // The second triangle uses the second model's vertices.
    let z: Vec<f32> = mesh.triangles[1]
        .iter()
        .map(|&k| mesh.positions[k as usize][2])
        .collect();
    assert_eq!(z, vec![1.0, 1.0, 1.0]);
}
