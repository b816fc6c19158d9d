//! `auto` by time to error: on each scene, every candidate strategy is
//! piloted (as `auto` pilots where it is unsure) and rendered to a measured error against a
//! converged reference, and the checks are that
//! - the pilot's ratio of the candidates' spp to mean ΔE00 1 matches the measured ratio to within
//!   a factor 1.5 (what `auto`'s choice relies on; the pilot's absolute spp is low wherever
//!   rare bright paths make error fall slower than 1/√spp at the spp measured: on the Cornell
//!   box 420 predicted, 1000 from 64 spp and 2500 from 256 spp, the same for every strategy), and
//! - the strategy `auto` picks reaches mean ΔE00 1 within 1.25× the time of the fastest
//!   candidate measured (renders are timed on a shared machine: ±20 %).
//!
//! Measured time to ΔE00 1 of a candidate = t(s) · e(s)², from its render at s spp taking t(s)
//! with mean ΔE00 e(s) (time ∝ spp, error ∝ 1/√spp).

use integrator::{AutoCandidate, auto_decision, pilot_strategies};

use super::refs::RefCache;
use super::*;

/// A scene of the check.
struct Case {
    /// Under `scenes/`.
    file: &'static str,
    /// Image size (full run, `--quick`).
    size: (u32, u32),
    quick_size: (u32, u32),
    /// The spp of the measured renders (full, `--quick`).
    spp: (u32, u32),
    /// The converged reference: strategy and spp (full, `--quick`).
    reference: SpectralMode,
    reference_spp: (u32, u32),
}

const CASES: &[Case] = &[
    // auto: bins:24, no pilot (as cheap per ray as hero:4): the check is that bins:24 is indeed
    // the fastest.
    Case {
        file: "reference/cornell_box.json",
        size: (64, 64),
        quick_size: (24, 24),
        spp: (64, 64),
        reference: SpectralMode::Bins(95),
        reference_spp: (4096, 1024),
    },
    // F11's lines: bins:95 against hero wavelengths, piloted.
    Case {
        file: "reference/colorchecker_f11.json",
        size: (60, 40),
        quick_size: (30, 20),
        spp: (16, 16),
        reference: SpectralMode::Bins(95),
        reference_spp: (256, 64),
    },
    // A narrow absorption band no bin count holds: hero:4 against hero:8, piloted. Its
    // reference is hero:8 (unbiased; bins would be biased here).
    Case {
        file: "reference/slab_band.json",
        size: (48, 48),
        quick_size: (24, 24),
        spp: (64, 64),
        reference: SpectralMode::Hero { count: 8 },
        reference_spp: (8192, 2048),
    },
];

/// The spp at which a render of the case's size is long enough for `auto` to pilot: the
/// decision checked is that of a long render of this image.
const DECISION_SPP: u32 = 4096;

/// Agreement asked of the predicted and measured ratios of two candidates' spp to ΔE00 1.
const MAX_RATIO_FACTOR: f64 = 1.5;

/// The pick's time to ΔE00 1 may exceed the fastest measured by this factor (timing noise).
const MAX_TIME_FACTOR: f64 = 1.25;

/// Below this measured mean ΔE00 a candidate's error is the references' difference, not its
/// noise, and its spp to ΔE00 1 is not measurable (fixed bins on the flat chart).
const NOISE_FLOOR: f64 = 0.05;

pub(crate) fn checks(report: &mut Report, root: &Path, refs: &RefCache, quick: bool) -> anyhow::Result<()> {
    let mut md = String::from(
        "## `auto` by time to error\n\n\
         Every candidate strategy piloted (`integrator::pilot_strategies`: two independent 16-spp renders of up \
         to 32×32 pixels) and rendered at the stated spp against a converged reference. Predicted: the \
         pilot's spp to mean ΔE00 1 and modelled cost (rays × (1 + lanes·0.0065 + hero wavelengths·0.05), in \
         units of a ray's lane-independent cost). Measured: spp to ΔE00 1 = s·e(s)² and time to ΔE00 1 = \
         t(s)·e(s)² from the render at s spp (error ∝ 1/√spp). Reproduce: `cargo xtask validate --only auto` \
         (`xtask/src/validate/auto_time.rs`).\n\n",
    );
    for case in CASES {
        one(report, root, refs, case, quick, &mut md)?;
    }
    report.sections.push_str(&md);
    Ok(())
}

