//! Fuzz target `gltf`: see `spectrace_fuzz::gltf` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::gltf(data));
