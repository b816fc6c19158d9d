//! The BSDF test suite: χ² goodness of fit of every non-delta lobe, discrete checks of the
//! delta lobes, energy (albedo ≤ 1, furnace), reciprocity and named hard cases.

use std::f32::consts::PI;

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};

use super::compensation::{conductor_table, dielectric_albedo, dielectric_table, mirror_albedos};
use super::test_support::{Chi2Config, Chi2Result, TestRng, chi2_test, mean_and_standard_error, sidak};
use super::*;

pub(super) const FRAME: Frame = Frame { n: Vec3::Z, ns: Vec3::Z };

/// The roughness grid and incident angles (degrees from the normal) the BSDFs are tested at.
pub(super) const ALPHAS: [f32; 4] = [0.05, 0.2, 0.5, 1.0];
pub(super) const ANGLES: [f32; 4] = [0.0, 30.0, 60.0, 85.0];

/// A direction θ degrees from +z (−z when `below`), azimuth 0.3 rad so anisotropic lobes
/// are not seen along an axis.
pub(super) fn incident(theta_deg: f32, below: bool) -> Vec3 {
    let t = theta_deg.to_radians();
    let phi = 0.3f32;
    let z = if below { -t.cos() } else { t.cos() };
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), z).normalize()
}

/// ∫ f(ω_i) dω_i over the +z hemisphere: the midpoint rule on an n × n grid in (θ, φ).
fn hemisphere_quadrature(n: usize, f: impl Fn(Vec3) -> f32) -> f64 {
    let (dtheta, dphi) = (f64::from(0.5 * PI / n as f32), f64::from(2.0 * PI / n as f32));
    let mut sum = 0.0f64;
    for i in 0..n {
        let theta = (i as f32 + 0.5) / n as f32 * 0.5 * PI;
        for j in 0..n {
            let phi = (j as f32 + 0.5) / n as f32 * 2.0 * PI;
            let wi = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            sum += f64::from(f(wi) * theta.sin()) * dtheta * dphi;
        }
    }
    sum
}

/// f(ωo, ωi) = f(ωi, ωo) to 1e-4 relative (plus 1e-7) over `count` random pairs above the surface.
pub(super) fn assert_reciprocal<const N: usize>(bsdf: &Bsdf<N>, count: usize, rng: &mut TestRng) {
    for _ in 0..count {
        let (a, b) = (rng.sphere(), rng.sphere());
        let (wo, wi) = (Vec3::new(a.x, a.y, a.z.abs()), Vec3::new(b.x, b.y, b.z.abs()));
        let (f1, f2) = (bsdf.f(&FRAME, wo, wi).0[0], bsdf.f(&FRAME, wi, wo).0[0]);
        assert!((f1 - f2).abs() <= 1e-4 * f1.abs().max(f2.abs()) + 1e-7, "{bsdf:?}: {wo} {wi}: {f1} vs {f2}");
    }
}

/// χ² of a BSDF's sampling against its pdf, seen from `wo`; a finer first integration grid
/// for sharp lobes.
pub(super) fn chi2_bsdf<const N: usize>(bsdf: &Bsdf<N>, wo: Vec3, alpha: f32, seed: u64) -> Chi2Result {
    let sub = if alpha < 0.1 { 8 } else { 4 };
    let cfg = Chi2Config { sub, seed, ..Chi2Config::default() };
    chi2_test(cfg, |uc, u| bsdf.sample_f(&FRAME, wo, uc, u).map(|s| s.wi), |wi| bsdf.pdf(&FRAME, wo, wi))
}

/// Run a family of χ² tests, each at Šidák's corrected level, and report all failures at once.
pub(super) fn chi2_family<const N: usize>(cases: &[(String, Bsdf<N>, Vec3, f32)]) {
    let level = sidak(cases.len());
    let mut failures = Vec::new();
    let mut smallest = (f64::INFINITY, "");
    for (i, (name, bsdf, wo, alpha)) in cases.iter().enumerate() {
        let r = chi2_bsdf(bsdf, *wo, *alpha, 1000 + i as u64);
        if r.p_value < smallest.0 {
            smallest = (r.p_value, name);
        }
        if !(r.p_value >= level) {
            failures.push(format!(
                "{name}: χ² = {:.1}, dof {}, p = {:.2e} < {level:.2e}, {} samples in cells of pdf 0",
                r.statistic, r.dof, r.p_value, r.in_empty_cells
            ));
        }
    }
    // For the report (`--nocapture`): the family's size, level and weakest case.
    eprintln!("χ² family of {}: Šidák level {level:.2e}, smallest p {:.3} ({})", cases.len(), smallest.0, smallest.1);
    assert!(failures.is_empty(), "{} of {} χ² tests failed:\n{}", failures.len(), cases.len(), failures.join("\n"));
}

fn conductor(ax: f32, ay: f32, compensate: bool) -> Bsdf<1> {
    // Gold-like at 600 nm (J&C: n ≈ 0.25, k ≈ 3.07).
    Bsdf::Conductor(ConductorBxdf::new(
        TrowbridgeReitz::new(ax, ay),
        SampledSpectrum([0.25]),
        SampledSpectrum([3.07]),
        compensate,
    ))
}

fn rough_glass(ax: f32, ay: f32, compensate: bool) -> Bsdf<1> {
    Bsdf::RoughDielectric(RoughDielectricBxdf::new(
        TrowbridgeReitz::new(ax, ay),
        1.5,
        SampledSpectrum([1.0]),
        compensate,
    ))
}

// ---------------------------------------------------------------------------------------
// The harness can fail.

#[test]
fn chi2_rejects_a_wrong_pdf() {
    // Cosine-weighted sampling judged against the uniform-hemisphere pdf 1/2π: a wrong pdf
    // that integrates to 1, so only the shape is wrong.
    let cfg = Chi2Config::default();
    let r = chi2_test(
        cfg,
        |_, u| Some(cosine_hemisphere(Vec3::Z, u)),
        |w| if w.z > 0.0 { 0.5 * std::f32::consts::FRAC_1_PI } else { 0.0 },
    );
    assert!(r.p_value < 1e-12, "{r:?}");
    // A subtler error: GGX samples at α = 0.5 judged by the pdf of α = 0.55 (10 % off).
    let (good, off) = (conductor(0.5, 0.5, false), conductor(0.55, 0.55, false));
    let wo = incident(30.0, false);
    let r = chi2_test(cfg, |uc, u| good.sample_f(&FRAME, wo, uc, u).map(|s| s.wi), |wi| off.pdf(&FRAME, wo, wi));
    assert!(r.p_value < sidak(100), "a 10 % roughness error passed: {r:?}");
    // And the right pdf passes the same test.
    let r = chi2_test(cfg, |uc, u| good.sample_f(&FRAME, wo, uc, u).map(|s| s.wi), |wi| good.pdf(&FRAME, wo, wi));
    assert!(r.p_value > sidak(1), "{r:?}");
}

// ---------------------------------------------------------------------------------------
// χ² of every non-delta lobe.

#[test]
fn chi2_lambertian() {
    let bsdf = Bsdf::Lambertian { r: SampledSpectrum([0.8]) };
    let cases: Vec<_> = ANGLES
        .iter()
        .flat_map(|&t| {
            [false, true].map(|below| (format!("Lambertian θ {t} below {below}"), bsdf, incident(t, below), 1.0))
        })
        .collect();
    chi2_family(&cases);
}

/// A model's χ² cases over the roughness grid × incident angles, in the order α, θ, lobe,
/// side: `lobes(α)` lists (name, lobe, its sharpest α, whether to test it from below too).
fn grid_cases(lobes: impl Fn(f32) -> Vec<(String, Bsdf<1>, f32, bool)>) -> Vec<(String, Bsdf<1>, Vec3, f32)> {
    let mut cases = Vec::new();
    for &a in &ALPHAS {
        for &t in &ANGLES {
            for (name, bsdf, sharpest, both_sides) in lobes(a) {
                for below in [false, true] {
                    if below && !both_sides {
                        continue;
                    }
                    let side = if below { " from inside" } else { "" };
                    cases.push((format!("{name} θ {t}{side}"), bsdf, incident(t, below), sharpest));
                }
            }
        }
    }
    cases
}

/// The sheen lobe samples the hemisphere uniformly: χ² checks that `pdf` says so and that `sample_f`
/// stays above the surface, at the sharpest and the broadest roughness.
#[test]
fn chi2_sheen() {
    let cases: Vec<_> = [MIN_SHEEN_ROUGHNESS, 0.5, 1.0]
        .iter()
        .flat_map(|&r| {
            let bsdf = Bsdf::Sheen(SheenBxdf::new(SampledSpectrum([0.8]), r));
            ANGLES.iter().map(move |&t| (format!("sheen r {r} θ {t}"), bsdf, incident(t, false), 1.0))
        })
        .collect();
    chi2_family(&cases);
}

#[test]
fn chi2_rough_conductor_isotropic_anisotropic_compensated() {
    chi2_family(&grid_cases(|a| {
        vec![
            (format!("conductor α {a}"), conductor(a, a, false), a, false),
            (format!("conductor α ({a}, {})", 0.4 * a), conductor(a, 0.4 * a, false), 0.4 * a, false),
            (format!("conductor α {a} compensated"), conductor(a, a, true), a, false),
        ]
    }));
}

