//! Wavefront OBJ (+ MTL) → [`SceneDescription`], through `tobj`.
//!
//! `tobj` trusts its input in places: it panics on legal MTL lines such as `Kd 0.5` (one component, which
//! the MTL specification allows: g and b default to r), rejects `Kd spectral file.rfl`, and overflows on
//! face indices like `f 1/-99999999999999`. So both files are pre-scanned here, line by line, with
//! errors that name the file and line: OBJ vertex and face lines are checked, and the MTL text is rewritten
//! into a canonical form (`Kd 0.5` → `Kd 0.5 0.5 0.5`, spectral and `xyz` colours and `Tf` taken out and
//! kept aside, texture maps (`map_Kd`, `map_Ks`, `map_Ns`, `map_d`, `norm`, `map_Bump`/`bump`, `map_Ke` with `-s`/`-o`/`-clamp`) taken out and read
//! here) before `tobj` sees it.
//!
//! OBJ texture coordinates have v up from the image's bottom edge; meshes hold glTF's convention (v down from
//! the top edge), so v is flipped on load.

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};
use serde_json::{Map, Value};

use crate::desc::{
    ImageDesc, IorDesc, MaterialDesc, MaterialFormat, SceneDescription, SceneFormat, SpectrumDesc, TextureDesc,
    TextureTransform, WrapMode,
};
use crate::error::{Error, Result};
use crate::limits::{Budget, MAX_SPECTRUM_FILE_BYTES, check_coordinates, guard_panic, mesh_charge};
use crate::shapes::Mesh;

/// Loads an `.obj` file; `mtllib` files resolve against its folder. Everything it allocates is charged to
/// `budget` first.
pub(crate) fn load_obj_file(path: &Path, budget: &Budget) -> Result<SceneDescription> {
    let bytes = budget.read(path, path)?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    // `from_utf8` checks ASCII a word at a time; `from_utf8_lossy` (the same text where the file
    // is valid) a character at a time, 18 ms on a 60 MB file. Only invalid files need its copy.
    let text = std::str::from_utf8(&bytes).map_or_else(|_| String::from_utf8_lossy(&bytes), std::borrow::Cow::Borrowed);
    load_obj_text(&text, Some(base), path, budget)
}

/// Loads OBJ from memory. `base`: folder for `mtllib` (`None`: materials are not loaded, with a warning);
/// `path`: the name used in messages.
pub(crate) fn load_obj_text(text: &str, base: Option<&Path>, path: &Path, budget: &Budget) -> Result<SceneDescription> {
    let memory = budget.memory();
    match crate::obj_plain::parse(text, memory.limit.saturating_sub(memory.used)) {
        Some(plain) => load_plain(plain, base, path, budget),
        None => load_obj_checked(text, base, path, budget),
    }
}

/// A plain file ([`crate::obj_plain`]) as [`load_obj_checked`] loads it: the same charge, checks,
/// materials, objects and meshes.
fn load_plain(
    plain: crate::obj_plain::Plain,
    base: Option<&Path>,
    path: &Path,
    budget: &Budget,
) -> Result<SceneDescription> {
    use crate::obj_plain::Mark;
    let mut desc = SceneDescription::empty(SceneFormat::Obj);
    budget.charge(
        path,
        || format!("{} face corners and {} triangles", plain.corners, plain.triangles),
        mesh_charge(plain.corners, plain.triangles),
    )?;
    // The marked lines as tobj reads them: each `mtllib` file's materials appended to the list (a
    // file that fails adds none); `usemtl` naming one of those read so far, or none; an object
    // ended, where it has faces, by an `o`/`g` line, by a `usemtl` that changes the material, and
    // by the end of the file. Objects without faces give no mesh.
    let reads = MtlReads::default();
    let (mut materials, mut by_name) = (Vec::new(), HashMap::new());
    let mut objects: Vec<(std::ops::Range<usize>, String, Option<usize>)> = Vec::new();
    let (mut start, mut name, mut material_id) = (0, UNNAMED.to_owned(), None);
    guard_panic(path, "tobj", || {
        for (at, mark) in &plain.marks {
            match mark {
                Mark::Name(new_name) => {
                    if *at > start {
                        objects.push((start..*at, name.clone(), material_id));
                        start = *at;
                    }
                    name = if new_name.is_empty() { UNNAMED } else { new_name }.to_owned();
                }
                Mark::Library(file) => {
                    if let Ok((mut read, names)) = reads.load(Path::new(file), base, path, budget) {
                        let offset = materials.len();
                        materials.append(&mut read);
                        by_name.extend(names.into_iter().map(|(name, id)| (name, id + offset)));
                    }
                }
                Mark::Use(material) => {
                    let id = by_name.get(material).copied();
                    if id != material_id && *at > start {
                        objects.push((start..*at, name.clone(), material_id));
                        start = *at;
                    }
                    material_id = id;
                }
            }
        }
        Ok(())
    })?;
    let triangles = plain.triangles as usize;
    if triangles > start {
        objects.push((start..triangles, name, material_id));
    }
    add_materials(reads, materials, &mut desc, path, budget)?;
    let ranges: Vec<_> = objects.iter().map(|o| o.0.clone()).collect();
    for (object, (_, name, material_id)) in plain.into_objects(&ranges).into_iter().zip(objects) {
        let context = format!("object '{name}'");
        check_coordinates(&object.positions, path, &context)?;
        // The parse refused values that are not finite.
        let uvs = object.texcoords.map(|mut t| {
            t.iter_mut().for_each(|c| *c = mesh_uv(c.x, c.y));
            t
        });
        let material = material_index(material_id, &desc);
        let colors = object.colors.map(|c| c.into_iter().map(opaque).collect());
        let mesh = object_mesh(object.positions, object.normals, uvs, object.indices, material, colors);
        desc.meshes.push(mesh.map_err(|e| invalid_geometry(path, context, e))?);
    }
    Ok(desc)
}

