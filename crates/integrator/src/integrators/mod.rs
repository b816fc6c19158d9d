//! Light transport: the [`Kernel`] contract the pixel loop calls (radiance along a camera ray)
//! and its models: the paper's Whitted–Hall ray tracer, the spectral path tracer, bidirectional
//! path tracing over the path tracer's surfaces, and photon mapping over BDPT's walks (which runs its
//! own passes: a photon pass between camera passes). Kernels see the assembled scene, the lights and
//! textures, the film's sensor and the sampler; they know nothing of pixels, passes or output (a
//! kernel's light for other pixels goes back as splats).

mod bdpt;
mod fluorescence;
mod kernel;
pub(crate) mod path;
mod sppm;
pub(crate) mod whitted;

pub(crate) use bdpt::Bdpt;
pub(crate) use kernel::{Kernel, Radiance, RayCount, Splat};
pub(crate) use path::PathTracer;
pub(crate) use sppm::PhotonMapping;
pub(crate) use whitted::Whitted;
