//! Arguments shared by `render` and `info` that decide what a render looks like with no flags:
//! the integrator, the camera and the PNG's exposure.

use std::str::FromStr;

use glam::Vec3;
use integrator::{
    AssemblyOptions, CIE_SKY_DEFAULT_LUX, CameraOptions, CieSkyOption, CieSkyScale, CieSunOption, DefaultLights,
    EnvironmentOption, IntegratorKind, RenderScene, SkyOption, Tonemap, UpAxis, ViewPlan,
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
        s.parse().map(Self::Kind).map_err(|_| format!("expected auto, whitted-hall, path, bdpt or sppm, got `{s}`"))
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
            cie_sky: None,
            thin_glass: self.thin_glass,
        }
    }
}

/// The flags only `--light-env cie-sky:N` reads, for messages.
const CIE_FLAGS: &str = "--sky-illuminance, --zenith-luminance, --sky-cct, --sun-illuminance, --sun-horizontal-illuminance and --sun-spectrum";

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
    /// lux); `cie-sky:N` the CIE standard general sky of type N (ISO 15469 / CIE S 011: 1 overcast,
    /// steep gradation … 5 uniform … 12 CIE clear sky … 15 turbid with a broad solar corona) in CIE
    /// daylight, absolute, with a sun only if --sun-illuminance is given; or an .hdr/.exr map (as --env
    /// FILE).
    #[arg(long, value_name = "none|uniform|sky|cie-sky:N|FILE", conflicts_with = "env")]
    light_env: Option<String>,
    /// Sky: turbidity of the atmosphere, 2 (very clear) to 10 (hazy) [default: 3].
    #[arg(long, value_name = "T", requires = "light_env")]
    turbidity: Option<f32>,
    /// Sky (either): the sun's elevation above the horizon in degrees, 0–90 [default: 45].
    #[arg(long, value_name = "DEG", requires = "light_env", allow_hyphen_values = true)]
    sun_elevation: Option<f32>,
    /// Sky (either): the sun's azimuth in degrees (the maps' φ: 0 towards −Z, 90 towards +X) [default:
    /// the key light's, behind, above and right of the camera].
    #[arg(long, value_name = "DEG", requires = "light_env", allow_hyphen_values = true)]
    sun_azimuth: Option<f32>,
    /// Sky: no sun (the sky alone, with the key light scaled to it).
    #[arg(long, requires = "light_env")]
    no_sun: bool,
    /// CIE sky: its diffuse illuminance on a horizontal plane, lux (the sun's excluded) [default: 10000].
    #[arg(long, value_name = "LUX", requires = "light_env", conflicts_with = "zenith_luminance")]
    sky_illuminance: Option<f32>,
    /// CIE sky: its zenith luminance, cd/m², instead of --sky-illuminance.
    #[arg(long, value_name = "NITS", requires = "light_env")]
    zenith_luminance: Option<f32>,
    /// CIE sky: the correlated colour temperature of its CIE daylight spectrum, K, 4000–25000
    /// [default: 6500].
    #[arg(long, value_name = "K", requires = "light_env")]
    sky_cct: Option<f32>,
    /// CIE sky: add the sun, a directional light of this illuminance at normal incidence, lux.
    #[arg(long, value_name = "LUX", requires = "light_env", conflicts_with = "sun_horizontal_illuminance")]
    sun_illuminance: Option<f32>,
    /// CIE sky: add the sun, of this illuminance on a horizontal plane, lux.
    #[arg(long, value_name = "LUX", requires = "light_env")]
    sun_horizontal_illuminance: Option<f32>,
    /// CIE sky: the sun's spectrum, an illuminant name (D55, D5800, bb5778, …) [default: D55].
    #[arg(long, value_name = "NAME", requires = "light_env")]
    sun_spectrum: Option<String>,
    /// Add no default lights: the file's own lights, emitters and background only (a scene with none
    /// is an error).
    #[arg(long, conflicts_with_all = ["env", "light_env"])]
    no_default_lights: bool,
}

