//! Light transport: the [`Kernel`] contract the pixel loop calls (radiance along a camera ray)
//! and its models: the paper's Whitted–Hall ray tracer, the spectral path tracer, and bidirectional
//! path tracing over the path tracer's surfaces. Kernels see the assembled scene, the lights and
//! textures, the film's sensor and the sampler; they know nothing of pixels, passes or output (a
//! kernel's light for other pixels goes back as splats).

mod bdpt;
mod fluorescence;
mod kernel;
pub(crate) mod path;
pub(crate) mod whitted;

pub(crate) use bdpt::Bdpt;
pub(crate) use kernel::{Kernel, Radiance, RayCount, Splat};
pub(crate) use path::PathTracer;
pub(crate) use whitted::Whitted;
