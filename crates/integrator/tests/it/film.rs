//! The film's sums merge exactly: sample ranges rendered apart equal the whole render.

use std::sync::atomic::AtomicBool;

use integrator::{
    Film, Integrator, PathOptions, RenderOptions, RenderScene, SamplerKind, SpectralMode, ViewPlan, WavelengthPdf,
};

use crate::reference;

fn film(scene: &RenderScene, options: &RenderOptions) -> Film {
    integrator::render_film(scene, options, &|_| {}, &AtomicBool::new(false)).expect("render succeeds").0
}

/// Samples 0..k and k..n rendered separately (and k..n split again) merge into exactly the
/// film of 0..n: every sum, count and first-hit id, bit for bit.
#[test]
fn films_of_disjoint_sample_ranges_merge_into_the_whole_render() {
    let cases: [(&str, Integrator, SpectralMode, bool); 5] = [
        ("cornell_box.json", Integrator::default(), SpectralMode::Bins(16), true),
        ("cornell_box.json", Integrator::Path(PathOptions::default()), SpectralMode::Bins(16), true),
        ("cornell_box.json", Integrator::Path(PathOptions::default()), SpectralMode::Rgb, false),
        ("prism.json", Integrator::Path(PathOptions::default()), SpectralMode::Hero { count: 8 }, false),
        (
            "slab_beer.json",
            Integrator::Path(PathOptions { wavelength_pdf: WavelengthPdf::Visible, ..PathOptions::default() }),
            SpectralMode::Hero { count: 4 },
            false,
        ),
    ];
    for (file, integrator, spectral, spectral_film) in cases {
        let scene = reference(file);
        let base = RenderOptions {
            width: 12,
            height: 9,
            integrator,
            spectral,
            spp: 7,
            seed: 5,
            threads: Some(2),
            spectral_film,
            ..RenderOptions::default()
        };
        let whole = film(&scene, &base);
        let part = |range: std::ops::Range<u32>| film(&scene, &RenderOptions { samples: Some(range), ..base.clone() });
        // Merged in a different order than rendered, and in uneven pieces.
        let mut merged = part(5..7);
        merged.merge(&part(0..2)).unwrap();
        merged.merge(&part(2..5)).unwrap();
        assert!(merged == whole, "{file} {spectral}: merged film differs from the whole render");
        assert_eq!(merged.min_sample_count(), 7);
        let (a, b) = (merged.to_image(), whole.to_image());
        assert_eq!(a.pixels(), b.pixels());
        assert_eq!(a.object_ids(), b.object_ids());
        assert_eq!(a.spectral(), b.spectral());
        // The sums are not trivially equal: a film missing one range differs.
        let mut partial = part(0..2);
        partial.merge(&part(2..5)).unwrap();
        assert!(partial != whole && partial.min_sample_count() == 5);
    }
}

#[test]
fn films_of_different_renders_do_not_merge() {
    let scene = reference("cornell_box.json");
    let base = RenderOptions { width: 4, height: 3, spectral: SpectralMode::Bins(8), ..RenderOptions::default() };
    let mut a = film(&scene, &base);
    let b = film(&scene, &RenderOptions { width: 5, ..base.clone() });
    assert!(a.merge(&b).is_err());
    let c = film(&scene, &RenderOptions { spectral_film: true, ..base });
    assert!(a.merge(&c).is_err(), "a spectral film needs the same wavelengths");
}

#[test]
fn luminance_variance_is_the_variance_of_the_mean() {
    // The white furnace at fixed bins is noise-free: variance 0 up to rounding.
    let furnace = reference("white_furnace.json");
    let opts = RenderOptions {
        width: 8,
        height: 8,
        integrator: Integrator::Path(PathOptions::default()),
        spectral: SpectralMode::Bins(8),
        spp: 8,
        ..RenderOptions::default()
    };
    assert!(film(&furnace, &opts).luminance_variance().iter().all(|v| *v < 1e-10));
    // With hero wavelengths each sample's Y is an estimate of 1 with the same variance (Sobol'
    // points stratify them over the pixel's samples, but s² estimates one sample's variance
    // all the same): s²/n falls as 1/spp. Summed over 64 pixels the ratio for 4× the samples is 4 with a
    // relative standard error of about √(2/63 + 2/255) ≈ 0.2; accept 2.5..6.5.
    let noisy = |spp| {
        let o = RenderOptions { spectral: SpectralMode::Hero { count: 4 }, spp, ..opts.clone() };
        film(&furnace, &o).luminance_variance().iter().map(|&x| f64::from(x)).sum::<f64>()
    };
    let (v16, v64) = (noisy(16), noisy(64));
    assert!(v16 > 0.0);
    let ratio = v16 / v64;
    assert!((2.5..6.5).contains(&ratio), "variance ratio {ratio}");
}