/// (Compensation scales the dielectric's f by 1/E(μ_o) and leaves its sampling and pdf alone,
/// so the compensated lobe has the same χ² test as this one.)
#[test]
fn chi2_rough_dielectric_from_both_sides() {
    chi2_family(&grid_cases(|a| {
        vec![
            (format!("glass α {a}"), rough_glass(a, a, false), a, true),
            (format!("glass α ({a}, {})", 0.4 * a), rough_glass(a, 0.4 * a, false), 0.4 * a, false),
        ]
    }));
}

// ---------------------------------------------------------------------------------------
// Delta lobes: discrete probabilities.

/// Share of `n` samples for which `pick` holds, and its binomial standard deviation for `p`.
fn share(n: u32, p: f64, mut pick: impl FnMut() -> bool) -> (f64, f64) {
    let hits = (0..n).filter(|_| pick()).count();
    (hits as f64 / f64::from(n), (p * (1.0 - p) / f64::from(n)).sqrt())
}

#[test]
fn smooth_dielectric_reflects_with_the_fresnel_probability() {
    let bsdf = Bsdf::Dielectric { eta: 1.5, tint: SampledSpectrum([1.0; 4]) };
    let mut rng = TestRng::new(3);
    for (theta, below) in [(0.0, false), (45.0, false), (80.0, false), (30.0, true), (41.0, true), (60.0, true)] {
        let wo = incident(theta, below);
        let f = f64::from(crate::scattering::fr_dielectric(wo.z, 1.5));
        let (s, sd) = share(20_000, f, || {
            let s = bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()).unwrap();
            s.wi.z * wo.z > 0.0
        });
        assert!((s - f).abs() <= 5.0 * sd + 1e-9, "θ {theta} inside {below}: {s} vs F = {f}");
        if theta >= 60.0 && below {
            assert_eq!(f, 1.0, "past the critical angle everything reflects");
        }
    }
    // The transmitted ray goes straight through at normal incidence and carries 1/η².
    let t = bsdf.sample_f(&FRAME, Vec3::Z, 0.99, Vec2::ZERO).unwrap();
    assert!((t.wi + Vec3::Z).length() < 1e-6);
    assert!((t.weight.0[0] - 1.0 / 2.25).abs() < 1e-6 && (t.eta_scale - 2.25).abs() < 1e-6);
    assert!(t.flags.is_transmissive() && t.flags.is_specular());
}

#[test]
fn thin_dielectric_reflects_with_the_slab_probability_and_does_not_bend() {
    let bsdf = Bsdf::ThinDielectric(ThinDielectricBxdf::new(1.5, SampledSpectrum([0.9; 4])));
    let mut rng = TestRng::new(4);
    for theta in [0.0, 45.0, 80.0] {
        let wo = incident(theta, false);
        let r = f64::from(crate::scattering::fr_dielectric(wo.z, 1.5));
        // Slab: R' = R + T² R / (1 − R²) = 2R / (1 + R).
        let slab = 2.0 * r / (1.0 + r);
        let (s, sd) =
            share(20_000, slab, || bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()).unwrap().wi.z > 0.0);
        assert!((s - slab).abs() <= 5.0 * sd, "θ {theta}: {s} vs {slab}");
    }
    let wo = incident(30.0, false);
    let t = bsdf.sample_f(&FRAME, wo, 0.999, Vec2::ZERO).unwrap();
    assert!((t.wi + wo).length() < 1e-6 && t.eta_scale == 1.0 && (t.weight.0[0] - 0.9).abs() < 1e-6);
    // At normal incidence on η = 1.5: R = 0.04, R' = 0.08 / 1.04 = 0.0769.
    assert!((ThinDielectricBxdf::<1>::new(1.5, SampledSpectrum([1.0])).reflectance(1.0) - 0.076_923).abs() < 1e-5);
}

#[test]
fn smooth_conductor_and_mirror_reflect_by_fresnel_and_r() {
    let wo = incident(60.0, false);
    let c = Bsdf::Conductor(ConductorBxdf::new(
        TrowbridgeReitz::isotropic(0.0),
        SampledSpectrum([0.25, 1.5]),
        SampledSpectrum([3.07, 0.0]),
        true,
    ));
    assert!(c.is_specular() && c.flags().is_specular());
    let s = c.sample_f(&FRAME, wo, 0.5, Vec2::splat(0.5)).unwrap();
    assert!((s.wi - reflect(wo, Vec3::Z)).length() < 1e-6);
    for i in 0..2 {
        let expected = [crate::scattering::fr_conductor(wo.z, 0.25, 3.07), fr_dielectric(wo.z, 1.5)][i];
        assert!((s.weight.0[i] - expected).abs() < 1e-6);
    }
    let m = Bsdf::Mirror { r: SampledSpectrum([0.7]) };
    let s = m.sample_f(&FRAME, wo, 0.5, Vec2::ZERO).unwrap();
    assert!(s.flags.is_specular() && s.weight.0[0] == 0.7 && (s.wi - reflect(wo, Vec3::Z)).length() < 1e-6);
}

#[test]
fn smooth_conductor_falls_back_to_the_geometric_mirror_like_mirror() {
    // Shading normal tilted 40° towards +x; wo is above both normals, but its mirror image
    // about the shading normal lies below the geometric surface: Mirror (and the glTF delta
    // layer) reflect about the geometric normal instead, and so must the smooth conductor.
    let frame = Frame { n: Vec3::Z, ns: Vec3::new(40f32.to_radians().sin(), 0.0, 40f32.to_radians().cos()) };
    let wo = Vec3::new(-0.6, 0.0, 0.8);
    assert!(wo.dot(frame.ns) > 0.0 && reflect(wo, frame.ns).z < 0.0, "the case needs the fallback");
    let mirror = Bsdf::Mirror { r: SampledSpectrum([1.0]) }.sample_f(&frame, wo, 0.5, Vec2::ZERO).unwrap();
    let c = conductor(0.0, 0.0, false);
    let s = c.sample_f(&frame, wo, 0.5, Vec2::ZERO).expect("a smooth conductor reflects like a mirror");
    assert_eq!(s.wi, mirror.wi);
    assert!(s.wi.z > 0.0 && s.flags.is_specular() && s.weight.0[0] > 0.0 && s.weight.0[0] <= 1.0, "{s:?}");
    let g = gltf(1.0, 1.0, 0.0).sample_f(&frame, wo, 0.5, Vec2::ZERO).unwrap();
    assert_eq!(g.wi, mirror.wi);
}

// ---------------------------------------------------------------------------------------
// Energy.

/// Directional albedo ∫ f |cos| dω_i with refraction's radiance scaling undone (it moves
/// radiance between media; it creates no energy): mean and standard error of the weights.
pub(super) fn albedo<const N: usize>(bsdf: &Bsdf<N>, wo: Vec3, count: usize, rng: &mut TestRng) -> (f64, f64) {
    mean_and_standard_error(count, || match bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()) {
        Some(s) => {
            assert!(s.weight.is_finite() && s.wi.is_finite(), "{bsdf:?} at {wo}: {s:?}");
            f64::from(s.weight.max_component() * s.eta_scale)
        }
        None => 0.0,
    })
}

#[test]
fn every_bsdf_reflects_no_more_than_it_receives() {
    // Each model from 60 directions over the whole sphere, 2000 samples each. The smooth
    // lobes' estimator is bounded by 1 sample-wise (weights F/F, (1−F)T/(1−F) or R), so any
    // mean above 1 + 1e-5 would be a real gain; the rough ones must not exceed 1 by more than
    // 4 standard errors plus the compensation tables' interpolation error (1 %).
    let mut rng = TestRng::new(42);
    let white = SampledSpectrum([1.0; 4]);
    let models = [
        (Bsdf::Lambertian { r: SampledSpectrum([1.0, 0.5, 0.2, 0.0]) }, 1e-5),
        (Bsdf::Mirror { r: SampledSpectrum([1.0, 0.9, 0.8, 0.7]) }, 1e-5),
        (Bsdf::Dielectric { eta: 1.5, tint: white }, 1e-5),
        (Bsdf::Dielectric { eta: 1.33, tint: SampledSpectrum([0.9, 0.8, 0.7, 0.6]) }, 1e-5),
        (Bsdf::Dielectric { eta: 0.0, tint: white }, 1e-5),
        (Bsdf::ThinDielectric(ThinDielectricBxdf::new(1.5, white)), 1e-5),
        (Bsdf::Conductor(ConductorBxdf::from_reflectance(white, TrowbridgeReitz::isotropic(0.6), false)), 0.0),
        (Bsdf::Conductor(ConductorBxdf::from_reflectance(white, TrowbridgeReitz::new(0.3, 0.9), true)), 0.01),
        (Bsdf::RoughDielectric(RoughDielectricBxdf::new(TrowbridgeReitz::isotropic(0.4), 1.5, white, false)), 0.0),
        (Bsdf::RoughDielectric(RoughDielectricBxdf::new(TrowbridgeReitz::isotropic(0.7), 1.5, white, true)), 0.01),
        (Bsdf::Sheen(SheenBxdf::new(white, MIN_SHEEN_ROUGHNESS)), 0.0),
        (gltf_anisotropic(1.0, 0.0, 0.2, 1.0), 0.0),
        (gltf_anisotropic(1.0, 1.0, 0.0, 1.0), 0.0),
        (Bsdf::Sheen(SheenBxdf::new(white, 1.0)), 0.0),
        (Bsdf::GltfMetalRough(GltfMetalRoughBxdf::new(white, 1.0, 0.6, 1.5).compensated()), 0.01),
        (Bsdf::GltfMetalRough(GltfMetalRoughBxdf::new(white, 0.4, 0.9, 1.5).compensated()), 0.01),
        (gltf_compensated_anisotropic(1.0, 0.5, 0.5, 0.8), 0.01),
    ];
    for (bsdf, slack) in &models {
        for _ in 0..60 {
            let wo = rng.sphere();
            if wo.z.abs() < 1e-3 {
                continue;
            }
            let (a, se) = albedo(bsdf, wo, 2000, &mut rng);
            assert!(a <= 1.0 + slack + 4.0 * se + 1e-6, "{bsdf:?} at {wo}: albedo {a} ± {se}");
        }
    }
}

