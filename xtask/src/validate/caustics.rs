//! Caustics: light from a small light through delta vertices onto a diffuse surface. Photon mapping
//! against the analytic image of a caustic seen in a mirror (light → mirror → floor → mirror → camera),
//! which bidirectional path tracing cannot join (no delta vertex can be connected to), and BDPT's gap
//! measured on it; BDPT against the path tracer where both find every path (the Cornell box).

use super::*;

#[path = "../../../crates/integrator/tests/it/mirrored_disc.rs"]
mod mirrored_disc;

pub(crate) fn checks(report: &mut Report, root: &Path, quick: bool) -> anyhow::Result<()> {
    photon_mapping(report, quick)?;
    agreement(report, root, quick)
}

/// BDPT and the path tracer on the Cornell box (an area light: no caustic from a delta light, so both
/// converge): the mean of the per-pixel differences over its standard error, so the image's own
/// structure cancels, and the mean luminance ratio.
fn agreement(report: &mut Report, root: &Path, quick: bool) -> anyhow::Result<()> {
    let (size, spp, tolerance) = if quick { (24, 32, 0.02) } else { (64, 128, 0.01) };
    let scene = load_scene(root, "reference/cornell_box.json")?;
    let independent = PathOptions { sampler: SamplerKind::Independent, ..PathOptions::default() };
    let base = path_options(size, size, SpectralMode::Bins(16), spp);
    let (b, _) = render(&scene, &RenderOptions { integrator: Integrator::Bdpt(independent), seed: 3, ..base.clone() })?;
    let (p, _) =
        render(&scene, &RenderOptions { integrator: Integrator::Path(independent), spp: 4 * spp, seed: 4, ..base })?;
    let (mean, se) = mean_se_of(b.pixels().iter().zip(p.pixels()).map(|(x, y)| f64::from(x[1]) - f64::from(y[1])));
    let z = mean / se;
    let ratio = mean_se(&b).0 / mean_se(&p).0;
    report.check(
        "caustics",
        format!("bdpt against the path tracer, Cornell box ({size}², {spp} and {} spp)", 4 * spp),
        format!("Y ratio {ratio:.4}, z {z:.2}"),
        format!("|ratio − 1| < {tolerance}, |z| < 4"),
        "converged",
        (ratio - 1.0).abs() < tolerance && z.abs() < 4.0,
    );
    Ok(())
}

fn photon_mapping(report: &mut Report, quick: bool) -> anyhow::Result<()> {
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
