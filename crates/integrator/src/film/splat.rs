//! Splat sums: light a sample sends to other pixels than its own (bidirectional path tracing's
//! t = 1 strategy, [`crate::integrators::Splat`]), kept beside the film's own sums and exact in
//! the same way.
//!
//! **Normalisation.** A pixel's own sums estimate its measurement per sample of *that* pixel,
//! but a splat is a sample of the whole image landing anywhere: pbrt-v4's `RGBFilm::AddSplat`
//! and Veach's light tracing divide the splat sums by the samples per pixel. Here that is
//! S = (samples over all pixels) / pixels, read from the film's counts, so a render stopped by
//! a time limit, an adaptive one or a merge of sample ranges is normalised by the samples it
//! actually holds: a pixel's value is (own sums / its count) + (splat sums / S). The half-films
//! of the error estimate do the same per half: a splat belongs to the half of the sample index
//! that made it ([`crate::film::second_half`]), and a half's splat sums are divided by that half's samples
//! per pixel. The luminance variance ([`Film::luminance_variance`]) is the own samples' alone:
//! a splat's variance is not a per-pixel sum of squares.
//!
//! **Order.** Rows run in parallel and splats land in any row, so each row's splat sums have a
//! lock of their own ([`SplatTarget`]); a row task converts its samples' splats, keeps a bounded
//! batch of them and adds each batch row by row. Integer sums do not depend on the order of
//! the additions, so the film is the same bits for any thread count.

use std::sync::{Mutex, PoisonError};

use crate::film::fixed::{clamp_sample, to_fixed_f32};

/// Σ X, Σ Y, Σ Z of the splats per pixel (fixed point, 64 fractional bits), Σ lane values per
/// pixel with a spectral film (pixel-major), and Σ X, Σ Y, Σ Z of the splats made by samples of
/// the second half-film where the film keeps halves. All empty without splats.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct SplatSums {
    pub(crate) xyz: Vec<[i128; 3]>,
    pub(crate) spectral: Vec<i128>,
    pub(crate) halves: Vec<[i128; 3]>,
}

/// One splat as the pixel loop passes it to the film: its pixel (index row by row), whether the
/// sample that made it is in the second half-film, and its XYZ and lane values
/// ([`crate::film::Sensor::to_xyz`], as a sample's own value).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SplatValue<const N: usize> {
    pub(crate) pixel: usize,
    pub(crate) second: bool,
    pub(crate) xyz: [f32; 3],
    pub(crate) values: [f32; N],
}

/// Splats a row task keeps before adding them to the film: a bounded batch (a pass's splats are
/// never collected at once), large enough that taking the row locks costs nothing next to the
/// samples that made them (at 1024 splats of up to 96 lanes: about 100 kB per thread).
pub(crate) const SPLAT_BATCH: usize = 1024;

/// One row's splat sums, lent to a pass.
struct SplatRow<'a> {
    xyz: &'a mut [[i128; 3]],
    spectral: &'a mut [i128],
    halves: &'a mut [[i128; 3]],
    nonfinite: u64,
    clamped: u64,
}

/// A film's splat sums lent to one pass of the pixel loop, a lock per row
/// ([`Film::pass_mut`]).
pub(crate) struct SplatTarget<'a> {
    rows: Vec<Mutex<SplatRow<'a>>>,
    width: usize,
    lanes: usize,
}

impl<'a> SplatTarget<'a> {
    /// The rows of `sums` (empty sums: a target that takes nothing).
    pub(crate) fn new(sums: &'a mut SplatSums, width: usize, lanes: usize) -> Self {
        if sums.xyz.is_empty() {
            return Self { rows: Vec::new(), width, lanes };
        }
        let height = sums.xyz.len() / width;
        let mut spectral = sums.spectral.chunks_mut((width * lanes).max(1));
        let mut halves = sums.halves.chunks_mut(width);
        let rows = sums
            .xyz
            .chunks_mut(width)
            .map(|xyz| {
                Mutex::new(SplatRow {
                    xyz,
                    spectral: if lanes > 0 { spectral.next().unwrap_or_default() } else { &mut [] },
                    halves: halves.next().unwrap_or_default(),
                    nonfinite: 0,
                    clamped: 0,
                })
            })
            .collect::<Vec<_>>();
        debug_assert_eq!(rows.len(), height);
        Self { rows, width, lanes }
    }

