//! The scene as the renderer sees it: meshes with materials, lights, and one pinhole camera.
//! Read from a file by [`file`](mod@file) (meshes by [`mesh_file`], analytic shapes by [`shapes`]);
//! turned into an Embree scene by [`Scene::build_embree`].

pub mod camera;
pub mod descriptions;
pub mod file;
pub mod hash;
mod instances;
pub mod mesh_file;
pub mod shapes;
pub mod warnings;

use crate::embree::{self, BvhSettings, Device, EmbreeError, TriangleMesh};
use camera::Camera;
use glam::{DAffine3, DVec3};
use mesh_file::MeshReport;
use std::sync::Arc;

/// A surface's scattering.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// Lambertian reflection with the given albedo (RGB, each in `[0, 1]`). Two-sided.
    Diffuse {
        /// Albedo per channel.
        albedo: DVec3,
    },
    /// Perfect specular reflection scaled by `reflectance` (RGB).
    Mirror {
        /// Reflectance per channel.
        reflectance: DVec3,
    },
    /// A smooth dielectric of index `ior` inside (the side the geometric normal points away
    /// from) and 1 outside; reflection and refraction weighted by Fresnel.
    Glass {
        /// Index of refraction inside.
        ior: f64,
    },
    /// The emitting face of a quad area light: radiance `radiance` on the front (the side of
    /// `edge_u x edge_v`), black behind. Not declared in scene files: made for each quad light.
    Emitter {
        /// Emitted radiance.
        radiance: DVec3,
    },
}

impl Material {
    /// Whether the camera path continues through this surface (mirror, glass).
    pub fn is_specular(&self) -> bool {
        matches!(self, Material::Mirror { .. } | Material::Glass { .. })
    }
}

/// A light source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Light {
    /// An isotropic point light of radiant intensity `intensity` (W/sr, RGB).
    Point {
        /// Position.
        position: DVec3,
        /// Radiant intensity.
        intensity: DVec3,
    },
    /// A spot light: intensity `intensity` along `direction`, full up to `cos_falloff_start`,
    /// smoothly falling to zero at `cos_cone` (cosines of the angles from the axis).
    Spot {
        /// Position.
        position: DVec3,
        /// Unit axis.
        direction: DVec3,
        /// Radiant intensity on the axis.
        intensity: DVec3,
        /// Cosine of the outer cone angle (zero beyond).
        cos_cone: f64,
        /// Cosine of the angle where the falloff starts.
        cos_falloff_start: f64,
    },
    /// A one-sided parallelogram area light `corner + s edge_u + t edge_v`, `s, t` in `[0, 1]`,
    /// emitting `radiance` towards `edge_u x edge_v`.
    Quad {
        /// One corner.
        corner: DVec3,
        /// First edge.
        edge_u: DVec3,
        /// Second edge.
        edge_v: DVec3,
        /// Emitted radiance (W/(m^2 sr), RGB).
        radiance: DVec3,
    },
}

impl Light {
    /// Intensity of a point or spot light towards the unit direction `w` (away from the light).
    pub fn intensity_towards(&self, w: DVec3) -> DVec3 {
        match *self {
            Light::Spot { direction, .. } => self.intensity_at_cosine(w.dot(direction)),
            _ => self.intensity_at_cosine(1.0),
        }
    }

    /// Intensity of a point or spot light towards a direction whose cosine with a spot's
    /// axis is `c` (a point light's is the same every way; a quad light has none).
    pub fn intensity_at_cosine(&self, c: f64) -> DVec3 {
        match *self {
            Light::Point { intensity, .. } => intensity,
            Light::Spot {
                intensity,
                cos_cone,
                cos_falloff_start,
                ..
            } => {
                if c <= cos_cone {
                    DVec3::ZERO
                } else if c >= cos_falloff_start {
                    intensity
                } else {
                    // Smoothstep between the outer cone and the start of the falloff.
                    let s = (c - cos_cone) / (cos_falloff_start - cos_cone);
                    intensity * (s * s * (3.0 - 2.0 * s))
                }
            }
            Light::Quad { .. } => DVec3::ZERO,
        }
    }
}

