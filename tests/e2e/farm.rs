//! A render split into parts (`render --part K/M --film`) and merged (`spectrace merge`) is bit
//! for bit the single render; merge refuses what does not belong together; a killed render
//! resumes from its checkpoint to the same bits.

use std::path::Path;

use crate::render::{refused, repo, scratch, spectrace};

/// Runs `spectrace <args>` in `dir`; it must succeed. Returns stderr.
fn run(dir: &Path, args: &[&str]) -> String {
    let output = spectrace().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{args:?}: {stderr}");
    stderr
}

fn same_bytes(dir: &Path, a: &str, b: &str) {
    let (x, y) = (std::fs::read(dir.join(a)).unwrap(), std::fs::read(dir.join(b)).unwrap());
    assert!(x == y, "{a} and {b} differ ({} and {} bytes)", x.len(), y.len());
}

fn cornell() -> String {
    repo("scenes/reference/cornell_box.json").display().to_string()
}

#[test]
fn parts_merge_bit_for_bit_into_the_single_render() {
    let dir = scratch("farm_parts");
    let scene = cornell();
    let cases: [(&str, &[&str], bool); 5] = [
        ("whitted", &["--integrator", "whitted-hall", "--spectral", "bins:16"], true),
        ("whitted-rgb", &["--integrator", "whitted-hall", "--spectral", "rgb"], false),
        ("path-bins", &["--integrator", "path", "--spectral", "bins:16"], true),
        ("path-bins-plain", &["--integrator", "path", "--spectral", "bins:16"], false),
        ("path-hero", &["--integrator", "path", "--spectral", "hero:8", "--seed", "7"], false),
    ];
    for (name, options, spectral) in cases {
        let base: Vec<&str> = [scene.as_str(), "--width", "20", "--height", "15", "--spp", "7", "--quiet"]
            .into_iter()
            .chain(options.iter().copied())
            .collect();
        let mut single = vec!["render"];
        single.extend(&base);
        let (exr, sexr) = (format!("{name}-single.exr"), format!("{name}-single-spectral.exr"));
        single.extend(["-o", &exr]);
        if spectral {
            single.extend(["--spectral-exr", &sexr]);
        }
        run(&dir, &single);
        // Three parts by --part, rendered in another order than merged; then uneven --samples.
        let splits: [&[&str]; 2] =
            [&["--part", "1/3", "--part", "2/3", "--part", "3/3"], &["--samples", "0..1", "--samples", "1..7"]];
        for (s, split) in splits.iter().enumerate() {
            let mut films = Vec::new();
            for (i, pair) in split.chunks(2).enumerate().rev() {
                let film = format!("{name}-{s}-{i}.film");
                let mut part = vec!["render"];
                part.extend(&base);
                part.extend([pair[0], pair[1], "--film", &film]);
                if spectral {
                    part.push("--spectral-film");
                }
                run(&dir, &part);
                films.push(film);
            }
            let (merged, mexr) = (format!("{name}-{s}-merged.exr"), format!("{name}-{s}-merged-spectral.exr"));
            let mut merge = vec!["merge"];
            merge.extend(films.iter().map(String::as_str));
            merge.extend(["-o", &merged]);
            if spectral {
                merge.extend(["--spectral-exr", &mexr]);
            }
            let stderr = run(&dir, &merge);
            same_bytes(&dir, &exr, &merged);
            same_bytes(&dir, &exr.replace(".exr", ".png"), &merged.replace(".exr", ".png"));
            if spectral {
                same_bytes(&dir, &sexr, &mexr);
            }
            assert!(stderr.contains("samples 0..7 of 7 spp, 7..=7 per pixel"), "{name}: {stderr}");
        }
    }
    // The comparison can fail: two parts of another seed merge into other bytes.
    let base = [
        scene.as_str(),
        "--width",
        "20",
        "--height",
        "15",
        "--spp",
        "7",
        "--integrator",
        "path",
        "--spectral",
        "hero:8",
        "-q",
    ];
    for (k, film) in [("1/2", "s1.film"), ("2/2", "s2.film")] {
        let mut part = vec!["render"];
        part.extend(base);
        part.extend(["--part", k, "--film", film]);
        run(&dir, &part);
    }
    run(&dir, &["merge", "s1.film", "s2.film", "-o", "seed0.exr", "-q"]);
    let other = std::fs::read(dir.join("seed0.exr")).unwrap();
    assert_ne!(other, std::fs::read(dir.join("path-hero-single.exr")).unwrap(), "seed 0 and seed 7 differ");
}