/// Loads OBJ through tobj, behind the line-by-line pre-scan whose errors name the file and line.
fn load_obj_checked(text: &str, base: Option<&Path>, path: &Path, budget: &Budget) -> Result<SceneDescription> {
    let mut desc = SceneDescription::empty(SceneFormat::Obj);
    let counts = prescan_obj(text, path, &mut desc.warnings)?;
    // tobj's output before it is read: with `single_index` up to one vertex per face corner, and the
    // triangles of the fan triangulation; charged before tobj allocates them.
    budget.charge(
        path,
        || format!("{} face corners and {} triangles", counts.corners, counts.triangles),
        mesh_charge(counts.corners, counts.triangles),
    )?;

    let reads = MtlReads::default();
    let options = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, materials) = guard_panic(path, "tobj", || {
        tobj::load_obj_buf(&mut text.as_bytes(), &options, |mtl| reads.load(mtl, base, path, budget))
            .map_err(|cause| Error::Obj { path: path.to_path_buf(), cause })
    })?;
    // A missing MTL file was reported as a warning.
    add_materials(reads, materials.unwrap_or_default(), &mut desc, path, budget)?;

    for model in models {
        let mesh = &model.mesh;
        let context = format!("object '{}'", model.name);
        let positions: Vec<Vec3> = mesh.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        // The pre-scan rejected non-finite `v` lines; a `w` component can still overflow the division, which
        // the coordinate rule (non-finite or beyond the limit) catches with the vertex and its value.
        check_coordinates(&positions, path, &context)?;
        let indices: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        if indices.is_empty() {
            continue;
        }
        let normals: Vec<Vec3> = mesh.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        let normals = per_vertex(
            normals,
            positions.len(),
            |n: &Vec3| n.is_finite(),
            &mut desc.warnings,
            || format!("{}: {context}: normals missing on some faces or not finite; normals dropped", path.display()),
        );
        let uvs: Vec<Vec2> = mesh.texcoords.chunks_exact(2).map(|c| mesh_uv(c[0], c[1])).collect();
        let uvs = (uvs.len() == positions.len() && uvs.iter().all(|v| v.is_finite())).then_some(uvs);
        let material = material_index(mesh.material_id, &desc);
        let colors: Vec<Vec4> =
            mesh.vertex_color.chunks_exact(3).map(|c| opaque(Vec3::new(c[0], c[1], c[2]))).collect();
        let colors = per_vertex(
            colors,
            positions.len(),
            |c: &Vec4| c.is_finite(),
            &mut desc.warnings,
            || {
                format!(
                    "{}: {context}: vertex colours missing on some vertices or not finite; vertex colours dropped",
                    path.display()
                )
            },
        );
        let mesh = object_mesh(positions, normals, uvs, indices, material, colors);
        desc.meshes.push(mesh.map_err(|e| invalid_geometry(path, context, e))?);
    }
    Ok(desc)
}

/// What reading a file's `mtllib` files gathers: per-material data tobj does not keep (Tf, spectral
/// colours, texture maps), the first MTL error (the loader can only return tobj's error type), warnings,
/// and the files read. tobj calls [`MtlReads::load`] at each `mtllib` line; the plain path calls it for
/// each in order after its parse.
#[derive(Default)]
struct MtlReads {
    side: RefCell<HashMap<String, SideInfo>>,
    error: RefCell<Option<Error>>,
    warnings: RefCell<Vec<String>>,
    /// Each MTL file is read once, by resolved path, and the repeats are counted for one note: tobj
    /// appends a file's materials again at every `mtllib` naming it, so 1000 lines naming a
    /// 10 000-material file made 10⁷ materials.
    seen: RefCell<HashMap<PathBuf, usize>>,
}

impl MtlReads {
    /// Whether the file `key` was read before (and counts this reading).
    fn repeated(&self, key: PathBuf) -> bool {
        let mut seen = self.seen.borrow_mut();
        let count = seen.entry(key).or_insert(0);
        *count += 1;
        *count > 1
    }

