//! Each pixel's colour error, estimated from the render's own samples: what `--target-error`
//! stops at, what the progress bar and the summary report, and what `--error-map` writes.
//!
//! **The measure.** The error of a pixel is the CIEDE2000 colour difference between its
//! displayed colour and the converged one: what a viewer of the PNG sees, in the unit colour
//! scientists quote (ΔE00 ≈ 1 is about a just noticeable difference between two patches side by
//! side). Colours are taken as the display shows them: the film's XYZ times the display's scale
//! (2^EV of the view), against a D65 white of Y = 1, and clipped to white at Y = 1 (chromaticity
//! kept), so the noise of a highlight the display clips does not count, and a firefly in a dark
//! pixel counts as the white dot it shows.
//!
//! **The estimate.** A pixel's samples are split into two half-films ([`second_half`]: odd and
//! even sample indices) whose means A and B are independent estimates of the same colour. With
//! Sobol' points each half is its own randomisation of the points (`SobolSample::of_half`), so
//! the halves are independent and each as well stratified as a whole render of its samples; a
//! split of one sequence would not do (its halves are worse stratified than the whole, so their
//! difference overstates its error: 1.5–1.8× measured on direct light). With n_A and n_B samples,
//! the whole mean M = (n_A A + n_B B)/n has error variance σ²/n and A − B has σ²(1/n_A + 1/n_B),
//! so (A − B)·√(n_A n_B)/n has the distribution of M's error while noise is small enough to be
//! linear: ΔE00 between M and M ± (A − B)·√(n_A n_B)/n estimates the pixel's ΔE00 from the truth
//! (M ± ½ (A − B) for equal halves), in mean over pixels, without a reference. It is taken from M,
//! as the true error is: where the display clips, ΔE00 is not linear, and a firefly that whitens
//! half A (and M) would count half as much between A and B as it does between M and the truth
//! (measured on the Cornell box's caustics: 0.67 of the true error, against 0.96–1.01 elsewhere). One pixel's estimate is one draw (a
//! single degree of freedom); decisions are taken on tiles of [`TILE`]² pixels, whose mean is
//! steady to about 10 %.
//!
//! [`second_half`]: crate::film::second_half

use colorimetry::{Lab, Xyz, delta_e_2000};
use rayon::prelude::*;

use crate::film::splat::SplatScales;
use crate::film::{FRACTION_BITS, Film, from_fixed, second_half_count};

/// Side in pixels of the tiles that adaptive sampling decides on: 64 one-draw pixel estimates
/// average to within about 10 % (the mean of |normal| draws has a relative deviation of
/// 0.76/√64), while a small bright object still fills a good part of a tile.
pub const TILE: u32 = 8;

/// The display's white, in the display's linear units: D65 at Y = 1 (CIELAB's reference white
/// for every ΔE00 the renderer computes: this estimate and `auto`'s pilot).
pub(crate) const WHITE: Xyz = Xyz { x: 0.95047, y: 1.0, z: 1.08883 };

/// The estimated error of every pixel and tile of a film.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorEstimate {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Per pixel, row by row from the top: the estimated ΔE00 of its mean from the converged
    /// colour (infinite where a half-film holds no sample of it yet).
    pub pixels: Vec<f32>,
    /// Per tile of [`TILE`]² pixels, row by row: the mean of its pixels' estimates.
    pub tiles: Vec<f32>,
    /// Tiles per row.
    pub tiles_x: u32,
}

impl ErrorEstimate {
    /// Mean of the pixels' estimates (over those that have one; 0 if none has).
    pub fn mean(&self) -> f64 {
        let (sum, n) =
            self.pixels.iter().filter(|e| e.is_finite()).fold((0.0f64, 0u64), |(s, n), &e| (s + f64::from(e), n + 1));
        if n == 0 { 0.0 } else { sum / n as f64 }
    }

    /// The largest tile estimate (infinite while some tile lacks one).
    pub fn worst_tile(&self) -> f64 {
        self.tiles.iter().fold(0.0f64, |m, &e| m.max(f64::from(e)))
    }

