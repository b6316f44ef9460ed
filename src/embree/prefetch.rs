//! A hint to the CPU to start loading memory the program will read soon, so that several cache
//! misses overlap instead of waiting in turn. The hit's triangles use it here (a packet's lanes
//! fetch their vertices first); the photon maps use it to fetch the powers of a BVH leaf's
//! photons while the leaf is being tested (`photons::map`). It lives in this folder because its
//! one `unsafe` block (the intrinsic takes a pointer) does: all of photondiff's `unsafe` is here.

/// A hint to load the cache line holding `value` (nothing on targets without one).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
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

/// [`prefetch`] of every cache line holding `values` (at most a few lines: a BVH leaf's).
#[inline(always)]
pub fn prefetch_all<T>(values: &[T]) {
    // One value a line is enough where a value is no larger than a line, whatever the slice's
    // alignment, if the last value is fetched too.
    let step = (64 / std::mem::size_of::<T>().max(1)).max(1);
    for v in values.iter().step_by(step).chain(values.last()) {
        prefetch(v);
    }
}
