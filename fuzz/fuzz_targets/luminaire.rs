//! Fuzz target `luminaire`: see `spectrace_fuzz::luminaire` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::luminaire(data));