impl EnvArgs {
    /// The lights these flags ask for, set on `assembly` (what `render`, `info` and `measure` share).
    pub(crate) fn apply(&self, assembly: &mut AssemblyOptions) -> anyhow::Result<()> {
        assembly.environment = self.option()?;
        assembly.default_lights = self.default_lights()?;
        assembly.sky = self.sky()?;
        assembly.cie_sky = self.cie_sky()?;
        Ok(())
    }

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
                !sky_flags || self.cie_sky_type()?.is_some(),
                "--turbidity, --sun-elevation, --sun-azimuth and --no-sun need --light-env sky"
            );
            return Ok(None);
        }
        anyhow::ensure!(!self.cie_flags(), "{} need --light-env cie-sky:N", CIE_FLAGS);
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

    /// The sky type N of `--light-env cie-sky:N`, if that was asked for.
    fn cie_sky_type(&self) -> anyhow::Result<Option<u8>> {
        let Some(n) = self.light_env.as_deref().and_then(|v| v.strip_prefix("cie-sky:")) else { return Ok(None) };
        match n.parse::<u8>() {
            Ok(n) if (1..=15).contains(&n) => Ok(Some(n)),
            _ => anyhow::bail!("--light-env cie-sky:{n}: the CIE standard general sky has types 1–15"),
        }
    }

    /// Whether a flag only the CIE sky reads was given.
    fn cie_flags(&self) -> bool {
        self.sky_illuminance.is_some()
            || self.zenith_luminance.is_some()
            || self.sky_cct.is_some()
            || self.sun_illuminance.is_some()
            || self.sun_horizontal_illuminance.is_some()
            || self.sun_spectrum.is_some()
    }

    /// The CIE sky of `--light-env cie-sky:N`, if asked for; its options without it are refused.
    pub(crate) fn cie_sky(&self) -> anyhow::Result<Option<CieSkyOption>> {
        let Some(sky_type) = self.cie_sky_type()? else {
            anyhow::ensure!(!self.cie_flags(), "{} need --light-env cie-sky:N", CIE_FLAGS);
            return Ok(None);
        };
        anyhow::ensure!(
            self.turbidity.is_none() && !self.no_sun,
            "--turbidity and --no-sun are the Preetham sky's: the CIE sky has a sun only with --sun-illuminance"
        );
        anyhow::ensure!(
            self.env_intensity.is_none() && self.env_rotation.is_none(),
            "--env-intensity and --env-rotation do not apply to the CIE sky: use --sky-illuminance or \
             --zenith-luminance, and --sun-azimuth"
        );
        let default = CieSkyOption::default();
        let sun_elevation_deg = self.sun_elevation.unwrap_or(default.sun_elevation_deg);
        anyhow::ensure!(
            (0.0..=90.0).contains(&sun_elevation_deg),
            "--sun-elevation {sun_elevation_deg}: expected degrees in 0–90"
        );
        if let Some(a) = self.sun_azimuth {
            anyhow::ensure!(a.is_finite(), "--sun-azimuth {a}: must be finite");
        }
        let positive = |flag: &str, v: f32| {
            anyhow::ensure!(v.is_finite() && v >= 0.0, "{flag} {v}: must be finite and ≥ 0");
            Ok(v)
        };
        let scale = match (self.sky_illuminance, self.zenith_luminance) {
            (_, Some(l)) => CieSkyScale::ZenithNits(positive("--zenith-luminance", l)?),
            (e, None) => {
                CieSkyScale::DiffuseHorizontalLux(positive("--sky-illuminance", e.unwrap_or(CIE_SKY_DEFAULT_LUX))?)
            }
        };
        let cct = self.sky_cct.unwrap_or(default.cct);
        anyhow::ensure!((4000.0..=25000.0).contains(&cct), "--sky-cct {cct}: CIE daylight is defined for 4000–25000 K");
        let sun = match (self.sun_illuminance, self.sun_horizontal_illuminance) {
            (Some(e), _) => Some((positive("--sun-illuminance", e)?, false)),
            (None, Some(e)) => {
                anyhow::ensure!(
                    sun_elevation_deg > 0.0,
                    "--sun-horizontal-illuminance needs the sun above the horizon (--sun-elevation > 0)"
                );
                Some((positive("--sun-horizontal-illuminance", e)?, true))
            }
            (None, None) => {
                anyhow::ensure!(self.sun_spectrum.is_none(), "--sun-spectrum needs --sun-illuminance");
                None
            }
        };
        let spectrum = self.sun_spectrum.clone().unwrap_or_else(|| "D55".to_owned());
        if sun.is_some() {
            colorimetry::Illuminant::parse(&spectrum).map_err(|e| anyhow::anyhow!("--sun-spectrum {spectrum}: {e}"))?;
        }
        Ok(Some(CieSkyOption {
            sky_type,
            sun_elevation_deg,
            sun_azimuth_deg: self.sun_azimuth,
            scale,
            cct,
            sun: sun.map(|(illuminance_lux, horizontal)| CieSunOption { illuminance_lux, horizontal, spectrum }),
        }))
    }

    /// The assembly's environment option (`--env FILE`, or `--light-env FILE`).
    pub(crate) fn option(&self) -> anyhow::Result<Option<EnvironmentOption>> {
        let path = match (&self.env, self.light_env.as_deref()) {
            (Some(path), _) => path.clone(),
            (None, Some(value)) if !matches!(value, "none" | "uniform" | "sky") && !value.starts_with("cie-sky:") => {
                std::path::PathBuf::from(value)
            }
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
        IntegratorKind::Bdpt => "bdpt",
        IntegratorKind::Sppm => "sppm",
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
        assert_eq!("bdpt".parse::<IntegratorChoice>(), Ok(IntegratorChoice::Kind(IntegratorKind::Bdpt)));
        assert_eq!("sppm".parse::<IntegratorChoice>(), Ok(IntegratorChoice::Kind(IntegratorKind::Sppm)));
        assert!("photons".parse::<IntegratorChoice>().is_err());
    }
}
