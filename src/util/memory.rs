//! The process's resident memory, as Linux reports it in `/proc/self/status`.

use std::sync::atomic::{AtomicU64, Ordering};

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
    [total_machine_bytes(), address_space_limit(), cgroup_limit()]
        .into_iter()
        .flatten()
        .min()
}

/// The machine's memory (`MemTotal` of `/proc/meminfo`).
fn total_machine_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    text.lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().strip_suffix("kB")?.trim().parse::<u64>().ok())
        .map(|kb| kb * 1024)
}

/// The memory this process may still take: under each of [`total_bytes`]' limits, what it
/// does not hold already (the machine's memory less what is resident, the address-space limit
/// less the address space mapped, `VmSize`, the control group's `memory.max` less its
/// `memory.current`); `None` where no limit is known. The checks before big allocations read
/// it: counting the limit alone, a tile needing 2.89 GB under a 3.07 GB `ulimit -v` started
/// and aborted, the scene, Embree and the threads holding the rest.
pub fn available_bytes() -> Option<u64> {
    let machine = total_machine_bytes().map(|t| t.saturating_sub(resident_bytes()));
    let address_space = address_space_limit()
        .map(|limit| limit.saturating_sub(status_bytes("VmSize").unwrap_or(0)));
    let group = cgroup_limit().map(|max| max.saturating_sub(cgroup_current().unwrap_or(0)));
    [machine, address_space, group].into_iter().flatten().min()
}

/// What the checks keep free beyond the need they check: the many small allocations a run
/// makes that no check sees (each chunk's photon paths, each tile's buffers, the threads'
/// stacks). Without it a render whose BVH left a few tens of MB of its limit passed every
/// check and aborted on a 32 KB allocation while tracing photons.
pub const HEADROOM: u64 = 64 << 20;

/// Where `need` bytes (and the [`HEADROOM`]) are more than this process may still take
/// ([`available_bytes`]), what it may take, as the refusals say it: "the 2.9 GB left of the 3.1
/// GB this process may use"; `None` where they fit or no limit is known.
pub fn short_of(need: u64) -> Option<String> {
    let (total, left) = (total_bytes()?, available_bytes()?);
    (need.saturating_add(HEADROOM) > left).then(|| {
        let kept = if need <= left {
            format!(
                ", less the {} kept for the run's small allocations",
                gigabytes(HEADROOM)
            )
        } else {
            String::new()
        };
        format!(
            "the {} left of the {} this process may use{kept}",
            gigabytes(left),
            gigabytes(total)
        )
    })
}

/// Gigabytes as the refusals give them: one decimal, two below one gigabyte so that 60 MB
/// does not read as "0.0 GB", and megabytes below 10 MB ("4.2 MB", not "0.00 GB").
pub fn gigabytes(bytes: u64) -> String {
    let gb = bytes as f64 / 1e9;
    if gb < 0.00995 {
        format!("{:.1} MB", bytes as f64 / 1e6)
    } else if gb < 0.995 {
        format!("{gb:.2} GB")
    } else {
        format!("{gb:.1} GB")
    }
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
    cgroup_file("memory.max")?.parse().ok()
}

/// The memory this process's control group holds (`memory.current`, cgroup v2).
fn cgroup_current() -> Option<u64> {
    cgroup_file("memory.current")?.parse().ok()
}

/// A file of this process's control group (cgroup v2), trimmed.
fn cgroup_file(name: &str) -> Option<String> {
    let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = own.lines().find_map(|l| l.strip_prefix("0::"))?;
    let text = std::fs::read_to_string(format!("/sys/fs/cgroup{}/{name}", path.trim())).ok()?;
    Some(text.trim().to_string())
}

/// The process's peak before [`ResidentMark::now`] last restarted the kernel's (`VmHWM`).
static EARLIER_PEAK: AtomicU64 = AtomicU64::new(0);

/// The most resident memory the process has held so far (`VmHWM`, and the peak before a
/// [`ResidentMark`] restarted it), 0 where unknown.
pub fn peak_resident_bytes() -> u64 {
    let now = status_bytes("VmHWM").unwrap_or(0);
    now.max(EARLIER_PEAK.load(Ordering::Relaxed))
}

/// The resident memory at the start of a stage, to tell what the stage adds: at its end and at
/// its peak. Embree's memory monitor counts the blocks it reserves, not the pages it writes: a
/// compact BVH of 8.4M triangles said 560 MB where its build kept 296 MB resident.
#[derive(Debug, Clone, Copy)]
pub struct ResidentMark {
    resident: u64,
    /// Whether the kernel's peak was restarted at the mark (`/proc/self/clear_refs`), so that
    /// its peak from then on is the stage's.
    peak_restarted: bool,
}

impl ResidentMark {
    /// Marks now. The kernel's peak is restarted (its value so far is kept for
    /// [`peak_resident_bytes`]), so the mark cannot be taken twice at once: one per stage.
    pub fn now() -> Self {
        EARLIER_PEAK.fetch_max(status_bytes("VmHWM").unwrap_or(0), Ordering::Relaxed);
        // "5" resets the peak resident size to the current one (Linux 4.0 and later).
        let peak_restarted = std::fs::write("/proc/self/clear_refs", "5").is_ok();
        Self {
            resident: resident_bytes(),
            peak_restarted,
        }
    }

    /// Resident bytes added since the mark (0 where fewer are resident now).
    pub fn added(&self) -> u64 {
        resident_bytes().saturating_sub(self.resident)
    }

    /// The most resident bytes added at once since the mark, `None` where the kernel's peak
    /// could not be restarted.
    pub fn most_added(&self) -> Option<u64> {
        self.peak_restarted.then(|| {
            status_bytes("VmHWM")
                .unwrap_or(0)
                .saturating_sub(self.resident)
        })
    }
}

/// The resident memory the process holds now (`VmRSS`), 0 where unknown.
pub fn resident_bytes() -> u64 {
    status_bytes("VmRSS").unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mark sees a block written after it, in what is added and at the peak, and the process's
    /// peak keeps what it held before the mark restarted the kernel's.
    #[test]
    fn a_mark_measures_what_is_added_after_it() {
        let earlier = vec![1u8; 96 << 20];
        assert!(earlier.iter().step_by(4096).all(|&b| b == 1));
        drop(earlier);
        let peak = peak_resident_bytes();
        let mark = ResidentMark::now();
        let block = vec![1u8; 64 << 20];
        assert!(block.iter().step_by(4096).all(|&b| b == 1));
        // Other tests of this process allocate too: only lower bounds hold.
        assert!(mark.added() >= 48 << 20, "{}", mark.added());
        assert!(mark.most_added().unwrap() >= 48 << 20);
        assert!(
            peak_resident_bytes() >= peak,
            "{peak} -> {}",
            peak_resident_bytes()
        );
    }

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

    /// What is left is the limit less what the process holds: with 256 MiB written, at least
    /// 200 MiB less than the limit (other tests of the process allocate and free meanwhile).
    #[test]
    fn what_is_left_counts_what_the_process_holds() {
        let block = vec![1u8; 256 << 20];
        assert!(block.iter().step_by(4096).all(|&b| b == 1));
        let (total, left) = (total_bytes().unwrap(), available_bytes().unwrap());
        assert!(left + (200 << 20) <= total, "{left} of {total}");
        assert!(short_of(total).is_some() && short_of(0).is_none());
        drop(block);
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
