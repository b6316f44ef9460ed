//! The scene file: a small TOML format (documented in README.md) read into a [`Scene`].
//!
//! Every problem is an error that names the file and the line or field at fault; nothing here
//! panics on bad input.

use crate::embree::MAX_COORDINATE;
use crate::scene::camera::Camera;
use crate::scene::descriptions::{
    exactly_three, Diffuse, Glass, LightDesc, MaterialDesc, MeshShape, Mirror, PointLight,
    QuadLight, QuadShape, ShapeDesc, SphereShape, SpotLight, Vec3,
};
use crate::scene::instances::{InstanceDesc, MeshDesc};
use crate::scene::mesh_file::{load_mesh_reporting, LoadedMesh, MeshReport};
use crate::scene::shapes;
use crate::scene::{Light, Material, Scene, SceneMesh};
use glam::DVec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A scene that could not be loaded: the file and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}: {message}", file.display())]
pub struct SceneError {
    /// The scene file.
    pub file: PathBuf,
    /// What is wrong (with the line, field or mesh file at fault).
    pub message: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(deserialize_with = "one_table")]
    camera: CameraDesc,
    #[serde(default)]
    materials: BTreeMap<String, MaterialDesc>,
    #[serde(default)]
    lights: Vec<LightDesc>,
    #[serde(default)]
    shapes: Vec<ShapeDesc>,
    #[serde(default)]
    meshes: BTreeMap<String, MeshDesc>,
    #[serde(default)]
    instances: Vec<InstanceDesc>,
}

impl SceneFile {
    /// The names of the meshes some instance places.
    fn placed(&self) -> std::collections::BTreeSet<&str> {
        self.instances.iter().map(|i| i.mesh.as_str()).collect()
    }

    /// The mesh files the scene uses, as the hash reads them
    /// (`crate::scene::hash::scene_hash_with`): the mesh shapes' in order, then the placed
    /// `[meshes.NAME]` by name, each with its field, resolved against `base`.
    fn mesh_files(&self, base: &Path) -> Vec<(String, PathBuf)> {
        let shapes = self.shapes.iter().enumerate().filter_map(|(i, s)| match s {
            ShapeDesc::Mesh(MeshShape { file, .. }) => Some((format!("shapes[{i}].file"), file)),
            _ => None,
        });
        let used = self.placed();
        let placed = self
            .meshes
            .iter()
            .filter(|(name, _)| used.contains(name.as_str()))
            .map(|(name, m)| (format!("meshes.{name}.file"), &m.file));
        shapes
            .chain(placed)
            .map(|(field, file)| (field, base.join(file)))
            .collect()
    }
}

/// `[camera]` as a table only: `[[camera]]` (an array of tables) was read field by field as
/// a sequence, and refused as "expected an array of three numbers [x, y, z]".
fn one_table<'de, D: serde::Deserializer<'de>>(d: D) -> Result<CameraDesc, D::Error> {
    struct Table;
    impl<'de> serde::de::Visitor<'de> for Table {
        type Value = CameraDesc;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("one [camera] table")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<CameraDesc, A::Error> {
            CameraDesc::deserialize(serde::de::value::MapAccessDeserializer::new(map))
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, _: A) -> Result<CameraDesc, A::Error> {
            Err(serde::de::Error::custom(
                "a scene has one camera: write [camera], not [[camera]] (an array of tables)",
            ))
        }
    }
    d.deserialize_map(Table)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    #[serde(deserialize_with = "exactly_three")]
    eye: Vec3,
    #[serde(deserialize_with = "exactly_three")]
    look_at: Vec3,
    #[serde(deserialize_with = "exactly_three")]
    up: Vec3,
    fov_y: f64,
    width: u32,
    height: u32,
}

/// Largest image side accepted, to catch typos before allocating a huge film.
pub const MAX_IMAGE_SIDE: u32 = 32768;

/// Most pixels accepted: 2^27 (16384 x 8192, four times 8K UHD). 32768 x 32768 asked for 51 GB
/// at once and the allocation aborted the process.
pub const MAX_PIXELS: u64 = 1 << 27;