    /// The tile holding pixel (`x`, `y`).
    pub fn tile_of(&self, x: u32, y: u32) -> usize {
        tile_index(x, y, self.tiles_x)
    }
}

/// The tile holding pixel (`x`, `y`) of an image `tiles_x` tiles wide, counted row by row.
#[inline]
pub(crate) fn tile_index(x: u32, y: u32, tiles_x: u32) -> usize {
    (y / TILE) as usize * tiles_x as usize + (x / TILE) as usize
}

/// Tiles per row and per column of a `width` × `height` image.
pub(crate) fn tile_grid(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(TILE), height.div_ceil(TILE))
}

/// An XYZ as the display shows it: at `scale`, non-negative, and clipped at the white's Y with
/// its chromaticity kept.
fn displayed(xyz: [f64; 3], scale: f64) -> Lab {
    let [x, y, z] = xyz.map(|v| (v * scale).max(0.0));
    let clip = if y > 1.0 { 1.0 / y } else { 1.0 };
    Lab::from_xyz(Xyz { x: x * clip, y: y * clip, z: z * clip }, WHITE)
}

/// ΔE00 between two XYZ colours as the display shows them at `scale` (clipped at white): the
/// measure the estimate predicts, for scoring a render against a reference.
pub fn displayed_delta_e(a: [f64; 3], b: [f64; 3], scale: f64) -> f64 {
    delta_e_2000(displayed(a, scale), displayed(b, scale))
}

/// The estimated ΔE00 of one pixel's mean M from the truth: ΔE00 between M and M ± (A − B)·
/// √(n_A n_B)/n, A and B its half-films (½ (A − B) for equal halves), the larger of the two.
/// `total` and `second` are the pixel's sums (all samples, second half), `count` its samples,
/// the first at index `first`.
pub(crate) fn pixel_error(total: [i128; 3], second: [i128; 3], count: u32, first: u32, scale: f64) -> f32 {
    pixel_error_with_splats(total, second, count, first, scale, None)
}

/// [`pixel_error`] of a pixel with splat sums: `splats` holds the pixel's splat sums (all
/// samples', the second half's) and the film's factors for them; each half-film adds its own
/// splats over its own samples per pixel (`film::splat`).
pub(crate) fn pixel_error_with_splats(
    total: [i128; 3],
    second: [i128; 3],
    count: u32,
    first: u32,
    scale: f64,
    splats: Option<([i128; 3], [i128; 3], SplatScales)>,
) -> f32 {
    // A film file may pair any start with any count (a merge checks them; a fuzzed file need not).
    let n_second = second_half_count(first..first.saturating_add(count));
    let n_first = count - n_second;
    if n_first == 0 || n_second == 0 {
        return f32::INFINITY;
    }
    let total = total.map(|s| from_fixed(s, FRACTION_BITS));
    let second = second.map(|s| from_fixed(s, FRACTION_BITS));
    let (inv_a, inv_b) = (1.0 / f64::from(n_first), 1.0 / f64::from(n_second));
    let mut a = [0, 1, 2].map(|c| (total[c] - second[c]) * inv_a);
    let mut b = second.map(|v| v * inv_b);
    let mut mean = total.map(|v| v / f64::from(count));
    if let Some((splat_total, splat_second, scales)) = splats {
        let splat_total = splat_total.map(|s| from_fixed(s, FRACTION_BITS));
        let splat_second = splat_second.map(|s| from_fixed(s, FRACTION_BITS));
        for c in 0..3 {
            a[c] += (splat_total[c] - splat_second[c]) * scales.first_half;
            b[c] += splat_second[c] * scales.second_half;
            mean[c] += splat_total[c] * scales.whole;
        }
    }
    // A draw of the mean's error: the half-films' difference, weighted. It is taken from the
    // mean itself, as the true error is, rather than between the halves: where the display
    // clips (a firefly in one half), ΔE00(A, B) is that of the mean against the truth, not
    // twice it. Of the two signs, the larger: the one that takes the firefly back out.
    let weight = (f64::from(n_first) * f64::from(n_second)).sqrt() / f64::from(count);
    let d = [0, 1, 2].map(|c| weight * (a[c] - b[c]));
    let shown = displayed(mean, scale);
    let plus = displayed([0, 1, 2].map(|c| mean[c] + d[c]), scale);
    let minus = displayed([0, 1, 2].map(|c| mean[c] - d[c]), scale);
    delta_e_2000(shown, plus).max(delta_e_2000(shown, minus)) as f32
}

