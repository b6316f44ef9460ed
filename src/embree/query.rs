//! Ray queries: single rays and 16-wide packets. Every traversal call goes through `api`, the
//! backend module (`v3.rs` or `v4.rs`) whose signatures match the installed Embree.

use super::api::{self, IntersectArgs, OccludedArgs};
use super::ffi;
use super::hit::{complete_hit, top_level, Hit};
use super::ray::Ray;
use super::scene::Scene;
use super::PACKET_WIDTH;
use glam::DVec3;

/// A 64-byte aligned ray-hit packet: Embree segfaults on a misaligned one.
#[repr(C, align(64))]
#[derive(Default)]
struct RayHit16(ffi::RTCRayHit16);

/// A 64-byte aligned occlusion packet.
#[repr(C, align(64))]
#[derive(Default)]
struct Ray16(ffi::RTCRay16);

/// A 64-byte aligned `valid` mask for 16-wide calls (-1 = active lane, 0 = inactive).
#[repr(C, align(64))]
#[derive(Default)]
struct Valid16([i32; PACKET_WIDTH]);

impl Valid16 {
    /// Whether every lane is active.
    fn is_full(&self) -> bool {
        self.0.iter().all(|&v| v != 0)
    }
}

/// One lane's answer in a traced packet, with its triangle's world-space vertices (and vertex
/// normals, where the mesh has them).
struct LaneHit {
    /// Top-level geometry id (the instance's, for an instanced mesh).
    id: u32,
    prim: u32,
    u: f32,
    v: f32,
    tfar: f32,
    vertices: ([DVec3; 3], Option<[DVec3; 3]>),
}

/// Writes a single ray's answer into lane `lane` of a packet.
fn store_lane(packet: &mut ffi::RTCRayHit16, lane: usize, rayhit: &ffi::RTCRayHit) {
    let (p, h) = (&mut packet.hit, &rayhit.hit);
    packet.ray.tfar[lane] = rayhit.ray.tfar;
    p.geomID[lane] = h.geomID;
    p.primID[lane] = h.primID;
    p.u[lane] = h.u;
    p.v[lane] = h.v;
    for (level, &id) in p.instID.iter_mut().zip(&h.instID) {
        level[lane] = id;
    }
}