/// A mesh of the scene and the material of all its triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMesh {
    /// What the mesh came from, for messages ("`shapes[2]` (sphere)", "`shapes[0]` (mesh
    /// bunny.ply)").
    pub name: String,
    /// The triangles, shared with the Embree scene built from them (not copied).
    pub mesh: Arc<TriangleMesh>,
    /// Its material.
    pub material: Material,
    /// What loading its file dropped or repaired (all zero for shapes made in the scene file,
    /// and for every instance of a mesh but the first).
    pub report: MeshReport,
    /// For an instance, where it puts the (shared) mesh: `world = transform * local`; `None`
    /// for a mesh whose vertices are in world space.
    pub transform: Option<DAffine3>,
}

impl SceneMesh {
    /// Its triangles' vertices in world space.
    pub fn world_triangles(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        let to_world = self.transform.unwrap_or(DAffine3::IDENTITY);
        self.mesh.triangles.iter().map(move |t| {
            t.map(|k| {
                to_world
                    .transform_point3(DVec3::from(self.mesh.positions[k as usize].map(f64::from)))
            })
        })
    }
}

/// A complete scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// The lights.
    pub lights: Vec<Light>,
    /// The meshes; mesh `i` becomes Embree geometry `i`.
    pub meshes: Vec<SceneMesh>,
    /// The `[meshes.NAME]` no instance places, by name (their files are not read).
    pub unplaced_meshes: Vec<String>,
    /// Every mesh file the scene file names (placed or not), resolved: inputs that no output
    /// of a run may overwrite.
    pub mesh_files: Vec<std::path::PathBuf>,
}

impl Scene {
    /// Builds the Embree scene: every mesh in order, so geometry id `i` is `self.meshes[i]`;
    /// the BVH's settings are the default for the scene's size
    /// ([`BvhSettings::for_triangles`]).
    pub fn build_embree(&self, device: &Device) -> Result<embree::Scene, EmbreeError> {
        self.build_embree_with(device, BvhSettings::for_triangles(self.triangle_count()))
    }

    /// [`Scene::build_embree`] with the BVH's settings (quality, compact, robust).
    pub fn build_embree_with(
        &self,
        device: &Device,
        settings: BvhSettings,
    ) -> Result<embree::Scene, EmbreeError> {
        self.embree_builder(device, settings)?.commit()
    }

    /// [`Scene::build_embree_with`], telling `report` the build's progress, from 0 to 1
    /// ([`embree::SceneBuilder::progress`]).
    pub fn build_embree_reporting(
        &self,
        device: &Device,
        settings: BvhSettings,
        report: impl Fn(f64) + Send + Sync + 'static,
    ) -> Result<embree::Scene, EmbreeError> {
        self.embree_builder(device, settings)?
            .progress(report)
            .commit()
    }

    /// The scene's meshes and instances, ready for Embree to build.
    fn embree_builder(
        &self,
        device: &Device,
        settings: BvhSettings,
    ) -> Result<embree::SceneBuilder, EmbreeError> {
        let mut builder = embree::SceneBuilder::new(device).settings(settings);
        for mesh in &self.meshes {
            match mesh.transform {
                None => builder.add_mesh(mesh.mesh.clone()),
                Some(to_world) => builder.add_instance(&mesh.mesh, to_world),
            }
            .map_err(|e| match e {
                // Named once: the inner message already says "invalid mesh".
                EmbreeError::InvalidMesh(m) => {
                    EmbreeError::InvalidMesh(format!("{}: {m}", mesh.name))
                }
                other => other,
            })?;
        }
        Ok(builder)
    }

    /// What loading the scene's mesh files dropped or repaired, summed over the meshes.
    pub fn mesh_report(&self) -> MeshReport {
        let mut total = MeshReport::default();
        for m in &self.meshes {
            total.add(&m.report);
        }
        total
    }

    /// One warning per mesh file that had elements dropped or repaired, naming the mesh.
    pub fn warnings(&self) -> Vec<String> {
        self.meshes
            .iter()
            .filter_map(|m| {
                let why = match m.name.ends_with(" (sphere)") {
                    // A tessellated sphere's only degenerate triangles are those that single
                    // precision merged.
                    true => {
                        " (merged by single precision at the sphere's distance from the \
                             origin: fewer `segments` keep them apart)"
                    }
                    false => "",
                };
                Some(format!("{}: {}{why}", m.name, m.report.warning()?))
            })
            .collect()
    }

