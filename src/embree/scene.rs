//! Triangle meshes, the scene builder, and the committed, immutable, shareable scene.

use super::bvh::{BvhQuality, BvhSettings};
use super::device::{Device, DeviceHandle, EmbreeError};
use super::ffi;
use super::mesh::TriangleMesh;
use glam::{DAffine3, DMat3, DVec3};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// A geometry of the committed scene: a mesh placed directly (its own vertices are world
/// space) or an instance of a mesh (one BVH per mesh, shared by all its instances).
///
/// Embree reads the mesh's positions and triangles in place and loads the last vertex with a
/// 16-byte read, 4 bytes past its end, so `positions` must have at least one element of spare
/// capacity ([`TriangleMesh::reserve_padding`]); a mesh that lacks it is copied into one that
/// has it.
pub(super) struct Geometry {
    pub(super) mesh: Arc<TriangleMesh>,
    /// `None` for a mesh placed directly.
    pub(super) instance: Option<Placement>,
}

/// Where an instance puts its mesh: `world = to_world * local`.
pub(super) struct Placement {
    to_world: DAffine3,
    /// `to_world`'s inverse transpose (linear part): what normals transform with.
    normal_matrix: DMat3,
    /// Whether `to_world` mirrors (a negative determinant: an odd number of negative scale
    /// factors). It reverses the triangles' winding, so the world-space vertices are handed
    /// out with their second and third swapped (and Embree's `u`, `v` with them,
    /// [`Geometry::barycentrics`]): the geometric normal `(p1 - p0) x (p2 - p0)` then keeps
    /// the side the mesh file gave it, and glass keeps its inside in.
    mirrored: bool,
}

impl Geometry {
    /// The instance's transform and normal matrix; `None` for a mesh placed directly.
    pub(super) fn placement(&self) -> Option<(&DAffine3, &DMat3)> {
        self.instance
            .as_ref()
            .map(|p| (&p.to_world, &p.normal_matrix))
    }

    /// Triangle `prim`'s vertices in world space, and its vertex normals (world space, not
    /// normalised: an affine map keeps barycentric interpolation, so interpolating these
    /// equals mapping the interpolated local normal).
    pub(super) fn world_triangle(&self, prim: u32) -> ([DVec3; 3], Option<[DVec3; 3]>) {
        self.world_vertices(self.mesh.triangles[prim as usize])
    }

    /// Triangle `prim`'s vertex indices.
    pub(super) fn triangle(&self, prim: u32) -> [u32; 3] {
        self.mesh.triangles[prim as usize]
    }

    /// [`Geometry::world_triangle`] of the triangle with vertex indices `tri`.
    pub(super) fn world_vertices(&self, tri: [u32; 3]) -> ([DVec3; 3], Option<[DVec3; 3]>) {
        // Written out rather than with array maps: `[T; 3]::map` is an out-of-line call here,
        // and these loads are the cache misses a packet's lanes overlap (see `intersect16`).
        let wide = |v: &[f32; 3]| DVec3::new(v[0].into(), v[1].into(), v[2].into());
        let at = |a: &[[f32; 3]]| {
            [
                wide(&a[tri[0] as usize]),
                wide(&a[tri[1] as usize]),
                wide(&a[tri[2] as usize]),
            ]
        };
        let p = at(&self.mesh.positions);
        let n = self.mesh.normals.as_deref().map(at);
        match &self.instance {
            None => (p, n),
            Some(placement) => {
                let order = |[a, b, c]: [DVec3; 3]| {
                    if placement.mirrored {
                        [a, c, b]
                    } else {
                        [a, b, c]
                    }
                };
                (
                    order(p.map(|x| placement.to_world.transform_point3(x))),
                    n.map(|n| order(n.map(|x| placement.normal_matrix * x))),
                )
            }
        }
    }

    /// Asks the CPU to start loading the vertices (and vertex normals) of the triangle with
    /// vertex indices `tri`, so that several lanes' cache misses overlap before
    /// [`Geometry::world_vertices`] reads them.
    #[inline]
    pub(super) fn prefetch_vertices(&self, tri: [u32; 3]) {
        let fetch = |a: &[[f32; 3]]| {
            for &i in &tri {
                if let Some(v) = a.get(i as usize) {
                    prefetch(v);
                }
            }
        };
        fetch(&self.mesh.positions);
        if let Some(n) = self.mesh.normals.as_deref() {
            fetch(n);
        }
    }