impl Film {
    /// Each pixel's and tile's estimated error at the display scale `scale` (2^EV: film units to
    /// the display's, where white is 1), its samples being those from index `first` on; `None`
    /// without half-film sums ([`Film::has_halves`]).
    pub fn error_estimate(&self, scale: f64, first: u32) -> Option<ErrorEstimate> {
        if !self.has_halves() {
            return None;
        }
        let width = self.width as usize;
        let pixels: Vec<f32> = match self.splat_scales(first) {
            None => self
                .pixels
                .par_chunks(width)
                .zip(self.halves.par_chunks(width))
                .flat_map_iter(|(row, halves)| {
                    row.iter().zip(halves).map(|(p, h)| pixel_error(p.xyz, *h, p.count, first, scale))
                })
                .collect(),
            Some(scales) => self
                .pixels
                .par_iter()
                .zip(&self.halves)
                .zip(&self.splats.xyz)
                .zip(&self.splats.halves)
                .map(|(((p, h), s), sh)| {
                    pixel_error_with_splats(p.xyz, *h, p.count, first, scale, Some((*s, *sh, scales)))
                })
                .collect(),
        };
        let (tiles_x, tiles_y) = tile_grid(self.width, self.height);
        let mut sums = vec![(0.0f64, 0u32); tiles_x as usize * tiles_y as usize];
        for (i, &e) in pixels.iter().enumerate() {
            let tile = &mut sums[tile_index((i % width) as u32, (i / width) as u32, tiles_x)];
            tile.0 += f64::from(e);
            tile.1 += 1;
        }
        let tiles = sums.iter().map(|&(s, n)| (s / f64::from(n.max(1))) as f32).collect();
        Some(ErrorEstimate { width: self.width, height: self.height, pixels, tiles, tiles_x })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::second_half;

    #[test]
    fn halves_are_odd_and_even_indices_counted_exactly() {
        for start in 0..40 {
            for end in start..80 {
                let counted = (start..end).filter(|&i| second_half(i)).count() as u32;
                assert_eq!(second_half_count(start..end), counted, "{start}..{end}");
            }
        }
    }

    fn fixed(v: f64) -> i128 {
        crate::film::to_fixed(v, FRACTION_BITS)
    }

    #[test]
    fn a_pixel_error_is_half_the_difference_of_its_half_films() {
        // Four samples, indices 0..4: 0 and 2 in the first half, 1 and 3 in the second.
        // First half grey 0.2, second half grey 0.22: the mean 0.21 against 0.20 and 0.22.
        let grey = |y: f64| [WHITE.x * y, y, WHITE.z * y];
        let a = grey(0.2);
        let b = grey(0.22);
        let total = [0, 1, 2].map(|c| fixed(2.0 * a[c] + 2.0 * b[c]));
        let second = [0, 1, 2].map(|c| fixed(2.0 * b[c]));
        let e = pixel_error(total, second, 4, 0, 1.0);
        // The larger is the step down (L* is concave); for small noise about half the halves'
        // difference (within the curvature's 3 %).
        let lab = |y: f64| Lab::from_xyz(Xyz { x: WHITE.x * y, y, z: WHITE.z * y }, WHITE);
        let want = delta_e_2000(lab(0.21), lab(0.20));
        assert!((f64::from(e) / want - 1.0).abs() < 1e-5, "{e} vs {want}");
        assert!(want > delta_e_2000(lab(0.21), lab(0.22)));
        let half = 0.5 * delta_e_2000(lab(0.20), lab(0.22));
        assert!((want / half - 1.0).abs() < 0.03, "{want} vs {half}");
        // L* 51.8 against 54.0: about 1.1 ΔE00 each side.
        assert!((0.9..1.3).contains(&e), "{e}");
        // At four times the scale the colours are brighter; above white both clip: no error.
        assert!(pixel_error(total, second, 4, 0, 4.0) != e);
        assert!(pixel_error(total, second, 4, 0, 100.0) < 1e-9);
        // A firefly: one sample 40 brighter among grey 0.2 ones, in half B. The mean (Y 10.2)
        // shows white, the truth grey; M + ½ (A − B) takes the firefly back out (Y 0.2): the
        // estimate is ΔE00(white, grey 0.2), as the true error is, not half of it as
        // ΔE00(A, B)/2 would say.
        let firefly = [0, 1, 2].map(|c| fixed(4.0 * a[c] + 200.0 * a[c]));
        let second_half = [0, 1, 2].map(|c| fixed(2.0 * a[c] + 200.0 * a[c]));
        let e = f64::from(pixel_error(firefly, second_half, 4, 0, 1.0));
        let white_vs_grey = delta_e_2000(lab(1.0), lab(0.2));
        assert!((e / white_vs_grey - 1.0).abs() < 0.02, "{e} vs {white_vs_grey}");
        // One sample: no second half yet.
        assert_eq!(pixel_error(total, second, 1, 0, 1.0), f32::INFINITY);
    }

    #[test]
    fn the_estimate_follows_the_true_error_of_independent_noise() {
        // Noise of known size on a grey of Y 0.18: the mean estimate over many pixels must be
        // the mean true ΔE00 of their means within a few per cent. Deliberately wrong input, to
        // show the comparison can fail: halves that are not independent (each odd sample a copy
        // of the even one before it) make the same means but no difference between the halves.
        let ratio = |copied_pairs: bool| -> (f64, ErrorEstimate) {
            let (width, height, n) = (64u32, 64u32, 16u32);
            let mut film = Film::new(width, height, Vec::new()).with_halves();
            let mut state = 0x2545_F491_4F6C_DD1Du64;
            let mut normal = || {
                // Sum of 12 uniforms − 6: a normal variable, near enough.
                let mut s = 0.0;
                for _ in 0..12 {
                    state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                    s += (state >> 11) as f64 / (1u64 << 53) as f64;
                }
                s - 6.0
            };
            let truth = [WHITE.x * 0.18, 0.18, WHITE.z * 0.18];
            let mut true_error = 0.0;
            let mut rows = film.rows_mut().collect::<Vec<_>>();
            for row in rows.iter_mut() {
                for x in 0..width as usize {
                    let mut sum = [0.0f64; 3];
                    let mut xyz = [0.0f32; 3];
                    for i in 0..n {
                        if !(copied_pairs && i % 2 == 1) {
                            let (noise, chroma) = (0.02 * normal(), 0.01 * normal());
                            let v = [truth[0] + noise + chroma, truth[1] + noise, truth[2] + noise - chroma];
                            xyz = v.map(|c| c as f32);
                        }
                        row.add_sample::<1>(x, i, xyz, &[0.0]);
                        for c in 0..3 {
                            sum[c] += f64::from(xyz[c]);
                        }
                    }
                    let mean = sum.map(|s| s / f64::from(n));
                    true_error += delta_e_2000(displayed(mean, 1.0), displayed(truth, 1.0));
                }
            }
            drop(rows);
            let true_error = true_error / f64::from(width * height);
            let estimate = film.error_estimate(1.0, 0).unwrap();
            (estimate.mean() / true_error, estimate)
        };
        let (right, estimate) = ratio(false);
        assert!((0.93..1.07).contains(&right), "estimated over true: {right}");
        assert_eq!(estimate.tiles.len(), 64);
        assert!(estimate.worst_tile() < 1.5 * estimate.mean());
        let (wrong, _) = ratio(true);
        assert!(!(0.93..1.07).contains(&wrong), "{wrong}");
    }
}
