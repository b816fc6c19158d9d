//! Colorimetry checks: white points against CIE 015, the ColorChecker integrated at each
//! wavelength count against 1 nm, and the RGB → spectrum upsampling round trip.

use super::*;

pub(crate) fn checks(report: &mut Report, quick: bool) {
    // CIE 015:2018 white points, 2°: tolerance 3e-5 in xy (PROVENANCE.md: 1 nm vs the
    // published 5-decimal values).
    for (name, xy) in [("D65", [0.31272, 0.32903]), ("D50", [0.34567, 0.35850]), ("A", [0.447575, 0.40745])] {
        let s = Illuminant::parse(name).and_then(|i| i.spectrum()).expect("built-in illuminant");
        let got = white_xyz(&s, &Integration::Step(1.0)).chromaticity();
        let err = (got[0] - xy[0]).abs().max((got[1] - xy[1]).abs());
        report.check(
            "colorimetry",
            format!("{name} white point xy"),
            format!("({:.5}, {:.5})", got[0], got[1]),
            "|Δxy| < 3e-5".into(),
            "published",
            err < 3e-5,
        );
    }
    // The ColorChecker under each illuminant, integrated at the renderer's wavelength counts
    // (bins:N = N evenly spaced wavelengths over 360–830 nm) against 1 nm.
    let mut table = String::from(
        "## What a wavelength count costs: ColorChecker, max ΔE00 vs 1 nm\n\n| illuminant | bins:8 | bins:16 | bins:32 | bins:95 |\n| --- | --- | --- | --- | --- |\n",
    );
    for name in ["D65", "A", "F2", "F11"] {
        let s = Illuminant::parse(name).and_then(|i| i.spectrum()).expect("built-in illuminant");
        let reference = Integration::Step(1.0);
        let mut row = format!("| {name} |");
        let mut worst95 = 0.0;
        for n in [8usize, 16, 32, 95] {
            let step = 470.0 / (n - 1) as f64;
            let integration = Integration::Step(step);
            let (w_ref, w) = (white_xyz(&s, &reference), white_xyz(&s, &integration));
            let worst = colorchecker()
                .iter()
                .map(|p| {
                    let a = Lab::from_xyz(reflectance_to_xyz(&p.spectrum, &s, Observer::Cie1931, &reference), w_ref);
                    let b = Lab::from_xyz(reflectance_to_xyz(&p.spectrum, &s, Observer::Cie1931, &integration), w);
                    delta_e_2000(a, b)
                })
                .fold(0.0, f64::max);
            write!(row, " {worst:.3} |").ok();
            if n == 95 {
                worst95 = worst;
            }
        }
        table.push_str(&row);
        table.push('\n');
        // The 5 nm grid carries the CIE's own tabulation of these illuminants: within 0.5 ΔE00.
        report.check(
            "colorimetry",
            format!("ColorChecker under {name}, bins:95 vs 1 nm"),
            format!("max ΔE00 {worst95:.3}"),
            "< 0.5".into(),
            "published",
            worst95 < 0.5,
        );
    }
    report.sections.push_str(&table);
    report.sections.push('\n');
    // RGB upsampling round trip over a grid of the sRGB gamut (white excepted: unreachable by
    // reflectances within [0, 1], see colorimetry's upsample docs; it is within 0.005).
    let steps = if quick { 9 } else { 17 };
    let srgb = RgbColorSpace::srgb();
    let d65 = Illuminant::D65.spectrum().expect("D65");
    let white = Xyz::from_xy_y(srgb.white(), 1.0);
    let mut worst: f64 = 0.0;
    for i in 0..steps * steps * steps {
        let c = [i % steps, (i / steps) % steps, i / (steps * steps)].map(|v| v as f64 / (steps - 1) as f64);
        let spectrum = upsample_reflectance(c).to_spectrum();
        let xyz = reflectance_to_xyz(&spectrum, &d65, Observer::Cie1931, &Integration::Step(1.0)).scaled(0.01);
        let want = srgb.rgb_to_xyz(Rgb { r: c[0], g: c[1], b: c[2] });
        worst = worst.max(delta_e_2000(Lab::from_xyz(xyz, white), Lab::from_xyz(want, white)));
    }
    report.check(
        "colorimetry",
        format!("RGB upsampling round trip, {steps}³ sRGB grid"),
        format!("max ΔE00 {worst:.4}"),
        "< 0.01".into(),
        "analytic",
        worst < 0.01,
    );
}
