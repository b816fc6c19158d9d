//! `spectrace info`: what a scene contains and what it needs.

use std::path::PathBuf;

use anyhow::Context as _;
use integrator::{IntegratorKind, RenderScene};

/// Arguments of `spectrace info`.
#[derive(Debug, clap::Args)]
pub(crate) struct InfoArgs {
    /// Scene file (.json manifest, .gltf/.glb, .obj); the default scene when omitted.
    scene: Option<PathBuf>,
    #[command(flatten)]
    load: crate::render::LoadArgs,
}

pub(crate) fn run(args: &InfoArgs) -> anyhow::Result<()> {
    let (desc, scene) = match &args.scene {
        Some(path) => {
            // Loader errors name the file (and line) themselves.
            let desc = geometry::load_scene_with(path, &args.load.options())?;
            let scene = RenderScene::from_description(desc.clone())
                .with_context(|| format!("assembling {}", path.display()))?;
            (desc, scene)
        }
        None => {
            let desc = RenderScene::default_description().context("building the default scene")?;
            let scene = RenderScene::from_description(desc.clone()).context("assembling the default scene")?;
            (desc, scene)
        }
    };
    let mut summary = integrator::summarize(&desc, &scene);
    if let Some(object) = summary.as_object_mut() {
        object.insert(
            "spectral_auto".to_owned(),
            serde_json::Value::String(integrator::choose_auto(&scene, IntegratorKind::WhittedHall).to_string()),
        );
        object.insert("spiky_spectra".to_owned(), serde_json::Value::Bool(integrator::scene_is_spiky(&scene)));
    }
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
