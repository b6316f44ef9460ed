//! `--threads` holds for Embree's BVH builds too: Embree starts build threads of its own,
//! apart from photondiff's workers. Each count is taken in a process of its own (this test
//! binary run again for one test): Embree's build threads, once started, outlive their device,
//! and no other test's threads may come and go while the process's threads are counted.

use glam::DVec3;
use photondiff::embree::{Device, SceneBuilder};
use photondiff::scene::shapes;
use std::process::Command;

/// Set in the child process to the device's thread count.
const CHILD: &str = "PHOTONDIFF_BUILD_THREADS_CHILD";

/// The threads this process runs now (Linux: `/proc/self/status`).
fn process_threads() -> usize {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("Threads:")).unwrap();
    line["Threads:".len()..].trim().parse().unwrap()
}

/// In the child process: prints the threads the process gained while a device of the asked
/// build threads built a sphere of 2,000,000 triangles (enough for Embree to split the build
/// into tasks). Does nothing in the ordinary test run.
#[test]
fn child() {
    let Ok(threads) = std::env::var(CHILD) else {
        return;
    };
    let before = process_threads();
    let device = Device::with_threads(threads.parse().unwrap()).unwrap();
    let mut builder = SceneBuilder::new(&device);
    builder
        .add_mesh(shapes::sphere(DVec3::ZERO, 1.0, 1000))
        .unwrap();
    let _scene = builder.commit().unwrap();
    println!("gained {}", process_threads().saturating_sub(before));
}

/// The threads gained building on a device of `threads` threads, in a new process.
fn threads_gained_building(threads: usize) -> usize {
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "child", "--nocapture", "--test-threads", "1"])
        .env(CHILD, threads.to_string())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    // The harness prints the test's name on the same line: "test child ... gained N".
    let count = stdout
        .split("gained ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next());
    count.unwrap_or_else(|| panic!("{stdout}")).parse().unwrap()
}

#[test]
fn a_device_of_one_thread_builds_on_the_calling_thread_alone() {
    assert_eq!(threads_gained_building(1), 0);
    if std::thread::available_parallelism().map_or(1, |n| n.get()) > 1 {
        // The same build on a device of every core starts threads: the count above would
        // have seen them.
        assert!(threads_gained_building(0) > 0);
    }
}
