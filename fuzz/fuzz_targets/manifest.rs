//! Manifest JSON text → parse (references resolve under scenes/, so mutated manifests also
//! load the committed meshes and spectra) → assemble → info → 8×8 renders.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/reference");
    if let Ok(desc) = geometry::parse_manifest(&text, &base, "fuzz.json") {
        spectrace_fuzz::run_description(desc);
    }
});
