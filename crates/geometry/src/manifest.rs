//! The scene manifest: a small JSON file a user writes by hand (format in `docs/scene-format.md`).
//!
//! Parsing is two-staged: serde reads the structure (unknown top-level, camera, light, object and transform
//! keys are errors naming the key, so typos are never silent), then each value that can take several forms
//! (spectra, IORs, absorption) is converted by hand with a context path such as `materials.glass.ior`, so
//! every error says where it is.

use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use serde::Deserialize;
use serde_json::{Map, Value};

use crate::error::{Error, Result};
use crate::scene::{
    AbsorptionDesc, CameraDesc, IorDesc, LightDesc, MaterialDesc, SceneDescription, SpectrumDesc,
    shininess_from_roughness,
};
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
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraJson {
    position: [f32; 3],
    look_at: [f32; 3],
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
    },
    Directional {
        direction: [f32; 3],
        #[serde(default = "default_light_spectrum")]
        spectrum: Value,
        #[serde(default = "one")]
        intensity: f32,
    },
    Environment {
        #[serde(default = "default_light_spectrum")]
        spectrum: Value,
        #[serde(default = "one")]
        intensity: f32,
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

/// Material keys; anything else goes to `extras` (with a warning, so typos are visible).
#[derive(Deserialize)]
struct MaterialJson {
    model: Option<String>,
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
    #[serde(flatten)]
    extras: Map<String, Value>,
}

/// Model hints the layers above understand (see [`MaterialDesc::model`]).
const KNOWN_MODELS: &[&str] = &["hall", "diffuse", "dielectric", "conductor", "mirror"];

/// Context for converting values: where the manifest came from, for error messages and relative paths.
struct Ctx<'a> {
    origin: &'a str,
    base_dir: &'a Path,
}

impl Ctx<'_> {
    fn err(&self, context: impl Into<String>, message: impl Into<String>) -> Error {
        Error::ManifestValue { origin: self.origin.to_owned(), context: context.into(), message: message.into() }
    }

    fn finite(&self, context: &str, v: f32) -> Result<f32> {
        if v.is_finite() { Ok(v) } else { Err(self.err(context, format!("{v} is not finite"))) }
    }

    fn in_range(&self, context: &str, v: f32, lo: f32, hi: f32) -> Result<f32> {
        if (lo..=hi).contains(&v) { Ok(v) } else { Err(self.err(context, format!("{v} is outside [{lo}, {hi}]"))) }
    }

    fn vec3(&self, context: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = Vec3::from_array(v);
        if v.is_finite() { Ok(v) } else { Err(self.err(context, format!("{v} is not finite"))) }
    }

    fn unit(&self, context: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = self.vec3(context, v)?;
        v.try_normalize().ok_or_else(|| self.err(context, "direction has zero length"))
    }
}

/// Parses a manifest from text. `base_dir` resolves relative file paths (spectra CSVs, meshes); `origin`
/// names the manifest in error messages (a path, or e.g. `"<embedded default scene>"`).
///
/// # Errors
/// [`Error::ManifestSyntax`] for malformed JSON or an unknown key (the message names the key, line and
/// column), [`Error::ManifestValue`] for a value out of range (with its path in the document),
/// [`Error::MissingMaterial`] for an object naming a material that is not defined, and the loaders' errors
/// for referenced files.
pub fn parse_manifest(text: &str, base_dir: &Path, origin: &str) -> Result<SceneDescription> {
    let json: ManifestJson =
        serde_json::from_str(text).map_err(|cause| Error::ManifestSyntax { origin: origin.to_owned(), cause })?;
    let ctx = Ctx { origin, base_dir };
    let mut desc = SceneDescription::empty();

    // Materials first: objects refer to them by name. serde_json's map is sorted by key, so indices are
    // deterministic.
    let mut names: Vec<String> = Vec::new();
    for (name, value) in &json.materials {
        desc.materials.push(material(&ctx, name, value, &mut desc.warnings)?);
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
    if desc.camera.is_none() {
        desc.warnings.push(format!("{origin}: no camera: the renderer chooses one"));
    }
    for (i, light) in json.lights.into_iter().enumerate() {
        desc.lights.push(light_desc(&ctx, &format!("lights[{i}]"), light)?);
    }
    if let Some(bg) = &json.background {
        desc.background = Some(background(&ctx, bg)?);
    }
    desc.settings = json.settings;

    for (i, object) in json.objects.into_iter().enumerate() {
        let context = format!("objects[{i}]");
        match object {
            ObjectJson::Sphere { center, radius, material } => {
                let m = lookup(&material, &context)?;
                let center = ctx.vec3(&format!("{context}.center"), center)?;
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(ctx.err(format!("{context}.radius"), format!("{radius} must be finite and > 0")));
                }
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
                let path = base_dir.join(&file);
                include_file(&ctx, &context, &path, matrix, m, &mut desc)?;
            }
        }
    }
    if desc.lights.is_empty() && !desc.materials.iter().any(MaterialDesc::is_emissive) {
        desc.warnings.push(format!("{origin}: no lights and no emissive materials"));
    }
    Ok(desc)
}

