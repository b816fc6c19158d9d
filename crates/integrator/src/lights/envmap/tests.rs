//! The map's orientation, its density (normalised, and matching a histogram of its samples by χ²,
//! shown to fail on a density without the sin θ Jacobian) and its decoding errors.

use std::f64::consts::PI;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::*;
use crate::sampling::Rng;

/// A `width` × `height` map with texel values that vary by column and row (a few times over), one
/// black texel, and unequal channels (so luminance, not one channel, decides).
fn test_map(width: usize, height: usize, rotation_deg: f32) -> EnvironmentMap {
    let rgb = (0..width * height)
        .map(|i| {
            let (column, row) = (i % width, i / width);
            let v = if i == 5 { 0.0 } else { 0.1 + ((column * 7 + row * 3) % 11) as f32 };
            [v, 0.5 * v, 2.0 * v]
        })
        .collect();
    EnvironmentMap::from_rgb(Path::new("<test>"), width, height, rgb, 1.0, rotation_deg).unwrap().0
}

#[test]
fn orientation_is_mitsubas_with_y_up() {
    let uv = |d: Vec3| EnvironmentMap::direction_to_uv(d);
    assert_eq!(uv(Vec3::NEG_Z), Vec2::new(0.0, 0.5));
    assert!((uv(Vec3::X) - Vec2::new(0.25, 0.5)).length() < 1e-6, "{}", uv(Vec3::X));
    assert!((uv(Vec3::Z) - Vec2::new(0.5, 0.5)).length() < 1e-6, "{}", uv(Vec3::Z));
    assert!((uv(Vec3::NEG_X) - Vec2::new(0.75, 0.5)).length() < 1e-6, "{}", uv(Vec3::NEG_X));
    assert_eq!(uv(Vec3::Y).y, 0.0);
    assert_eq!(uv(Vec3::NEG_Y).y, 1.0);
    // uv → direction → uv is the identity away from the seam.
    for &(u, v) in &[(0.1f32, 0.2f32), (0.6, 0.9), (0.33, 0.5)] {
        let (d, sin_theta) = EnvironmentMap::uv_to_direction(Vec2::new(u, v));
        assert!((d.length() - 1.0).abs() < 1e-6 && (sin_theta - (std::f32::consts::PI * v).sin()).abs() < 1e-6);
        assert!((uv(d) - Vec2::new(u, v)).length() < 1e-5, "{u} {v}: {}", uv(d));
    }
    // One bright texel at the centre of the image (u = ½, v = ½) is seen looking along +Z; turned by
    // 90° about +Y, along +X.
    let (width, height) = (8, 4);
    let mut rgb = vec![[0.0f32; 3]; width * height];
    rgb[2 * width + 4] = [1.0; 3];
    for (rotation, towards) in [(0.0, Vec3::Z), (90.0, Vec3::X), (-90.0, Vec3::NEG_X)] {
        let (map, _) =
            EnvironmentMap::from_rgb(Path::new("<test>"), width, height, rgb.clone(), 3.0, rotation).unwrap();
        // Just inside the texel's corner (it spans u ∈ [½, ⅝), v ∈ [½, ¾)).
        let (d, _) = EnvironmentMap::uv_to_direction(Vec2::new(0.51, 0.51));
        let bright = map.to_world(d);
        assert!((bright - (towards - 0.03 * Vec3::Y)).length() < 0.1, "{rotation}°: {bright}");
        assert!((map.luminance(bright) - 3.0).abs() < 1e-5, "{rotation}°");
        assert_eq!(map.luminance(-bright), 0.0);
    }
}

/// ∫ f dω over the sphere by the midpoint rule on a θ × φ grid, each cell weighted by its exact
/// solid angle.
fn integrate_sphere(rows: usize, columns: usize, f: impl Fn(Vec3) -> f64) -> f64 {
    let mut sum = 0.0;
    for i in 0..rows {
        let (t0, t1) = (PI * i as f64 / rows as f64, PI * (i + 1) as f64 / rows as f64);
        let solid_angle = 2.0 * PI / columns as f64 * (t0.cos() - t1.cos());
        for j in 0..columns {
            let uv = Vec2::new((j as f32 + 0.5) / columns as f32, (i as f32 + 0.5) / rows as f32);
            sum += f(EnvironmentMap::uv_to_direction(uv).0) * solid_angle;
        }
    }
    sum
}