    /// Embree's barycentrics `(u, v)` of a hit, in the vertex order of
    /// [`Geometry::world_vertices`] (swapped for a mirroring instance).
    #[inline]
    pub(super) fn barycentrics(&self, u: f32, v: f32) -> (f32, f32) {
        match &self.instance {
            Some(placement) if placement.mirrored => (v, u),
            _ => (u, v),
        }
    }
}

/// A hint to load the cache line holding `value` (nothing on targets without one).
#[inline(always)]
fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint: it never faults, reads nothing into the program and
    // writes nothing; the pointer comes from a live reference anyway.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// Pads `mesh` for Embree (a copy) unless it already is.
fn padded(mesh: Arc<TriangleMesh>) -> Arc<TriangleMesh> {
    if mesh.positions.capacity() > mesh.positions.len() {
        return mesh;
    }
    let mut copy = (*mesh).clone();
    copy.reserve_padding();
    Arc::new(copy)
}

/// Collects meshes; [`SceneBuilder::commit`] turns them into an immutable [`Scene`].
pub struct SceneBuilder {
    device: Device,
    geometries: Vec<Geometry>,
    settings: BvhSettings,
    /// Told the build's progress, from 0 to 1 ([`SceneBuilder::progress`]).
    progress: Option<Box<BuildProgress>>,
}

/// What [`SceneBuilder::progress`] is told: the fraction of the build done, from any of
/// Embree's build threads.
pub type BuildProgress = dyn Fn(f64) + Send + Sync;

impl SceneBuilder {
    /// An empty scene on `device`.
    pub fn new(device: &Device) -> Self {
        SceneBuilder {
            device: device.clone(),
            geometries: Vec::new(),
            settings: BvhSettings::default(),
            progress: None,
        }
    }

    /// How the BVH is built (default: `medium` quality, no flags).
    pub fn settings(mut self, settings: BvhSettings) -> Self {
        self.settings = settings;
        self
    }

    /// Reports the build's progress to `report`: fractions from 0 to 1, from Embree's progress
    /// monitor (called on its build threads, possibly at once), and 1 when the build is done.
    /// A scene with instanced meshes builds one BVH per mesh and one over them: each takes an
    /// equal share of the range.
    pub fn progress(mut self, report: impl Fn(f64) + Send + Sync + 'static) -> Self {
        self.progress = Some(Box::new(report));
        self
    }

    /// Adds a mesh and returns its geometry id (0, 1, 2, ... in the order of the calls). The
    /// committed scene shares the mesh's buffers with the caller rather than copying them
    /// (unless its positions lack the padding Embree reads past the last vertex).
    pub fn add_mesh(&mut self, mesh: impl Into<Arc<TriangleMesh>>) -> Result<u32, EmbreeError> {
        let mesh: Arc<TriangleMesh> = mesh.into();
        mesh.validate().map_err(EmbreeError::InvalidMesh)?;
        self.geometries.push(Geometry {
            mesh: padded(mesh),
            instance: None,
        });
        Ok(self.geometries.len() as u32 - 1)
    }

    /// Adds an instance of `mesh` placed by `to_world` and returns its geometry id (counted with
    /// the meshes). Every instance of the same `Arc` shares one BVH and one copy of the mesh.
    /// A transform that is not finite or is singular is refused.
    pub fn add_instance(
        &mut self,
        mesh: &Arc<TriangleMesh>,
        to_world: DAffine3,
    ) -> Result<u32, EmbreeError> {
        let linear = to_world.matrix3;
        let finite = linear.to_cols_array().iter().all(|c| c.is_finite())
            && to_world.translation.is_finite();
        let scale = linear.x_axis.length() * linear.y_axis.length() * linear.z_axis.length();
        if !finite || scale == 0.0 || linear.determinant().abs() <= 1e-12 * scale {
            return Err(EmbreeError::InvalidMesh(format!(
                "the instance transform is singular or not finite: {to_world:?}"
            )));
        }
        // The same mesh is validated (and padded) once, however many instances it has.
        let mesh = match self
            .geometries
            .iter()
            .find(|g| g.instance.is_some() && Arc::ptr_eq(&g.mesh, mesh))
        {
            Some(g) => g.mesh.clone(),
            None => {
                mesh.validate().map_err(EmbreeError::InvalidMesh)?;
                padded(mesh.clone())
            }
        };
        self.geometries.push(Geometry {
            mesh,
            instance: Some(Placement {
                to_world,
                normal_matrix: linear.inverse().transpose(),
                mirrored: linear.determinant() < 0.0,
            }),
        });
        Ok(self.geometries.len() as u32 - 1)
    }