/// Reads and checks the scene file at `path`; mesh paths are relative to its folder.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_reporting(path, |_, _| {})
}

/// [`load_scene`], telling `progress` the bytes of mesh files read so far and their total,
/// every few megabytes and after each file: large meshes take seconds to read.
pub fn load_scene_reporting(path: &Path, progress: impl Fn(u64, u64)) -> Result<Scene, SceneError> {
    load_scene_hashed(path, progress).map(|(scene, _)| scene)
}

/// [`load_scene_reporting`], with the scene's content hash ([`crate::scene::hash`]) taken
/// from the text it read: a scene given as a named pipe (`<(...)`) can be read once only, and
/// hashing it by a second read hung (a FIFO waits for a writer) or hashed nothing.
pub fn load_scene_hashed(
    path: &Path,
    progress: impl Fn(u64, u64),
) -> Result<(Scene, u64), SceneError> {
    let err = |message: String| SceneError {
        file: path.to_path_buf(),
        message,
    };
    let text =
        crate::util::input::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    // Parsing allocates as it goes and aborts where an allocation fails: a generated scene of
    // 100,000 instances (10 MB) aborted under a 300 MB limit. Checked first, then.
    crate::util::reserve::check(
        text.len() as u64 * PARSE_BYTES_PER_BYTE,
        &format!(
            "its {} bytes of text (about {PARSE_BYTES_PER_BYTE} bytes each while parsed)",
            text.len()
        ),
    )
    .map_err(err)?;
    let file = parse(&text).map_err(err)?;
    let meshes = file.mesh_files(path.parent().unwrap_or(Path::new("")));
    let scene = build(file, base, &progress).map_err(err)?;
    // Its errors name the scene first, as `err` does.
    let prefix = format!("{}: ", path.display());
    let hash = crate::scene::hash::scene_hash_with(path, text.as_bytes(), meshes)
        .map_err(|e| err(e.strip_prefix(&prefix).unwrap_or(&e).to_string()))?;
    Ok((scene, hash))
}

/// Parses scene text; `base` is the folder mesh paths are relative to.
pub fn parse_scene(text: &str, base: &Path) -> Result<Scene, String> {
    build(parse(text)?, base, &|_, _| {})
}

/// Memory a scene file's parse takes at most, per byte of its text: the parsed document and
/// the scene's own tables. A scene of 30,000 and one of 100,000 instances (3.0 and 10.0 MB)
/// peaked at 126 and 403 MB resident: 40 bytes a byte.
pub const PARSE_BYTES_PER_BYTE: u64 = 48;

fn parse(text: &str) -> Result<SceneFile, String> {
    toml::from_str(text).map_err(|e| e.to_string().trim().to_string())
}

/// Tells `progress` how much of the mesh files `build` reads it has read: the files of the
/// mesh shapes and of the instanced meshes (each once), by their sizes on disk.
struct MeshBytes<'a> {
    progress: &'a dyn Fn(u64, u64),
    total: u64,
    done: std::cell::Cell<u64>,
}

impl<'a> MeshBytes<'a> {
    fn new(file: &SceneFile, base: &Path, progress: &'a dyn Fn(u64, u64)) -> Self {
        let shapes = file.shapes.iter().filter_map(|s| match s {
            ShapeDesc::Mesh(MeshShape { file, .. }) => Some(file),
            _ => None,
        });
        let instanced: std::collections::BTreeSet<&str> =
            file.instances.iter().map(|i| i.mesh.as_str()).collect();
        // Each instanced file once, as `build` reads it.
        let instanced: std::collections::BTreeSet<PathBuf> = instanced
            .into_iter()
            .filter_map(|name| file.meshes.get(name))
            .map(|m| {
                let path = base.join(&m.file);
                std::fs::canonicalize(&path).unwrap_or(path)
            })
            .collect();
        // A file that cannot be read counts nothing here; its loader says why.
        let size = |f: &Path| std::fs::metadata(f).map_or(0, |m| m.len());
        let shapes: u64 = shapes.map(|f| size(&base.join(f))).sum();
        MeshBytes {
            progress,
            total: shapes + instanced.iter().map(|f| size(f)).sum::<u64>(),
            done: std::cell::Cell::new(0),
        }
    }

