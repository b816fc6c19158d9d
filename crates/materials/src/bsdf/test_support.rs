//! The test harness every BSDF uses: a χ² goodness-of-fit test of `sample_f` against `pdf`
//! (after pbrt-v4 `src/pbrt/bsdfs_test.cpp` and Mitsuba 3 `chi2.py`), the directional albedo
//! with its standard error (energy), and a small deterministic generator (whose sphere
//! directions come from [`crate::sampling::uniform_sphere`], as the integrator's do).
//!
//! χ² test: directions are binned on a (θ, φ) grid over the whole sphere, plus one cell for
//! samples that were rejected (`None`). Expected counts integrate `pdf` over each bin
//! numerically (midpoint rule on a sub-grid refined where it has not converged; the rejected
//! cell gets 1 − ∫ pdf). Cells expected to hold fewer than [`MIN_EXPECTED`] samples are pooled
//! into one (Mitsuba does the same); the statistic has (cells − 1) degrees of freedom, and its
//! p-value, the χ² survival function Q(k/2, x/2), is computed here from the regularised
//! incomplete gamma function. A family of m tests is judged at significance 0.01 with Šidák's
//! correction, 1 − 0.99^(1/m) per test.

use std::f64::consts::PI;

use glam::{Vec2, Vec3};

use crate::sampling::uniform_sphere;

/// SplitMix64 (Steele, Lea & Flood 2014) as a test-only uniform generator: deterministic per
/// seed, independent of the integrator's PCG streams.
#[derive(Debug, Clone)]
pub(crate) struct TestRng(u64);

impl TestRng {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 24 bits, exact in f32.
    pub(crate) fn uniform(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    pub(crate) fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }

    /// A uniformly distributed unit vector.
    pub(crate) fn sphere(&mut self) -> Vec3 {
        uniform_sphere(self.uniform2())
    }
}

/// Cells expected to hold fewer samples than this are pooled (the usual χ² validity rule).
pub(crate) const MIN_EXPECTED: f64 = 5.0;

/// Family-wise significance of the χ² tests.
pub(crate) const SIGNIFICANCE: f64 = 0.01;

/// Šidák's per-test significance for a family of `m` tests at family-wise `SIGNIFICANCE`.
pub(crate) fn sidak(m: usize) -> f64 {
    1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / m as f64)
}

/// Grid and sample sizes of one χ² test.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Chi2Config {
    pub(crate) theta_bins: usize,
    pub(crate) phi_bins: usize,
    /// Midpoint sub-cells per bin and axis for the first estimate of the expected counts.
    pub(crate) sub: usize,
    pub(crate) samples: usize,
    pub(crate) seed: u64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Self { theta_bins: 18, phi_bins: 36, sub: 4, samples: 100_000, seed: 1 }
    }
}

/// The outcome of one χ² test.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Chi2Result {
    pub(crate) statistic: f64,
    pub(crate) dof: usize,
    pub(crate) p_value: f64,
    /// Samples landing in cells whose integrated pdf is exactly 0 (a gross error by itself).
    pub(crate) in_empty_cells: usize,
}

fn direction(theta: f64, phi: f64) -> Vec3 {
    let (s, c) = theta.sin_cos();
    Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32)
}

