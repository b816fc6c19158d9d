//! The precomputed coefficient table (Jakob & Hanika 2019, §4; pbrt-v4
//! `RGBToSpectrumTable`): fits on a grid over the RGB cube, looked up with
//! trilinear interpolation in coefficient space, in f64 to start the per-colour
//! refinement ([`Table::lookup`]) and in f32 as the texel path's answer without a
//! fit ([`Table::lookup_f32`]).
//!
//! # Layout
//! The cube is split by which channel is largest (`l` = 0, 1, 2 for r, g, b).
//! Within block `l` a colour is `(z, x·z, y·z)` rotated so that `z` lands on
//! channel `l`, `x` on channel `l + 1` and `y` on channel `l + 2` (mod 3): `z` is
//! the largest channel and `x, y ∈ [0, 1]` are ratios, sampled evenly. `z` is
//! sampled at `smoothstep(smoothstep(k / (res − 1)))`, which crowds the samples
//! near black and white where the coefficients change fastest (the paper's §4
//! and pbrt-v4's `rgb2spec_opt`).
//!
//! # File format (little-endian)
//! | bytes | content |
//! | --- | --- |
//! | 0..8 | magic `SPTRJH19` |
//! | 8..12 | `u32` format version, [`VERSION`] |
//! | 12..16 | `u32` resolution `res` (≥ 2) |
//! | 16.. | `3 · res³ · 3` `f32`: for `l`, then `k` (z), then `j` (y), then `i` (x), the coefficients `a, b, c` of `a t² + b t + c` in the normalised wavelength `t = (λ − 360)/470` |

use super::fit::{Coefficients, ForwardModel, fit};

/// File magic: "spectrace, Jakob–Hanika 2019".
pub(crate) const MAGIC: [u8; 8] = *b"SPTRJH19";
/// Format version; bump when the layout or the meaning of the coefficients changes.
pub(crate) const VERSION: u32 = 1;
/// Header length in bytes (magic, version, resolution).
pub(crate) const HEADER_LEN: usize = 16;
/// Largest resolution the parser accepts (64 is pbrt-v4's; 256 would be 600 MB).
pub(crate) const MAX_RESOLUTION: usize = 128;

/// Iteration budget of one table fit. Fits start from the neighbouring entry
/// and usually converge in fewer than 10; the budget only bounds the few
/// unreachable targets (z = 0, exact black, and the corner at white).
const TABLE_FIT_ITERATIONS: usize = 200;

/// Bound on the table's (normalised) coefficients. Reachable targets need at
/// most about 3600 (dark saturated ones at the first non-zero z sample, where
/// the coefficients grow like 1/√z); the bound, three times that, keeps
/// the unreachable ones near white from running off towards a step function
/// (coefficients of 1e5 and more), which would spoil the trilinear
/// interpolation for every colour in the neighbouring cells.
const TABLE_MAX_COEFFICIENT: f64 = 1e4;

/// Why an embedded table could not be read.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum TableError {
    /// The file is shorter than its header.
    Truncated { len: usize },
    /// The first 8 bytes are not [`MAGIC`].
    Magic,
    /// A format version this code does not read.
    Version { found: u32 },
    /// Resolution outside `2..=MAX_RESOLUTION`.
    Resolution { found: u32 },
    /// The payload does not hold `3 · res³ · 3` floats.
    Length { expected: usize, found: usize },
    /// A coefficient is NaN or infinite.
    NonFinite { index: usize },
}

/// `z` sample positions: `smoothstep(smoothstep(k / (res − 1)))`, increasing from 0 to 1.
pub(crate) fn z_samples(resolution: usize) -> Vec<f64> {
    let smoothstep = |x: f64| x * x * (3.0 - 2.0 * x);
    (0..resolution).map(|k| smoothstep(smoothstep(k as f64 / (resolution - 1) as f64))).collect()
}