    /// Loads the mesh at `path` (its report as it reads).
    fn load(&self, path: &Path) -> Result<LoadedMesh, String> {
        // A scene's mesh is read twice: loaded here, then hashed for the scene's content hash
        // (`load_scene_hashed`). A named pipe gives its bytes once: the second read waited for
        // a writer for ever. (`info` reads a mesh given alone once, and takes a pipe.)
        use std::os::unix::fs::FileTypeExt;
        if std::fs::metadata(path).is_ok_and(|m| m.file_type().is_fifo()) {
            return Err(format!(
                "{}: is a named pipe: a scene's mesh file is read twice (loaded, then hashed \
                 for the scene's content hash), which a pipe cannot give; write it to a file",
                path.display()
            ));
        }
        let before = self.done.get();
        let loaded = load_mesh_reporting(path, &|read| (self.progress)(before + read, self.total))?;
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        self.done.set(before + size);
        (self.progress)(self.done.get(), self.total);
        Ok(loaded)
    }
}

fn vec3(field: &str, v: Vec3) -> Result<DVec3, String> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(DVec3::from(v))
    } else {
        Err(format!(
            "{field}: every component must be a finite number, got {v:?}"
        ))
    }
}

/// A point rays start from (the eye, a light): within the coordinates Embree takes, or every ray
/// from it would be refused as invalid and the image would come out black without a word.
fn point(field: &str, v: Vec3) -> Result<DVec3, String> {
    let d = vec3(field, v)?;
    let limit = f64::from(MAX_COORDINATE);
    if d.abs().max_element() >= limit {
        return Err(format!(
            "{field}: must lie within the coordinates Embree takes (|x| < {MAX_COORDINATE:e}), got {v:?}"
        ));
    }
    Ok(d)
}

/// Largest light intensity (W/sr) or radiance (W/(m^2 sr)) accepted: photon powers and pixels
/// are single precision (at most 3.4e38), and a stronger light comes out as infinity.
pub const MAX_LIGHT: f64 = 1.0e20;

/// Smallest light intensity or radiance accepted but 0: photon powers are single precision
/// (at least 1.2e-38 at full precision; a light of 6e-100 W/sr stored a caustic map of power 0
/// and rendered its caustic black without a word), and the passes' noise estimate squares the
/// pixels (a light of 6e-170 W/sr read "noise 0.00%" and stopped `--target-noise` at once).
pub const MIN_LIGHT: f64 = 1.0e-30;

/// A light's intensity or radiance: non-negative, each component 0 or within
/// [`MIN_LIGHT`]..=[`MAX_LIGHT`].
fn emission(field: &str, v: Vec3) -> Result<DVec3, String> {
    let d = non_negative(field, v)?;
    if d.max_element() > MAX_LIGHT {
        return Err(format!(
            "{field}: components must be at most {MAX_LIGHT:e}, got {v:?}"
        ));
    }
    if d.to_array().iter().any(|&c| c > 0.0 && c < MIN_LIGHT) {
        return Err(format!(
            "{field}: components must be 0 or at least {MIN_LIGHT:e} (photon powers are single \
             precision; scale every light up and the image scales with them), got {v:?}"
        ));
    }
    Ok(d)
}

/// The bounding box `[lo, hi]` of a mesh's vertices (lo > hi for none).
fn vertex_bounds(mesh: &crate::embree::TriangleMesh) -> [DVec3; 2] {
    mesh.positions
        .iter()
        .fold([DVec3::INFINITY, DVec3::NEG_INFINITY], |[lo, hi], p| {
            let p = DVec3::from(p.map(f64::from));
            [lo.min(p), hi.max(p)]
        })
}