fn camera(ctx: &Ctx<'_>, c: CameraJson) -> Result<CameraDesc> {
    let position = ctx.vec3("camera.position", c.position)?;
    let look_at = ctx.vec3("camera.look_at", c.look_at)?;
    let up = ctx.unit("camera.up", c.up)?;
    let dir =
        (look_at - position).try_normalize().ok_or_else(|| ctx.err("camera.look_at", "equals camera.position"))?;
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
    Ok(CameraDesc { position, look_at, up, vfov_deg: c.vfov_deg, width: c.width, height: c.height })
}

fn intensity(ctx: &Ctx<'_>, context: &str, v: f32) -> Result<f32> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(ctx.err(format!("{context}.intensity"), format!("{v} must be finite and ≥ 0")))
    }
}

fn light_desc(ctx: &Ctx<'_>, context: &str, light: LightJson) -> Result<LightDesc> {
    let spec = |v: &Value| spectrum(ctx, &format!("{context}.spectrum"), v);
    Ok(match light {
        LightJson::Point { position, spectrum, intensity: i } => LightDesc::Point {
            position: ctx.vec3(&format!("{context}.position"), position)?,
            spectrum: spec(&spectrum)?,
            intensity: intensity(ctx, context, i)?,
        },
        LightJson::Spot { position, direction, inner_cone_deg, outer_cone_deg, spectrum, intensity: i } => {
            let outer = ctx.in_range(&format!("{context}.outer_cone_deg"), outer_cone_deg, 0.0, 90.0)?;
            let inner = ctx.in_range(&format!("{context}.inner_cone_deg"), inner_cone_deg, 0.0, outer)?;
            LightDesc::Spot {
                position: ctx.vec3(&format!("{context}.position"), position)?,
                direction: ctx.unit(&format!("{context}.direction"), direction)?,
                inner_cone_deg: inner,
                outer_cone_deg: outer,
                spectrum: spec(&spectrum)?,
                intensity: intensity(ctx, context, i)?,
            }
        }
        LightJson::Directional { direction, spectrum, intensity: i } => LightDesc::Directional {
            direction: ctx.unit(&format!("{context}.direction"), direction)?,
            spectrum: spec(&spectrum)?,
            intensity: intensity(ctx, context, i)?,
        },
        LightJson::Environment { spectrum, intensity: i } => {
            LightDesc::Environment { spectrum: spec(&spectrum)?, intensity: intensity(ctx, context, i)? }
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
        return Ok((s, intensity(ctx, "background", i)?));
    }
    Ok((spectrum(ctx, "background", v)?, 1.0))
}

fn number(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<f32> {
    let x = v.as_f64().ok_or_else(|| ctx.err(context, format!("expected a number, found {v}")))? as f32;
    ctx.finite(context, x)
}

fn numbers<const N: usize>(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<[f32; N]> {
    let arr = v
        .as_array()
        .filter(|a| a.len() == N)
        .ok_or_else(|| ctx.err(context, format!("expected an array of {N} numbers, found {v}")))?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(arr) {
        *o = number(ctx, context, x)?;
    }
    Ok(out)
}

/// Checks that an object has exactly the keys in `allowed` (plus none other), for the tagged forms.
fn only_keys(ctx: &Ctx<'_>, context: &str, obj: &Map<String, Value>, allowed: &[&str]) -> Result<()> {
    match obj.keys().find(|k| !allowed.contains(&k.as_str())) {
        Some(k) => Err(ctx.err(context, format!("unknown key `{k}` (expected {})", allowed.join(", ")))),
        None => Ok(()),
    }
}

/// `number | "name" | {"rgb":[r,g,b]} | {"csv":"file","column":"c"} | {"samples":[[λ,v],…]}`.
pub(crate) fn spectrum_from_value(v: &Value, base_dir: &Path, origin: &str, context: &str) -> Result<SpectrumDesc> {
    spectrum(&Ctx { origin, base_dir }, context, v)
}

fn spectrum(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<SpectrumDesc> {
    const FORMS: &str = "a number, a name (\"D65\", \"colorchecker:13\"), {\"rgb\": [r, g, b]}, \
                         {\"csv\": \"file\", \"column\": \"name\"} or {\"samples\": [[nm, value], …]}";
    match v {
        Value::Number(_) => Ok(SpectrumDesc::Constant(number(ctx, context, v)?)),
        Value::String(s) if !s.trim().is_empty() => Ok(SpectrumDesc::Named(s.trim().to_owned())),
        Value::Object(obj) if obj.contains_key("rgb") => {
            only_keys(ctx, context, obj, &["rgb"])?;
            Ok(SpectrumDesc::Rgb(numbers::<3>(ctx, &format!("{context}.rgb"), &obj["rgb"])?))
        }
        Value::Object(obj) if obj.contains_key("csv") => {
            only_keys(ctx, context, obj, &["csv", "column"])?;
            let file = obj["csv"]
                .as_str()
                .filter(|s| !s.is_empty())
                .ok_or_else(|| ctx.err(format!("{context}.csv"), "expected a file name"))?;
            let column = match obj.get("column") {
                None => None,
                Some(Value::String(c)) => Some(c.clone()),
                Some(Value::Number(n)) => Some(n.to_string()),
                Some(other) => {
                    return Err(ctx.err(format!("{context}.column"), format!("expected a string, found {other}")));
                }
            };
            Ok(SpectrumDesc::Csv { path: ctx.base_dir.join(file), column })
        }
        Value::Object(obj) if obj.contains_key("samples") => {
            only_keys(ctx, context, obj, &["samples"])?;
            let c = format!("{context}.samples");
            let rows = obj["samples"].as_array().ok_or_else(|| ctx.err(&c, "expected [[nm, value], …]"))?;
            let mut lambda = Vec::with_capacity(rows.len());
            let mut values = Vec::with_capacity(rows.len());
            for row in rows {
                let [l, x] = numbers::<2>(ctx, &c, row)?;
                if let Some(prev) = lambda.last()
                    && l <= *prev
                {
                    return Err(ctx.err(&c, format!("wavelength {l} nm after {prev} nm (must increase)")));
                }
                lambda.push(l);
                values.push(x);
            }
            if lambda.len() < 2 {
                return Err(ctx.err(&c, "needs at least 2 samples"));
            }
            Ok(SpectrumDesc::Samples { lambda, values })
        }
        _ => Err(ctx.err(context, format!("expected {FORMS}, found {v}"))),
    }
}

fn ior(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<IorDesc> {
    let obj = match v {
        Value::Number(_) => {
            let n = number(ctx, context, v)?;
            if n < 0.0 {
                return Err(ctx.err(context, format!("{n} must be ≥ 0 (0 is glTF's Fresnel ≡ 1 mode)")));
            }
            return Ok(IorDesc::Constant(n));
        }
        Value::Object(obj) if obj.len() == 1 => obj,
        _ => {
            return Err(ctx.err(
                context,
                format!(
                    "expected a number, {{\"cauchy\": {{\"a\", \"b\"}}}}, {{\"sellmeier\": {{\"b\": [3], \"c\": [3]}}}} or {{\"abbe\": {{\"nd\", \"vd\"}}}}, found {v}"
                ),
            ));
        }
    };
    let (kind, body) = obj.iter().next().ok_or_else(|| ctx.err(context, "empty object"))?;
    let c = format!("{context}.{kind}");
    let body = body.as_object().ok_or_else(|| ctx.err(&c, "expected an object"))?;
    let field = |key: &str| -> Result<&Value> { body.get(key).ok_or_else(|| ctx.err(&c, format!("missing `{key}`"))) };
    match kind.as_str() {
        "cauchy" => {
            only_keys(ctx, &c, body, &["a", "b"])?;
            Ok(IorDesc::Cauchy { a: number(ctx, &c, field("a")?)?, b: number(ctx, &c, field("b")?)? })
        }
        "sellmeier" => {
            only_keys(ctx, &c, body, &["b", "c"])?;
            Ok(IorDesc::Sellmeier { b: numbers::<3>(ctx, &c, field("b")?)?, c: numbers::<3>(ctx, &c, field("c")?)? })
        }
        "abbe" => {
            only_keys(ctx, &c, body, &["nd", "vd"])?;
            let nd = number(ctx, &c, field("nd")?)?;
            let vd = number(ctx, &c, field("vd")?)?;
            if vd <= 0.0 || nd < 1.0 {
                return Err(ctx.err(&c, format!("nd = {nd} must be ≥ 1 and vd = {vd} > 0")));
            }
            Ok(IorDesc::Abbe { nd, vd })
        }
        other => Err(ctx.err(context, format!("unknown IOR form `{other}` (expected cauchy, sellmeier, abbe)"))),
    }
}

fn absorption(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<AbsorptionDesc> {
    let obj = v.as_object().ok_or_else(|| {
        ctx.err(
            context,
            format!("expected {{\"per_unit\": spectrum}}, {{\"sigma_a\": spectrum}} or {{\"attenuation_color\": [r, g, b], \"attenuation_distance\": d}}, found {v}"),
        )
    })?;
    if let Some(s) = obj.get("per_unit") {
        only_keys(ctx, context, obj, &["per_unit"])?;
        return Ok(AbsorptionDesc::PerUnit(spectrum(ctx, &format!("{context}.per_unit"), s)?));
    }
    if let Some(s) = obj.get("sigma_a") {
        only_keys(ctx, context, obj, &["sigma_a"])?;
        return Ok(AbsorptionDesc::SigmaA(spectrum(ctx, &format!("{context}.sigma_a"), s)?));
    }
    only_keys(ctx, context, obj, &["attenuation_color", "attenuation_distance"])?;
    let color = obj.get("attenuation_color").ok_or_else(|| ctx.err(context, "missing `attenuation_color`"))?;
    let color = numbers::<3>(ctx, &format!("{context}.attenuation_color"), color)?;
    let distance = obj.get("attenuation_distance").ok_or_else(|| ctx.err(context, "missing `attenuation_distance`"))?;
    let distance = number(ctx, &format!("{context}.attenuation_distance"), distance)?;
    if distance <= 0.0 {
        return Err(ctx.err(format!("{context}.attenuation_distance"), format!("{distance} must be > 0")));
    }
    Ok(AbsorptionDesc::Attenuation { color, distance })
}

fn material(ctx: &Ctx<'_>, name: &str, value: &Value, warnings: &mut Vec<String>) -> Result<MaterialDesc> {
    let context = format!("materials.{name}");
    let m: MaterialJson = serde_json::from_value(value.clone()).map_err(|e| ctx.err(&context, e.to_string()))?;
    let mut out = MaterialDesc::named(name);
    let unit_interval = |key: &str, v: Option<f32>, default: f32| -> Result<f32> {
        match v {
            None => Ok(default),
            Some(x) => ctx.in_range(&format!("{context}.{key}"), x, 0.0, 1.0),
        }
    };
    let non_negative = |key: &str, v: Option<f32>, default: f32| -> Result<f32> {
        match v {
            None => Ok(default),
            Some(x) => ctx.in_range(&format!("{context}.{key}"), x, 0.0, f32::MAX),
        }
    };
    if let Some(model) = &m.model
        && !KNOWN_MODELS.contains(&model.as_str())
    {
        return Err(ctx.err(
            format!("{context}.model"),
            format!("unknown model `{model}` (expected {})", KNOWN_MODELS.join(", ")),
        ));
    }
    out.model = m.model;
    if let Some(v) = &m.base_color {
        out.base_color = spectrum(ctx, &format!("{context}.base_color"), v)?;
    }
    out.diffuse = non_negative("diffuse", m.diffuse, out.diffuse)?;
    out.specular = m.specular.as_ref().map(|v| spectrum(ctx, &format!("{context}.specular"), v)).transpose()?;
    out.ks = non_negative("ks", m.ks, 0.0)?;
    out.metallic = unit_interval("metallic", m.metallic, 0.0)?;
    out.roughness = unit_interval("roughness", m.roughness, out.roughness)?;
    out.shininess = non_negative("shininess", m.shininess, shininess_from_roughness(out.roughness))?;
    out.transmission = non_negative("transmission", m.transmission, 0.0)?;
    out.transmittance =
        m.transmittance.as_ref().map(|v| spectrum(ctx, &format!("{context}.transmittance"), v)).transpose()?;
    if let Some(v) = &m.ior {
        out.ior = ior(ctx, &format!("{context}.ior"), v)?;
    }
    out.dispersion = non_negative("dispersion", m.dispersion, 0.0)?;
    out.absorption = m.absorption.as_ref().map(|v| absorption(ctx, &format!("{context}.absorption"), v)).transpose()?;
    out.thickness = non_negative("thickness", m.thickness, 0.0)?;
    out.emission = m.emission.as_ref().map(|v| spectrum(ctx, &format!("{context}.emission"), v)).transpose()?;
    out.emission_strength = non_negative("emission_strength", m.emission_strength, 1.0)?;
    out.double_sided = m.double_sided.unwrap_or(false);
    if !m.extras.is_empty() {
        let keys: Vec<&str> = m.extras.keys().map(String::as_str).collect();
        warnings.push(format!(
            "{}: {context}: unknown key(s) {} kept in extras for the layers above",
            ctx.origin,
            keys.join(", ")
        ));
        out.extras = Some(Value::Object(m.extras));
    }
    Ok(out)
}

fn quad(ctx: &Ctx<'_>, context: &str, corner: Vec3, u: Vec3, v: Vec3, material: Option<u32>) -> Result<Mesh> {
    if u.cross(v).length_squared() == 0.0 {
        return Err(ctx.err(context, "the quad's edges are parallel or zero (zero area)"));
    }
    let positions = vec![corner, corner + u, corner + u + v, corner + v];
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

/// Loads a glTF/OBJ file referenced from a manifest into `desc`, transformed by `matrix`.
fn include_file(
    ctx: &Ctx<'_>,
    context: &str,
    path: &Path,
    matrix: Mat4,
    material_override: Option<u32>,
    desc: &mut SceneDescription,
) -> Result<()> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    let sub = match extension.as_str() {
        "gltf" | "glb" => crate::gltf_loader::load_gltf_file(path)?,
        "obj" => crate::obj_loader::load_obj_file(path)?,
        _ => {
            return Err(ctx.err(
                format!("{context}.file"),
                format!("{}: meshes must be .gltf, .glb or .obj files", path.display()),
            ));
        }
    };
    // Material counts are tiny compared with u32::MAX.
    let offset = desc.materials.len() as u32;
    // A mirroring transform turns outward faces inward; reversing the winding keeps geometric normals
    // outward (as glTF 2.0 §3.7.4 requires for node transforms), which refraction relies on.
    // `Mesh::transformed` keeps the winding as it is.
    let mirrored = matrix.determinant() < 0.0;
    let use_file_materials = material_override.is_none();
    for mut mesh in sub.meshes {
        let m = if use_file_materials { mesh.material().map(|i| i + offset) } else { material_override };
        mesh.set_material(m);
        let mesh = if matrix == Mat4::IDENTITY { mesh } else { mesh.transformed(matrix) };
        desc.meshes.push(if mirrored { reverse_winding(ctx, context, &mesh)? } else { mesh });
    }
    if use_file_materials {
        desc.materials.extend(sub.materials);
    }
    for light in sub.lights {
        desc.lights.push(transform_light(light, matrix));
    }
    if sub.camera.is_some() {
        desc.warnings.push(format!("{}: the file's camera is ignored (the manifest's is used)", path.display()));
    }
    desc.warnings.extend(sub.warnings);
    Ok(())
}

fn reverse_winding(ctx: &Ctx<'_>, context: &str, mesh: &Mesh) -> Result<Mesh> {
    let indices = mesh.indices().iter().map(|[a, b, c]| [*a, *c, *b]).collect();
    Mesh::new(
        mesh.positions().to_vec(),
        mesh.normals().map(<[Vec3]>::to_vec),
        mesh.uvs().map(<[glam::Vec2]>::to_vec),
        indices,
        mesh.material(),
    )
    .map_err(|e| ctx.err(context, e.to_string()))
}

fn transform_light(light: LightDesc, m: Mat4) -> LightDesc {
    let dir = |d: Vec3| m.transform_vector3(d).try_normalize().unwrap_or(d);
    match light {
        LightDesc::Point { position, spectrum, intensity } => {
            LightDesc::Point { position: m.transform_point3(position), spectrum, intensity }
        }
        LightDesc::Spot { position, direction, inner_cone_deg, outer_cone_deg, spectrum, intensity } => {
            LightDesc::Spot {
                position: m.transform_point3(position),
                direction: dir(direction),
                inner_cone_deg,
                outer_cone_deg,
                spectrum,
                intensity,
            }
        }
        LightDesc::Directional { direction, spectrum, intensity } => {
            LightDesc::Directional { direction: dir(direction), spectrum, intensity }
        }
        env @ LightDesc::Environment { .. } => env,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<SceneDescription> {
        parse_manifest(text, Path::new("/scenes"), "test.json")
    }

    #[test]
    fn spectrum_forms_parse() {
        let ctx = Ctx { origin: "t", base_dir: Path::new("/base") };
        let s = |t: &str| spectrum(&ctx, "x", &serde_json::from_str(t).unwrap_or(Value::Null));
        assert_eq!(s("0.9").ok(), Some(SpectrumDesc::Constant(0.9)));
        assert_eq!(s("\"colorchecker:13\"").ok(), Some(SpectrumDesc::Named("colorchecker:13".into())));
        assert_eq!(s("{\"rgb\":[1,0.5,0]}").ok(), Some(SpectrumDesc::Rgb([1.0, 0.5, 0.0])));
        assert_eq!(
            s("{\"csv\":\"a.csv\",\"column\":\"r\"}").ok(),
            Some(SpectrumDesc::Csv { path: "/base/a.csv".into(), column: Some("r".into()) })
        );
        assert_eq!(
            s("{\"samples\":[[400,0.1],[700,0.9]]}").ok(),
            Some(SpectrumDesc::Samples { lambda: vec![400.0, 700.0], values: vec![0.1, 0.9] })
        );
        assert!(s("{\"samples\":[[500,0.1],[400,0.9]]}").is_err());
        assert!(s("[1,2,3]").is_err());
        assert!(s("{\"rgb\":[1,2,3],\"x\":1}").is_err());
    }

    #[test]
    fn ior_and_absorption_forms_parse() {
        let ctx = Ctx { origin: "t", base_dir: Path::new("/") };
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
        let ctx = Ctx { origin: "t", base_dir: Path::new("/") };
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
        let ctx = Ctx { origin: "t", base_dir: Path::new("/") };
        let t: TransformJson = serde_json::from_str(r#"{"matrix":[[1,0,0,5],[0,1,0,6],[0,0,1,7],[0,0,0,1]]}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        let m = transform_matrix(&ctx, "t", t).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.transform_point3(Vec3::ZERO), Vec3::new(5.0, 6.0, 7.0));
    }

    #[test]
    fn plane_faces_its_normal() {
        let d = parse(r#"{"objects":[{"type":"plane","point":[0,0,0],"normal":[0,1,0],"size":2}]}"#)
            .unwrap_or_else(|e| panic!("{e}"));
        let m = &d.meshes[0];
        let [a, b, c] = m.indices()[0];
        let p = m.positions();
        let n = (p[b as usize] - p[a as usize]).cross(p[c as usize] - p[a as usize]).normalize();
        assert!((n - Vec3::Y).length() < 1e-6, "{n}");
        assert!((p[2] - p[0]).length() - 2.0 * 2f32.sqrt() < 1e-5);
    }

    #[test]
    fn mirrored_mesh_keeps_outward_winding() {
        let dir = std::env::temp_dir().join("spectrace-geometry-manifest-mirror");
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap_or_else(|e| panic!("{e}"));
        let text = r#"{"objects":[{"type":"mesh","file":"t.obj","transform":{"scale":[1,1,-1]}}]}"#;
        let d = parse_manifest(text, &dir, "m.json").unwrap_or_else(|e| panic!("{e}"));
        let p = d.meshes[0].positions();
        let [a, b, c] = d.meshes[0].indices()[0];
        // The +z-facing triangle, mirrored in z, faces −z.
        assert!((p[b as usize] - p[a as usize]).cross(p[c as usize] - p[a as usize]).z < 0.0);
    }

    #[test]
    fn unknown_material_key_goes_to_extras_with_a_warning() {
        let d = parse(r#"{"materials":{"m":{"ks":0.1,"spectral_override":"x"}}}"#).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.materials[0].extras, Some(serde_json::json!({"spectral_override":"x"})));
        assert!(d.warnings.iter().any(|w| w.contains("spectral_override")));
    }
}