#[test]
fn white_lambertian_albedo_is_one_and_f_matches_pdf() {
    let bsdf = Bsdf::Lambertian { r: SampledSpectrum([1.0; 4]) };
    let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
    let mut rng = TestRng::new(1);
    for _ in 0..1000 {
        let s = bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()).expect("above the surface");
        // f cos / pdf = R exactly, and eval agrees with sample.
        let f = bsdf.f_cos(&FRAME, wo, s.wi);
        assert!((f.0[0] / s.pdf - 1.0).abs() < 1e-4);
        assert!((bsdf.pdf(&FRAME, wo, s.wi) - s.pdf).abs() < 1e-6);
        assert!((bsdf.f(&FRAME, wo, s.wi).0[0] - std::f32::consts::FRAC_1_PI).abs() < 1e-7);
    }
    // Lit from below: nothing reflected towards wo.
    assert_eq!(bsdf.f_cos(&FRAME, wo, -Vec3::Z).0, [0.0; 4]);
}

#[test]
fn rough_lobes_sample_weights_equal_f_cos_over_pdf() {
    // sample_f's weight, pdf and the separately evaluated f·cos and pdf agree.
    let mut rng = TestRng::new(9);
    let white = SampledSpectrum([1.0; 4]);
    let lobes = [
        Bsdf::Conductor(ConductorBxdf::new(
            TrowbridgeReitz::new(0.3, 0.1),
            SampledSpectrum([0.2; 4]),
            SampledSpectrum([3.0; 4]),
            true,
        )),
        Bsdf::RoughDielectric(RoughDielectricBxdf::new(TrowbridgeReitz::new(0.3, 0.5), 1.5, white, true)),
        Bsdf::Sheen(SheenBxdf::new(white, 0.3)),
        gltf_anisotropic(0.8, 0.3, 0.4, 0.9),
        gltf_compensated_anisotropic(0.8, 0.3, 0.6, 0.9),
        Bsdf::GltfMetalRough(gltf_specular(0.8, 0.7, 0.6, [0.1; 4], 0.3).compensated()),
    ];
    for bsdf in &lobes {
        let mut checked = 0;
        for _ in 0..2000 {
            let wo = rng.sphere();
            let Some(s) = bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()) else { continue };
            let (f, pdf) = (bsdf.f_cos(&FRAME, wo, s.wi), bsdf.pdf(&FRAME, wo, s.wi));
            assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{bsdf:?} {wo} {s:?}: pdf {pdf}");
            let w = f.0[0] / pdf;
            assert!((w - s.weight.0[0]).abs() <= 1e-3 * w.max(1e-3), "{bsdf:?} {wo} {s:?}: f cos/pdf {w}");
            checked += 1;
        }
        assert!(checked > 1000);
    }
}

#[test]
fn compensation_tables_agree_with_brute_force_quadrature() {
    // E(μ, α) of a white GGX mirror by midpoint quadrature of f·cos over the hemisphere
    // (θ_i, φ_i, 400 × 400), against the table; and the dielectric E through its own
    // estimator with 4× the table's strata.
    for (mu, alpha) in [(0.9f32, 0.5f32), (0.3, 1.0), (0.6, 0.25), (0.1, 0.75)] {
        let d = TrowbridgeReitz::isotropic(alpha);
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let e = hemisphere_quadrature(400, |wi| {
            let wm = (wo + wi).normalize();
            d.d(wm) * d.g(wo, wi) / (4.0 * wo.z * wi.z) * wi.z
        });
        let table = conductor_table().e(mu, alpha);
        assert!((table as f64 - e).abs() < 3e-3, "μ {mu} α {alpha}: table {table}, quadrature {e}");
        assert!((mirror_albedos(&d, wo, 96).0 as f64 - e).abs() < 2e-3);
        for below in [false, true] {
            let w = if below { -wo } else { wo };
            let reference = dielectric_albedo(&d, w, 1.5, 64);
            let table = dielectric_table().e(mu, alpha, 1.5, below);
            assert!((table - reference).abs() < 0.01, "μ {mu} α {alpha} inside {below}: {table} vs {reference}");
        }
    }
}

#[test]
fn white_ggx_albedo_at_alpha_one_is_one_minus_ln_two() {
    // At α = 1, D = 1/π and, from the normal, G = 2μ_i / (1 + μ_i), so
    // E(1, 1) = ∫ G / (4π) dω_i = ∫₀¹ μ / (1 + μ) dμ · 2 / 2 = 1 − ln 2 (derived here, exact).
    let exact = 1.0 - std::f32::consts::LN_2;
    assert!((conductor_table().e(1.0, 1.0) - exact).abs() < 2e-3, "{}", conductor_table().e(1.0, 1.0));
    assert!((mirror_albedos(&TrowbridgeReitz::isotropic(1.0), Vec3::Z, 96).0 - exact).abs() < 1e-3);
}

/// Furnace: albedo of a white conductor and of clear glass (from outside) over α × angle,
/// with and without compensation. Printed for the report (`--nocapture`).
#[test]
fn furnace_white_conductor_and_glass_stay_white_with_compensation() {
    let white = SampledSpectrum([1.0]);
    let mut rng = TestRng::new(77);
    let mut table = String::from("lobe | α | θ | E uncompensated | E compensated\n");
    for &a in &ALPHAS {
        for &t in &ANGLES {
            let wo = incident(t, false);
            for (name, plain, comp) in [
                (
                    "conductor",
                    Bsdf::Conductor(ConductorBxdf::from_reflectance(white, TrowbridgeReitz::isotropic(a), false)),
                    Bsdf::Conductor(ConductorBxdf::from_reflectance(white, TrowbridgeReitz::isotropic(a), true)),
                ),
                (
                    "glass 1.5",
                    Bsdf::RoughDielectric(RoughDielectricBxdf::new(TrowbridgeReitz::isotropic(a), 1.5, white, false)),
                    Bsdf::RoughDielectric(RoughDielectricBxdf::new(TrowbridgeReitz::isotropic(a), 1.5, white, true)),
                ),
            ] {
                let (e0, se0) = albedo(&plain, wo, 40_000, &mut rng);
                let (e1, se1) = albedo(&comp, wo, 40_000, &mut rng);
                table += &format!("{name} | {a} | {t}° | {e0:.4} ± {se0:.4} | {e1:.4} ± {se1:.4}\n");
                // Compensated: white within 1.5 % (tables) plus 4 standard errors.
                assert!((e1 - 1.0).abs() < 0.015 + 4.0 * se1, "{name} α {a} θ {t}: compensated {e1} ± {se1}");
                // Uncompensated never gains and loses visibly at α = 1.
                assert!(e0 < 1.0 + 4.0 * se0, "{name} α {a} θ {t}: {e0}");
                if a == 1.0 {
                    assert!(e0 < 0.95, "{name} α 1 θ {t}: single scattering should lose energy, got {e0}");
                }
            }
        }
    }
    println!("{table}");
}

// ---------------------------------------------------------------------------------------
// Reciprocity.

#[test]
fn reflection_lobes_are_reciprocal() {
    // f(ωo, ωi) = f(ωi, ωo) for every reflection lobe that should be: Lambertian, the rough
    // conductor with and without the Kulla–Conty lobe (reciprocal by construction) and the
    // uncompensated rough dielectric's reflection. (Turquin's 1/E(μo) scaling of the
    // compensated dielectric is not reciprocal, a known property of that method.) The glTF model's
    // multiple-scattering lobe and its diffuse coupling are products of one factor per direction.
    let mut rng = TestRng::new(11);
    let lobes = [
        Bsdf::Lambertian { r: SampledSpectrum([0.7]) },
        conductor(0.3, 0.3, false),
        conductor(0.2, 0.6, false),
        conductor(0.5, 0.5, true),
        rough_glass(0.4, 0.2, false),
        Bsdf::Sheen(SheenBxdf::new(SampledSpectrum([0.7]), 0.4)),
        gltf_anisotropic(0.7, 0.5, 0.3, 0.7),
        oriented_glass(0.5, 0.15),
        gltf_compensated(0.7, 1.0, 0.8),
        gltf_compensated(0.7, 0.5, 0.4),
        gltf_compensated_anisotropic(0.7, 0.3, 0.5, 0.7),
        Bsdf::GltfMetalRough(gltf_specular(0.6, 0.5, 0.6, [0.1], 0.3).compensated()),
        Bsdf::GltfMetalRough(GltfMetalRoughBxdf::clearcoat(0.6).compensated()),
    ];
    for bsdf in &lobes {
        assert_reciprocal(bsdf, 2000, &mut rng);
    }
}

// ---------------------------------------------------------------------------------------
// Hard cases: no NaN or Inf anywhere.

