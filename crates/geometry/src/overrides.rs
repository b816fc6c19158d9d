//! Scene-parameter overrides for sweeps and animation: `--set PATH=VALUE` and a manifest's `frames`
//! (docs/scene-format.md, "Overrides and frames").
//!
//! Both change the manifest's JSON document before it is read, so every value passes the same checks as
//! one written in the file, and a job array can vary a scene without writing a file per task. A path is
//! the dotted form the manifest's errors already use (`materials.glass.ior`, `lights.0.intensity`):
//! object keys, and array indices from 0.

use std::str::FromStr;

use serde_json::{Map, Value};

/// One `PATH=VALUE` assignment.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Override {
    /// The path's segments: object keys or array indices.
    path: Vec<String>,
    /// The value: the text after `=` read as JSON, or as a JSON string when it is not JSON (so
    /// `--set materials.glass.spectrum=colorchecker:3` needs no quotes).
    value: Value,
}

impl Override {
    /// The assignment of `value` at `path` (dotted).
    ///
    /// # Errors
    /// The reason, when the path is empty or has an empty segment.
    pub fn new(path: &str, value: Value) -> Result<Self, String> {
        let segments: Vec<String> = path.split('.').map(str::to_owned).collect();
        if segments.iter().any(String::is_empty) {
            return Err(format!("`{path}`: expected a dotted path such as materials.glass.ior"));
        }
        Ok(Self { path: segments, value })
    }

    /// The dotted path.
    pub fn path(&self) -> String {
        self.path.join(".")
    }

    /// Sets the value in `doc`. Missing object keys on the way are created as empty objects, so
    /// `settings.max_depth` works in a manifest without `settings`; array indices must exist. The
    /// manifest's own checks then refuse a key it does not know.
    ///
    /// # Errors
    /// What stands in the way, naming the path up to it.
    pub(crate) fn apply(&self, doc: &mut Value) -> Result<(), String> {
        let mut here = doc;
        for (depth, segment) in self.path.iter().enumerate() {
            let last = depth + 1 == self.path.len();
            let at = || self.path[..=depth].join(".");
            here = match here {
                Value::Object(map) => {
                    if last {
                        map.insert(segment.clone(), self.value.clone());
                        return Ok(());
                    }
                    map.entry(segment.clone()).or_insert_with(|| Value::Object(Map::new()))
                }
                Value::Array(items) => {
                    let len = items.len();
                    let slot = segment.parse::<usize>().ok().and_then(|i| items.get_mut(i)).ok_or_else(|| {
                        format!("`{}`: `{}` has {len} entries (indices 0..{len})", at(), self.path[..depth].join("."))
                    })?;
                    if last {
                        *slot = self.value.clone();
                        return Ok(());
                    }
                    slot
                }
                other => {
                    let kind = match other {
                        Value::Null => "null",
                        Value::Bool(_) => "a boolean",
                        Value::Number(_) => "a number",
                        _ => "a string",
                    };
                    return Err(format!(
                        "`{}`: `{}` is {kind}, not an object or array",
                        at(),
                        self.path[..depth].join(".")
                    ));
                }
            };
        }
        Ok(())
    }
}

impl FromStr for Override {
    type Err = String;

    /// `PATH=VALUE`.
    fn from_str(s: &str) -> Result<Self, String> {
        let (path, text) = s
            .split_once('=')
            .ok_or_else(|| format!("expected PATH=VALUE (e.g. materials.glass.ior=1.5), got `{s}`"))?;
        let value = serde_json::from_str(text.trim()).unwrap_or_else(|_| Value::String(text.to_owned()));
        Self::new(path.trim(), value)
    }
}

impl std::fmt::Display for Override {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}={}", self.path(), self.value)
    }
}

/// What the command line asks to change in a manifest: one of its `frames` (0-based), then the `--set`
/// assignments in order (a later one wins, and `--set` wins over the frame).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Variation {
    /// `--frame K`.
    pub frame: Option<u32>,
    /// `--set PATH=VALUE`, in order.
    pub overrides: Vec<Override>,
}

impl Variation {
    /// Whether nothing is changed.
    pub fn is_empty(&self) -> bool {
        self.frame.is_none() && self.overrides.is_empty()
    }

    /// The bytes that make a varied scene's digest differ from the file's: the frame and each
    /// assignment, in order (docs/film-format.md: parts of different variations refuse to merge).
    pub(crate) fn digest_bytes(&self) -> Vec<u8> {
        let mut text = String::new();
        if let Some(k) = self.frame {
            text.push_str(&format!("--frame {k}\n"));
        }
        for o in &self.overrides {
            text.push_str(&format!("--set {o}\n"));
        }
        text.into_bytes()
    }