fn one(
    report: &mut Report,
    root: &Path,
    refs: &RefCache,
    case: &Case,
    quick: bool,
    md: &mut String,
) -> anyhow::Result<()> {
    let scene = load_scene(root, case.file)?;
    let (w, h) = if quick { case.quick_size } else { case.size };
    let spp = if quick { case.spp.1 } else { case.spp.0 };
    let ref_spp = if quick { case.reference_spp.1 } else { case.reference_spp.0 };
    let reference = path_reference(refs, &scene, case.file, case.reference, (w, h), ref_spp)?;
    let decision = auto_decision(&scene, &path_options(w, h, SpectralMode::Auto, DECISION_SPP))?;
    let first = integrator::choose_auto(&scene, integrator::IntegratorKind::Path);
    let mut strategies = vec![SpectralMode::Hero { count: 4 }, SpectralMode::Hero { count: 8 }];
    if matches!(first, SpectralMode::Bins(_)) {
        strategies.insert(0, first);
    }
    let piloted = pilot_strategies(&scene, &path_options(w, h, SpectralMode::Auto, DECISION_SPP), &strategies)?;
    writeln!(
        md,
        "### {} (path tracer, {w}×{h}, {spp} spp; reference {} at {ref_spp} spp)\n\n`auto` picks **{}**: {}.\n\n\
         | strategy | pilot: cost/sample | pilot: ΔE00 at 1 spp | pilot: spp to ΔE00 1 | measured: ΔE00 at {spp} spp | \
         measured: spp to ΔE00 1 | measured: time to ΔE00 1 (s) |\n| --- | --- | --- | --- | --- | --- | --- |",
        case.file, case.reference, decision.spectral, decision.reason
    )?;
    let mut measured = Vec::new();
    for c in &piloted {
        // Seed 2: independent of the reference's seed 1.
        // Independent numbers, the pilot's model (Sobol' points reach an error sooner).
        let options = independent(RenderOptions { seed: 2, ..path_options(w, h, c.spectral, spp) });
        let (image, stats) = render(&scene, &options)?;
        let e = mean(&delta_e_all(image.pixels(), &reference.pixels));
        let secs = stats.elapsed.as_secs_f64();
        let (spp_to, time_to) = (f64::from(spp) * e * e, secs * e * e);
        writeln!(
            md,
            "| {} | {:.3} | {:.3} | {:.3} | {e:.3} | {spp_to:.3} | {time_to:.4} |",
            c.spectral,
            c.cost_per_sample,
            c.error_1spp,
            c.spp_for(1.0),
        )?;
        measured.push((*c, e, spp_to, time_to));
    }
    md.push('\n');
    // The ratios to the pick's spp (or the first candidate's, if the pick's error is the
    // references' difference, below the noise floor).
    let base = measured.iter().find(|m| m.0.spectral == decision.spectral && m.1 >= NOISE_FLOOR);
    let base = base.or_else(|| measured.iter().find(|m| m.1 >= NOISE_FLOOR));
    for &(c, e, spp_to, _) in &measured {
        let Some(&(b, _, b_spp_to, _)) = base.filter(|b| b.0.spectral != c.spectral && e >= NOISE_FLOOR) else {
            continue;
        };
        let (predicted, got) = (c.spp_for(1.0) / b.spp_for(1.0), spp_to / b_spp_to);
        let factor = (predicted / got).max(got / predicted);
        report.check(
            "auto",
            format!("{}: spp to ΔE00 1 of {} over {}, pilot against measured", case.file, c.spectral, b.spectral),
            format!("{predicted:.3} vs {got:.3} (×{factor:.2})"),
            format!("within ×{MAX_RATIO_FACTOR}"),
            "converged",
            factor <= MAX_RATIO_FACTOR,
        );
    }
    let fastest = measured.iter().map(|m| m.3).fold(f64::INFINITY, f64::min);
    let pick = measured.iter().find(|m| m.0.spectral == decision.spectral);
    let pick_time = pick.map_or(f64::INFINITY, |m| m.3);
    let name = |m: &(AutoCandidate, f64, f64, f64)| m.0.spectral.to_string();
    let fastest_name = measured.iter().find(|m| m.3 == fastest).map(name).unwrap_or_default();
    // Renders of a few hundred pixels time their overheads and the machine's noise, not their
    // strategies: `--quick` (CI) checks the predictions only; the table shows the times.
    if quick {
        return Ok(());
    }
    report.check(
        "auto",
        format!(
            "{}: auto's pick {} reaches ΔE00 1 about as fast as the fastest ({fastest_name})",
            case.file, decision.spectral
        ),
        format!("{:.3}× the fastest's time", pick_time / fastest),
        format!("≤ {MAX_TIME_FACTOR}"),
        "converged",
        pick_time <= MAX_TIME_FACTOR * fastest,
    );
    Ok(())
}