/// Evaluate and sample `bsdf` from `wo` with many random numbers; everything must be finite.
pub(super) fn assert_all_finite<const N: usize>(bsdf: &Bsdf<N>, wo: Vec3, rng: &mut TestRng) {
    for _ in 0..500 {
        let wi = rng.sphere();
        let (f, p) = (bsdf.f_cos(&FRAME, wo, wi), bsdf.pdf(&FRAME, wo, wi));
        assert!(f.is_finite() && p.is_finite() && p >= 0.0, "{bsdf:?} {wo} {wi}: {f:?} {p}");
        if let Some(s) = bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()) {
            assert!(
                s.wi.is_finite() && s.weight.is_finite() && s.pdf.is_finite() && s.eta_scale.is_finite(),
                "{bsdf:?} {wo}: {s:?}"
            );
            assert!((s.wi.length() - 1.0).abs() < 1e-3, "{s:?}");
        }
    }
    for u in [Vec2::ZERO, Vec2::new(0.999_999_94, 0.999_999_94), Vec2::new(0.5, 0.0)] {
        for uc in [0.0, 0.999_999_94] {
            if let Some(s) = bsdf.sample_f(&FRAME, wo, uc, u) {
                assert!(s.wi.is_finite() && s.weight.is_finite() && s.pdf.is_finite(), "{bsdf:?} {wo} {u}: {s:?}");
            }
        }
    }
}

#[test]
fn hard_case_alpha_to_zero_falls_back_to_smooth() {
    let mut rng = TestRng::new(21);
    for alpha in [0.0f32, 1e-7, 1e-4, 9.99e-4, 1e-3, 1.001e-3, 3e-3] {
        for compensate in [false, true] {
            let c = conductor(alpha, alpha, compensate);
            let g = rough_glass(alpha, alpha, compensate);
            assert_eq!(c.is_specular(), alpha < 1e-3, "α {alpha}");
            assert_eq!(g.is_specular(), alpha < 1e-3, "α {alpha}");
            for t in [0.0, 45.0, 89.0] {
                for below in [false, true] {
                    assert_all_finite(&c, incident(t, below), &mut rng);
                    assert_all_finite(&g, incident(t, below), &mut rng);
                }
            }
        }
    }
    // The smooth fallback of rough glass is the smooth dielectric, sample for sample.
    let (rough, smooth) = (rough_glass(1e-4, 1e-4, true), Bsdf::Dielectric { eta: 1.5, tint: SampledSpectrum([1.0]) });
    for uc in [0.01, 0.5, 0.99] {
        let wo = incident(50.0, false);
        let (a, b) =
            (rough.sample_f(&FRAME, wo, uc, Vec2::ZERO).unwrap(), smooth.sample_f(&FRAME, wo, uc, Vec2::ZERO).unwrap());
        assert_eq!((a.wi, a.weight.0, a.pdf), (b.wi, b.weight.0, b.pdf));
    }
}

#[test]
fn hard_case_grazing_directions() {
    let mut rng = TestRng::new(22);
    let grazing =
        [Vec3::X, Vec3::new(1.0, 0.0, 1e-6).normalize(), Vec3::new(0.0, 1.0, -1e-4).normalize(), incident(89.9, false)];
    for &a in &ALPHAS {
        for bsdf in [
            conductor(a, a, true),
            conductor(a, 0.3 * a, false),
            rough_glass(a, a, true),
            rough_glass(a, 0.3 * a, false),
        ] {
            for wo in grazing {
                assert_all_finite(&bsdf, wo, &mut rng);
            }
        }
    }
}

#[test]
fn hard_case_total_internal_reflection_inside_rough_glass() {
    // From inside η = 1.5 past the critical angle (41.8°): most microfacets reflect totally.
    // Nothing non-finite, energy conserved, and at α = 0.05, 18° past it, almost everything
    // reflects.
    let mut rng = TestRng::new(23);
    for &a in &ALPHAS {
        for t in [45.0, 60.0, 85.0] {
            let wo = incident(t, true);
            for compensate in [false, true] {
                let g = rough_glass(a, a, compensate);
                assert_all_finite(&g, wo, &mut rng);
                let (e, se) = albedo(&g, wo, 4000, &mut rng);
                assert!(e <= 1.0 + 0.015 + 4.0 * se, "α {a} θ {t}: {e}");
            }
            if a == 0.05 && t >= 60.0 {
                let g = rough_glass(a, a, false);
                let reflected = (0..2000)
                    .filter_map(|_| g.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()))
                    .filter(|s| s.wi.z < 0.0)
                    .count();
                assert!(reflected > 1900, "θ {t}: {reflected} of 2000 reflected");
            }
        }
    }
}

#[test]
fn shading_normals_never_leak_light_through_the_geometric_surface() {
    // A shading normal tilted 40° from the geometric one: reflection must stay on wo's side of
    // the geometric surface, transmission must cross it.
    let frame = Frame { n: Vec3::Z, ns: Vec3::new(0.64, 0.0, 0.77).normalize() };
    let mut rng = TestRng::new(31);
    let lobes =
        [conductor(0.5, 0.5, true), rough_glass(0.5, 0.5, true), Bsdf::Lambertian { r: SampledSpectrum([1.0]) }];
    for bsdf in &lobes {
        for _ in 0..4000 {
            let wo = rng.sphere();
            let Some(s) = bsdf.sample_f(&frame, wo, rng.uniform(), rng.uniform2()) else { continue };
            let same_side = s.wi.z * wo.z > 0.0;
            assert_eq!(same_side, s.flags.is_reflective(), "{bsdf:?} {wo}: {s:?}");
            let (f, p) = (bsdf.f_cos(&frame, wo, s.wi), bsdf.pdf(&frame, wo, s.wi));
            assert!(f.is_finite() && p > 0.0, "{bsdf:?} {wo}: sampled direction has pdf {p}");
        }
    }
}

#[test]
fn reflections_have_a_value_in_the_terminator_wedge_that_sampling_never_returns() {
    // Shading normal tilted 40° from the geometric one: directions below the geometric surface but
    // above the shading one (the shadow terminator's wedge) have a value for the reflection models
    // (light sampling covers them; the shadow ray decides), a density of 0 (BSDF sampling never
    // returns them: `shading_normals_never_leak_light_through_the_geometric_surface`), so MIS gives
    // light sampling all the weight there. Below the shading surface: no value at all. Rough glass
    // keeps no value in the wedge (its pair would be a transmission to the geometry).
    let frame = Frame { n: Vec3::Z, ns: Vec3::new(0.64, 0.0, 0.77).normalize() };
    let wo = Vec3::new(-0.3, 0.0, 0.95).normalize();
    let wedge = Vec3::new(0.99, 0.0, -0.1).normalize();
    let below = Vec3::new(-0.5, 0.0, -0.5).normalize();
    assert!(wedge.dot(frame.n) < 0.0 && wedge.dot(frame.ns) > 0.0 && below.dot(frame.ns) < 0.0);
    let reflections = [Bsdf::Lambertian { r: SampledSpectrum([0.8]) }, conductor(0.5, 0.5, true), gltf(0.8, 0.0, 0.5)];
    for bsdf in &reflections {
        let f = bsdf.f_cos(&frame, wo, wedge).0[0];
        assert!(f > 0.0 && f.is_finite(), "{bsdf:?}: f cos in the wedge {f}");
        assert!(bsdf.f(&frame, wo, wedge).0[0] > 0.0, "{bsdf:?}: f in the wedge");
        assert_eq!(bsdf.pdf(&frame, wo, wedge), 0.0, "{bsdf:?}: pdf in the wedge");
        assert_eq!(bsdf.f_cos(&frame, wo, below).0[0], 0.0, "{bsdf:?}: below the shading surface");
        // Above both surfaces both are positive, as before.
        let up = Vec3::new(0.2, 0.1, 0.97).normalize();
        assert!(bsdf.f_cos(&frame, wo, up).0[0] > 0.0 && bsdf.pdf(&frame, wo, up) > 0.0, "{bsdf:?}");
    }
    let glass = rough_glass(0.5, 0.5, true);
    assert_eq!(glass.f_cos(&frame, wo, wedge).0[0], 0.0, "rough glass in the wedge");
}

// ---------------------------------------------------------------------------------------
// The glTF metallic–roughness BRDF.

fn gltf(base: f32, metallic: f32, roughness: f32) -> Bsdf<1> {
    Bsdf::GltfMetalRough(GltfMetalRoughBxdf::new(SampledSpectrum([base]), metallic, roughness, 1.5))
}

/// `KHR_materials_anisotropy` on the glTF model: strength `strength` along the direction 30° counter-clockwise
/// from local x (so the lobe's frame is neither the default basis nor seen along an axis).
fn gltf_anisotropic<const N: usize>(base: f32, metallic: f32, roughness: f32, strength: f32) -> Bsdf<N> {
    let g = GltfMetalRoughBxdf::new(SampledSpectrum([base; N]), metallic, roughness, 1.5);
    Bsdf::GltfMetalRough(g.with_anisotropy(strength, anisotropy_direction()).conserving())
}

/// The compensated glTF model (what the path tracer builds by default).
fn gltf_compensated(base: f32, metallic: f32, roughness: f32) -> Bsdf<1> {
    Bsdf::GltfMetalRough(GltfMetalRoughBxdf::new(SampledSpectrum([base]), metallic, roughness, 1.5).compensated())
}

/// [`gltf_anisotropic`] compensated.
fn gltf_compensated_anisotropic<const N: usize>(base: f32, metallic: f32, roughness: f32, strength: f32) -> Bsdf<N> {
    let g = GltfMetalRoughBxdf::new(SampledSpectrum([base; N]), metallic, roughness, 1.5);
    Bsdf::GltfMetalRough(g.with_anisotropy(strength, anisotropy_direction()).compensated())
}

