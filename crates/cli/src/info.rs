//! `spectrace info`: what a scene contains and what it needs, and the camera, integrator and
//! exposure a render with the same flags would use.

use std::path::PathBuf;

use anyhow::Context as _;
use integrator::RenderScene;

/// Arguments of `spectrace info`.
#[derive(Debug, clap::Args)]
pub(crate) struct InfoArgs {
    /// Scene file (.json manifest, .gltf/.glb, .obj); the default scene when omitted.
    scene: Option<PathBuf>,
    /// As `render --integrator`: the report says which model a render would use.
    #[arg(long, default_value = "auto")]
    integrator: crate::view::IntegratorChoice,
    /// As `render --width/--height/--spp`: `auto`'s choice for the path tracer may depend on
    /// them (a render too small for its pilot is not piloted).
    #[arg(long)]
    width: Option<u32>,
    #[arg(long)]
    height: Option<u32>,
    #[command(flatten)]
    sampling: crate::render::SamplingArgs,
    #[command(flatten)]
    load: crate::render::LoadArgs,
    #[command(flatten)]
    camera: crate::view::CameraArgs,
    #[command(flatten)]
    env: crate::view::EnvArgs,
    #[command(flatten)]
    exposure: crate::view::ExposureArgs,
}

pub(crate) fn run(args: &InfoArgs) -> anyhow::Result<()> {
    args.load.check_scene(args.scene.as_deref())?;
    // The size a render with the same flags would frame a default view for.
    let mut assembly = args.camera.assembly((args.width, args.height));
    args.env.apply(&mut assembly)?;
    let (desc, scene) = match &args.scene {
        Some(path) => {
            // Loader errors name the file (and line) themselves.
            let mut desc = geometry::load_scene_with(path, &args.load.options())?;
            // The summary reads the meshes' count and materials only: it gets empty meshes with
            // the same materials, not a copy of every vertex and triangle (24 bytes a triangle
            // on a plain mesh, all alive while the BVH is built).
            let meshes = std::mem::take(&mut desc.meshes);
            let mut summary_desc = desc.clone();
            summary_desc.meshes = meshes
                .iter()
                .map(|m| geometry::Mesh::new(Vec::new(), None, None, Vec::new(), m.material()))
                .collect::<Result<_, _>>()?;
            desc.meshes = meshes;
            let scene = RenderScene::from_description_with(desc, &assembly)
                .with_context(|| format!("assembling {}", path.display()))?;
            (summary_desc, scene)
        }
        None => {
            let desc = RenderScene::default_description().context("building the default scene")?;
            let scene =
                RenderScene::from_description_with(desc.clone(), &assembly).context("assembling the default scene")?;
            (desc, scene)
        }
    };
    let (kind, why) = args.integrator.resolve(&scene);
    let (plan, exposure_why) = args.exposure.plan(&scene)?;
    let mut summary = integrator::summarize(&desc, &scene);
    if let Some(object) = summary.as_object_mut() {
        object.insert(
            "integrator".to_owned(),
            serde_json::json!({
                "name": crate::view::kind_name(kind),
                "why": why.unwrap_or_else(|| "--integrator".to_owned()),
            }),
        );
        let ev = match plan.exposure {
            integrator::Exposure::Fixed(ev) => serde_json::json!(ev),
            integrator::Exposure::Auto => serde_json::json!("auto"),
        };
        object.insert(
            "exposure".to_owned(),
            serde_json::json!({
                "ev": ev,
                "why": exposure_why,
                "tonemap": plan.tonemap.to_string(),
                "photometric_lights": scene.has_photometric_lights(),
            }),
        );
        let (width, height) = scene.resolution_for(args.width, args.height);
        let integrator = match kind {
            integrator::IntegratorKind::WhittedHall => integrator::Integrator::default(),
            integrator::IntegratorKind::Path => integrator::Integrator::Path(integrator::PathOptions::default()),
            integrator::IntegratorKind::Bdpt => integrator::Integrator::Bdpt(integrator::PathOptions {
                sampler: integrator::SamplerKind::Independent,
                ..integrator::PathOptions::default()
            }),
            integrator::IntegratorKind::Sppm => integrator::Integrator::Sppm(integrator::SppmOptions {
                path: integrator::PathOptions {
                    sampler: integrator::SamplerKind::Independent,
                    ..integrator::PathOptions::default()
                },
                photons: None,
                radius: None,
            }),
        };
        let sampling = args.sampling.plan(kind)?;
        let options = integrator::RenderOptions {
            width,
            height,
            integrator,
            spp: sampling.spp,
            time_limit: sampling.time_limit,
            target_error: sampling.target.map(|delta_e| integrator::TargetError { delta_e, exposure_ev: None }),
            ..Default::default()
        };
        options.check_limits()?;
        let auto = integrator::auto_decision(&scene, &options)?;
        object.insert("spectral_auto".to_owned(), serde_json::Value::String(auto.spectral.to_string()));
        // What a render would stop at, and (when the pilot ran) the samples it predicts for it.
        let chosen = auto.candidates.iter().find(|c| c.spectral == auto.spectral);
        object.insert(
            "samples".to_owned(),
            serde_json::json!({
                "stop": sampling.why,
                "spp": sampling.spp,
                "target_delta_e00": sampling.target,
                "time_limit_s": sampling.time_limit.map(|t| t.as_secs_f64()),
                // The pilot judges colours at EV 0 (white = 1 in the scene's units): only then is it
                // the render's measure.
                "pilot_spp_to_target": match (chosen, sampling.target, plan.exposure) {
                    (Some(c), Some(t), integrator::Exposure::Fixed(0.0)) =>
                        serde_json::json!(c.spp_for(f64::from(t)).round()),
                    _ => serde_json::Value::Null,
                },
            }),
        );
        // What the pilot measured, per candidate: modelled cost per sample, the predicted mean
        // ΔE00 of a 1-spp image and the spp and cost to mean ΔE00 1.
        let candidates: Vec<_> = auto
            .candidates
            .iter()
            .map(|c| {
                serde_json::json!({
                    "spectral": c.spectral.to_string(),
                    "rays_per_sample": c.rays_per_sample,
                    "cost_per_sample": c.cost_per_sample,
                    "delta_e00_at_1_spp": c.error_1spp,
                    "spp_to_delta_e00_1": c.spp_for(1.0),
                    "cost_to_delta_e00_1": c.cost_for(1.0),
                })
            })
            .collect();
        object.insert("spectral_auto_why".to_owned(), serde_json::json!({"reason": auto.reason, "pilot": candidates}));
        object.insert("spiky_spectra".to_owned(), serde_json::Value::Bool(integrator::scene_is_spiky(&scene)));
    }
    crate::write_stdout(&format!("{}\n", serde_json::to_string_pretty(&summary)?))
}