fn single_ray(ray: &Ray) -> ffi::RTCRay {
    ffi::RTCRay {
        org_x: ray.origin.x as f32,
        org_y: ray.origin.y as f32,
        org_z: ray.origin.z as f32,
        tnear: ray.tnear as f32,
        dir_x: ray.direction.x as f32,
        dir_y: ray.direction.y as f32,
        dir_z: ray.direction.z as f32,
        time: 0.0,
        tfar: ray.tfar_f32(),
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

fn empty_hit() -> ffi::RTCHit {
    // As the headers' `rtcInitRayHit`: no geometry and no instance.
    let mut hit = ffi::RTCHit {
        geomID: ffi::INVALID_GEOMETRY_ID,
        primID: ffi::INVALID_GEOMETRY_ID,
        ..Default::default()
    };
    hit.instID.fill(ffi::INVALID_GEOMETRY_ID);
    hit
}

/// Writes `ray` into lane `lane` of a packet's ray part.
fn set_lane(packet: &mut ffi::RTCRay16, lane: usize, ray: &Ray) {
    packet.org_x[lane] = ray.origin.x as f32;
    packet.org_y[lane] = ray.origin.y as f32;
    packet.org_z[lane] = ray.origin.z as f32;
    packet.tnear[lane] = ray.tnear as f32;
    packet.dir_x[lane] = ray.direction.x as f32;
    packet.dir_y[lane] = ray.direction.y as f32;
    packet.dir_z[lane] = ray.direction.z as f32;
    packet.time[lane] = 0.0;
    packet.tfar[lane] = ray.tfar_f32();
    packet.mask[lane] = u32::MAX;
    packet.id[lane] = lane as u32;
    packet.flags[lane] = 0;
}

impl Scene {
    /// The closest hit along `ray`, or `None` for a miss or an invalid ray.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_valid() {
            self.count_invalid();
            return None;
        }
        let mut args = IntersectArgs::new(false);
        let mut rayhit = ffi::RTCRayHit {
            ray: single_ray(ray),
            hit: empty_hit(),
        };
        // SAFETY: the scene is committed, the ray was validated, and both structs are properly
        // aligned locals that outlive the call.
        unsafe { api::intersect1(self.raw, &mut rayhit, &mut args) };
        let hit = &rayhit.hit;
        (hit.geomID != ffi::INVALID_GEOMETRY_ID).then(|| {
            self.make_hit(
                ray,
                hit.geomID,
                hit.instID[0],
                hit.primID,
                hit.u,
                hit.v,
                rayhit.ray.tfar,
            )
        })
    }

    /// Whether anything blocks `ray` within `[tnear, tfar]`. An invalid ray counts as a miss
    /// (unblocked) and is counted in [`Scene::invalid_rays`].
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_valid() {
            self.count_invalid();
            return false;
        }
        let mut args = OccludedArgs::new(false);
        let mut raw = single_ray(ray);
        // SAFETY: as in `intersect`.
        unsafe { api::occluded1(self.raw, &mut raw, &mut args) };
        // Embree sets tfar to -inf when the ray is occluded.
        raw.tfar < 0.0
    }

    /// Closest hits for up to 16 rays traced as one packet. `coherent` tells Embree the rays are
    /// coherent (camera rays of neighbouring pixels, shadow rays to one light).
    /// `hits[i]` answers `rays[i]`; invalid rays are answered `None` and counted.
    pub fn intersect16(&self, rays: &[Ray], coherent: bool, hits: &mut [Option<Hit>]) {
        assert!(rays.len() <= PACKET_WIDTH && hits.len() >= rays.len());
        self.intersect16_each(rays, coherent, |l, hit| hits[l] = hit.copied());
    }

    /// [`Scene::intersect16`] with each answer handed to `answer` in lane order (`None` for a
    /// miss or an invalid ray) instead of stored: a hit is some 240 bytes, and one built on the
    /// stack and copied into an array is read back whole before its stores have landed.
    pub fn intersect16_each(
        &self,
        rays: &[Ray],
        coherent: bool,
        mut answer: impl FnMut(usize, Option<&Hit>),
    ) {
        assert!(rays.len() <= PACKET_WIDTH);
        self.for_each_hit16(rays, coherent, |l, x| match x {
            Some(x) => answer(
                l,
                Some(&complete_hit(
                    &rays[l], x.id, x.prim, x.u, x.v, x.tfar, x.vertices,
                )),
            ),
            None => answer(l, None),
        });
    }

    /// The distance to the closest hit and its unit geometric normal (world space,
    /// `(p1 - p0) x (p2 - p0)` normalised, as [`Hit::geometric_normal`]) for up to 16 rays
    /// traced as one packet: `out[i]` answers `rays[i]`, `None` for a miss or an invalid ray
    /// (counted). Cheaper than [`Scene::intersect16`] (no position, shading normal or
    /// derivatives): for probes that need only how far a ray got and what it met.
    pub fn hit_normals16(&self, rays: &[Ray], coherent: bool, out: &mut [Option<(f64, DVec3)>]) {
        assert!(rays.len() <= PACKET_WIDTH && out.len() >= rays.len());
        self.for_each_hit16(rays, coherent, |l, x| {
            out[l] = x.map(|x| {
                let [p0, p1, p2] = x.vertices.0;
                (f64::from(x.tfar), (p1 - p0).cross(p2 - p0).normalize())
            });
        });
    }

    /// Traces up to 16 rays as one packet and calls `visit` with each lane in order and its
    /// answer (`None` for a miss or an invalid ray). The hit triangles' indices are read for
    /// every lane, then their vertices are prefetched for every lane, before any is used: on a
    /// large mesh each read is a cache miss, and one lane at a time they would wait in turn;
    /// so the lanes' misses overlap.
    /// (Prefetched rather than copied out: a packet-sized array of vertices would be zeroed
    /// and copied twice on every call.)
    fn for_each_hit16(
        &self,
        rays: &[Ray],
        coherent: bool,
        mut visit: impl FnMut(usize, Option<LaneHit>),
    ) {
        let (mut packet, mut valid) = (RayHit16::default(), Valid16::default());
        self.trace16(rays, coherent, &mut packet, &mut valid);
        let (r, h) = (&packet.0.ray, &packet.0.hit);
        let hit_lanes = || {
            (0..rays.len()).filter(|&l| valid.0[l] != 0 && h.geomID[l] != ffi::INVALID_GEOMETRY_ID)
        };
        let mut ids = [0u32; PACKET_WIDTH];
        let mut triangles = [[0u32; 3]; PACKET_WIDTH];
        for l in hit_lanes() {
            ids[l] = top_level(h.geomID[l], h.instID[0][l]);
            triangles[l] = self.geometries[ids[l] as usize].triangle(h.primID[l]);
        }
        for l in hit_lanes() {
            self.geometries[ids[l] as usize].prefetch_vertices(triangles[l]);
        }
        for l in 0..rays.len() {
            if valid.0[l] == 0 || h.geomID[l] == ffi::INVALID_GEOMETRY_ID {
                visit(l, None);
                continue;
            }
            let geometry = &self.geometries[ids[l] as usize];
            let (u, v) = geometry.barycentrics(h.u[l], h.v[l]);
            let answer = LaneHit {
                id: ids[l],
                prim: h.primID[l],
                u,
                v,
                tfar: r.tfar[l],
                vertices: geometry.world_vertices(triangles[l]),
            };
            visit(l, Some(answer));
        }
    }

    /// Traces up to 16 rays as one packet into `packet` (fresh), marking in `valid` (fresh)
    /// the lanes that held a valid ray (the others are counted as invalid and left as misses).
    /// Out-parameters, not a returned pair: the packet is over a kilobyte, and a returned one
    /// may be copied on the hot path of photon tracing.
    fn trace16(&self, rays: &[Ray], coherent: bool, packet: &mut RayHit16, valid: &mut Valid16) {
        // As in `occluded16`: not where Embree can loop forever on a coherent packet.
        let coherent = self.coherent(coherent);
        for (lane, ray) in rays.iter().enumerate() {
            if ray.is_valid() {
                set_lane(&mut packet.0.ray, lane, ray);
                valid.0[lane] = -1;
            } else {
                self.count_invalid();
            }
            packet.0.hit.geomID[lane] = ffi::INVALID_GEOMETRY_ID;
            for level in &mut packet.0.hit.instID {
                level[lane] = ffi::INVALID_GEOMETRY_ID;
            }
        }
        let mut args = IntersectArgs::new(coherent);
        if valid.is_full() {
            // SAFETY: packet and mask are 64-byte aligned; every lane holds a validated ray.
            unsafe { api::intersect16(&valid.0, self.raw, &mut packet.0, &mut args) };
        } else {
            // A packet with inactive lanes costs Embree 3.13.5 ~1.5 us per inactive lane (a
            // 16-wide call with one active lane takes as long as ~300 single rays; measured on
            // the photon tracer's packets, which end part-full when paths run out), so its
            // lanes are traced one by one, each answer written back into the packet.
            for lane in (0..rays.len()).filter(|&l| valid.0[l] != 0) {
                let mut rayhit = ffi::RTCRayHit {
                    ray: single_ray(&rays[lane]),
                    hit: empty_hit(),
                };
                // SAFETY: the ray was validated; the struct is an aligned local.
                unsafe { api::intersect1(self.raw, &mut rayhit, &mut args) };
                store_lane(&mut packet.0, lane, &rayhit);
            }
        }
    }

    /// Occlusion for up to 16 rays traced as one packet; `blocked[i]` answers `rays[i]`.
    /// Invalid rays are answered `false` (a miss) and counted.
    pub fn occluded16(&self, rays: &[Ray], coherent: bool, blocked: &mut [bool]) {
        assert!(rays.len() <= PACKET_WIDTH && blocked.len() >= rays.len());
        // Debian's Embree 3.13.5 can loop forever in a coherent 16-wide occlusion query through
        // an instance (seen on a shadow packet of two active lanes) or in a compact and robust
        // BVH; the incoherent path does not, so such scenes trace their packets as incoherent.
        let coherent = self.coherent(coherent);
        let mut packet = Ray16::default();
        let mut valid = Valid16::default();
        for (lane, ray) in rays.iter().enumerate() {
            if ray.is_valid() {
                set_lane(&mut packet.0, lane, ray);
                valid.0[lane] = -1;
            } else {
                self.count_invalid();
            }
        }
        let mut args = OccludedArgs::new(coherent);
        if valid.is_full() {
            // SAFETY: packet and mask are 64-byte aligned; every lane holds a validated ray.
            unsafe { api::occluded16(&valid.0, self.raw, &mut packet.0, &mut args) };
        } else {
            // Lanes one by one, as in `intersect16`.
            for lane in (0..rays.len()).filter(|&l| valid.0[l] != 0) {
                let mut raw = single_ray(&rays[lane]);
                // SAFETY: the ray was validated; the struct is an aligned local.
                unsafe { api::occluded1(self.raw, &mut raw, &mut args) };
                packet.0.tfar[lane] = raw.tfar;
            }
        }
        for (lane, b) in blocked.iter_mut().enumerate().take(rays.len()) {
            *b = valid.0[lane] != 0 && packet.0.tfar[lane] < 0.0;
        }
    }

    /// Embree's raw single-ray throughput on `rays`, for benchmarks: `rtcIntersect1` with no
    /// validation and no hit post-processing. Returns the number of hits.
    pub fn raw_intersect1(&self, rays: &RawRays) -> usize {
        let mut args = IntersectArgs::new(false);
        let mut hits = 0;
        for ray in &rays.single {
            let mut rayhit = ffi::RTCRayHit {
                ray: *ray,
                hit: empty_hit(),
            };
            // SAFETY: `RawRays` holds only validated rays; the scene is committed.
            unsafe { api::intersect1(self.raw, &mut rayhit, &mut args) };
            hits += usize::from(rayhit.hit.geomID != ffi::INVALID_GEOMETRY_ID);
        }
        hits
    }

    /// Embree's raw 16-wide throughput on `rays` (consecutive groups of 16 as packets).
    pub fn raw_intersect16(&self, rays: &RawRays, coherent: bool) -> usize {
        let mut args = IntersectArgs::new(self.coherent(coherent));
        let mut packet = RayHit16::default();
        let mut hits = 0;
        for (chunk, valid) in rays.packets.iter().zip(&rays.valid) {
            packet.0.ray = chunk.0;
            packet.0.hit.geomID = [ffi::INVALID_GEOMETRY_ID; PACKET_WIDTH];
            // SAFETY: aligned packet and mask; active lanes hold validated rays.
            unsafe { api::intersect16(&valid.0, self.raw, &mut packet.0, &mut args) };
            hits += packet
                .0
                .hit
                .geomID
                .iter()
                .filter(|&&g| g != ffi::INVALID_GEOMETRY_ID)
                .count();
        }
        hits
    }

    /// Embree's raw single-ray occlusion throughput on `rays`. Returns the number blocked.
    pub fn raw_occluded1(&self, rays: &RawRays) -> usize {
        let mut args = OccludedArgs::new(false);
        let mut blocked = 0;
        for ray in &rays.single {
            let mut raw = *ray;
            // SAFETY: as in `raw_intersect1`.
            unsafe { api::occluded1(self.raw, &mut raw, &mut args) };
            blocked += usize::from(raw.tfar < 0.0);
        }
        blocked
    }

    /// Embree's raw 16-wide occlusion throughput on `rays`. Returns the number blocked.
    pub fn raw_occluded16(&self, rays: &RawRays, coherent: bool) -> usize {
        let mut args = OccludedArgs::new(self.coherent(coherent));
        let mut packet = Ray16::default();
        let mut blocked = 0;
        for (chunk, valid) in rays.packets.iter().zip(&rays.valid) {
            packet.0 = chunk.0;
            // SAFETY: aligned packet and mask; active lanes hold validated rays.
            unsafe { api::occluded16(&valid.0, self.raw, &mut packet.0, &mut args) };
            blocked += (0..PACKET_WIDTH)
                .filter(|&lane| valid.0[lane] != 0 && packet.0.tfar[lane] < 0.0)
                .count();
        }
        blocked
    }
}

/// Rays converted once into Embree's layouts, to measure Embree's raw throughput in benchmarks.
/// Invalid rays are dropped.
pub struct RawRays {
    single: Vec<ffi::RTCRay>,
    packets: Vec<Ray16>,
    valid: Vec<Valid16>,
}

impl RawRays {
    /// Converts the valid ones of `rays`.
    pub fn new(rays: &[Ray]) -> Self {
        let rays: Vec<&Ray> = rays.iter().filter(|r| r.is_valid()).collect();
        let single = rays.iter().map(|r| single_ray(r)).collect();
        let mut packets = Vec::new();
        let mut valid = Vec::new();
        for chunk in rays.chunks(PACKET_WIDTH) {
            let mut packet = Ray16::default();
            let mut mask = Valid16::default();
            for (lane, ray) in chunk.iter().enumerate() {
                set_lane(&mut packet.0, lane, ray);
                mask.0[lane] = -1;
            }
            packets.push(packet);
            valid.push(mask);
        }
        RawRays {
            single,
            packets,
            valid,
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.single.len()
    }

    /// Whether there are no rays.
    pub fn is_empty(&self) -> bool {
        self.single.is_empty()
    }
}
