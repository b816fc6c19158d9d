//! Arguments shared by `render` and `info` that decide what a render looks like with no flags:
//! the integrator, the camera and the PNG's exposure.

use std::str::FromStr;

use glam::Vec3;
use integrator::{
    AssemblyOptions, CameraOptions, DefaultLights, EnvironmentOption, IntegratorKind, RenderScene, SkyOption, Tonemap,
    UpAxis, ViewPlan,
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

/// Camera choice and overrides, and how glass without a volume is read (both shape what a file
/// renders as with no flags).
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Camera")]
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
    /// Read glTF transmission without KHR_materials_volume as thin walls everywhere, as the
    /// specification does [default: solid glass on closed meshes, thin walls on open ones].
    #[arg(long, help_heading = "Materials")]
    thin_glass: bool,
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
            sky: None,
            thin_glass: self.thin_glass,
        }
    }
}

/// Image-based lighting from the command line.
#[derive(Debug, Clone, clap::Args)]
#[command(group(clap::ArgGroup::new("env_source").args(["env", "light_env"]).multiple(false)))]
#[command(next_help_heading = "Lights and exposure")]
pub(crate) struct EnvArgs {
    /// Light the scene with an equirectangular environment map (Radiance .hdr or OpenEXR .exr; +Y up,
    /// docs/scene-format.md "Environment maps"): it replaces the file's environment and background,
    /// and a glTF/OBJ file's default lights.
    #[arg(long, value_name = "FILE")]
    env: Option<std::path::PathBuf>,
    /// Factor on the map's texels (--env FILE, --light-env FILE), whose luminance is then in nits, or on
    /// the sky and sun of --light-env sky [default: 1].
    #[arg(long, value_name = "X", requires = "env_source")]
    env_intensity: Option<f32>,
    /// Rotation of the map (--env FILE, --light-env FILE) about +Y in degrees, counter-clockwise seen from
    /// above [default: 0]; the sky is turned with --sun-azimuth.
    #[arg(long, value_name = "DEG", requires = "env_source", allow_hyphen_values = true)]
    env_rotation: Option<f32>,
    /// The environment of the default lights: by default a glTF/OBJ file without lights (or with only
    /// emitters too weak to read by) gets a D65 environment and a key light, and a file's own lights
    /// or bright emitters nothing (docs/defaults.md); `uniform` adds the environment and key light to
    /// any file without lights, and a world around a file's lamps; `none` the key light alone over
    /// black where the default adds it; `sky` a Preetham 1999 daylight sky and sun (absolute: nits and
    /// lux); or an .hdr/.exr map (as --env FILE).
    #[arg(long, value_name = "none|uniform|sky|FILE", conflicts_with = "env")]
    light_env: Option<String>,
    /// Sky: turbidity of the atmosphere, 2 (very clear) to 10 (hazy) [default: 3].
    #[arg(long, value_name = "T", requires = "light_env")]
    turbidity: Option<f32>,
    /// Sky: the sun's elevation above the horizon in degrees, 0–90 [default: 45].
    #[arg(long, value_name = "DEG", requires = "light_env", allow_hyphen_values = true)]
    sun_elevation: Option<f32>,
    /// Sky: the sun's azimuth in degrees (the maps' φ: 0 towards −Z, 90 towards +X) [default: the key
    /// light's, behind, above and right of the camera].
    #[arg(long, value_name = "DEG", requires = "light_env", allow_hyphen_values = true)]
    sun_azimuth: Option<f32>,
    /// Sky: no sun (the sky alone, with the key light scaled to it).
    #[arg(long, requires = "light_env")]
    no_sun: bool,
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
            (false, Some("uniform")) => DefaultLights::EnvironmentAndKey,
            _ => DefaultLights::Auto,
        })
    }

    /// The factor of `--env-intensity`, checked.
    fn intensity(&self) -> anyhow::Result<f32> {
        let intensity = self.env_intensity.unwrap_or(1.0);
        if !(intensity.is_finite() && intensity >= 0.0) {
            anyhow::bail!("--env-intensity {intensity}: must be finite and ≥ 0");
        }
        Ok(intensity)
    }

    /// The sky of `--light-env sky`, if asked for; the sky's options without it are refused.
    pub(crate) fn sky(&self) -> anyhow::Result<Option<SkyOption>> {
        let is_sky = self.light_env.as_deref() == Some("sky");
        let sky_flags =
            self.turbidity.is_some() || self.sun_elevation.is_some() || self.sun_azimuth.is_some() || self.no_sun;
        if !is_sky {
            anyhow::ensure!(
                !sky_flags,
                "--turbidity, --sun-elevation, --sun-azimuth and --no-sun need --light-env sky"
            );
            return Ok(None);
        }
        anyhow::ensure!(self.env_rotation.is_none(), "--env-rotation does not turn the sky: use --sun-azimuth DEG");
        let default = SkyOption::default();
        let turbidity = self.turbidity.unwrap_or(default.turbidity);
        anyhow::ensure!(
            (2.0..=10.0).contains(&turbidity),
            "--turbidity {turbidity}: the Preetham sky is fitted for turbidities 2–10"
        );
        let sun_elevation_deg = self.sun_elevation.unwrap_or(default.sun_elevation_deg);
        anyhow::ensure!(
            (0.0..=90.0).contains(&sun_elevation_deg),
            "--sun-elevation {sun_elevation_deg}: expected degrees in 0–90 (the model has no night sky)"
        );
        if let Some(a) = self.sun_azimuth {
            anyhow::ensure!(a.is_finite(), "--sun-azimuth {a}: must be finite");
        }
        Ok(Some(SkyOption {
            turbidity,
            sun_elevation_deg,
            sun_azimuth_deg: self.sun_azimuth,
            sun: !self.no_sun,
            intensity: self.intensity()?,
        }))
    }

    /// The assembly's environment option (`--env FILE`, or `--light-env FILE`).
    pub(crate) fn option(&self) -> anyhow::Result<Option<EnvironmentOption>> {
        let path = match (&self.env, self.light_env.as_deref()) {
            (Some(path), _) => path.clone(),
            (None, Some(value)) if !matches!(value, "none" | "uniform" | "sky") => std::path::PathBuf::from(value),
            (None, Some("none" | "uniform")) => {
                anyhow::ensure!(
                    self.env_intensity.is_none() && self.env_rotation.is_none(),
                    "--env-intensity and --env-rotation apply to a map or the sky, not --light-env {}",
                    self.light_env.as_deref().unwrap_or_default()
                );
                return Ok(None);
            }
            _ => return Ok(None),
        };
        let intensity = self.intensity()?;
        let rotation_deg = self.env_rotation.unwrap_or(0.0);
        if !rotation_deg.is_finite() {
            anyhow::bail!("--env-rotation {rotation_deg}: must be finite");
        }
        Ok(Some(EnvironmentOption { path, intensity, rotation_deg }))
    }
}

/// The PNG's exposure and tone curve (the EXR is never scaled).
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Lights and exposure")]
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

impl ExposureArgs {
    /// How `scene`'s PNG is shown ([`RenderScene::view_plan`]), and why (a note for the user).
    pub(crate) fn plan(&self, scene: &RenderScene) -> anyhow::Result<(ViewPlan, &'static str)> {
        if let Some(ev) = self.exposure {
            anyhow::ensure!(ev.is_finite() && ev.abs() <= 100.0, "--exposure {ev}: expected stops in [-100, 100]");
        }
        Ok(scene.view_plan(self.exposure, self.auto_exposure, self.tonemap)?)
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
