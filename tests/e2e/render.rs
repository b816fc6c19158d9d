//! `spectrace render` and `spectrace info` end to end.

use std::path::{Path, PathBuf};
use std::process::Command;

pub(crate) fn spectrace() -> Command {
    Command::new(env!("CARGO_BIN_EXE_spectrace"))
}

/// A fresh, empty folder under the target directory for one test's files (the e2e tests
/// of every command share it).
pub(crate) fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<std::ffi::OsString> {
    let mut names: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    names.sort();
    names
}

/// Runs `spectrace <args>` in `dir`, which must refuse it: exit code `code` (1 for a refused
/// run, 2 for an argument clap rejects), each of `needles` in stderr, and nothing in `dir`
/// that was not there before. Returns stderr.
pub(crate) fn refused(dir: &Path, args: &[&str], code: i32, needles: &[&str]) -> String {
    let before = listing(dir);
    let output = spectrace().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(code), "{args:?}: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{args:?}: no `{needle}` in: {stderr}");
    }
    assert_eq!(listing(dir), before, "{args:?} left files behind");
    stderr
}

pub(crate) fn repo(path: &str) -> PathBuf {
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
fn a_bad_setting_or_material_key_is_refused_naming_the_file_and_the_key() {
    let dir = scratch("bad_settings");
    let sphere = r#"{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}"#;
    let write = |name: &str, material: &str, settings: &str| {
        let text = format!(r#"{{"materials": {{"m": {material}}}, "objects": [{sphere}], "settings": {settings}}}"#);
        std::fs::write(dir.join(name), text).unwrap();
    };
    write("typo.json", "{}", r#"{"max_dpeth": 8}"#);
    write("negative.json", "{}", r#"{"max_depth": -3}"#);
    write("colour.json", r#"{"base_colour": "colorchecker:15"}"#, "{}");
    write("ok.json", r#"{"base_color": "colorchecker:15", "extras": {"anything": 1}}"#, r#"{"max_depth": 4}"#);
    let refuse = |scene: &str, set: Option<&str>, needle: &str| {
        let mut args = vec!["render", "-q", "--width", "8", "--height", "6", "-o", "o.exr", scene];
        args.extend(set.map(|s| ["--set", s]).into_iter().flatten());
        refused(&dir, &args, 1, &[needle])
    };
    refuse("typo.json", None, "typo.json: settings.max_dpeth: unknown key; did you mean `max_depth`?");
    refuse("negative.json", None, "negative.json: settings.max_depth: expected an integer in 0..=1024, got -3");
    refuse("colour.json", None, "colour.json: materials.m.base_colour: unknown key; did you mean `base_color`?");
    // A value set on the command line is checked as one in the file is.
    refuse(
        "ok.json",
        Some("settings.max_depth=1e30"),
        "settings.max_depth: expected an integer in 0..=1024, got 1e+30",
    );
    let output = spectrace()
        .current_dir(&dir)
        .args(["render", "-q", "--width", "8", "--height", "6", "-o", "o.exr", "ok.json"])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

#[test]
fn a_path_tracer_flag_given_to_the_paper_model_is_named_not_dropped() {
    let dir = scratch("rr_depth_whitted");
    let output = spectrace()
        .args(["render", "-q", "--width", "8", "--height", "6", "--rr-depth", "5", "-o"])
        .arg(dir.join("w.exr"))
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("--rr-depth is ignored by whitted-hall"), "{stderr}");
    let output = spectrace()
        .args(["render", "-q", "--width", "8", "--height", "6", "--sampler", "independent", "-o"])
        .arg(dir.join("w2.exr"))
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("--sampler is ignored by whitted-hall"), "{stderr}");
}

#[test]
fn the_sampler_is_chosen_on_the_command_line() {
    let dir = scratch("sampler");
    let run = |sampler: &str, name: &str| {
        spectrace()
            .args(["render", "-q", "--integrator", "path", "--width", "16", "--height", "12", "--spp", "4"])
            .args(["--sampler", sampler, "-o"])
            .arg(dir.join(name))
            .output()
            .unwrap()
    };
    for (sampler, name) in [("sobol", "s.exr"), ("independent", "i.exr")] {
        let output = run(sampler, name);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    }
    // Different numbers, different images (the default is Sobol').
    let default = spectrace()
        .args(["render", "-q", "--integrator", "path", "--width", "16", "--height", "12", "--spp", "4", "-o"])
        .arg(dir.join("d.exr"))
        .output()
        .unwrap();
    assert!(default.status.success());
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert_eq!(read("d.exr"), read("s.exr"));
    assert_ne!(read("s.exr"), read("i.exr"));
    let bad = run("halton", "h.exr");
    assert!(!bad.status.success() && !dir.join("h.exr").exists());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("halton") && stderr.contains("sobol or independent"), "{stderr}");
}

#[test]
fn bad_input_is_a_clear_error_and_writes_nothing() {
    let dir = scratch("render_errors");
    let out = dir.join("x.exr");
    let missing = dir.join("no_such_scene.json").display().to_string();
    let png = dir.join("x.png").display().to_string();
    for (args, code, needle) in [
        (vec!["render", missing.as_str()], 1, "no_such_scene.json"),
        (vec!["render", "--spectral", "bins:1"], 2, "bins:N"),
        (vec!["render", "--ambient", "sky"], 2, "ambient"),
        (vec!["render", "-o", png.as_str()], 1, ".exr"),
    ] {
        refused(&dir, &[&args[..], &["--quiet"]].concat(), code, &[needle]);
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
    // A manifest whose mesh file is missing, and one whose mesh file is malformed.
    let missing_mesh = dir.join("missing_mesh.json");
    std::fs::write(&missing_mesh, r#"{"objects": [{"type": "mesh", "file": "nowhere.obj"}]}"#).unwrap();
    let bad_mesh = dir.join("bad_mesh.json");
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(&bad_mesh, r#"{"objects": [{"type": "mesh", "file": "bad.obj"}]}"#).unwrap();
    for (scene, parts) in [
        (&missing, ["no_such_scene.json", "cannot read", "os error"]),
        (&bad_material, ["bad_material.json", "missing.csv", "os error"]),
        (&missing_mesh, ["missing_mesh.json: objects[0]", "nowhere.obj", "os error"]),
        (&bad_mesh, ["bad_mesh.json: objects[0]", "bad.obj: line 3", "not finite"]),
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

/// Where `auto` pilots (F11's lines need bins:95, dearer per ray than hero:4), the
/// render says what the pilot measured and `info` tables it; a render too small to pilot says
/// nothing and keeps the first step's choice.
#[test]
fn auto_says_what_its_pilot_measured() {
    let dir = scratch("auto_pilot");
    let f11 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/reference/colorchecker_f11.json");
    let f11 = f11.to_str().unwrap();
    let run = |spp: &str| {
        let args =
            ["render", f11, "--integrator", "path", "--width", "12", "--height", "8", "--spp", spp, "-o", "f.exr"];
        let output = spectrace().current_dir(&dir).args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "{stderr}");
        stderr
    };
    // 12 × 8 pixels piloted at 2 × 16 spp for three candidates is 9216 samples: the render needs
    // 32× that, 3072 spp.
    let piloted = run("3072");
    assert!(piloted.contains("--spectral auto piloted: bins:95 reaches a given error first"), "{piloted}");
    assert!(piloted.contains("hero:4 ") && piloted.contains("hero:8 ") && piloted.contains("bins:95 0,"), "{piloted}");
    let small = run("64");
    assert!(!small.contains("piloted") && small.contains(" bins:95 64 spp"), "{small}");
    let output = spectrace()
        .args(["info", f11, "--integrator", "path", "--width", "12", "--height", "8", "--spp", "3072"])
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["spectral_auto"], "bins:95");
    let pilot = json["spectral_auto_why"]["pilot"].as_array().unwrap();
    let spectra: Vec<_> = pilot.iter().map(|c| c["spectral"].as_str().unwrap()).collect();
    assert_eq!(spectra, ["bins:95", "hero:4", "hero:8"]);
    // Fixed bins on flat, directly lit patches have no colour noise; hero:4 has the most.
    let spp_to_1 = |i: usize| pilot[i]["spp_to_delta_e00_1"].as_f64().unwrap();
    assert!(spp_to_1(0) < 1e-3 && spp_to_1(1) > spp_to_1(2) && spp_to_1(2) > 1.0, "{pilot:?}");
}

#[test]
fn image_and_pool_limits_are_checked_before_rendering() {
    // 65536² passed the per-side check and aborted allocating 51 GB;
    // `--threads 100000` hung; `--width 0` reported "480".
    let dir = scratch("render_limits");
    for (args, needle) in [
        (
            vec!["--width", "65536", "--height", "65536"],
            "65536x65536 = 4294967296 pixels is more than the limit of 134217728",
        ),
        (vec!["--width", "0"], "--width 0 is out of range: 1..=65536 pixels per side"),
        (vec!["--height", "70000"], "--height 70000 is out of range"),
        (vec!["--threads", "100000"], "--threads 100000 is out of range: 1..=1024"),
        (vec!["--threads", "0"], "--threads 0 is out of range"),
        (
            vec!["--width", "2000", "--height", "2000", "--spectral", "bins:95", "--spectral-exr", "s.exr"],
            "4000000 pixels x 95 wavelengths = 380000000 samples is more than the limit of 268435456",
        ),
    ] {
        refused(&dir, &[&["render"], &args[..], &["--quiet"]].concat(), 1, &[needle]);
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

#[test]
fn one_path_for_two_outputs_is_refused_before_rendering() {
    // `-o X.exr --spectral-exr X.exr` silently replaced the RGB EXR.
    let dir = scratch("render_same_path");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    for film in ["X.exr", "./X.exr", "sub/../X.exr"] {
        let args = ["render", "-o", "X.exr", "--spectral", "bins:8", "--spectral-exr", film, "--quiet"];
        refused(&dir, &args, 1, &["given for two outputs", "-o X.exr also writes X.png"]);
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "only sub/");
}

#[test]
fn a_failed_spectral_exr_leaves_neither_exr_nor_png() {
    // It left out.exr and out.png with exit 1.
    let dir = scratch("render_failed_spectral");
    let args = ["render", "-o", "out.exr", "--spectral", "bins:8", "--spectral-exr", "missing/s.exr"];
    let size = ["--width", "16", "--height", "12", "--quiet"];
    refused(&dir, &[&args[..], &size].concat(), 1, &["missing/s.exr", "none was written"]);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "no out.exr, out.png or temporary");
}

#[test]
fn a_full_disk_is_an_error_exit_with_nothing_left() {
    // A 64 KiB tmpfs holds the 61.6 KB EXR of a 94×60 render but not the PNG beside it: the
    // PNG came out as 0 bytes with exit 0 (its write sat in a buffer whose flush error was
    // dropped). Mounting needs root; elsewhere the unit test `a_full_disk_is_an_error_even_
    // when_the_image_fits_the_buffer` (integrator output.rs) covers the same path.
    let dir = scratch("render_full_disk");
    let mounted = Command::new("mount").args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"]).arg(&dir).status();
    if !mounted.is_ok_and(|s| s.success()) {
        eprintln!("skipped: cannot mount a small tmpfs here (needs root)");
        return;
    }
    let output = spectrace()
        .current_dir(&dir)
        .args(["render", "-o", "out.exr", "--width", "94", "--height", "60", "--quiet"])
        .output()
        .unwrap();
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    let _ = Command::new("umount").arg(&dir).status();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("No space left on device"), "{stderr}");
    assert!(names.is_empty(), "left behind: {names:?}");
}

#[test]
fn sigterm_during_a_render_exits_130_and_writes_nothing() {
    // SIGTERM used to kill the process outright (no cleanup); it is now handled like Ctrl-C.
    let dir = scratch("render_sigterm");
    let child = spectrace()
        .current_dir(&dir)
        .args(["render", "--width", "2000", "--height", "2000", "--spectral", "bins:32", "--threads", "1", "--quiet"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough for the handler to be installed (the scene loads in milliseconds).
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(130), "{}", String::from_utf8_lossy(&output.stderr));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

#[test]
fn ctrl_c_stops_a_render_of_many_samples_per_pixel_within_a_second() {
    // Cancellation was seen between rows only: at 2^20 spp a row of 64 pixels is minutes of work,
    // and SIGINT took 24 s to end this render.
    let dir = scratch("render_sigint_spp");
    let mut child = spectrace()
        .current_dir(&dir)
        .args(["render", "--spp", "1048576", "--width", "64", "--height", "48", "--threads", "1", "--quiet"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough for the handler to be installed (the scene loads in milliseconds).
    std::thread::sleep(std::time::Duration::from_millis(1000));
    assert!(child.try_wait().unwrap().is_none(), "the render ended before the signal");
    let sent = std::time::Instant::now();
    let killed = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    while child.try_wait().unwrap().is_none() {
        if sent.elapsed() > std::time::Duration::from_secs(2) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("still rendering 2 s after SIGINT");
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let latency = sent.elapsed();
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("render cancelled; nothing was written"), "{stderr}");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
    eprintln!("SIGINT to exit: {latency:?}");
}

/// With no flags, the paper's scenes render with the paper's model and everything else
/// with the path tracer, each saying why; a file without camera gets the three-quarter view.
#[test]
fn no_flags_choose_the_integrator_and_camera_and_say_why() {
    let dir = scratch("render_auto");
    let run = |scene: &str| {
        let output = spectrace()
            .current_dir(&dir)
            .args(["render", "--width", "16", "--height", "12", "--spectral", "rgb"])
            .arg(repo(scene))
            .output()
            .unwrap();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let paper = run("scenes/paper/four_spheres_mesh.json");
    assert!(paper.contains("integrator whitted-hall: the scene's settings ask for it"), "{paper}");
    let gem = run("scenes/meshes/gem.gltf");
    assert!(gem.contains("integrator path:"), "{gem}");
    assert!(gem.contains("camera: no camera in the file: a three-quarter view"), "{gem}");
    // The glass torus has a camera and a KHR_lights_punctual light: its camera, auto-exposure.
    let torus = run("scenes/gltf/glass_torus.gltf");
    assert!(!torus.contains("three-quarter"), "{torus}");
    assert!(torus.contains("EV (auto: log-average luminance to 0.18; the file's lights are photometric"), "{torus}");
}

/// `spectrace info ARGS` as JSON (it must succeed).
fn info(args: &[&str]) -> serde_json::Value {
    let output = spectrace().args(["info"]).args(args).output().unwrap();
    assert!(output.status.success(), "{args:?}: {}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

#[test]
fn info_reports_the_camera_integrator_and_exposure_a_render_uses() {
    let default = info(&[]);
    assert_eq!(default["integrator"]["name"], "whitted-hall", "{default}");
    assert_eq!(default["exposure"]["ev"], 0.0);
    assert_eq!(default["camera"]["source"], "the file's camera 'camera'");
    let torus = repo("scenes/gltf/glass_torus.gltf");
    let torus = torus.to_str().unwrap();
    let t = info(&[torus]);
    // A glass torus under the file's point light: caustics, so bidirectional path tracing.
    assert_eq!(t["integrator"]["name"], "bdpt");
    assert_eq!(t["exposure"]["ev"], "auto");
    assert_eq!(t["exposure"]["photometric_lights"], true);
    let moved = info(&[torus, "--look-from", "0,0,9", "--look-at", "0,0,0", "--fov", "25", "--exposure", "-1.5"]);
    assert_eq!(moved["camera"]["position"], serde_json::json!([0.0, 0.0, 9.0]), "{moved}");
    assert_eq!(moved["camera"]["vfov_deg"], 25.0);
    assert_eq!(moved["exposure"]["ev"], -1.5);
    // The tone curve: pbr-neutral for glTF/OBJ files, clamp for manifests, unless asked.
    assert_eq!(default["exposure"]["tonemap"], "clamp");
    assert_eq!(t["exposure"]["tonemap"], "pbr-neutral");
    let obj = repo("scenes/obj/cube_and_sphere.obj");
    assert_eq!(info(&[obj.to_str().unwrap()])["exposure"]["tonemap"], "pbr-neutral");
    let tilted = info(&[torus, "--integrator", "whitted-hall", "--tonemap", "clamp"]);
    assert_eq!(tilted["integrator"]["name"], "whitted-hall");
    assert_eq!(tilted["exposure"]["tonemap"], "clamp");
    assert_eq!(info(&["--tonemap", "pbr-neutral"])["exposure"]["tonemap"], "pbr-neutral");
    let dir = scratch("info_bad_camera");
    refused(&dir, &["info", torus, "--camera", "nope"], 1, &["--camera nope: no such camera", "0 'camera'"]);
    refused(&dir, &["render", torus, "--exposure", "1", "--auto-exposure"], 2, &["cannot be used with"]);
}

/// `--env`: an OBJ without lights is lit by the map (not the default lights) and the image is written;
/// a map that is not there, or `--env-intensity` without `--env`, is refused before anything is written.
#[test]
fn env_option_lights_a_file_with_a_map_and_bad_maps_are_refused() {
    let dir = scratch("render_env");
    std::fs::write(dir.join("tri.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let sky: Vec<image::Rgb<f32>> = (0..8).map(|i| image::Rgb([0.5 + i as f32 * 0.125; 3])).collect();
    let file = std::io::BufWriter::new(std::fs::File::create(dir.join("sky.hdr")).unwrap());
    image::codecs::hdr::HdrEncoder::new(file).encode(&sky, 4, 2).unwrap();
    let output = spectrace()
        .current_dir(&dir)
        .args(["render", "tri.obj", "--env", "sky.hdr", "--env-intensity", "2", "--width", "16", "--height", "12"])
        .args(["--spp", "2", "-o", "out.exr"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("--env") && stderr.contains("sky.hdr"), "{stderr}");
    assert!(!stderr.contains("no light in the file"), "{stderr}");
    assert!(dir.join("out.exr").is_file() && dir.join("out.png").is_file());
    refused(&dir, &["render", "tri.obj", "--env", "nowhere.hdr", "-o", "x.exr"], 1, &["nowhere.hdr"]);
    refused(&dir, &["render", "tri.obj", "--env-intensity", "2", "-o", "x.exr"], 2, &["--env"]);
    std::fs::write(dir.join("broken.exr"), b"v/1\x01 not really").unwrap();
    refused(&dir, &["render", "tri.obj", "--env", "broken.exr", "-o", "x.exr"], 1, &["broken.exr"]);
    // `--light-env`: `none` keeps only the key light, a file name is `--env`; `--no-default-lights`
    // leaves a file without lights unlit, which is refused.
    let tri = dir.join("tri.obj");
    let tri = tri.to_str().unwrap();
    let lights = |args: &[&str]| info(&[&[tri], args].concat())["lights"].as_array().unwrap().len();
    assert_eq!(lights(&[]), 2, "default: environment and key light");
    assert_eq!(lights(&["--light-env", "uniform"]), 2);
    assert_eq!(lights(&["--light-env", "none"]), 1, "the key light alone");
    let sky_path = dir.join("sky.hdr");
    let mapped = info(&[tri, "--light-env", sky_path.to_str().unwrap()]);
    let mapped = mapped["lights"].as_array().unwrap();
    assert!(mapped.len() == 1 && mapped[0]["map"].as_str().unwrap().ends_with("sky.hdr"), "{mapped:?}");
    refused(&dir, &["info", "tri.obj", "--no-default-lights"], 1, &["no light"]);
    // `--light-env sky`: the sky map and the sun (the key light replaced); without the sun, the key
    // light scaled to the sky; out-of-range options refused; `--env-intensity` scales `--light-env MAP`.
    let sky = info(&[tri, "--light-env", "sky", "--turbidity", "4", "--sun-elevation", "30"]);
    let sky_lights = sky["lights"].as_array().unwrap();
    assert_eq!(sky_lights.len(), 2, "{sky_lights:?}");
    assert!(sky_lights[0]["spectrum"].as_str().unwrap().contains("Preetham sky T=4 sun 30°"), "{sky_lights:?}");
    assert_eq!(sky_lights[1]["type"], "directional");
    assert!(sky_lights[1]["unit"] == "lux" && sky_lights[1]["intensity"].as_f64().unwrap() > 1e4, "{sky_lights:?}");
    let no_sun = info(&[tri, "--light-env", "sky", "--no-sun"]);
    let no_sun = no_sun["lights"].as_array().unwrap();
    assert!(no_sun.len() == 2 && no_sun[1]["spectrum"] == "D65", "the key light: {no_sun:?}");
    refused(&dir, &["info", "tri.obj", "--light-env", "sky", "--turbidity", "11"], 1, &["--turbidity 11", "2–10"]);
    refused(&dir, &["info", "tri.obj", "--light-env", "sky", "--sun-elevation", "-5"], 1, &["--sun-elevation -5"]);
    refused(&dir, &["info", "tri.obj", "--light-env", "sky", "--env-rotation", "5"], 1, &["--sun-azimuth"]);
    refused(&dir, &["info", "tri.obj", "--turbidity", "3"], 2, &["--light-env"]);
    refused(&dir, &["info", "tri.obj", "--light-env", "uniform", "--turbidity", "3"], 1, &["--light-env sky"]);
    let scaled =
        info(&[tri, "--light-env", sky_path.to_str().unwrap(), "--env-intensity", "2", "--env-rotation", "10"]);
    assert_eq!(scaled["lights"][0]["intensity"].as_f64(), Some(2.0), "{scaled}");
    refused(&dir, &["info", "tri.obj", "--light-env", "none", "--no-default-lights"], 2, &["cannot be used with"]);
}