/// The colour that entry `(l, k, j, i)` stands for.
pub(crate) fn entry_color(resolution: usize, z_samples: &[f64], l: usize, k: usize, j: usize, i: usize) -> [f64; 3] {
    let z = z_samples[k];
    let step = (resolution - 1) as f64;
    let mut rgb = [0.0; 3];
    rgb[l] = z;
    rgb[(l + 1) % 3] = i as f64 / step * z;
    rgb[(l + 2) % 3] = j as f64 / step * z;
    rgb
}

/// Index of the first of an entry's three coefficients in the flat payload.
pub(crate) fn entry_offset(resolution: usize, l: usize, k: usize, j: usize, i: usize) -> usize {
    3 * (((l * resolution + k) * resolution + j) * resolution + i)
}

/// A decoded table.
#[derive(Debug, Clone)]
pub(crate) struct Table {
    resolution: usize,
    z_samples: Vec<f64>,
    coefficients: Vec<f32>,
    /// `z_samples` in f32, for [`Table::lookup_f32`].
    z_samples_f32: Vec<f32>,
    /// `inverse_sigmoid(z_samples[k])` in f32 (the last, `+∞` at z = 1, is not used).
    z_inverse: Vec<f32>,
    /// `1 / (z_inverse[k + 1] − z_inverse[k])`, except in the last cell
    /// `1 / (z_samples[k + 1] − z_samples[k])` (see [`Table::lookup_f32`]).
    z_cell_scale: Vec<f32>,
    /// For each of [`Z_BINS`] even bins of z, the last sample `k ≤ res − 2` with
    /// `z_samples[k] ≤` the bin's start: the binary search of `lookup` becomes an index
    /// and a step or two.
    z_bin_start: Vec<u8>,
    /// `res − 1` in f32.
    last_index_f32: f32,
}

/// Even z bins of the `lookup_f32` index (resolution ≤ 128 fits in a `u8`).
const Z_BINS: usize = 256;

/// The inverse of the sigmoid `s(x) = ½ + x / (2√(1 + x²))`:
/// `x = (2s − 1) / (2√(s (1 − s)))` (from `(2s − 1)² = x² / (1 + x²)`).
///
/// The z axis of [`Table::lookup_f32`] is interpolated in this variable: along a
/// grey column the coefficients are `(0, 0, s⁻¹(z))`, so the interpolation is
/// exact there, and for dark colours (`s(x) ≈ 1/(4x²)`, coefficients ∝ 1/√z) it
/// follows the coefficients' own growth. Measured on the committed table: mean
/// ΔE00 at the midpoints between z samples 0.031 instead of 0.18 with weights
/// linear in z.
#[inline]
fn inverse_sigmoid(s: f32) -> f32 {
    (2.0 * s - 1.0) / (2.0 * (s * (1.0 - s)).sqrt())
}