/// An instance's mesh (its vertices' bounds `[lo, hi]`), placed by `to_world`, must stay within the coordinates Embree takes
/// (as a shape's vertices must): beyond them its rays are refused and it vanishes.
fn check_placed_bounds(
    field: &str,
    [lo, hi]: [DVec3; 2],
    to_world: &glam::DAffine3,
) -> Result<(), String> {
    if lo.x > hi.x {
        return Ok(()); // No vertex.
    }
    let limit = f64::from(MAX_COORDINATE);
    let corners = (0..8).map(|k| {
        let pick = |bit: usize, a: f64, b: f64| if k & bit == 0 { a } else { b };
        to_world.transform_point3(DVec3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        ))
    });
    let reach = corners.fold(0.0f64, |m, c| m.max(c.abs().max_element()));
    if reach.is_nan() || reach >= limit {
        return Err(format!(
            "{field}: the placed mesh reaches {reach:e}, beyond the coordinates Embree takes (|x| < {MAX_COORDINATE:e})"
        ));
    }
    Ok(())
}

fn non_negative(field: &str, v: Vec3) -> Result<DVec3, String> {
    let d = vec3(field, v)?;
    if d.min_element() < 0.0 {
        return Err(format!("{field}: components must be >= 0, got {v:?}"));
    }
    Ok(d)
}

fn number(field: &str, x: f64) -> Result<f64, String> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{field}: must be a finite number, got {x}"))
    }
}

fn parallelogram(field: &str, corner: Vec3, u: Vec3, v: Vec3) -> Result<[DVec3; 3], String> {
    let c = vec3(&format!("{field}.corner"), corner)?;
    let u = vec3(&format!("{field}.edge_u"), u)?;
    let v = vec3(&format!("{field}.edge_v"), v)?;
    // Named by the fields the user wrote: past this, the quad's mesh blamed its vertex 1 (or,
    // with edges near 1e160, whose cross product overflows, called them parallel).
    let reach = [c, c + u, c + v, c + u + v]
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    if reach >= f64::from(MAX_COORDINATE) {
        return Err(format!(
            "{field}: corner, edge_u and edge_v reach {reach:e}, beyond the coordinates Embree \
             takes (|x| < {MAX_COORDINATE:e})"
        ));
    }
    if u.cross(v).length() <= 1e-12 * u.length() * v.length() || u == DVec3::ZERO {
        return Err(format!(
            "{field}: edge_u and edge_v must be non-zero and not parallel"
        ));
    }
    // Embree takes single precision: corners that round together make no surface (a light of
    // edges 1e-30 was an 'invalid mesh' with a degenerate triangle).
    let (p0, p1, p2) = (c.as_vec3(), (c + u).as_vec3(), (c + v).as_vec3());
    if (p1 - p0).cross(p2 - p0) == glam::Vec3::ZERO {
        return Err(format!(
            "{field}: too small for single precision where it stands (edges {:.3e} and {:.3e} \
             long, {:.3e} from the origin): its corners round together",
            u.length(),
            v.length(),
            c.length()
        ));
    }
    Ok([c, u, v])
}

/// The `[camera]` table checked and made a camera.
fn camera(c: &CameraDesc) -> Result<Camera, String> {
    let fov = number("camera.fov_y", c.fov_y)?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!(
            "camera.fov_y: must be in (0, 180) degrees, got {fov}"
        ));
    }
    for (name, side) in [("width", c.width), ("height", c.height)] {
        if side == 0 || side > MAX_IMAGE_SIDE {
            return Err(format!(
                "camera.{name}: must be in 1..={MAX_IMAGE_SIDE}, got {side}"
            ));
        }
    }
    let pixels = u64::from(c.width) * u64::from(c.height);
    if pixels > MAX_PIXELS {
        return Err(format!(
            "camera: width x height must be at most {MAX_PIXELS} pixels (20 GB to render), got \
             {} x {} = {pixels}",
            c.width, c.height
        ));
    }
    // Whether the image fits in this machine's memory is the commands' question, not the
    // file's: `photons` and `info` hold no image, and a `--tile` part holds its tile only
    // (`PEAK_BYTES_PER_PIXEL`'s checks are in `cli/render.rs` and `cli/reference.rs`).
    let eye = point("camera.eye", c.eye)?;
    let look_at = vec3("camera.look_at", c.look_at)?;
    let up = vec3("camera.up", c.up)?;
    if eye == look_at {
        return Err("camera: eye and look_at are the same point".into());
    }
    // Only the direction matters, but it must be a number: `look_at = [1e200, 0, 1e200]`
    // overflowed the view direction's length, and the error blamed `up`.
    if !(look_at - eye).length().is_finite() {
        return Err(format!(
            "camera.look_at: too far from the eye: the view direction's length overflows \
             (got {:?}; only the direction matters, so a nearer point on it will do)",
            c.look_at
        ));
    }
    Camera::look_at(eye, look_at, up, fov, c.width, c.height).ok_or(
        "camera.up: must not be zero or parallel to the view direction (look_at - eye)".into(),
    )
}