fn anisotropy_direction() -> Vec3 {
    Vec3::new(30f32.to_radians().cos(), 30f32.to_radians().sin(), 0.0)
}

/// The anisotropic direction's 16-bit octahedral code ([`Direction`]) round-trips every unit vector, both
/// hemispheres and the poles and axes, to within 1e-4 rad; zero and non-finite vectors are no direction.
#[test]
fn octahedral_directions_round_trip() {
    let mut rng = TestRng::new(11);
    let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(1.0, -1.0, -1.0).normalize()];
    let random = (0..10_000).map(|_| {
        let (u, v) = (rng.uniform(), rng.uniform());
        let z = 1.0 - 2.0 * u;
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * (2.0 * PI * v).cos(), r * (2.0 * PI * v).sin(), z)
    });
    for w in axes.into_iter().chain(random) {
        let back = Direction::new(w).get().expect("a unit vector has a direction");
        assert!((back.length() - 1.0).abs() < 1e-5, "{w} → {back}");
        // (The angle from the cross product: its cosine rounds to 1 in f32.)
        let angle = w.cross(back).length().atan2(w.dot(back));
        assert!(angle < 1e-4, "{w} → {back}: {angle} rad");
    }
    for w in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 0.0)] {
        assert_eq!(Direction::new(w), Direction::NONE, "{w}");
    }
}

/// Rough glass stretched along a direction (`KHR_materials_anisotropy` on a transmitting glTF material).
fn oriented_glass(ax: f32, ay: f32) -> Bsdf<1> {
    let glass = RoughDielectricBxdf::new(TrowbridgeReitz::new(ax, ay), 1.5, SampledSpectrum([1.0]), false);
    Bsdf::RoughDielectric(glass.along(anisotropy_direction()))
}

#[test]
fn chi2_oriented_rough_dielectric_from_both_sides() {
    chi2_family(&grid_cases(|a| {
        vec![(format!("oriented glass α ({a}, {})", 0.4 * a), oriented_glass(a, 0.4 * a), 0.4 * a, true)]
    }));
}

/// An oriented lobe is the default-frame lobe turned: f of the glass stretched along direction t, at (wo, wi),
/// equals f of the same distribution in the default basis at (wo, wi) rotated so that t lands on that
/// basis' x axis (here the basis about +z is (x, y), so the rotation is −30° about z).
#[test]
fn an_oriented_dielectric_is_the_default_lobe_turned_to_its_direction() {
    let (ax, ay) = (0.6, 0.1);
    let oriented = oriented_glass(ax, ay);
    let plain = rough_glass(ax, ay, false);
    let (x, y) = crate::sampling::basis(Vec3::Z);
    assert!((x - Vec3::X).length() < 1e-6 && (y - Vec3::Y).length() < 1e-6, "the default basis about +z");
    let turn = glam::Quat::from_rotation_z(-30f32.to_radians());
    let mut rng = TestRng::new(5);
    let mut differs = 0;
    for _ in 0..2000 {
        let wo = cosine_hemisphere(Vec3::Z, rng.uniform2());
        let below = cosine_hemisphere(Vec3::Z, rng.uniform2());
        for wi in [cosine_hemisphere(Vec3::Z, rng.uniform2()), -below] {
            let got = oriented.f(&FRAME, wo, wi).0[0];
            let want = plain.f(&FRAME, turn * wo, turn * wi).0[0];
            assert!((got - want).abs() <= 2e-3 * want.max(1.0), "f({wo}, {wi}) = {got}, turned {want}");
            let unturned = plain.f(&FRAME, wo, wi).0[0];
            if (unturned - want).abs() > 0.1 * want.max(1e-3) {
                differs += 1;
            }
        }
    }
    assert!(differs > 500, "only {differs} pairs where the orientation matters");
}

#[test]
fn chi2_gltf_anisotropic() {
    chi2_family(&grid_cases(|a| {
        [(0.0, 0.5), (1.0, 1.0)]
            .map(|(m, s)| {
                (
                    format!("glTF anisotropic metallic {m} strength {s} α {a}"),
                    gltf_anisotropic(0.8, m, a.sqrt(), s),
                    a,
                    false,
                )
            })
            .to_vec()
    }));
}

/// The anisotropic metal against the extension's own formulas (its README's `D_GGX_anisotropic` and
/// `V_GGX_anisotropic`, with F = 1 for a white metal), in the frame of its direction: the lobe is stretched
/// along the direction (α_t = mix(α, 1, strength²)) and not across it.
#[test]
fn anisotropic_metal_is_the_extensions_ggx_along_its_direction() {
    let (roughness, strength) = (0.3f32, 0.8f32);
    let alpha = roughness * roughness;
    let (at, ab) = (alpha + (1.0 - alpha) * strength * strength, alpha);
    let n = Vec3::Z;
    let t = anisotropy_direction();
    let b = n.cross(t);
    let reference = |l: Vec3, v: Vec3| {
        let h = (l + v).normalize();
        let a2 = at * ab;
        let f = Vec3::new(ab * t.dot(h), at * b.dot(h), a2 * n.dot(h));
        let w2 = a2 / f.dot(f);
        let d = a2 * w2 * w2 / PI;
        let ggx_v = n.dot(l) * Vec3::new(at * t.dot(v), ab * b.dot(v), n.dot(v)).length();
        let ggx_l = n.dot(v) * Vec3::new(at * t.dot(l), ab * b.dot(l), n.dot(l)).length();
        d * 0.5 / (ggx_v + ggx_l)
    };
    let bsdf = Bsdf::GltfMetalRough(
        GltfMetalRoughBxdf::new(SampledSpectrum([1.0]), 1.0, roughness, 1.5).with_anisotropy(strength, t),
    );
    let mut rng = TestRng::new(7);
    for _ in 0..2000 {
        let wo = cosine_hemisphere(n, rng.uniform2());
        let wi = cosine_hemisphere(n, rng.uniform2());
        let (got, want) = (bsdf.f(&FRAME, wo, wi).0[0], reference(wi, wo));
        // (The direction is stored to 16 bits: 2e-3 of a sharp lobe's value.)
        assert!((got - want).abs() <= 2e-3 * want.max(1.0), "f({wo}, {wi}) = {got}, the extension's {want}");
    }
    // Along the direction the highlight is wider: a view 20° off the mirror direction along t sees more
    // than one 20° off across it.
    let wi = Vec3::Z;
    let off = |axis: Vec3| n * 20f32.to_radians().cos() + axis * 20f32.to_radians().sin();
    let (f_along, f_across) = (bsdf.f(&FRAME, off(t), wi).0[0], bsdf.f(&FRAME, off(b), wi).0[0]);
    assert!(f_along > 3.0 * f_across, "along {f_along}, across {f_across}");
}

#[test]
fn chi2_gltf_metal_rough() {
    // roughness = √α for the α grid (`ALPHAS`).
    chi2_family(&grid_cases(|a| {
        [0.0, 0.5, 1.0].map(|m| (format!("glTF metallic {m} α {a}"), gltf(0.8, m, a.sqrt()), a, false)).to_vec()
    }));
}

#[test]
fn gltf_metal_rough_matches_the_spec_formula() {
    // From the normal to the normal at roughness 1 (α = 1): V·H = 1, D = 1/π, G = 1, so
    // specular_brdf = D / 4 = 1/(4π); dielectric F = 0.04 (ior 1.5).
    // metallic 0, base 0.5: (1 − 0.04) · 0.5/π + 0.04/(4π) = 0.49/π.
    let f = gltf(0.5, 0.0, 1.0).f(&FRAME, Vec3::Z, Vec3::Z).0[0];
    assert!((f - 0.49 / PI).abs() < 1e-6, "{f}");
    // metallic 1, base 0.8: conductor_fresnel = 0.8 at V·H = 1: 0.8/(4π).
    let f = gltf(0.8, 1.0, 1.0).f(&FRAME, Vec3::Z, Vec3::Z).0[0];
    assert!((f - 0.8 / (4.0 * PI)).abs() < 1e-6, "{f}");
    // Off-specular pair at roughness 0.5 (α = 0.25), metallic 0.3, base 0.6, written out from
    // Appendix B with its own D and V formulas.
    let (wo, wi) = (incident(40.0, false), Vec3::new(-0.3, 0.2, 0.9).normalize());
    let (alpha, m, base) = (0.25f32, 0.3f32, 0.6f32);
    let h = (wo + wi).normalize();
    let (nl, nv, nh, vh) = (wi.z, wo.z, h.z, wo.dot(h));
    let a2 = alpha * alpha;
    let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let v = 0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
    let spec = d * v;
    let fr = 0.04 + 0.96 * (1.0 - vh).powi(5);
    let dielectric = (1.0 - fr) * base / PI + fr * spec;
    let metal = (base + (1.0 - base) * (1.0 - vh).powi(5)) * spec;
    let expected = (1.0 - m) * dielectric + m * metal;
    let f = gltf(base, m, 0.5).f(&FRAME, wo, wi).0[0];
    assert!((f - expected).abs() < 1e-5 * expected, "{f} vs {expected}");
}

