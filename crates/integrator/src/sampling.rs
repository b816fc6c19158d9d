//! Random numbers, the triangle warp and the power heuristic the path tracer needs (the
//! sphere and hemisphere warps live with the BSDFs in `materials::sampling`).
//!
//! A sample draws its numbers from a [`Sampler`]: padded Sobol' points (the default) or
//! independent numbers. The generator under both is PCG32 (O'Neill 2014, "PCG: A family of
//! simple fast space-efficient statistically good algorithms for random number generation",
//! `pcg32_random_r` and `pcg32_srandom_r`): a sample's own stream seeded from a hash of (seed,
//! pixel, sample index), the Sobol' seeds from a hash of (seed, pixel, block), so that a
//! sample's numbers depend on nothing else: the image does not depend on which thread renders
//! which row.

use glam::Vec2;

/// PCG32's multiplier (O'Neill 2014, `PCG_DEFAULT_MULTIPLIER_64`).
const PCG_MULT: u64 = 6_364_136_223_846_793_005;

/// A PCG32 generator (XSH RR output, 64-bit state).
#[derive(Debug, Clone)]
pub(crate) struct Rng {
    state: u64,
    inc: u64,
}

/// The PCG32 stream of pixel `pixel` for the render seed `seed`.
#[inline]
fn pixel_stream(seed: u64, pixel: u64) -> u64 {
    splitmix64(seed ^ splitmix64(pixel))
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
        Self::of_sample(pixel_stream(seed, pixel), sample)
    }

    /// The stream of sample `sample` of the pixel whose stream is `stream`.
    #[inline]
    fn of_sample(stream: u64, sample: u64) -> Self {
        Self::seeded(stream, splitmix64(stream ^ splitmix64(sample.wrapping_add(0x5851_F42D_4C95_7F2D))))
    }

    /// `pcg32_srandom_r` with stream `stream` and initial state `state`: state 0, step, add the
    /// initial state, step.
    #[inline]
    fn seeded(stream: u64, state: u64) -> Self {
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

/// The random numbers one sample of the path tracer draws.
///
/// `Sobol` is the default: padded, randomised Sobol' points (the design of pbrt-v4's
/// `PaddedSobolSampler`). The decisions whose stratification pays (the hero wavelengths and
/// the position in the pixel; per bounce the light choice and point, the BSDF's lobe and
/// direction, Russian roulette) each take a dimension fixed by the *block* they are in and
/// their order in it: block 0 is the camera's, block 2d + 1 the light sample's at bounce d and
/// block 2d + 2 the BSDF sample's, whatever the path did before (a skipped light sample or an
/// extra decision does not shift the dimensions of the others). A call for one number takes the
/// first Sobol' dimension (the radical inverse of the sample index), a call for two the first
/// two (a (0, 2)-sequence). Each dimension shuffles the sample index with its own nested hash
/// (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4), §4, so dimensions do not
/// correlate) and shifts the digits with its own random XOR (a digital shift: nets stay nets and
/// each number is uniform; full Owen scrambling of the outputs cost +12–21 % of the render
/// against +3–8 % for an error within 6 %, `docs/path-tracer.md`, "Samplers"). So every aligned block of 2^m samples
/// of a pixel is stratified in each dimension, and a (0, m, 2)-net in each pair. The seeds of
/// a block's dimensions are a PCG32 stream of (seed, pixel, block). Decisions only some paths
/// make (cut-outs, a coat or sheen layer, a glTF surface's glass share, a dispersive lane) draw
/// independent numbers [`Sampler::uniform_aside`].
///
/// `Independent` is a PCG32 stream per sample for every decision. With either, a sample's
/// numbers depend only on (seed, pixel, sample index): images do not depend on threads or on
/// how samples are split into parts.
#[derive(Debug, Clone)]
pub(crate) enum Sampler {
    Independent(Rng),
    Sobol(SobolSample),
}

impl Sampler {
    /// Uniform in [0, 1), never 1.
    #[inline]
    pub(crate) fn uniform(&mut self) -> f32 {
        match self {
            Self::Independent(rng) => rng.uniform(),
            Self::Sobol(s) => s.uniform(),
        }
    }

    /// Two uniforms (one stratified pair for `Sobol`).
    #[inline]
    pub(crate) fn uniform2(&mut self) -> Vec2 {
        match self {
            Self::Independent(rng) => rng.uniform2(),
            Self::Sobol(s) => s.uniform2(),
        }
    }

    /// A uniform for a decision that only some paths make (not stratified: independent).
    #[inline]
    pub(crate) fn uniform_aside(&mut self) -> f32 {
        match self {
            Self::Independent(rng) => rng.uniform(),
            Self::Sobol(s) => s.aside().uniform(),
        }
    }

    /// The next calls take the dimensions of block `block` (see [`Sampler`]); independent
    /// numbers have no blocks.
    #[inline]
    pub(crate) fn start_block(&mut self, block: u32) {
        if let Self::Sobol(s) = self {
            s.seeds = SobolSample::block_seeds(s.stream, block);
        }
    }
}

/// Sample `index` of a pixel's padded, randomised Sobol' points; see [`Sampler`].
#[derive(Debug, Clone)]
pub(crate) struct SobolSample {
    /// The sample index bit-reversed: its radical inverse, the first Sobol' dimension, as a
    /// 0.32 fixed-point value.
    radical: u32,
    /// The pixel's PCG32 stream.
    stream: u64,
    /// The seeds of the current block's dimensions (the same for every sample of a pixel).
    seeds: Rng,
    index: u32,
    /// Independent numbers for [`Sampler::uniform_aside`] (this sample's own stream, made at
    /// its first use: most scenes never ask).
    aside: Option<Rng>,
}

impl SobolSample {
    /// Sample `index` of a render whose samples alternate between two independent randomisations
    /// of the points (`--target-error`, `--error-map`): even indices are sample `index / 2` of one,
    /// odd ones of the other. Each half is then a whole stratified sequence, and the two halves'
    /// means are independent, so half their difference has the distribution of the whole mean's
    /// error (`film/estimate.rs`): the split that makes the error estimate honest for Sobol' points.
    pub(crate) fn of_half(seed: u64, pixel: u64, index: u32) -> Self {
        const HALF_SEED: [u64; 2] = [0x6a09_e667_f3bc_c908, 0xbb67_ae85_84ca_a73b];
        Self::new(splitmix64(seed ^ HALF_SEED[(index & 1) as usize]), pixel, index >> 1)
    }

    /// Sample `index` of pixel `pixel`, at block 0.
    pub(crate) fn new(seed: u64, pixel: u64, index: u32) -> Self {
        let stream = pixel_stream(seed, pixel);
        Self { radical: index.reverse_bits(), stream, seeds: Self::block_seeds(stream, 0), index, aside: None }
    }

    /// The stream of block `block`'s seeds in the pixel whose stream is `stream`: its state a
    /// hash of the two (without `pcg32_srandom_r`'s two steps, which the hash makes needless; a
    /// block starts twice a bounce).
    #[inline]
    fn block_seeds(stream: u64, block: u32) -> Rng {
        Rng { state: splitmix64(stream ^ u64::from(block).wrapping_add(SOBOL_BLOCK_OFFSET)), inc: (stream << 1) | 1 }
    }

    /// The sample's own independent stream, as [`Rng::new`] makes it.
    #[inline]
    fn aside(&mut self) -> &mut Rng {
        let (stream, index) = (self.stream, self.index);
        self.aside.get_or_insert_with(|| Rng::of_sample(stream, u64::from(index)))
    }

    /// The shuffled index's radical inverse: a Laine–Karras permutation of the radical inverse
    /// flips each bit of the index by a hash of the bits above it, so every aligned block of
    /// 2^m indices maps onto another.
    #[inline]
    fn shuffled(&mut self) -> u32 {
        laine_karras(self.radical, self.seeds.next_u32())
    }

    #[inline]
    pub(crate) fn uniform(&mut self) -> f32 {
        let x = self.shuffled();
        to_unit(x ^ self.seeds.next_u32())
    }

    #[inline]
    pub(crate) fn uniform2(&mut self) -> Vec2 {
        let x = self.shuffled();
        let y = sobol_second_dimension(x);
        Vec2::new(to_unit(x ^ self.seeds.next_u32()), to_unit(y ^ self.seeds.next_u32()))
    }
}

/// Added to a block's number before hashing it into the state of its seeds' stream: apart from
/// every sample's own state (hashed from the sample index plus PCG's multiplier).
const SOBOL_BLOCK_OFFSET: u64 = 0x2545_F491_4F6C_DD1D;

/// The top 24 bits as a float in [0, 1) (exact, never 1), as [`Rng::uniform`].
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A permutation of u32 in which each bit is flipped by a hash of the bits below it and the
/// seed (Laine & Karras 2011's observation; the constants are Vegdahl 2021's, "Building a
/// Better LK Hash", which scramble all bits well).
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3D20_ADEA);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6C56);
    x ^= x.wrapping_mul(0x53A2_2864);
    x
}