#[test]
fn density_integrates_to_one_over_the_sphere() {
    for rotation in [0.0, 90.0] {
        let map = test_map(16, 8, rotation);
        // The grid is a multiple of the texels (a rotation by 90° moves them by 4 columns), so each cell is
        // inside one texel, where pdf · sin θ is constant: the midpoint rule's only error is its sinc
        // factor, 1 − Δθ²/24 ≈ 1.6e-6 at 512 rows.
        let integral = integrate_sphere(512, 1024, |w| f64::from(map.pdf(w)));
        assert!((integral - 1.0).abs() < 1e-4, "{rotation}°: ∫ pdf dω = {integral}");
    }
    // A black map is sampled uniformly over (u, v), still a density.
    let (black, _) = EnvironmentMap::from_rgb(Path::new("<test>"), 4, 2, vec![[0.0; 3]; 8], 1.0, 0.0).unwrap();
    let integral = integrate_sphere(256, 512, |w| f64::from(black.pdf(w)));
    assert!((integral - 1.0).abs() < 1e-4, "black map: {integral}");
}

/// Pearson's χ² of `counts` against `expected` probabilities (cells expecting fewer than 5 samples pooled,
/// as pbrt-v4's `ChiSquareTest`), and the critical value at significance 1e-4 for its degrees of freedom
/// (Wilson–Hilferty: χ²_crit ≈ k (1 − 2/(9k) + z √(2/(9k)))³, z = 3.719 the normal quantile of 1 − 1e-4).
fn chi_square(counts: &[u64], expected: &[f64], n: u64) -> (f64, f64) {
    let (mut chi2, mut cells) = (0.0, 0usize);
    let (mut pooled_count, mut pooled_expected) = (0.0, 0.0);
    for (&c, &p) in counts.iter().zip(expected) {
        let e = p * n as f64;
        if e < 5.0 {
            pooled_count += c as f64;
            pooled_expected += e;
        } else {
            chi2 += (c as f64 - e).powi(2) / e;
            cells += 1;
        }
    }
    if pooled_expected > 0.0 {
        chi2 += (pooled_count - pooled_expected).powi(2) / pooled_expected;
        cells += 1;
    }
    let k = (cells - 1) as f64;
    let z = 3.719;
    (chi2, k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3))
}

/// Probability of each texel under the density `pdf` (by texels, rows first), integrated on a 16 × 16
/// sub-grid per texel.
fn texel_probabilities(map: &EnvironmentMap, pdf: &dyn Fn(Vec3) -> f64) -> Vec<f64> {
    let (width, height) = map.size();
    let sub = 16;
    let mut out = Vec::with_capacity(width * height);
    for row in 0..height {
        for column in 0..width {
            let mut sum = 0.0;
            for i in 0..sub {
                let (t0, t1) = (
                    PI * (row * sub + i) as f64 / (height * sub) as f64,
                    PI * (row * sub + i + 1) as f64 / (height * sub) as f64,
                );
                let solid_angle = 2.0 * PI / (width * sub) as f64 * (t0.cos() - t1.cos());
                for j in 0..sub {
                    let uv = Vec2::new(
                        ((column * sub + j) as f32 + 0.5) / (width * sub) as f32,
                        ((row * sub + i) as f32 + 0.5) / (height * sub) as f32,
                    );
                    sum += pdf(map.to_world(EnvironmentMap::uv_to_direction(uv).0)) * solid_angle;
                }
            }
            out.push(sum);
        }
    }
    out
}

/// Histogram of `n` samples of the map over its texels.
fn histogram(map: &EnvironmentMap, n: u64) -> Vec<u64> {
    let (width, height) = map.size();
    let mut counts = vec![0u64; width * height];
    for i in 0..n {
        let mut rng = Rng::new(7, 0, i);
        let Some((w, pdf)) = map.sample(rng.uniform2()) else { continue };
        assert!(pdf > 0.0 && pdf.is_finite() && (w.length() - 1.0).abs() < 1e-5);
        // The density a sample reports is the density `pdf` gives its direction.
        assert!((pdf / map.pdf(w) - 1.0).abs() < 1e-3, "{pdf} vs {}", map.pdf(w));
        let (column, row) = map.texel_of(EnvironmentMap::direction_to_uv(map.to_local(w)));
        counts[row * width + column] += 1;
    }
    counts
}