#[test]
fn gltf_metal_rough_conserves_energy_is_reciprocal_and_finite() {
    let mut rng = TestRng::new(61);
    for roughness in [0.0, 0.01, 0.2, 0.6, 1.0] {
        for m in [0.0, 0.4, 1.0] {
            let bsdf = gltf(1.0, m, roughness);
            for t in [0.0, 45.0, 85.0, 89.9] {
                let wo = incident(t, false);
                // The metal part conserves energy; the dielectric part does not at grazing
                // angles (see `gltf_dielectric_part_gains_energy_at_grazing_as_the_spec_says`).
                if m == 1.0 || t <= 45.0 {
                    let (e, se) = albedo(&bsdf, wo, 4000, &mut rng);
                    let slack = if m < 1.0 { 1e-3 } else { 1e-5 };
                    assert!(e <= 1.0 + slack + 4.0 * se, "roughness {roughness} metallic {m} θ {t}: {e} ± {se}");
                }
                assert_all_finite(&bsdf, wo, &mut rng);
                assert_all_finite(&bsdf, incident(t, true), &mut rng);
            }
            assert_reciprocal(&bsdf, 500, &mut rng);
        }
    }
    // A smooth white metal is a perfect mirror: every sample reflects with weight 1.
    let mirror = gltf(1.0, 1.0, 0.0);
    assert!(mirror.is_specular());
    let s = mirror.sample_f(&FRAME, incident(30.0, false), 0.5, Vec2::splat(0.5)).unwrap();
    assert!(s.flags.is_specular() && (s.weight.0[0] - 1.0).abs() < 1e-6);
    // Smooth plastic has a diffuse part: not purely specular, so light sampling applies.
    assert!(!gltf(0.5, 0.0, 0.0).is_specular());
}

#[test]
fn gltf_dielectric_part_gains_energy_at_grazing_as_the_spec_says() {
    // Appendix B's fresnel_mix weights the diffuse layer by 1 − F(V·H) for each light
    // direction while the specular layer reflects about F(N·V): at grazing view the two sum to
    // more than 1. For smooth white plastic the albedo is exactly
    // A(μ_o) = F(μ_o) + ∫ (1 − F(V·H)) cos θ_i / π dω_i; quadrature (400 × 400) against the
    // sampled estimate. (The model is implemented as the spec writes it; this measures its gain.)
    let schlick = |c: f32| 0.04 + 0.96 * (1.0 - c).powi(5);
    let mut rng = TestRng::new(62);
    for (t, expected_min) in [(45.0f32, 1.0f64), (85.0, 1.5)] {
        let wo = incident(t, false);
        let a = f64::from(schlick(wo.z))
            + hemisphere_quadrature(400, |wi| (1.0 - schlick(wo.dot((wo + wi).normalize()))) / PI * wi.z);
        let (e, se) = albedo(&gltf(1.0, 0.0, 0.0), wo, 20_000, &mut rng);
        assert!((e - a).abs() < 4.0 * se + 2e-3, "θ {t}: sampled {e} ± {se}, quadrature {a}");
        assert!(a >= expected_min, "θ {t}: {a}");
    }
}

#[test]
fn gltf_energy_conserving_variant_keeps_a_white_dielectric_white() {
    // White plastic (metallic 0) in a furnace: exactly 1 up to the tables' error, at every
    // roughness and angle (the spec's coupling reaches 1.59 at 85°); reciprocal; the metal
    // part is unchanged; same sampling, so the spec model's χ² test covers it.
    let mut rng = TestRng::new(63);
    for roughness in [0.0f32, 0.2, 0.5, 1.0] {
        let b =
            Bsdf::GltfMetalRough(GltfMetalRoughBxdf::energy_conserving(SampledSpectrum([1.0]), 0.0, roughness, 1.5));
        for &t in &ANGLES {
            let (e, se) = albedo(&b, incident(t, false), 20_000, &mut rng);
            assert!((e - 1.0).abs() < 0.01 + 4.0 * se, "roughness {roughness} θ {t}: {e} ± {se}");
            assert_all_finite(&b, incident(t, false), &mut rng);
        }
        assert_reciprocal(&b, 500, &mut rng);
        let metal = |c: bool| {
            let base = SampledSpectrum([0.7]);
            let m = if c {
                GltfMetalRoughBxdf::energy_conserving(base, 1.0, roughness, 1.5)
            } else {
                GltfMetalRoughBxdf::new(base, 1.0, roughness, 1.5)
            };
            Bsdf::GltfMetalRough(m).f(&FRAME, incident(30.0, false), Vec3::new(0.1, 0.2, 0.97).normalize()).0[0]
        };
        assert_eq!(metal(true), metal(false));
    }
}

/// Angles of the glTF furnace tests (degrees from the normal), up to 80°.
const FURNACE_ANGLES: [f32; 5] = [0.0, 30.0, 50.0, 70.0, 80.0];

#[test]
fn gltf_default_material_is_white_in_a_furnace_compensated_and_one_minus_ln_two_without() {
    // glTF's default material (§3.9.6: base colour white, metallic 1, roughness 1, so α = 1) is a white
    // GGX mirror. Single scattering (`conserving`, the path tracer with `multiple_scattering` off) reflects
    // the tables' E(μ, 1): 1 − ln 2 = 0.307 at normal view (`white_ggx_albedo_at_alpha_one_is_one_minus_ln_two`);
    // compensated, 1 up to the tables' interpolation (1.5 %) at every angle. Likewise a white metal at
    // roughness 0.5 (α = 0.25), which loses 5–15 % in single scattering.
    let mut rng = TestRng::new(67);
    let white = SampledSpectrum([1.0]);
    for roughness in [1.0f32, 0.5] {
        let alpha = roughness * roughness;
        let off = Bsdf::GltfMetalRough(GltfMetalRoughBxdf::new(white, 1.0, roughness, 1.5).conserving());
        let on = gltf_compensated(1.0, 1.0, roughness);
        for t in FURNACE_ANGLES {
            let wo = incident(t, false);
            let (e_on, se_on) = albedo(&on, wo, 40_000, &mut rng);
            assert!((e_on - 1.0).abs() < 0.015 + 4.0 * se_on, "roughness {roughness} θ {t}: {e_on} ± {se_on}");
            let (e_off, se_off) = albedo(&off, wo, 40_000, &mut rng);
            let table = f64::from(conductor_table().e(wo.z, alpha));
            assert!((e_off - table).abs() < 0.01 + 4.0 * se_off, "off, θ {t}: {e_off} ± {se_off} vs E = {table}");
            if roughness == 1.0 && t == 0.0 {
                let exact = 1.0 - std::f64::consts::LN_2;
                assert!((e_off - exact).abs() < 0.005 + 4.0 * se_off, "off at normal view: {e_off} vs 1 − ln 2");
            }
            if roughness == 0.5 {
                assert!(e_off < 0.96 && e_off > 0.84, "off, roughness 0.5, θ {t}: {e_off}");
            }
        }
    }
}

#[test]
fn gltf_compensated_white_dielectric_and_mixes_stay_white_and_never_exceed_one() {
    // metallic 0 and 0.5, white: the compensated specular layer takes from the diffuse one exactly what
    // it adds, so the model reflects 1 (tables: 1.5 %) and never more, at every roughness and angle; also
    // under `KHR_materials_specular` (its strongest wavelength white) and stretched by
    // `KHR_materials_anisotropy` (≤ 1: the tables at the smaller α lose a little there).
    let mut rng = TestRng::new(68);
    for roughness in [0.0f32, 0.2, 0.5, 0.8, 1.0] {
        for m in [0.0f32, 0.5] {
            let b = gltf_compensated(1.0, m, roughness);
            for t in FURNACE_ANGLES.into_iter().chain([85.0]) {
                let (e, se) = albedo(&b, incident(t, false), 20_000, &mut rng);
                assert!((e - 1.0).abs() < 0.015 + 4.0 * se, "roughness {roughness} metallic {m} θ {t}: {e} ± {se}");
                assert_all_finite(&b, incident(t, false), &mut rng);
            }
        }
        let specular = Bsdf::GltfMetalRough(gltf_specular(1.0, roughness, 0.7, [0.3], 0.3).compensated());
        let stretched: Bsdf<1> = gltf_compensated_anisotropic(1.0, 0.3, roughness, 0.9);
        let single: Bsdf<1> = gltf_anisotropic(1.0, 0.3, roughness, 0.9);
        for t in FURNACE_ANGLES {
            let (e, se) = albedo(&specular, incident(t, false), 20_000, &mut rng);
            assert!((e - 1.0).abs() < 0.015 + 4.0 * se, "specular, roughness {roughness} θ {t}: {e} ± {se}");
            let (e, se) = albedo(&stretched, incident(t, false), 20_000, &mut rng);
            let (e_single, se_single) = albedo(&single, incident(t, false), 20_000, &mut rng);
            eprintln!("anisotropic roughness {roughness} θ {t}: {e:.4} compensated, {e_single:.4} single");
            assert!(e < 1.01 + 4.0 * se, "anisotropic, roughness {roughness} θ {t}: {e} ± {se}");
            assert!(e > e_single - 4.0 * (se + se_single), "roughness {roughness} θ {t}: {e} vs {e_single}");
        }
    }
}

/// Per-lane albedo of `bsdf` from `wo`: the mean of `sample_f`'s weights, lane by lane.
fn lane_albedos<const N: usize>(bsdf: &Bsdf<N>, wo: Vec3, count: usize, rng: &mut TestRng) -> [f64; N] {
    let mut sum = [0.0f64; N];
    for _ in 0..count {
        if let Some(s) = bsdf.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()) {
            for (sum, w) in sum.iter_mut().zip(s.weight.0) {
                *sum += f64::from(w);
            }
        }
    }
    sum.map(|s| s / count as f64)
}

