//! `spectrace color` end to end: published values and errors.

use std::process::Command;

fn color(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_spectrace")).arg("color").args(args).output().unwrap()
}

fn fixture(name: &str) -> String {
    format!("{}/../../tests/e2e/fixtures/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn lines(output: &std::process::Output) -> Vec<serde_json::Value> {
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8_lossy(&output.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

#[test]
fn perfect_white_under_d65_is_the_cie_white_point_and_srgb_white() {
    // CIE 015:2018: D65 2° white XYZ (95.047, 100, 108.883), xy (0.31272, 0.32903); sRGB 255.
    let out = lines(&color(&[&fixture("three_patches.csv"), "--column", "white"]));
    assert_eq!(out.len(), 1);
    let xyz: Vec<f64> = out[0]["XYZ"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!(
        (xyz[0] - 95.047).abs() < 0.02 && (xyz[1] - 100.0).abs() < 1e-9 && (xyz[2] - 108.883).abs() < 0.02,
        "{xyz:?}"
    );
    let xy = out[0]["xy"].as_array().unwrap();
    assert!((xy[0].as_f64().unwrap() - 0.31272).abs() < 3e-5);
    assert_eq!(out[0]["srgb8"], serde_json::json!([255, 255, 255]));
}

#[test]
fn grey_is_neutral_under_every_illuminant_after_adaptation() {
    // A flat 50 % reflector under A, F11 or D50, adapted to D65 by Bradford, is a neutral
    // grey: linear sRGB (0.5, 0.5, 0.5) to within the adaptation's rounding (1e-6).
    for ill in ["A", "F11", "D50", "E", "D9300", "bb3000"] {
        let out = lines(&color(&[&fixture("three_patches.csv"), "--column", "grey50", "--illuminant", ill]));
        for c in out[0]["srgb_linear"].as_array().unwrap() {
            assert!((c.as_f64().unwrap() - 0.5).abs() < 1e-6, "{ill}: {}", out[0]);
        }
        assert!((out[0]["XYZ"][1].as_f64().unwrap() - 50.0).abs() < 1e-9);
    }
}

#[test]
fn every_column_and_the_10_degree_observer() {
    let out = lines(&color(&[&fixture("three_patches.csv"), "--observer", "10", "--step", "5"]));
    assert_eq!(out.iter().map(|o| o["name"].as_str().unwrap()).collect::<Vec<_>>(), ["white", "grey50", "blue"]);
    // D65 10° white: XYZ (94.811, 100, 107.304) (CIE 015:2018), here summed at 5 nm.
    assert!((out[0]["XYZ"][0].as_f64().unwrap() - 94.811).abs() < 0.05, "{}", out[0]);
    // The blue patch is blue: b > r, g in 8 bits.
    let rgb = out[2]["srgb8"].as_array().unwrap();
    assert!(rgb[2].as_u64() > rgb[0].as_u64() && rgb[2].as_u64() > rgb[1].as_u64(), "{}", out[2]);
}

#[test]
fn bad_input_names_the_file_and_line() {
    let out = color(&[&fixture("unsorted.csv")]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("unsorted.csv:4") && stderr.contains("must increase"), "{stderr}");
    let out = color(&[&fixture("three_patches.csv"), "--illuminant", "F99"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("unknown illuminant `F99`"));
    let out = color(&[&fixture("three_patches.csv"), "--column", "nope"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("no column `nope`"));
    let out = color(&[&fixture("missing.csv")]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("missing.csv"));
}
