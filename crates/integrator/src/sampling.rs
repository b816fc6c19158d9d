//! Random numbers, the triangle warp and the power heuristic the path tracer needs (the
//! sphere and hemisphere warps live with the BSDFs in `materials::sampling`).
//!
//! The generator is PCG32 (O'Neill 2014, "PCG: A family of simple fast space-efficient
//! statistically good algorithms for random number generation", `pcg32_random_r` and
//! `pcg32_srandom_r`), seeded from a hash of (seed, pixel, sample index) so that every sample
//! has its own stream: the image does not depend on which thread renders which row.

use glam::Vec2;

/// PCG32's multiplier (O'Neill 2014, `PCG_DEFAULT_MULTIPLIER_64`).
const PCG_MULT: u64 = 6_364_136_223_846_793_005;

/// A PCG32 generator (XSH RR output, 64-bit state).
#[derive(Debug, Clone)]
pub(crate) struct Rng {
    state: u64,
    inc: u64,
}

/// SplitMix64's finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mix, used to turn
/// (seed, pixel, sample) into well-separated PCG states and streams.
#[inline]
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Rng {
    /// The stream of sample `sample` of pixel `pixel` for the render seed `seed`.
    pub(crate) fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let stream = splitmix64(seed ^ splitmix64(pixel));
        let state = splitmix64(stream ^ splitmix64(sample.wrapping_add(0x5851_F42D_4C95_7F2D)));
        // pcg32_srandom_r: state 0, step, add the initial state, step.
        let mut rng = Self { state: 0, inc: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(state);
        rng.next_u32();
        rng
    }

    #[inline]
    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1): the top 24 bits, so the result is exact in f32 and never 1.
    #[inline]
    pub(crate) fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniforms.
    #[inline]
    pub(crate) fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }
}

/// Barycentrics (b0, b1) of a point uniformly distributed over a triangle (Osada et al. 2002,
/// the square-root parameterisation).
#[inline]
pub(crate) fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let s = u.x.sqrt();
    (1.0 - s, u.y * s)
}

/// Veach's power heuristic (β = 2) for the strategy with density `f` against one with `g`.
#[inline]
pub(crate) fn power_heuristic(f: f32, g: f32) -> f32 {
    let (f2, g2) = (f * f, g * g);
    if f2.is_infinite() {
        return 1.0;
    }
    if f2 + g2 > 0.0 { f2 / (f2 + g2) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = (0..8)
            .map({
                let mut r = Rng::new(7, 3, 1);
                move |_| r.uniform()
            })
            .collect();
        let b: Vec<f32> = (0..8)
            .map({
                let mut r = Rng::new(7, 3, 1);
                move |_| r.uniform()
            })
            .collect();
        let c: Vec<f32> = (0..8)
            .map({
                let mut r = Rng::new(7, 3, 2);
                move |_| r.uniform()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn uniforms_have_the_right_mean_and_range() {
        // Mean of n uniforms: 1/2 with standard error 1/√(12 n); 5 standard errors.
        let n = 100_000;
        let mut rng = Rng::new(1, 2, 3);
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += f64::from(u);
        }
        let se = 1.0 / (12.0 * f64::from(n)).sqrt();
        assert!((sum / f64::from(n) - 0.5).abs() < 5.0 * se);
    }
}

/// A piecewise-constant density on [0, 1) with `n` equal pieces ∝ a non-negative function
/// (pbrt-v4 `PiecewiseConstant1D`; PBRT 3rd ed. §13.3.1): sampled by inverting its CDF.
/// A function that is zero everywhere is sampled uniformly (pbrt-v4 does the same).
#[derive(Debug, Clone)]
pub(crate) struct PiecewiseConstant1D {
    func: Vec<f32>,
    /// `cdf[i]`: the probability of the pieces before `i`; `cdf[n]` = 1.
    cdf: Vec<f32>,
    /// ∫₀¹ f = Σ f_i / n.
    integral: f64,
}

impl PiecewiseConstant1D {
    /// The density ∝ `func` (at least one piece; negative or NaN values count as 0).
    pub(crate) fn new(func: &[f32]) -> Self {
        assert!(!func.is_empty(), "a distribution needs at least one piece");
        let func: Vec<f32> = func.iter().map(|&f| if f > 0.0 && f.is_finite() { f } else { 0.0 }).collect();
        let n = func.len();
        // Sums in f64: a row of thousands of texels would lose the small ones in f32.
        let mut running = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        running.push(0.0);
        for &f in &func {
            acc += f64::from(f);
            running.push(acc);
        }
        let integral = acc / n as f64;
        let cdf = if acc > 0.0 {
            running.iter().map(|&c| (c / acc) as f32).collect()
        } else {
            (0..=n).map(|i| i as f32 / n as f32).collect()
        };
        Self { func, cdf, integral }
    }

    /// ∫₀¹ f.
    pub(crate) fn integral(&self) -> f64 {
        self.integral
    }

    /// The density at piece `i` (1 everywhere for a zero function).
    #[inline]
    pub(crate) fn pdf_of(&self, i: usize) -> f32 {
        if self.integral > 0.0 { (f64::from(self.func[i]) / self.integral) as f32 } else { 1.0 }
    }

    /// A point x ∈ [0, 1) for `u` ∈ [0, 1), its density and its piece.
    #[inline]
    pub(crate) fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // The last piece whose CDF start is ≤ u (pieces of zero probability are never chosen: their
        // start equals the next one's).
        let i = self.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 { ((u - self.cdf[i]) / width).clamp(0.0, 1.0) } else { 0.5 };
        // Strictly below 1, so the piece of x is i.
        let x = ((i as f32 + du) / n as f32).min(1.0 - f32::EPSILON / 2.0);
        (x, self.pdf_of(i), i)
    }
}

/// A piecewise-constant density on [0, 1)² over a `width` × `height` grid, rows first (pbrt-v4
/// `PiecewiseConstant2D`; PBRT 3rd ed. §13.6.7): a marginal density over rows, then a conditional
/// one within the chosen row.
#[derive(Debug, Clone)]
pub(crate) struct PiecewiseConstant2D {
    rows: Vec<PiecewiseConstant1D>,
    marginal: PiecewiseConstant1D,
}

impl PiecewiseConstant2D {
    /// The density ∝ `func`, `width` values per row, `height` rows (row 0 at v = 0).
    pub(crate) fn new(func: &[f32], width: usize, height: usize) -> Self {
        assert!(width > 0 && height > 0 && func.len() == width * height, "a {width}×{height} grid");
        let rows: Vec<PiecewiseConstant1D> = func.chunks_exact(width).map(PiecewiseConstant1D::new).collect();
        let marginal = PiecewiseConstant1D::new(&rows.iter().map(|r| r.integral() as f32).collect::<Vec<_>>());
        Self { rows, marginal }
    }

    /// A point (u, v) ∈ [0, 1)² for `u`, its density, and its cell (column, row).
    #[inline]
    pub(crate) fn sample(&self, u: Vec2) -> (Vec2, f32, (usize, usize)) {
        let (v, pdf_row, row) = self.marginal.sample(u.y);
        let (x, pdf_column, column) = self.rows[row].sample(u.x);
        (Vec2::new(x, v), pdf_row * pdf_column, (column, row))
    }

    /// The density of cell (`column`, `row`).
    #[inline]
    pub(crate) fn pdf_of(&self, column: usize, row: usize) -> f32 {
        self.marginal.pdf_of(row) * self.rows[row].pdf_of(column)
    }
}
