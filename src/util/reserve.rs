//! Room for buffers whose size an input decides (a mesh file's header, its faces as they
//! come), or an error that says so: Rust aborts the process where an allocation fails, and
//! under a batch job's memory limit a 10M-triangle PLY did ("memory allocation of 61401636
//! bytes failed", then `SIGABRT`) instead of saying the mesh does not fit.
//!
//! Two checks, because limits fail in two ways: where the need is more than the process may
//! still take ([`super::memory::short_of`]: a control group's limit, whose allocations succeed
//! and are killed later when written), and where the allocator refuses it (`try_reserve`: an
//! address-space limit, `ulimit -v`).

use super::memory::{gigabytes, short_of};

/// An error where `bytes` are more than the process may still take, naming `what` needs them.
pub fn check(bytes: u64, what: &str) -> Result<(), String> {
    match short_of(bytes) {
        Some(left) => Err(format!(
            "{what} need {}, more than {left}",
            gigabytes(bytes)
        )),
        None => Ok(()),
    }
}

/// Reserves exactly `additional` more elements in `v`, or says that `what` (e.g. "its
/// 5116802 vertices") does not fit.
pub fn reserve_exact<T>(v: &mut Vec<T>, additional: usize, what: &str) -> Result<(), String> {
    let bytes = (additional as u64).saturating_mul(size_of::<T>() as u64);
    check(bytes, what)?;
    v.try_reserve_exact(additional)
        .map_err(|_| format!("{what} need {}, which the system refused", gigabytes(bytes)))
}

/// Makes room for `more` elements in `v`, growing it as a `Vec` grows (to twice its capacity
/// at least) but through [`reserve_exact`]'s checks: for buffers that grow as a file is read or
/// photons are traced. `what` says what the elements are so far ("triangles read"); the error
/// counts them: "2097152 vertices read; room for more would need 0.03 GB, more than ...".
#[inline]
pub fn make_room<T>(v: &mut Vec<T>, more: usize, what: &str) -> Result<(), String> {
    if v.capacity() - v.len() >= more {
        return Ok(());
    }
    grow(v, more, what)
}

#[cold]
fn grow<T>(v: &mut Vec<T>, more: usize, what: &str) -> Result<(), String> {
    let target = (2 * v.capacity()).max(v.len() + more).max(1024);
    let have = v.len();
    reserve_exact(
        v,
        target - have,
        &format!("{have} {what}; room for more would"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Room is made ahead (twice the capacity), so that growing costs what a `Vec`'s does.
    #[test]
    fn room_grows_geometrically() {
        let mut v: Vec<u32> = Vec::new();
        let mut reallocations = 0;
        for i in 0..100_000u32 {
            let before = v.capacity();
            make_room(&mut v, 1, "numbers counted").unwrap();
            reallocations += (v.capacity() != before) as u32;
            v.push(i);
        }
        assert!(v.capacity() >= 100_000);
        assert!(reallocations <= 8, "{reallocations} reallocations");
    }

    /// A need beyond what the process may take is refused, naming what needed it, without
    /// allocating.
    #[test]
    fn more_than_the_process_may_take_is_an_error() {
        let mut v: Vec<[f32; 3]> = Vec::new();
        let err = reserve_exact(&mut v, usize::MAX / 64, "its vertices").unwrap_err();
        assert!(
            err.starts_with("its vertices need ") && err.contains(" GB, more than the "),
            "{err}"
        );
        assert!(err.ends_with(" GB this process may use"), "{err}");
        assert_eq!(v.capacity(), 0);
        assert_eq!(gigabytes(61_401_636), "0.06 GB");
        assert_eq!(gigabytes(3_070_000_000), "3.1 GB");
        assert_eq!(gigabytes(4_194_304), "4.2 MB");
    }
}
