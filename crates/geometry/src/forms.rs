//! The value forms a scene file writes the same way wherever they appear: spectra, indices of refraction and
//! absorption (`docs/scene-format.md`, "Spectra"). Used by the manifest and by glTF `extras` overrides; each
//! conversion carries a context path such as `materials.glass.ior`, so every error says where it is.

use std::path::Path;

use glam::Vec3;
use serde_json::{Map, Value};

use crate::desc::{AbsorptionDesc, IorDesc, SpectrumDesc};
use crate::error::{Error, Result};
use crate::limits::{Budget, MAX_SPECTRUM_FILE_BYTES};

/// Context for converting values: where the manifest came from, for error messages and relative paths.
pub(crate) struct Ctx<'a> {
    /// The file's path or name, for messages.
    pub(crate) origin: &'a str,
    /// Folder that relative file references resolve against.
    pub(crate) base_dir: &'a Path,
    /// The scene's budget and file rules.
    pub(crate) budget: &'a Budget,
}

impl Ctx<'_> {
    pub(crate) fn err(&self, context: impl Into<String>, message: impl Into<String>) -> Error {
        Error::ManifestValue { origin: self.origin.to_owned(), context: context.into(), message: message.into() }
    }

    pub(crate) fn finite(&self, context: &str, v: f32) -> Result<f32> {
        if v.is_finite() { Ok(v) } else { Err(self.err(context, format!("{v} is not finite"))) }
    }

    pub(crate) fn in_range(&self, context: &str, v: f32, lo: f32, hi: f32) -> Result<f32> {
        if (lo..=hi).contains(&v) { Ok(v) } else { Err(self.err(context, format!("{v} is outside [{lo}, {hi}]"))) }
    }

    pub(crate) fn vec3(&self, context: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = Vec3::from_array(v);
        if v.is_finite() { Ok(v) } else { Err(self.err(context, format!("{v} is not finite"))) }
    }

    pub(crate) fn unit(&self, context: &str, v: [f32; 3]) -> Result<Vec3> {
        let v = self.vec3(context, v)?;
        v.try_normalize().ok_or_else(|| self.err(context, "direction has zero length"))
    }
}

