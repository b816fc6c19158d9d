//! Fuzz target `obj_mtl`: see `spectrace_fuzz::obj_mtl` (fuzz/src/lib.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| spectrace_fuzz::obj_mtl(data));