    /// The materials of the `mtllib` file `mtl` of the OBJ file `path`, resolved against `base`.
    fn load(&self, mtl: &Path, base: Option<&Path>, path: &Path, budget: &Budget) -> tobj::MTLLoadResult {
        let Some(base) = base else {
            if self.repeated(mtl.to_path_buf()) {
                return Ok((Vec::new(), HashMap::new()));
            }
            self.warnings.borrow_mut().push(format!(
                "{}: mtllib {} not loaded (OBJ read from memory)",
                path.display(),
                mtl.display()
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        };
        let resolved = mtl
            .to_str()
            .ok_or_else(|| Error::ReadFile {
                path: mtl.to_path_buf(),
                cause: std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8"),
            })
            .and_then(|m| budget.resolve(path, base, m));
        if let Ok(mtl_path) = &resolved {
            // `sub/../a.mtl` and `a.mtl` are one file; a file that does not exist keeps its written path.
            let key = std::fs::canonicalize(mtl_path).unwrap_or_else(|_| mtl_path.clone());
            if self.repeated(key) {
                // Nothing to merge: the materials (or the warning) of the first `mtllib` stand.
                return Ok((Vec::new(), HashMap::new()));
            }
        }
        let read = resolved.and_then(|mtl_path| budget.read(path, &mtl_path).map(|b| (mtl_path, b)));
        let (mtl_path, text) = match read {
            Ok((mtl_path, bytes)) => (mtl_path, String::from_utf8_lossy(&bytes).into_owned()),
            // A missing MTL is a warning (the geometry still renders); a refused one (device, absolute
            // path, over budget) is an error.
            Err(
                e @ (Error::NotRegularFile { .. }
                | Error::AbsolutePath { .. }
                | Error::OverBudget { .. }
                | Error::FileTooLarge { .. }),
            ) => {
                self.error.borrow_mut().get_or_insert(e);
                return Err(tobj::LoadError::OpenFileFailed);
            }
            Err(e) => {
                self.warnings.borrow_mut().push(format!("{}: {e}; default materials used", path.display()));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        match sanitize_mtl(&text, &mtl_path, budget) {
            Ok((clean, info, warnings)) => {
                self.side.borrow_mut().extend(info);
                self.warnings.borrow_mut().extend(warnings);
                tobj::load_mtl_buf(&mut clean.as_bytes())
            }
            Err(e) => {
                self.error.borrow_mut().get_or_insert(e);
                Err(tobj::LoadError::MaterialParseError)
            }
        }
    }
}

/// The materials tobj read (in its order: ids index them) as descriptions, with their texture images,
/// and what reading them gathered; the first MTL error, if any, is the load's error.
fn add_materials(
    reads: MtlReads,
    materials: Vec<tobj::Material>,
    desc: &mut SceneDescription,
    path: &Path,
    budget: &Budget,
) -> Result<()> {
    if let Some(e) = reads.error.into_inner() {
        return Err(e);
    }
    desc.warnings.extend(reads.warnings.into_inner());
    let repeats: usize = reads.seen.into_inner().values().map(|n| n - 1).sum();
    if repeats > 0 {
        desc.warnings.push(format!(
            "{}: {repeats} `mtllib` line(s) name a material file already read; each file is read once",
            path.display()
        ));
    }
    let side = reads.side.into_inner();
    // Images by resolved path: each read once however many materials use it.
    let mut images: HashMap<PathBuf, usize> = HashMap::new();
    for m in &materials {
        let mut d = material(m, side.get(&m.name), path, &mut desc.warnings);
        for (key, file, mut texture) in side.get(&m.name).map(|s| s.textures.clone()).unwrap_or_default() {
            let image = match images.get(&file) {
                Some(&i) => i,
                None => match budget.read(path, &file) {
                    Ok(bytes) => {
                        desc.images.push(ImageDesc {
                            label: file.display().to_string(),
                            mime: None,
                            bytes: Arc::from(bytes),
                        });
                        images.insert(file.clone(), desc.images.len() - 1);
                        desc.images.len() - 1
                    }
                    Err(e @ (Error::OverBudget { .. } | Error::AbsolutePath { .. })) => return Err(e),
                    Err(e) => {
                        desc.warnings.push(format!("{}: material '{}': `{key}` not used: {e}", path.display(), m.name));
                        continue;
                    }
                },
            };
            texture.image = image;
            let slot = match key.as_str() {
                "map_Kd" => &mut d.textures.base_color,
                "map_d" => &mut d.textures.alpha,
                "norm" => &mut d.textures.normal,
                "map_Bump" | "map_bump" | "bump" => &mut d.textures.bump,
                "map_Ks" => &mut d.textures.specular_map,
                "map_Ns" => &mut d.textures.shininess,
                _ => &mut d.textures.emissive,
            };
            *slot = Some(texture);
        }
        desc.materials.push(d);
    }
    Ok(())
}

/// tobj's name of an object without one (no `o`/`g` line above it, or an empty one).
const UNNAMED: &str = "unnamed_object";

/// An object's mesh, either path's.
fn object_mesh(
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<[u32; 3]>,
    material: Option<u32>,
    colors: Option<Vec<Vec4>>,
) -> Result<Mesh> {
    let mesh = Mesh::new(positions, normals, uvs, indices, material)?;
    match colors {
        Some(c) => mesh.with_colors(c),
        None => Ok(mesh),
    }
}

/// An object's mesh refused (`context` names the object).
fn invalid_geometry(path: &Path, context: String, cause: Error) -> Error {
    Error::InvalidGeometry { path: path.to_path_buf(), context, cause: Box::new(cause) }
}

/// An OBJ vertex colour (`v x y z r g b`) as the meshes hold it: it multiplies `Kd` (and
/// `map_Kd`), read as linear RGB as glTF's COLOR_0 is (the format says nothing of its encoding),
/// opaque.
fn opaque(rgb: Vec3) -> Vec4 {
    rgb.extend(1.0)
}

/// An OBJ texture coordinate as the meshes hold it: v flipped, since OBJ's origin is the image's
/// bottom-left corner and the meshes' (glTF's) its top-left.
fn mesh_uv(u: f32, v: f32) -> Vec2 {
    Vec2::new(u, 1.0 - v)
}

/// A material id of tobj's (or the plain path's replay of it) as a mesh's material: ids index
/// the list read, which `desc` holds in order; ids past its end (a missing MTL) mean none.
fn material_index(id: Option<usize>, desc: &SceneDescription) -> Option<u32> {
    id.filter(|id| *id < desc.materials.len()).map(|id| id as u32)
}

fn syntax(path: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::ObjSyntax { path: path.to_path_buf(), line, message: message.into() }
}

/// What the pre-scan counted, for the budget.
#[derive(Debug, Default)]
struct Counts {
    /// Face corners (vertex references on `f` lines).
    corners: u64,
    /// Triangles after fan triangulation.
    triangles: u64,
}

/// OBJ statements the pre-scan knows are harmless for tobj (grouping, smoothing, materials, free-form
/// surfaces tobj ignores); any other first word is reported as not an OBJ statement.
const OTHER_STATEMENTS: &[&str] = &[
    "o",
    "g",
    "s",
    "mtllib",
    "usemtl",
    "vp",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "mg",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "maplib",
    "usemap",
];

/// Checks the OBJ lines tobj would mis-handle: vertex data (count and finiteness) and face indices (in range,
/// non-zero, relative ones resolved), so every error has a line number and tobj never sees an overflow.
fn prescan_obj(text: &str, path: &Path, warnings: &mut Vec<String>) -> Result<Counts> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    let mut lines_and_points = 0usize;
    let mut counts = Counts::default();
    let mut unknown: Option<(usize, usize)> = None;
    // Faces of one or two vertices: (count, first line).
    let mut short_faces: Option<(usize, usize)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let mut words = raw.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        match key {
            "v" | "vn" | "vt" => {
                let need = if key == "vt" { 1 } else { 3 };
                if rest.len() < need {
                    return Err(syntax(path, line_no, format!("`{key}` needs at least {need} numbers")));
                }
                let values: Vec<f32> = rest
                    .iter()
                    .take(if key == "v" { 7 } else { 3 })
                    .map(|w| w.parse::<f32>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| syntax(path, line_no, format!("`{key}`: not a number in `{}`", raw.trim())))?;
                if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                    if key == "v" {
                        let value = [values[0], values[1], values[2]];
                        return Err(Error::NonFiniteVertex {
                            path: path.to_path_buf(),
                            context: format!("line {line_no}"),
                            vertex: nv as usize,
                            value,
                        });
                    }
                    return Err(syntax(path, line_no, format!("`{key}`: {bad} is not finite")));
                }
                match key {
                    "v" => nv += 1,
                    "vt" => {
                        // A lone u is legal OBJ (v defaults to 0) but tobj rejects it without a line number.
                        if values.len() < 2 {
                            return Err(syntax(
                                path,
                                line_no,
                                "`vt` with one component is not supported; write `vt u 0`",
                            ));
                        }
                        nvt += 1;
                    }
                    _ => nvn += 1,
                }
            }
            "f" | "l" | "p" => {
                if key != "f" {
                    lines_and_points += 1;
                }
                if key == "p" {
                    continue; // tobj ignores `p` lines.
                }
                if key == "f" {
                    if rest.is_empty() {
                        // tobj refuses it without a line number ("invalid polygon").
                        return Err(syntax(path, line_no, "`f` without vertices"));
                    }
                    if rest.len() < 3 {
                        // tobj reads it as a point or a line and drops it.
                        let (count, _) = short_faces.get_or_insert((0, line_no));
                        *count += 1;
                    }
                    counts.corners += rest.len() as u64;
                    counts.triangles += rest.len().saturating_sub(2) as u64;
                }
                for token in &rest {
                    let parts: Vec<&str> = token.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(syntax(
                            path,
                            line_no,
                            format!("malformed vertex `{token}` (expected v, v/vt, v//vn or v/vt/vn)"),
                        ));
                    }
                    for (part, count, what) in parts
                        .iter()
                        .zip([nv, nvt, nvn])
                        .zip(["vertex", "texture coordinate", "normal"])
                        .map(|((p, c), w)| (p, c, w))
                    {
                        if part.is_empty() {
                            continue;
                        }
                        let index: i64 = part
                            .parse()
                            .map_err(|_| syntax(path, line_no, format!("`{part}` in `{token}` is not an integer")))?;
                        // OBJ indices are 1-based; negative ones count back from the last defined element.
                        let resolved = if index < 0 { count + index + 1 } else { index };
                        if index == 0 || resolved < 1 || resolved > count {
                            return Err(Error::IndexOutOfRange {
                                path: path.to_path_buf(),
                                context: format!("line {line_no}: {what} index {index} in `{token}`"),
                                index: index.unsigned_abs(),
                                vertex_count: count as usize,
                            });
                        }
                    }
                }
            }
            k if k.starts_with('#') || OTHER_STATEMENTS.contains(&k) => {}
            _ => {
                let (count, _) = unknown.get_or_insert((0, line_no));
                *count += 1;
            }
        }
    }
    if lines_and_points > 0 {
        warnings.push(format!(
            "{}: {lines_and_points} line/point element(s) skipped (only faces are rendered)",
            path.display()
        ));
    }
    if let Some((count, first)) = short_faces {
        warnings.push(format!(
            "{}: {count} face(s) with fewer than 3 vertices skipped (the first is line {first}); a face needs 3",
            path.display()
        ));
    }
    if let Some((count, first)) = unknown {
        warnings.push(format!(
            "{}: {count} line(s) are not OBJ statements (the first is line {first}); ignored",
            path.display()
        ));
    }
    Ok(counts)
}