impl Table {
    /// Decodes the file format in the module docs.
    pub(crate) fn parse(bytes: &[u8]) -> Result<Self, TableError> {
        if bytes.len() < HEADER_LEN {
            return Err(TableError::Truncated { len: bytes.len() });
        }
        if bytes[0..8] != MAGIC {
            return Err(TableError::Magic);
        }
        let read_u32 = |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
        let version = read_u32(8);
        if version != VERSION {
            return Err(TableError::Version { found: version });
        }
        let found = read_u32(12);
        let resolution = found as usize;
        if !(2..=MAX_RESOLUTION).contains(&resolution) {
            return Err(TableError::Resolution { found });
        }
        let payload = &bytes[HEADER_LEN..];
        let expected = 4 * 9 * resolution.pow(3);
        if payload.len() != expected {
            return Err(TableError::Length { expected, found: payload.len() });
        }
        // `include_bytes!` data is only byte-aligned: decode each float, never cast the slice.
        let coefficients: Vec<f32> =
            payload.chunks_exact(4).map(|chunk| f32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]])).collect();
        if let Some(index) = coefficients.iter().position(|c| !c.is_finite()) {
            return Err(TableError::NonFinite { index });
        }
        let z_samples = z_samples(resolution);
        let z_samples_f32: Vec<f32> = z_samples.iter().map(|&z| z as f32).collect();
        let z_inverse: Vec<f32> = z_samples_f32.iter().map(|&z| inverse_sigmoid(z)).collect();
        let z_cell_scale = (0..resolution - 1)
            .map(|k| {
                if k + 2 == resolution {
                    1.0 / (z_samples_f32[k + 1] - z_samples_f32[k])
                } else {
                    1.0 / (z_inverse[k + 1] - z_inverse[k])
                }
            })
            .collect();
        let z_bin_start = (0..Z_BINS)
            .map(|bin| {
                let start = bin as f32 / Z_BINS as f32;
                (z_samples_f32.partition_point(|&z| z <= start).saturating_sub(1).min(resolution - 2)) as u8
            })
            .collect();
        let last_index_f32 = (resolution - 1) as f32;
        Ok(Self {
            resolution,
            z_samples,
            coefficients,
            z_samples_f32,
            z_inverse,
            z_cell_scale,
            z_bin_start,
            last_index_f32,
        })
    }

    /// The resolution from the header.
    #[cfg(test)]
    pub(crate) fn resolution(&self) -> usize {
        self.resolution
    }

    /// The stored coefficients of entry `(l, k, j, i)`.
    pub(crate) fn entry(&self, l: usize, k: usize, j: usize, i: usize) -> Coefficients {
        let at = entry_offset(self.resolution, l, k, j, i);
        [self.coefficients[at] as f64, self.coefficients[at + 1] as f64, self.coefficients[at + 2] as f64]
    }

    /// The `z` sample positions.
    #[cfg(test)]
    pub(crate) fn z_samples(&self) -> &[f64] {
        &self.z_samples
    }

    /// Trilinear interpolation of the coefficients at `rgb ∈ [0, 1]³` with a
    /// positive largest channel (black has no table entry worth interpolating).
    pub(crate) fn lookup(&self, rgb: [f64; 3]) -> Coefficients {
        let res = self.resolution;
        // The largest channel picks the block; on ties either block holds the
        // same colour (the tied ratio is 1), so the first is as good as any.
        let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let z = rgb[l];
        debug_assert!(z > 0.0 && z <= 1.0, "lookup needs a positive largest channel, got {rgb:?}");
        let step = (res - 1) as f64;
        let (i, dx) = cell(rgb[(l + 1) % 3] / z * step, res);
        let (j, dy) = cell(rgb[(l + 2) % 3] / z * step, res);
        let z_first = self.z_samples[1];
        if z < z_first {
            // Below the first non-black sample the k = 0 entries (fits of exact
            // black, stopped at some large negative offset) are no guide. There
            // the sigmoid is deep in its tail, s(x) ≈ 1/(4x²), so scaling every
            // coefficient by √(z_first / z) scales the spectrum by z / z_first:
            // same chromaticity, the right brightness.
            let factor = (z_first / z).sqrt();
            return self.interpolate(l, [(1, 1.0)], (j, dy), (i, dx)).map(|c| c * factor);
        }
        // Last sample ≤ z, kept inside the grid so that k + 1 exists.
        let k = self.z_samples.partition_point(|&s| s <= z).saturating_sub(1).min(res - 2);
        let dz = ((z - self.z_samples[k]) / (self.z_samples[k + 1] - self.z_samples[k])).clamp(0.0, 1.0);
        self.interpolate(l, [(k, 1.0 - dz), (k + 1, dz)], (j, dy), (i, dx))
    }

    /// The texel path (`RgbSigmoid::from_rgb`): the same table as [`Table::lookup`],
    /// in f32, with the z weight taken in the inverse-sigmoid variable (see
    /// [`inverse_sigmoid`]). No fit: an index into the z samples and a trilinear blend
    /// of 8 entries (about 150 instructions). Needs `rgb ∈ [0, 1]³` with a positive
    /// largest channel.
    ///
    /// [`Table::lookup`] stays as it is because it is the start of the exact fit:
    /// changing it would move every fitted scene colour by rounding.
    #[inline]
    pub(crate) fn lookup_f32(&self, rgb: [f32; 3]) -> [f32; 3] {
        let [r, g, b] = rgb;
        // Block l: z on channel l, x on l + 1, y on l + 2 (mod 3).
        let (l, z, x, y) = if r >= g && r >= b {
            (0, r, g, b)
        } else if g >= b {
            (1, g, b, r)
        } else {
            (2, b, r, g)
        };
        debug_assert!(z > 0.0 && z <= 1.0, "lookup needs a positive largest channel, got {rgb:?}");
        let scale = self.last_index_f32 / z;
        let (i, dx) = self.cell_f32(x * scale);
        let (j, dy) = self.cell_f32(y * scale);
        let w = inverse_sigmoid(z);
        if z < self.z_samples_f32[1] {
            // Below the first non-black sample (see `lookup`): the k = 1 fits scaled to
            // the requested darkness, coefficients ∝ s⁻¹(z) (∝ 1/√z in the sigmoid's tail).
            let factor = w / self.z_inverse[1];
            return self.blend_f32(l, 1, 0.0, (j, dy), (i, dx)).map(|c| c * factor);
        }
        // Last sample ≤ z (kept ≤ res − 2 so that k + 1 exists): the bin's start, then
        // forward over the samples inside the bin (several only in the first bins, where
        // the samples crowd near black).
        let res = self.resolution;
        let mut k = usize::from(self.z_bin_start[((z * Z_BINS as f32) as usize).min(Z_BINS - 1)]);
        while k + 2 < res && self.z_samples_f32[k + 1] <= z {
            k += 1;
        }
        let dz = if k + 2 == res {
            // s⁻¹(1) = +∞: the last cell blends linearly in z.
            (z - self.z_samples_f32[k]) * self.z_cell_scale[k]
        } else {
            (w - self.z_inverse[k]) * self.z_cell_scale[k]
        };
        self.blend_f32(l, k, dz.clamp(0.0, 1.0), (j, dy), (i, dx))
    }

    /// Cell index `≤ res − 2` and fraction of a grid coordinate `u ∈ [0, res − 1]`.
    #[inline(always)]
    fn cell_f32(&self, u: f32) -> (usize, f32) {
        // max/min rather than clamp: no min ≤ max check at run time (NaN becomes 0).
        let u = u.max(0.0).min(self.last_index_f32);
        // i32 conversions: one instruction each (u ≤ 127, so no saturation is needed).
        let index = (u as i32).min(self.resolution as i32 - 2);
        (index as usize, u - index as f32)
    }

    /// Trilinear blend in f32 of block `l`'s entries at `(k, k + 1) × (j, j + 1) × (i, i + 1)`.
    #[inline(always)]
    fn blend_f32(&self, l: usize, k: usize, dz: f32, (j, dy): (usize, f32), (i, dx): (usize, f32)) -> [f32; 3] {
        let res = self.resolution;
        // Entries (k, j, i) and (k, j, i + 1) are adjacent: one slice of 6 floats per (k, j),
        // the four of them `3·res` (next j) and `3·res²` (next k) floats apart.
        let base = entry_offset(res, l, k, j, i);
        let (next_j, next_k) = (3 * res, 3 * res * res);
        let cube = &self.coefficients[base..base + next_k + next_j + 6];
        let (wx0, wx1) = (1.0 - dx, dx);
        let mut out = [0.0f32; 3];
        for (offset_k, weight_k) in [(0, 1.0 - dz), (next_k, dz)] {
            for (offset_j, weight_j) in [(0, 1.0 - dy), (next_j, dy)] {
                let at = offset_k + offset_j;
                let pair = &cube[at..at + 6];
                let weight = weight_k * weight_j;
                let (w0, w1) = (weight * wx0, weight * wx1);
                for c in 0..3 {
                    out[c] += w0 * pair[c] + w1 * pair[3 + c];
                }
            }
        }
        out
    }

    /// Weighted sum of block `l`'s entries over the given `z` samples and the
    /// `(j, j + 1) × (i, i + 1)` cell with fractions `dy`, `dx`.
    fn interpolate<const N: usize>(
        &self,
        l: usize,
        z_weights: [(usize, f64); N],
        (j, dy): (usize, f64),
        (i, dx): (usize, f64),
    ) -> Coefficients {
        let mut out = [0.0; 3];
        for (corner_k, weight_k) in z_weights {
            for (corner_j, weight_j) in [(j, 1.0 - dy), (j + 1, dy)] {
                for (corner_i, weight_i) in [(i, 1.0 - dx), (i + 1, dx)] {
                    let weight = weight_k * weight_j * weight_i;
                    let entry = self.entry(l, corner_k, corner_j, corner_i);
                    for (o, e) in out.iter_mut().zip(entry) {
                        *o += weight * e;
                    }
                }
            }
        }
        out
    }
}