#[test]
fn gltf_compensated_coloured_metals_reflect_no_more_than_their_colour_allows() {
    // A metal of colour b (lanes 0.2, 0.5, 0.8) with Schlick's Fresnel reflects F_avg(b) = b + (1 − b)/21
    // of white light averaged over the hemisphere (2 ∫ F μ dμ): Kulla–Conty's lobe brings the
    // cosine-weighted average of its albedo up to F_avg E_avg + F_ms (1 − E_avg) ≤ F_avg (equal iff
    // F_avg = 1), never above. Per view angle the albedo is at most b at normal view (microfacets seen
    // head-on), but exceeds b towards grazing (Schlick's F → 1 there, even for the smooth metal: 0.84 for
    // b = 0.8, α 0.05 at 75°, 0.82 uncompensated); per angle it stays below the white metal's 1 and above
    // the uncompensated albedo (the lobe only adds).
    let colours = [0.2f32, 0.5, 0.8];
    let mut rng = TestRng::new(69);
    // 8-point Gauss–Legendre on μ ∈ [0, 1]: (μ, weight).
    let gauss = super::conductor::GAUSS_LEGENDRE_8.map(|(mu, w)| (mu, f64::from(w)));
    for roughness in [0.2f32, 0.5, 1.0] {
        let g = GltfMetalRoughBxdf::new(SampledSpectrum(colours), 1.0, roughness, 1.5);
        let (on, off) = (Bsdf::GltfMetalRough(g.compensated()), Bsdf::GltfMetalRough(g.conserving()));
        let mut average = [0.0f64; 3];
        for &(mu, w) in &gauss {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (a_on, a_off) = (lane_albedos(&on, wo, 20_000, &mut rng), lane_albedos(&off, wo, 20_000, &mut rng));
            for l in 0..3 {
                average[l] += 2.0 * f64::from(mu) * w * a_on[l];
                // Statistical slack: a weight is at most ~2 here, so 20 000 samples give σ < 0.01.
                assert!(a_on[l] <= 1.0 + 0.01, "roughness {roughness} μ {mu} lane {l}: {}", a_on[l]);
                assert!(a_on[l] >= a_off[l] - 0.02, "roughness {roughness} μ {mu} lane {l}: {a_on:?} vs {a_off:?}");
            }
        }
        let normal = lane_albedos(&on, Vec3::Z, 40_000, &mut rng);
        let t = conductor_table();
        let alpha = roughness * roughness;
        let (e_avg, e2_avg) = (f64::from(t.e_avg(alpha)), f64::from(t.e_schlick_avg(alpha)));
        for (l, &b) in colours.iter().enumerate() {
            let b = f64::from(b);
            let f_avg = b + (1.0 - b) / 21.0;
            // Kulla–Conty's value: single scattering's b E_avg + (1 − b) E₂,avg, plus F_ms (1 − E_avg).
            let f_ms = f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg));
            let expected = b * e_avg + (1.0 - b) * e2_avg + f_ms * (1.0 - e_avg);
            eprintln!(
                "roughness {roughness} colour {b}: average {:.4}, expected {expected:.4}, F_avg {f_avg:.4}",
                average[l]
            );
            assert!(
                (average[l] - expected).abs() < 0.01,
                "roughness {roughness} lane {l}: {} vs {expected}",
                average[l]
            );
            assert!(
                average[l] <= f_avg + 0.005,
                "roughness {roughness} lane {l}: average {} > F_avg {f_avg}",
                average[l]
            );
            assert!(normal[l] <= b + 0.01, "roughness {roughness} lane {l} at normal view: {}", normal[l]);
        }
    }
}

#[test]
fn chi2_gltf_compensated() {
    // The cosine lobe samples the multiple-scattering lobe too (for a pure metal it is the only one it
    // samples): the pdf must include it. Roughness 0.2, 0.5, 1 (α 0.04, 0.25, 1) × metallic 0, 0.5, 1 ×
    // `ANGLES`, and the extensions' forms.
    let mut cases = Vec::new();
    for roughness in [0.2f32, 0.5, 1.0] {
        let alpha = roughness * roughness;
        for m in [0.0, 0.5, 1.0] {
            for &t in &ANGLES {
                let name = format!("glTF compensated metallic {m} roughness {roughness} θ {t}");
                cases.push((name, gltf_compensated(0.8, m, roughness), incident(t, false), alpha));
            }
        }
        for &t in &[0.0f32, 60.0] {
            let (specular, stretched) = (
                Bsdf::GltfMetalRough(gltf_specular(0.8, roughness, 0.6, [0.1], 0.3).compensated()),
                gltf_compensated_anisotropic(0.8, 0.5, roughness, 0.8),
            );
            cases.push((
                format!("glTF specular compensated roughness {roughness} θ {t}"),
                specular,
                incident(t, false),
                alpha,
            ));
            cases.push((
                format!("glTF anisotropic compensated roughness {roughness} θ {t}"),
                stretched,
                incident(t, false),
                alpha,
            ));
            let coat = Bsdf::GltfMetalRough(GltfMetalRoughBxdf::clearcoat(roughness).compensated());
            cases.push((
                format!("clear coat compensated roughness {roughness} θ {t}"),
                coat,
                incident(t, false),
                alpha,
            ));
        }
    }
    chi2_family(&cases);
}

#[test]
fn gltf_compensation_leaves_smooth_models_and_the_uncompensated_lobe_alone() {
    // `compensated` of a smooth model is `conserving` (no microfacet layer to compensate); and `conserving`
    // (the path tracer with `multiple_scattering` off) is the model as it was before compensation existed:
    // the spec's layers with the albedo-scaled diffuse coupling, checked against that formula.
    let mut rng = TestRng::new(70);
    let base = SampledSpectrum([0.6]);
    for m in [0.0f32, 0.5, 1.0] {
        let (on, off) = (
            GltfMetalRoughBxdf::new(base, m, 0.0, 1.5).compensated(),
            GltfMetalRoughBxdf::new(base, m, 0.0, 1.5).conserving(),
        );
        for _ in 0..200 {
            let (a, b) = (rng.sphere(), rng.sphere());
            let (wo, wi) = (Vec3::new(a.x, a.y, a.z.abs()), Vec3::new(b.x, b.y, b.z.abs()));
            assert_eq!(on.f(wo, wi).0, off.f(wo, wi).0);
            assert_eq!(on.pdf(wo, wi), off.pdf(wo, wi));
        }
    }
    let (alpha, m, b) = (0.25f32, 0.3f32, 0.6f32);
    let off = GltfMetalRoughBxdf::new(SampledSpectrum([b]), m, alpha.sqrt(), 1.5).conserving();
    let t = conductor_table();
    let e_s = |mu: f32| 0.04 * t.e(mu, alpha) + 0.96 * t.e_schlick(mu, alpha);
    let e_s_avg = 0.04 * t.e_avg(alpha) + 0.96 * t.e_schlick_avg(alpha);
    for _ in 0..200 {
        let (a, c) = (rng.sphere(), rng.sphere());
        let (wo, wi) = (Vec3::new(a.x, a.y, a.z.abs()), Vec3::new(c.x, c.y, c.z.abs()));
        let (spec, vh) = appendix_b_specular(wo, wi, alpha);
        let fr = 0.04 + 0.96 * (1.0 - vh).powi(5);
        let metal = b + (1.0 - b) * (1.0 - vh).powi(5);
        let diffuse = (1.0 - e_s(wo.z)) * (1.0 - e_s(wi.z)) / (1.0 - e_s_avg) * b / PI;
        let expected = (1.0 - m) * (diffuse + fr * spec) + m * metal * spec;
        let f = off.f(wo, wi).0[0];
        assert!((f - expected).abs() <= 1e-5 * expected.max(1e-3), "{wo} {wi}: {f} vs {expected}");
    }
}

/// The glTF model with `KHR_materials_specular`: F0 per lane `f0`, its largest over the spectrum `f0_max`.
fn gltf_specular<const N: usize>(
    base: f32,
    roughness: f32,
    weight: f32,
    f0: [f32; N],
    f0_max: f32,
) -> GltfMetalRoughBxdf<N> {
    GltfMetalRoughBxdf::new(SampledSpectrum([base; N]), 0.0, roughness, 1.5).with_specular(
        weight,
        SampledSpectrum(f0),
        f0_max,
    )
}

/// Appendix B's `specular_brdf` = D · V (its own formulas) and V·H, for a pair above the surface.
fn appendix_b_specular(wo: Vec3, wi: Vec3, alpha: f32) -> (f32, f32) {
    let h = (wo + wi).normalize();
    let (nl, nv, nh) = (wi.z, wo.z, h.z);
    let a2 = alpha * alpha;
    let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let v = 0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
    (d * v, wo.dot(h))
}