#[test]
fn merge_of_gltf_and_obj_parts_writes_the_single_renders_images() {
    // glTF and OBJ files get a view of their own (PBR Neutral; auto-exposure for photometric
    // lights): the film records it, so the merge shows the merged image as the render did.
    let dir = scratch("farm_files");
    let gltf = repo("scenes/gltf/glass_torus.gltf").display().to_string();
    let obj = repo("scenes/obj/cube_and_sphere.obj").display().to_string();
    let cases: [(&str, &str, &[&str]); 4] = [
        ("gltf", &gltf, &[]),
        ("obj", &obj, &[]),
        ("obj-auto", &obj, &["--auto-exposure"]),
        ("gltf-ev", &gltf, &["--exposure", "1.5", "--tonemap", "clamp"]),
    ];
    for (name, scene, view) in cases {
        let base: Vec<&str> = [scene, "--width", "24", "--height", "16", "--spp", "2", "--quiet"]
            .into_iter()
            .chain(view.iter().copied())
            .collect();
        let exr = format!("{name}-single.exr");
        let mut single = vec!["render"];
        single.extend(&base);
        single.extend(["-o", &exr]);
        run(&dir, &single);
        let films = [format!("{name}-1.film"), format!("{name}-2.film")];
        for (k, film) in ["1/2", "2/2"].into_iter().zip(&films) {
            let mut part = vec!["render"];
            part.extend(&base);
            part.extend(["--part", k, "--film", film]);
            run(&dir, &part);
        }
        let merged = format!("{name}-merged.exr");
        run(&dir, &["merge", &films[0], &films[1], "-o", &merged, "-q"]);
        same_bytes(&dir, &exr, &merged);
        same_bytes(&dir, &exr.replace(".exr", ".png"), &merged.replace(".exr", ".png"));
    }
    // The view is part of the render: parts shown differently do not merge.
    let parts = [("1/2", "ev0.film", "0"), ("2/2", "ev1.film", "1")];
    for (k, film, ev) in parts {
        run(
            &dir,
            &[
                "render",
                &obj,
                "--width",
                "8",
                "--height",
                "8",
                "--spp",
                "2",
                "-q",
                "--part",
                k,
                "--film",
                film,
                "--exposure",
                ev,
            ],
        );
    }
    refused(&dir, &["merge", "ev0.film", "ev1.film", "-o", "x.exr"], 1, &["another view of the image"]);
}