pub(crate) fn number(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<f32> {
    let x = v.as_f64().ok_or_else(|| ctx.err(context, format!("expected a number, found {v}")))? as f32;
    ctx.finite(context, x)
}

pub(crate) fn numbers<const N: usize>(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<[f32; N]> {
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
pub(crate) fn only_keys(ctx: &Ctx<'_>, context: &str, obj: &Map<String, Value>, allowed: &[&str]) -> Result<()> {
    match obj.keys().find(|k| !allowed.contains(&k.as_str())) {
        Some(k) => Err(ctx.err(context, format!("unknown key `{k}` (expected {})", allowed.join(", ")))),
        None => Ok(()),
    }
}

/// The error for `key`, not one of the `known` keys of the object at `context`: it lists them, and names the
/// nearest when it is within two edits (a typo such as `max_dpeth` or `base_colour`), so a misspelt key is
/// refused with its fix instead of being ignored.
pub(crate) fn unknown_key(ctx: &Ctx<'_>, context: &str, key: &str, known: &[&str]) -> Error {
    let nearest = known.iter().map(|k| (edit_distance(key, k), *k)).filter(|(d, _)| *d <= 2).min_by_key(|(d, _)| *d);
    let hint = nearest.map(|(_, k)| format!("; did you mean `{k}`?")).unwrap_or_default();
    ctx.err(format!("{context}.{key}"), format!("unknown key{hint} (known keys: {})", known.join(", ")))
}

/// Edits (insert, delete or replace a character, or swap two neighbours) that turn `a` into `b`: the
/// optimal string alignment distance, so a swapped pair (`dpeth`) counts as one typo.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    // Three rows of the table: i − 2, i − 1 and i characters of `a` against every prefix of `b`.
    let mut before: Vec<usize> = Vec::new();
    let mut previous: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut current = vec![i; b.len() + 1];
        for j in 1..=b.len() {
            let replace = previous[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            current[j] = replace.min(previous[j] + 1).min(current[j - 1] + 1);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                current[j] = current[j].min(before[j - 2] + 1);
            }
        }
        before = std::mem::replace(&mut previous, current);
    }
    previous[b.len()]
}

/// `number | "name" | {"rgb":[r,g,b]} | {"csv":"file","column":"c"} | {"samples":[[λ,v],…]} | {"name":"n"}`;
/// the `name`, `csv` and `samples` objects may add `"normalize": false` (an absolute emission
/// spectrum, [`SpectrumDesc::Absolute`]; `true` is the default).
pub(crate) fn spectrum(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<SpectrumDesc> {
    const FORMS: &str = "a number, a name (\"D65\", \"colorchecker:13\"), {\"rgb\": [r, g, b]}, \
                         {\"csv\": \"file\", \"column\": \"name\"}, {\"samples\": [[nm, value], …]} or \
                         {\"name\": \"D65\"} (the last three may add \"normalize\": false)";
    if let Value::Object(obj) = v
        && let Some(flag) = obj.get("normalize")
    {
        let c = format!("{context}.normalize");
        let normalize = flag.as_bool().ok_or_else(|| ctx.err(&c, format!("expected true or false, found {flag}")))?;
        if !["name", "csv", "samples"].iter().any(|k| obj.contains_key(*k)) {
            return Err(ctx.err(&c, "only a {\"name\"}, {\"csv\"} or {\"samples\"} spectrum is normalised"));
        }
        let mut rest = obj.clone();
        rest.remove("normalize");
        let inner = spectrum(ctx, context, &Value::Object(rest))?;
        return Ok(if normalize { inner } else { SpectrumDesc::Absolute(Box::new(inner)) });
    }
    match v {
        Value::Object(obj) if obj.contains_key("name") => {
            only_keys(ctx, context, obj, &["name"])?;
            match obj["name"].as_str().map(str::trim).filter(|s| !s.is_empty()) {
                Some(name) => Ok(SpectrumDesc::Named(name.to_owned())),
                None => Err(ctx.err(format!("{context}.name"), format!("expected a name, found {}", obj["name"]))),
            }
        }
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
            // The CSV is parsed by the layers above; here it must pass the file rules (regular file, relative
            // path, at most MAX_SPECTRUM_FILE_BYTES), so no parser is ever handed `/dev/zero`.
            let referrer = Path::new(ctx.origin);
            let path = ctx.budget.resolve(referrer, ctx.base_dir, file)?;
            ctx.budget.check_file(referrer, &path, MAX_SPECTRUM_FILE_BYTES)?;
            Ok(SpectrumDesc::Csv { path, column })
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
                // Below f32's smallest normal a value is zero, as in every spectrum the renderer builds
                // (colorimetry's `MIN_SPECTRUM_VALUE`): an f32 subnormal divided into overflows.
                values.push(if x.abs() < f32::MIN_POSITIVE { 0.0 } else { x });
            }
            if lambda.len() < 2 {
                return Err(ctx.err(&c, "needs at least 2 samples"));
            }
            Ok(SpectrumDesc::Samples { lambda, values })
        }
        _ => Err(ctx.err(context, format!("expected {FORMS}, found {v}"))),
    }
}

pub(crate) fn ior(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<IorDesc> {
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

pub(crate) fn absorption(ctx: &Ctx<'_>, context: &str, v: &Value) -> Result<AbsorptionDesc> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_counts_a_swapped_pair_as_one_edit() {
        assert_eq!(edit_distance("max_depth", "max_depth"), 0);
        assert_eq!(edit_distance("max_dpeth", "max_depth"), 1);
        assert_eq!(edit_distance("base_colour", "base_color"), 1);
        assert_eq!(edit_distance("maxdepth", "max_depth"), 1);
        assert_eq!(edit_distance("depth", "max_depth"), 4);
        assert_eq!(edit_distance("", "ks"), 2);
        assert_eq!(edit_distance("ks", ""), 2);
        assert_eq!(edit_distance("ïor", "ior"), 1);
    }
}