    /// Add a batch of splats (and empty it): sorted by pixel, so each row's lock is taken once.
    /// A splat is checked as [`crate::film::FilmRow::add_sample`] checks a sample: non-finite,
    /// it is dropped and counted; beyond 2⁴², clamped and counted.
    pub(crate) fn add<const N: usize>(&self, batch: &mut Vec<SplatValue<N>>) {
        if self.rows.is_empty() {
            batch.clear();
            return;
        }
        batch.sort_unstable_by_key(|s| s.pixel);
        for group in batch.chunk_by(|a, b| a.pixel / self.width == b.pixel / self.width) {
            let Some(row) = self.rows.get(group[0].pixel / self.width) else {
                debug_assert!(false, "a splat outside the film: pixel {}", group[0].pixel);
                continue;
            };
            let mut row = row.lock().unwrap_or_else(PoisonError::into_inner);
            for s in group {
                row.add(s.pixel % self.width, s, self.lanes);
            }
        }
        batch.clear();
    }

    /// The non-finite and clamped splats counted in this pass (the sums are in the film).
    pub(crate) fn finish(self) -> (u64, u64) {
        self.rows.into_iter().fold((0, 0), |(n, c), row| {
            let row = row.into_inner().unwrap_or_else(PoisonError::into_inner);
            (n + row.nonfinite, c + row.clamped)
        })
    }
}

impl SplatRow<'_> {
    fn add<const N: usize>(&mut self, x: usize, s: &SplatValue<N>, lanes: usize) {
        let finite = s.xyz.iter().all(|v| v.is_finite()) && s.values.iter().take(lanes).all(|v| v.is_finite());
        if !finite {
            self.nonfinite += 1;
            return;
        }
        let fixed = s.xyz.map(|v| to_fixed_f32(clamp_sample(v, &mut self.clamped)));
        for (sum, v) in self.xyz[x].iter_mut().zip(fixed) {
            *sum += v;
        }
        if !self.halves.is_empty() && s.second {
            for (sum, v) in self.halves[x].iter_mut().zip(fixed) {
                *sum += v;
            }
        }
        if lanes > 0 {
            let sums = &mut self.spectral[x * lanes..(x + 1) * lanes];
            for (sum, &v) in sums.iter_mut().zip(&s.values) {
                *sum += to_fixed_f32(clamp_sample(v, &mut self.clamped));
            }
        }
    }
}

/// 1/S for the whole film and for each half-film: pixels over the samples they hold (0 where
/// none), the factors the splat sums are multiplied by ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SplatScales {
    pub(crate) whole: f64,
    pub(crate) first_half: f64,
    pub(crate) second_half: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Film;
    use crate::film::fixed::MAX_SAMPLE_VALUE;

    #[test]
    fn non_finite_splats_are_dropped_and_huge_ones_clamped_and_both_counted() {
        let mut film = Film::new(2, 2, vec![500.0]).with_halves().with_splats();
        let (nonfinite, clamped) = {
            let (_, target) = film.pass_mut();
            let splat = |pixel, second, xyz, value| SplatValue::<2> { pixel, second, xyz, values: [value, f32::NAN] };
            let mut batch = vec![
                splat(3, true, [1.0, 2.0, 0.5], 4.0),
                splat(3, false, [f32::NAN, 1.0, 1.0], 1.0),
                splat(2, false, [1.0, 1.0, 1.0], f32::INFINITY),
                splat(0, false, [1e20, 0.25, 0.0], 1e20),
                splat(3, false, [1.0, 2.0, 0.5], 4.0),
            ];
            target.add(&mut batch);
            assert!(batch.is_empty());
            target.finish()
        };
        // The NaN lane beyond the film's one wavelength is not read.
        assert_eq!((nonfinite, clamped), (2, 2));
        let one = |v: f64| crate::film::to_fixed(v, crate::film::FRACTION_BITS);
        assert_eq!(film.splats.xyz[3], [one(2.0), one(4.0), one(1.0)]);
        assert_eq!(film.splats.halves[3], [one(1.0), one(2.0), one(0.5)], "only the second-half splat");
        assert_eq!(film.splats.spectral, [one(MAX_SAMPLE_VALUE), 0, 0, one(8.0)]);
        assert_eq!(film.splats.xyz[0][0], one(MAX_SAMPLE_VALUE));
        assert_eq!(film.splats.xyz[2], [0; 3]);
        // No samples yet: the splats have nothing to be divided by.
        assert_eq!(film.splat_scales(0).map(|s| s.whole), Some(0.0));
    }
}