/// Light `lights[i]` checked and made a light, with the emitter mesh a quad light is seen as.
fn light(i: usize, l: &LightDesc) -> Result<(Light, Option<SceneMesh>), String> {
    let field = format!("lights[{i}]");
    let mut emitter = None;
    let light = match *l {
        LightDesc::Point(PointLight {
            position,
            intensity,
        }) => Light::Point {
            position: point(&format!("{field}.position"), position)?,
            intensity: emission(&format!("{field}.intensity"), intensity)?,
        },
        LightDesc::Spot(SpotLight {
            position,
            direction,
            intensity,
            cone_angle,
            falloff_start,
        }) => {
            let direction = vec3(&format!("{field}.direction"), direction)?;
            // Scaled first, as the camera's up: [1e300, -1e300, 0] is a direction.
            let direction = (direction / direction.abs().max_element())
                .try_normalize()
                .ok_or(format!("{field}.direction: must not be zero"))?;
            let cone = number(&format!("{field}.cone_angle"), cone_angle)?;
            if !(cone > 0.0 && cone <= 180.0) {
                return Err(format!(
                    "{field}.cone_angle: must be in (0, 180] degrees, got {cone}"
                ));
            }
            let start = number(
                &format!("{field}.falloff_start"),
                falloff_start.unwrap_or(cone),
            )?;
            if !(0.0..=cone).contains(&start) {
                return Err(format!(
                    "{field}.falloff_start: must be in [0, cone_angle] degrees, got {start}"
                ));
            }
            Light::Spot {
                position: point(&format!("{field}.position"), position)?,
                direction,
                intensity: emission(&format!("{field}.intensity"), intensity)?,
                cos_cone: cone.to_radians().cos(),
                cos_falloff_start: start.to_radians().cos(),
            }
        }
        LightDesc::Quad(QuadLight {
            corner,
            edge_u,
            edge_v,
            radiance,
        }) => {
            let [c, u, v] = parallelogram(&field, corner, edge_u, edge_v)?;
            let radiance = emission(&format!("{field}.radiance"), radiance)?;
            emitter = Some(SceneMesh {
                name: format!("{field} (quad light)"),
                mesh: Arc::new(shapes::quad(c, u, v)),
                material: Material::Emitter { radiance },
                report: MeshReport::default(),
                transform: None,
            });
            Light::Quad {
                corner: c,
                edge_u: u,
                edge_v: v,
                radiance,
            }
        }
    };
    Ok((light, emitter))
}

