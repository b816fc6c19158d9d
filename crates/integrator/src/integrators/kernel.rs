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

/// An integrator as the pixel loop sees it: radiance along a camera ray.
pub(crate) trait Kernel<const N: usize>: Sync {
    /// Whether samples are random (camera jitter and hero wavelengths drawn from the sample's
    /// own stream); otherwise sub-pixel positions are the deterministic R2 sequence.
    const RANDOM: bool;

    /// Radiance arriving along `ray` at `lambda` (which a dispersive path may narrow).
    fn li(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> Radiance<N>;
}