/// Bytes charged per MTL material (`newmtl`): tobj's `Material` (312 B on a 64-bit target), the side info
/// (112 B), the description (1408 B) and three name-keyed map entries, 1.9 KB in all; the test
/// `material_charge_covers_its_records` checks the sum against it. Their heap parts (names, values) are
/// charged with the text.
const BYTES_PER_MATERIAL: u64 = 2048;

/// Bytes charged per other MTL statement: its sanitised line (a short number such as `1e-30` prints as
/// 32 digits, three times for `Kd`) and its entry in the side info or tobj's map.
const BYTES_PER_MTL_STATEMENT: u64 = 256;

/// What the MTL pre-scan keeps aside for one material.
#[derive(Default, Debug)]
struct SideInfo {
    /// `Tf r g b`.
    tf: Option<[f32; 3]>,
    /// Spectral colour references, by key (`Kd`, `Ks`, `Tf`, `Ke`).
    spectral: HashMap<String, SpectrumDesc>,
    /// Raw data for the layers above (spectral file references that are not CSV, `xyz` colours, `Tr`).
    extras: Map<String, Value>,
    /// Texture statements: the key (`map_Kd`, …), the resolved image file and how it is sampled
    /// (`TextureDesc::image` is filled when the image is read).
    textures: Vec<(String, PathBuf, TextureDesc)>,
}

/// A texture statement's options and file: `-s u v w` (scale), `-o u v w` (offset), `-clamp on|off`, `-bm
/// mult` (normal/bump strength); the others are skipped with their arguments and named in `ignored`. The
/// file name is the rest of the line (it may contain spaces).
fn texture_statement<'a>(
    args: &[&'a str],
    ignored: &mut Vec<&'a str>,
) -> std::result::Result<(String, TextureDesc), String> {
    // The image index is filled in when the image is read.
    let mut texture = TextureDesc::new(0);
    let mut transform = TextureTransform { offset: [0.0, 0.0], rotation: 0.0, scale: [1.0, 1.0] };
    let mut i = 0;
    // Option → number of numeric arguments it takes (up to), per the MTL specification.
    while i < args.len() && args[i].starts_with('-') && args[i].len() > 1 {
        let option = args[i];
        let numbers = |from: usize, max: usize| -> Vec<f32> {
            args[from..].iter().take(max).map_while(|w| w.parse::<f32>().ok().filter(|v| v.is_finite())).collect()
        };
        match option {
            "-s" | "-o" => {
                let v = numbers(i + 1, 3);
                if v.is_empty() {
                    return Err(format!("`{option}` needs numbers"));
                }
                let (u, w) = (v[0], v.get(1).copied().unwrap_or(if option == "-s" { 1.0 } else { 0.0 }));
                if option == "-s" {
                    transform.scale = [u, w];
                } else {
                    transform.offset = [u, w];
                }
                i += 1 + v.len();
            }
            "-clamp" => {
                let on = args.get(i + 1).is_some_and(|w| *w == "on");
                texture.wrap = [if on { WrapMode::ClampToEdge } else { WrapMode::Repeat }; 2];
                i += 2;
            }
            "-bm" => {
                let v = numbers(i + 1, 1);
                texture.scale = v.first().copied().ok_or("`-bm` needs a number")?;
                i += 2;
            }
            "-blendu" | "-blendv" | "-cc" | "-imfchan" | "-type" => {
                ignored.push(option);
                i += 2;
            }
            "-boost" | "-texres" => {
                ignored.push(option);
                i += 2;
            }
            "-mm" => {
                ignored.push(option);
                i += 3;
            }
            "-t" => {
                ignored.push(option);
                i += 1 + numbers(i + 1, 3).len();
            }
            _ => {
                return Err(format!("unknown texture option `{option}`"));
            }
        }
    }
    let file = args.get(i..).unwrap_or_default().join(" ");
    if file.is_empty() {
        return Err("no image file named".into());
    }
    if transform.scale != [1.0, 1.0] || transform.offset != [0.0, 0.0] {
        texture.transform = Some(transform);
    }
    Ok((file, texture))
}