#[test]
fn merge_refuses_what_is_not_one_render_and_damaged_files() {
    let dir = scratch("farm_refuse");
    let scene = cornell();
    let prism = repo("scenes/reference/prism.json").display().to_string();
    let part = |file: &str, scene: &str, extra: &[&str]| {
        let mut args = vec!["render", scene, "--width", "8", "--height", "6", "--spp", "4", "--integrator", "path"];
        args.extend(["--spectral", "bins:8", "--film", file, "-q"]);
        args.extend(extra);
        run(&dir, &args);
    };
    part("a.film", &scene, &["--part", "1/2"]);
    part("b.film", &scene, &["--part", "2/2"]);
    part("prism.film", &prism, &["--part", "2/2"]);
    part("depth.film", &scene, &["--part", "2/2", "--max-depth", "3"]);
    part("seed.film", &scene, &["--part", "2/2", "--seed", "1"]);
    part("over.film", &scene, &["--samples", "1..4"]);
    let merge = |parts: &[&str], needles: &[&str]| {
        let mut args = vec!["merge"];
        args.extend(parts);
        args.extend(["-o", "out.exr"]);
        refused(&dir, &args, 1, needles);
    };
    merge(&["a.film", "prism.film"], &["prism.film: cannot merge with a.film", "a different scene"]);
    merge(&["a.film", "depth.film"], &["depth.film", "other options", "max_depth=Some(3)"]);
    merge(&["a.film", "seed.film"], &["seed.film", "another seed (1, not 0)"]);
    merge(&["a.film", "over.film"], &["over.film: cannot merge with a.film", "overlapping sample ranges"]);
    merge(&["b.film"], &["samples 0..2 are in no part", "--allow-gaps"]);
    // With --allow-gaps the image is written, with a warning.
    let stderr = run(&dir, &["merge", "b.film", "-o", "gaps.exr", "--allow-gaps", "--variance", "v.exr"]);
    assert!(stderr.contains("warning") && stderr.contains("samples 0..2 are in no part"), "{stderr}");
    assert!(dir.join("gaps.exr").exists() && dir.join("gaps.png").exists() && dir.join("v.exr").exists());
    // Damaged films: each error names the file.
    let bytes = std::fs::read(dir.join("b.film")).unwrap();
    std::fs::write(dir.join("short.film"), &bytes[..bytes.len() - 100]).unwrap();
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 0x01;
    std::fs::write(dir.join("flipped.film"), &flipped).unwrap();
    let mut future = bytes.clone();
    future[8] = 9;
    std::fs::write(dir.join("future.film"), &future).unwrap();
    std::fs::write(dir.join("text.film"), b"hello").unwrap();
    merge(&["a.film", "short.film"], &["short.film: truncated"]);
    merge(&["a.film", "flipped.film"], &["flipped.film: corrupted: checksum"]);
    merge(&["a.film", "future.film"], &["future.film: film format version 9"]);
    merge(&["text.film"], &["text.film: not a spectrace film file"]);
    merge(&["missing.film"], &["missing.film"]);
    // A part without --film is refused before rendering.
    refused(&dir, &["render", &scene, "--part", "1/2", "--spp", "4"], 1, &["--film"]);
    refused(&dir, &["render", &scene, "--part", "3/2", "--film", "x.film"], 2, &["K/M"]);
    // Resuming another render's film is refused.
    refused(
        &dir,
        &[
            "render",
            &scene,
            "--width",
            "8",
            "--height",
            "6",
            "--spp",
            "4",
            "--integrator",
            "path",
            "--spectral",
            "bins:8",
            "--resume",
            "a.film",
            "-o",
            "r.exr",
        ],
        1,
        &["a.film: cannot resume", "samples"],
    );
}

/// Samples done in a film file (the fewest of any pixel).
fn samples_done(path: &Path) -> u32 {
    integrator::FilmFile::read(path).unwrap().film.min_sample_count()
}

