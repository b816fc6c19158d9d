//! Light transport: the [`Kernel`] contract the pixel loop calls (radiance along a camera ray)
//! and its two models, the paper's Whitted–Hall ray tracer and the spectral path tracer.
//! Kernels see the assembled scene, the lights and textures, the film's sensor and the sampler;
//! they know nothing of pixels, passes or output.

mod fluorescence;
mod kernel;
pub(crate) mod path;
pub(crate) mod whitted;

pub(crate) use kernel::{Kernel, Radiance, RayCount};
pub(crate) use path::PathTracer;
pub(crate) use whitted::Whitted;