    /// Applies the variation to a manifest document. Every frame is checked (each must be an object of
    /// `PATH: VALUE` that applies to the document), so a typo in any frame fails the first task of a job
    /// array rather than one of the last. Errors are `(context, message)` for the manifest's value error.
    pub(crate) fn apply(&self, doc: &mut Value) -> Result<(), (String, String)> {
        let frames = match doc.get("frames") {
            None => Vec::new(),
            Some(Value::Array(frames)) => frames.clone(),
            Some(_) => return Err(("frames".to_owned(), "expected an array of objects of PATH: VALUE".to_owned())),
        };
        let mut chosen = Vec::new();
        for (i, frame) in frames.iter().enumerate() {
            let context = format!("frames[{i}]");
            let Value::Object(assignments) = frame else {
                return Err((
                    context,
                    "expected an object of PATH: VALUE (e.g. {\"camera.position\": [0, 1, 5]})".to_owned(),
                ));
            };
            let mut trial = doc.clone();
            let mut list = Vec::with_capacity(assignments.len());
            for (path, value) in assignments {
                let o = Override::new(path, value.clone()).map_err(|m| (context.clone(), m))?;
                if o.path.first().is_some_and(|s| s == "frames") {
                    return Err((context, format!("`{path}`: a frame cannot change the frames")));
                }
                o.apply(&mut trial).map_err(|m| (context.clone(), m))?;
                list.push(o);
            }
            if Some(i as u64) == self.frame.map(u64::from) {
                chosen = list;
            }
        }
        if let Some(k) = self.frame
            && k as usize >= frames.len()
        {
            return Err((
                "frames".to_owned(),
                format!("--frame {k}, but the manifest has {} frame(s) (0-based)", frames.len()),
            ));
        }
        for o in chosen.iter().chain(&self.overrides) {
            o.apply(doc).map_err(|m| (format!("--set {}", o.path()), m))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc() -> Value {
        serde_json::json!({
            "materials": {"glass": {"ior": 1.5}},
            "lights": [{"type": "point", "intensity": 1.0}],
            "frames": [{"camera.vfov_deg": 30}, {"camera.vfov_deg": 40, "materials.glass.ior": 1.7}]
        })
    }

    fn set(s: &str) -> Override {
        s.parse().unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn values_are_json_or_else_strings() {
        assert_eq!(set("a.b=1.5").value, serde_json::json!(1.5));
        assert_eq!(set("a=[1, 2, 3]").value, serde_json::json!([1, 2, 3]));
        assert_eq!(set("a=true").value, Value::Bool(true));
        assert_eq!(set("a=colorchecker:3").value, Value::String("colorchecker:3".to_owned()));
        assert_eq!(set("a=\"1.5\"").value, Value::String("1.5".to_owned()));
        assert!("a.b".parse::<Override>().is_err());
        assert!("a..b=1".parse::<Override>().is_err());
        assert!("=1".parse::<Override>().is_err());
    }

    #[test]
    fn keys_are_set_created_and_indices_must_exist() {
        let mut d = doc();
        set("materials.glass.ior=1.6").apply(&mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d["materials"]["glass"]["ior"], 1.6);
        set("lights.0.intensity=7").apply(&mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d["lights"][0]["intensity"], 7);
        set("settings.max_depth=5").apply(&mut d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d["settings"]["max_depth"], 5);
        let e = set("lights.1.intensity=7").apply(&mut d).unwrap_err();
        assert!(e.contains("`lights.1`") && e.contains("1 entries"), "{e}");
        let e = set("lights.x=7").apply(&mut d).unwrap_err();
        assert!(e.contains("`lights.x`"), "{e}");
        let e = set("materials.glass.ior.n=7").apply(&mut d).unwrap_err();
        assert!(e.contains("`materials.glass.ior` is a number"), "{e}");
    }

    #[test]
    fn a_frame_applies_then_set_wins() {
        let mut d = doc();
        let v = Variation { frame: Some(1), overrides: vec![set("materials.glass.ior=2")] };
        v.apply(&mut d).unwrap_or_else(|e| panic!("{e:?}"));
        assert_eq!(d["camera"]["vfov_deg"], 40);
        assert_eq!(d["materials"]["glass"]["ior"], 2);
        let mut d = doc();
        Variation { frame: Some(0), overrides: Vec::new() }.apply(&mut d).unwrap_or_else(|e| panic!("{e:?}"));
        assert_eq!(d["camera"]["vfov_deg"], 30);
        assert_eq!(d["materials"]["glass"]["ior"], 1.5);
    }

    #[test]
    fn frames_out_of_range_or_malformed_are_refused_naming_them() {
        let (context, message) = Variation { frame: Some(2), overrides: Vec::new() }.apply(&mut doc()).unwrap_err();
        assert_eq!(context, "frames");
        assert!(message.contains("has 2 frame(s)"), "{message}");
        // A bad path in a frame not chosen still fails.
        let mut d = doc();
        d["frames"][1] = serde_json::json!({"lights.3.intensity": 1});
        let (context, _) = Variation { frame: Some(0), overrides: Vec::new() }.apply(&mut d).unwrap_err();
        assert_eq!(context, "frames[1]");
        d["frames"][1] = serde_json::json!(3);
        assert_eq!(Variation::default().apply(&mut d).unwrap_err().0, "frames[1]");
    }

    #[test]
    fn digest_bytes_name_frame_and_assignments_in_order() {
        let v = Variation { frame: Some(3), overrides: vec![set("a=1"), set("b=x")] };
        assert_eq!(String::from_utf8(v.digest_bytes()).unwrap_or_default(), "--frame 3\n--set a=1\n--set b=\"x\"\n");
        let swapped = Variation { frame: Some(3), overrides: vec![set("b=x"), set("a=1")] };
        assert_ne!(v.digest_bytes(), swapped.digest_bytes());
    }
}
