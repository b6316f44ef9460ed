//! Triangle meshes, the scene builder, and the committed, immutable, shareable scene.

use super::device::{Device, DeviceHandle, EmbreeError};
use super::ffi;
use super::hit::Hit;
use super::ray::Ray;
use glam::DVec3;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// A triangle mesh as Embree takes it: vertex positions, optional per-vertex normals (for
/// interpolated shading normals) and triangles as vertex index triples.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Per-vertex normals (same length as `positions`), or `None` for flat shading.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Triangles, counter-clockwise seen from the side the geometric normal points to.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Makes sure `positions` has one element of spare capacity, zeroed: Embree reads 4 bytes
    /// past the last vertex, and a mesh with this padding is shared with Embree without a copy
    /// (see [`SceneBuilder::add_mesh`]). Loaders that know the vertex count allocate it upfront.
    pub fn reserve_padding(&mut self) {
        self.positions.reserve(1);
        self.positions.spare_capacity_mut()[0].write([0.0; 3]);
    }

    /// Bytes of the mesh's data: 12 per position, per normal and per triangle (three 32-bit
    /// indices). The PLY loader reserves exactly this (plus the padding position); the OBJ
    /// loader's buffers grow as it reads and may hold up to twice as much.
    pub fn bytes(&self) -> u64 {
        let normals = self.normals.as_ref().map_or(0, Vec::len);
        12 * (self.positions.len() + normals + self.triangles.len()) as u64
    }

    /// Checks what Embree would otherwise silently drop or mis-handle: non-finite or huge
    /// vertices, out-of-range indices, zero-area triangles, mismatched or zero normals.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |p: &[f32; 3]| p.iter().all(|c| c.is_finite() && c.abs() < 1.0e18);
        // Embree drops such vertices' triangles silently, and a huge one trips its assertions.
        if let Some(i) = self.positions.iter().position(|p| !finite(p)) {
            return Err(format!("vertex {i} is not finite: {:?}", self.positions[i]));
        }
        if self.positions.len() >= u32::MAX as usize {
            return Err("too many vertices".into());
        }
        if let Some(normals) = &self.normals {
            if normals.len() != self.positions.len() {
                return Err(format!(
                    "{} normals for {} vertices",
                    normals.len(),
                    self.positions.len()
                ));
            }
            if let Some(i) = normals
                .iter()
                .position(|n| !finite(n) || n.iter().all(|c| *c == 0.0))
            {
                return Err(format!(
                    "normal {i} is zero or not finite: {:?}",
                    normals[i]
                ));
            }
        }
        let n = self.positions.len() as u32;
        for (i, tri) in self.triangles.iter().enumerate() {
            if let Some(bad) = tri.iter().find(|&&index| index >= n) {
                return Err(format!(
                    "triangle {i} uses vertex {bad}, but the mesh has {n} vertices"
                ));
            }
            let [a, b, c] = tri.map(|k| DVec3::from(self.positions[k as usize].map(f64::from)));
            let area2 = (b - a).cross(c - a).length();
            let scale = (b - a).length().max((c - a).length()).max(1e-30);
            if area2.is_nan() || area2 <= 1e-12 * scale * scale {
                return Err(format!(
                    "triangle {i} is degenerate (zero area): {:?} {:?} {:?}",
                    a.to_array(),
                    b.to_array(),
                    c.to_array()
                ));
            }
        }
        Ok(())
    }
}

/// A mesh as the committed scene keeps it: Embree reads the positions and triangles in place.
/// Embree loads the last vertex with a 16-byte read, 4 bytes past its end, so `positions` must
/// have at least one element of spare capacity ([`TriangleMesh::reserve_padding`]); a mesh that
/// lacks it is copied into one that has it.
struct MeshBuffers {
    mesh: Arc<TriangleMesh>,
}

impl MeshBuffers {
    fn vertex(&self, index: u32) -> DVec3 {
        DVec3::from(self.mesh.positions[index as usize].map(f64::from))
    }

    fn triangle(&self, prim: u32) -> [u32; 3] {
        self.mesh.triangles[prim as usize]
    }
}

/// How much time Embree's BVH build spends on the tree's quality (`RTCBuildQuality`): `high`
/// builds slowest and traces fastest (spatial splits), `low` the reverse.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BvhQuality {
    /// Morton-code build: fastest, for scenes traced with few rays.
    Low,
    /// Binned SAH build without spatial splits: less build memory than `high`.
    Medium,
    /// SAH build with spatial splits: fastest tracing (photondiff's default).
    #[default]
    High,
}

/// Collects meshes; [`SceneBuilder::commit`] turns them into an immutable [`Scene`].
pub struct SceneBuilder {
    device: Device,
    meshes: Vec<MeshBuffers>,
    settings: BvhSettings,
}

