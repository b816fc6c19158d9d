//! The film's fixed-point arithmetic (why: `film/mod.rs`): sample values to 128-bit integers with 64
//! fractional bits and back, their clamp, and which samples make the second half-film.

/// Fractional bits of the first-moment sums (XYZ, spectral lanes).
pub(crate) const FRACTION_BITS: i32 = 64;
/// Fractional bits of the second-moment sum (Y²): squares need range more than resolution.
/// Y² is kept for Y ≥ 2⁻¹⁶ (1.5·10⁻⁵, in units where white is 1); darker samples add 0 to it,
/// so the variance of pixels that dark reads low.
pub(crate) const SQUARE_FRACTION_BITS: i32 = 32;
/// Largest |Y| whose square the second moment takes as it is: 2³⁷ (1.4·10¹¹, 85× a directly
/// seen sun), so that 2²⁰ samples stay below 2¹²⁷: (2³⁷)²·2³²·2²⁰ = 2¹²⁶. The variance of a
/// pixel brighter than that reads low; its mean is unaffected.
pub(crate) const MAX_SQUARED_LUMINANCE: f64 = 137_438_953_472.0;
/// Largest |sample value| added as it is: 2⁴² (4.4·10¹² — a directly seen sun is ~1.6·10⁹
/// cd/m²). With at most 2²⁰ samples per pixel the sums stay below 2¹²⁷: 2⁴²·2⁶⁴·2²⁰ = 2¹²⁶.
/// Larger values are clamped to it and counted.
pub(crate) const MAX_SAMPLE_VALUE: f64 = 4_398_046_511_104.0;
/// Largest samples per pixel a film accepts (see [`MAX_SAMPLE_VALUE`]).
pub(crate) const MAX_SPP: u32 = 1 << 20;

/// `v · 2^bits` as an integer, exact where representable, truncated towards zero below the
/// last bit; `v` finite and |v| ≤ [`MAX_SAMPLE_VALUE`] (or its square for the second moment).
#[inline]
pub(crate) fn to_fixed(v: f64, bits: i32) -> i128 {
    let raw = v.to_bits();
    let exponent = ((raw >> 52) & 0x7ff) as i32;
    if exponent == 0 {
        return 0; // zero or subnormal (< 2⁻¹⁰²²): far below the last bit
    }
    let mantissa = i128::from((raw & ((1 << 52) - 1)) | (1 << 52));
    // v = mantissa · 2^(exponent − 1075); fixed = mantissa · 2^(exponent − 1075 + bits).
    let shift = exponent - 1075 + bits;
    let magnitude = if shift >= 0 {
        mantissa << shift.min(74)
    } else if shift > -53 {
        mantissa >> -shift
    } else {
        0
    };
    if raw >> 63 == 1 { -magnitude } else { magnitude }
}

/// An f32 sample value as a first-moment term (64 fractional bits): the same integer as
/// `to_fixed(f64::from(v), FRACTION_BITS)`, from the f32's own 24-bit mantissa (the hot path:
/// three or more per sample). `v` finite, |v| ≤ [`MAX_SAMPLE_VALUE`].
#[inline]
pub(crate) fn to_fixed_f32(v: f32) -> i128 {
    let raw = v.to_bits();
    let exponent = ((raw >> 23) & 0xff) as i32;
    if exponent == 0 {
        return 0; // zero or subnormal (< 2⁻¹²⁶): below the last bit, 2⁻⁶⁴
    }
    let mantissa = i128::from((raw & 0x7f_ffff) | 0x80_0000);
    // v = mantissa · 2^(exponent − 150); fixed = mantissa · 2^(exponent − 150 + 64).
    let shift = exponent - 86;
    let magnitude = if shift >= 0 {
        mantissa << shift.min(83)
    } else if shift > -24 {
        mantissa >> -shift
    } else {
        0
    };
    if raw >> 31 == 1 { -magnitude } else { magnitude }
}

/// `2^-bits` for 0 ≤ bits < 1023, exactly (built from the exponent field, no `exp2` call).
#[inline]
pub(crate) fn inverse_power_of_two(bits: i32) -> f64 {
    f64::from_bits(((1023 - bits) as u64) << 52)
}

/// `sum · 2^-bits` rounded to the nearest f64, as `sum as f64` would round it. Sums below
/// 2¹⁰⁶ in magnitude (every sum of values ≤ 2⁴²) split into two parts that f64 holds exactly,
/// so their one addition is the only rounding; larger ones take the general conversion.
#[inline]
pub(crate) fn from_fixed(sum: i128, bits: i32) -> f64 {
    const TWO_53: f64 = 9_007_199_254_740_992.0;
    let high = sum >> 53;
    let low = sum - (high << 53); // in [0, 2^53)
    let value =
        if high.unsigned_abs() < 1 << 53 { (high as i64 as f64) * TWO_53 + low as i64 as f64 } else { sum as f64 };
    value * inverse_power_of_two(bits)
}

/// The mean of a first-moment `sum` over `count` samples (0 for none), as images show it.
#[inline]
pub(crate) fn pixel_mean(sum: i128, count: u32) -> f32 {
    (from_fixed(sum, FRACTION_BITS) * (1.0 / f64::from(count.max(1)))) as f32
}

/// A pixel's value with splats: the mean of its own `sum` over `count` samples plus its
/// `splat` sum times `scale` (1/S, [`super::splat::SplatScales`]).
#[inline]
pub(crate) fn pixel_value(sum: i128, count: u32, splat: i128, scale: f64) -> f32 {
    (from_fixed(sum, FRACTION_BITS) * (1.0 / f64::from(count.max(1))) + from_fixed(splat, FRACTION_BITS) * scale) as f32
}

/// `v` clamped to ±[`MAX_SAMPLE_VALUE`], counting a clamp in `clamped`.
#[inline]
pub(crate) fn clamp_sample(v: f32, clamped: &mut u64) -> f32 {
    // 2⁴² is exact in f32, so the clamp compares and clamps without widening.
    const MAX: f32 = MAX_SAMPLE_VALUE as f32;
    if v.abs() > MAX {
        *clamped += 1;
        MAX.copysign(v)
    } else {
        v
    }
}

/// Whether sample `index` of a pixel belongs to the second of the two half-films: the odd
/// indices. With Sobol' points the two halves are two independent randomisations of the points
/// (`SobolSample::of_half`); with independent numbers any split is independent.
#[inline]
pub(crate) fn second_half(index: u32) -> bool {
    index % 2 == 1
}

/// How many of the sample indices `range` fall in the second half ([`second_half`]).
pub(crate) fn second_half_count(range: std::ops::Range<u32>) -> u32 {
    range.end / 2 - range.start / 2
}