/// Cell index and fraction of a grid coordinate `u ∈ [0, res − 1]`.
fn cell(u: f64, res: usize) -> (usize, f64) {
    let u = u.clamp(0.0, (res - 1) as f64);
    let index = (u.floor() as usize).min(res - 2);
    (index, u - index as f64)
}

/// Residual (ΔE*ab) above which a table fit counts as inexact and is retried.
const INEXACT: f64 = 1e-6;

/// Summary of a table build, for the xtask report.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BuildStats {
    /// Largest fit residual (CIELAB ΔE*ab) over entries with `z > 0`.
    pub(crate) max_residual: f64,
    /// Entries with `z > 0` whose fit residual exceeds 1e-6 ΔE*ab.
    pub(crate) inexact: usize,
}

/// Fits every entry and encodes the table (header included).
///
/// Each `(l, j, i)` column is fitted along `z`, as the paper does: from zero
/// coefficients at `k = res / 5` (a mid-dark colour the fit reaches from a flat
/// grey start) upwards, then from that first fit downwards, each fit starting
/// from its neighbour's result.
pub(crate) fn build(model: &ForwardModel, resolution: usize) -> (Vec<u8>, BuildStats) {
    assert!((2..=MAX_RESOLUTION).contains(&resolution), "table resolution {resolution} outside 2..={MAX_RESOLUTION}");
    let zs = z_samples(resolution);
    let mut coefficients = vec![0.0f32; 9 * resolution.pow(3)];
    let mut stats = BuildStats { max_residual: 0.0, inexact: 0 };
    let first = resolution / 5;
    for l in 0..3 {
        for j in 0..resolution {
            for i in 0..resolution {
                let mut store = |k: usize, start: Coefficients| {
                    let target = entry_color(resolution, &zs, l, k, j, i);
                    let mut result = fit(model, target, start, TABLE_FIT_ITERATIONS, TABLE_MAX_COEFFICIENT);
                    if result.residual > INEXACT && k > 0 {
                        // A neighbour's solution can be a poor start across a
                        // sharp change; flat grey is the paper's neutral start.
                        let fresh = fit(model, target, [0.0; 3], TABLE_FIT_ITERATIONS, TABLE_MAX_COEFFICIENT);
                        if fresh.residual < result.residual {
                            result = fresh;
                        }
                    }
                    let at = entry_offset(resolution, l, k, j, i);
                    for c in 0..3 {
                        coefficients[at + c] = result.coefficients[c] as f32;
                    }
                    if k > 0 {
                        stats.max_residual = stats.max_residual.max(result.residual);
                        stats.inexact += usize::from(result.residual > INEXACT);
                    }
                    result.coefficients
                };
                let anchor = store(first, [0.0; 3]);
                let mut previous = anchor;
                for k in first + 1..resolution {
                    previous = store(k, previous);
                }
                previous = anchor;
                for k in (0..first).rev() {
                    previous = store(k, previous);
                }
            }
        }
    }
    let mut bytes = Vec::with_capacity(HEADER_LEN + 4 * coefficients.len());
    bytes.extend_from_slice(&MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&(resolution as u32).to_le_bytes());
    for c in coefficients {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    (bytes, stats)
}