    /// Builds Embree's acceleration structures: one BVH per instanced mesh, and the scene's
    /// over its meshes and instances.
    pub fn commit(self) -> Result<Scene, EmbreeError> {
        let device = self.device.handle.clone();
        device.take_error()?;
        let settings = self.settings;
        // One build per instanced mesh, and the scene's own.
        let mut instanced: Vec<*const TriangleMesh> = self
            .geometries
            .iter()
            .filter(|g| g.instance.is_some())
            .map(|g| Arc::as_ptr(&g.mesh))
            .collect();
        instanced.sort_unstable();
        instanced.dedup();
        let builds = instanced.len() + 1;
        let progress = self.progress;
        let triangles = unique_triangles(&self.geometries);
        let commit = |raw: ffi::RTCScene, done: usize| {
            commit_reporting(raw, progress.as_deref(), done, builds);
            device
                .take_error()
                .map_err(|e| out_of_memory(e, triangles, settings))
        };
        // From here on the scene owns every raw scene made and releases them on drop, whatever
        // fails below.
        let mut scene = Scene {
            raw: std::ptr::null_mut(),
            _device: device.clone(),
            geometries: self.geometries,
            prototypes: Vec::new(),
            invalid_rays: AtomicU64::new(0),
            // Set once the instances are known, below.
            coherent_packets: false,
        };
        scene.raw = new_scene(&device, settings)?;
        // The BVH of each instanced mesh, made once: (the mesh, its committed scene).
        let mut made: Vec<(*const TriangleMesh, ffi::RTCScene)> = Vec::new();
        for (id, g) in scene.geometries.iter().enumerate() {
            let Some(placement) = &g.instance else {
                attach_triangles(&device, scene.raw, &g.mesh, id as u32)?;
                continue;
            };
            let key = Arc::as_ptr(&g.mesh);
            let prototype = match made.iter().find(|(k, _)| *k == key) {
                Some((_, p)) => *p,
                None => {
                    let p = new_scene(&device, settings)?;
                    scene.prototypes.push(p);
                    attach_triangles(&device, p, &g.mesh, 0)?;
                    commit(p, made.len())?;
                    made.push((key, p));
                    p
                }
            };
            let m = placement.to_world;
            // Column-major 3x4: the three columns of the linear part, then the translation.
            let columns: [f32; 12] = [
                m.matrix3.x_axis,
                m.matrix3.y_axis,
                m.matrix3.z_axis,
                m.translation,
            ]
            .map(|c| [c.x as f32, c.y as f32, c.z as f32])
            .concat()
            .try_into()
            .expect("12 floats");
            // SAFETY: `prototype` is a committed scene owned by `scene.prototypes` until after the
            // top-level scene is released; `columns` is read (copied) during the call.
            unsafe {
                let geometry = ffi::rtcNewGeometry(
                    device.raw,
                    ffi::RTCGeometryType::RTC_GEOMETRY_TYPE_INSTANCE,
                );
                if geometry.is_null() {
                    return Err(device_error(&device, "rtcNewGeometry (instance) failed"));
                }
                ffi::rtcSetGeometryInstancedScene(geometry, prototype);
                ffi::rtcSetGeometryTransform(
                    geometry,
                    0,
                    ffi::RTCFormat::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                    columns.as_ptr() as *const std::ffi::c_void,
                );
                ffi::rtcCommitGeometry(geometry);
                ffi::rtcAttachGeometryByID(scene.raw, geometry, id as u32);
                ffi::rtcReleaseGeometry(geometry);
            }
        }
        commit(scene.raw, made.len())?;
        // Debian's Embree 3.13.5 was seen to loop forever in coherent 16-wide occlusion queries
        // through an instance (a shadow packet of two active lanes) and in every compact and
        // robust scene (the canonical scene's first shadow packets); its incoherent path does
        // not.
        scene.coherent_packets = made.is_empty() && !(settings.compact && settings.robust);
        Ok(scene)
    }
}