fn build(file: SceneFile, base: &Path, progress: &dyn Fn(u64, u64)) -> Result<Scene, String> {
    let mesh_bytes = MeshBytes::new(&file, base, progress);
    let camera = camera(&file.camera)?;

    let mut materials = BTreeMap::new();
    for (name, m) in &file.materials {
        let field = format!("materials.{name}");
        let material = match *m {
            MaterialDesc::Diffuse(Diffuse { albedo }) => {
                let albedo = non_negative(&format!("{field}.albedo"), albedo)?;
                if albedo.max_element() > 1.0 {
                    return Err(format!(
                        "{field}.albedo: components must be <= 1, got {:?}",
                        albedo.to_array()
                    ));
                }
                Material::Diffuse { albedo }
            }
            MaterialDesc::Mirror(Mirror { reflectance }) => {
                let reflectance = non_negative(&format!("{field}.reflectance"), reflectance)?;
                if reflectance.max_element() > 1.0 {
                    return Err(format!(
                        "{field}.reflectance: components must be <= 1, got {:?}",
                        reflectance.to_array()
                    ));
                }
                Material::Mirror { reflectance }
            }
            MaterialDesc::Glass(Glass { ior }) => {
                let ior = number(&format!("{field}.ior"), ior)?;
                if ior <= 0.0 {
                    return Err(format!("{field}.ior: must be > 0, got {ior}"));
                }
                Material::Glass { ior }
            }
        };
        materials.insert(name.clone(), material);
    }
    let material = |field: &str, name: &str| -> Result<Material, String> {
        materials.get(name).copied().ok_or_else(|| {
            let known: Vec<&str> = materials.keys().map(String::as_str).collect();
            format!(
                "{field}.material: unknown material '{name}' (defined: {})",
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            )
        })
    };

    let mut meshes = Vec::new();
    check_sphere_memory(&file.shapes, crate::util::memory::total_bytes())?;
    for (i, shape) in file.shapes.iter().enumerate() {
        let field = format!("shapes[{i}]");
        let mut report = MeshReport::default();
        let (kind, mut mesh, material) = match shape {
            ShapeDesc::Mesh(MeshShape { file, material: m }) => {
                let path = base.join(file);
                let loaded = mesh_bytes
                    .load(&path)
                    .map_err(|e| format!("{field}.file: {e}"))?;
                report = loaded.report;
                let kind = format!("mesh {}", file.display());
                (kind, loaded.mesh, material(&field, m)?)
            }
            ShapeDesc::Quad(QuadShape {
                corner,
                edge_u,
                edge_v,
                material: m,
            }) => {
                let [c, u, v] = parallelogram(&field, *corner, *edge_u, *edge_v)?;
                let mesh = shapes::quad(c, u, v);
                ("quad".to_string(), mesh, material(&field, m)?)
            }
            ShapeDesc::Sphere(SphereShape {
                center,
                radius,
                material: m,
                segments,
            }) => {
                let center = vec3(&format!("{field}.center"), *center)?;
                let radius = number(&format!("{field}.radius"), *radius)?;
                if radius <= 0.0 {
                    return Err(format!("{field}.radius: must be > 0, got {radius}"));
                }
                // As a quad's corners: its mesh blamed its vertex 0, a point never written.
                let reach = center.abs().max_element() + radius;
                if reach >= f64::from(MAX_COORDINATE) {
                    return Err(format!(
                        "{field}: center and radius reach {reach:e}, beyond the coordinates \
                         Embree takes (|x| < {MAX_COORDINATE:e})"
                    ));
                }
                let segments = segments.unwrap_or(shapes::DEFAULT_SPHERE_SEGMENTS);
                if !(3..=8192).contains(&segments) {
                    return Err(format!(
                        "{field}.segments: must be in 3..=8192, got {segments}"
                    ));
                }
                let mut mesh = shapes::sphere(center, radius, segments);
                // Far from the origin, single precision merges the vertices near the poles:
                // their triangles are dropped and warned about, as a mesh file's are (they
                // were an error naming a triangle the user never wrote).
                crate::scene::mesh_file::repair::repair(&mut mesh, &mut report)
                    .map_err(|e| format!("{field} (sphere): {e}"))?;
                if mesh.triangles.is_empty() {
                    return Err(format!(
                        "{field} (sphere): every triangle has zero area in single precision \
                         (radius {radius} at {:?}): bring it nearer the origin",
                        center.to_array()
                    ));
                }
                ("sphere".to_string(), mesh, material(&field, m)?)
            }
        };
        mesh.validate()
            .map_err(|e| format!("{field} ({kind}): {e}"))?;
        mesh.reserve_padding();
        meshes.push(SceneMesh {
            name: format!("{field} ({kind})"),
            mesh: Arc::new(mesh),
            material,
            report,
            transform: None,
        });
    }

    // Each instanced mesh is loaded once, by its first instance, and shared by the others;
    // its load report goes with that first instance only, so that counts are not repeated.
    // Keyed by the file itself: two `[meshes]` names for one file read it (and held it) twice.
    // Each name's file is resolved once (not once an instance: there may be 100,000).
    let mut loaded: BTreeMap<PathBuf, (Arc<crate::embree::TriangleMesh>, [DVec3; 2])> =
        BTreeMap::new();
    let mut files: BTreeMap<&str, (PathBuf, PathBuf)> = BTreeMap::new(); // (key, path)
    for (i, inst) in file.instances.iter().enumerate() {
        let field = format!("instances[{i}]");
        let to_world = inst.transform(&field)?;
        let material = material(&field, &inst.material)?;
        let Some(desc) = file.meshes.get(&inst.mesh) else {
            let known: Vec<&str> = file.meshes.keys().map(String::as_str).collect();
            return Err(format!(
                "{field}.mesh: unknown mesh '{}' (defined in [meshes]: {})",
                inst.mesh,
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            ));
        };
        let mut report = MeshReport::default();
        let (key, path) = files.entry(inst.mesh.as_str()).or_insert_with(|| {
            let path = base.join(&desc.file);
            (
                std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone()),
                path,
            )
        });
        let (mesh, bounds) = match loaded.get(key) {
            Some((mesh, bounds)) => (mesh.clone(), *bounds),
            None => {
                let mut m = mesh_bytes
                    .load(path)
                    .map_err(|e| format!("meshes.{}.file: {e}", inst.mesh))?;
                report = m.report;
                m.mesh.reserve_padding();
                let mesh = Arc::new(m.mesh);
                let bounds = vertex_bounds(&mesh);
                loaded.insert(key.clone(), (mesh.clone(), bounds));
                (mesh, bounds)
            }
        };
        check_placed_bounds(&field, bounds, &to_world)?;
        meshes.push(SceneMesh {
            name: format!("{field} (instance of mesh {})", inst.mesh),
            mesh,
            material,
            report,
            transform: Some(to_world),
        });
    }

    let mut lights = Vec::new();
    for (i, l) in file.lights.iter().enumerate() {
        let (light, emitter) = light(i, l)?;
        lights.push(light);
        meshes.extend(emitter);
    }
    let placed = file.placed();
    let unplaced: Vec<(&String, &MeshDesc)> = file
        .meshes
        .iter()
        .filter(|(name, _)| !placed.contains(name.as_str()))
        .collect();
    let unplaced_meshes = unplaced.iter().map(|(name, _)| (*name).clone()).collect();
    // The files the scene reads, then those of the meshes no instance places.
    let mesh_files = file
        .mesh_files(base)
        .into_iter()
        .map(|(_, path)| path)
        .chain(unplaced.iter().map(|(_, m)| base.join(&m.file)))
        .collect();
    Ok(Scene {
        camera,
        lights,
        meshes,
        unplaced_meshes,
        mesh_files,
    })
}

