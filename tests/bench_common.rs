//! The benchmarks' shared helpers (`benches/common`), which `cargo test` does not build with
//! the benches: their settings from the environment and their marking of errors that the
//! reference cannot resolve.

#[path = "../benches/common/mod.rs"]
mod common;

use common::{env_or, Resolution};

#[test]
fn settings_parse_as_the_readme_writes_them() {
    // One test sets every variable it reads: tests run on threads of one process.
    std::env::set_var("PHOTONDIFF_TEST_COUNT", "2e7");
    assert_eq!(env_or::<u64>("PHOTONDIFF_TEST_COUNT", 5), 20_000_000);
    std::env::set_var("PHOTONDIFF_TEST_COUNT", " 300 ");
    assert_eq!(env_or::<u64>("PHOTONDIFF_TEST_COUNT", 5), 300);
    assert_eq!(env_or::<u64>("PHOTONDIFF_TEST_UNSET", 5), 5);
    // A fractional setting where the bench takes one.
    std::env::set_var("PHOTONDIFF_TEST_COUNT", "0.25");
    assert_eq!(env_or::<f64>("PHOTONDIFF_TEST_COUNT", 1.0), 0.25);
}

#[test]
fn errors_under_three_times_the_noise_are_marked_and_counted() {
    let mut r = Resolution::default();
    assert_eq!(r.note("X"), "");
    assert_eq!(r.cell(0.0301, 0.0100, 4, false), "0.0301");
    assert_eq!(r.cell(0.0299, 0.0100, 4, false), "~0.0299");
    assert_eq!(r.cell(0.2036, 0.0590, 2, true), "20.36%");
    assert_eq!(r.cell(0.1000, 0.0590, 2, true), "~10.00%");
    assert!(r.any());
    assert_eq!(
        r.note("PHOTONDIFF_REFERENCE_PATHS"),
        "`~`: 2 of 4 errors are under three times the reference's noise over the same pixels, \
         which cannot resolve them; a larger reference (PHOTONDIFF_REFERENCE_PATHS) can."
    );
}
