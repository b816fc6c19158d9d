//! Caustics: light from a small light through delta vertices onto a diffuse surface. Photon mapping
//! against the analytic image of a caustic seen in a mirror (light → mirror → floor → mirror → camera),
//! which bidirectional path tracing cannot join (no delta vertex can be connected to), and BDPT's gap
//! measured on it.

use super::*;

#[path = "../../../crates/integrator/tests/it/mirrored_disc.rs"]
mod mirrored_disc;

pub(crate) fn checks(report: &mut Report, quick: bool) -> anyhow::Result<()> {
    let (w, h, iterations) = if quick { (48, 36, 16) } else { (96, 72, 64) };
    let scene = scene(&mirrored_disc::mirrored_disc())?;
    let (want, inside, _) = mirrored_disc::disc_answer(w, h);
    anyhow::ensure!(inside.len() > 100, "the disc covers only {} pixels", inside.len());
    let expected = inside.iter().map(|&i| want[i]).sum::<f64>() / inside.len() as f64;
    let mean_inside =
        |image: &Image| inside.iter().map(|&i| f64::from(image.pixels()[i][1])).sum::<f64>() / inside.len() as f64;
    let independent = PathOptions { sampler: SamplerKind::Independent, ..PathOptions::default() };
    let base = RenderOptions { spectral: SpectralMode::Bins(16), seed: 1, ..small(w, h) };
    let sppm = Integrator::Sppm(integrator::SppmOptions {
        path: independent,
        photons: Some(u64::from(w * h) * 4),
        radius: Some(0.1),
    });
    let (image, stats) = render(&scene, &RenderOptions { integrator: sppm, spp: iterations, ..base.clone() })?;
    let ratio = mean_inside(&image) / expected;
    report.check(
        "caustics",
        format!("sppm: a spot light's disc from one mirror seen in another ({w}×{h}, {iterations} iterations)"),
        format!("Y / analytic {ratio:.4} ({} pixels, {} non-finite)", inside.len(), stats.nonfinite_samples),
        "0.99–1.04 (interreflection adds ~1 %)".to_owned(),
        "analytic",
        (0.99..1.04).contains(&ratio) && stats.nonfinite_samples == 0,
    );
    let (image, _) = render(&scene, &RenderOptions { integrator: Integrator::Bdpt(independent), spp: 16, ..base })?;
    let seen = mean_inside(&image) / expected;
    report.check(
        "caustics",
        "bdpt on the same disc: no strategy joins a diffuse vertex between two delta ones",
        format!("Y / analytic {seen:.4}"),
        "< 0.05 (what sppm adds)".to_owned(),
        "analytic",
        seen < 0.05,
    );
    Ok(())
}
