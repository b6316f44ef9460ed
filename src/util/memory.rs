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

/// The memory this process may use: the machine's (`MemTotal` of `/proc/meminfo`), or less
/// where its address-space limit (`ulimit -v`, `/proc/self/limits`) or its control group's
/// `memory.max` (a batch job's allocation) says so; `None` where none is known. The checks
/// before big allocations read it: under a 6 GB limit on a 25 GB machine, a render went ahead
/// and aborted minutes later ("memory allocation of 5368709120 bytes failed").
pub fn total_bytes() -> Option<u64> {
    let machine = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find_map(|l| l.strip_prefix("MemTotal:"))
                .and_then(|v| v.trim().strip_suffix("kB")?.trim().parse::<u64>().ok())
                .map(|kb| kb * 1024)
        });
    [machine, address_space_limit(), cgroup_limit()]
        .into_iter()
        .flatten()
        .min()
}

/// The soft address-space limit (`Max address space` of `/proc/self/limits`), `None` when
/// unlimited or unknown.
fn address_space_limit() -> Option<u64> {
    address_space_in(&std::fs::read_to_string("/proc/self/limits").ok()?)
}

/// The soft limit in the `Max address space` line of a `/proc/PID/limits` text.
fn address_space_in(limits: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// The `memory.max` of this process's control group (cgroup v2), `None` when `max` or
/// unknown.
fn cgroup_limit() -> Option<u64> {
    let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = own.lines().find_map(|l| l.strip_prefix("0::"))?;
    let max = std::fs::read_to_string(format!("/sys/fs/cgroup{}/memory.max", path.trim())).ok()?;
    max.trim().parse().ok()
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

    /// The limit is read from the limits' text: a child under `ulimit -v` (in KiB) shows its
    /// own; an unlimited one reads as none.
    #[test]
    fn an_address_space_limit_is_the_memory_a_process_may_use() {
        let limits = |shell: &str| {
            let out = std::process::Command::new("sh")
                .args(["-c", shell])
                .output()
                .unwrap();
            String::from_utf8(out.stdout).unwrap()
        };
        let limited = limits("ulimit -v 3000000; cat /proc/self/limits");
        assert_eq!(
            address_space_in(&limited),
            Some(3_000_000 * 1024),
            "{limited}"
        );
        let unlimited = limits("ulimit -v unlimited; cat /proc/self/limits");
        assert_eq!(address_space_in(&unlimited), None, "{unlimited}");
        // This process: unlimited here, so the machine's memory or a control group's.
        assert!(address_space_limit().is_none_or(|l| l >= total_bytes().unwrap()));
    }

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