#[test]
fn a_render_killed_after_a_checkpoint_resumes_to_the_same_bits() {
    let dir = scratch("farm_resume");
    let scene = cornell();
    let spp = 48;
    let args: Vec<String> =
        [&scene, "--width", "24", "--height", "18", "--spp", &spp.to_string(), "--integrator", "path"]
            .iter()
            .map(|s| s.to_string())
            .chain(["--spectral", "hero:8", "--threads", "1", "-q"].map(String::from))
            .collect();
    let render = |extra: &[&str]| {
        let mut a: Vec<&str> = vec!["render"];
        a.extend(args.iter().map(String::as_str));
        a.extend(extra);
        run(&dir, &a);
    };
    render(&["-o", "whole.exr"]);
    // A checkpoint after every pass of one sample per pixel; SIGKILL as soon as one exists.
    let mut child = spectrace()
        .current_dir(&dir)
        .arg("render")
        .args(&args)
        .args(["-o", "killed.exr", "--checkpoint", "c.film", "--checkpoint-every", "0"])
        .spawn()
        .unwrap();
    let checkpoint = dir.join("c.film");
    while !checkpoint.exists() {
        assert!(child.try_wait().unwrap().is_none(), "the render ended before its first checkpoint");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap(); // SIGKILL: no handler runs
    child.wait().unwrap();
    let done = samples_done(&checkpoint);
    assert!((1..spp).contains(&done), "killed after {done} of {spp} samples: the test needs a partial render");
    assert!(!dir.join("killed.exr").exists());
    render(&["-o", "resumed.exr", "--resume", "c.film"]);
    same_bytes(&dir, "whole.exr", "resumed.exr");
    same_bytes(&dir, "whole.png", "resumed.png");
    // A time-limited render writes a resumable film (rows the limit skipped hold one sample
    // fewer); resuming it gives the same bits too.
    render(&["--time-limit", "0.01", "--film", "t.film"]);
    assert!(samples_done(&dir.join("t.film")) < spp);
    render(&["-o", "t.exr", "--resume", "t.film"]);
    same_bytes(&dir, "whole.exr", "t.exr");
    // The comparison can fail: a render stopped by the time limit, not resumed, differs.
    render(&["--time-limit", "0.01", "-o", "short.exr"]);
    assert_ne!(std::fs::read(dir.join("short.exr")).unwrap(), std::fs::read(dir.join("whole.exr")).unwrap());
}

/// `--set` and `--frame` (docs/scene-format.md "Overrides and frames"): the same image as the edited
/// file, `{frame}` in output paths, and parts of different variations refuse to merge.
#[test]
fn set_and_frame_render_what_the_edited_file_renders() {
    let dir = scratch("farm_vary");
    let text = std::fs::read_to_string(repo("scenes/paper/five_spheres.json")).unwrap();
    // The file with its light's intensity edited, and the file with that edit as its frame 1.
    let edited = text.replacen("\"intensity\": 13441", "\"intensity\": 26882", 1);
    assert_ne!(edited, text, "the fixture's light intensity moved");
    std::fs::write(dir.join("edited.json"), &edited).unwrap();
    let framed = text.replacen(
        "\"camera\":",
        "\"frames\": [{\"lights.0.intensity\": 1}, {\"lights.0.intensity\": 26882}],\n  \"camera\":",
        1,
    );
    std::fs::write(dir.join("framed.json"), framed).unwrap();
    let base = repo("scenes/paper/five_spheres.json").display().to_string();
    let small = ["--width", "16", "--height", "12", "-q"];
    let render = |scene: &str, extra: &[&str], out: &str| {
        let mut args = vec!["render", scene, "-o", out];
        args.extend(small);
        args.extend(extra);
        run(&dir, &args)
    };
    render("edited.json", &[], "edited.exr");
    render(&base, &[], "base.exr");
    render(&base, &["--set", "lights.0.intensity=26882"], "set.exr");
    same_bytes(&dir, "edited.exr", "set.exr");
    let (a, b) = (std::fs::read(dir.join("base.exr")).unwrap(), std::fs::read(dir.join("set.exr")).unwrap());
    assert_ne!(a, b, "--set changed nothing");
    // Frame 1, with {frame} in the name; --set wins over the frame.
    render("framed.json", &["--frame", "1"], "frame{frame}.exr");
    same_bytes(&dir, "edited.exr", "frame1.exr");
    render("framed.json", &["--frame", "0", "--set", "lights.0.intensity=26882"], "frame{frame}.exr");
    same_bytes(&dir, "edited.exr", "frame0.exr");
    // Without --frame the frames are named in a warning and the file renders as written.
    let stderr = run(&dir, &["render", "framed.json", "-o", "plain.exr", "--width", "16", "--height", "12"]);
    assert!(stderr.contains("2 frame(s) defined"), "{stderr}");
    same_bytes(&dir, "base.exr", "plain.exr");
    // Bad variations are refused before anything is written, naming the file and the value.
    let refuse = |extra: &[&str], needles: &[&str]| {
        let mut args = vec!["render", "framed.json", "-o", "bad.exr"];
        args.extend(small);
        args.extend(extra);
        refused(&dir, &args, 1, needles);
    };
    refuse(&["--frame", "2"], &["framed.json", "--frame 2, but the manifest has 2 frame(s)"]);
    refuse(&["--set", "lights.3.intensity=1"], &["framed.json", "--set lights.3.intensity", "1 entries"]);
    refuse(&["--set", "camera.vfov_deg=\"wide\""], &["framed.json (after --frame/--set)"]);
    let gltf = repo("scenes/gltf/glass_torus.gltf").display().to_string();
    let mut args = vec!["render", gltf.as_str(), "--set", "a=1", "-o", "bad.exr"];
    args.extend(small);
    refused(&dir, &args, 1, &["glass_torus.gltf: --frame and --set change a manifest"]);
    refused(&dir, &["render", "--set", "novalue", "-o", "bad.exr"], 2, &["expected PATH=VALUE"]);
    // Without a scene file (the built-in default scene) there is no manifest to vary: refused, not ignored.
    let needs = "--frame needs a scene manifest with \"frames\"";
    refused(&dir, &["render", "--frame", "1", "-o", "bad.exr", "--width", "16", "--height", "12"], 1, &[needs]);
    refused(&dir, &["info", "--frame", "0"], 1, &[needs]);
    let needs = "--set needs a scene manifest";
    refused(&dir, &["render", "--set", "lights.0.intensity=1", "-o", "bad.exr"], 1, &[needs]);
    // Parts of two variations are two renders.
    for (k, value, film) in [("1/2", "26882", "a.film"), ("2/2", "26883", "b.film")] {
        let set = format!("lights.0.intensity={value}");
        run(
            &dir,
            &[
                "render", &base, "--width", "8", "--height", "6", "--spp", "2", "--set", &set, "--part", k, "--film",
                film, "-q",
            ],
        );
    }
    refused(
        &dir,
        &["merge", "a.film", "b.film", "-o", "m.exr"],
        1,
        &["b.film: cannot merge with a.film", "a different scene"],
    );
}

/// `bytes` of a film file claiming `count` non-finite samples, its checksums remade: no valid
/// scene makes them any more, but a film records them, so this is how a render or merge meets them.
fn with_nonfinite(bytes: &[u8], count: u64) -> Vec<u8> {
    let mut b = bytes.to_vec();
    // Magic, version, header length (16 bytes), then 3 u64 and 7 u32 fields before the count.
    b[68..76].copy_from_slice(&count.to_le_bytes());
    let header_end = 16 + u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let header = geometry::xxh64(&b[..header_end], 0);
    b[header_end..header_end + 8].copy_from_slice(&header.to_le_bytes());
    let end = b.len() - 8;
    let all = geometry::xxh64(&b[..end], 0);
    b[end..].copy_from_slice(&all.to_le_bytes());
    b
}

#[test]
fn non_finite_samples_are_a_warning_and_beyond_one_percent_an_error() {
    let dir = scratch("farm_nonfinite");
    let scene = cornell();
    let args = ["render", &scene, "--width", "8", "--height", "6", "--spp", "4", "--integrator", "path", "-q"];
    let args = [&args[..], &["--spectral", "bins:8"]].concat();
    run(&dir, &[&args[..], &["--part", "1/2", "--film", "a.film"]].concat());
    run(&dir, &[&args[..], &["--part", "2/2", "--film", "b.film"]].concat());
    let a = std::fs::read(dir.join("a.film")).unwrap();
    // 96 samples a part: 1 of the 192 is 0.52 %, written with a warning; 2 % is refused.
    for (name, count) in [("one.film", 1), ("four.film", 4), ("all.film", 96)] {
        std::fs::write(dir.join(name), with_nonfinite(&a, count)).unwrap();
        assert_eq!(integrator::FilmFile::read(&dir.join(name)).unwrap().film.nonfinite_samples(), count);
    }
    let stderr = run(&dir, &["merge", "one.film", "b.film", "-o", "one.exr"]);
    assert!(
        stderr.contains("spectrace: warning: 1 of 192 samples (0.521 %) were NaN or infinite and were added as black"),
        "{stderr}"
    );
    assert!(dir.join("one.exr").exists() && dir.join("one.png").exists());
    refused(
        &dir,
        &["merge", "four.film", "b.film", "-o", "four.exr", "--film", "m.film", "-q"],
        1,
        &["4 of 192 samples (2.083 %) were NaN or infinite, more than 1 %", "nothing was written"],
    );
    // A render that resumes a film holding them counts them too (here nothing is left to render).
    let resume = [&args[..], &["--part", "1/2", "--resume", "all.film", "--film", "r.film", "-o", "r.exr"]].concat();
    refused(&dir, &resume, 1, &["96 of 96 samples (100.000 %) were NaN or infinite", "nothing was written"]);
}