/// The render of `options` with a checkpoint after every pass: its film, and each checkpoint's
/// file bytes (with `header`).
fn checkpointed(scene: &RenderScene, options: &RenderOptions, header: &integrator::FilmHeader) -> (Film, Vec<Vec<u8>>) {
    use integrator::{Checkpoint, FilmFile, RenderControl};
    let saved = std::sync::Mutex::new(Vec::new());
    let write = |f: &Film| {
        saved.lock().unwrap().push(FilmFile { header: header.clone(), film: f.clone() }.to_bytes());
        Ok(())
    };
    let cancel = AtomicBool::new(false);
    let control = RenderControl {
        progress: &|_| {},
        cancel: &cancel,
        resume: None,
        checkpoint: Some(Checkpoint { every: std::time::Duration::ZERO, write: &write }),
        spectral: None,
    };
    let (film, _) = integrator::render_film_with(scene, options, control).unwrap();
    (film, saved.into_inner().unwrap())
}

/// The film of `options` resumed from a checkpoint file's `bytes`.
fn resumed(scene: &RenderScene, options: &RenderOptions, header: &integrator::FilmHeader, bytes: &[u8]) -> Film {
    use integrator::{FilmFile, RenderControl};
    let path = std::path::Path::new("c.film");
    let file = FilmFile::from_bytes(bytes, path).unwrap();
    let resume = file.resumable(header, options.width, options.height, path).unwrap();
    let cancel = AtomicBool::new(false);
    let control =
        RenderControl { progress: &|_| {}, cancel: &cancel, resume: Some(resume), checkpoint: None, spectral: None };
    integrator::render_film_with(scene, options, control).unwrap().0
}

/// A checkpoint taken between passes, read back from its bytes and resumed, gives exactly the
/// uninterrupted film (uneven counts, as a time limit leaves them, are `tests/e2e/farm.rs`).
#[test]
fn a_resumed_checkpoint_equals_the_uninterrupted_render() {
    use integrator::{FilmFile, FilmHeader};
    let scene = reference("cornell_box.json");
    let options = RenderOptions {
        width: 10,
        height: 8,
        integrator: Integrator::Path(PathOptions::default()),
        spectral: SpectralMode::Bins(8),
        spp: 6,
        seed: 3,
        threads: Some(2),
        spectral_film: true,
        ..RenderOptions::default()
    };
    let whole = film(&scene, &options);
    let header = FilmHeader::new(scene.source_hash(), &options, SpectralMode::Bins(8), ViewPlan::default().to_string());
    let (checkpointed, saved) = checkpointed(&scene, &options, &header);
    assert!(checkpointed == whole, "short passes change no sum");
    assert_eq!(saved.len(), 5, "one checkpoint between each of the 6 passes");
    for (k, bytes) in saved.iter().enumerate() {
        let file = FilmFile::from_bytes(bytes, std::path::Path::new("c.film")).unwrap();
        assert_eq!(file.film.min_sample_count(), k as u32 + 1);
        assert!(resumed(&scene, &options, &header, bytes) == whole, "resumed after pass {}", k + 1);
    }
    // A film of another seed is refused.
    let other = FilmHeader::new(
        scene.source_hash(),
        &RenderOptions { seed: 4, ..options.clone() },
        SpectralMode::Bins(8),
        ViewPlan::default().to_string(),
    );
    let file = FilmFile::from_bytes(&saved[0], std::path::Path::new("c.film")).unwrap();
    assert!(file.resumable(&other, 10, 8, std::path::Path::new("c.film")).is_err());
}

