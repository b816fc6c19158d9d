//! Arguments shared by `render` and `info` that decide what a render looks like with no flags
//! (issue 13): the integrator, the camera and the PNG's exposure.

use std::str::FromStr;

use glam::Vec3;
use integrator::{
    AssemblyOptions, CameraOptions, DefaultLights, EnvironmentOption, IntegratorKind, RenderScene, Tonemap, UpAxis,
};

/// `--integrator`: a model, or `auto` (the scene's `settings.integrator`, else the path tracer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum IntegratorChoice {
    Auto,
    Kind(IntegratorKind),
}

impl FromStr for IntegratorChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Self::Auto);
        }
        s.parse().map(Self::Kind).map_err(|_| format!("expected auto, whitted-hall or path, got `{s}`"))
    }
}

impl IntegratorChoice {
    /// The model to render `scene` with, and a note saying why when `auto` chose it.
    pub(crate) fn resolve(self, scene: &RenderScene) -> (IntegratorKind, Option<String>) {
        match self {
            Self::Kind(kind) => (kind, None),
            Self::Auto => {
                let (kind, why) = scene.auto_integrator();
                (kind, Some(format!("integrator {why} (--integrator auto)")))
            }
        }
    }
}

/// Camera choice and overrides.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct CameraArgs {
    /// One of the file's cameras, by index (file order, from 0) or by name [default: the first].
    #[arg(long, value_name = "N|NAME")]
    camera: Option<String>,
    /// Up axis of the default camera for files without one: y (glTF, manifests, most OBJ) or z
    /// (Blender/CAD exports, scans) [default: y].
    #[arg(long, value_parser = parse_up)]
    up: Option<UpAxis>,
    /// Eye position, overriding the camera's (then looking at --look-at, else the bounds' centre).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    look_from: Option<Vec3>,
    /// Point looked at, overriding the camera's.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    look_at: Option<Vec3>,
    /// Vertical field of view in degrees, overriding the camera's.
    #[arg(long, value_name = "DEG")]
    fov: Option<f32>,
}

impl CameraArgs {
    /// The assembly's options; `size` is the image size the user asked for (framing uses its aspect).
    pub(crate) fn assembly(&self, size: (Option<u32>, Option<u32>)) -> AssemblyOptions {
        let aspect = match size {
            (None, None) => None,
            (w, h) => {
                let (dw, dh) = integrator::DEFAULT_RESOLUTION;
                Some(w.unwrap_or(dw).max(1) as f32 / h.unwrap_or(dh).max(1) as f32)
            }
        };
        AssemblyOptions {
            camera: CameraOptions {
                camera: self.camera.clone(),
                up: self.up,
                look_from: self.look_from,
                look_at: self.look_at,
                vfov_deg: self.fov,
                aspect,
            },
            environment: None,
            default_lights: DefaultLights::default(),
        }
    }
}

/// Image-based lighting from the command line.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct EnvArgs {
    /// Light the scene with an equirectangular environment map (Radiance .hdr or OpenEXR .exr; +Y up,
    /// docs/scene-format.md "Environment maps"): it replaces the file's environment and background,
    /// and a glTF/OBJ file's default lights.
    #[arg(long, value_name = "FILE")]
    env: Option<std::path::PathBuf>,
    /// Factor on the map's texels, whose luminance is then in nits [default: 1].
    #[arg(long, value_name = "X", requires = "env")]
    env_intensity: Option<f32>,
    /// Rotation of the map about +Y in degrees, counter-clockwise seen from above [default: 0].
    #[arg(long, value_name = "DEG", requires = "env", allow_hyphen_values = true)]
    env_rotation: Option<f32>,
    /// The environment of the default lights a glTF/OBJ file without lights gets: `uniform` (a D65
    /// environment with the key light, the default), `none` (the key light over black), or an
    /// .hdr/.exr map (as --env FILE).
    #[arg(long, value_name = "none|uniform|FILE", conflicts_with = "env")]
    light_env: Option<String>,
    /// Add no default lights: the file's own lights, emitters and background only (a scene with none
    /// is an error).
    #[arg(long, conflicts_with_all = ["env", "light_env"])]
    no_default_lights: bool,
}

impl EnvArgs {
    /// Which default lights the assembly may add.
    pub(crate) fn default_lights(&self) -> anyhow::Result<DefaultLights> {
        Ok(match (self.no_default_lights, self.light_env.as_deref()) {
            (true, _) => DefaultLights::None,
            (false, Some("none")) => DefaultLights::KeyOnly,
            (false, Some("sky")) => anyhow::bail!(
                "--light-env sky: spectrace has no analytic sky yet; give an equirectangular .hdr or .exr map"
            ),
            _ => DefaultLights::EnvironmentAndKey,
        })
    }

