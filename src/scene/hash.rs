//! The content hash of a scene: 64-bit FNV-1a over the scene file's bytes and those of every
//! mesh file it names, in order, each preceded by its length. Files written for a scene (photon
//! maps, parts of a split render) carry it, so that they are never combined with another scene
//! or another version of the same one; moving or renaming the files does not change it.

use std::io::Read;
use std::path::{Path, PathBuf};

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// 64-bit FNV-1a, continued from `hash`.
pub fn fnv1a(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash ^= b as u64;
        hash = hash.wrapping_mul(FNV_PRIME);
    }
    hash
}

/// The content hash of a scene as loaded (or built in code, as the benchmarks' stress scenes
/// are): xxh3 over its camera, lights, materials and transforms (their `Debug` text, whose
/// numbers round-trip exactly) and its meshes' buffers. It names what a cached reference was
/// made of ([`crate::reference::cache`]): a scene edited under the same name was measured
/// against the old scene's reference, without a word.
pub fn content_hash(scene: &super::Scene) -> u64 {
    use xxhash_rust::xxh3::Xxh3;
    let mut hash = Xxh3::new();
    let mut text = |t: String| {
        hash.update(&(t.len() as u64).to_le_bytes());
        hash.update(t.as_bytes());
    };
    text(format!("{:?}", scene.camera));
    text(format!("{:?}", scene.lights));
    for m in &scene.meshes {
        text(format!("{:?} {:?}", m.material, m.transform));
    }
    // Each buffer's numbers as little-endian bytes, a block at a time.
    let mut block: Vec<u8> = Vec::with_capacity(1 << 16);
    let mut words = |values: &mut dyn Iterator<Item = u32>| {
        for v in values {
            block.extend(v.to_le_bytes());
            if block.len() == block.capacity() {
                hash.update(&block);
                block.clear();
            }
        }
        hash.update(&block);
        block.clear();
        hash.update(&u64::MAX.to_le_bytes()); // the buffer's end
    };
    for m in &scene.meshes {
        let mesh = &m.mesh;
        words(&mut mesh.positions.iter().flatten().map(|c| c.to_bits()));
        let normals = mesh.normals.iter().flatten().flatten();
        words(&mut normals.map(|c| c.to_bits()));
        words(&mut mesh.triangles.iter().flatten().copied());
    }
    hash.digest()
}

/// The mesh files a scene file names (`[[shapes]]` of type "mesh", then the `[meshes.NAME]`
/// an instance places, by name), resolved against its folder, in the file's order, each with the
/// field that names it (`shapes[2].file`, `meshes.NAME.file`) for messages.
fn mesh_files(text: &str, base: &Path) -> Vec<(String, PathBuf)> {
    let Ok(value) = text.parse::<toml::Table>() else {
        return Vec::new();
    };
    let shapes = value
        .get("shapes")
        .and_then(|s| s.as_array())
        .into_iter()
        .flatten()
        .enumerate()
        .filter(|(_, s)| s.get("type").and_then(|t| t.as_str()) == Some("mesh"))
        .filter_map(|(i, s)| Some((format!("shapes[{i}].file"), s.get("file")?.as_str()?)));
    // A mesh no instance places is not read (the loader does not read it either).
    let placed: std::collections::BTreeSet<&str> = value
        .get("instances")
        .and_then(|i| i.as_array())
        .into_iter()
        .flatten()
        .filter_map(|i| i.get("mesh")?.as_str())
        .collect();
    let named = value
        .get("meshes")
        .and_then(|m| m.as_table())
        .into_iter()
        .flatten()
        .filter(|(name, _)| placed.contains(&name.as_str()))
        .filter_map(|(name, m)| Some((format!("meshes.{name}.file"), m.get("file")?.as_str()?)));
    shapes
        .chain(named)
        .map(|(field, f)| (field, base.join(f)))
        .collect()
}

/// The content hash of the scene file at `path` and its mesh files.
pub fn scene_hash(path: &Path) -> Result<u64, String> {
    let scene = crate::util::input::read(path)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    scene_hash_of(path, &scene)
}

/// [`scene_hash`] of the scene file at `path` whose bytes, already read, are `scene`.
pub fn scene_hash_of(path: &Path, scene: &[u8]) -> Result<u64, String> {
    let base = path.parent().unwrap_or(Path::new(""));
    let meshes = mesh_files(&String::from_utf8_lossy(scene), base);
    scene_hash_with(path, scene, meshes)
}