/// Run a χ² test of `sample` (u_c, u ↦ a direction or `None`) against `pdf` (per steradian).
pub(crate) fn chi2_test(
    cfg: Chi2Config,
    mut sample: impl FnMut(f32, Vec2) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Chi2Result {
    let (nt, np) = (cfg.theta_bins, cfg.phi_bins);
    let cells = nt * np;
    // Observed counts; the last cell counts rejected samples.
    let mut observed = vec![0u64; cells + 1];
    let mut rng = TestRng::new(cfg.seed);
    for _ in 0..cfg.samples {
        let uc = rng.uniform();
        let u = rng.uniform2();
        match sample(uc, u) {
            Some(w) if w.is_finite() => {
                let w = w.normalize();
                let theta = f64::from(w.z.clamp(-1.0, 1.0)).acos();
                let phi = f64::from(w.y).atan2(f64::from(w.x)).rem_euclid(2.0 * PI);
                let i = ((theta / PI * nt as f64) as usize).min(nt - 1);
                let j = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
                observed[i * np + j] += 1;
            }
            Some(_) => panic!("sample_f returned a non-finite direction"),
            None => observed[cells] += 1,
        }
    }
    // Expected counts: ∫ pdf sin θ dθ dφ per bin by the midpoint rule on sub × sub cells,
    // refined 3× (up to twice) where a bin's estimate moves by more than a tenth of its
    // standard deviation: steps (visibility cut-offs) and peaks need the finer grid.
    let (dt, dp) = (PI / nt as f64, 2.0 * PI / np as f64);
    let n = cfg.samples as f64;
    let bin = |i: usize, j: usize, sub: usize| {
        let (ht, hp) = (dt / sub as f64, dp / sub as f64);
        let mut sum = 0.0;
        for a in 0..sub {
            let theta = i as f64 * dt + (a as f64 + 0.5) * ht;
            let weight = theta.sin() * ht * hp;
            for b in 0..sub {
                let phi = j as f64 * dp + (b as f64 + 0.5) * hp;
                let p = f64::from(pdf(direction(theta, phi)));
                assert!(p.is_finite() && p >= 0.0, "pdf = {p} at θ {theta}, φ {phi}");
                sum += p * weight;
            }
        }
        sum
    };
    let mut expected = vec![0.0f64; cells + 1];
    let mut total = 0.0;
    for i in 0..nt {
        for j in 0..np {
            let mut sub = cfg.sub;
            let mut estimate = bin(i, j, sub);
            for _ in 0..2 {
                let finer = bin(i, j, 3 * sub);
                let converged = (finer - estimate).abs() * n <= 0.1 * (finer * n).sqrt() + 0.05;
                estimate = finer;
                sub *= 3;
                if converged {
                    break;
                }
            }
            expected[i * np + j] = estimate * n;
            total += estimate;
        }
    }
    expected[cells] = (1.0 - total).max(0.0) * cfg.samples as f64;
    if std::env::var_os("CHI2_DEBUG").is_some() {
        for (c, (&o, &e)) in observed.iter().zip(&expected).enumerate() {
            if (o as f64 - e).powi(2) / e.max(1e-9) > 10.0 {
                eprintln!("cell θ{} φ{}: observed {o}, expected {e:.2}", c / np, c % np);
            }
        }
    }
    chi2_statistic(&observed, &expected)
}

/// Pearson's χ² with low-expectation cells pooled.
pub(crate) fn chi2_statistic(observed: &[u64], expected: &[f64]) -> Chi2Result {
    let mut statistic = 0.0;
    let mut dof = 0usize;
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    let mut in_empty_cells = 0;
    for (&o, &e) in observed.iter().zip(expected) {
        let o = o as f64;
        if e == 0.0 {
            in_empty_cells += o as usize;
        }
        if e < MIN_EXPECTED {
            pooled_obs += o;
            pooled_exp += e;
        } else {
            statistic += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pooled_exp > 0.0 {
        statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        dof += 1;
    } else if pooled_obs > 0.0 {
        statistic = f64::INFINITY;
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = chi2_survival(statistic, dof);
    Chi2Result { statistic, dof, p_value, in_empty_cells }
}

/// P(X > x) for X ~ χ²(k): Q(k/2, x/2).
pub(crate) fn chi2_survival(x: f64, k: usize) -> f64 {
    if !x.is_finite() {
        return 0.0;
    }
    gamma_q(0.5 * k as f64, 0.5 * x)
}

/// ln Γ(x) for x > 0, Lanczos approximation (g = 7, n = 9; coefficients of Godfrey's
/// published set, relative error below 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x) / Γ(a): the power series of P for
/// x < a + 1, Lentz's continued fraction for Q otherwise (both converge fast there).
pub(crate) fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{−x} x^a / Γ(a + 1) Σ x^n / ((a + 1)…(a + n)).
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * log_prefactor.exp()
    } else {
        // Q(a, x) = e^{−x} x^a / Γ(a) · 1 / (x + 1 − a − 1(1 − a) / (x + 3 − a − …)).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        log_prefactor.exp() * h
    }
}

/// Monte Carlo mean and standard error of `estimate()` over `n` draws.
pub(crate) fn mean_and_standard_error(n: usize, mut estimate: impl FnMut() -> f64) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let x = estimate();
        assert!(x.is_finite(), "non-finite estimate {x}");
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(0.0);
    (mean, (var / n as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_survival_matches_tables() {
        // Critical values of χ² (NIST/SEMATECH e-Handbook, table 1.3.6.7.4): P(X > c) = α.
        for (k, c, alpha) in [(1, 6.635, 0.01), (10, 23.209, 0.01), (100, 135.807, 0.01), (50, 67.505, 0.05)] {
            let p = chi2_survival(c, k);
            assert!((p - alpha).abs() < 2e-4 * alpha.max(0.01) / 0.01, "k {k}: Q = {p}, table {alpha}");
        }
        // Exact cases: χ²(2) has survival e^{−x/2}.
        assert!((chi2_survival(3.0, 2) - (-1.5f64).exp()).abs() < 1e-12);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12 && (ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        assert_eq!(chi2_survival(f64::INFINITY, 3), 0.0);
    }

    #[test]
    fn sidak_correction_is_the_family_wise_rate() {
        let m = 32;
        assert!(((1.0 - (1.0 - sidak(m)).powi(m as i32)) - SIGNIFICANCE).abs() < 1e-12);
    }
}
