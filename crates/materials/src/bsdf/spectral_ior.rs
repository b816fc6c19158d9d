//! Measured complex refractive indices η(λ) + iκ(λ) of metals (`data/metals/*.csv`, see
//! `data/PROVENANCE.md`), interpolated linearly in wavelength and held constant past the
//! table's ends.

use std::str::FromStr;
use std::sync::LazyLock;

use colorimetry::{SampledSpectrum, SampledWavelengths};

use crate::error::Error;

/// The text of `data/metals/<file>`, embedded.
macro_rules! metal_file {
    ($file:literal) => {
        include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/metals/", $file))
    };
}

/// Declares [`Metal`], [`METALS`] and [`KNOWN_METALS`] from one list (the first entry apart,
/// for the separators), so that they cannot disagree.
macro_rules! metals {
    ($(#[$doc0:meta])* $m0:ident => $file0:literal, $($(#[$doc:meta])* $m:ident => $file:literal,)*) => {
        /// A metal with measured optical constants.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Metal {
            $(#[$doc0])* $m0,
            $($(#[$doc])* $m,)*
        }

        /// Every metal: (metal, chemical symbol, table file in `data/metals/`, its text).
        const METALS: &[(Metal, &str, &str, &str)] = &[
            (Metal::$m0, stringify!($m0), $file0, metal_file!($file0)),
            $((Metal::$m, stringify!($m), $file, metal_file!($file)),)*
        ];

        /// The metal names [`Metal::from_str`] accepts.
        pub const KNOWN_METALS: &str = concat!(stringify!($m0) $(, ", ", stringify!($m))*);
    };
}

metals! {
    /// Gold (Johnson & Christy 1972).
    Au => "Au_johnson_christy_1972.csv",
    /// Silver (Johnson & Christy 1972).
    Ag => "Ag_johnson_christy_1972.csv",
    /// Copper (Johnson & Christy 1972).
    Cu => "Cu_johnson_christy_1972.csv",
    /// Aluminium (McPeak et al. 2015).
    Al => "Al_mcpeak_2015.csv",
    /// Chromium (Johnson & Christy 1974).
    Cr => "Cr_johnson_christy_1974.csv",
    /// Nickel (Johnson & Christy 1974).
    Ni => "Ni_johnson_christy_1974.csv",
    /// Titanium (Johnson & Christy 1974).
    Ti => "Ti_johnson_christy_1974.csv",
    /// Iron (Johnson & Christy 1974).
    Fe => "Fe_johnson_christy_1974.csv",
    /// Platinum (Rakić et al. 1998, Lorentz–Drude fit).
    Pt => "Pt_rakic_1998_ld.csv",
}

impl FromStr for Metal {
    type Err = Error;
    /// A chemical symbol, case-insensitive (`"Au"`, `"au"`).
    fn from_str(name: &str) -> Result<Self, Error> {
        let trimmed = name.trim();
        METALS
            .iter()
            .find(|e| e.1.eq_ignore_ascii_case(trimmed))
            .map(|e| e.0)
            .ok_or_else(|| Error::UnknownMetal { name: name.to_owned(), known: KNOWN_METALS })
    }
}

impl Metal {
    /// The metal's entry in [`METALS`] (`metals!` declares every variant with one).
    fn entry(self) -> &'static (Metal, &'static str, &'static str, &'static str) {
        METALS.iter().find(|e| e.0 == self).expect("metals! declares every metal with its table")
    }

    /// The chemical symbol.
    pub fn symbol(self) -> &'static str {
        self.entry().1
    }

    /// Reflectance at normal incidence, ((η − 1)² + κ²) / ((η + 1)² + κ²), every 5 nm over
    /// 360–830 nm: the colour of the metal, for RGB rendering and Hall's specular colour F_s.
    pub fn normal_reflectance(self) -> colorimetry::DenselySampledSpectrum {
        let ior = self.ior();
        let lambda: Vec<f64> = (0..=94).map(|i| 360.0 + 5.0 * f64::from(i)).collect();
        let r: Vec<f64> = lambda
            .iter()
            .map(|&l| {
                let (n, k) = ior.eval(l as f32);
                let (n, k) = (f64::from(n), f64::from(k));
                ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k)
            })
            .collect();
        colorimetry::DenselySampledSpectrum::from_samples(&lambda, &r)
            .expect("an ascending 5 nm grid with finite reflectances in [0, 1] is a valid spectrum")
    }

    /// The metal's tabulated index (parsed once).
    pub(crate) fn ior(self) -> &'static MetalIor {
        static TABLES: LazyLock<Vec<(Metal, MetalIor)>> = LazyLock::new(|| {
            METALS
                .iter()
                .map(|&(m, _, file, text)| {
                    (m, MetalIor::parse(text).unwrap_or_else(|e| panic!("embedded table {file} is corrupt: {e}")))
                })
                .collect()
        });
        let entry = TABLES.iter().find(|(m, _)| *m == self).expect("metals! declares every metal with its table");
        &entry.1
    }
}

/// A tabulated complex index: η and κ at ascending wavelengths.
#[derive(Debug, Clone)]
pub(crate) struct MetalIor {
    lambda_nm: Vec<f32>,
    eta: Vec<f32>,
    k: Vec<f32>,
}