    /// The distinct meshes in memory: an instanced mesh once, however many instances it has.
    pub fn unique_meshes(&self) -> Vec<&Arc<TriangleMesh>> {
        let mut unique: Vec<&Arc<TriangleMesh>> = Vec::new();
        for m in &self.meshes {
            if !unique.iter().any(|u| Arc::ptr_eq(u, &m.mesh)) {
                unique.push(&m.mesh);
            }
        }
        unique
    }

    /// Triangles in memory (each instanced mesh counted once).
    pub fn triangle_count(&self) -> u64 {
        let unique = self.unique_meshes();
        unique.iter().map(|m| m.triangles.len() as u64).sum()
    }

    /// Triangles placed in the scene (each instance counted): what the rays see.
    pub fn placed_triangle_count(&self) -> u64 {
        self.meshes
            .iter()
            .map(|m| m.mesh.triangles.len() as u64)
            .sum()
    }

    /// Whether some shape is diffuse: the only surfaces photons are stored on and that reflect
    /// light towards the camera from the photon maps and direct light.
    pub fn has_diffuse_surface(&self) -> bool {
        self.meshes
            .iter()
            .any(|m| matches!(m.material, Material::Diffuse { .. }))
    }

    /// Bytes of the mesh buffers (shared with the Embree scene; each mesh once).
    pub fn mesh_bytes(&self) -> u64 {
        self.unique_meshes().iter().map(|m| m.bytes()).sum()
    }

    /// World-space bounds `[lo, hi]` of each of `self.meshes` (an instance's are its mesh's
    /// box transformed, a little larger than tight), each mesh's positions read once.
    pub fn mesh_bounds(&self) -> Vec<[DVec3; 2]> {
        self.placed_bounds(&self.local_bounds())
    }

    /// World-space bounds of each of `self.meshes` from `local`, its bounds in its own frame
    /// ([`Scene::local_bounds`]).
    fn placed_bounds(&self, local: &[[DVec3; 2]]) -> Vec<[DVec3; 2]> {
        self.meshes
            .iter()
            .zip(local.iter().copied())
            .map(|(m, box_)| match m.transform {
                None => box_,
                Some(t) => bounds((0..8).map(|i| {
                    let pick = |axis: usize| box_[(i >> axis) & 1][axis];
                    t.transform_point3(DVec3::new(pick(0), pick(1), pick(2)))
                })),
            })
            .collect()
    }

    /// Bounds `[lo, hi]` of each of `self.meshes` in its own file's coordinates (its vertices
    /// as stored), each mesh's positions read once.
    fn local_bounds(&self) -> Vec<[DVec3; 2]> {
        let mut local: Vec<(&Arc<TriangleMesh>, [DVec3; 2])> = Vec::new();
        self.meshes
            .iter()
            .map(
                |m| match local.iter().find(|(u, _)| Arc::ptr_eq(u, &m.mesh)) {
                    Some((_, b)) => *b,
                    None => {
                        let b = bounds(
                            m.mesh
                                .positions
                                .iter()
                                .map(|p| DVec3::from(p.map(f64::from))),
                        );
                        local.push((&m.mesh, b));
                        b
                    }
                },
            )
            .collect()
    }

    /// The material of Embree geometry `geom_id`.
    pub fn material(&self, geom_id: u32) -> &Material {
        &self.meshes[geom_id as usize].material
    }

