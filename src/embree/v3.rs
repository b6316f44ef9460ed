//! The Embree 3 backend: the traversal calls take an `RTCIntersectContext`.

use super::ffi;
use super::PACKET_WIDTH;

/// Rust version of the header's `RTC_FORCEINLINE rtcInitIntersectContext`, which has no binding.
fn intersect_context(coherent: bool) -> ffi::RTCIntersectContext {
    let mut context = ffi::RTCIntersectContext {
        flags: if coherent {
            ffi::RTCIntersectContextFlags::RTC_INTERSECT_CONTEXT_FLAG_COHERENT
        } else {
            ffi::RTCIntersectContextFlags::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
        },
        filter: None,
        ..Default::default()
    };
    context.instID.fill(ffi::INVALID_GEOMETRY_ID);
    context
}

/// What `rtcIntersect*` takes besides the scene and the rays.
pub(super) struct IntersectArgs(ffi::RTCIntersectContext);

/// What `rtcOccluded*` takes besides the scene and the rays.
pub(super) struct OccludedArgs(ffi::RTCIntersectContext);

impl IntersectArgs {
    pub(super) fn new(coherent: bool) -> Self {
        IntersectArgs(intersect_context(coherent))
    }
}

impl OccludedArgs {
    pub(super) fn new(coherent: bool) -> Self {
        OccludedArgs(intersect_context(coherent))
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
    // SAFETY: guaranteed by the caller; the references are valid for the call.
    unsafe { ffi::rtcIntersect1(scene, &mut args.0, rayhit) }
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
    // SAFETY: guaranteed by the caller; the references are valid for the call.
    unsafe { ffi::rtcOccluded1(scene, &mut args.0, ray) }
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
    // SAFETY: guaranteed by the caller; the references are valid for the call.
    unsafe { ffi::rtcIntersect16(valid.as_ptr(), scene, &mut args.0, rayhit) }
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
    // SAFETY: guaranteed by the caller; the references are valid for the call.
    unsafe { ffi::rtcOccluded16(valid.as_ptr(), scene, &mut args.0, ray) }
}