/// Rewrites MTL text into lines tobj parses without panicking; returns the text, per-material side info and
/// warnings. Errors name the MTL file and line.
fn sanitize_mtl(text: &str, path: &Path, budget: &Budget) -> Result<(String, HashMap<String, SideInfo>, Vec<String>)> {
    // What the file becomes, charged before any of it is built: per material the records of tobj, of
    // the side info and of the description (with their map entries), per statement its sanitised line and
    // its entry, and the names and values, copied about four times on the way (sanitised text, tobj's
    // strings, side info, description). A 10 000-material file is charged ≈ 30 MB.
    let (mut materials, mut statements) = (0u64, 0u64);
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("newmtl") => materials += 1,
            Some(word) if !word.starts_with('#') => statements += 1,
            _ => {}
        }
    }
    budget.charge(
        path,
        || format!("{materials} materials and {statements} statements read into the loader's structures"),
        materials
            .saturating_mul(BYTES_PER_MATERIAL)
            .saturating_add(statements.saturating_mul(BYTES_PER_MTL_STATEMENT))
            .saturating_add((text.len() as u64).saturating_mul(4)),
    )?;
    let mut out = String::with_capacity(text.len());
    let mut side: HashMap<String, SideInfo> = HashMap::new();
    let mut warnings = Vec::new();
    let mut current: Option<String> = None;
    let folder = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let err = |line: usize, message: String| Error::ObjSyntax { path: path.to_path_buf(), line, message };
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let trimmed = strip_trailing_comment(raw.trim());
        let mut words = trimmed.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        if key.starts_with('#') {
            continue;
        }
        if key == "newmtl" {
            let name = trimmed["newmtl".len()..].trim();
            if name.is_empty() {
                return Err(err(line_no, "`newmtl` without a name".into()));
            }
            current = Some(name.to_owned());
            side.entry(name.to_owned()).or_default();
            out.push_str(&format!("newmtl {name}\n"));
            continue;
        }
        let Some(name) = current.clone() else {
            warnings.push(format!("{}:{line_no}: `{key}` before any `newmtl`; ignored", path.display()));
            continue;
        };
        let info = side.entry(name.clone()).or_default();
        match key {
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => match rest.first().copied() {
                Some("spectral") => {
                    let Some(file) = rest.get(1) else {
                        return Err(err(line_no, format!("`{key} spectral` without a file name")));
                    };
                    let file_path = budget.resolve(path, &folder, file)?;
                    let is_csv = Path::new(file).extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
                    if is_csv {
                        budget.check_file(path, &file_path, MAX_SPECTRUM_FILE_BYTES)?;
                        info.spectral.insert(key.to_owned(), SpectrumDesc::Csv { path: file_path, column: None });
                    } else {
                        warnings.push(format!(
                            "{}:{line_no}: material '{name}': `{key} spectral {file}` (.rfl) is not read; kept in extras as `{key}_spectral`",
                            path.display()
                        ));
                        info.extras.insert(format!("{key}_spectral"), Value::String(file_path.display().to_string()));
                    }
                }
                Some("xyz") => {
                    let values = parse_floats(&rest[1..]).map_err(|m| err(line_no, format!("`{key} xyz`: {m}")))?;
                    let xyz =
                        expand(&values).ok_or_else(|| err(line_no, format!("`{key} xyz` needs 1 or 3 numbers")))?;
                    warnings.push(format!(
                        "{}:{line_no}: material '{name}': CIE XYZ colour kept in extras as `{key}_xyz`",
                        path.display()
                    ));
                    info.extras.insert(format!("{key}_xyz"), serde_json::json!(xyz));
                }
                _ => {
                    let values = parse_floats(&rest).map_err(|m| err(line_no, format!("`{key}`: {m}")))?;
                    // MTL: "g and b are optional; if only r is given, g and b equal r".
                    let rgb = expand(&values)
                        .ok_or_else(|| err(line_no, format!("`{key}` needs 1 or 3 numbers, found {}", values.len())))?;
                    if key == "Tf" {
                        info.tf = Some(rgb);
                    } else {
                        out.push_str(&format!("{key} {} {} {}\n", rgb[0], rgb[1], rgb[2]));
                    }
                }
            },
            "Ns" | "Ni" | "d" | "Tr" => {
                // `d -halo 0.5` is legal; the halo option is not supported.
                let args: Vec<&str> = rest.iter().copied().filter(|w| *w != "-halo").collect();
                let values = parse_floats(&args).map_err(|m| err(line_no, format!("`{key}`: {m}")))?;
                let [v] = values[..] else {
                    return Err(err(line_no, format!("`{key}` needs one number")));
                };
                if key == "Tr" {
                    // Tr is transparency, 1 − d (a common exporter extension).
                    out.push_str(&format!("d {}\n", 1.0 - v));
                    info.extras.insert("Tr".into(), serde_json::json!(v));
                } else {
                    out.push_str(&format!("{key} {v}\n"));
                }
            }
            "illum" => match rest.first().and_then(|w| w.parse::<u8>().ok()) {
                Some(n) if n <= 10 => out.push_str(&format!("illum {n}\n")),
                _ => warnings.push(format!("{}:{line_no}: `illum` needs an integer 0–10; ignored", path.display())),
            },
            "map_Kd" | "map_d" | "norm" | "map_Ke" | "map_Bump" | "map_bump" | "bump" | "map_Ks" | "map_Ns" => {
                let mut ignored = Vec::new();
                // The statements supported most recently (bump, specular colour and exponent maps)
                // were warnings before: a bad one stays a warning, so no file that loaded fails now; the file
                // rules (a path outside the folder, the memory budget) stay errors, as for every image read.
                let lenient = matches!(key, "map_Bump" | "map_bump" | "bump" | "map_Ks" | "map_Ns");
                let statement = texture_statement(&rest, &mut ignored)
                    .map_err(|m| err(line_no, format!("`{key}`: {m}")))
                    .and_then(|(file, texture)| Ok((budget.resolve(path, &folder, &file)?, texture)));
                let (file, texture) = match statement {
                    Ok(statement) => statement,
                    Err(e) if lenient && !matches!(e, Error::OverBudget { .. } | Error::AbsolutePath { .. }) => {
                        warnings
                            .push(format!("{}:{line_no}: material '{name}': `{key}` not used: {e}", path.display()));
                        continue;
                    }
                    Err(e) => return Err(e),
                };
                if !ignored.is_empty() {
                    warnings.push(format!(
                        "{}:{line_no}: material '{name}': `{key}` options {ignored:?} ignored",
                        path.display()
                    ));
                }
                info.textures.push((key.to_owned(), file, texture));
            }
            k if k.starts_with("map_") || k == "disp" || k == "decal" || k == "refl" => {
                warnings.push(format!("{}:{line_no}: material '{name}': texture `{k}` ignored", path.display()));
            }
            other => {
                // Unknown statements go to extras as text; tobj never sees them.
                if other.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                    info.extras.insert(other.to_owned(), Value::String(rest.join(" ")));
                }
            }
        }
    }
    Ok((out, side, warnings))
}

/// A statement without a trailing comment: from a `#` that follows whitespace to the end of the line
/// (`Ka 0.63 0.065 0.05 # Red`, as McGuire's Cornell box writes). A `#` inside a word (a file name)
/// is kept.
fn strip_trailing_comment(line: &str) -> &str {
    match line.char_indices().find(|&(i, c)| c == '#' && line[..i].ends_with(char::is_whitespace)) {
        Some((i, _)) => line[..i].trim_end(),
        None => line,
    }
}

fn parse_floats(words: &[&str]) -> std::result::Result<Vec<f32>, String> {
    words
        .iter()
        .map(|w| match w.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("`{w}` is not a finite number")),
        })
        .collect()
}

fn expand(values: &[f32]) -> Option<[f32; 3]> {
    match *values {
        [v] => Some([v; 3]),
        [r, g, b] => Some([r, g, b]),
        _ => None,
    }
}

fn material(m: &tobj::Material, side: Option<&SideInfo>, path: &Path, warnings: &mut Vec<String>) -> MaterialDesc {
    // Each statement as written; what `illum`, `d` and `Ks` mean for shading is the assembly's decision.
    let mut d = MaterialDesc::new(m.name.clone(), MaterialFormat::Mtl);
    let spectral = |key: &str| side.and_then(|s| s.spectral.get(key).cloned());
    d.base_color = spectral("Kd").or(m.diffuse.map(SpectrumDesc::Rgb));
    d.specular = spectral("Ks").or(m.specular.map(SpectrumDesc::Rgb));
    d.shininess = m.shininess.filter(|n| n.is_finite());
    match m.optical_density {
        Some(ni) if ni.is_finite() && ni >= 0.0 => d.ior = Some(IorDesc::Constant(ni)),
        Some(ni) => warnings.push(format!(
            "{}: material '{}': Ni {ni} is not an index of refraction; the default is used",
            path.display(),
            m.name
        )),
        None => {}
    }
    let tf = side.and_then(|s| s.tf);
    d.transmittance = spectral("Tf").or(tf.map(SpectrumDesc::Rgb));
    d.dissolve = m.dissolve;
    d.illum = m.illumination_model;
    d.emission = spectral("Ke").or(m.emissive.map(SpectrumDesc::Rgb));
    let mut extras = side.map(|s| s.extras.clone()).unwrap_or_default();
    for (k, v) in &m.unknown_param {
        extras.entry(k.clone()).or_insert_with(|| Value::String(v.clone()));
    }
    if let Some(ka) = m.ambient {
        extras.insert("Ka".into(), serde_json::json!(ka));
    }
    d.extras = (!extras.is_empty()).then_some(Value::Object(extras));
    d
}

