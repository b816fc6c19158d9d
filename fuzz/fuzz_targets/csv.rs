//! Fuzz target `csv`: see `spectrace_fuzz::csv` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::csv(data));
