//! Decisions a render leaves to the renderer, and the public entry points that make them: the
//! spectral mode `auto` ([`choose`]: from the scene's spectra; [`pilot`]: by short pilot
//! renders when that is not enough), then the pixel loop ([`crate::render`]) with the mode
//! fixed. This sits above the loop because a pilot is a render.

use std::sync::atomic::AtomicBool;

use crate::error::{Error, Result};
use crate::film::Film;
use crate::options::{IntegratorKind, RenderOptions};
use crate::output::Image;
use crate::render::{Progress, RenderControl, RenderStats, check_options, render_resolved};
use crate::scene::RenderScene;
use crate::spectral::SpectralMode;

pub(crate) mod choose;
pub(crate) mod pilot;

pub use choose::choose_auto;
pub use pilot::{AutoCandidate, AutoDecision, auto_decision, pilot_strategies};

/// Render `scene`. `progress` is called from worker threads after each row; setting `cancel`
/// stops the render at the next row and returns [`Error::Cancelled`].
pub fn render(
    scene: &RenderScene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Image, RenderStats)> {
    let (film, stats) = render_film(scene, options, progress, cancel)?;
    Ok((film.to_image(), stats))
}

/// Render `scene` (or the sample range `options.samples` of it) into a [`Film`], which can be
/// merged with the films of the other ranges.
pub fn render_film(
    scene: &RenderScene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Film, RenderStats)> {
    render_film_with(scene, options, RenderControl { progress, cancel, resume: None, checkpoint: None, spectral: None })
}

/// [`render_film`] with checkpoints and resumption ([`RenderControl`]).
pub fn render_film_with(
    scene: &RenderScene,
    options: &RenderOptions,
    control: RenderControl<'_>,
) -> Result<(Film, RenderStats)> {
    let samples = check_options(options)?;
    let spectral = match control.spectral {
        Some(s) => s,
        None => resolved_spectral(scene, options)?,
    };
    render_resolved(scene, options, control, spectral, samples)
}

/// The spectral mode a render of `scene` with `options` uses: `auto` resolved, hero refused
/// for the paper's model.
pub fn resolved_spectral(scene: &RenderScene, options: &RenderOptions) -> Result<SpectralMode> {
    Ok(match options.spectral {
        SpectralMode::Auto => auto_decision(scene, options)?.spectral,
        SpectralMode::Hero { .. } if options.integrator.kind() == IntegratorKind::WhittedHall => {
            return Err(Error::InvalidOption {
                option: "spectral mode",
                value: options.spectral.to_string(),
                expected: "rgb, bins:N or auto for the whitted-hall integrator (hero sampling needs a Monte Carlo integrator)",
            });
        }
        mode => mode,
    })
}