/// The second dimension of Sobol's sequence, as a 0.32 fixed-point value, at the index whose
/// radical inverse is `radical`: the product of the index's bits with its generator matrix
/// (Pascal's triangle mod 2: direction numbers v₁ = 2⁻¹, v_{k+1} = v_k ⊕ v_k/2), a byte at a
/// time from tables (shuffled indices use all 32 bits: a loop over them cost 32 steps a call).
#[inline]
fn sobol_second_dimension(radical: u32) -> u32 {
    let t = &SOBOL_SECOND_TABLES;
    t[0][(radical & 0xFF) as usize]
        ^ t[1][((radical >> 8) & 0xFF) as usize]
        ^ t[2][((radical >> 16) & 0xFF) as usize]
        ^ t[3][(radical >> 24) as usize]
}

/// `SOBOL_SECOND_TABLES[k][b]`: the XOR of the direction numbers of the index bits that bit j
/// of byte `b` at byte `k` of a radical inverse stands for (bit 8k + j of the radical inverse
/// is bit 31 − 8k − j of the index).
static SOBOL_SECOND_TABLES: [[u32; 256]; 4] = sobol_second_tables();

const fn sobol_second_tables() -> [[u32; 256]; 4] {
    let mut directions = [0u32; 32];
    let mut v = 1u32 << 31;
    let mut bit = 0;
    while bit < 32 {
        directions[bit] = v;
        v ^= v >> 1;
        bit += 1;
    }
    let mut tables = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            let mut x = 0;
            let mut j = 0;
            while j < 8 {
                if b & (1 << j) != 0 {
                    x ^= directions[31 - (8 * k + j)];
                }
                j += 1;
            }
            tables[k][b] = x;
            b += 1;
        }
        k += 1;
    }
    tables
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

    /// The value of dimension `dim` of block `block` (as one number or a pair) of sample `i`.
    fn sobol_1d(seed: u64, pixel: u64, i: u32, block: u32, dim: usize) -> f32 {
        at(seed, pixel, i, block, dim).uniform()
    }

    fn sobol_2d(seed: u64, pixel: u64, i: u32, block: u32, dim: usize) -> Vec2 {
        at(seed, pixel, i, block, dim).uniform2()
    }

    fn at(seed: u64, pixel: u64, i: u32, block: u32, dim: usize) -> Sampler {
        let mut s = Sampler::Sobol(SobolSample::new(seed, pixel, i));
        s.start_block(block);
        (0..dim).for_each(|_| {
            s.uniform();
        });
        s
    }

    #[test]
    fn sobols_second_dimension_is_the_generator_product() {
        let reference = |mut i: u32| {
            let (mut v, mut x) = (1u32 << 31, 0u32);
            while i != 0 {
                if i & 1 != 0 {
                    x ^= v;
                }
                i >>= 1;
                v ^= v >> 1;
            }
            x
        };
        // Its first points: 0, ½, ¾, ¼, then ⅝ (index order, not Gray-code order).
        let first: Vec<u32> = (0..5u32).map(|i| sobol_second_dimension(i.reverse_bits())).collect();
        assert_eq!(first, [0, 1 << 31, 3 << 30, 1 << 30, 5 << 29]);
        let mut rng = Rng::new(5, 0, 0);
        for _ in 0..10_000 {
            let i = rng.next_u32();
            assert_eq!(sobol_second_dimension(i.reverse_bits()), reference(i), "{i:#x}");
        }
    }

    /// Every aligned block of 2^m samples of a pixel is stratified: one point in each of the
    /// 2^m intervals of a dimension, and one in each elementary box 2^-a × 2^-(m-a) of a pair
    /// (a (0, m, 2)-net), in every dimension, for any seed and pixel.
    #[test]
    fn sobol_blocks_are_nets_in_every_dimension() {
        for (seed, pixel) in [(0, 0), (7, 12_345), (u64::MAX, 3)] {
            for m in 0..=8u32 {
                let n = 1u32 << m;
                for block in [0, 1, 5] {
                    let samples = block * n..(block + 1) * n;
                    for (b, dim) in [(0, 0), (0, 1), (1, 2), (6, 0), (9, 30)] {
                        let mut seen = vec![false; n as usize];
                        for i in samples.clone() {
                            let u = sobol_1d(seed, pixel, i, b, dim);
                            assert!((0.0..1.0).contains(&u));
                            let cell = (u * n as f32) as usize;
                            assert!(
                                !seen[cell],
                                "1D seed {seed} pixel {pixel} m {m} block {b} dim {dim}: cell {cell} twice"
                            );
                            seen[cell] = true;
                        }
                        for a in 0..=m {
                            let mut seen = vec![false; n as usize];
                            for i in samples.clone() {
                                let u = sobol_2d(seed, pixel, i, b, dim);
                                assert!((0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y));
                                let cx = (u.x * (1u32 << a) as f32) as usize;
                                let cy = (u.y * (1u32 << (m - a)) as f32) as usize;
                                let cell = (cx << (m - a)) | cy;
                                assert!(
                                    !seen[cell],
                                    "2D seed {seed} m {m} a {a} block {b} dim {dim}: box {cell} twice"
                                );
                                seen[cell] = true;
                            }
                        }
                    }
                }
            }
        }
    }

    /// Two dimensions of one pixel must not repeat each other's strata: the estimate of
    /// P([u_a < ½] ≠ [u_b < ½]) = ½ from a pixel's 64 samples scatters about ½ as with
    /// independent numbers (the shuffle pairs samples 2k and 2k+1, so at most twice the
    /// variance 1/(4·64)). Without the per-dimension shuffle (the deliberately wrong sampler
    /// below) both first digits follow the sample index and every estimate is 0 or 1.
    #[test]
    fn sobol_dimensions_do_not_correlate() {
        let n = 64u32;
        let mse = |f: &dyn Fn(u64, u32) -> (f32, f32)| {
            let pixels = 256u64;
            let mut sum = 0.0;
            for pixel in 0..pixels {
                let hits = (0..n).filter(|&i| (f(pixel, i).0 < 0.5) != (f(pixel, i).1 < 0.5)).count();
                sum += (hits as f64 / f64::from(n) - 0.5).powi(2);
            }
            sum / pixels as f64
        };
        let random = 0.25 / f64::from(n);
        for (a, b) in [(0, 1), (2, 5), (3, 4)] {
            let got = mse(&|pixel, i| (sobol_1d(1, pixel, i, 0, a), sobol_1d(1, pixel, i, 0, b)));
            assert!(got < 3.0 * random, "dims {a},{b}: {got} against {random}");
            // The same dimension of two blocks.
            let got = mse(&|pixel, i| (sobol_1d(1, pixel, i, a as u32, 0), sobol_1d(1, pixel, i, b as u32 + 7, 0)));
            assert!(got < 3.0 * random, "blocks {a},{b}: {got} against {random}");
        }
        // The deliberately wrong sampler: each dimension the radical inverse with its own
        // digital shift, and no shuffle.
        let unshuffled = |pixel: u64, i: u32, dim: usize| {
            let Sampler::Sobol(mut s) = at(1, pixel, i, 0, dim) else { unreachable!() };
            s.seeds.next_u32();
            to_unit(s.radical ^ s.seeds.next_u32())
        };
        let wrong = mse(&|pixel, i| (unshuffled(pixel, i, 0), unshuffled(pixel, i, 1)));
        assert!(wrong > 0.2, "the unshuffled sampler went unnoticed: {wrong}");
    }

    #[test]
    fn sobol_samples_differ_by_seed_pixel_index_and_block() {
        let draw = |seed, pixel, i, block| {
            let mut s = at(seed, pixel, i, block, 0);
            let u = s.uniform2();
            [s.uniform(), u.x, u.y, s.uniform_aside()]
        };
        let base = draw(3, 9, 17, 2);
        for other in [draw(4, 9, 17, 2), draw(3, 10, 17, 2), draw(3, 9, 18, 2)] {
            assert!(base.iter().zip(other).all(|(a, b)| *a != b), "{base:?} {other:?}");
        }
        // Another block: other stratified numbers, the same sample's independent stream, which
        // is the one `--sampler independent` gives that sample.
        let other = draw(3, 9, 17, 3);
        assert!(base[..3].iter().zip(&other[..3]).all(|(a, b)| a != b) && base[3] == other[3], "{other:?}");
        assert_eq!(base[3], Rng::new(3, 9, 17).uniform());
        // Over many pixels a sample is uniform in each dimension: means within 5 standard
        // errors of ½, at the first sample and at others.
        let pixels = 20_000;
        for (i, block, dim) in [(0, 0, 0), (0, 0, 3), (5, 1, 0), (1000, 4, 2)] {
            let mean = (0..pixels).map(|p| f64::from(sobol_1d(2, p, i, block, dim))).sum::<f64>() / pixels as f64;
            assert!((mean - 0.5).abs() < 5.0 / (12.0 * pixels as f64).sqrt(), "dim {dim}: {mean}");
        }
    }

    /// Pairs are uniform on the square over many pixels (a χ² test on 4 × 4 cells at sample
    /// indices other than 0), and the test rejects pairs on the diagonal (y = x).
    #[test]
    fn sobol_pairs_are_uniform_over_pixels() {
        let chi2 = |points: &[Vec2]| {
            let mut cells = [0u32; 16];
            for p in points {
                cells[(p.x * 4.0) as usize * 4 + (p.y * 4.0) as usize] += 1;
            }
            let expected = points.len() as f64 / 16.0;
            cells.iter().map(|&c| (f64::from(c) - expected).powi(2) / expected).sum::<f64>()
        };
        // χ² with 15 degrees of freedom exceeds 42 with probability 2 · 10⁻⁴.
        for (i, block, dim) in [(3, 0, 1), (77, 2, 0), (1 << 20, 5, 3)] {
            let points: Vec<Vec2> = (0..16_000).map(|p| sobol_2d(4, p, i, block, dim)).collect();
            let c = chi2(&points);
            assert!(c < 42.0, "sample {i} block {block} dim {dim}: χ² {c}");
            let diagonal: Vec<Vec2> = points.iter().map(|p| Vec2::splat(p.x)).collect();
            assert!(chi2(&diagonal) > 42.0, "the χ² test passes the diagonal");
        }
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
