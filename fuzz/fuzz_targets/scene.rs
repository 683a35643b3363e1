//! Arbitrary bytes -> scene parser and validator -> (accepted, <= 200 particles) 20 engine steps:
//! no panic, every position and velocity finite.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../../crates/carom-scene/tests/fuzz_support/mod.rs"]
mod fuzz_support;

fuzz_target!(|data: &[u8]| {
    fuzz_support::check(data);
});
