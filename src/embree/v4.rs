//! The Embree 4 backend: the traversal calls take optional `RTCIntersectArguments` /
//! `RTCOccludedArguments` (after the rays) instead of Embree 3's `RTCIntersectContext`.
//!
//! The other Embree 4 changes that matter here, from its release notes:
//! - ray masks are enabled by default: a ray whose `mask` has no bit in common with the
//!   geometry's (default all ones) is ignored, so `query.rs` sets `mask = 0xFFFF_FFFF` on every
//!   ray and packet lane (Embree 3 builds ignore the field unless built with `EMBREE_RAY_MASK`);
//! - filter functions passed in the arguments run only in scenes created with
//!   `RTC_SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS`: photondiff uses no filter functions, so the
//!   scene keeps its default flags and the arguments carry none;
//! - the stream calls (`rtcIntersect1M`, `rtcIntersectNp`, ...) and `rtcGetGeometryUserData` are
//!   gone: photondiff uses neither (packets of 16 instead of streams, ids instead of user data);
//! - the scene and geometry calls used by `scene.rs` and `device.rs` keep their signatures.

use super::ffi;
use super::PACKET_WIDTH;

fn query_flags(coherent: bool) -> ffi::RTCRayQueryFlags {
    if coherent {
        ffi::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_COHERENT
    } else {
        ffi::RTCRayQueryFlags::RTC_RAY_QUERY_FLAG_INCOHERENT
    }
}

/// What `rtcIntersect*` takes besides the scene and the rays.
pub(super) struct IntersectArgs(ffi::RTCIntersectArguments);

/// What `rtcOccluded*` takes besides the scene and the rays.
pub(super) struct OccludedArgs(ffi::RTCOccludedArguments);

impl IntersectArgs {
    /// Rust version of the header's `RTC_FORCEINLINE rtcInitIntersectArguments` (no binding),
    /// with the coherence hint. The rest is zero, which is also the header's value of
    /// `minWidthDistanceFactor` in builds that have that field.
    // The update fills `minWidthDistanceFactor` where the headers have it (RTC_MIN_WIDTH).
    #[allow(clippy::needless_update)]
    pub(super) fn new(coherent: bool) -> Self {
        IntersectArgs(ffi::RTCIntersectArguments {
            flags: query_flags(coherent),
            feature_mask: ffi::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
            context: std::ptr::null_mut(),
            filter: None,
            intersect: None,
            ..Default::default()
        })
    }
}

impl OccludedArgs {
    /// Rust version of the header's `RTC_FORCEINLINE rtcInitOccludedArguments`, as above.
    #[allow(clippy::needless_update)]
    pub(super) fn new(coherent: bool) -> Self {
        OccludedArgs(ffi::RTCOccludedArguments {
            flags: query_flags(coherent),
            feature_mask: ffi::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
            context: std::ptr::null_mut(),
            filter: None,
            occluded: None,
            ..Default::default()
        })
    }
}

/// `rtcIntersect1`.
///
/// # Safety
/// `scene` is a committed scene and the ray is valid (finite, `0 <= tnear <= tfar`).
pub(super) unsafe fn intersect1(
    scene: ffi::RTCScene,
    rayhit: &mut ffi::RTCRayHit,
    args: &mut IntersectArgs,
) {
    // SAFETY: guaranteed by the caller; the references are valid for the call, and a null
    // context in the arguments makes Embree use its own.
    unsafe { ffi::rtcIntersect1(scene, rayhit, &mut args.0) }
}

/// `rtcOccluded1`.
///
/// # Safety
/// As for [`intersect1`].
pub(super) unsafe fn occluded1(
    scene: ffi::RTCScene,
    ray: &mut ffi::RTCRay,
    args: &mut OccludedArgs,
) {
    // SAFETY: as in `intersect1`.
    unsafe { ffi::rtcOccluded1(scene, ray, &mut args.0) }
}

/// `rtcIntersect16`.
///
/// # Safety
/// `scene` is committed; `valid` and `rayhit` are 64-byte aligned; active lanes hold valid rays.
pub(super) unsafe fn intersect16(
    valid: &[i32; PACKET_WIDTH],
    scene: ffi::RTCScene,
    rayhit: &mut ffi::RTCRayHit16,
    args: &mut IntersectArgs,
) {
    // SAFETY: as in `intersect1`.
    unsafe { ffi::rtcIntersect16(valid.as_ptr(), scene, rayhit, &mut args.0) }
}

/// `rtcOccluded16`.
///
/// # Safety
/// As for [`intersect16`].
pub(super) unsafe fn occluded16(
    valid: &[i32; PACKET_WIDTH],
    scene: ffi::RTCScene,
    ray: &mut ffi::RTCRay16,
    args: &mut OccludedArgs,
) {
    // SAFETY: as in `intersect1`.
    unsafe { ffi::rtcOccluded16(valid.as_ptr(), scene, ray, &mut args.0) }
}