/// A render to a target error: its tiles stop at different stages; the film is the same at any
/// thread count, and resumed from any of its checkpoints it is the uninterrupted one, bit for bit.
#[test]
fn an_adaptive_render_is_deterministic_and_resumes_exactly() {
    use integrator::{FilmFile, FilmHeader, TargetError};
    let scene = reference("cornell_box.json");
    let options = RenderOptions {
        width: 40,
        height: 16,
        integrator: Integrator::Path(PathOptions::default()),
        spectral: SpectralMode::Bins(8),
        spp: 96,
        seed: 11,
        threads: Some(2),
        target_error: Some(TargetError { delta_e: 4.0, exposure_ev: Some(0.0) }),
        ..RenderOptions::default()
    };
    let (whole, stats) = integrator::render_film(&scene, &options, &|_| {}, &AtomicBool::new(false)).unwrap();
    // Tiles stopped at different stages: the background and quiet walls early, the rest later.
    let counts = whole.sample_counts();
    let (fewest, most) = (whole.min_sample_count(), whole.max_sample_count());
    assert!(fewest >= integrator::FIRST_STAGE_SPP && fewest < most, "{fewest}..{most}");
    assert!(integrator::stage_ends(96, true).contains(&fewest));
    assert!(counts.iter().all(|c| integrator::stage_ends(96, true).contains(c)), "{counts:?}");
    let error = stats.error.expect("an adaptive render reports its error");
    assert!(error.tiles_done > 0.0 && error.mean > 0.0);
    // Every tile that stopped before the last stage was at or below the target then; its film
    // has not changed since, so its estimate now is the one it stopped at.
    let estimate = whole.error_estimate(1.0, 0).unwrap();
    for y in 0..16 {
        for x in 0..40 {
            if whole.sample_count(x, y) < most {
                assert!(estimate.tiles[estimate.tile_of(x, y)] <= 4.0);
            }
        }
    }
    let one_thread = film(&scene, &RenderOptions { threads: Some(1), ..options.clone() });
    assert!(one_thread == whole, "the thread count changed the film");

    let header = FilmHeader::new(scene.source_hash(), &options, SpectralMode::Bins(8), ViewPlan::default().to_string());
    let (checkpointed, saved) = checkpointed(&scene, &options, &header);
    assert!(checkpointed == whole, "passes of one sample change no decision");
    assert!(saved.len() > 20, "{} checkpoints", saved.len());
    for (k, bytes) in saved.iter().enumerate() {
        assert!(FilmFile::from_bytes(bytes, std::path::Path::new("c.film")).unwrap().film.has_halves());
        assert!(resumed(&scene, &options, &header, bytes) == whole, "resumed from checkpoint {}", k + 1);
    }
    // A target error decides from the whole film: it does not render a sample range.
    let part = RenderOptions { samples: Some(0..48), ..options.clone() };
    assert!(integrator::render_film(&scene, &part, &|_| {}, &AtomicBool::new(false)).is_err());
}

/// Keeping the half-film sums for an error map: with independent numbers no pixel changes; with
/// Sobol' points the samples come from two independent randomisations, one per half, so pixels
/// change by noise only.
#[test]
fn an_error_estimate_changes_pixels_by_noise_only() {
    let scene = reference("cornell_box.json");
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        let options = RenderOptions {
            width: 12,
            height: 9,
            integrator: Integrator::Path(PathOptions { sampler, ..PathOptions::default() }),
            spectral: SpectralMode::Bins(8),
            spp: 64,
            seed: 2,
            ..RenderOptions::default()
        };
        let plain = film(&scene, &options);
        let with = film(&scene, &RenderOptions { error_estimate: true, ..options.clone() });
        assert!(!plain.has_halves() && with.has_halves());
        assert_eq!(plain.sample_counts(), with.sample_counts());
        let (a, b) = (plain.to_image(), with.to_image());
        if sampler == SamplerKind::Independent {
            assert_eq!(a.pixels(), b.pixels());
        } else {
            assert_ne!(a.pixels(), b.pixels());
            let mean = |i: &integrator::Image| i.pixels().iter().map(|p| f64::from(p[1])).sum::<f64>() / 108.0;
            // Two independent renders of 7k samples of the Cornell box, whose glass sphere's
            // caustics are rare bright paths: their means differ by up to about 10 %.
            assert!((mean(&a) / mean(&b) - 1.0).abs() < 0.15, "{} vs {}", mean(&a), mean(&b));
        }
        let estimate = with.error_estimate(1.0, 0).unwrap();
        assert!(estimate.mean() > 0.0 && estimate.pixels.iter().all(|e| e.is_finite()));
        assert!(plain.error_estimate(1.0, 0).is_none());
    }
}