/// A per-vertex attribute as tobj gives it: `None` when the file has none; `values` when there is one per
/// position and all are finite; else dropped with the `warning` (the mesh still renders without it).
fn per_vertex<T>(
    values: Vec<T>,
    count: usize,
    finite: impl Fn(&T) -> bool,
    warnings: &mut Vec<String>,
    warning: impl FnOnce() -> String,
) -> Option<Vec<T>> {
    if values.is_empty() {
        None
    } else if values.len() == count && values.iter().all(finite) {
        Some(values)
    } else {
        warnings.push(warning());
        None
    }
}

/// For tests: the sanitised MTL text, without the side info.
#[cfg(test)]
pub(crate) fn sanitize_mtl_text(text: &str, path: &Path) -> Result<String> {
    sanitize_mtl(text, path, &Budget::allowing_absolute_paths()).map(|(t, _, _)| t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn material_charge_covers_its_records() {
        use std::mem::size_of;
        // A name-keyed map entry: the key, the value and about a word of table overhead.
        let entry = |value: usize| size_of::<String>() + value + 16;
        let records = size_of::<tobj::Material>()
            + entry(size_of::<usize>())
            + entry(size_of::<SideInfo>())
            + size_of::<MaterialDesc>();
        assert!(records as u64 <= BYTES_PER_MATERIAL, "{records} bytes per material");
    }

    /// One mesh as loaded: positions, triangles, normals, texture coordinates, material and
    /// vertex colours.
    type LoadedMesh = (Vec<Vec3>, Vec<[u32; 3]>, Option<Vec<Vec3>>, Option<Vec<Vec2>>, Option<u32>, Option<Vec<Vec4>>);

    /// What a load gives, for comparing the two paths: warnings, the meshes, the materials and
    /// the images' labels and sizes.
    type Loaded = (Vec<String>, Vec<LoadedMesh>, Vec<MaterialDesc>, Vec<(String, usize)>);

    fn loaded(desc: Result<SceneDescription>) -> std::result::Result<Loaded, String> {
        let desc = desc.map_err(|e| e.to_string())?;
        let meshes = desc
            .meshes
            .iter()
            .map(|m| {
                let (normals, uvs) = (m.normals().map(<[Vec3]>::to_vec), m.uvs().map(<[Vec2]>::to_vec));
                let colors = m.colors().map(<[Vec4]>::to_vec);
                (m.positions().to_vec(), m.indices().to_vec(), normals, uvs, m.material(), colors)
            })
            .collect();
        let images = desc.images.iter().map(|i| (i.label.clone(), i.bytes.len())).collect();
        Ok((desc.warnings, meshes, desc.materials, images))
    }

    /// The `v` lines of an (n + 1)² grid, `position(i, j)` at row j, column i, each ended by `eol`.
    fn vertex_grid(n: usize, eol: &str, position: impl Fn(usize, usize) -> [f32; 3]) -> String {
        let mut text = String::new();
        for j in 0..=n {
            for i in 0..=n {
                let [x, y, z] = position(i, j);
                text.push_str(&format!("v {x} {y} {z}{eol}"));
            }
        }
        text
    }

    #[test]
    fn plain_files_load_exactly_as_through_tobj() {
        let path = Path::new("t.obj");
        let budget = || Budget::allowing_absolute_paths();
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut texts: Vec<(String, String)> =
            ["scenes/reference/prism.obj", "scenes/meshes/icosphere.obj", "scenes/obj/cube_and_sphere.obj"]
                .iter()
                .map(|f| (f.to_string(), std::fs::read_to_string(root.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"))))
                .collect();
        // The normals and the object line taken out of the icosphere: plain, 5120 triangles.
        let plain_sphere: String = texts[1]
            .1
            .lines()
            .filter(|l| !l.starts_with("vn") && !l.starts_with("o "))
            .map(|l| {
                // `f a//na b//nb c//nc` → `f a b c`
                let words: Vec<&str> = l.split_whitespace().map(|w| w.split('/').next().unwrap_or(w)).collect();
                format!("{}\n", words.join(" "))
            })
            .collect();
        texts.push(("icosphere without normals".into(), plain_sphere.clone()));
        // The same with a colour on every `v` line.
        let mut k = 0;
        let coloured: String = plain_sphere
            .lines()
            .map(|l| {
                if !l.starts_with("v ") {
                    return format!("{l}\n");
                }
                k += 1;
                format!("{l} {} 0.5 {}\n", (k % 7) as f32 / 7.0, (k % 3) as f32 * 0.25)
            })
            .collect();
        texts.push(("coloured icosphere".into(), coloured));
        // A terrain of quads and a polygon, with CRLF line ends, a name and unused vertices; large
        // enough for several parallel chunks (~2.6 MB).
        let n = 300;
        let mut terrain = String::from("# terrain\r\no terrain\r\n");
        terrain.push_str(&vertex_grid(n, "\r\n", |i, j| [i as f32 / 7.0, ((i * j) % 13) as f32 * 0.1, j as f32 / 3.0]));
        terrain.push_str("v 1e6 1e6 1e6\r\ns 1\r\n");
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i + 1;
                terrain.push_str(&format!("f {} {} {} {}\r\n", a + n + 1, a, a + 1, a + n + 2));
            }
        }
        terrain.push_str("f 1 2 3 4 5 6 7\r\n");
        texts.push(("terrain".into(), terrain));
        // A terrain with texture coordinates and normals (~4 MB, several chunks), whose rows meet
        // at seams: every quad's corners share positions with its neighbours, but the even rows'
        // quads have texture coordinates and normals of their own, so a position comes with one
        // to four pairs. Then the same faces as `v//vn` and `v/vt`.
        let n = 200;
        let mut seams = String::from("o seams\n");
        seams.push_str(&vertex_grid(n, "\n", |i, j| [i as f32 / 9.0, ((i + 2 * j) % 7) as f32 * 0.1, j as f32 / 5.0]));
        seams.push_str("vt 0.25 0.75 0\n");
        for k in 0..4 * n * n {
            seams.push_str(&format!("vt {} {}\nvn {} 1 {}\n", k as f32 * 1e-4, 1.0 - k as f32 * 2e-4, k % 3, k % 5));
        }
        let corner = |a: usize, k: usize| format!("{a}/{k}/{k}");
        let mut both = seams.clone();
        let (mut normal_only, mut texcoord_only) = (seams.clone(), seams.clone());
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i + 1;
                let quad = [a + n + 1, a, a + 1, a + n + 2];
                let face = |f: &dyn Fn(usize, usize) -> String| {
                    let corners: Vec<String> = (0..4)
                        .map(|c| {
                            // Even rows: a pair of the quad's own per corner; odd rows: the position's.
                            let k = if j % 2 == 0 { 4 * (j * n + i) + 2 + c } else { quad[c] + 1 };
                            f(quad[c], k)
                        })
                        .collect();
                    format!("f {}\n", corners.join(" "))
                };
                both.push_str(&face(&corner));
                normal_only.push_str(&face(&|a, k| format!("{a}//{k}")));
                texcoord_only.push_str(&face(&|a, k| format!("{a}/{k}")));
            }
        }
        texts.push(("seams v/vt/vn".into(), both));
        texts.push(("seams v//vn".into(), normal_only));
        texts.push(("seams v/vt".into(), texcoord_only));
        let mut fast = 0;
        for (name, text) in &texts {
            let checked = loaded(load_obj_checked(text, None, path, &budget()));
            let either = loaded(load_obj_text(text, None, path, &budget()));
            assert_eq!(either, checked, "{name}");
            if crate::obj_plain::parse(text, u64::MAX).is_some() {
                fast += 1;
                let triangles: usize = checked.as_ref().map(|c| c.1.iter().map(|m| m.1.len()).sum()).unwrap_or(0);
                assert!(triangles > 0, "{name}");
            }
        }
        // All took the fast path.
        assert_eq!(fast, texts.len());
        // Errors: the fast path declines, and the checked path names the line.
        let e =
            load_obj_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", None, path, &budget()).err().map(|e| e.to_string());
        assert!(e.as_deref().is_some_and(|e| e.contains("line 4")), "{e:?}");
        let e = load_obj_text("v 0 0 0\nv 1 inf 0\n", None, path, &budget()).err().map(|e| e.to_string());
        assert!(e.as_deref().is_some_and(|e| e.contains("line 2")), "{e:?}");
        // Over budget: the same error either way.
        let small = || Budget::new(crate::LoadOptions { max_memory: 1000, ..Default::default() });
        let text = &texts[0].1;
        let a = load_obj_text(text, None, path, &small()).err().map(|e| e.to_string());
        let b = load_obj_checked(text, None, path, &small()).err().map(|e| e.to_string());
        assert!(a.is_some() && a == b, "{a:?} {b:?}");
    }

    /// The third-party OBJ files in `shared/real_assets` (read only, not in the repository; the
    /// test says so and passes where they are absent): each loads the same through either path.
    #[test]
    fn real_files_load_the_same_through_either_path() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/real_assets");
        let mut files = Vec::new();
        let mut dirs = vec![root.clone()];
        while let Some(dir) = dirs.pop() {
            for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
                let path = entry.path();
                if path.is_dir() {
                    dirs.push(path);
                } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj")) {
                    files.push(path);
                }
            }
        }
        if files.is_empty() {
            eprintln!("skipped: no OBJ files under {}", root.display());
            return;
        }
        let budget = || Budget::allowing_absolute_paths();
        let mut fast = Vec::new();
        for file in &files {
            let Ok(bytes) = std::fs::read(file) else { continue };
            let text = String::from_utf8_lossy(&bytes);
            let base = file.parent();
            let checked = loaded(load_obj_checked(&text, base, file, &budget()));
            assert_eq!(loaded(load_obj_text(&text, base, file, &budget())), checked, "{}", file.display());
            if crate::obj_plain::parse(&text, u64::MAX).is_some() {
                fast.push(file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
            }
        }
        eprintln!("{} OBJ files, the fast path read {fast:?}", files.len());
    }

    /// A folder of the temporary directory holding the repository scene's materials as
    /// `scene.mtl` (floor, red_paint, glass).
    fn folder_with_scene_mtl(name: &str) -> std::path::PathBuf {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let dir = std::env::temp_dir().join(name);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let mtl =
            std::fs::read_to_string(root.join("scenes/obj/cube_and_sphere.mtl")).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.join("scene.mtl"), mtl).unwrap_or_else(|e| panic!("{e}"));
        dir
    }

    #[test]
    fn material_lines_before_the_faces_load_as_through_tobj() {
        // Materials of the repository's scene; a texture map written next to them for the test.
        let dir = folder_with_scene_mtl("spectrace-geometry-obj-plain-materials");
        std::fs::write(dir.join("textured.mtl"), "newmtl tex\nKd 1 1 1\nmap_Kd checker.png\n")
            .unwrap_or_else(|e| panic!("{e}"));
        // Read here as bytes only (decoded by the renderer).
        std::fs::write(dir.join("checker.png"), [7u8; 64]).unwrap_or_else(|e| panic!("{e}"));
        let geometry = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
        let path = dir.join("t.obj");
        let budget = || Budget::allowing_absolute_paths();
        for head in [
            "mtllib scene.mtl\nusemtl red_paint\n",
            "mtllib scene.mtl\nusemtl glass\nusemtl floor\n", // the last one counts
            "usemtl floor\nmtllib scene.mtl\n",               // named before it is read: none
            "mtllib scene.mtl\nusemtl no_such_material\n",
            "mtllib missing.mtl\nusemtl floor\n", // a warning, default materials
            "mtllib scene.mtl\nmtllib textured.mtl\nusemtl tex\n", // ids offset by the first file's
            "mtllib scene.mtl\nmtllib ./scene.mtl\nusemtl glass\n", // a file read once, with a note
            "o  panel \nmtllib  scene.mtl \ns 1\nusemtl  red_paint\n",
        ] {
            let text = format!("{head}{geometry}");
            assert!(crate::obj_plain::parse(&text, u64::MAX).is_some(), "{head:?}");
            for base in [Some(dir.as_path()), None] {
                let checked = loaded(load_obj_checked(&text, base, &path, &budget()));
                assert!(checked.is_ok(), "{head:?}: {checked:?}");
                assert_eq!(loaded(load_obj_text(&text, base, &path, &budget())), checked, "{head:?}");
            }
        }
        // What the comparisons compared: the second material of the first file, and the fourth
        // (the second file's) with the texture's image.
        for (head, material, materials, images) in
            [("usemtl red_paint", 1, 3, 0), ("mtllib textured.mtl\nusemtl tex", 3, 4, 1)]
        {
            let text = format!("mtllib scene.mtl\n{head}\n{geometry}");
            let l = loaded(load_obj_text(&text, Some(&dir), &path, &budget()));
            let counts = l.as_ref().map(|l| (l.1[0].4, l.2.len(), l.3.len()));
            assert_eq!(counts, Ok((Some(material), materials, images)), "{head:?}");
        }
        // A refused MTL (over the budget: the mesh's 768 bytes fit, the file does not) is the same
        // error either way.
        let small = || Budget::new(crate::LoadOptions { max_memory: 900, ..Default::default() });
        let text = format!("mtllib scene.mtl\nusemtl glass\n{geometry}");
        let a = load_obj_text(&text, Some(&dir), &path, &small()).err().map(|e| e.to_string());
        let b = load_obj_checked(&text, Some(&dir), &path, &small()).err().map(|e| e.to_string());
        assert!(a.is_some() && a == b, "{a:?} {b:?}");
        assert!(a.is_some_and(|e| e.contains("scene.mtl")), "{b:?}");
    }

    #[test]
    fn objects_and_material_changes_load_as_through_tobj() {
        let dir = folder_with_scene_mtl("spectrace-geometry-obj-plain-objects");
        let v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
        let (a, b, c) = ("f 1/1 2/2 3/3\n", "f 3/3 4/4 1/1\n", "f 2/4 3/3 4/2\n");
        // (text, the meshes tobj makes of it with the MTL file read)
        let mut texts = vec![
            (format!("mtllib scene.mtl\n{v}o a\nusemtl red_paint\n{a}{b}o b\nusemtl glass\n{c}{a}"), 2),
            // A change of material ends an object; naming the same one again does not.
            (format!("mtllib scene.mtl\n{v}o a\nusemtl floor\n{a}usemtl glass\n{b}usemtl glass\n{c}"), 2),
            // Unknown materials are none: no change between two of them, a change to a known one.
            (format!("mtllib scene.mtl\n{v}usemtl x\n{a}usemtl y\n{b}usemtl floor\n{c}"), 2),
            // Objects without faces make nothing; an empty name is tobj's default.
            (format!("{v}o empty\no a\n{a}g\n{b}s 1\n{c}o last\n"), 2),
            (format!("{v}{a}o\n{b}g  spaced name \n{c}"), 3),
            // A material file read after faces; a material named before its file is read.
            (format!("{v}o a\n{a}mtllib scene.mtl\nusemtl glass\n{b}"), 2),
            (format!("{v}usemtl glass\n{a}mtllib scene.mtl\nusemtl glass\n{b}usemtl glass\n{c}"), 2),
            (format!("mtllib scene.mtl\n{v}o a\nusemtl glass\n{a}mtllib scene.mtl\nusemtl floor\n{b}"), 2),
            // Objects of different corner forms, the vertices of each with what its corners have.
            (format!("{v}vn 0 0 1\no a\nf 1//1 2//1 3//1\no b\n{a}{b}g c\nf 1 3 4\no\nf 4/1/1 2/2/1 1/3/1\n"), 4),
            // Vertex colours, each object's vertices with their positions' colours.
            (
                format!(
                    "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 0.5 0.5 0.5\n{}o a\n{a}{b}o b\n{c}",
                    &v[32..]
                ),
                2,
            ),
        ];
        // Several chunks: a grid of quads sharing positions across objects, with normals, an object
        // per row and a material change every third row (~3 MB).
        let n = 250;
        let mut grid = String::from("mtllib scene.mtl\n");
        grid.push_str(&vertex_grid(n, "\n", |i, j| [i as f32 / 3.0, ((i * j) % 11) as f32 * 0.1, j as f32 / 7.0]));
        grid.push_str("vn 0 1 0\nvn 0 0.8 0.6\n");
        for j in 0..n {
            grid.push_str(&format!("o row {j}\n"));
            if j % 3 == 0 {
                grid.push_str(["usemtl floor\n", "usemtl glass\n"][j / 3 % 2]);
            }
            for i in 0..n {
                let q = j * (n + 1) + i + 1;
                let k = 1 + (i + j) % 2;
                grid.push_str(&format!("f {}//{k} {q}//{k} {}//{k} {}//{k}\n", q + n + 1, q + 1, q + n + 2));
            }
        }
        texts.push((grid, n));
        let path = dir.join("t.obj");
        let budget = || Budget::allowing_absolute_paths();
        for (text, meshes) in &texts {
            assert!(crate::obj_plain::parse(text, u64::MAX).is_some(), "{text:?}");
            for base in [Some(dir.as_path()), None] {
                let checked = loaded(load_obj_checked(text, base, &path, &budget()));
                assert_eq!(loaded(load_obj_text(text, base, &path, &budget())), checked, "{text:?}");
                if base.is_some() {
                    assert_eq!(checked.map(|c| c.1.len()), Ok(*meshes), "{text:?}");
                }
            }
        }
        // Objects' names appear in errors (tobj's default for an empty one): the same either way.
        let far = "v 0 0 0\nv 1e30 0 0\nv 0 1 0\nv 1 1 0\no a\nf 1 3 4\ng\nf 1 2 3\n";
        assert!(crate::obj_plain::parse(far, u64::MAX).is_some());
        let checked = loaded(load_obj_checked(far, None, &path, &budget()));
        assert!(checked.as_ref().is_err_and(|e| e.contains("'unnamed_object'")), "{checked:?}");
        assert_eq!(loaded(load_obj_text(far, None, &path, &budget())), checked);
    }

    #[test]
    fn texture_coordinates_have_v_flipped_on_either_path() {
        // `vt` counts v up from the image's bottom edge, meshes down from its top edge.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.2\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
        let path = Path::new("t.obj");
        let expected = vec![Vec2::new(0.25, 0.8), Vec2::new(1.0, 1.0), Vec2::new(0.0, 0.0)];
        let budget = || Budget::allowing_absolute_paths();
        for desc in [load_obj_text(text, None, path, &budget()), load_obj_checked(text, None, path, &budget())] {
            let uvs = desc.ok().and_then(|d| d.meshes.first().and_then(|m| m.uvs().map(<[Vec2]>::to_vec)));
            assert_eq!(uvs.as_ref(), Some(&expected));
        }
    }

    #[test]
    fn one_component_colour_is_expanded() {
        let t = sanitize_mtl_text("newmtl a\nKd 0.5\n", Path::new("t.mtl")).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(t, "newmtl a\nKd 0.5 0.5 0.5\n");
    }

    #[test]
    fn trailing_comments_are_not_values() {
        let t = sanitize_mtl_text(
            "newmtl red # the left wall\nKa 0.63 0.065 0.05 # Red\nKd 0.5\t# grey\n",
            Path::new("t.mtl"),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(t, "newmtl red\nKa 0.63 0.065 0.05\nKd 0.5 0.5 0.5\n");
        assert_eq!(strip_trailing_comment("map_Kd wall#2.png"), "map_Kd wall#2.png");
    }

    #[test]
    fn two_component_colour_names_the_line() {
        let e = sanitize_mtl_text("newmtl a\n\nKs 0.5 0.2\n", Path::new("t.mtl"))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("t.mtl:3"), "{e}");
    }

    #[test]
    fn spectral_csv_reference_becomes_csv_spectrum() {
        let dir = std::env::temp_dir().join("spectrace-geometry-obj-spectral");
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.join("refl.csv"), "nm,r\n400,0.1\n700,0.2\n").unwrap_or_else(|e| panic!("{e}"));
        let budget = Budget::new(crate::LoadOptions::default());
        let (_, side, _) = sanitize_mtl("newmtl a\nKd spectral refl.csv\n", &dir.join("t.mtl"), &budget)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(side["a"].spectral["Kd"], SpectrumDesc::Csv { path: dir.join("refl.csv"), column: None });
        // A CSV that does not exist is refused when the MTL is read, not later.
        let e = sanitize_mtl("newmtl a\nKd spectral ../../../../dev/zero.csv\n", &dir.join("t.mtl"), &budget);
        assert!(e.is_err());
    }
}
