//! CSV spectra: parsed directly, extended to the visible range as `spectrace color` does,
//! then used as a material's reflectance and a light's spectrum in a one-sphere scene that is
//! rendered 8×8.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(table) = colorimetry::parse_spectra_csv(&text, "fuzz.csv") {
        for column in &table {
            if let Ok(held) = column.spectrum.held_to_visible() {
                let white = colorimetry::DenselySampledSpectrum::constant(1.0);
                let xyz = colorimetry::reflectance_to_xyz(
                    &held,
                    &white,
                    colorimetry::Observer::Cie1931,
                    &colorimetry::Integration::Step(1.0),
                );
                assert!(xyz.x.is_finite() && xyz.y.is_finite() && xyz.z.is_finite(), "{xyz:?}");
            }
        }
    }
    spectrace_fuzz::put("fuzz.csv", data);
    let manifest = r#"{
        "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40},
        "lights": [{"type": "point", "position": [2, 2, 4], "spectrum": {"csv": "fuzz.csv"}}],
        "materials": {"m": {"model": "diffuse", "base_color": {"csv": "fuzz.csv"}}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}]
    }"#;
    if let Ok(desc) = geometry::parse_manifest(manifest, &spectrace_fuzz::scratch(), "fuzz.json") {
        spectrace_fuzz::run_description(desc);
    }
});
