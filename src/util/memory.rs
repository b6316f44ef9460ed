//! The process's resident memory, as Linux reports it in `/proc/self/status`.

/// A field of `/proc/self/status` in bytes (`VmRSS`, `VmHWM`, ...), or `None` where the file
/// or the field is missing (not Linux, or a restricted /proc).
pub fn status_bytes(field: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|v| v.trim().strip_suffix("kB")?.trim().parse::<u64>().ok())
        .map(|kb| kb * 1024)
}

/// The machine's memory (`MemTotal` of `/proc/meminfo`), `None` where unknown.
pub fn total_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().strip_suffix("kB")?.trim().parse::<u64>().ok())
        .map(|kb| kb * 1024)
}

/// The most resident memory the process has held so far (`VmHWM`), 0 where unknown.
pub fn peak_resident_bytes() -> u64 {
    status_bytes("VmHWM").unwrap_or(0)
}

/// The resident memory the process holds now (`VmRSS`), 0 where unknown.
pub fn resident_bytes() -> u64 {
    status_bytes("VmRSS").unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_machine_has_more_memory_than_the_process_holds() {
        let total = total_bytes().expect("Linux");
        assert!(total > resident_bytes() && total > 1 << 28, "{total}");
    }

    /// The peak never falls, holds at least what is resident, and what is resident counts a
    /// block written page by page. (Unit tests share the process with other threads that
    /// allocate and free, so the peak's growth by the block cannot be asserted here: another
    /// test may have raised it beyond already. `tests/memory.rs` checks peaks of whole runs.)
    #[test]
    fn peak_is_monotone_and_at_least_what_is_resident() {
        let before = peak_resident_bytes();
        assert!(before > 0);
        let block = vec![1u8; 64 << 20];
        // Resident first, then the peak: the peak can only have risen in between.
        let resident = resident_bytes();
        let after = peak_resident_bytes();
        assert!(block.iter().step_by(4096).all(|&b| b == 1));
        assert!(resident >= 48 << 20, "VmRSS {resident} holding 64 MiB");
        assert!(after >= before, "VmHWM {before} -> {after}");
        // The kernel's resident counters are per thread and lag by up to 64 pages each.
        assert!(
            after + (4 << 20) >= resident,
            "VmHWM {after} < VmRSS {resident}"
        );
    }
}