/// The least a triangle's share of its BVH takes: Embree's compact BVH, 566 MB for the
/// production ball's 10.2M triangles (55 bytes a triangle; the ordinary one 65).
const LEAST_BVH_BYTES_PER_TRIANGLE: u64 = 50;

/// Refuses, before tessellating, spheres whose mesh buffers and the least BVH over them would
/// not fit in `total` bytes of memory: four spheres of 8,192 segments asked for 6.4 GB of
/// buffers, and where that could not be had the process aborted ("memory allocation failed")
/// rather than saying why; ten of them fitted their 15.4 GB of buffers in 25 GB and were
/// refused by Embree 86 s later, for want of the 34 GB their BVH needs.
fn check_sphere_memory(shapes: &[ShapeDesc], total: Option<u64>) -> Result<(), String> {
    let Some(total) = total else { return Ok(()) };
    let (mut bytes, mut triangles, mut largest) = (0u64, 0u64, 0u32);
    for shape in shapes {
        if let ShapeDesc::Sphere(SphereShape { segments, .. }) = shape {
            let s = segments
                .unwrap_or(shapes::DEFAULT_SPHERE_SEGMENTS)
                .clamp(3, 8192);
            bytes += shapes::sphere_bytes(s);
            triangles += shapes::sphere_triangles(s);
            largest = largest.max(s);
        }
    }
    let bvh = triangles * LEAST_BVH_BYTES_PER_TRIANGLE;
    if bytes + bvh > total {
        return Err(format!(
            "the spheres' {triangles} triangles need {:.1} GB of mesh buffers and {:.1} GB or \
             more of BVH (segments up to {largest}: {} triangles a sphere), more than the {:.1} \
             GB this process may use: use fewer segments",
            bytes as f64 / 1e9,
            bvh as f64 / 1e9,
            shapes::sphere_triangles(largest),
            total as f64 / 1e9
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The loader hashes the mesh files of its own parse; the hash must be the one of the
    /// scene file alone (`scene_hash`, which `merge` and the photon-map checks compute).
    #[test]
    fn the_loader_hashes_as_the_scene_file_alone_does() {
        let dir = tempfile::tempdir().unwrap();
        let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        for name in ["a.obj", "b.obj", "c.obj"] {
            std::fs::write(dir.path().join(name), format!("# {name}\n{tri}")).unwrap();
        }
        let scene = "[camera]\neye = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n\
            up = [0.0, 1.0, 0.0]\nfov_y = 40.0\nwidth = 8\nheight = 8\n\
            [materials.white]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
            [[shapes]]\ntype = \"mesh\"\nfile = \"a.obj\"\nmaterial = \"white\"\n\
            [meshes.z]\nfile = \"b.obj\"\n[meshes.unused]\nfile = \"missing.obj\"\n\
            [meshes.y]\nfile = \"c.obj\"\n\
            [[instances]]\nmesh = \"z\"\nmaterial = \"white\"\n\
            [[instances]]\nmesh = \"y\"\nmaterial = \"white\"\n";
        let path = dir.path().join("s.toml");
        std::fs::write(&path, scene).unwrap();
        let (_, hash) = load_scene_hashed(&path, |_, _| {}).unwrap();
        assert_eq!(hash, crate::scene::hash::scene_hash(&path).unwrap());
        // And it reads the files: another mesh's bytes, another hash.
        std::fs::write(dir.path().join("c.obj"), tri).unwrap();
        assert_ne!(load_scene_hashed(&path, |_, _| {}).unwrap().1, hash);
    }

    #[test]
    fn spheres_beyond_memory_are_refused_before_they_are_made() {
        let ball = |segments| {
            ShapeDesc::Sphere(SphereShape {
                center: [0.0; 3],
                radius: 1.0,
                material: "glass".into(),
                segments,
            })
        };
        // Four spheres of 8,192 segments: 6.4 GB of buffers, 13.4 GB of BVH at the least.
        let four: Vec<ShapeDesc> = (0..4).map(|_| ball(Some(8192))).collect();
        assert_eq!(
            check_sphere_memory(&four, Some(4_000_000_000)).unwrap_err(),
            "the spheres' 268369920 triangles need 6.4 GB of mesh buffers and 13.4 GB or more \
             of BVH (segments up to 8192: 67092480 triangles a sphere), more than the 4.0 GB \
             this process may use: use fewer segments"
        );
        // The buffers alone would fit in 8 GB: the BVH would not.
        assert!(check_sphere_memory(&four, Some(8_000_000_000)).is_err());
        assert!(check_sphere_memory(&four, Some(24_000_000_000)).is_ok());
        assert!(check_sphere_memory(&four, None).is_ok());
        assert!(check_sphere_memory(&[ball(None)], Some(100_000_000)).is_ok());
    }
}
