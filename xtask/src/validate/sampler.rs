//! The path tracer's default Sobol' points against independent numbers, at equal spp: mean
//! ΔE00 of each against a converged reference, and the check that Sobol' points lower it where
//! direct light and the pixel footprint dominate the noise, and do not raise it where paths
//! are long and caustics dominate (the Cornell box). A negative control (independent numbers
//! against themselves, two seeds) shows that the check tells a stratifying sampler from one
//! that does not.

use super::refs::RefCache;
use super::*;

/// A scene of the check.
struct Case {
    /// Under `scenes/`.
    file: &'static str,
    /// Image size (full run, `--quick`).
    size: (u32, u32),
    quick_size: (u32, u32),
    spectral: SpectralMode,
    /// The spp of both renders (full, `--quick`).
    spp: (u32, u32),
    /// The reference's spectral mode and spp (full, `--quick`).
    reference: SpectralMode,
    reference_spp: (u32, u32),
    /// Most the ratio Sobol' / independent of mean ΔE00 may be (full, `--quick`).
    max_ratio: (f64, f64),
    /// Part of `--quick`.
    in_quick: bool,
}

const CASES: &[Case] = &[
    // A bare OBJ under the default lights: the error is direct light and edges.
    Case {
        file: "obj/cube_and_sphere.obj",
        size: (96, 96),
        quick_size: (32, 32),
        spectral: SpectralMode::Bins(16),
        spp: (64, 16),
        reference: SpectralMode::Bins(16),
        reference_spp: (4096, 1024),
        max_ratio: (0.6, 0.7),
        in_quick: true,
    },
    // Rough metals of the glTF grid: glossy lobes and their highlights. Not in `--quick`: with the
    // energy-compensated glTF lobes (light bounces between the spheres longer) one 32×32, 16 spp render's
    // mean ΔE00 varies by 5.6 % (relative standard deviation over seeds 2–11), so two seeds differ by up
    // to 10 %, more than the control's resolution.
    Case {
        file: "gltf/metal_rough_grid.gltf",
        size: (96, 96),
        quick_size: (32, 32),
        spectral: SpectralMode::Bins(16),
        spp: (64, 16),
        reference: SpectralMode::Bins(16),
        reference_spp: (4096, 1024),
        max_ratio: (0.95, 1.05),
        in_quick: false,
    },
    // Long diffuse paths and the glass sphere's caustics: little to stratify. The references
    // are the `auto` part's. Not in `--quick`: at 24×24 two seeds of the same sampler differ
    // by 11 % (its rare bright paths), more than what is checked.
    Case {
        file: "reference/cornell_box.json",
        size: (64, 64),
        quick_size: (24, 24),
        spectral: SpectralMode::Bins(24),
        spp: (256, 64),
        reference: SpectralMode::Bins(95),
        reference_spp: (4096, 1024),
        max_ratio: (1.02, 1.1),
        in_quick: false,
    },
];

/// Where a case claims no gain (its largest ratio is 1 or more), the negative control's ratio
/// (independent against independent) must lie within this of 1: the check's resolution.
const CONTROL_RESOLUTION: f64 = 0.05;

pub(crate) fn checks(report: &mut Report, root: &Path, refs: &RefCache, quick: bool) -> anyhow::Result<()> {
    let mut md = String::from(
        "## Sobol' points against independent numbers\n\n\
         The path tracer's default sampler (padded, shuffled, digitally shifted Sobol' points) against \
         independent numbers (PCG32 per sample) at the same spp and spectral mode, each scored against a \
         converged reference (mean ΔE00, D65 white at Y = 1; the reference's own noise is in every figure). \
         Control: independent numbers with another seed. Reproduce: `cargo xtask validate --only sampler` \
         (`xtask/src/validate/sampler.rs`).\n\n\
         | scene | size, spp | ΔE00 Sobol' | ΔE00 independent | ΔE00 control | Sobol' / independent | time Sobol' / independent |\n\
         | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for case in CASES.iter().filter(|c| c.in_quick || !quick) {
        let scene = load_scene(root, case.file)?;
        let (w, h) = if quick { case.quick_size } else { case.size };
        let spp = if quick { case.spp.1 } else { case.spp.0 };
        let ref_spp = if quick { case.reference_spp.1 } else { case.reference_spp.0 };
        let max_ratio = if quick { case.max_ratio.1 } else { case.max_ratio.0 };
        let reference = path_reference(refs, &scene, case.file, case.reference, (w, h), ref_spp)?;
        let run = |sampler, seed| -> anyhow::Result<(f64, f64)> {
            let options =
                RenderOptions { seed, ..path_options(w, h, case.spectral, spp) }.path(|p| p.sampler = sampler);
            let (image, stats) = render(&scene, &options)?;
            Ok((mean(&delta_e_all(image.pixels(), &reference.pixels)), stats.elapsed.as_secs_f64()))
        };
        // Seeds 2 and 3: independent of the reference's seed 1.
        let (sobol, t_sobol) = run(SamplerKind::Sobol, 2)?;
        let (independent, t_independent) = run(SamplerKind::Independent, 2)?;
        let (control, _) = run(SamplerKind::Independent, 3)?;
        let (ratio, control_ratio) = (sobol / independent, control / independent);
        writeln!(
            md,
            "| {} | {w}×{h}, {spp} | {sobol:.4} | {independent:.4} | {control:.4} | {ratio:.3} | {:.3} |",
            case.file,
            t_sobol / t_independent
        )?;
        report.check(
            "sampler",
            format!("{}: mean ΔE00 of Sobol' over independent numbers, {spp} spp", case.file),
            format!("{ratio:.3}"),
            format!("≤ {max_ratio}"),
            "converged",
            ratio <= max_ratio,
        );
        // Where a gain is claimed, the control must fail the claim: otherwise the check could
        // not tell a sampler that stratifies from one that does not. Where none is, the seeds'
        // own scatter must be small enough for the bound to mean something.
        let (tolerance, pass) = if max_ratio < 1.0 {
            (format!("> {max_ratio}"), control_ratio > max_ratio)
        } else {
            (format!("within {CONTROL_RESOLUTION} of 1"), (control_ratio - 1.0).abs() < CONTROL_RESOLUTION)
        };
        report.check(
            "sampler",
            format!("{}: control, independent numbers over themselves (another seed)", case.file),
            format!("{control_ratio:.3}"),
            tolerance,
            "converged",
            pass,
        );
    }
    md.push('\n');
    report.sections.push_str(&md);
    Ok(())
}