    /// The assembly's environment option (`--env FILE`, or `--light-env FILE`).
    pub(crate) fn option(&self) -> anyhow::Result<Option<EnvironmentOption>> {
        let path = match (&self.env, self.light_env.as_deref()) {
            (Some(path), _) => path.clone(),
            (None, Some(value)) if !matches!(value, "none" | "uniform" | "sky") => std::path::PathBuf::from(value),
            _ => return Ok(None),
        };
        let path = &path;
        let intensity = self.env_intensity.unwrap_or(1.0);
        if !(intensity.is_finite() && intensity >= 0.0) {
            anyhow::bail!("--env-intensity {intensity}: must be finite and ≥ 0");
        }
        let rotation_deg = self.env_rotation.unwrap_or(0.0);
        if !rotation_deg.is_finite() {
            anyhow::bail!("--env-rotation {rotation_deg}: must be finite");
        }
        Ok(Some(EnvironmentOption { path: path.clone(), intensity, rotation_deg }))
    }
}

/// The PNG's exposure and tone curve (the EXR is never scaled).
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct ExposureArgs {
    /// Exposure of the PNG in stops: its values are the EXR's × 2^EV [default: 0, or auto for
    /// files with photometric lights (glTF KHR_lights_punctual)].
    #[arg(long, value_name = "EV", allow_hyphen_values = true, conflicts_with = "auto_exposure")]
    exposure: Option<f32>,
    /// Expose the PNG so the image's log-average luminance is middle grey (0.18); the EV chosen
    /// is printed and recorded in the EXR's header.
    #[arg(long)]
    auto_exposure: bool,
    /// Display curve of the PNG: clamp (exact colours up to white) or pbr-neutral (Khronos PBR
    /// Neutral: a highlight shoulder, base colours kept) [default: pbr-neutral for glTF and OBJ
    /// files, clamp for manifests].
    #[arg(long)]
    tonemap: Option<Tonemap>,
}

/// How the PNG's exposure is decided, before the image exists.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ExposurePlan {
    /// A fixed EV.
    Manual(f32),
    /// Log-average luminance to 0.18, once rendered.
    Auto,
}

impl ExposureArgs {
    /// The plan for `scene`, and why (a note for the user).
    pub(crate) fn plan(&self, scene: &RenderScene) -> anyhow::Result<(ExposurePlan, &'static str)> {
        if let Some(ev) = self.exposure {
            anyhow::ensure!(ev.is_finite() && ev.abs() <= 100.0, "--exposure {ev}: expected stops in [-100, 100]");
            return Ok((ExposurePlan::Manual(ev), "--exposure"));
        }
        Ok(if self.auto_exposure {
            (ExposurePlan::Auto, "--auto-exposure")
        } else if scene.has_photometric_lights() {
            (ExposurePlan::Auto, "the file's lights are photometric (candela, lux): its values are absolute")
        } else {
            (ExposurePlan::Manual(0.0), "the default for relative units")
        })
    }

    /// The PNG's tone curve for `scene`: the one asked for, else PBR Neutral for glTF and OBJ files
    /// (authored for display: highlights roll off instead of clipping, as in the Khronos sample viewer)
    /// and clamp for manifests (colour-accuracy work: every colour below white exact).
    pub(crate) fn tonemap(&self, scene: &RenderScene) -> Tonemap {
        self.tonemap.unwrap_or(if scene.is_gltf_or_obj() { Tonemap::PbrNeutral } else { Tonemap::Clamp })
    }
}

/// The model's name as `--integrator` spells it.
pub(crate) fn kind_name(kind: IntegratorKind) -> &'static str {
    match kind {
        IntegratorKind::WhittedHall => "whitted-hall",
        IntegratorKind::Path => "path",
    }
}

fn parse_up(s: &str) -> Result<UpAxis, String> {
    s.parse().map_err(|_| format!("expected y or z, got `{s}`"))
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three numbers X,Y,Z, got `{s}`"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(*x, *y, *z)),
        _ => Err(format!("expected three finite numbers X,Y,Z, got `{s}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_and_choices_parse() {
        assert_eq!(parse_vec3("1,-2.5, 3"), Ok(Vec3::new(1.0, -2.5, 3.0)));
        assert!(parse_vec3("1,2").is_err() && parse_vec3("1,2,nan").is_err() && parse_vec3("a,b,c").is_err());
        assert_eq!("auto".parse::<IntegratorChoice>(), Ok(IntegratorChoice::Auto));
        assert_eq!("path".parse::<IntegratorChoice>(), Ok(IntegratorChoice::Kind(IntegratorKind::Path)));
        assert!("bdpt".parse::<IntegratorChoice>().is_err());
    }
}