/// How Embree builds the scene's BVH: the trade between build time, memory and tracing speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BvhSettings {
    /// Build quality (`rtcSetSceneBuildQuality`).
    pub quality: BvhQuality,
    /// `RTC_SCENE_FLAG_COMPACT`: a BVH that takes less memory and traces somewhat slower.
    pub compact: bool,
    /// `RTC_SCENE_FLAG_ROBUST`: traversal without the optimisations that can miss hits on
    /// edges and vertices; somewhat slower.
    pub robust: bool,
}

impl SceneBuilder {
    /// An empty scene on `device`.
    pub fn new(device: &Device) -> Self {
        SceneBuilder {
            device: device.clone(),
            meshes: Vec::new(),
            settings: BvhSettings::default(),
        }
    }

    /// How the BVH is built (default: `high` quality, no flags).
    pub fn settings(mut self, settings: BvhSettings) -> Self {
        self.settings = settings;
        self
    }

    /// Adds a mesh and returns its geometry id (0, 1, 2, ... in the order of the calls). The
    /// committed scene shares the mesh's buffers with the caller rather than copying them
    /// (unless its positions lack the padding Embree reads past the last vertex).
    pub fn add_mesh(&mut self, mesh: impl Into<Arc<TriangleMesh>>) -> Result<u32, EmbreeError> {
        let mut mesh: Arc<TriangleMesh> = mesh.into();
        mesh.validate().map_err(EmbreeError::InvalidMesh)?;
        if mesh.positions.capacity() <= mesh.positions.len() {
            let mut padded = (*mesh).clone();
            padded.reserve_padding();
            mesh = Arc::new(padded);
        }
        self.meshes.push(MeshBuffers { mesh });
        Ok(self.meshes.len() as u32 - 1)
    }

    /// Builds Embree's acceleration structure over the meshes added so far.
    pub fn commit(self) -> Result<Scene, EmbreeError> {
        let device = self.device.handle.clone();
        device.take_error()?;
        // SAFETY: the device is valid for the lifetime of `device`, which the scene keeps.
        let raw = unsafe { ffi::rtcNewScene(device.raw) };
        // From here on the scene owns `raw` and releases it on drop, whatever fails below.
        let scene = Scene {
            raw,
            _device: device.clone(),
            meshes: self.meshes,
            invalid_rays: AtomicU64::new(0),
        };
        if raw.is_null() {
            return Err(device.take_error().err().unwrap_or(EmbreeError::Embree {
                code: 0,
                message: "rtcNewScene failed".into(),
            }));
        }
        let quality = match self.settings.quality {
            BvhQuality::Low => ffi::RTCBuildQuality::RTC_BUILD_QUALITY_LOW,
            BvhQuality::Medium => ffi::RTCBuildQuality::RTC_BUILD_QUALITY_MEDIUM,
            BvhQuality::High => ffi::RTCBuildQuality::RTC_BUILD_QUALITY_HIGH,
        };
        let mut flags = ffi::RTCSceneFlags::RTC_SCENE_FLAG_NONE.0;
        if self.settings.compact {
            flags |= ffi::RTCSceneFlags::RTC_SCENE_FLAG_COMPACT.0;
        }
        if self.settings.robust {
            flags |= ffi::RTCSceneFlags::RTC_SCENE_FLAG_ROBUST.0;
        }
        // SAFETY: `raw` is a valid scene.
        unsafe {
            ffi::rtcSetSceneBuildQuality(raw, quality);
            ffi::rtcSetSceneFlags(raw, ffi::RTCSceneFlags(flags));
        }
        for (id, buffers) in scene.meshes.iter().enumerate() {
            let mesh = &buffers.mesh;
            let vertex_count = mesh.positions.len();
            let triangle_count = mesh.triangles.len();
            // SAFETY: the buffers live in the `Arc`s of `scene.meshes`, which the scene keeps
            // (their heap storage never moves: nothing can mutate a shared `Arc`) until after
            // rtcReleaseScene; `add_mesh` made sure the positions have spare capacity, so the 4
            // bytes Embree reads past the last vertex are allocated; `[f32; 3]` and `[u32; 3]`
            // are 12 bytes with no padding, the strides given; the indices were validated
            // against the vertex count.
            unsafe {
                let geometry = ffi::rtcNewGeometry(
                    device.raw,
                    ffi::RTCGeometryType::RTC_GEOMETRY_TYPE_TRIANGLE,
                );
                if geometry.is_null() {
                    break;
                }
                ffi::rtcSetSharedGeometryBuffer(
                    geometry,
                    ffi::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
                    0,
                    ffi::RTCFormat::RTC_FORMAT_FLOAT3,
                    mesh.positions.as_ptr() as *const std::ffi::c_void,
                    0,
                    12,
                    vertex_count,
                );
                ffi::rtcSetSharedGeometryBuffer(
                    geometry,
                    ffi::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
                    0,
                    ffi::RTCFormat::RTC_FORMAT_UINT3,
                    mesh.triangles.as_ptr() as *const std::ffi::c_void,
                    0,
                    12,
                    triangle_count,
                );
                ffi::rtcCommitGeometry(geometry);
                ffi::rtcAttachGeometryByID(raw, geometry, id as u32);
                ffi::rtcReleaseGeometry(geometry);
            }
        }
        // SAFETY: `raw` is a valid scene whose geometries are all committed.
        unsafe { ffi::rtcCommitScene(raw) };
        device.take_error()?;
        Ok(scene)
    }
}

