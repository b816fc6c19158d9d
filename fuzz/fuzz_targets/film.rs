//! Fuzz target `film`: see `spectrace_fuzz::film` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::film(data));
