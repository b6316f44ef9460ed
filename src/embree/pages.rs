//! Transparent huge pages for the large buffers Embree shares with the renderer.
//!
//! A mesh's vertex and index buffers are read at random, by Embree's compact BVH (which reads
//! the shared vertices) and by hit completion (a hit's indices, then its vertices). On a
//! 10M-triangle mesh (184 MB) in 4 kB pages nearly every such read misses the TLB as well
//! as the cache. Backed by 2 MB pages, `production.toml`'s photons traced in 0.90-0.96 of the
//! time and its render stage took 0.96 (the instanced scene's 0.90), for a BVH build 0.2 s
//! longer on this project's virtual machine, where a huge page's first touch costs more
//! (README, "Huge pages for large meshes"; stop 67).

/// Buffers smaller than this are left alone: the TLB covers them anyway, and a huge page
/// rounds a buffer's resident memory up to 2 MB.
pub const HUGE_PAGES_FROM_BYTES: usize = 4 << 20;

/// Asks the kernel to back `v`'s allocation (its whole capacity) with transparent huge pages
/// where it takes at least [`HUGE_PAGES_FROM_BYTES`]. Call it before writing the buffer:
/// pages are made huge as they are first touched (the kernel's own collapsing of pages
/// already written comes minutes later, if ever). Only advice: nothing changes where the
/// kernel's setting (`/sys/kernel/mm/transparent_hugepage/enabled`) is `never`, or on other
/// systems. Returns whether the advice was taken.
pub fn advise_huge_pages<T>(v: &mut Vec<T>) -> bool {
    let bytes = v.capacity().saturating_mul(size_of::<T>());
    if bytes < HUGE_PAGES_FROM_BYTES {
        return false;
    }
    advise(v.as_mut_ptr().cast(), bytes)
}

#[cfg(target_os = "linux")]
fn advise(start: *mut u8, bytes: usize) -> bool {
    // madvise wants a page-aligned start; the part of the buffer from its first whole page on
    // is advised (4 kB, the smallest page size Linux has on x86-64 and ARM64 alike).
    const PAGE: usize = 4096;
    let skip = (PAGE - start as usize % PAGE) % PAGE;
    if bytes <= skip {
        return false;
    }
    let length = (bytes - skip) / PAGE * PAGE;
    // SAFETY: `[start + skip, start + skip + length)` lies inside one live allocation (the
    // vector's, which the caller holds mutably for the call). MADV_HUGEPAGE changes how the
    // kernel backs those pages, never their contents, and reads or writes no memory.
    let answer = unsafe { libc::madvise(start.add(skip).cast(), length, libc::MADV_HUGEPAGE) };
    answer == 0
}

#[cfg(not(target_os = "linux"))]
fn advise(_start: *mut u8, _bytes: usize) -> bool {
    false
}

/// Whether the memory mapping holding `buffer`'s middle element carries the huge-page advice
/// (the `hg` flag of `/proc/self/smaps`; the middle, since the advice starts at the buffer's
/// first whole page); `None` where that cannot be read (other systems) or the buffer is empty.
/// For tests that check a loader advised its buffers.
pub fn has_huge_page_advice<T>(buffer: &[T]) -> Option<bool> {
    let address = buffer.get(buffer.len() / 2)? as *const T as usize;
    let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
    let mut inside = false;
    for line in smaps.lines() {
        // A mapping's first line starts with its address range, `lo-hi` in hexadecimal.
        let range = line.split_whitespace().next().unwrap_or("");
        if let Some((lo, hi)) = range.split_once('-') {
            if let (Ok(lo), Ok(hi)) = (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
            {
                inside = (lo..hi).contains(&address);
                continue;
            }
        }
        if let (true, Some(flags)) = (inside, line.strip_prefix("VmFlags:")) {
            return Some(flags.split_whitespace().any(|flag| flag == "hg"));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The advice reaches the kernel: a large buffer's mapping carries the `hg` flag
    /// (`MADV_HUGEPAGE`) in `/proc/self/smaps`; a small buffer is left alone.
    #[test]
    #[cfg(target_os = "linux")]
    fn large_buffers_are_advised_and_small_ones_are_not() {
        let mut small: Vec<[f32; 3]> = Vec::with_capacity(1000);
        assert!(!advise_huge_pages(&mut small));
        assert_eq!(has_huge_page_advice(&small), None, "empty");
        // 144 MB, never written: an allocation past both the allocator's largest mmap threshold
        // (32 MB) and a thread arena's heap (64 MB) is a mapping of its own, so it cannot be
        // memory that another test advised and freed (smaller ones can: the advice stays).
        let plain = vec![[0.0f32; 3]; 12_000_000];
        assert_eq!(has_huge_page_advice(&plain), Some(false));
        let mut large: Vec<[f32; 3]> = Vec::with_capacity(4_000_000);
        assert!(advise_huge_pages(&mut large));
        large.resize(4_000_000, [0.0; 3]);
        assert_eq!(has_huge_page_advice(&large), Some(true));
    }
}