#[test]
fn gltf_specular_extension_is_the_formula_its_defaults_the_plain_model() {
    let mut rng = TestRng::new(64);
    let (base, roughness) = (0.6f32, 0.5f32);
    let plain = GltfMetalRoughBxdf::new(SampledSpectrum([base]), 0.0, roughness, 1.5);
    // The defaults (factor 1, white: F0 = 0.04 in every lane) are the plain model.
    let defaults = gltf_specular(base, roughness, 1.0, [0.04], 0.04);
    for _ in 0..200 {
        let (a, b) = (rng.sphere(), rng.sphere());
        let (wo, wi) = (Vec3::new(a.x, a.y, a.z.abs()), Vec3::new(b.x, b.y, b.z.abs()));
        for (x, y) in [(plain, defaults), (plain.conserving(), defaults.conserving())] {
            let (fx, fy) = (x.f(wo, wi).0[0], y.f(wo, wi).0[0]);
            assert!((fx - fy).abs() <= 1e-6 * fx.abs(), "{wo} {wi}: {fx} vs {fy}");
            assert!((x.pdf(wo, wi) - y.pdf(wo, wi)).abs() <= 1e-6 * x.pdf(wo, wi));
        }
    }
    // Factor 0.5 and a coloured F0 (0.12 in this lane, 0.3 the spectrum's largest), as the extension
    // writes it: fr = F0 + (1 − F0)(1 − V·H)⁵ per wavelength, the layer weight · fr, the diffuse layer
    // 1 − weight · max(fr).
    let (weight, f0, f0_max) = (0.5f32, 0.12f32, 0.3f32);
    let (wo, wi) = (incident(40.0, false), Vec3::new(-0.3, 0.2, 0.9).normalize());
    let (spec, vh) = appendix_b_specular(wo, wi, roughness * roughness);
    let fr = |f0: f32| f0 + (1.0 - f0) * (1.0 - vh).powi(5);
    let expected = (1.0 - weight * fr(f0_max)) * base / PI + weight * fr(f0) * spec;
    let f = gltf_specular(base, roughness, weight, [f0], f0_max).f(wo, wi).0[0];
    assert!((f - expected).abs() < 1e-5 * expected, "{f} vs {expected}");
    // Factor 0 disables the layer: a pure diffuse material (the extension's words), exactly base / π,
    // also with the albedo coupling.
    let off = gltf_specular(base, roughness, 0.0, [0.04], 0.04).conserving();
    for t in [0.0, 60.0, 85.0] {
        let f = off.f(incident(t, false), wi).0[0];
        assert!((f - base / PI).abs() < 1e-6, "θ {t}: {f}");
    }
}

#[test]
fn gltf_specular_colour_keeps_the_strongest_wavelength_white_in_a_furnace() {
    // White base, coloured layer: the wavelength with the largest F0 reflects exactly 1 (the albedo
    // coupling is computed for it, as the extension's max_value rule intends); one with a smaller F0
    // reflects less, by what its layer misses: E_s(F0_max) − E_s(F0) at α = 0.25, μ = cos 30°.
    let mut rng = TestRng::new(65);
    let (f0_max, f0) = (0.3f32, 0.04f32);
    let b = Bsdf::GltfMetalRough(gltf_specular(1.0, 0.5, 1.0, [f0_max, f0], f0_max).conserving());
    let wo = incident(30.0, false);
    let n = 40_000;
    let (mut sum, mut sum2) = ([0.0f64; 2], [0.0f64; 2]);
    for _ in 0..n {
        if let Some(s) = b.sample_f(&FRAME, wo, rng.uniform(), rng.uniform2()) {
            for l in 0..2 {
                let w = f64::from(s.weight.0[l]);
                sum[l] += w;
                sum2[l] += w * w;
            }
        }
    }
    let mean = |l: usize| sum[l] / f64::from(n);
    let se = |l: usize| ((sum2[l] / f64::from(n) - mean(l).powi(2)) / f64::from(n)).sqrt();
    assert!((mean(0) - 1.0).abs() < 0.015 + 4.0 * se(0), "strongest lane: {} ± {}", mean(0), se(0));
    let t = conductor_table();
    let e_s = |f0: f64| f0 * f64::from(t.e(wo.z, 0.25)) + (1.0 - f0) * f64::from(t.e_schlick(wo.z, 0.25));
    let expected = 1.0 - (e_s(f64::from(f0_max)) - e_s(f64::from(f0)));
    assert!((mean(1) - expected).abs() < 0.015 + 4.0 * se(1), "weaker lane: {} ± {} vs {expected}", mean(1), se(1));
    assert!(mean(1) < mean(0) - 0.05, "{} vs {}", mean(1), mean(0));
}

#[test]
fn chi2_gltf_specular_extension() {
    // Sampling reads the layer's scalar strength (weight · Schlick(F0_max)); the pdf must follow it.
    chi2_family(&grid_cases(|a| {
        vec![(
            format!("glTF specular 0.6 F0 0.1/0.3 α {a}"),
            Bsdf::GltfMetalRough(gltf_specular(0.8, a.sqrt(), 0.6, [0.1], 0.3).conserving()),
            a,
            false,
        )]
    }));
}

#[test]
fn clearcoat_weight_is_schlick_of_index_1_5_and_its_lobe_the_white_ggx() {
    let coat = crate::Coat { weight: 0.8, roughness: 0.3 };
    assert!((coat.probability(1.0) - 0.8 * 0.04).abs() < 1e-7);
    assert!((coat.probability(-1.0) - 0.8 * 0.04).abs() < 1e-7, "seen from either side");
    assert!((coat.probability(0.0) - 0.8).abs() < 1e-7);
    assert!((coat.probability(0.5) - 0.8 * (0.04 + 0.96 / 32.0)).abs() < 1e-7);
    // The coat lobe's albedo is single-scattering GGX's E(μ, α) (the compensation tables' own
    // quadrature), at α = roughness².
    let mut rng = TestRng::new(66);
    for roughness in [0.3f32, 0.7] {
        let lobe = Bsdf::GltfMetalRough(GltfMetalRoughBxdf::<1>::clearcoat(roughness));
        for t in [0.0f32, 60.0] {
            let wo = incident(t, false);
            let (e, se) = albedo(&lobe, wo, 20_000, &mut rng);
            let table = f64::from(conductor_table().e(wo.z, roughness * roughness));
            assert!((e - table).abs() < 0.01 + 4.0 * se, "roughness {roughness} θ {t}: {e} ± {se} vs {table}");
            // Compensated (F_ms = 1 for its white microfacets), the lobe reflects all it receives.
            let compensated = Bsdf::GltfMetalRough(GltfMetalRoughBxdf::<1>::clearcoat(roughness).compensated());
            let (e, se) = albedo(&compensated, wo, 20_000, &mut rng);
            assert!((e - 1.0).abs() < 0.015 + 4.0 * se, "compensated, roughness {roughness} θ {t}: {e} ± {se}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Size of the per-hit value.

#[test]
fn bsdf_size_is_the_conductors() {
    // A Bsdf is as large as its largest lobe, the conductor: GGX α (8 bytes), η and κ per
    // wavelength (8N) and the optional Kulla–Conty spectrum with its α (4N + 4, plus the
    // Option's tag, in whose niche the enum keeps its own). The three lobes the path tracer
    // uses would fit in 4N + 8 (`ThreeLobes`, the enum before the rough lobes), so every hit
    // carries about 3× the bytes: 64 against 24 at N = 4, 1168 against 392 at N = 96.
    // Boxing or borrowing the conductor's spectra would need a lifetime on Bsdf (not done).
    #[allow(dead_code)]
    enum ThreeLobes<const N: usize> {
        Lambertian { r: SampledSpectrum<N> },
        Dielectric { eta: f32, tint: SampledSpectrum<N> },
        Mirror { r: SampledSpectrum<N> },
    }
    for (n, bsdf, three) in [
        (4, size_of::<Bsdf<4>>(), size_of::<ThreeLobes<4>>()),
        (96, size_of::<Bsdf<96>>(), size_of::<ThreeLobes<96>>()),
    ] {
        assert_eq!(bsdf, 12 * n + 16, "N = {n}");
        assert_eq!(three, 4 * n + 8, "N = {n}");
    }
    assert_eq!(size_of::<Bsdf<4>>(), size_of::<ConductorBxdf<4>>());
    assert_eq!(size_of::<Bsdf<96>>(), size_of::<ConductorBxdf<96>>());
}

/// The measurement behind the anisotropic coupling (docs/scene-format.md): the largest albedo, less three
/// standard errors, of a white glTF dielectric stretched by `KHR_materials_anisotropy`, over roughness
/// 0…0.7 × 35 views (θ up to 88°, azimuths 0°–90° from the direction), 40 000 samples each, for strength 0
/// (the isotropic lobe: the tables' interpolation alone), 0.6 and 1. `cargo test --release -p materials --lib
/// anisotropic_albedo_sweep -- --ignored --nocapture` (a few seconds; ignored in the suite, which checks two
/// of these lobes in `every_bsdf_reflects_no_more_than_it_receives`).
#[test]
#[ignore]
fn anisotropic_albedo_sweep() {
    for &strength in &[0.0f32, 0.6, 1.0] {
        let mut worst = (0.0f64, String::new());
        for &r in &[0.0f32, 0.1, 0.2, 0.4, 0.7] {
            let b: Bsdf<1> = gltf_anisotropic(1.0, 0.0, r, strength);
            for &t in &[0.0f32, 30.0, 60.0, 80.0, 88.0] {
                for k in 0..7 {
                    // The direction is 30° from local x (`anisotropy_direction`).
                    let phi = (k as f32 * 15.0 + 30.0).to_radians();
                    let tt = t.to_radians();
                    let wo = Vec3::new(tt.sin() * phi.cos(), tt.sin() * phi.sin(), tt.cos());
                    let (a, se) = albedo(&b, wo, 40_000, &mut TestRng::new(3));
                    if a - 3.0 * se > worst.0 {
                        worst = (a - 3.0 * se, format!("roughness {r}, θ {t}°, {}° from the direction", k * 15));
                    }
                }
            }
        }
        println!("strength {strength}: largest albedo − 3σ {:.4} at {}", worst.0, worst.1);
        assert!(worst.0 < 1.005, "strength {strength}: {worst:?}");
    }
}
