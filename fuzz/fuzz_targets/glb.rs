//! Binary glTF bytes → load → assemble → info → 8×8 renders.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    spectrace_fuzz::run_file(&spectrace_fuzz::put("fuzz.glb", data));
});