/// The triangles of the meshes BVHs are built over: each instanced mesh once.
fn unique_triangles(geometries: &[Geometry]) -> u64 {
    let mut meshes: Vec<&Arc<TriangleMesh>> = geometries.iter().map(|g| &g.mesh).collect();
    meshes.sort_unstable_by_key(|m| Arc::as_ptr(m));
    meshes.dedup_by_key(|m| Arc::as_ptr(m));
    meshes.iter().map(|m| m.triangles.len() as u64).sum()
}

/// Embree's out-of-memory error (`RTC_ERROR_OUT_OF_MEMORY`) during a build, said as what the
/// user can act on: the BVH of how many triangles, within what limit, and the setting that
/// needs less (a compact BVH peaks at about half an ordinary one's memory). Other errors pass.
fn out_of_memory(error: EmbreeError, triangles: u64, settings: BvhSettings) -> EmbreeError {
    const RTC_ERROR_OUT_OF_MEMORY: u32 = 4;
    if !matches!(
        error,
        EmbreeError::Embree {
            code: RTC_ERROR_OUT_OF_MEMORY,
            ..
        }
    ) {
        return error;
    }
    let limit = crate::util::memory::total_bytes().map_or(String::new(), |total| {
        format!(
            " within the {} this process may use",
            crate::util::memory::gigabytes(total)
        )
    });
    let advice = if settings.compact {
        "the BVH is compact already (about 60 bytes a triangle at the build's peak): it needs \
         fewer triangles or more memory"
    } else {
        "--bvh-compact builds one in about half the memory"
    };
    EmbreeError::BvhOutOfMemory(format!(
        "building the BVH of {triangles} triangles ran out of memory{limit}; {advice}"
    ))
}

/// What Embree's progress monitor is handed during one build: the report, and the build's
/// place among the `builds` a commit makes.
struct Monitor<'a> {
    report: &'a BuildProgress,
    done: usize,
    builds: usize,
}

/// Called by Embree on its build threads with the fraction `n` of one build done; answers
/// true (go on). It must not unwind into C: a panicking report is caught and ignored.
extern "C" fn progress_monitor(user_ptr: *mut std::ffi::c_void, n: f64) -> bool {
    // SAFETY: `user_ptr` is the `Monitor` on `commit_reporting`'s stack, which unsets the
    // monitor before that returns (Embree calls it only during the commit).
    let monitor = unsafe { &*(user_ptr as *const Monitor) };
    let fraction = (monitor.done as f64 + n.clamp(0.0, 1.0)) / monitor.builds as f64;
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (monitor.report)(fraction)));
    true
}

/// Commits `raw` (build number `done` of `builds`), reporting its progress to `report`.
fn commit_reporting(
    raw: ffi::RTCScene,
    report: Option<&BuildProgress>,
    done: usize,
    builds: usize,
) {
    let Some(report) = report else {
        // SAFETY: `raw` is a valid scene whose geometries are all committed.
        unsafe { ffi::rtcCommitScene(raw) };
        return;
    };
    let monitor = Monitor {
        report,
        done,
        builds,
    };
    // SAFETY: `raw` is a valid scene whose geometries are all committed; the monitor's user
    // pointer is `monitor`, alive until after the monitor is unset below; the callback never
    // unwinds.
    unsafe {
        ffi::rtcSetSceneProgressMonitorFunction(
            raw,
            Some(progress_monitor),
            &monitor as *const Monitor as *mut std::ffi::c_void,
        );
        ffi::rtcCommitScene(raw);
        ffi::rtcSetSceneProgressMonitorFunction(raw, None, std::ptr::null_mut());
    }
    report((done + 1) as f64 / builds as f64);
}

/// The error Embree reported, or `what` when it reported none.
fn device_error(device: &DeviceHandle, what: &str) -> EmbreeError {
    device.take_error().err().unwrap_or(EmbreeError::Embree {
        code: 0,
        message: what.into(),
    })
}

