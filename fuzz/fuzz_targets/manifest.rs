//! Fuzz target `manifest`: see `spectrace_fuzz::manifest` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::manifest(data));