/// A committed Embree scene: immutable, and safe to query from many threads at once.
pub struct Scene {
    pub(super) raw: ffi::RTCScene,
    _device: Arc<DeviceHandle>,
    meshes: Vec<MeshBuffers>,
    pub(super) invalid_rays: AtomicU64,
}

// SAFETY: a committed Embree scene is immutable and Embree documents rtcIntersect*/rtcOccluded* as
// thread-safe on it; the mesh buffers are never written after commit.
unsafe impl Send for Scene {}
// SAFETY: as above.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: `raw` came from rtcNewScene and is released once, before the buffers it reads
            // (fields drop after this) and before the device (held by `_device`).
            unsafe { ffi::rtcReleaseScene(self.raw) };
        }
    }
}

impl Scene {
    /// Number of meshes.
    pub fn mesh_count(&self) -> usize {
        self.meshes.len()
    }

    /// Number of rays rejected so far because Embree could not take them (answered as misses).
    pub fn invalid_rays(&self) -> u64 {
        self.invalid_rays.load(Ordering::Relaxed)
    }

    pub(super) fn count_invalid(&self) {
        self.invalid_rays.fetch_add(1, Ordering::Relaxed);
    }

    /// Completes a hit from Embree's ids, barycentrics and distance with this layer's mesh data.
    ///
    /// Embree answers in single precision: on a large triangle its barycentrics place the hit
    /// only to within ~1e-7 of the triangle's size, too coarse for differentials and finite
    /// differences. The hit is therefore refined in double precision against the triangle's
    /// plane (Embree's answer is kept where the ray is parallel to the plane).
    pub(super) fn make_hit(
        &self,
        ray: &Ray,
        geom_id: u32,
        prim_id: u32,
        u: f32,
        v: f32,
        t: f32,
    ) -> Hit {
        let mesh = &self.meshes[geom_id as usize];
        let tri = mesh.triangle(prim_id);
        let p0 = mesh.vertex(tri[0]);
        let dp_du = mesh.vertex(tri[1]) - p0;
        let dp_dv = mesh.vertex(tri[2]) - p0;
        let cross = dp_du.cross(dp_dv);
        let geometric_normal = cross.normalize();
        let (mut u, mut v, mut t) = (u as f64, v as f64, t as f64);
        let denom = ray.direction.dot(cross);
        if denom.abs() > 1e-12 * ray.direction.length() * cross.length() {
            let t64 = (p0 - ray.origin).dot(cross) / denom;
            let w = ray.origin + ray.direction * t64 - p0;
            let area = cross.length_squared();
            let u64 = w.cross(dp_dv).dot(cross) / area;
            let v64 = dp_du.cross(w).dot(cross) / area;
            if t64.is_finite() && u64.is_finite() && v64.is_finite() {
                // Stay on the triangle Embree found (rounding can step just outside it).
                u = u64.clamp(0.0, 1.0);
                v = v64.clamp(0.0, 1.0 - u);
                t = t64;
            }
        }
        let (shading_normal, dn_du, dn_dv) = match &mesh.mesh.normals {
            None => (geometric_normal, DVec3::ZERO, DVec3::ZERO),
            Some(normals) => {
                let [n0, n1, n2] = tri.map(|k| DVec3::from(normals[k as usize].map(f64::from)));
                let unnormalised = n0 * (1.0 - u - v) + n1 * u + n2 * v;
                let length = unnormalised.length();
                let n = unnormalised / length;
                // d(N/|N|) = (dN - (dN . n) n) / |N|
                let project = |dn: DVec3| (dn - n * dn.dot(n)) / length;
                let n = if n.dot(geometric_normal) < 0.0 { -n } else { n };
                let sign = if unnormalised.dot(geometric_normal) < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                (n, sign * project(n1 - n0), sign * project(n2 - n0))
            }
        };
        Hit {
            t,
            geom_id,
            prim_id,
            u,
            v,
            position: p0 + dp_du * u + dp_dv * v,
            geometric_normal,
            shading_normal,
            dn_du,
            dn_dv,
            dp_du,
            dp_dv,
        }
    }
}
