//! `spectrace render` and `spectrace info` end to end.

use std::path::PathBuf;
use std::process::Command;

fn spectrace() -> Command {
    Command::new(env!("CARGO_BIN_EXE_spectrace"))
}

/// A fresh, empty folder under the target directory for one test's outputs.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..").join(path)
}

#[test]
fn render_without_arguments_writes_the_default_exr_and_png() {
    // Small size to keep the suite fast; the default scene itself is what runs with no arguments.
    let dir = scratch("render_default");
    let status =
        spectrace().current_dir(&dir).args(["render", "--width", "64", "--height", "48", "--quiet"]).status().unwrap();
    assert!(status.success());
    let png = image::open(dir.join("render.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (64, 48));
    let exr = std::fs::read(dir.join("render.exr")).unwrap();
    assert_eq!(&exr[..4], &[0x76, 0x2f, 0x31, 0x01], "OpenEXR magic number");
    // Nothing else left behind (no temporary files).
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn render_of_a_scene_file_with_options() {
    let dir = scratch("render_scene");
    let out = dir.join("spheres.exr");
    let output = spectrace()
        .args(["render"])
        .arg(repo("scenes/paper/five_spheres.json"))
        .args(["-o"])
        .arg(&out)
        .args(["--width", "32", "--height", "24", "--spectral", "rgb", "--ambient", "constant:0.1"])
        .args(["--absorption", "off", "--display", "paper9300"])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(out.exists() && dir.join("spheres.png").exists());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("rgb") && stderr.contains("0 non-finite"), "{stderr}");
}

#[test]
fn bad_input_is_a_clear_error_and_writes_nothing() {
    let dir = scratch("render_errors");
    let out = dir.join("x.exr");
    let missing = dir.join("no_such_scene.json");
    for (args, needle) in [
        (vec!["render".into(), missing.display().to_string()], "no_such_scene.json"),
        (vec!["render".into(), "--spectral".into(), "bins:1".into()], "bins:N"),
        (vec!["render".into(), "--ambient".into(), "sky".into()], "ambient"),
        (vec!["render".into(), "-o".into(), dir.join("x.png").display().to_string()], ".exr"),
    ] {
        let output = spectrace().current_dir(&dir).args(&args).arg("--quiet").output().unwrap();
        assert!(!output.status.success(), "{args:?} should fail");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "no partial output");
}

#[test]
fn spectral_exr_is_written_for_fixed_wavelengths_only() {
    let dir = scratch("render_spectral_exr");
    let render = |spectral: &str, film: &str, out: &str| {
        let args =
            ["render", "--spectral", spectral, "--spectral-exr", film, "-o", out, "--width", "16", "--height", "12"];
        spectrace().current_dir(&dir).args(args).arg("--quiet").output().unwrap()
    };
    let output = render("bins:8", "s.exr", "x.exr");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(dir.join("s.exr").exists() && dir.join("x.exr").exists() && dir.join("x.png").exists());
    // RGB has no wavelengths: an error before anything is rendered or written.
    let output = render("rgb", "t.exr", "y.exr");
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("bins:N"));
    assert!(!dir.join("t.exr").exists() && !dir.join("y.exr").exists());
}

#[test]
fn load_errors_say_each_thing_once() {
    // The file name, the cause and the OS reason each appear once in the message (errors
    // that quote their source's message must not also chain it).
    let dir = scratch("render_error_chain");
    let missing = dir.join("no_such_scene.json");
    let bad_material = dir.join("bad_material.json");
    std::fs::write(
        &bad_material,
        r#"{"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "vfov_deg": 30},
            "materials": {"m": {"base_color": {"csv": "missing.csv"}}},
            "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}]}"#,
    )
    .unwrap();
    for (scene, parts) in [
        (&missing, ["no_such_scene.json", "cannot read", "os error"]),
        (&bad_material, ["bad_material.json", "missing.csv", "os error"]),
    ] {
        for command in ["render", "info"] {
            let output = spectrace().current_dir(&dir).arg(command).arg(scene).output().unwrap();
            assert!(!output.status.success());
            let stderr = String::from_utf8_lossy(&output.stderr);
            for part in parts {
                assert_eq!(stderr.matches(part).count(), 1, "`{part}` in: {stderr}");
            }
        }
    }
}

#[test]
fn info_reports_what_the_default_scene_needs() {
    let output = spectrace().args(["info"]).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["spheres"], 5, "{json}");
    assert_eq!(json["spiky_spectra"], false);
    // Smooth ColorChecker spectra under D65: 32 wavelengths keep every light × surface
    // product within ΔE00 0.1 of the 1 nm integral (see `integrator::choose_auto`).
    assert_eq!(json["spectral_auto"], "bins:32");
}
