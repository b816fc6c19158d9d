//! Fuzz target `texture`: see `spectrace_fuzz::texture` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::texture(data));