    /// Offset of secondary ray origins off a surface, along its normal: far above Embree's
    /// single-precision error at the scene's scale, far below any feature.
    ///
    /// 2e-5 of the scene's extent, but at most 1e-3 of its smallest object's size (and 1e-2 of
    /// the thinnest side of a glass mesh's box): under a
    /// floor 10^5 across, 2e-5 of the extent is 2.8, and rays leaving a sphere of radius 1
    /// stepped over its far side and its shadow (the sphere vanished). Never below 5e-7 of
    /// the largest coordinate (about ten single-precision steps there), where Embree's own
    /// rounding would have rays hit the surface they leave. An instance's coordinates count
    /// as Embree sees them: its mesh's own, times the transform's largest stretch (Embree
    /// intersects an instance in its mesh's frame; a mesh stored 10^5 from its origin and
    /// placed back at the world's was tested with the world's offset, and its lit side came
    /// out in bands of acne at 55% of its light).
    pub fn ray_epsilon(&self) -> f64 {
        let local = self.local_bounds();
        let boxes = self.placed_bounds(&local);
        let [lo, hi] = bounds(boxes.iter().flatten().copied());
        if lo.x > hi.x {
            return 2e-5;
        }
        let extent = size_or_default(hi - lo);
        let smallest = boxes
            .iter()
            .map(|[a, b]| (*b - *a).length())
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min);
        // A glass pane's rays must not start past its far side: the thinnest side of a glass
        // mesh's box counts too (a slab 2e-4 thick under an offset of 3.4e-4 was stepped
        // through, its shadow black in a grid, light-traced references alike). Its box only:
        // a pane turned off the axes keeps the offset of its box.
        let thinnest_glass = self
            .meshes
            .iter()
            .zip(&boxes)
            .filter(|(m, _)| matches!(m.material, Material::Glass { .. }))
            .map(|(_, [a, b])| (*b - *a).min_element())
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min);
        let in_frames = self
            .meshes
            .iter()
            .zip(&local)
            .filter_map(|(m, [lo, hi])| {
                let t = m.transform?;
                let stretch = [t.matrix3.x_axis, t.matrix3.y_axis, t.matrix3.z_axis]
                    .map(|c| c.length())
                    .into_iter()
                    .fold(0.0, f64::max);
                Some(lo.abs().max(hi.abs()).max_element() * stretch)
            })
            .fold(0.0, f64::max);
        let largest_coordinate = lo.abs().max(hi.abs()).max_element().max(in_frames);
        (2e-5 * extent)
            .min(1e-3 * smallest)
            .min(1e-2 * thinnest_glass)
            .max(5e-7 * largest_coordinate)
    }

    /// The bounding box `[lo, hi]` of every mesh in world space (an instance's is its mesh's
    /// box transformed), `None` for a scene without meshes.
    pub fn bounds(&self) -> Option<[DVec3; 2]> {
        let [lo, hi] = bounds(self.mesh_bounds().into_iter().flatten());
        (lo.x <= hi.x).then_some([lo, hi])
    }

    /// The diagonal of the scene's bounding box (`size_or_default`), to scale ray offsets and
    /// the photons' footprint limits.
    pub fn extent(&self) -> f64 {
        let [lo, hi] = bounds(self.mesh_bounds().into_iter().flatten());
        if lo.x > hi.x {
            return 1.0;
        }
        size_or_default(hi - lo)
    }
}

impl Scene {
    /// The length the caustic map's footprint limits are fractions of
    /// ([`crate::photons::options::PhotonOptions::class_limits`]): the scene's extent, but at most
    /// twice the diagonal of the box around the camera's eye, the lights and the mirror and
    /// glass objects. A ground plane reaching far away does not widen the caustics: a floor
    /// 10^5 across under the canonical sphere made the smallest footprint 1.4 units, wider
    /// than the sphere, and the caustic kept 16% of its light. (The scenes in `scenes/` keep
    /// their extent: their boxes are more than half as large.)
    pub fn footprint_extent(&self) -> f64 {
        let mut points = vec![self.camera.eye];
        for light in &self.lights {
            match *light {
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    points.push(position)
                }
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    ..
                } => points.extend([
                    corner,
                    corner + edge_u,
                    corner + edge_v,
                    corner + edge_u + edge_v,
                ]),
            }
        }
        let boxes = self.mesh_bounds();
        for (m, [lo, hi]) in self.meshes.iter().zip(boxes) {
            if m.material.is_specular() {
                points.extend([lo, hi]);
            }
        }
        let [lo, hi] = bounds(points.into_iter());
        self.extent().min(2.0 * size_or_default(hi - lo))
    }
}

/// The length of `diagonal`, or 1e-3 where the scene has no size to speak of. (It was at least
/// 1e-3 in any case: a scene a micrometre across, in metres, had its ray offsets and footprint
/// limits set for a millimetre, and its caustic blurred, at 1e-12 lost, without a word.)
fn size_or_default(diagonal: DVec3) -> f64 {
    let length = diagonal.length();
    if length > 1e-20 && length.is_finite() {
        length
    } else {
        1e-3
    }
}

/// The bounding box `[lo, hi]` of `points` (`lo > hi` when there are none).
fn bounds(points: impl Iterator<Item = DVec3>) -> [DVec3; 2] {
    points.fold(
        [DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)],
        |[lo, hi], p| [lo.min(p), hi.max(p)],
    )
}