#[test]
fn samples_follow_the_density_by_chi_square_and_a_density_without_sin_theta_fails() {
    let map = test_map(16, 8, 30.0);
    let n = 200_000;
    let counts = histogram(&map, n);
    assert_eq!(counts[5], 0, "the black texel is never sampled");

    let right = texel_probabilities(&map, &|w| f64::from(map.pdf(w)));
    assert!((right.iter().sum::<f64>() - 1.0).abs() < 1e-4);
    let (chi2, critical) = chi_square(&counts, &right, n);
    assert!(chi2 < critical, "χ² = {chi2} ≥ {critical}: samples do not follow pdf");

    // The same density without the Jacobian of the lat-long mapping (luminance × sin θ per unit
    // solid angle instead of luminance alone), renormalised: χ² must reject it.
    let without_jacobian = |w: Vec3| {
        let d = map.to_local(w);
        f64::from(map.pdf(w)) * f64::from((d.x * d.x + d.z * d.z).sqrt())
    };
    let norm = integrate_sphere(512, 1024, without_jacobian);
    let wrong: Vec<f64> = texel_probabilities(&map, &|w| without_jacobian(w) / norm);
    assert!((wrong.iter().sum::<f64>() - 1.0).abs() < 1e-3);
    let (chi2_wrong, critical_wrong) = chi_square(&counts, &wrong, n);
    eprintln!("χ²: right pdf {chi2:.1}, without sin θ {chi2_wrong:.1} (critical {critical:.1}, {critical_wrong:.1})");
    assert!(chi2_wrong > 10.0 * critical_wrong, "χ² = {chi2_wrong} should reject the density without sin θ");
}

#[test]
fn non_finite_and_negative_texels_become_black_and_are_counted() {
    let rgb = vec![[1.0, 1.0, 1.0], [f32::NAN, 1.0, 1.0], [f32::INFINITY, 0.0, 0.0], [-1.0, 2.0, 2.0]];
    let (map, bad) = EnvironmentMap::from_rgb(Path::new("<test>"), 2, 2, rgb, 2.0, 0.0).unwrap();
    assert_eq!(bad, 3);
    let Texels::Rgb(texels) = &map.texels else { panic!("an RGB map") };
    assert!(texels.iter().all(|t| t.rgb.iter().all(|c| c.is_finite() && *c >= 0.0)));
    assert_eq!(texels[0].rgb, [2.0; 3]);
    assert!(texels[1..].iter().all(|t| t.rgb == [0.0; 3]));
    // Only the top-left quarter of the sphere shines: the mean is a quarter of its 2 (rows of equal solid
    // angle), and only it is sampled.
    assert!(map.mean_rgb().iter().all(|&m| (m - 0.5).abs() < 1e-6), "{:?}", map.mean_rgb());
    for i in 0..1000 {
        let mut rng = Rng::new(1, 0, i);
        let (w, _) = map.sample(rng.uniform2()).unwrap();
        assert_eq!(map.luminance(w), 2.0 * (0.2126 + 0.7152 + 0.0722));
    }
}

#[test]
fn unreadable_or_malformed_files_are_errors_naming_the_file() {
    let dir = std::env::temp_dir().join(format!("spectrace-envmap-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut warnings = Vec::new();
    let cases = [
        ("missing.hdr", None),
        ("garbage.hdr", Some(&b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 2\n\x01"[..])),
        ("garbage.exr", Some(&b"not an exr file at all"[..])),
        ("empty.exr", Some(&b""[..])),
        ("picture.png", Some(&b"\x89PNG"[..])),
    ];
    for (name, bytes) in cases {
        let path = dir.join(name);
        if let Some(b) = bytes {
            std::fs::write(&path, b).unwrap();
        }
        match EnvironmentMap::load(&path, 1.0, 0.0, &mut geometry::MemoryBudget::default(), &mut warnings) {
            Err(e @ Error::EnvironmentMap { .. }) => {
                let message = e.to_string();
                assert!(message.contains(name), "{name}: {message}");
                eprintln!("{message}");
            }
            other => panic!("{name}: expected an environment-map error, got {other:?}"),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
