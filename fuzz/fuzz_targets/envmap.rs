//! Fuzz target `envmap`: see `spectrace_fuzz::envmap` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::envmap(data));
