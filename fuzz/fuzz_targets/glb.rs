//! Fuzz target `glb`: see `spectrace_fuzz::glb` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::glb(data));