impl MetalIor {
    /// Parse `wavelength_um,n,k` rows (one header line), wavelengths strictly ascending.
    fn parse(text: &str) -> Result<Self, String> {
        let mut ior = Self { lambda_nm: Vec::new(), eta: Vec::new(), k: Vec::new() };
        for (i, line) in text.lines().enumerate().skip(1) {
            let fields: Vec<f32> = line
                .split(',')
                .map(|f| f.trim().parse::<f32>().map_err(|e| format!("line {}: {e}", i + 1)))
                .collect::<Result<_, _>>()?;
            let &[um, n, k] = fields.as_slice() else { return Err(format!("line {}: expected 3 fields", i + 1)) };
            if ior.lambda_nm.last().is_some_and(|&last| last >= um * 1e3) || !(n > 0.0 && k >= 0.0) {
                return Err(format!("line {}: wavelengths must ascend and n > 0, k >= 0", i + 1));
            }
            ior.lambda_nm.push(um * 1e3);
            ior.eta.push(n);
            ior.k.push(k);
        }
        if ior.lambda_nm.len() < 2 { Err("fewer than two rows".to_owned()) } else { Ok(ior) }
    }

    /// (η, κ) at `lambda` nm.
    pub(crate) fn eval(&self, lambda: f32) -> (f32, f32) {
        let l = &self.lambda_nm;
        let i = l.partition_point(|&x| x <= lambda).clamp(1, l.len() - 1);
        let t = ((lambda - l[i - 1]) / (l[i] - l[i - 1])).clamp(0.0, 1.0);
        let lerp = |v: &[f32]| v[i - 1] + t * (v[i] - v[i - 1]);
        (lerp(&self.eta), lerp(&self.k))
    }

    /// (η, κ) at each of the path's wavelengths.
    pub(crate) fn sample<const N: usize>(
        &self,
        lambda: &SampledWavelengths<N>,
    ) -> (SampledSpectrum<N>, SampledSpectrum<N>) {
        let mut eta = [0.0; N];
        let mut k = [0.0; N];
        for i in 0..N {
            (eta[i], k[i]) = self.eval(lambda.lambda(i));
        }
        (SampledSpectrum(eta), SampledSpectrum(k))
    }

    /// The wavelength range the table covers (nm).
    #[cfg(test)]
    pub(crate) fn range(&self) -> (f32, f32) {
        (self.lambda_nm[0], self.lambda_nm[self.lambda_nm.len() - 1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scattering::fr_conductor;

    #[test]
    fn every_table_parses_and_covers_the_visible_range() {
        assert_eq!(KNOWN_METALS, "Au, Ag, Cu, Al, Cr, Ni, Ti, Fe, Pt");
        for &(m, ..) in METALS {
            let (lo, hi) = m.ior().range();
            assert!(lo <= colorimetry::LAMBDA_MIN && hi >= colorimetry::LAMBDA_MAX, "{m:?}: {lo}..{hi}");
            assert_eq!(m.symbol().parse::<Metal>().unwrap(), m);
        }
        assert!(matches!("Xx".parse::<Metal>(), Err(Error::UnknownMetal { .. })));
        assert_eq!("au".parse::<Metal>().unwrap(), Metal::Au);
    }

    #[test]
    fn interpolation_hits_table_rows_and_holds_the_ends() {
        // Johnson & Christy 1972, gold: 616.8 nm → n = 0.21, k = 3.272.
        let (n, k) = Metal::Au.ior().eval(616.8);
        assert!((n - 0.21).abs() < 1e-5 && (k - 3.272).abs() < 1e-5, "{n} {k}");
        // Halfway between 582.1 nm (0.29, 2.863) and 616.8 nm (0.21, 3.272).
        let (n, k) = Metal::Au.ior().eval(0.5 * (582.1 + 616.8));
        assert!((n - 0.25).abs() < 1e-5 && (k - 3.0675).abs() < 1e-4, "{n} {k}");
        assert_eq!(Metal::Au.ior().eval(100.0), Metal::Au.ior().eval(331.5));
    }

    /// Normal-incidence reflectance R = ((n−1)² + k²) / ((n+1)² + k²) from the sources' own
    /// tabulated values, against the Fresnel code through the loaded tables.
    #[test]
    fn normal_incidence_reflectance_matches_the_sources() {
        let cases = [
            // Johnson & Christy 1972, Au at 616.8 nm: n 0.21, k 3.272 → R = 0.9310.
            (Metal::Au, 616.8, 0.9310),
            // Johnson & Christy 1972, Ag at 548.6 nm: n 0.06, k 3.586 → R = 0.9828.
            (Metal::Ag, 548.6, 0.9828),
            // Johnson & Christy 1972, Cu at 659.5 nm: n 0.22, k 3.747 → R = 0.9433.
            (Metal::Cu, 659.5, 0.9433),
            // McPeak et al. 2015, Al at 550 nm: n 0.7894, k 5.8519 → R = 0.9157.
            (Metal::Al, 550.0, 0.9157),
            // Johnson & Christy 1974, Cr at 549 nm: n 3.18, k 3.33 → R = 0.5546.
            (Metal::Cr, 549.0, 0.5546),
            // Rakić et al. 1998 (LD), Pt at 557.74 nm: n 2.1105, k 3.7474 → R = 0.6441.
            (Metal::Pt, 557.74, 0.6441),
        ];
        for (m, lambda, expected) in cases {
            let (n, k) = m.ior().eval(lambda);
            let r = fr_conductor(1.0, n, k);
            assert!((r - expected).abs() < 2e-4, "{m:?} at {lambda} nm: R = {r}, source gives {expected}");
        }
        // Gold is yellow: it reflects red far better than blue (J&C at 450.9 nm: n 1.38, k 1.914 → R = 0.4082).
        let (n, k) = Metal::Au.ior().eval(450.9);
        assert!((fr_conductor(1.0, n, k) - 0.4082).abs() < 2e-4);
    }
}
