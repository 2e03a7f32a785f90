//! Shared test plumbing: a proptest runner that reports how many cases it ran.
#![allow(clippy::panic, reason = "a failed property fails the test by panicking")]

use std::sync::atomic::{AtomicU64, Ordering};

use proptest::strategy::Strategy;
use proptest::test_runner::{Config, TestRunner};

/// Runs `property` on `cases` values drawn from `strategy` (shrinking on failure, as
/// `proptest!` does) and prints `name: N cases`.
///
/// # Panics
/// When the property fails; the message carries proptest's minimal failing input.
pub fn check<S: Strategy>(name: &str, cases: u32, strategy: S, property: impl Fn(S::Value)) {
    let ran = AtomicU64::new(0);
    let mut runner =
        TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let result = runner.run(&strategy, |value| {
        property(value);
        ran.fetch_add(1, Ordering::Relaxed);
        Ok(())
    });
    if let Err(failure) = result {
        panic!("{name}: {failure}");
    }
    println!("{name}: {} cases (proptest)", ran.load(Ordering::Relaxed));
}
