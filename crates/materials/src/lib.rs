//! `materials`: what surfaces and media do to light, spectrally.
//!
//! Spectral reflectance and transmittance, index of refraction (constant or dispersive),
//! Bouguer–Beer absorption (the paper's eq. 8), emission, Fresnel, reflection and
//! refraction, the material record with its closed [`MaterialModel`], the BSDFs
//! ([`bsdf::Bsdf`]: Lambertian, mirror, smooth, rough and thin dielectrics, rough GGX
//! conductors with measured metals and the glTF metallic–roughness BRDF), the
//! warps they sample with ([`sampling`]) and the paper's Hall shading terms (eqs. 6–7) as
//! pure functions.
//!
//! **Invariant:** depends on `colorimetry` only (and glam for vectors in a local frame,
//! thiserror for the error type).
//! Nothing here casts rays, recurses or samples lights: that is the integrator's job.
//!
//! ```
//! use colorimetry::{DenselySampledSpectrum, SampledWavelengths};
//! use materials::Absorption;
//!
//! // Table 1 of the paper: 95 % transmitted per unit thickness. Through 3 units: 0.95³.
//! let glass = Absorption::from_per_unit_transmittance(&DenselySampledSpectrum::constant(0.95))?;
//! let lambda = SampledWavelengths::<4>::from_parts([450.0, 500.0, 550.0, 600.0], [1.0; 4]);
//! let t = glass.transmittance(&lambda, 3.0);
//! assert!((t.0[0] - 0.95f32.powi(3)).abs() < 1e-6);
//! # Ok::<(), materials::Error>(())
//! ```
#![warn(missing_docs)]

mod absorption;
pub mod bsdf;
mod error;
mod fluorescence;
pub mod hall;
mod ior;
mod material;
pub mod sampling;
pub mod scattering;
mod spectra;

pub use absorption::{Absorption, beer_transmittance};
pub use error::{Error, Result};
pub use fluorescence::{Fluorescence, LAMBDA_UV_MIN};
pub use ior::{Ior, LAMBDA_D};
pub use material::{Anisotropy, Coat, ConductorIndex, DielectricSpecular, Material, MaterialModel, Sheen};
pub use spectra::{
    KNOWN_SPECTRUM_NAMES, REC709_LUMINANCE, csv_spectrum, illuminant_from_rgb, is_flat, luminance_normalized,
    named_spectrum, reflectance_from_rgb, spikiness,
};
