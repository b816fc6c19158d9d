//! What the pixel loop asks of an integrator, and what it gets back.

use colorimetry::{SampledSpectrum, SampledWavelengths};
use geometry::Ray;

use crate::film::{ObjectId, Sensor};
use crate::sampling::Sampler;

/// Per-thread counters.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct RayCount {
    /// Every ray traced.
    pub(crate) rays: u64,
    /// Those of them that were shadow rays ([`RenderStats::shadow_rays`]).
    pub(crate) shadow: u64,
}

impl RayCount {
    /// Count one shadow ray (it is a ray too).
    #[inline]
    pub(crate) fn shadow_ray(&mut self) {
        self.rays += 1;
        self.shadow += 1;
    }
}

/// What an integrator returns for one camera sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Radiance<const N: usize> {
    /// Radiance at the sample's lanes.
    pub(crate) l: SampledSpectrum<N>,
    /// What the camera ray hit first.
    pub(crate) first: ObjectId,
    /// With fixed lanes, the one lane a dispersive path kept (see [`Sensor::to_xyz`]).
    pub(crate) lane: Option<usize>,
}

/// Light a sample sends to another pixel than its own: a light subpath connected to the camera
/// (bidirectional path tracing's t = 1 strategy). The pixel loop adds it to the film's splat sums
/// with the sample's final wavelengths and lane ([`Radiance::lane`]), like the sample's own value.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Splat<const N: usize> {
    /// The pixel it lands in (column, row from the top).
    pub(crate) x: u32,
    pub(crate) y: u32,
    /// Its contribution to that pixel's measurement, in the units of a sample's radiance: the film
    /// divides the splat sums by the samples per pixel (all samples over all pixels).
    pub(crate) l: SampledSpectrum<N>,
}

/// An integrator as the pixel loop sees it: radiance along a camera ray.
pub(crate) trait Kernel<const N: usize>: Sync {
    /// Whether samples are random (camera jitter and hero wavelengths drawn from the sample's
    /// own stream); otherwise sub-pixel positions are the deterministic R2 sequence.
    const RANDOM: bool;

    /// Whether [`Kernel::li`] may push splats; the pixel loop keeps no splat sums otherwise.
    const SPLATS: bool = false;

    /// Radiance arriving along `ray` at `lambda` (which a dispersive path may narrow); light the
    /// sample sends to other pixels is pushed to `splats` (only where [`Kernel::SPLATS`]).
    #[allow(clippy::too_many_arguments)]
    fn li(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
        splats: &mut Vec<Splat<N>>,
    ) -> Radiance<N>;
}
