//! Cost of turning an RGB colour into spectral values at a hit: the fit-free table lookup
//! (`RgbSigmoid::from_rgb`) plus the sigmoid at 4 and 8 wavelengths, the evaluation alone
//! (coefficients precomputed per texel), and, for comparison, the path the renderer takes for
//! RGB colours today (`upsample_reflectance`: lookup + Gauss–Newton fit, then the 471-value
//! 1 nm table).
//! Inputs: 1024 pseudo-random linear sRGB colours and wavelength sets, generated in code;
//! each iteration takes the next one. Throughput: one colour (lookup + evaluation) per element.
//!
//! `taskset -c 0 cargo bench -p colorimetry --bench spectrum -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;

use colorimetry::{
    DenselySampledSpectrum, RgbSigmoid, RgbToSpectrumTable, SampledWavelengths, Spectrum, upsample_reflectance,
};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// SplitMix64 (Steele et al. 2014): fixed seed, the same inputs every run.
struct SplitMix(u64);
impl SplitMix {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

const INPUTS: usize = 1024;

fn colors() -> Vec<[f32; 3]> {
    let mut rng = SplitMix(1);
    (0..INPUTS).map(|_| [rng.next_f32(), rng.next_f32(), rng.next_f32()]).collect()
}

fn wavelengths<const N: usize>() -> Vec<SampledWavelengths<N>> {
    let mut rng = SplitMix(2);
    (0..INPUTS).map(|_| SampledWavelengths::sample_visible(rng.next_f32())).collect()
}

fn lookup_and_sample<const N: usize>(c: &mut Criterion) {
    let table = RgbToSpectrumTable::srgb();
    let colors = colors();
    let lambdas = wavelengths::<N>();
    let mut group = c.benchmark_group("rgb_albedo");
    group.throughput(Throughput::Elements(1));
    let mut i = 0;
    group.bench_function(format!("lookup_and_sample_{N}"), |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            let sigmoid = RgbSigmoid::from_rgb(table, black_box(colors[i]));
            black_box(sigmoid.sample(&lambdas[i]))
        })
    });
    // Neighbouring texels of an image: a slow gradient (table rows stay in cache, the
    // branches are predictable). The random colours above are the worst case.
    let gradient: Vec<[f32; 3]> = (0..INPUTS)
        .map(|k| {
            let t = k as f32 / INPUTS as f32;
            [0.2 + 0.6 * t, 0.5 - 0.3 * t, 0.1 + 0.05 * t]
        })
        .collect();
    group.bench_function(format!("lookup_and_sample_{N}_gradient"), |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            let sigmoid = RgbSigmoid::from_rgb(table, black_box(gradient[i]));
            black_box(sigmoid.sample(&lambdas[i]))
        })
    });
    let sigmoids: Vec<RgbSigmoid> = colors.iter().map(|&rgb| RgbSigmoid::from_rgb(table, rgb)).collect();
    group.bench_function(format!("sample_{N}"), |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            black_box(black_box(&sigmoids[i]).sample(&lambdas[i]))
        })
    });
    // Through the enum, as a material will hold it.
    let spectra: Vec<Spectrum> = sigmoids.iter().map(|&s| Spectrum::RgbAlbedo(s)).collect();
    group.bench_function(format!("spectrum_enum_sample_{N}"), |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            black_box(black_box(&spectra[i]).sample(&lambdas[i]))
        })
    });
    group.finish();
}

fn old_path(c: &mut Criterion) {
    let colors = colors();
    let lambdas = wavelengths::<4>();
    let mut group = c.benchmark_group("rgb_albedo_old");
    group.throughput(Throughput::Elements(1));
    let mut i = 0;
    // `materials::reflectance_from_rgb` as the renderer calls it, then 4 wavelengths.
    group.bench_function("fit_to_spectrum_and_sample_4", |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            let rgb = black_box(colors[i]).map(f64::from);
            let dense: DenselySampledSpectrum = upsample_reflectance(rgb).to_spectrum();
            black_box(dense.sample(&lambdas[i]))
        })
    });
    // Load-time alternatives for exact colours: lookup + 2 Newton evaluations, and the fit.
    group.bench_function("refined", |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            black_box(RgbSigmoid::refined(black_box(colors[i])))
        })
    });
    group.bench_function("fit", |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            black_box(RgbSigmoid::fit(black_box(colors[i]).map(f64::from)))
        })
    });
    // The dense table's evaluation alone, for the per-hit comparison with `sample_4`.
    let dense: Vec<DenselySampledSpectrum> =
        colors.iter().take(64).map(|&rgb| upsample_reflectance(rgb.map(f64::from)).to_spectrum()).collect();
    group.bench_function("dense_sample_4", |b| {
        b.iter(|| {
            i = (i + 1) % INPUTS;
            black_box(black_box(&dense[i % 64]).sample(&lambdas[i]))
        })
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    lookup_and_sample::<4>(c);
    lookup_and_sample::<8>(c);
    old_path(c);
}

criterion_group!(spectrum, benches);
criterion_main!(spectrum);
