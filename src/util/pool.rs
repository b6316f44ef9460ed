//! Worker threads: one pool per thread count, kept for the whole process. A pool built for
//! each pass (one for its photons, one for its tiles) started fresh threads twice a pass: a
//! trace of 800 passes showed 801 thread tracks, and each pass paid the threads' start.

use rayon::ThreadPool;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

static POOLS: Mutex<BTreeMap<usize, Arc<ThreadPool>>> = Mutex::new(BTreeMap::new());

/// The process's pool of `threads` worker threads (0: one per core), named `worker N`, built
/// on first use.
pub fn workers(threads: usize) -> Result<Arc<ThreadPool>, String> {
    let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(pool) = pools.get(&threads) {
        return Ok(pool.clone());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("worker {}", i + 1))
        .build()
        .map_err(|e| format!("cannot start worker threads: {e}"))?;
    let pool = Arc::new(pool);
    pools.insert(threads, pool.clone());
    Ok(pool)
}

#[cfg(test)]
mod tests {
    #[test]
    fn one_pool_per_thread_count() {
        let a = super::workers(2).unwrap();
        let b = super::workers(2).unwrap();
        assert!(std::sync::Arc::ptr_eq(&a, &b));
        assert_eq!(a.current_num_threads(), 2);
        let c = super::workers(1).unwrap();
        assert!(!std::sync::Arc::ptr_eq(&a, &c));
        let name = c.install(|| std::thread::current().name().map(str::to_string));
        assert_eq!(name.as_deref(), Some("worker 1"));
    }
}