/// A new, empty scene built with `settings`; the caller releases it.
fn new_scene(device: &DeviceHandle, settings: BvhSettings) -> Result<ffi::RTCScene, EmbreeError> {
    // SAFETY: the device is valid while `device` is.
    let raw = unsafe { ffi::rtcNewScene(device.raw) };
    if raw.is_null() {
        return Err(device_error(device, "rtcNewScene failed"));
    }
    let quality = match settings.quality {
        BvhQuality::Low => ffi::RTCBuildQuality::RTC_BUILD_QUALITY_LOW,
        BvhQuality::Medium => ffi::RTCBuildQuality::RTC_BUILD_QUALITY_MEDIUM,
        BvhQuality::High => ffi::RTCBuildQuality::RTC_BUILD_QUALITY_HIGH,
    };
    let mut flags = ffi::RTCSceneFlags::RTC_SCENE_FLAG_NONE.0;
    if settings.compact {
        flags |= ffi::RTCSceneFlags::RTC_SCENE_FLAG_COMPACT.0;
    }
    if settings.robust {
        flags |= ffi::RTCSceneFlags::RTC_SCENE_FLAG_ROBUST.0;
    }
    // SAFETY: `raw` is a valid scene.
    unsafe {
        ffi::rtcSetSceneBuildQuality(raw, quality);
        ffi::rtcSetSceneFlags(raw, ffi::RTCSceneFlags(flags));
    }
    Ok(raw)
}

/// Attaches `mesh` to `scene` as triangle geometry `id`, reading its buffers in place.
fn attach_triangles(
    device: &DeviceHandle,
    scene: ffi::RTCScene,
    mesh: &Arc<TriangleMesh>,
    id: u32,
) -> Result<(), EmbreeError> {
    // SAFETY: the caller keeps `mesh` (an `Arc` held by the committed scene's geometries) alive
    // until after `scene` is released, and nothing can mutate a shared `Arc`, so the buffers
    // never move; `padded` made sure the positions have spare capacity, so the 4 bytes Embree
    // reads past the last vertex are allocated; `[f32; 3]` and `[u32; 3]` are 12 bytes with no
    // padding, the strides given; the indices were validated against the vertex count.
    unsafe {
        let geometry =
            ffi::rtcNewGeometry(device.raw, ffi::RTCGeometryType::RTC_GEOMETRY_TYPE_TRIANGLE);
        if geometry.is_null() {
            return Err(device_error(device, "rtcNewGeometry (triangles) failed"));
        }
        ffi::rtcSetSharedGeometryBuffer(
            geometry,
            ffi::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
            0,
            ffi::RTCFormat::RTC_FORMAT_FLOAT3,
            mesh.positions.as_ptr() as *const std::ffi::c_void,
            0,
            12,
            mesh.positions.len(),
        );
        ffi::rtcSetSharedGeometryBuffer(
            geometry,
            ffi::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
            0,
            ffi::RTCFormat::RTC_FORMAT_UINT3,
            mesh.triangles.as_ptr() as *const std::ffi::c_void,
            0,
            12,
            mesh.triangles.len(),
        );
        ffi::rtcCommitGeometry(geometry);
        ffi::rtcAttachGeometryByID(scene, geometry, id);
        ffi::rtcReleaseGeometry(geometry);
    }
    device.take_error()
}

/// A committed Embree scene: immutable, and safe to query from many threads at once.
pub struct Scene {
    pub(super) raw: ffi::RTCScene,
    _device: Arc<DeviceHandle>,
    /// Geometry `i` of the top-level scene.
    pub(super) geometries: Vec<Geometry>,
    /// The scenes of the instanced meshes (one per mesh), released after `raw`.
    prototypes: Vec<ffi::RTCScene>,
    pub(super) invalid_rays: AtomicU64,
    /// Whether packets said to be coherent may be traced with Embree's coherent flag (not
    /// through instances, nor in a compact and robust BVH: [`Scene::coherent`]).
    coherent_packets: bool,
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
        for &p in &self.prototypes {
            // SAFETY: each came from rtcNewScene and is released once, after the top-level scene
            // whose instances referenced it, before its mesh buffers and the device.
            unsafe { ffi::rtcReleaseScene(p) };
        }
    }
}

impl Scene {
    /// Number of geometries: meshes placed directly and instances.
    pub fn mesh_count(&self) -> usize {
        self.geometries.len()
    }

    /// Whether a packet said to be `coherent` goes to Embree with its coherent flag: not where
    /// Debian's Embree 3.13.5 can loop forever on it (through instances, and in a compact and
    /// robust BVH), where the incoherent path gives the same answers.
    pub(super) fn coherent(&self, coherent: bool) -> bool {
        coherent && self.coherent_packets
    }

    /// Number of rays rejected so far because Embree could not take them (answered as misses).
    pub fn invalid_rays(&self) -> u64 {
        self.invalid_rays.load(Ordering::Relaxed)
    }

    pub(super) fn count_invalid(&self) {
        self.invalid_rays.fetch_add(1, Ordering::Relaxed);
    }
}
