//! The scene manifest: a small JSON file a user writes by hand (format in `docs/scene-format.md`).
//!
//! Parsing is two-staged: serde reads the structure (unknown top-level, camera, light, object, transform,
//! material and settings keys are errors naming the key, so typos are never silent), then each value that can
//! take several forms (spectra, IORs, absorption) is converted by hand with a context path such as
//! `materials.glass.ior`, so every error says where it is.

use std::path::{Path, PathBuf};

use glam::{DVec3, Mat4, Quat, Vec3};
use serde::Deserialize;
use serde_json::{Map, Value};

use crate::desc::{
    CameraDesc, EnvironmentMapDesc, FluorescenceDesc, LightAmount, LightDesc, LightUnit, MaterialDesc, MaterialFormat,
    Projection, SceneDescription, SceneFormat, Settings, SpectrumDesc,
};
use crate::error::{Error, Result};
use crate::forms::{Ctx, absorption, ior, number, only_keys, spectrum, unknown_key};
use crate::limits::{Budget, MAX_PHOTOMETRIC_FILE_BYTES, MAX_SPECTRUM_FILE_BYTES, check_coordinates};
use crate::photometry;
use crate::shapes::{Mesh, Sphere};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestJson {
    /// Free text for the reader; ignored.
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    camera: Option<CameraJson>,
    background: Option<Value>,
    #[serde(default)]
    lights: Vec<LightJson>,
    #[serde(default)]
    materials: Map<String, Value>,
    #[serde(default)]
    objects: Vec<ObjectJson>,
    #[serde(default)]
    settings: Map<String, Value>,
    /// Per-frame changes, chosen by `--frame K` ([`crate::Variation`]); checked there.
    #[serde(default)]
    frames: Vec<Value>,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraJson {
    // As written (f64), so that a look_at that differs from the position only beyond f32's precision is
    // told apart from one that equals it.
    position: [f64; 3],
    look_at: [f64; 3],
    #[serde(default = "default_up")]
    up: [f32; 3],
    vfov_deg: f32,
    width: Option<u32>,
    height: Option<u32>,
}

fn default_light_spectrum() -> Value {
    Value::String("D65".into())
}

fn one() -> f32 {
    1.0
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightJson {
    Point {
        position: [f32; 3],
        #[serde(default = "default_light_spectrum")]
        spectrum: Value,
        #[serde(default = "one")]
        intensity: f32,
        unit: Option<String>,
        /// A photometric file (`.ies`, `.ldt`) relative to the manifest: the light becomes a luminaire.
        ies: Option<String>,
        /// A luminaire's nadir (default straight down); only with `ies`.
        direction: Option<[f32; 3]>,
        /// A direction in a luminaire's C0 plane; only with `ies`.
        up: Option<[f32; 3]>,
    },
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        inner_cone_deg: f32,
        outer_cone_deg: f32,
        #[serde(default = "default_light_spectrum")]
        spectrum: Value,
        #[serde(default = "one")]
        intensity: f32,
        unit: Option<String>,
    },
    Directional {
        direction: [f32; 3],
        #[serde(default = "default_light_spectrum")]
        spectrum: Value,
        #[serde(default = "one")]
        intensity: f32,
        unit: Option<String>,
    },
    Environment {
        /// The uniform environment's spectrum (D65 when absent); excludes `map`.
        spectrum: Option<Value>,
        #[serde(default = "one")]
        intensity: f32,
        unit: Option<String>,
        /// An equirectangular image (`.hdr`, `.exr`) relative to the manifest.
        map: Option<String>,
        rotation_deg: Option<f32>,
    },
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum ObjectJson {
    Sphere {
        center: [f32; 3],
        radius: f32,
        material: Option<String>,
    },
    /// A parallelogram `corner + s·edge_u + t·edge_v`, s, t ∈ [0, 1], facing `edge_u × edge_v`.
    Quad {
        corner: [f32; 3],
        edge_u: [f32; 3],
        edge_v: [f32; 3],
        material: Option<String>,
    },
    /// A square of side `size` centred at `point`, facing `normal`.
    Plane {
        point: [f32; 3],
        normal: [f32; 3],
        size: f32,
        material: Option<String>,
    },
    /// A glTF or OBJ file, transformed, optionally with all its materials replaced by one.
    Mesh {
        file: String,
        transform: Option<TransformJson>,
        material: Option<String>,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformJson {
    translate: Option<[f32; 3]>,
    rotate: Option<RotationsJson>,
    scale: Option<ScaleJson>,
    /// Row-major 4×4 matrix as written on paper (last row normally 0 0 0 1); excludes the other keys.
    matrix: Option<[[f32; 4]; 4]>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RotationsJson {
    One(RotationJson),
    Many(Vec<RotationJson>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RotationJson {
    axis: [f32; 3],
    deg: f32,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum ScaleJson {
    Uniform(f32),
    PerAxis([f32; 3]),
}

/// Material keys ([`MATERIAL_KEYS`]); free-form data for the layers above goes under `extras`, so a misspelt
/// key is an error, not data.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialJson {
    model: Option<String>,
    metal: Option<String>,
    eta: Option<Value>,
    k: Option<Value>,
    nonlinear: Option<bool>,
    base_color: Option<Value>,
    diffuse: Option<f32>,
    specular: Option<Value>,
    ks: Option<f32>,
    shininess: Option<f32>,
    metallic: Option<f32>,
    roughness: Option<f32>,
    transmission: Option<f32>,
    transmittance: Option<Value>,
    ior: Option<Value>,
    dispersion: Option<f32>,
    absorption: Option<Value>,
    thickness: Option<f32>,
    emission: Option<Value>,
    emission_strength: Option<f32>,
    double_sided: Option<bool>,
    multiple_scattering: Option<bool>,
    fluorescence: Option<Value>,
    extras: Option<Value>,
}

/// The fields of [`MaterialJson`], checked before serde reads them so that an unknown one gets a
/// did-you-mean (a test keeps the two lists equal).
const MATERIAL_KEYS: &[&str] = &[
    "model",
    "metal",
    "eta",
    "k",
    "nonlinear",
    "base_color",
    "diffuse",
    "specular",
    "ks",
    "shininess",
    "metallic",
    "roughness",
    "transmission",
    "transmittance",
    "ior",
    "dispersion",
    "absorption",
    "thickness",
    "emission",
    "emission_strength",
    "double_sided",
    "multiple_scattering",
    "fluorescence",
    "extras",
];

/// The keys of `settings`, each read by [`settings`].
const SETTINGS_KEYS: &[&str] = &["integrator", "max_depth", "rr_depth"];

/// Model hints the layers above understand (see [`MaterialDesc::model`]).
const KNOWN_MODELS: &[&str] = &["hall", "diffuse", "dielectric", "conductor", "mirror", "plastic"];

/// A mesh file an object of the manifest refers to, loaded by the `load` module (the manifest does not
/// depend on the other loaders).
#[derive(Debug)]
pub(crate) struct Include {
    /// Where in the manifest, e.g. `objects[3]`.
    pub(crate) context: String,
    /// The file, resolved against the manifest's folder.
    pub(crate) path: PathBuf,
    /// Object-to-world transform.
    pub(crate) matrix: Mat4,
    /// The manifest material replacing all the file's materials, if any.
    pub(crate) material: Option<u32>,
    /// Number of the manifest's own meshes before this object: the included meshes go there, so meshes
    /// keep the objects' order (the BVH's primitive order, hence the renders, depend on it).
    pub(crate) position: usize,
}

/// Parses a manifest's text into a description (without the mesh files it includes, returned for the
/// caller to load). `base_dir` resolves relative file paths (spectra CSVs, meshes); `origin` names the
/// manifest in error messages (a path, or e.g. `"<embedded default scene>"`). A leading UTF-8 byte-order
/// mark is skipped (Windows editors write one).
pub(crate) fn parse(
    text: &str,
    base_dir: &Path,
    origin: &str,
    budget: &Budget,
) -> Result<(SceneDescription, Vec<Include>)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let syntax = |cause| Error::ManifestSyntax { origin: origin.to_owned(), cause };
    let variation = &budget.options.variation;
    let json: ManifestJson = if variation.is_empty() {
        // Straight from the text, so errors keep their line and column.
        serde_json::from_str(text).map_err(syntax)?
    } else {
        let mut doc: Value = serde_json::from_str(text).map_err(syntax)?;
        variation.apply(&mut doc).map_err(|(context, message)| Error::ManifestValue {
            origin: origin.to_owned(),
            context,
            message,
        })?;
        // The varied scene is another scene: its digest (film files, `info`) says so.
        budget.record(&variation.digest_bytes());
        ManifestJson::deserialize(doc)
            .map_err(|cause| Error::ManifestSyntax { origin: format!("{origin} (after --frame/--set)"), cause })?
    };
    let ctx = Ctx { origin, base_dir, budget };
    let mut desc = SceneDescription::empty(SceneFormat::Manifest);
    if variation.frame.is_none() && !json.frames.is_empty() {
        desc.warnings.push(format!(
            "{origin}: {} frame(s) defined; the scene without them is rendered (choose one with --frame K, from 0)",
            json.frames.len()
        ));
    }
    let mut includes = Vec::new();

    // Materials first: objects refer to them by name. serde_json's map is sorted by key, so indices are
    // deterministic.
    let mut names: Vec<String> = Vec::new();
    for (name, value) in &json.materials {
        desc.materials.push(material(&ctx, name, value)?);
        names.push(name.clone());
    }
    let lookup = |name: &Option<String>, context: &str| -> Result<Option<u32>> {
        match name {
            None => Ok(None),
            Some(n) => match names.iter().position(|m| m == n) {
                // Material counts come from a JSON map, far below u32::MAX.
                Some(i) => Ok(Some(i as u32)),
                None => Err(Error::MissingMaterial {
                    origin: origin.to_owned(),
                    name: n.clone(),
                    context: context.to_owned(),
                    available: names.join(", "),
                }),
            },
        }
    };

    desc.camera = json.camera.map(|c| camera(&ctx, c)).transpose()?;
    desc.cameras = desc.camera.iter().map(|c| ("camera".to_owned(), c.clone())).collect();
    for (i, light) in json.lights.into_iter().enumerate() {
        desc.lights.push(light_desc(&ctx, &format!("lights[{i}]"), light, &mut desc.warnings)?);
    }
    if let Some(bg) = &json.background {
        desc.background = Some(background(&ctx, bg)?);
    }
    desc.settings = settings(&ctx, &json.settings)?;

    for (i, object) in json.objects.into_iter().enumerate() {
        let context = format!("objects[{i}]");
        match object {
            ObjectJson::Sphere { center, radius, material } => {
                let m = lookup(&material, &context)?;
                let center = ctx.vec3(&format!("{context}.center"), center)?;
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(ctx.err(format!("{context}.radius"), format!("{radius} must be finite and > 0")));
                }
                // The rule of every object, applied to the sphere's bounding box.
                let r = Vec3::splat(radius);
                check_coordinates(&[center - r, center + r], Path::new(origin), &context)?;
                let sphere = Sphere::new(center, radius, m).map_err(|e| ctx.err(&context, e.to_string()))?;
                desc.spheres.push(sphere);
            }
            ObjectJson::Quad { corner, edge_u, edge_v, material } => {
                let m = lookup(&material, &context)?;
                let p = ctx.vec3(&format!("{context}.corner"), corner)?;
                let u = ctx.vec3(&format!("{context}.edge_u"), edge_u)?;
                let v = ctx.vec3(&format!("{context}.edge_v"), edge_v)?;
                desc.meshes.push(quad(&ctx, &context, p, u, v, m)?);
            }
            ObjectJson::Plane { point, normal, size, material } => {
                let m = lookup(&material, &context)?;
                let p = ctx.vec3(&format!("{context}.point"), point)?;
                let n = ctx.unit(&format!("{context}.normal"), normal)?;
                if !(size.is_finite() && size > 0.0) {
                    return Err(ctx.err(format!("{context}.size"), format!("{size} must be finite and > 0")));
                }
                // Any orthonormal tangent pair; edge_u × edge_v must equal +n so the quad faces `normal`.
                let (t, b) = n.any_orthonormal_pair();
                let (u, v) = if t.cross(b).dot(n) > 0.0 { (t, b) } else { (b, t) };
                let corner = p - 0.5 * size * (u + v);
                desc.meshes.push(quad(&ctx, &context, corner, size * u, size * v, m)?);
            }
            ObjectJson::Mesh { file, transform, material } => {
                let m = lookup(&material, &context)?;
                let matrix = match transform {
                    Some(t) => transform_matrix(&ctx, &format!("{context}.transform"), t)?,
                    None => Mat4::IDENTITY,
                };
                let extension = Path::new(&file).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
                if !matches!(extension.as_deref(), Some("gltf" | "glb" | "obj")) {
                    return Err(ctx.err(
                        format!("{context}.file"),
                        format!("`{file}`: meshes must be .gltf, .glb or .obj files"),
                    ));
                }
                let path = budget.resolve(Path::new(origin), base_dir, &file)?;
                includes.push(Include { context, path, matrix, material: m, position: desc.meshes.len() });
            }
        }
    }
    Ok((desc, includes))
}

fn camera(ctx: &Ctx<'_>, c: CameraJson) -> Result<CameraDesc> {
    // The same f32 values serde gave before these were read as f64.
    let position = ctx.vec3("camera.position", c.position.map(|v| v as f32))?;
    let look_at = ctx.vec3("camera.look_at", c.look_at.map(|v| v as f32))?;
    let up = ctx.unit("camera.up", c.up)?;
    if c.position == c.look_at {
        return Err(ctx.err("camera.look_at", "equals camera.position"));
    }
    if !(look_at - position).is_finite() {
        return Err(ctx.err(
            "camera.look_at",
            format!(
                "{:?} is too far from camera.position {:?} (their difference overflows f32)",
                c.look_at, c.position
            ),
        ));
    }
    let dir = view_direction(position, look_at, c.position, c.look_at).ok_or_else(|| {
        ctx.err(
            "camera.look_at",
            format!(
                "{:?} is too close to camera.position {:?} for its magnitude (precision lost: positions are f32, about 7 significant digits)",
                c.look_at, c.position
            ),
        )
    })?;
    if dir.cross(up).length() < 1e-6 {
        return Err(ctx.err("camera.up", "is parallel to the viewing direction"));
    }
    if !(c.vfov_deg > 0.0 && c.vfov_deg < 180.0) {
        return Err(ctx.err("camera.vfov_deg", format!("{} is outside (0, 180)", c.vfov_deg)));
    }
    for (key, v) in [("camera.width", c.width), ("camera.height", c.height)] {
        if v == Some(0) {
            return Err(ctx.err(key, "must be > 0"));
        }
    }
    Ok(CameraDesc {
        position,
        look_at,
        up,
        vfov_deg: c.vfov_deg,
        projection: Projection::Perspective,
        aspect_ratio: None,
        width: c.width,
        height: c.height,
    })
}

/// The viewing direction from the f32 `position` to the f32 `look_at`, if it is the direction the file
/// writes (`written_*`, f64, distinct): `None` when the f32 difference cannot be normalised (it rounded to
/// zero, underflows when squared, or overflows) or points more than 1 mrad away from the written one,
/// as when a far camera's look_at is a few f32 steps from its position.
fn view_direction(
    position: Vec3,
    look_at: Vec3,
    written_position: [f64; 3],
    written_look_at: [f64; 3],
) -> Option<Vec3> {
    let dir = (look_at - position).try_normalize()?;
    let written = DVec3::from_array(written_look_at) - DVec3::from_array(written_position);
    let written = written.try_normalize()?;
    (written.cross(dir.as_dvec3()).length() <= 1e-3 && written.dot(dir.as_dvec3()) > 0.0).then_some(dir)
}

/// A light's `intensity` and `unit`: `allowed` units for its kind, the first being the default.
fn intensity(ctx: &Ctx<'_>, context: &str, v: f32, unit: Option<&str>, allowed: &[LightUnit]) -> Result<LightAmount> {
    if !(v.is_finite() && v >= 0.0) {
        return Err(ctx.err(format!("{context}.intensity"), format!("{v} must be finite and ≥ 0")));
    }
    let unit = match unit {
        None => allowed[0],
        Some(name) => LightUnit::from_name(name).filter(|u| allowed.contains(u)).ok_or_else(|| {
            let names: Vec<_> = allowed.iter().map(|u| format!("\"{}\"", u.name())).collect();
            ctx.err(format!("{context}.unit"), format!("\"{name}\" is not one of {} for this light", names.join(", ")))
        })?,
    };
    Ok(LightAmount { value: v, unit })
}

/// Units of point and spot lights, the default first.
const POINT_UNITS: &[LightUnit] = &[LightUnit::Candela, LightUnit::Lumen, LightUnit::Watt];

fn light_desc(ctx: &Ctx<'_>, context: &str, light: LightJson, warnings: &mut Vec<String>) -> Result<LightDesc> {
    let spec = |v: &Value| spectrum(ctx, &format!("{context}.spectrum"), v);
    Ok(match light {
        LightJson::Point { position, spectrum, intensity: i, unit, ies: None, direction, up } => {
            if let Some(key) = [("direction", direction.is_some()), ("up", up.is_some())].iter().find(|k| k.1) {
                return Err(ctx.err(format!("{context}.{}", key.0), "orients a luminaire: only with `ies`"));
            }
            LightDesc::Point {
                position: ctx.vec3(&format!("{context}.position"), position)?,
                spectrum: spec(&spectrum)?,
                intensity: intensity(ctx, context, i, unit.as_deref(), POINT_UNITS)?,
            }
        }
        LightJson::Point { position, spectrum, intensity: i, unit, ies: Some(file), direction, up } => {
            if unit.is_some() {
                return Err(ctx.err(
                    format!("{context}.unit"),
                    "a luminaire's file gives its candela; `intensity` is a plain factor on them (remove `unit`)",
                ));
            }
            let scale = intensity(ctx, context, i, None, POINT_UNITS)?.value;
            let direction = ctx.unit(&format!("{context}.direction"), direction.unwrap_or([0.0, -1.0, 0.0]))?;
            // The default C0 plane: towards +Z, or +X for a luminaire aimed along Z.
            let default_up = if direction.z.abs() < 0.999 { [0.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0] };
            let up = ctx.unit(&format!("{context}.up"), up.unwrap_or(default_up))?;
            let up =
                up.reject_from_normalized(direction).try_normalize().filter(|_| up.cross(direction).length() > 1e-3);
            let up = up.ok_or_else(|| ctx.err(format!("{context}.up"), "must not be parallel to `direction`"))?;
            let path = ctx.budget.resolve(Path::new(ctx.origin), ctx.base_dir, &file)?;
            ctx.budget.check_file(Path::new(ctx.origin), &path, MAX_PHOTOMETRIC_FILE_BYTES)?;
            let bytes = ctx.budget.read(Path::new(ctx.origin), &path)?;
            // IES files are often Latin-1; only numbers and keywords matter here.
            let text = String::from_utf8_lossy(&bytes);
            let format = photometry::format_of(&path, &text);
            let (web, file_warnings) = photometry::parse(&text, &path, format, ctx.budget, Path::new(ctx.origin))?;
            warnings.extend(file_warnings);
            LightDesc::Luminaire {
                position: ctx.vec3(&format!("{context}.position"), position)?,
                direction,
                up,
                spectrum: spec(&spectrum)?,
                scale,
                web,
            }
        }
        LightJson::Spot { position, direction, inner_cone_deg, outer_cone_deg, spectrum, intensity: i, unit } => {
            let outer = ctx.in_range(&format!("{context}.outer_cone_deg"), outer_cone_deg, 0.0, 90.0)?;
            let inner = ctx.in_range(&format!("{context}.inner_cone_deg"), inner_cone_deg, 0.0, outer)?;
            LightDesc::Spot {
                position: ctx.vec3(&format!("{context}.position"), position)?,
                direction: ctx.unit(&format!("{context}.direction"), direction)?,
                inner_cone_deg: inner,
                outer_cone_deg: outer,
                spectrum: spec(&spectrum)?,
                intensity: intensity(ctx, context, i, unit.as_deref(), POINT_UNITS)?,
            }
        }
        LightJson::Directional { direction, spectrum, intensity: i, unit } => LightDesc::Directional {
            direction: ctx.unit(&format!("{context}.direction"), direction)?,
            spectrum: spec(&spectrum)?,
            intensity: intensity(ctx, context, i, unit.as_deref(), &[LightUnit::Lux, LightUnit::Watt])?,
        },
        LightJson::Environment { spectrum, intensity: i, unit, map: None, rotation_deg } => {
            if rotation_deg.is_some() {
                return Err(ctx.err(format!("{context}.rotation_deg"), "rotates a `map`; this environment has none"));
            }
            LightDesc::Environment {
                spectrum: spec(&spectrum.unwrap_or_else(default_light_spectrum))?,
                intensity: intensity(ctx, context, i, unit.as_deref(), &[LightUnit::Nit, LightUnit::Watt])?,
                map: None,
            }
        }
        LightJson::Environment { spectrum, intensity: i, unit, map: Some(file), rotation_deg } => {
            if spectrum.is_some() {
                return Err(ctx.err(
                    format!("{context}.spectrum"),
                    "an environment with a `map` takes its colour from the map's texels (remove `spectrum`)",
                ));
            }
            let extension = Path::new(&file).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            if !matches!(extension.as_deref(), Some("hdr" | "exr")) {
                return Err(ctx.err(
                    format!("{context}.map"),
                    format!("`{file}`: environment maps must be Radiance .hdr or OpenEXR .exr files"),
                ));
            }
            let path = ctx.budget.resolve(Path::new(ctx.origin), ctx.base_dir, &file)?;
            ctx.budget.check_file(Path::new(ctx.origin), &path, u64::MAX)?;
            let rotation_deg = rotation_deg.unwrap_or(0.0);
            if !rotation_deg.is_finite() {
                return Err(ctx.err(format!("{context}.rotation_deg"), format!("{rotation_deg} must be finite")));
            }
            LightDesc::Environment {
                // The texels give the colour; the spectrum is unused (see `LightDesc::Environment`).
                spectrum: SpectrumDesc::Named("D65".into()),
                // A map's texels are luminances (nits): `intensity` multiplies them.
                intensity: intensity(ctx, context, i, unit.as_deref(), &[LightUnit::Nit])?,
                map: Some(EnvironmentMapDesc { path, rotation_deg }),
            }
        }
    })
}

fn background(ctx: &Ctx<'_>, v: &Value) -> Result<(SpectrumDesc, f32)> {
    // `{"spectrum": .., "intensity": ..}` or a bare spectrum (intensity 1).
    if let Some(obj) = v.as_object().filter(|o| o.contains_key("spectrum")) {
        if let Some(key) = obj.keys().find(|k| *k != "spectrum" && *k != "intensity") {
            return Err(ctx.err("background", format!("unknown key `{key}` (expected `spectrum`, `intensity`)")));
        }
        let s = spectrum(ctx, "background.spectrum", &obj["spectrum"])?;
        let i = match obj.get("intensity") {
            None => 1.0,
            Some(x) => number(ctx, "background.intensity", x)?,
        };
        return Ok((s, intensity(ctx, "background", i, None, &[LightUnit::Nit])?.value));
    }
    Ok((spectrum(ctx, "background", v)?, 1.0))
}

/// The `settings` object: each key known and its value in range, or an error naming the key.
fn settings(ctx: &Ctx<'_>, json: &Map<String, Value>) -> Result<Settings> {
    let mut out = Settings::default();
    for (key, value) in json {
        let context = format!("settings.{key}");
        match key.as_str() {
            "integrator" => {
                // Which names exist is the integrators' business (`--integrator auto` checks it).
                let name = value.as_str().ok_or_else(|| {
                    ctx.err(&context, format!("expected a string (\"whitted-hall\" or \"path\"), got {value}"))
                })?;
                out.integrator = Some(name.to_owned());
            }
            "max_depth" => out.max_depth = Some(depth(ctx, &context, value)?),
            "rr_depth" => out.rr_depth = Some(depth(ctx, &context, value)?),
            _ => return Err(unknown_key(ctx, "settings", key, SETTINGS_KEYS)),
        }
    }
    Ok(out)
}

/// A depth setting: a whole number in `0..=Settings::MAX_DEPTH` (`20.0` is 20). `-3`, `2.5`, `1e30` and `"20"`
/// are refused rather than clamped, truncated, saturated or ignored: a mistake in the file must not quietly
/// change the render.
fn depth(ctx: &Ctx<'_>, context: &str, value: &Value) -> Result<u32> {
    let max = Settings::MAX_DEPTH;
    value
        .as_f64()
        .filter(|d| d.fract() == 0.0 && (0.0..=f64::from(max)).contains(d))
        // In range and whole: exact.
        .map(|d| d as u32)
        .ok_or_else(|| ctx.err(context, format!("expected an integer in 0..={max}, got {value}")))
}

fn material(ctx: &Ctx<'_>, name: &str, value: &Value) -> Result<MaterialDesc> {
    let context = format!("materials.{name}");
    if let Some(key) = value.as_object().and_then(|o| o.keys().find(|k| !MATERIAL_KEYS.contains(&k.as_str()))) {
        return Err(unknown_key(ctx, &context, key, MATERIAL_KEYS));
    }
    let m: MaterialJson = serde_json::from_value(value.clone()).map_err(|e| ctx.err(&context, e.to_string()))?;
    let mut out = MaterialDesc::new(name, MaterialFormat::Manifest);
    // Ranges are checked here (an out-of-range value is an error naming its key); defaults are not filled
    // in: what the renderer assumes for an unwritten key is the assembly's decision.
    let unit_interval = |key: &str, v: Option<f32>| -> Result<Option<f32>> {
        v.map(|x| ctx.in_range(&format!("{context}.{key}"), x, 0.0, 1.0)).transpose()
    };
    let non_negative = |key: &str, v: Option<f32>| -> Result<Option<f32>> {
        v.map(|x| ctx.in_range(&format!("{context}.{key}"), x, 0.0, f32::MAX)).transpose()
    };
    let spectrum_of = |key: &str, v: &Option<Value>| -> Result<Option<SpectrumDesc>> {
        v.as_ref().map(|v| spectrum(ctx, &format!("{context}.{key}"), v)).transpose()
    };
    if let Some(model) = &m.model
        && !KNOWN_MODELS.contains(&model.as_str())
    {
        return Err(ctx.err(
            format!("{context}.model"),
            format!("unknown model `{model}` (expected {})", KNOWN_MODELS.join(", ")),
        ));
    }
    if m.metal.is_some() && m.model.as_deref() != Some("conductor") {
        return Err(ctx.err(format!("{context}.metal"), "`metal` needs `\"model\": \"conductor\"`"));
    }
    let conductor_key =
        |key: &str| ctx.err(format!("{context}.{key}"), format!("`{key}` needs `\"model\": \"conductor\"`"));
    if m.model.as_deref() != Some("conductor") {
        if m.eta.is_some() {
            return Err(conductor_key("eta"));
        }
        if m.k.is_some() {
            return Err(conductor_key("k"));
        }
    }
    match (&m.metal, m.eta.is_some(), m.k.is_some()) {
        (Some(_), true, _) | (Some(_), _, true) => {
            return Err(ctx.err(
                format!("{context}.metal"),
                "a conductor is either a named `metal` or measured `eta` and `k`, not both",
            ));
        }
        (None, true, false) => {
            return Err(ctx.err(format!("{context}.eta"), "`eta` needs `k` (the extinction coefficient) beside it"));
        }
        (None, false, true) => {
            return Err(ctx.err(format!("{context}.k"), "`k` needs `eta` (the real index) beside it"));
        }
        _ => {}
    }
    if m.nonlinear.is_some() && m.model.as_deref() != Some("plastic") {
        return Err(ctx.err(format!("{context}.nonlinear"), "`nonlinear` needs `\"model\": \"plastic\"`"));
    }
    out.eta = spectrum_of("eta", &m.eta)?;
    out.k = spectrum_of("k", &m.k)?;
    out.nonlinear = m.nonlinear;
    out.model = m.model;
    out.metal = m.metal;
    out.base_color = spectrum_of("base_color", &m.base_color)?;
    out.diffuse = non_negative("diffuse", m.diffuse)?;
    out.specular = spectrum_of("specular", &m.specular)?;
    out.ks = non_negative("ks", m.ks)?;
    out.metallic = unit_interval("metallic", m.metallic)?;
    out.roughness = unit_interval("roughness", m.roughness)?;
    out.shininess = non_negative("shininess", m.shininess)?;
    out.transmission = non_negative("transmission", m.transmission)?;
    out.transmittance = spectrum_of("transmittance", &m.transmittance)?;
    out.ior = m.ior.as_ref().map(|v| ior(ctx, &format!("{context}.ior"), v)).transpose()?;
    out.dispersion = non_negative("dispersion", m.dispersion)?;
    out.absorption = m.absorption.as_ref().map(|v| absorption(ctx, &format!("{context}.absorption"), v)).transpose()?;
    out.thickness = non_negative("thickness", m.thickness)?;
    out.emission = spectrum_of("emission", &m.emission)?;
    out.emission_strength = non_negative("emission_strength", m.emission_strength)?;
    out.double_sided = m.double_sided;
    out.multiple_scattering = m.multiple_scattering;
    if let Some(v) = &m.fluorescence {
        // Re-emission is modelled on a Lambertian surface only (`docs/fluorescence.md`).
        if !matches!(out.model.as_deref(), None | Some("diffuse")) {
            return Err(ctx.err(
                format!("{context}.fluorescence"),
                "fluorescence needs a Lambertian material (`\"model\": \"diffuse\"` or no model)",
            ));
        }
        out.fluorescence = Some(Box::new(fluorescence(ctx, &format!("{context}.fluorescence"), v)?));
    }
    // Passed up untouched, as a glTF material's `extras` are.
    out.extras = match m.extras {
        None => None,
        Some(extras @ Value::Object(_)) => Some(extras),
        Some(other) => {
            return Err(
                ctx.err(format!("{context}.extras"), format!("expected an object of free-form data, got {other}"))
            );
        }
    };
    Ok(out)
}

/// A material's `fluorescence`: `{"excitation", "emission", "yield"}` or `{"matrix": "file.csv"}`.
fn fluorescence(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<FluorescenceDesc> {
    const FORMS: &str =
        "{\"excitation\": SPECTRUM, \"emission\": SPECTRUM, \"yield\": q} or {\"matrix\": \"file.csv\"}";
    let Value::Object(obj) = v else { return Err(ctx.err(context, format!("expected {FORMS}, found {v}"))) };
    if let Some(file) = obj.get("matrix") {
        only_keys(ctx, context, obj, &["matrix"])?;
        let c = format!("{context}.matrix");
        let file = file.as_str().filter(|s| !s.is_empty()).ok_or_else(|| ctx.err(&c, "expected a file name"))?;
        let referrer = Path::new(ctx.origin);
        let path = ctx.budget.resolve(referrer, ctx.base_dir, file)?;
        ctx.budget.check_file(referrer, &path, MAX_SPECTRUM_FILE_BYTES)?;
        return Ok(FluorescenceDesc::Matrix(path));
    }
    only_keys(ctx, context, obj, &["excitation", "emission", "yield"])?;
    let required =
        |key: &str| obj.get(key).ok_or_else(|| ctx.err(context, format!("missing `{key}` (expected {FORMS})")));
    let excitation = spectrum(ctx, &format!("{context}.excitation"), required("excitation")?)?;
    let emission = spectrum(ctx, &format!("{context}.emission"), required("emission")?)?;
    let c = format!("{context}.yield");
    let quantum_yield = ctx.in_range(&c, number(ctx, &c, required("yield")?)?, 0.0, 1.0)?;
    Ok(FluorescenceDesc::Spectra { excitation, emission, quantum_yield })
}

fn quad(ctx: &Ctx<'_>, context: &str, corner: Vec3, u: Vec3, v: Vec3, material: Option<u32>) -> Result<Mesh> {
    if u.cross(v).length_squared() == 0.0 {
        return Err(ctx.err(context, "the quad's edges are parallel or zero (zero area)"));
    }
    let positions = vec![corner, corner + u, corner + u + v, corner + v];
    check_coordinates(&positions, Path::new(ctx.origin), context)?;
    let uvs = vec![glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::ONE, glam::Vec2::Y];
    Mesh::new(positions, None, Some(uvs), vec![[0, 1, 2], [0, 2, 3]], material)
        .map_err(|e| ctx.err(context, e.to_string()))
}

fn transform_matrix(ctx: &Ctx<'_>, context: &str, t: TransformJson) -> Result<Mat4> {
    let m = if let Some(rows) = t.matrix {
        if t.translate.is_some() || t.rotate.is_some() || t.scale.is_some() {
            return Err(ctx.err(context, "`matrix` excludes `translate`, `rotate` and `scale`"));
        }
        // Rows as written; glam is column-major, so transpose.
        Mat4::from_cols_array_2d(&rows).transpose()
    } else {
        let scale = match t.scale {
            None => Vec3::ONE,
            Some(ScaleJson::Uniform(s)) => Vec3::splat(s),
            Some(ScaleJson::PerAxis(s)) => Vec3::from_array(s),
        };
        if !scale.is_finite() || scale.cmpeq(Vec3::ZERO).any() {
            return Err(ctx.err(format!("{context}.scale"), format!("{scale} must be finite and non-zero")));
        }
        let rotations = match t.rotate {
            None => Vec::new(),
            Some(RotationsJson::One(r)) => vec![r],
            Some(RotationsJson::Many(rs)) => rs,
        };
        let mut rotation = Quat::IDENTITY;
        for (i, r) in rotations.iter().enumerate() {
            let c = format!("{context}.rotate[{i}]");
            let axis = ctx.unit(&c, r.axis)?;
            let deg = ctx.finite(&c, r.deg)?;
            // Listed rotations apply in order: the first listed acts first on the object.
            rotation = Quat::from_axis_angle(axis, deg.to_radians()) * rotation;
        }
        let translate = ctx.vec3(&format!("{context}.translate"), t.translate.unwrap_or([0.0; 3]))?;
        // Scale, then rotate, then translate.
        Mat4::from_scale_rotation_translation(scale, rotation, translate)
    };
    let det = m.determinant();
    if !m.is_finite() || !det.is_finite() || det.abs() < f32::MIN_POSITIVE {
        return Err(ctx.err(context, "the matrix must be finite and invertible"));
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::desc::{AbsorptionDesc, IorDesc};

    fn parse_text(text: &str) -> Result<SceneDescription> {
        parse(text, Path::new("/scenes"), "test.json", &Budget::allowing_absolute_paths()).map(|(d, _)| d)
    }

    fn ctx<'a>(base_dir: &'a Path, budget: &'a Budget) -> Ctx<'a> {
        Ctx { origin: "t", base_dir, budget }
    }

    /// `eta`/`k` and `nonlinear` belong to their models, `eta` and `k` come together and never with `metal`;
    /// each refusal names the key.
    #[test]
    fn conductor_and_plastic_keys_are_checked() {
        let material = |m: &str| parse_text(&format!(r#"{{"materials":{{"m":{m}}}}}"#));
        let d = material(r#"{"model":"conductor","eta":1.2,"k":{"samples":[[360,3],[830,4]]}}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.materials[0].eta, Some(SpectrumDesc::Constant(1.2)));
        assert!(matches!(d.materials[0].k, Some(SpectrumDesc::Samples { .. })));
        let d = material(r#"{"model":"plastic","nonlinear":true,"roughness":0.3}"#).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((d.materials[0].model.as_deref(), d.materials[0].nonlinear), (Some("plastic"), Some(true)));
        for (m, key, says) in [
            (r#"{"model":"diffuse","eta":1.2,"k":3}"#, "materials.m.eta", "needs"),
            (r#"{"model":"conductor","eta":1.2}"#, "materials.m.eta", "`k`"),
            (r#"{"model":"conductor","k":3}"#, "materials.m.k", "`eta`"),
            (r#"{"model":"conductor","metal":"Au","eta":1.2,"k":3}"#, "materials.m.metal", "not both"),
            (r#"{"model":"conductor","nonlinear":true}"#, "materials.m.nonlinear", "plastic"),
        ] {
            let e = material(m).err().map(|e| e.to_string()).unwrap_or_else(|| panic!("{m} loaded"));
            assert!(e.contains(key) && e.contains(says), "{m}: {e}");
        }
    }

    /// `fluorescence` takes excitation, emission and yield, or a matrix file, on a Lambertian material; each
    /// refusal names the key.
    #[test]
    fn fluorescence_keys_are_checked() {
        let material = |m: &str| parse_text(&format!(r#"{{"materials":{{"m":{m}}}}}"#));
        let d =
            material(r#"{"fluorescence":{"excitation":{"samples":[[300,0.2],[400,0]]},"emission":"D65","yield":0.8}}"#)
                .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            d.materials[0].fluorescence.as_deref(),
            Some(&FluorescenceDesc::Spectra {
                excitation: SpectrumDesc::Samples { lambda: vec![300.0, 400.0], values: vec![0.2, 0.0] },
                emission: SpectrumDesc::Named("D65".into()),
                quantum_yield: 0.8,
            })
        );
        for (m, key, says) in [
            (r#"{"model":"mirror","fluorescence":{"matrix":"m.csv"}}"#, "materials.m.fluorescence", "Lambertian"),
            (r#"{"fluorescence":{"excitation":0.1,"emission":1}}"#, "materials.m.fluorescence", "missing `yield`"),
            (
                r#"{"fluorescence":{"excitation":0.1,"emission":1,"yield":1.5}}"#,
                "materials.m.fluorescence.yield",
                "outside",
            ),
            (
                r#"{"fluorescence":{"excitation":0.1,"emission":1,"yield":1,"q":1}}"#,
                "materials.m.fluorescence",
                "unknown key `q`",
            ),
            (r#"{"fluorescence":{"matrix":""}}"#, "materials.m.fluorescence.matrix", "file name"),
            (r#"{"fluorescence":{"matrix":"m.csv","yield":1}}"#, "materials.m.fluorescence", "unknown key `yield`"),
            (r#"{"fluorescence":3}"#, "materials.m.fluorescence", "expected"),
        ] {
            let e = material(m).err().map(|e| e.to_string()).unwrap_or_else(|| panic!("{m} loaded"));
            assert!(e.contains(key) && e.contains(says), "{m}: {e}");
        }
    }

    #[test]
    fn spectrum_forms_parse() {
        let dir = std::env::temp_dir().join("spectrace-geometry-manifest-forms");
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.join("a.csv"), "nm,r\n400,0.1\n700,0.2\n").unwrap_or_else(|e| panic!("{e}"));
        let budget = Budget::new(crate::LoadOptions::default());
        let ctx = ctx(&dir, &budget);
        let s = |t: &str| spectrum(&ctx, "x", &serde_json::from_str(t).unwrap_or(Value::Null));
        assert_eq!(s("0.9").ok(), Some(SpectrumDesc::Constant(0.9)));
        assert_eq!(s("\"colorchecker:13\"").ok(), Some(SpectrumDesc::Named("colorchecker:13".into())));
        assert_eq!(s("{\"rgb\":[1,0.5,0]}").ok(), Some(SpectrumDesc::Rgb([1.0, 0.5, 0.0])));
        assert_eq!(
            s("{\"csv\":\"a.csv\",\"column\":\"r\"}").ok(),
            Some(SpectrumDesc::Csv { path: dir.join("a.csv"), column: Some("r".into()) })
        );
        // A CSV must be a regular file under a relative path.
        assert!(s("{\"csv\":\"missing.csv\"}").is_err());
        assert!(s("{\"csv\":\"/dev/zero\"}").is_err());
        assert_eq!(
            s("{\"samples\":[[400,0.1],[700,0.9]]}").ok(),
            Some(SpectrumDesc::Samples { lambda: vec![400.0, 700.0], values: vec![0.1, 0.9] })
        );
        assert!(s("{\"samples\":[[500,0.1],[400,0.9]]}").is_err());
        // Values below f32's smallest normal (here f32 subnormals) are zero.
        assert_eq!(
            s("{\"samples\":[[400,1e-45],[500,1e-39],[600,1.2e-38],[700,-1e-40]]}").ok(),
            Some(SpectrumDesc::Samples {
                lambda: vec![400.0, 500.0, 600.0, 700.0],
                values: vec![0.0, 0.0, 1.2e-38, 0.0]
            })
        );
        assert!(s("[1,2,3]").is_err());
        assert!(s("{\"rgb\":[1,2,3],\"x\":1}").is_err());
        // `"normalize": false`: the spectrum as given (absolute), for any spectral form.
        let absolute = |inner| Some(SpectrumDesc::Absolute(Box::new(inner)));
        assert_eq!(
            s("{\"samples\":[[400,2],[700,3]],\"normalize\":false}").ok(),
            absolute(SpectrumDesc::Samples { lambda: vec![400.0, 700.0], values: vec![2.0, 3.0] })
        );
        assert_eq!(s("{\"name\":\"D65\",\"normalize\":false}").ok(), absolute(SpectrumDesc::Named("D65".into())));
        assert_eq!(
            s("{\"csv\":\"a.csv\",\"normalize\":false}").ok(),
            absolute(SpectrumDesc::Csv { path: dir.join("a.csv"), column: None })
        );
        // `true` is the default; `{"name"}` alone is the name.
        assert_eq!(s("{\"name\":\"D65\",\"normalize\":true}").ok(), Some(SpectrumDesc::Named("D65".into())));
        assert_eq!(s("{\"name\":\"D65\"}").ok(), Some(SpectrumDesc::Named("D65".into())));
        // Not a boolean, or on a form that is never normalised (RGB, a number): an error naming the key.
        let msg = |t: &str| s(t).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            msg("{\"name\":\"D65\",\"normalize\":0}").contains("x.normalize"),
            "{}",
            msg("{\"name\":\"D65\",\"normalize\":0}")
        );
        assert!(msg("{\"rgb\":[1,1,1],\"normalize\":false}").contains("x.normalize"));
        assert!(s("{\"name\":\"\"}").is_err());
    }

    #[test]
    fn ior_and_absorption_forms_parse() {
        let budget = Budget::allowing_absolute_paths();
        let ctx = ctx(Path::new("/"), &budget);
        let v = |t: &str| serde_json::from_str::<Value>(t).unwrap_or(Value::Null);
        assert_eq!(ior(&ctx, "i", &v("0")).ok(), Some(IorDesc::Constant(0.0)));
        assert_eq!(
            ior(&ctx, "i", &v("{\"cauchy\":{\"a\":1.5,\"b\":0.004}}")).ok(),
            Some(IorDesc::Cauchy { a: 1.5, b: 0.004 })
        );
        assert_eq!(
            ior(&ctx, "i", &v("{\"abbe\":{\"nd\":1.5168,\"vd\":64.17}}")).ok(),
            Some(IorDesc::Abbe { nd: 1.5168, vd: 64.17 })
        );
        assert!(ior(&ctx, "i", &v("{\"abbe\":{\"nd\":1.5}}")).is_err());
        assert_eq!(
            absorption(&ctx, "a", &v("{\"per_unit\":0.95}")).ok(),
            Some(AbsorptionDesc::PerUnit(SpectrumDesc::Constant(0.95)))
        );
        assert_eq!(
            absorption(&ctx, "a", &v("{\"attenuation_color\":[1,0.5,0.5],\"attenuation_distance\":2}")).ok(),
            Some(AbsorptionDesc::Attenuation { color: [1.0, 0.5, 0.5], distance: 2.0 })
        );
    }

    #[test]
    fn transform_applies_scale_then_rotation_then_translation() {
        let budget = Budget::allowing_absolute_paths();
        let ctx = ctx(Path::new("/"), &budget);
        let t: TransformJson =
            serde_json::from_str(r#"{"translate":[1,0,0],"rotate":{"axis":[0,0,1],"deg":90},"scale":2}"#)
                .unwrap_or_else(|e| panic!("{e}"));
        let m = transform_matrix(&ctx, "t", t).unwrap_or_else(|e| panic!("{e}"));
        // (1,0,0) → scale (2,0,0) → rotate 90° about z (0,2,0) → translate (1,2,0).
        let p = m.transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 2.0, 0.0)).length() < 1e-6, "{p}");
    }

    #[test]
    fn row_major_matrix_translation_is_last_column() {
        let budget = Budget::allowing_absolute_paths();
        let ctx = ctx(Path::new("/"), &budget);
        let t: TransformJson = serde_json::from_str(r#"{"matrix":[[1,0,0,5],[0,1,0,6],[0,0,1,7],[0,0,0,1]]}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        let m = transform_matrix(&ctx, "t", t).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.transform_point3(Vec3::ZERO), Vec3::new(5.0, 6.0, 7.0));
    }

    #[test]
    fn plane_faces_its_normal() {
        let d = parse_text(r#"{"objects":[{"type":"plane","point":[0,0,0],"normal":[0,1,0],"size":2}]}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        let m = &d.meshes[0];
        let [a, b, c] = m.indices()[0];
        let p = m.positions();
        let n = (p[b as usize] - p[a as usize]).cross(p[c as usize] - p[a as usize]).normalize();
        assert!((n - Vec3::Y).length() < 1e-6, "{n}");
        assert!((p[2] - p[0]).length() - 2.0 * 2f32.sqrt() < 1e-5);
    }

    #[test]
    fn far_spheres_and_quads_are_refused_like_far_meshes() {
        // One rule and one error for every kind of object: a point of it beyond ±MAX_COORDINATE (for a
        // sphere, a corner of its bounding box), naming the manifest and the object.
        for (object, point) in [
            (r#"{"type":"sphere","center":[0,0,1e18],"radius":1e17}"#, 1),
            (r#"{"type":"sphere","center":[0,-1e18,0],"radius":1e17}"#, 0),
            (r#"{"type":"quad","corner":[0,0,0],"edge_u":[6e17,0,0],"edge_v":[6e17,0,1]}"#, 2),
            (r#"{"type":"plane","point":[0,0,0],"normal":[0,1,0],"size":3e18}"#, 0),
        ] {
            let text = format!(r#"{{"objects":[{{"type":"sphere","center":[0,0,0],"radius":1}},{object}]}}"#);
            let e = parse_text(&text).err().unwrap_or_else(|| panic!("{object} loaded"));
            assert!(
                matches!(&e, Error::CoordinateTooLarge { context, vertex, .. } if context == "objects[1]" && *vertex == point),
                "{object}: {e:?}"
            );
            let msg = e.to_string();
            assert!(msg.contains("test.json") && msg.contains("objects[1]"), "{msg}");
        }
        // At the limit exactly: accepted.
        assert!(parse_text(r#"{"objects":[{"type":"sphere","center":[0,0,0],"radius":1e18}]}"#).is_ok());
    }

    #[test]
    fn a_look_at_lost_to_f32_precision_is_not_called_equal() {
        let camera = |position: &str, look_at: &str| {
            let text =
                format!(r#"{{"camera":{{"position":{position},"look_at":{look_at},"vfov_deg":40}},"objects":[]}}"#);
            parse_text(&text).map(|d| d.camera.map(|c| (c.position, c.look_at)))
        };
        let message = |position: &str, look_at: &str| {
            camera(position, look_at).err().map(|e| e.to_string()).unwrap_or_else(|| panic!("{look_at} accepted"))
        };
        assert_eq!(message("[1, 2, 3]", "[1, 2, 3]"), "test.json: camera.look_at: equals camera.position");
        // Distinct as written, one f32 apart: the direction from the f32 values is not the file's.
        assert_eq!(
            message("[1e20, 0, 0]", "[1.00000000001e20, 0, 1e9]"),
            "test.json: camera.look_at: [1.00000000001e20, 0.0, 1000000000.0] is too close to camera.position \
             [1e20, 0.0, 0.0] for its magnitude (precision lost: positions are f32, about 7 significant digits)"
        );
        let m = message("[10000000, 10000000, 0]", "[10000000.3, 10000000.6, 0]");
        assert!(m.contains("too close to camera.position [10000000.0, 10000000.0, 0.0]"), "{m}");
        // A subnormal difference: its square underflows, so it has no direction.
        let m = message("[0, 0, 0]", "[1e-45, 0, 0]");
        assert!(m.contains("e-45, 0.0, 0.0] is too close to camera.position [0.0, 0.0, 0.0]"), "{m}");
        let m = message("[-3e38, 0, 0]", "[3e38, 0, 0]");
        assert!(m.contains("too far from camera.position [-3e38, 0.0, 0.0]"), "{m}");
        // Far from the origin but distinct to f32's precision: accepted as before.
        let far = camera("[1e20, 0, 0]", "[1e20, 0, 1e16]").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(far, Some((Vec3::new(1e20, 0.0, 0.0), Vec3::new(1e20, 0.0, 1e16))));
        let near = camera("[0.1, 0.2, 0.3]", "[0.1, 0.2, 0.30001]").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(near, Some((Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.1, 0.2, 0.30001))));
    }

    #[test]
    fn a_misspelt_material_key_is_refused_with_the_key_it_means() {
        let message = |material: &str| {
            let text = format!(r#"{{"materials":{{"m":{material}}}}}"#);
            parse_text(&text).err().map(|e| e.to_string()).unwrap_or_else(|| panic!("{material} loaded"))
        };
        let m = message(r#"{"base_colour":"colorchecker:13"}"#);
        assert!(m.starts_with("test.json: materials.m.base_colour: unknown key; did you mean `base_color`?"), "{m}");
        assert!(
            m.contains("known keys: model, metal, eta, k, nonlinear, base_color,") && m.ends_with("extras)"),
            "{m}"
        );
        let m = message(r#"{"fluorescense":0.5}"#);
        assert!(m.starts_with("test.json: materials.m.fluorescense: unknown key; did you mean `fluorescence`?"), "{m}");
        // Far from every key: refused with the list only.
        let m = message(r#"{"phosphorescence":0.5}"#);
        assert!(m.starts_with("test.json: materials.m.phosphorescence: unknown key (known keys: model,"), "{m}");
        // Free-form data has one place, an object.
        assert_eq!(
            message(r#"{"extras":3}"#),
            "test.json: materials.m.extras: expected an object of free-form data, got 3"
        );
    }

    #[test]
    fn material_extras_are_passed_up_untouched() {
        let d = parse_text(r#"{"materials":{"m":{"ks":0.1,"extras":{"anything":1,"spectral_override":"x"}}}}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.materials[0].extras, Some(serde_json::json!({"anything":1,"spectral_override":"x"})));
        assert_eq!(d.materials[0].ks, Some(0.1));
        assert!(d.warnings.is_empty(), "{:?}", d.warnings);
    }

    #[test]
    fn material_keys_list_the_fields_serde_reads() {
        // serde's own list of the struct's fields, in declaration order, from its unknown-field error.
        let e = serde_json::from_str::<MaterialJson>(r#"{"?":0}"#).err().map(|e| e.to_string()).unwrap_or_default();
        let quoted: Vec<String> = MATERIAL_KEYS.iter().map(|k| format!("`{k}`")).collect();
        assert!(e.contains(&format!("expected one of {}", quoted.join(", "))), "{e}");
    }

    #[test]
    fn settings_are_typed_and_checked() {
        let settings = |body: &str| parse_text(&format!(r#"{{"settings":{body}}}"#)).map(|d| d.settings);
        let message =
            |body: &str| settings(body).err().map(|e| e.to_string()).unwrap_or_else(|| panic!("{body} loaded"));
        assert_eq!(
            settings(r#"{"max_depth":20,"rr_depth":0,"integrator":"whitted-hall"}"#).ok(),
            Some(Settings { integrator: Some("whitted-hall".into()), max_depth: Some(20), rr_depth: Some(0) })
        );
        // A whole number written as a float is that number; the limit itself is accepted.
        assert_eq!(
            settings(r#"{"max_depth":20.0,"rr_depth":1024}"#).ok().map(|s| (s.max_depth, s.rr_depth)),
            Some((Some(20), Some(1024)))
        );
        assert_eq!(settings("{}").ok(), Some(Settings::default()));
        // A wrong type or a value out of range is an error naming its place, not clamped, saturated or ignored.
        let refused = [
            (r#"{"max_depth":-3}"#, "settings.max_depth: expected an integer in 0..=1024, got -3"),
            (r#"{"max_depth":"20"}"#, "settings.max_depth: expected an integer in 0..=1024, got \"20\""),
            (r#"{"max_depth":1e30}"#, "settings.max_depth: expected an integer in 0..=1024, got 1e+30"),
            (r#"{"rr_depth":-1}"#, "settings.rr_depth: expected an integer in 0..=1024, got -1"),
            (r#"{"max_depth":2.5}"#, "settings.max_depth: expected an integer in 0..=1024, got 2.5"),
            (r#"{"max_depth":1025}"#, "settings.max_depth: expected an integer in 0..=1024, got 1025"),
            (
                r#"{"max_dpeth":8}"#,
                "settings.max_dpeth: unknown key; did you mean `max_depth`? (known keys: integrator, max_depth, rr_depth)",
            ),
            (r#"{"ambient":0.1}"#, "settings.ambient: unknown key (known keys: integrator, max_depth, rr_depth)"),
            (r#"{"integrator":3}"#, "settings.integrator: expected a string (\"whitted-hall\" or \"path\"), got 3"),
        ];
        for (json, expected) in refused {
            assert_eq!(message(json), format!("test.json: {expected}"), "{json}");
        }
    }
}