/// [`scene_hash_of`] with the mesh files the scene uses already known, each with its field
/// (the loader has them from its own parse: a second parse of a scene of 100,000 instances
/// took a third of its loading time).
pub fn scene_hash_with(
    path: &Path,
    scene: &[u8],
    meshes: Vec<(String, PathBuf)>,
) -> Result<u64, String> {
    let mut hash = fnv1a(FNV_OFFSET, &(scene.len() as u64).to_le_bytes());
    hash = fnv1a(hash, scene);
    for (field, mesh) in meshes {
        // Named with the scene and the field: its bare path said nothing of where it came
        // from.
        hash = hash_file(hash, &mesh).map_err(|e| {
            format!(
                "{}: {field}: {}: cannot read: {e}",
                path.display(),
                mesh.display()
            )
        })?;
    }
    Ok(hash)
}

/// `hash` followed by the length of the file at `path` and its bytes, read a megabyte at a
/// time: reading a mesh file whole for its hash held a second copy of it in memory.
fn hash_file(mut hash: u64, path: &Path) -> std::io::Result<u64> {
    let mut file = crate::util::input::open(path)?;
    let metadata = file.metadata()?;
    if !metadata.is_file() {
        // A named pipe (the loader refuses them first): its bytes were the loader's.
        return Err(std::io::Error::other("not a regular file"));
    }
    let len = metadata.len();
    hash = fnv1a(hash, &len.to_le_bytes());
    let mut buffer = vec![0u8; 1 << 20];
    let mut read = 0u64;
    loop {
        let n = match file.read(&mut buffer) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        hash = fnv1a(hash, &buffer[..n]);
        read += n as u64;
    }
    if read != len {
        return Err(std::io::Error::other(format!(
            "changed while it was read ({len} bytes, then {read})"
        )));
    }
    Ok(hash)
}

/// A hash as 16 hexadecimal digits, as it appears in files and messages.
pub fn hex(hash: u64) -> String {
    format!("{hash:016x}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        assert_eq!(fnv1a(FNV_OFFSET, b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a(FNV_OFFSET, b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn the_hash_follows_the_mesh_files_content_not_their_names() {
        let dir = tempfile::tempdir().unwrap();
        let scene = "[camera]\n[[shapes]]\ntype = \"mesh\"\nfile = \"m.obj\"\n";
        std::fs::write(dir.path().join("a.toml"), scene).unwrap();
        std::fs::write(dir.path().join("m.obj"), "v 0 0 0\n").unwrap();
        let h1 = scene_hash(&dir.path().join("a.toml")).unwrap();
        std::fs::copy(dir.path().join("a.toml"), dir.path().join("b.toml")).unwrap();
        assert_eq!(scene_hash(&dir.path().join("b.toml")).unwrap(), h1);
        std::fs::write(dir.path().join("m.obj"), "v 0 0 1\n").unwrap();
        assert_ne!(scene_hash(&dir.path().join("a.toml")).unwrap(), h1);
        std::fs::remove_file(dir.path().join("m.obj")).unwrap();
        let err = scene_hash(&dir.path().join("a.toml")).unwrap_err();
        let (a, m) = (dir.path().join("a.toml"), dir.path().join("m.obj"));
        let expected = format!(
            "{}: shapes[0].file: {}: cannot read: ",
            a.display(),
            m.display()
        );
        assert!(err.starts_with(&expected), "{err}");
        // A placed mesh's error names its field; one no instance places is not read (the
        // loader does not read it either: a missing file was an error, a broken one not).
        let placed = "[camera]\n[meshes.a]\nfile = \"m.obj\"\n[[instances]]\nmesh = \"a\"\n";
        std::fs::write(&a, placed).unwrap();
        let err = scene_hash(&a).unwrap_err();
        let expected = format!(
            "{}: meshes.a.file: {}: cannot read: ",
            a.display(),
            m.display()
        );
        assert!(err.starts_with(&expected), "{err}");
        let unplaced = "[camera]\n[[shapes]]\ntype = \"quad\"\n[meshes.a]\nfile = \"m.obj\"\n";
        std::fs::write(&a, unplaced).unwrap();
        assert!(scene_hash(&a).is_ok());
    }
}
