//! glTF 2.0 (`.gltf`, `.glb`) → [`SceneDescription`].
//!
//! The `gltf` crate parses and validates the JSON; everything that touches the binary data is ours, with
//! checked arithmetic, because `gltf`'s accessor iterators trust the file (an accessor with `count = 0`
//! underflows, a stride of 0 divides by zero, and a bad percent-encoded URI panics). Buffers are read here
//! too, so a missing buffer file is reported with its URI. Images are read (from files, data URIs or buffer
//! views) but not decoded: decoding, colour and sampling are the integrator's.
//!
//! The node hierarchy is flattened: each mesh primitive becomes a world-space [`Mesh`].

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};

use crate::desc::{
    AbsorptionDesc, AlphaMode, AnisotropyLayer, CameraDesc, Clearcoat, ImageDesc, IorDesc, LightAmount, LightDesc,
    LightUnit, MaterialDesc, MaterialFormat, Projection, SceneDescription, SceneFormat, SheenLayer, SpectrumDesc,
    SpecularLayer, TextureDesc, TextureTransform, WrapMode,
};
use crate::error::{Error, Result};
use crate::limits::{BYTES_PER_INSTANCE, Budget, check_coordinates, guard_panic, mesh_charge};
use crate::shapes::{Instances, Mesh};

/// Extensions whose data we read; a file that *requires* anything else is refused.
/// `KHR_materials_dispersion`, `_specular`, `_clearcoat`, `_sheen` and `_anisotropy` are read from the raw extension map (the `gltf`
/// crate has no typed accessor).
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
    "KHR_materials_dispersion",
    // Factors and every texture.
    "KHR_materials_specular",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_anisotropy",
    // Read in full (offset, rotation, scale, texCoord); Blender marks it required whenever a Mapping
    // node is used.
    "KHR_texture_transform",
    // Archived, but still written by older exporters (Blender test files require it): converted to
    // metallic-roughness with a warning (see `Loader::material`).
    "KHR_materials_pbrSpecularGlossiness",
    "EXT_mesh_gpu_instancing",
    // The texture's WebP image is used (decoded by the `image` crate's pure-Rust WebP decoder).
    "EXT_texture_webp",
];

/// Extensions a file may require that we degrade gracefully: the file loads, with a warning (see
/// [`extension_notes`]). Animations are ignored, so a file whose animations need `KHR_animation_pointer`
/// still has a rest pose; `KHR_materials_variants` keeps each primitive's default material.
/// `KHR_materials_unlit` materials are shaded as lit ones (the base colour as albedo), with a warning.
const DEGRADED_EXTENSIONS: &[&str] = &["KHR_materials_variants", "KHR_animation_pointer", "KHR_materials_unlit"];

/// Extensions whose data we do not decode, with the way forward for the user. glTF Transform decodes Draco
/// and meshopt when it reads a file and writes plain buffers (its maintainer: "decompression happens by
/// default when loading a file", donmccurdy/glTF-Transform#150), and `ktxdecompress` turns KTX2 textures
/// into PNG (the renderer decodes 8-bit KTX2 itself, raw or zstd; not Basis Universal or GPU block formats). A file that requires one of them loads only if nothing it needs is missing (see
/// [`extension_notes`]).
const UNDECODED_EXTENSIONS: &[(&str, &str)] = &[
    ("KHR_draco_mesh_compression", "decompress the file first, e.g. `gltf-transform cp IN OUT`"),
    ("EXT_meshopt_compression", "decompress the file first, e.g. `gltf-transform cp IN OUT`"),
    ("KHR_texture_basisu", "for those, convert the file first, e.g. `gltf-transform ktxdecompress IN OUT`"),
];

/// Bytes charged per accessor component read: the f64 staging value and the f32 it becomes.
const BYTES_PER_COMPONENT: u64 = 12;

/// Loads a `.gltf` or `.glb` file; external buffers resolve against its folder. Everything it allocates is
/// charged to `budget` first.
pub(crate) fn load_gltf_file(path: &Path, budget: &Budget) -> Result<SceneDescription> {
    let bytes = budget.read(path, path)?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    load_gltf_slice(&bytes, Some(base), path, budget)
}

/// Loads glTF from memory. `base`: folder for external buffers (`None`: only embedded data allowed);
/// `path`: the name used in messages.
pub(crate) fn load_gltf_slice(
    bytes: &[u8],
    base: Option<&Path>,
    path: &Path,
    budget: &Budget,
) -> Result<SceneDescription> {
    let gltf_err = |cause| Error::Gltf { path: path.to_path_buf(), cause };
    // A GLB header whose total length is below the header's own 12 bytes makes `gltf` subtract with
    // overflow (gltf 1.4.1 src/binary.rs:252, found by the `glb` fuzz target): refuse it here.
    if let [b'g', b'l', b'T', b'F', _, _, _, _, l0, l1, l2, l3, ..] = *bytes {
        let length = u32::from_le_bytes([l0, l1, l2, l3]);
        if length < 12 {
            return Err(Error::GltfData {
                path: path.to_path_buf(),
                context: "GLB header".to_owned(),
                message: format!("declares a total length of {length} bytes, less than the 12-byte header"),
            });
        }
    }
    // The JSON document (tree of values) costs a few times its text; charge twice the file.
    budget.charge(path, || "the glTF JSON document".to_owned(), 2 * bytes.len() as u64)?;
    let parsed = guard_panic(path, "gltf", || gltf::Gltf::from_slice_without_validation(bytes).map_err(gltf_err));
    let mut dropped_animations = 0;
    let gltf::Gltf { document, blob } = match parsed {
        // `gltf-json` 1.4.1 refuses what glTF 2.0 allows or what we ignore anyway: a scene without the
        // optional `nodes` key (an empty scene), and animation channels without a `node` (a
        // `KHR_animation_pointer` target). Patch those and parse again; if that fails too, the first error
        // stands.
        Err(e) => {
            let (patched, animations) = match patch_json(bytes) {
                Some(p) => p,
                None => return Err(e),
            };
            dropped_animations = animations;
            guard_panic(path, "gltf", || gltf::Gltf::from_slice_without_validation(&patched).map_err(gltf_err))
                .map_err(|_| e)?
        }
        Ok(gltf) => gltf,
    };

    // Required extensions first, with our own list: `gltf`'s validation would reject
    // KHR_materials_volume and KHR_materials_dispersion, which we do read, with a vaguer message.
    let mut root = document.into_json();
    let known = |e: &str| {
        SUPPORTED_EXTENSIONS.contains(&e)
            || DEGRADED_EXTENSIONS.contains(&e)
            || UNDECODED_EXTENSIONS.iter().any(|u| u.0 == e)
    };
    if let Some(ext) = root.extensions_required.iter().find(|e| !known(e)) {
        return Err(Error::UnsupportedExtension {
            path: path.to_path_buf(),
            extension: ext.clone(),
            supported: SUPPORTED_EXTENSIONS.join(", "),
        });
    }
    let notes = extension_notes(&mut root, dropped_animations, path)?;
    root.extensions_required.clear();
    // `gltf-json`'s validation indexes `accessors` with the POSITION attribute before checking the index
    // (gltf-json 1.4.1 src/mesh.rs:151, found by the fuzz test): check it first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive.attributes.get(&gltf::json::validation::Checked::Valid(Semantic::Positions));
            if let Some(index) = position.filter(|i| i.value() >= root.accessors.len()) {
                return Err(Error::GltfData {
                    path: path.to_path_buf(),
                    context: format!("meshes[{m}] primitive {p} POSITION"),
                    message: format!("accessor {} does not exist ({} accessors)", index.value(), root.accessors.len()),
                });
            }
        }
    }
    // glTF requires min/max on POSITION accessors and `gltf` enforces it, but we never read them (bounds
    // come from the data), and some exporters omit them: fill placeholders rather than refuse the file.
    for accessor in &mut root.accessors {
        if let gltf::json::validation::Checked::Valid(t) = accessor.type_ {
            let zeros = serde_json::Value::Array(vec![serde_json::json!(0.0); t.multiplicity()]);
            accessor.min.get_or_insert_with(|| zeros.clone());
            accessor.max.get_or_insert(zeros);
        }
    }
    // Images `gltf` would unwrap into a panic (`Image::source`, gltf 1.4.1 src/image.rs:124-128: neither
    // a URI nor a buffer view with a MIME type, or a view that does not exist; found by the fuzz
    // targets): their textures are skipped with a warning.
    let bad_images: HashSet<usize> = root
        .images
        .iter()
        .enumerate()
        .filter(|(_, i)| match (&i.buffer_view, &i.uri) {
            (Some(view), _) => view.value() >= root.buffer_views.len() || i.mime_type.is_none(),
            (None, uri) => uri.is_none(),
        })
        .map(|(k, _)| k)
        .collect();
    let generator = root.asset.generator.clone();
    let document = guard_panic(path, "gltf", || gltf::Document::from_json(root).map_err(gltf_err))?;

    check_views(&document, path)?;
    let buffers = load_buffers(&document, base, blob, path, budget)?;
    let mut loader = Loader {
        path,
        base,
        buffers: &buffers,
        images: HashMap::new(),
        bad_images,
        budget,
        desc: SceneDescription::empty(SceneFormat::Gltf),
        default_material: None,
        refused: None,
    };
    loader.desc.generator = generator;
    for note in notes {
        loader.warn(note);
    }
    for material in document.materials() {
        let m = loader.material(&material, &document);
        loader.desc.materials.push(m);
    }
    loader.partial_triangles(&document);
    loader.traverse(&document)?;
    match loader.refused {
        Some(e) => Err(e),
        None => Ok(loader.desc),
    }
}

/// The file with `"nodes": []` added to every scene that has no `nodes` key and without its animations
/// (JSON or GLB), and the number of animations removed; `None` if its JSON cannot be read as an object.
fn patch_json(bytes: &[u8]) -> Option<(Vec<u8>, usize)> {
    let patch = |json: &[u8]| -> Option<(Vec<u8>, usize)> {
        let mut value: serde_json::Value = serde_json::from_slice(json).ok()?;
        let root = value.as_object_mut()?;
        for scene in root.get_mut("scenes").and_then(|s| s.as_array_mut()).into_iter().flatten() {
            scene.as_object_mut()?.entry("nodes").or_insert_with(|| serde_json::json!([]));
        }
        let animations = root.remove("animations").and_then(|a| a.as_array().map(Vec::len)).unwrap_or(0);
        Some((serde_json::to_vec(&value).ok()?, animations))
    };
    if !bytes.starts_with(b"glTF") {
        return patch(bytes);
    }
    let glb = gltf::Glb::from_slice(bytes).ok()?;
    // `to_vec` writes the header and chunk lengths (and the padding) from the chunks themselves.
    let (json, animations) = patch(&glb.json)?;
    let glb = gltf::Glb { header: glb.header, json: json.into(), bin: glb.bin };
    Some((glb.to_vec().ok()?, animations))
}

/// What the file uses that we do not render, as one warning per extension or feature, checked on the JSON
/// before `gltf`'s validation (which would refuse some of it with a vaguer message):
/// - Draco (`KHR_draco_mesh_compression`): primitives whose uncompressed fallback accessors are present
///   load from them (warning); a primitive without them (the file then requires the extension) is an
///   error naming the extension and the way forward.
/// - meshopt (`EXT_meshopt_compression`): buffer views whose uncompressed fallback buffer has data load
///   from it (warning); a fallback buffer without data (no URI) is an error, likewise.
/// - KTX2 (`KHR_texture_basisu`): a note; a texture with only a KTX2 image points at it, so that the
///   file validates (the assembly decodes 8-bit KTX2 and warns per image about the rest).
/// - `KHR_materials_variants`: each primitive's default material; the variants are named in a warning.
/// - Animations (including `KHR_animation_pointer` ones): removed, one warning (the rest pose is drawn).
fn extension_notes(root: &mut gltf::json::Root, dropped_animations: usize, path: &Path) -> Result<Vec<String>> {
    let way = |name: &str| UNDECODED_EXTENSIONS.iter().find(|u| u.0 == name).map_or("", |u| u.1);
    let mut notes = Vec::new();

    const DRACO: &str = "KHR_draco_mesh_compression";
    let mut draco = 0;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if !primitive.extensions.as_ref().is_some_and(|e| e.others.contains_key(DRACO)) {
                continue;
            }
            draco += 1;
            let accessors = primitive.attributes.values().chain(primitive.indices.iter());
            let missing = accessors.into_iter().any(|a| {
                root.accessors.get(a.value()).is_some_and(|acc| acc.buffer_view.is_none() && acc.sparse.is_none())
            });
            if missing {
                return Err(Error::GltfData {
                    path: path.to_path_buf(),
                    context: format!("meshes[{m}] primitive {p}"),
                    message: format!(
                        "{DRACO}: the geometry is only Draco-compressed, which is not decoded; {}",
                        way(DRACO)
                    ),
                });
            }
        }
    }
    if draco > 0 {
        notes.push(format!(
            "{DRACO}: {draco} primitive(s) also hold Draco data, not decoded; their uncompressed fallback is used"
        ));
    }

    const MESHOPT: &str = "EXT_meshopt_compression";
    let fallback_without_data = |b: &gltf::json::Buffer| {
        b.uri.is_none() && b.extensions.as_ref().is_some_and(|e| e.others.contains_key(MESHOPT))
    };
    let mut meshopt = 0;
    for (v, view) in root.buffer_views.iter().enumerate() {
        if !view.extensions.as_ref().is_some_and(|e| e.others.contains_key(MESHOPT)) {
            continue;
        }
        meshopt += 1;
        if root.buffers.get(view.buffer.value()).is_some_and(fallback_without_data) {
            return Err(Error::GltfData {
                path: path.to_path_buf(),
                context: format!("bufferViews[{v}]"),
                message: format!(
                    "{MESHOPT}: the data is only meshopt-compressed, which is not decoded; {}",
                    way(MESHOPT)
                ),
            });
        }
    }
    if meshopt > 0 || root.buffers.iter().any(fallback_without_data) {
        notes.push(format!("{MESHOPT}: {meshopt} buffer view(s) also hold meshopt data, not decoded; their uncompressed fallback is used"));
    }

    const BASISU: &str = "KHR_texture_basisu";
    let (mut ktx2, mut only_ktx2) = (0, 0);
    for texture in &mut root.textures {
        let Some(ext) = texture.extensions.as_ref().and_then(|e| e.others.get(BASISU)) else { continue };
        ktx2 += 1;
        let source = ext.get("source").and_then(serde_json::Value::as_u64).and_then(|i| u32::try_from(i).ok());
        if texture.source.value() == u32::MAX as usize {
            only_ktx2 += 1;
            if let Some(i) = source.filter(|i| (*i as usize) < root.images.len()) {
                texture.source = gltf::json::Index::new(i);
            }
        }
    }
    // EXT_texture_webp: the WebP image is used, as the extension asks of a client that supports it (a
    // PNG/JPEG `source` beside it is the fallback for those that do not).
    for texture in &mut root.textures {
        let webp = texture.extensions.as_ref().and_then(|e| e.others.get("EXT_texture_webp"));
        let source = webp.and_then(|w| w.get("source")).and_then(serde_json::Value::as_u64);
        if let Some(i) = source.and_then(|i| u32::try_from(i).ok()).filter(|i| (*i as usize) < root.images.len()) {
            texture.source = gltf::json::Index::new(i);
        }
    }
    if ktx2 > 0 {
        notes.push(format!(
            "{BASISU}: {ktx2} texture(s) in KTX2 ({only_ktx2} without a PNG/JPEG fallback): 8-bit ones are decoded, Basis Universal and block-compressed ones are not (a warning per image); {}",
            way(BASISU)
        ));
    }

    const VARIANTS: &str = "KHR_materials_variants";
    let variants = root
        .extensions
        .as_ref()
        .and_then(|e| e.others.get(VARIANTS))
        .and_then(|v| v.get("variants"))
        .and_then(serde_json::Value::as_array)
        .map(|list| {
            list.iter().map(|v| v.get("name").and_then(serde_json::Value::as_str).unwrap_or("?")).collect::<Vec<_>>()
        });
    let mapped = root
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .any(|p| p.extensions.as_ref().is_some_and(|e| e.others.contains_key(VARIANTS)));
    if variants.is_some() || mapped {
        let names =
            variants.map(|v| v.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")).unwrap_or_default();
        notes.push(format!("{VARIANTS}: variants {names} ignored; each primitive's default material is used"));
    }

    let animations = root.animations.len() + dropped_animations;
    if animations > 0 {
        let pointer = if root.extensions_used.iter().any(|e| e == "KHR_animation_pointer") {
            " (with KHR_animation_pointer)"
        } else {
            ""
        };
        notes.push(format!("{animations} animation(s){pointer} ignored: the still rest pose is rendered"));
        root.animations.clear();
    }
    Ok(notes)
}

fn load_buffers(
    document: &gltf::Document,
    base: Option<&Path>,
    mut blob: Option<Vec<u8>>,
    path: &Path,
    budget: &Budget,
) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let index = buffer.index();
        let data_err = |message: String| Error::GltfData {
            path: path.to_path_buf(),
            context: format!("buffers[{index}]"),
            message,
        };
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => {
                blob.take().ok_or_else(|| data_err("refers to the GLB binary chunk, which is missing".into()))?
            }
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                // The decoded bytes (3/4 of the base64 text) and the decoder's copy.
                budget.charge(path, || format!("buffers[{index}] data URI"), uri.len() as u64)?;
                // Data URIs never reach `gltf`'s percent-decoder (the panicking part).
                guard_panic(path, "gltf", || {
                    gltf::buffer::Data::from_source(buffer.source(), None)
                        .map_err(|cause| Error::Gltf { path: path.to_path_buf(), cause })
                })?
                .0
            }
            gltf::buffer::Source::Uri(uri) => {
                let relative = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")).unwrap_or(uri);
                if relative.contains(':') && !uri.starts_with("file:") {
                    return Err(data_err(format!("unsupported URI scheme in `{uri}`")));
                }
                let decoded = percent_decode(relative)
                    .ok_or_else(|| data_err(format!("malformed percent-encoding in `{uri}`")))?;
                let Some(base) = base else {
                    return Err(data_err(format!("external buffer `{uri}` in a glTF loaded from memory")));
                };
                let file = budget.resolve(path, base, &decoded)?;
                budget.read(path, &file).map_err(|e| match e {
                    Error::ReadFile { cause, .. } | Error::ReadReferenced { cause, .. } => Error::GltfBuffer {
                        path: path.to_path_buf(),
                        buffer: index,
                        uri: file.display().to_string(),
                        cause,
                    },
                    other => other,
                })?
            }
        };
        if data.len() < buffer.length() {
            return Err(data_err(format!("has {} bytes, the file declares {}", data.len(), buffer.length())));
        }
        out.push(data);
    }
    Ok(out)
}

/// Every buffer view within its buffer's declared `byteLength` (glTF 2.0: a view's `byteOffset +
/// byteLength` must not exceed it). The data read may be longer than declared (a GLB chunk's padding, a
/// larger file), so a view past the declared end would otherwise be read from bytes the file says are
/// not the buffer's.
fn check_views(document: &gltf::Document, path: &Path) -> Result<()> {
    for view in document.views() {
        let buffer = view.buffer();
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > buffer.length()) {
            return Err(Error::GltfData {
                path: path.to_path_buf(),
                context: format!("bufferViews[{}]", view.index()),
                message: format!(
                    "byteOffset {} + byteLength {} passes the end of buffers[{}] (byteLength {})",
                    view.offset(),
                    view.length(),
                    buffer.index(),
                    buffer.length()
                ),
            });
        }
    }
    Ok(())
}

/// RFC 3986 percent-decoding; `None` on a malformed escape or a result that is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = s.get(i + 1..i + 3)?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

struct Loader<'a> {
    path: &'a Path,
    /// Folder external images resolve against (`None`: loaded from memory).
    base: Option<&'a Path>,
    buffers: &'a [Vec<u8>],
    /// glTF image index → index in `desc.images`: each image is read once however many textures use it.
    images: HashMap<usize, usize>,
    /// Images with no usable source (see `load_gltf_slice`).
    bad_images: HashSet<usize>,
    budget: &'a Budget,
    desc: SceneDescription,
    /// Index of the glTF default material, added on first use by a primitive without a material.
    default_material: Option<u32>,
    /// The first image that the file rules refuse (an absolute path, the memory budget): an error of
    /// the whole file, as for buffers and MTL maps, not a texture dropped with a note.
    refused: Option<Error>,
}

impl Loader<'_> {
    fn data_err(&self, context: &str, message: impl Into<String>) -> Error {
        Error::GltfData { path: self.path.to_path_buf(), context: context.to_owned(), message: message.into() }
    }

    fn warn(&mut self, message: String) {
        self.desc.warnings.push(format!("{}: {message}", self.path.display()));
    }

    /// One note per triangle-list primitive whose index count (vertex count when not indexed) is not a
    /// multiple of 3, as glTF requires of a triangle list: its whole triangles are read, the rest dropped.
    /// Said once per primitive here rather than at each placement of its mesh.
    fn partial_triangles(&mut self, document: &gltf::Document) {
        for mesh in document.meshes() {
            for primitive in mesh.primitives().filter(|p| p.mode() == Mode::Triangles) {
                let (what, count) = match (primitive.indices(), primitive.get(&Semantic::Positions)) {
                    (Some(indices), _) => ("indices", indices.count()),
                    (None, Some(positions)) => ("vertices (not indexed)", positions.count()),
                    (None, None) => continue,
                };
                if count % 3 != 0 {
                    let name = mesh.name().map(|n| format!(" '{n}'")).unwrap_or_default();
                    self.warn(format!(
                        "meshes[{}]{name} primitive {}: {count} {what}, not a multiple of 3 (glTF requires whole triangles); the last {} ignored",
                        mesh.index(),
                        primitive.index(),
                        count % 3
                    ));
                }
            }
        }
    }

    fn traverse(&mut self, document: &gltf::Document) -> Result<()> {
        let roots: Vec<gltf::Node<'_>> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                // No scene: render every root node (a node no other node lists as a child).
                let children: HashSet<usize> = document.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
                document.nodes().filter(|n| !children.contains(&n.index())).collect()
            }
        };
        if roots.is_empty() {
            // Valid glTF (a scene may list no nodes, a file may have none), but there is nothing to render:
            // said here, so that the no-geometry error names the reason.
            self.warn(match document.default_scene().or_else(|| document.scenes().next()) {
                Some(scene) => format!("scene {} has no nodes (an empty scene)", scene.index()),
                None => "the file has no nodes and no scene".to_owned(),
            });
        }
        let mut visited = HashSet::new();
        // Every placement of a mesh, in traversal order: (mesh, world transform, node context).
        let mut placements: Vec<(gltf::Mesh<'_>, Mat4, String)> = Vec::new();
        let mut stack: Vec<(gltf::Node<'_>, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            if !visited.insert(node.index()) {
                return Err(self.data_err(
                    &format!("nodes[{}]", node.index()),
                    "reached twice: the node hierarchy must be a set of disjoint trees (glTF 2.0 §3.5.3)",
                ));
            }
            let mut local = Mat4::from_cols_array_2d(&node.transform().matrix());
            let context =
                format!("nodes[{}]{}", node.index(), node.name().map(|n| format!(" '{n}'")).unwrap_or_default());
            let bottom = local.row(3);
            if bottom != glam::Vec4::W {
                // glTF requires a node's matrix to be decomposable to TRS, so affine. Points are placed by
                // the affine part (w is never divided by); setting the row makes the determinant (mirroring,
                // singularity) that part's too.
                self.warn(format!(
                    "{context}: matrix has bottom row ({}, {}, {}, {}), not (0, 0, 0, 1) (glTF requires an affine transform); used as (0, 0, 0, 1)",
                    bottom.x, bottom.y, bottom.z, bottom.w
                ));
                local = Mat4::from_cols(
                    local.x_axis.truncate().extend(0.0),
                    local.y_axis.truncate().extend(0.0),
                    local.z_axis.truncate().extend(0.0),
                    local.w_axis.truncate().extend(1.0),
                );
            }
            let world = parent * local;
            let det = world.determinant();
            if !world.is_finite() || !det.is_finite() || det == 0.0 {
                self.warn(format!(
                    "{context}: transform is singular or not finite; the node and its children are skipped"
                ));
                continue;
            }
            if let Some(mesh) = node.mesh() {
                if node.skin().is_some() || mesh.weights().is_some() {
                    self.warn(format!("{context}: skinning and morph targets are ignored (rest pose used)"));
                }
                match node.extension_value("EXT_mesh_gpu_instancing") {
                    Some(ext) => {
                        for local in self.gpu_instances(document, ext, &context)? {
                            let m = world * local;
                            let det = m.determinant();
                            if m.is_finite() && det.is_finite() && det != 0.0 {
                                placements.push((mesh.clone(), m, context.clone()));
                            }
                        }
                    }
                    None => placements.push((mesh, world, context.clone())),
                }
            }
            if let Some(camera) = node.camera() {
                self.camera(&camera, world, &context, node.name());
            }
            if let Some(light) = node.light() {
                self.light(&light, world);
            }
            for child in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((child, world));
            }
        }
        self.place_meshes(placements)
    }

    /// World-space copies of each mesh placed once (in traversal order, as always), or placed several
    /// times while the copies add few triangles ([`crate::LoadOptions::flatten_triangles`]) or its
    /// material emits (a light: each triangle must be a light source); else the mesh is read once in
    /// object space and placed by its transforms ([`Instances`], a two-level BVH above).
    fn place_meshes(&mut self, placements: Vec<(gltf::Mesh<'_>, Mat4, String)>) -> Result<()> {
        let mut count = std::collections::HashMap::<usize, u64>::new();
        for (mesh, ..) in &placements {
            *count.entry(mesh.index()).or_default() += 1;
        }
        let limit = self.budget.options.flatten_triangles;
        let mut instanced = std::collections::HashMap::<usize, usize>::new();
        for (mesh, world, context) in placements {
            let n = count[&mesh.index()];
            let copies_add = (n - 1).saturating_mul(triangle_estimate(&mesh));
            if n == 1 || copies_add <= limit || self.emits(&mesh) {
                self.mesh(&mesh, world, world.determinant() < 0.0, &context)?;
                continue;
            }
            self.budget.charge(
                self.path,
                || format!("{context}: an instance of meshes[{}]", mesh.index()),
                BYTES_PER_INSTANCE,
            )?;
            let group = match instanced.get(&mesh.index()) {
                Some(&g) => g,
                None => {
                    // The object-space meshes, read once: the primitives as `mesh` would push them.
                    let before = self.desc.meshes.len();
                    self.mesh(&mesh, Mat4::IDENTITY, false, &format!("{context} (instanced {n}×)"))?;
                    let meshes = self.desc.meshes.split_off(before);
                    self.desc.instances.push(Instances::new(meshes, Vec::new())?);
                    instanced.insert(mesh.index(), self.desc.instances.len() - 1);
                    self.desc.instances.len() - 1
                }
            };
            self.desc.instances[group].push_transform(world)?;
        }
        for (&mesh, &group) in &instanced {
            if let Some((lo, hi)) = self.desc.instances[group].bounds() {
                check_coordinates(
                    &[lo, hi],
                    self.path,
                    &format!("meshes[{mesh}] (instanced; its placements' bounds)"),
                )?;
            }
        }
        if !instanced.is_empty() {
            let placed: u64 = instanced.keys().map(|k| count[k]).sum();
            self.warn(format!(
                "{} mesh(es) placed {placed} times in all are instanced (kept once, placed by transforms)",
                instanced.len()
            ));
        }
        Ok(())
    }

    /// Whether any primitive of `mesh` has an emissive material (read before the traversal).
    fn emits(&self, mesh: &gltf::Mesh<'_>) -> bool {
        mesh.primitives().any(|p| {
            p.material().index().and_then(|i| self.desc.materials.get(i)).is_some_and(|m| m.emission.is_some())
        })
    }

    /// The local transforms of `EXT_mesh_gpu_instancing`: TRANSLATION, ROTATION (unit quaternion, float or
    /// normalized integers) and SCALE accessors of equal count, each optional (identity), applied as
    /// T·R·S in the node's space.
    fn gpu_instances(
        &mut self,
        document: &gltf::Document,
        ext: &serde_json::Value,
        context: &str,
    ) -> Result<Vec<Mat4>> {
        let context = format!("{context} EXT_mesh_gpu_instancing");
        let attributes = ext.get("attributes").and_then(serde_json::Value::as_object);
        let accessor = |name: &str| -> Result<Option<gltf::Accessor<'_>>> {
            let Some(v) = attributes.and_then(|a| a.get(name)) else { return Ok(None) };
            let index =
                v.as_u64().ok_or_else(|| self.data_err(&context, format!("{name} is not an accessor index")))?;
            document
                .accessors()
                .nth(index as usize)
                .map(Some)
                .ok_or_else(|| self.data_err(&context, format!("{name}: accessor {index} does not exist")))
        };
        let (t, r, s) = (accessor("TRANSLATION")?, accessor("ROTATION")?, accessor("SCALE")?);
        let read = |acc: &gltf::Accessor<'_>, name: &str, dims: Dimensions| -> Result<Vec<f32>> {
            if acc.dimensions() != dims {
                return Err(self.data_err(&context, format!("{name} must be {dims:?}, found {:?}", acc.dimensions())));
            }
            self.read_accessor(acc, &format!("{context} {name}"))
        };
        let translations = t.as_ref().map(|a| read(a, "TRANSLATION", Dimensions::Vec3)).transpose()?;
        let rotations = r.as_ref().map(|a| read(a, "ROTATION", Dimensions::Vec4)).transpose()?;
        let scales = s.as_ref().map(|a| read(a, "SCALE", Dimensions::Vec3)).transpose()?;
        let counts: Vec<usize> = [(&translations, 3), (&rotations, 4), (&scales, 3)]
            .iter()
            .filter_map(|(v, k)| v.as_ref().map(|v| v.len() / k))
            .collect();
        let Some(&count) = counts.first() else {
            self.warn(format!("{context}: no TRANSLATION, ROTATION or SCALE; the node's mesh is placed once"));
            return Ok(vec![Mat4::IDENTITY]);
        };
        if counts.iter().any(|c| *c != count) {
            return Err(self.data_err(&context, format!("attribute counts differ: {counts:?}")));
        }
        let mut out = Vec::with_capacity(count);
        let mut skipped = 0;
        for i in 0..count {
            let tr = translations.as_ref().map_or(Vec3::ZERO, |v| Vec3::from_slice(&v[3 * i..]));
            let sc = scales.as_ref().map_or(Vec3::ONE, |v| Vec3::from_slice(&v[3 * i..]));
            let q = rotations.as_ref().map_or(glam::Quat::IDENTITY, |v| glam::Quat::from_slice(&v[4 * i..]));
            let Some(q) = (q.is_finite() && q.length_squared() > 0.0).then(|| q.normalize()) else {
                skipped += 1;
                continue;
            };
            let m = Mat4::from_scale_rotation_translation(sc, q, tr);
            if m.is_finite() && m.determinant() != 0.0 {
                out.push(m);
            } else {
                skipped += 1;
            }
        }
        if skipped > 0 {
            self.warn(format!(
                "{context}: {skipped} of {count} instances have a singular or non-finite transform; skipped"
            ));
        }
        Ok(out)
    }

    fn camera(&mut self, camera: &gltf::Camera<'_>, world: Mat4, context: &str, node_name: Option<&str>) {
        let (projection, vfov_deg, aspect_ratio) = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let vfov_deg = p.yfov().to_degrees();
                if !(vfov_deg > 0.0 && vfov_deg < 180.0) {
                    self.warn(format!("{context}: camera yfov {} rad is outside (0, π); ignored", p.yfov()));
                    return;
                }
                let aspect = p.aspect_ratio();
                if aspect.is_some_and(|a| !(a.is_finite() && a > 0.0)) {
                    self.warn(format!("{context}: camera aspectRatio {aspect:?} is not finite and > 0; ignored"));
                }
                (Projection::Perspective, vfov_deg, aspect.filter(|a| a.is_finite() && *a > 0.0))
            }
            gltf::camera::Projection::Orthographic(o) => {
                // glTF 2.0 §5.13: xmag and ymag must not be zero and should not be negative; the sign
                // would mirror the image, so a negative value is refused rather than guessed at.
                let (xmag, ymag) = (o.xmag(), o.ymag());
                if !(xmag.is_finite() && xmag > 0.0 && ymag.is_finite() && ymag > 0.0) {
                    self.warn(format!(
                        "{context}: orthographic camera xmag {xmag}, ymag {ymag}: both must be finite and > 0; ignored"
                    ));
                    return;
                }
                // vfov_deg is not used by an orthographic camera; it holds a valid value all the same.
                (Projection::Orthographic { xmag, ymag }, 40.0, Some(xmag / ymag))
            }
        };
        // glTF cameras look down their local −Z with +Y up (glTF 2.0 §3.10.1).
        let position = world.transform_point3(Vec3::ZERO);
        let (Some(forward), Some(up)) =
            (world.transform_vector3(Vec3::NEG_Z).try_normalize(), world.transform_vector3(Vec3::Y).try_normalize())
        else {
            return;
        };
        // A scaled node scales an orthographic view (the rectangle is in the camera's local units).
        let projection = match projection {
            Projection::Orthographic { xmag, ymag } => Projection::Orthographic {
                xmag: xmag * world.transform_vector3(Vec3::X).length(),
                ymag: ymag * world.transform_vector3(Vec3::Y).length(),
            },
            p => p,
        };
        let desc = CameraDesc {
            position,
            look_at: position + forward,
            up,
            vfov_deg,
            projection,
            aspect_ratio,
            width: None,
            height: None,
        };
        // Every camera is kept, named by the camera, else its node, else its rank; the first is the default.
        let name =
            camera.name().or(node_name).map_or_else(|| format!("camera {}", self.desc.cameras.len()), str::to_owned);
        if self.desc.camera.is_none() {
            self.desc.camera = Some(desc.clone());
        }
        self.desc.cameras.push((name, desc));
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light<'_>, world: Mat4) {
        use gltf::khr_lights_punctual::Kind;
        let name = light.name().unwrap_or("unnamed").to_owned();
        // A spectral override in the light's extras (`{"spectrum": <manifest spectrum>}`) wins over its colour.
        let spectrum = self
            .extras_spectrum(light.extras(), &format!("light '{name}'"))
            .unwrap_or(SpectrumDesc::Rgb(light.color()));
        let intensity = light.intensity();
        if !(intensity.is_finite() && intensity >= 0.0) {
            self.warn(format!("light '{name}': intensity {intensity} is not finite and ≥ 0; ignored"));
            return;
        }
        let amount = |unit| LightAmount { value: intensity, unit };
        let position = world.transform_point3(Vec3::ZERO);
        // Lights shine along their local −Z (KHR_lights_punctual).
        let direction = world.transform_vector3(Vec3::NEG_Z).try_normalize().unwrap_or(Vec3::NEG_Z);
        let desc = match light.kind() {
            // KHR_lights_punctual: point and spot lights in candela, directional lights in lux.
            Kind::Point => LightDesc::Point { position, spectrum, intensity: amount(LightUnit::Candela) },
            Kind::Directional => LightDesc::Directional { direction, spectrum, intensity: amount(LightUnit::Lux) },
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                let outer = outer_cone_angle.to_degrees().clamp(0.0, 90.0);
                LightDesc::Spot {
                    position,
                    direction,
                    inner_cone_deg: inner_cone_angle.to_degrees().clamp(0.0, outer),
                    outer_cone_deg: outer,
                    spectrum,
                    intensity: amount(LightUnit::Candela),
                }
            }
        };
        self.desc.lights.push(desc);
    }

    fn extras_spectrum(&mut self, extras: &gltf::json::Extras, context: &str) -> Option<SpectrumDesc> {
        let value = extras_value(extras)?;
        let spectrum = value.get("spectrum")?;
        let base = self.path.parent().unwrap_or_else(|| Path::new("."));
        let origin = self.path.display().to_string();
        let ctx = crate::forms::Ctx { origin: &origin, base_dir: base, budget: self.budget };
        match crate::forms::spectrum(&ctx, &format!("{context}.extras.spectrum"), spectrum) {
            Ok(s) => Some(s),
            Err(e) => {
                self.warn(format!("{e}; the colour is used instead"));
                None
            }
        }
    }

    fn material(&mut self, material: &gltf::Material<'_>, document: &gltf::Document) -> MaterialDesc {
        let index = material.index().unwrap_or(0);
        let name = material.name().map(str::to_owned).unwrap_or_else(|| format!("material{index}"));
        let pbr = material.pbr_metallic_roughness();
        // What the file says, with glTF's own defaults where it is silent (the `gltf` crate fills them:
        // base colour 1, metallic 1, roughness 1, IOR 1.5). What they mean for shading is the assembly's.
        let mut m = MaterialDesc::new(&name, MaterialFormat::Gltf);
        let [r, g, b, _alpha] = pbr.base_color_factor();
        m.base_color = Some(SpectrumDesc::Rgb([r, g, b]));
        m.metallic = Some(pbr.metallic_factor());
        m.roughness = Some(pbr.roughness_factor());
        m.double_sided = Some(material.double_sided());

        let emissive = material.emissive_factor();
        // Black (glTF's default) means not emissive.
        if emissive.iter().any(|c| *c > 0.0) {
            m.emission = Some(SpectrumDesc::Rgb(emissive));
            m.emission_strength = material.emissive_strength();
        }
        let context = format!("material '{name}'");
        if let Some(t) = material.transmission() {
            m.transmission = Some(t.transmission_factor());
            m.textures.transmission = t
                .transmission_texture()
                .and_then(|i| self.texture(&i.texture(), i.tex_coord(), transform(&i), 1.0, &context));
        }
        // 0 is kept: it means Fresnel ≡ 1 (see IorDesc). KHR_materials_ior allows 0 or ≥ 1; a negative or
        // non-finite value is not an index of refraction at all.
        if let Some(ior) = material.ior() {
            if ior.is_finite() && ior >= 0.0 {
                m.ior = Some(IorDesc::Constant(ior));
            } else {
                self.warn(format!(
                    "material '{name}': KHR_materials_ior.ior {ior} is not 0 or a positive number; glTF's default 1.5 is used"
                ));
            }
        }
        if let Some(v) = material.volume() {
            m.thickness = Some(v.thickness_factor());
            let distance = v.attenuation_distance();
            // An infinite distance (the default) means no absorption at all.
            if distance.is_finite() && distance > 0.0 {
                m.absorption = Some(AbsorptionDesc::Attenuation { color: v.attenuation_color(), distance });
            }
            if v.thickness_texture().is_some() {
                // Like the factor, it approximates the path length inside the volume for rasterisers; a path
                // tracer follows the real one through the closed mesh.
                self.warn(format!(
                    "material '{name}': thickness texture ignored (absorption follows the path length inside the mesh)"
                ));
            }
        }
        if let Some(value) = material.extension_value("KHR_materials_dispersion") {
            // The extension's default, 0, is no dispersion.
            m.dispersion = Some(self.factor(value, "dispersion", 0.0, f32::INFINITY, &context)).filter(|&d| d > 0.0);
        }
        m.extras = extras_value(material.extras());
        // `"extras": {"multiple_scattering": false}` selects the specification's uncompensated layers, as the
        // manifest key of that name does (a glTF file has no other place for it).
        m.multiple_scattering = m.extras.as_ref().and_then(|e| e.get("multiple_scattering")).and_then(|v| v.as_bool());

        m.textures.base_color = pbr
            .base_color_texture()
            .and_then(|t| self.texture(&t.texture(), t.tex_coord(), transform(&t), 1.0, &context));
        m.textures.metallic_roughness = pbr
            .metallic_roughness_texture()
            .and_then(|t| self.texture(&t.texture(), t.tex_coord(), transform(&t), 1.0, &context));
        m.textures.normal = material.normal_texture().and_then(|t| {
            let transform = t.extensions().and_then(|e| e.get("KHR_texture_transform")).and_then(transform_value);
            self.texture(&t.texture(), t.tex_coord(), transform, t.scale(), &context)
        });
        m.textures.emissive = material
            .emissive_texture()
            .and_then(|t| self.texture(&t.texture(), t.tex_coord(), transform(&t), 1.0, &context));
        if material.occlusion_texture().is_some() {
            // Ambient occlusion is baked shadowing; a path tracer computes the real thing.
            self.warn(format!("{context}: occlusion texture ignored (the path tracer computes occlusion)"));
        }
        m.alpha = Some(pbr.base_color_factor()[3]);
        if let Some(sg) = material.extension_value("KHR_materials_pbrSpecularGlossiness") {
            // The archived specular-glossiness model, converted as glTF's own migration notes suggest
            // for a dielectric: diffuse → base colour, roughness = 1 − glossiness, metallic 0. The
            // specular colour and the specular-glossiness texture are not converted (warned).
            let number = |v: &serde_json::Value| v.as_f64().filter(|x| x.is_finite()).map(|x| x as f32);
            let diffuse: Vec<f32> = sg
                .get("diffuseFactor")
                .and_then(|v| v.as_array())
                .map(|a| a.iter().filter_map(number).collect())
                .unwrap_or_default();
            let [r, g, b, a] = match diffuse[..] {
                [r, g, b, a] => [r, g, b, a],
                _ => [1.0; 4],
            };
            m.base_color = Some(SpectrumDesc::Rgb([r, g, b]));
            m.alpha = Some(a);
            m.metallic = Some(0.0);
            m.roughness = Some(1.0 - sg.get("glossinessFactor").and_then(number).unwrap_or(1.0).clamp(0.0, 1.0));
            m.textures.base_color = self.raw_texture(sg.get("diffuseTexture"), document, false, &context);
            self.warn(format!(
                "{context}: KHR_materials_pbrSpecularGlossiness converted to metallic-roughness (diffuse → base colour, roughness = 1 − glossiness, metallic 0; specular colour and specularGlossinessTexture ignored)"
            ));
        }
        m.alpha_mode = Some(match material.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask(material.alpha_cutoff().unwrap_or(0.5)),
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        });
        if material.extension_value("KHR_materials_unlit").is_some() {
            self.warn(format!(
                "{context}: KHR_materials_unlit is shaded as a lit material (its base colour as the albedo)"
            ));
        }
        if let Some(value) = material.extension_value("KHR_materials_specular") {
            m.specular_layer = Some(self.specular_layer(value, &context));
            m.textures.specular = self.raw_texture(value.get("specularTexture"), document, false, &context);
            m.textures.specular_color = self.raw_texture(value.get("specularColorTexture"), document, false, &context);
        }
        if let Some(value) = material.extension_value("KHR_materials_clearcoat") {
            m.clearcoat = self.clearcoat(value, &context);
            if m.clearcoat.is_some() {
                m.textures.clearcoat = self.raw_texture(value.get("clearcoatTexture"), document, false, &context);
                m.textures.clearcoat_roughness =
                    self.raw_texture(value.get("clearcoatRoughnessTexture"), document, false, &context);
                m.textures.clearcoat_normal =
                    self.raw_texture(value.get("clearcoatNormalTexture"), document, true, &context);
            }
        }
        if let Some(value) = material.extension_value("KHR_materials_sheen") {
            m.sheen = self.sheen(value, &context);
            if m.sheen.is_some() {
                m.textures.sheen_color = self.raw_texture(value.get("sheenColorTexture"), document, false, &context);
                m.textures.sheen_roughness =
                    self.raw_texture(value.get("sheenRoughnessTexture"), document, false, &context);
            }
        }
        if let Some(value) = material.extension_value("KHR_materials_anisotropy") {
            m.anisotropy = self.anisotropy(value, &context);
            if m.anisotropy.is_some() {
                m.textures.anisotropy = self.raw_texture(value.get("anisotropyTexture"), document, false, &context);
            }
        }
        for (extension, what) in [
            ("KHR_materials_iridescence", "iridescence"),
            ("KHR_materials_diffuse_transmission", "diffuse transmission"),
        ] {
            if material.extension_value(extension).is_some() {
                self.warn(format!("{context}: {extension} ({what}) is not rendered yet; ignored"));
            }
        }
        m
    }

    /// A factor of a material extension: `default` where absent, else a number in [0, `max`] (a warning and
    /// `default` otherwise).
    fn factor(&mut self, value: &serde_json::Value, key: &str, default: f32, max: f32, context: &str) -> f32 {
        match value.get(key) {
            None => default,
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() && (0.0..=f64::from(max)).contains(&x) => x as f32,
                _ => {
                    self.warn(format!(
                        "{context}: {key} {v} is not a number in [0, {max}]; the default {default} is used"
                    ));
                    default
                }
            },
        }
    }

    /// Any finite number at `key` of `value` (`what` naming it in the warning): `default` where absent, and
    /// with a warning where it is not a finite number.
    fn finite(&mut self, value: &serde_json::Value, key: &str, what: &str, default: f32, context: &str) -> f32 {
        match value.get(key) {
            None => default,
            Some(v) => match v.as_f64().filter(|x| x.is_finite()) {
                Some(x) => x as f32,
                None => {
                    self.warn(format!("{context}: {what} {v} is not a number; {default} is used"));
                    default
                }
            },
        }
    }

    /// A material extension's `textureInfo` (`index`, `texCoord`, `KHR_texture_transform`; and `scale` for a
    /// `normal` map's `normalTextureInfo`), read from its raw JSON (the `gltf` crate types only the core
    /// roles); `None` where absent, and with a warning where it names no texture of the file.
    fn raw_texture(
        &mut self,
        info: Option<&serde_json::Value>,
        document: &gltf::Document,
        normal: bool,
        context: &str,
    ) -> Option<TextureDesc> {
        let info = info?;
        let texture = info.get("index").and_then(serde_json::Value::as_u64).and_then(|i| {
            let i = usize::try_from(i).ok()?;
            document.textures().nth(i)
        });
        let Some(texture) = texture else {
            self.warn(format!("{context}: texture {info} names no texture of the file; ignored"));
            return None;
        };
        let set = info.get("texCoord").and_then(serde_json::Value::as_u64).unwrap_or(0) as u32;
        let transform = info.get("extensions").and_then(|e| e.get("KHR_texture_transform")).and_then(transform_value);
        let scale = if normal { self.finite(info, "scale", "normal texture scale", 1.0, context) } else { 1.0 };
        self.texture(&texture, set, transform, scale, context)
    }

    /// `KHR_materials_specular`: `specularFactor` (default 1) and `specularColorFactor` (default white, each
    /// component ≥ 0: the extension lets it exceed 1).
    fn specular_layer(&mut self, value: &serde_json::Value, context: &str) -> SpecularLayer {
        let factor = self.factor(value, "specularFactor", 1.0, 1.0, context);
        let color = self.color_factor(value, "KHR_materials_specular.specularColorFactor", [1.0; 3], f32::MAX, context);
        SpecularLayer { factor, color }
    }

    /// `KHR_materials_sheen`: `sheenColorFactor` (default black: no sheen) and `sheenRoughnessFactor`
    /// (default 0).
    fn sheen(&mut self, value: &serde_json::Value, context: &str) -> Option<SheenLayer> {
        let color = self.color_factor(value, "KHR_materials_sheen.sheenColorFactor", [0.0; 3], 1.0, context);
        let roughness = self.factor(value, "sheenRoughnessFactor", 0.0, 1.0, context);
        (color != [0.0; 3]).then_some(SheenLayer { color, roughness })
    }

    /// `KHR_materials_anisotropy`: `anisotropyStrength` (default 0: isotropic) and `anisotropyRotation`
    /// (radians, any finite number; default 0).
    fn anisotropy(&mut self, value: &serde_json::Value, context: &str) -> Option<AnisotropyLayer> {
        let strength = self.factor(value, "anisotropyStrength", 0.0, 1.0, context);
        let rotation = self.finite(value, "anisotropyRotation", "anisotropyRotation", 0.0, context);
        (strength > 0.0).then_some(AnisotropyLayer { strength, rotation })
    }

    /// A colour factor of a material extension (`key` is the extension and field, as a warning names it):
    /// `default` where absent, else three numbers in [0, `max`] (a warning and `default` otherwise).
    fn color_factor(
        &mut self,
        value: &serde_json::Value,
        key: &str,
        default: [f32; 3],
        max: f32,
        context: &str,
    ) -> [f32; 3] {
        let Some(v) = value.get(key.rsplit('.').next().unwrap_or(key)) else { return default };
        let parsed: Option<Vec<f32>> = v.as_array().filter(|a| a.len() == 3).and_then(|a| {
            a.iter()
                .map(|c| c.as_f64().filter(|x| x.is_finite() && (0.0..=f64::from(max)).contains(x)).map(|x| x as f32))
                .collect()
        });
        match parsed {
            Some(c) => [c[0], c[1], c[2]],
            None => {
                let range = if max == f32::MAX { "≥ 0".to_string() } else { format!("in [0, {max}]") };
                self.warn(format!("{context}: {key} {v} is not three numbers {range}; {default:?} is used"));
                default
            }
        }
    }

    /// `KHR_materials_clearcoat`: `clearcoatFactor` (default 0: no coat) and `clearcoatRoughnessFactor`
    /// (default 0).
    fn clearcoat(&mut self, value: &serde_json::Value, context: &str) -> Option<Clearcoat> {
        let factor = self.factor(value, "clearcoatFactor", 0.0, 1.0, context);
        let roughness = self.factor(value, "clearcoatRoughnessFactor", 0.0, 1.0, context);
        (factor > 0.0).then_some(Clearcoat { factor, roughness })
    }

    /// The texture `texture` addressed by `tex_coord` (before the transform's override), its image read
    /// once; `None` with a warning when the image cannot be read (the factor alone is used then).
    fn texture(
        &mut self,
        texture: &gltf::Texture<'_>,
        tex_coord: u32,
        transform: Option<(TextureTransform, Option<u32>)>,
        scale: f32,
        context: &str,
    ) -> Option<TextureDesc> {
        let image = texture.source();
        if self.bad_images.contains(&image.index()) {
            self.warn(format!(
                "{context}: texture {} not used: images[{}] has neither a URI nor a buffer view with a MIME type",
                texture.index(),
                image.index()
            ));
            return None;
        }
        let image = match self.images.get(&image.index()) {
            Some(&i) => i,
            None => match self.read_image(&image) {
                Ok(desc) => {
                    self.desc.images.push(desc);
                    self.images.insert(image.index(), self.desc.images.len() - 1);
                    self.desc.images.len() - 1
                }
                Err(e @ (Error::AbsolutePath { .. } | Error::OverBudget { .. })) => {
                    self.refused.get_or_insert(e);
                    return None;
                }
                Err(e) => {
                    self.warn(format!("{context}: texture {} not used: {e}", texture.index()));
                    return None;
                }
            },
        };
        let sampler = texture.sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::Repeat => WrapMode::Repeat,
            gltf::texture::WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
            gltf::texture::WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
        };
        Some(TextureDesc {
            image,
            tex_coord: transform.and_then(|(_, set)| set).unwrap_or(tex_coord),
            wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
            nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
            transform: transform.map(|(t, _)| t),
            scale: if scale.is_finite() { scale } else { 1.0 },
        })
    }

    /// The encoded bytes of `image`: a buffer view, a data URI, or a file beside the glTF (charged to the
    /// budget and hashed into the scene's digest, like buffers).
    fn read_image(&self, image: &gltf::Image<'_>) -> Result<ImageDesc> {
        let index = image.index();
        match image.source() {
            gltf::image::Source::View { view, mime_type } => {
                let bytes = self.view_bytes(&view, &format!("images[{index}]"))?;
                self.budget.charge(self.path, || format!("images[{index}] bytes"), bytes.len() as u64)?;
                Ok(ImageDesc {
                    label: format!("images[{index}] (buffer view {})", view.index()),
                    mime: Some(mime_type.to_owned()),
                    bytes: Arc::from(bytes),
                })
            }
            gltf::image::Source::Uri { uri, mime_type } if uri.starts_with("data:") => {
                self.budget.charge(self.path, || format!("images[{index}] data URI"), uri.len() as u64)?;
                let source = gltf::buffer::Source::Uri(uri);
                let bytes = guard_panic(self.path, "gltf", || {
                    gltf::buffer::Data::from_source(source, None)
                        .map_err(|cause| Error::Gltf { path: self.path.to_path_buf(), cause })
                })?
                .0;
                Ok(ImageDesc {
                    label: format!("images[{index}] (data URI)"),
                    mime: mime_type.map(str::to_owned),
                    bytes: Arc::from(bytes),
                })
            }
            gltf::image::Source::Uri { uri, mime_type } => {
                let err = |message: String| self.data_err(&format!("images[{index}]"), message);
                let relative = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")).unwrap_or(uri);
                if relative.contains(':') && !uri.starts_with("file:") {
                    return Err(err(format!("unsupported URI scheme in `{uri}`")));
                }
                let decoded =
                    percent_decode(relative).ok_or_else(|| err(format!("malformed percent-encoding in `{uri}`")))?;
                let Some(base) = self.base else {
                    return Err(err(format!("external image `{uri}` in a glTF loaded from memory")));
                };
                let file = self.budget.resolve(self.path, base, &decoded)?;
                let bytes = self.budget.read(self.path, &file)?;
                Ok(ImageDesc {
                    label: file.display().to_string(),
                    mime: mime_type.map(str::to_owned),
                    bytes: Arc::from(bytes),
                })
            }
        }
    }

    fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        // The file writes no material here, so the description says nothing: glTF 2.0 §3.9.6's default
        // material (base colour 1, metallic 1, roughness 1, single-sided) is what the assembly makes of an
        // empty `MaterialFormat::Gltf` record, decided there once.
        let m = MaterialDesc::new("gltf-default", MaterialFormat::Gltf);
        // Material counts come from a JSON array; far below u32::MAX.
        let i = self.desc.materials.len() as u32;
        self.desc.materials.push(m);
        self.default_material = Some(i);
        i
    }

    fn mesh(&mut self, mesh: &gltf::Mesh<'_>, world: Mat4, mirrored: bool, node_context: &str) -> Result<()> {
        for primitive in mesh.primitives() {
            let context = format!(
                "{node_context}: meshes[{}]{} primitive {}",
                mesh.index(),
                mesh.name().map(|n| format!(" '{n}'")).unwrap_or_default(),
                primitive.index()
            );
            let mode = primitive.mode();
            if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
                self.warn(format!("{context}: {mode:?} primitive skipped (only triangles are rendered)"));
                continue;
            }
            let Some(accessor) = primitive.get(&Semantic::Positions) else {
                self.warn(format!("{context}: no POSITION attribute; skipped"));
                continue;
            };
            // The mesh this primitive becomes: its vertices (with normals, UVs and the world-space copy) and
            // its triangles' share of the BVH, charged before anything is read.
            let vertices = accessor.count() as u64;
            let listed = primitive.indices().map_or(vertices, |a| a.count() as u64);
            let triangles = match mode {
                Mode::TriangleStrip | Mode::TriangleFan => listed.saturating_sub(2),
                _ => listed / 3,
            };
            self.budget.charge(
                self.path,
                || format!("{context} ({vertices} vertices, {triangles} triangles)"),
                mesh_charge(vertices, triangles),
            )?;
            let positions = self.read_vec3(&accessor, &format!("{context} POSITION"))?;
            for (i, p) in positions.iter().enumerate() {
                if !p.is_finite() {
                    return Err(Error::NonFiniteVertex {
                        path: self.path.to_path_buf(),
                        context: context.clone(),
                        vertex: i,
                        value: p.to_array(),
                    });
                }
            }
            let vertex_count = positions.len();
            let list: Vec<u32> = match primitive.indices() {
                Some(acc) => self.read_indices(&acc, &format!("{context} indices"))?,
                None => (0..u32::try_from(vertex_count).map_err(|_| self.data_err(&context, "too many vertices"))?)
                    .collect(),
            };
            if let Some(bad) = list.iter().find(|i| **i as usize >= vertex_count) {
                return Err(Error::IndexOutOfRange {
                    path: self.path.to_path_buf(),
                    context,
                    index: u64::from(*bad),
                    vertex_count,
                });
            }
            let mut triangles = triangulate(mode, &list);
            if mirrored {
                // A transform with negative determinant flips the winding (glTF 2.0 §3.7.4); restore it so
                // the geometric normal keeps facing out (`Mesh::transformed` keeps the winding as it is).
                for t in &mut triangles {
                    t.swap(1, 2);
                }
            }
            if triangles.is_empty() {
                self.warn(format!("{context}: no complete triangle; skipped"));
                continue;
            }
            let normals = match primitive.get(&Semantic::Normals) {
                Some(acc) => {
                    let n = self.read_vec3(&acc, &format!("{context} NORMAL"))?;
                    self.per_vertex(n, vertex_count, Vec3::is_finite, &context, "NORMAL", "normals dropped")
                }
                None => None,
            };
            let material = match primitive.material().index() {
                // Material indices were validated by `gltf` against the materials array.
                Some(i) => i as u32,
                None => self.default_material(),
            };
            // A mesh holds the uv sets its material's textures address: a primary one and at most one other.
            let textures = &self.desc.materials[material as usize].textures;
            let sets: Vec<u32> = textures.roles().into_iter().flatten().map(|t| t.tex_coord).collect();
            let (set, second_set) = textures.uv_sets();
            let wants_tangents = self.desc.materials[material as usize].needs_tangents();
            if let Some(other) = second_set
                && sets.iter().any(|&s| s != set && s != other)
            {
                self.warn(format!(
                    "{context}: the material's textures use more than two TEXCOORD sets {sets:?}; those beyond TEXCOORD_{set} and TEXCOORD_{other} are read with TEXCOORD_{other}"
                ));
            }
            let second_uvs = match second_set.map(|s| (s, primitive.get(&Semantic::TexCoords(s)))) {
                Some((s, Some(acc))) => {
                    let uv = self.read_vec2(&acc, &format!("{context} TEXCOORD_{s}"))?;
                    let name = format!("TEXCOORD_{s}");
                    self.per_vertex(
                        uv,
                        vertex_count,
                        Vec2::is_finite,
                        &context,
                        &name,
                        "its textures read the first set",
                    )
                }
                Some((s, None)) => {
                    self.warn(format!("{context}: the material's textures use TEXCOORD_{s}, which is missing; they read TEXCOORD_{set}"));
                    None
                }
                None => None,
            };
            let uvs = match primitive.get(&Semantic::TexCoords(set)) {
                Some(acc) => {
                    let uv = self.read_vec2(&acc, &format!("{context} TEXCOORD_{set}"))?;
                    let name = format!("TEXCOORD_{set}");
                    self.per_vertex(uv, vertex_count, Vec2::is_finite, &context, &name, "UVs dropped")
                }
                None => {
                    if !sets.is_empty() {
                        self.warn(format!("{context}: the material is textured but TEXCOORD_{set} is missing; textures read at uv (0, 0)"));
                    }
                    None
                }
            };
            let tangents = match primitive.get(&Semantic::Tangents).filter(|_| wants_tangents) {
                Some(acc) => {
                    let t = self.read_vec4(&acc, &format!("{context} TANGENT"))?;
                    let instead = "MikkTSpace tangents used";
                    self.per_vertex(t, vertex_count, glam::Vec4::is_finite, &context, "TANGENT", instead)
                }
                None => None,
            };
            // glTF 2.0 §3.7.2.1: COLOR_0 multiplies the base colour (linear RGB, alpha multiplying alpha).
            let colors = match primitive.get(&Semantic::Colors(0)) {
                Some(acc) => {
                    let c = self.read_colors(&acc, &format!("{context} COLOR_0"))?;
                    self.per_vertex(
                        c,
                        vertex_count,
                        glam::Vec4::is_finite,
                        &context,
                        "COLOR_0",
                        "vertex colours dropped",
                    )
                }
                None => None,
            };
            let local = Mesh::new(positions, normals, uvs, triangles, Some(material))
                .and_then(|m| match tangents {
                    Some(t) => m.with_tangents(t),
                    None => Ok(m),
                })
                .and_then(|m| match colors {
                    Some(c) => m.with_colors(c),
                    None => Ok(m),
                })
                .and_then(|m| match second_uvs {
                    Some(s) => m.with_second_uvs(s),
                    None => Ok(m),
                })
                .map_err(|e| Error::InvalidGeometry {
                    path: self.path.to_path_buf(),
                    context: context.clone(),
                    cause: Box::new(e),
                })?;
            let mesh = if world == Mat4::IDENTITY { local } else { local.transformed(world) };
            check_coordinates(mesh.positions(), self.path, &context)?;
            self.desc.meshes.push(mesh);
        }
        Ok(())
    }

    /// A vertex attribute, if it has one finite value per vertex; else `None` and a warning saying
    /// what is used `instead`.
    fn per_vertex<T: Copy>(
        &mut self,
        values: Vec<T>,
        vertex_count: usize,
        finite: impl Fn(T) -> bool,
        context: &str,
        name: &str,
        instead: &str,
    ) -> Option<Vec<T>> {
        if values.len() == vertex_count && values.iter().all(|&v| finite(v)) {
            return Some(values);
        }
        self.warn(format!("{context}: {name} count differs from POSITION or is not finite; {instead}"));
        None
    }

    fn read_vec3(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<Vec3>> {
        if acc.dimensions() != Dimensions::Vec3 || acc.data_type() != DataType::F32 {
            return Err(self.data_err(
                context,
                format!("must be VEC3 of FLOAT, found {:?} of {:?}", acc.dimensions(), acc.data_type()),
            ));
        }
        let v = self.read_accessor(acc, context)?;
        Ok(v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
    }

    fn read_vec2(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<Vec2>> {
        let ok_type = acc.data_type() == DataType::F32
            || (acc.normalized() && matches!(acc.data_type(), DataType::U8 | DataType::U16));
        if acc.dimensions() != Dimensions::Vec2 || !ok_type {
            return Err(self.data_err(
                context,
                format!(
                    "must be VEC2 of FLOAT or normalized UNSIGNED_BYTE/SHORT, found {:?} of {:?}",
                    acc.dimensions(),
                    acc.data_type()
                ),
            ));
        }
        let v = self.read_accessor(acc, context)?;
        Ok(v.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect())
    }

    fn read_vec4(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<glam::Vec4>> {
        if acc.dimensions() != Dimensions::Vec4 || acc.data_type() != DataType::F32 {
            return Err(self.data_err(
                context,
                format!("must be VEC4 of FLOAT, found {:?} of {:?}", acc.dimensions(), acc.data_type()),
            ));
        }
        // The tangents are not in the vertex charge (most meshes have none).
        self.budget.charge(self.path, || format!("{context} ({} tangents)", acc.count()), acc.count() as u64 * 16)?;
        let v = self.read_accessor(acc, context)?;
        Ok(v.chunks_exact(4).map(|c| glam::Vec4::new(c[0], c[1], c[2], c[3])).collect())
    }

    /// `COLOR_0` as linear RGBA: VEC3 (alpha 1) or VEC4 of FLOAT or normalized UNSIGNED_BYTE/SHORT, the
    /// accessor types glTF 2.0 §3.7.2.1 allows.
    fn read_colors(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<glam::Vec4>> {
        let ok_type = acc.data_type() == DataType::F32
            || (acc.normalized() && matches!(acc.data_type(), DataType::U8 | DataType::U16));
        let components = match acc.dimensions() {
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            _ => 0,
        };
        if components == 0 || !ok_type {
            return Err(self.data_err(
                context,
                format!(
                    "must be VEC3 or VEC4 of FLOAT or normalized UNSIGNED_BYTE/SHORT, found {:?} of {:?}",
                    acc.dimensions(),
                    acc.data_type()
                ),
            ));
        }
        // The colours are not in the vertex charge (most meshes have none).
        self.budget.charge(self.path, || format!("{context} ({} colours)", acc.count()), acc.count() as u64 * 16)?;
        let v = self.read_accessor(acc, context)?;
        Ok(v.chunks_exact(components)
            .map(|c| glam::Vec4::new(c[0], c[1], c[2], if components == 4 { c[3] } else { 1.0 }))
            .collect())
    }

    fn read_indices(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<u32>> {
        if acc.dimensions() != Dimensions::Scalar
            || !matches!(acc.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
            || acc.normalized()
        {
            return Err(self.data_err(
                context,
                format!("must be SCALAR of unsigned integers, found {:?} of {:?}", acc.dimensions(), acc.data_type()),
            ));
        }
        let raw = self.read_raw(acc, context)?;
        Ok(raw.into_iter().map(|v| v as u32).collect())
    }

    /// Reads an accessor as f32 components, applying glTF's normalisation for normalized integers.
    fn read_accessor(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<f32>> {
        let raw = self.read_raw(acc, context)?;
        let data_type = acc.data_type();
        if !acc.normalized() || data_type == DataType::F32 {
            return Ok(raw.into_iter().map(|v| v as f32).collect());
        }
        // glTF 2.0 §3.11 "Animations"/"Meshes": normalized integer decoding.
        let scale = match data_type {
            DataType::U8 => 255.0,
            DataType::U16 => 65535.0,
            DataType::I8 => 127.0,
            DataType::I16 => 32767.0,
            DataType::U32 | DataType::F32 => 1.0,
        };
        Ok(raw.into_iter().map(|v| ((v / scale) as f32).max(-1.0)).collect())
    }

    /// Reads `count × components` raw values (f64 holds every glTF component type exactly), dense part then
    /// sparse substitutions, with every offset checked against the buffer.
    fn read_raw(&self, acc: &gltf::Accessor<'_>, context: &str) -> Result<Vec<f64>> {
        let data_type = acc.data_type();
        let components = acc.dimensions().multiplicity();
        let component_size = data_type.size();
        let element_size = components * component_size;
        let count = acc.count();
        // Charged per read, not per accessor: 50 nodes sharing one accessor read it 50 times.
        self.budget.charge_items(
            self.path,
            || format!("{context} ({count} × {components} components)"),
            (count as u64).saturating_mul(components as u64),
            BYTES_PER_COMPONENT,
        )?;
        let mut out = match acc.view() {
            Some(view) => {
                let stride = view.stride().unwrap_or(element_size);
                if stride < element_size {
                    return Err(self.data_err(
                        context,
                        format!("byteStride {stride} is smaller than the element size {element_size}"),
                    ));
                }
                let bytes = self.view_bytes(&view, context)?;
                read_elements(bytes, acc.offset(), count, stride, data_type, components).ok_or_else(|| {
                    self.data_err(
                        context,
                        format!(
                            "{count} elements at offset {} overrun buffer view {} ({} bytes)",
                            acc.offset(),
                            view.index(),
                            bytes.len()
                        ),
                    )
                })?
            }
            // All zeros plus sparse values: costs memory without costing file size, hence the charge above.
            None => vec![0.0; count * components],
        };
        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            let indices = sparse.indices();
            let index_type = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let index_bytes = self.view_bytes(&indices.view(), context)?;
            let targets = read_elements(index_bytes, indices.offset(), n, index_type.size(), index_type, 1)
                .ok_or_else(|| self.data_err(context, "sparse indices overrun their buffer view"))?;
            let values = sparse.values();
            let value_bytes = self.view_bytes(&values.view(), context)?;
            let new = read_elements(value_bytes, values.offset(), n, element_size, data_type, components)
                .ok_or_else(|| self.data_err(context, "sparse values overrun their buffer view"))?;
            for (k, target) in targets.iter().enumerate() {
                let t = *target as usize;
                if t >= count {
                    return Err(Error::IndexOutOfRange {
                        path: self.path.to_path_buf(),
                        context: format!("{context} sparse"),
                        index: *target as u64,
                        vertex_count: count,
                    });
                }
                out[t * components..(t + 1) * components].copy_from_slice(&new[k * components..(k + 1) * components]);
            }
        }
        Ok(out)
    }

    fn view_bytes(&self, view: &gltf::buffer::View<'_>, context: &str) -> Result<&[u8]> {
        let buffer = self
            .buffers
            .get(view.buffer().index())
            .ok_or_else(|| self.data_err(context, format!("buffer {} is missing", view.buffer().index())))?;
        view.offset().checked_add(view.length()).and_then(|end| buffer.get(view.offset()..end)).ok_or_else(|| {
            self.data_err(
                context,
                format!(
                    "buffer view {} ({} bytes at {}) overruns its buffer ({} bytes)",
                    view.index(),
                    view.length(),
                    view.offset(),
                    buffer.len()
                ),
            )
        })
    }
}

/// Triangles of a mesh's triangle primitives, from the accessor counts (before anything is read).
fn triangle_estimate(mesh: &gltf::Mesh<'_>) -> u64 {
    mesh.primitives()
        .map(|p| {
            let vertices = p.get(&Semantic::Positions).map_or(0, |a| a.count() as u64);
            let listed = p.indices().map_or(vertices, |a| a.count() as u64);
            match p.mode() {
                Mode::Triangles => listed / 3,
                Mode::TriangleStrip | Mode::TriangleFan => listed.saturating_sub(2),
                _ => 0,
            }
        })
        .sum()
}

/// Reads `count` elements of `components` values each; `None` when any byte lies outside `bytes`.
fn read_elements(
    bytes: &[u8],
    offset: usize,
    count: usize,
    stride: usize,
    data_type: DataType,
    components: usize,
) -> Option<Vec<f64>> {
    if count == 0 {
        return Some(Vec::new());
    }
    let size = data_type.size();
    let last = offset.checked_add((count - 1).checked_mul(stride)?)?.checked_add(components.checked_mul(size)?)?;
    if last > bytes.len() {
        return None;
    }
    let mut out = Vec::with_capacity(count * components);
    for e in 0..count {
        let start = offset + e * stride;
        for c in 0..components {
            let at = start + c * size;
            let b = bytes.get(at..at + size)?;
            // glTF binary data is little-endian (glTF 2.0 §3.6.2).
            let v = match data_type {
                DataType::I8 => f64::from(i8::from_le_bytes([b[0]])),
                DataType::U8 => f64::from(b[0]),
                DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
                DataType::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
                DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            };
            out.push(v);
        }
    }
    Some(out)
}

/// Triangles from an index list in the given mode (strips and fans triangulated, glTF 2.0 §3.7.2.1).
fn triangulate(mode: Mode, list: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => (0..list.len().saturating_sub(2))
            .map(|i| if i % 2 == 0 { [list[i], list[i + 1], list[i + 2]] } else { [list[i + 1], list[i], list[i + 2]] })
            .collect(),
        Mode::TriangleFan => (1..list.len().saturating_sub(1)).map(|i| [list[0], list[i], list[i + 1]]).collect(),
        _ => list.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// The raw `extras` JSON, if any and valid.
/// `KHR_texture_transform` of a texture reference, with its `texCoord` override.
fn transform(info: &gltf::texture::Info<'_>) -> Option<(TextureTransform, Option<u32>)> {
    info.texture_transform()
        .map(|t| (TextureTransform { offset: t.offset(), rotation: t.rotation(), scale: t.scale() }, t.tex_coord()))
}

/// `KHR_texture_transform` from its JSON (normal textures expose only the raw extension map); glTF's
/// defaults where a member is missing or malformed.
fn transform_value(value: &serde_json::Value) -> Option<(TextureTransform, Option<u32>)> {
    let pair = |key: &str, default: [f32; 2]| {
        value
            .get(key)
            .and_then(|v| v.as_array())
            .and_then(|a| Some([a.first()?.as_f64()? as f32, a.get(1)?.as_f64()? as f32]))
            .unwrap_or(default)
    };
    let rotation = value.get("rotation").and_then(serde_json::Value::as_f64).unwrap_or(0.0) as f32;
    let set = value.get("texCoord").and_then(serde_json::Value::as_u64).and_then(|s| u32::try_from(s).ok());
    Some((TextureTransform { offset: pair("offset", [0.0, 0.0]), rotation, scale: pair("scale", [1.0, 1.0]) }, set))
}

fn extras_value(extras: &gltf::json::Extras) -> Option<serde_json::Value> {
    extras.as_ref().and_then(|raw| serde_json::from_str(raw.get()).ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every perspective camera is kept with its name (`--camera N|NAME` chooses); the first is
    /// the default; an unnamed camera takes its node's name, else its rank.
    #[test]
    fn glb_header_shorter_than_itself_is_a_clear_error() {
        // `fuzz/regressions/glb/glb_header_length_below_12.glb`: magic, version 2, length 0.
        let mut bytes = b"glTF".to_vec();
        bytes.extend_from_slice(&2u32.to_le_bytes());
        bytes.extend_from_slice(&[0; 40]);
        let budget = Budget::new(crate::LoadOptions::default());
        match load_gltf_slice(&bytes, None, Path::new("bad.glb"), &budget) {
            Err(e @ Error::GltfData { .. }) => assert!(e.to_string().contains("GLB header"), "{e}"),
            other => panic!("expected a GLB header error, got {other:?}"),
        }
    }

    #[test]
    fn textures_are_transcribed_with_sampler_transform_and_alpha() {
        // A 1×1 PNG in a data URI would need an encoder here; the loader reads but never decodes, so
        // any bytes do: "AAEC" is base64 for [0, 1, 2].
        let json = br#"{"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_texture_transform", "KHR_materials_pbrSpecularGlossiness"],
            "extensionsRequired": ["KHR_texture_transform", "KHR_materials_pbrSpecularGlossiness", "KHR_materials_unlit"],
            "images": [{"uri": "data:image/png;base64,AAEC"}],
            "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}],
            "textures": [{"source": 0, "sampler": 0}],
            "materials": [
              {"name": "a", "alphaMode": "MASK", "alphaCutoff": 0.3,
               "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.5], "baseColorTexture": {"index": 0, "texCoord": 1,
                 "extensions": {"KHR_texture_transform": {"offset": [0.25, 0], "rotation": 0.5, "scale": [2, 3], "texCoord": 0}}}},
               "normalTexture": {"index": 0, "scale": 0.7}},
              {"name": "flat", "extensions": {"KHR_materials_unlit": {}}},
              {"name": "sg", "extensions": {"KHR_materials_pbrSpecularGlossiness": {"diffuseFactor": [0.2, 0.4, 0.6, 0.9], "glossinessFactor": 0.75, "diffuseTexture": {"index": 0}}}}]}"#;
        let budget = Budget::new(crate::LoadOptions::default());
        let d = load_gltf_slice(json, None, Path::new("t.gltf"), &budget).unwrap_or_else(|e| panic!("{e}"));
        // One image however many textures use it, bytes as decoded from the URI (`gltf` pads decoded
        // data to four bytes, which image decoders ignore).
        assert_eq!(d.images.len(), 1);
        assert_eq!(&d.images[0].bytes[..3], &[0, 1, 2]);
        let a = &d.materials[0];
        let base = a.textures.base_color.as_ref().expect("base colour texture");
        assert_eq!(base.tex_coord, 0, "the transform's texCoord overrides the texture's");
        assert_eq!(base.wrap, [WrapMode::ClampToEdge, WrapMode::MirroredRepeat]);
        assert!(base.nearest);
        assert_eq!(base.transform, Some(TextureTransform { offset: [0.25, 0.0], rotation: 0.5, scale: [2.0, 3.0] }));
        assert_eq!(a.textures.normal.as_ref().map(|t| t.scale), Some(0.7));
        assert_eq!(a.alpha_mode, Some(AlphaMode::Mask(0.3)));
        assert_eq!(a.alpha, Some(0.5));
        // Specular-glossiness: diffuse → base colour, roughness = 1 − glossiness, metallic 0, and a warning.
        assert!(d.warnings.iter().any(|w| w.contains("material 'flat': KHR_materials_unlit is shaded as a lit")));
        let sg = &d.materials[2];
        assert_eq!(sg.base_color, Some(SpectrumDesc::Rgb([0.2, 0.4, 0.6])));
        assert_eq!((sg.roughness, sg.metallic, sg.alpha), (Some(0.25), Some(0.0), Some(0.9)));
        assert_eq!(sg.textures.base_color.as_ref().map(|t| t.image), Some(0));
        assert!(d.warnings.iter().any(|w| w.contains("material 'sg': KHR_materials_pbrSpecularGlossiness converted")));
    }

    /// The writer's name is transcribed for the layers above (Blender's exporter has unit habits of its own);
    /// a file that names none has none.
    #[test]
    fn the_generator_is_transcribed() {
        let budget = Budget::new(crate::LoadOptions::default());
        let named = br#"{"asset": {"version": "2.0", "generator": "Khronos glTF Blender I/O v4.0.44"}}"#;
        let d = load_gltf_slice(named, None, Path::new("t.gltf"), &budget).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.generator.as_deref(), Some("Khronos glTF Blender I/O v4.0.44"));
        let anonymous = br#"{"asset": {"version": "2.0"}}"#;
        let d = load_gltf_slice(anonymous, None, Path::new("t.gltf"), &budget).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.generator, None);
    }

    #[test]
    fn every_camera_is_kept_with_its_name() {
        let json = br#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
            "nodes": [{"camera": 0, "translation": [0, 0, 5]}, {"camera": 1, "name": "side", "translation": [4, 0, 0]},
                      {"camera": 2, "translation": [0, 3, 0]}],
            "cameras": [{"type": "perspective", "name": "front", "perspective": {"yfov": 0.5, "znear": 0.1}},
                        {"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1}},
                        {"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1}}]}"#;
        let budget = Budget::new(crate::LoadOptions::default());
        let d = load_gltf_slice(json, None, Path::new("cams.gltf"), &budget).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = d.cameras.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["front", "side", "camera 2"]);
        assert_eq!(d.cameras[1].1.position, Vec3::new(4.0, 0.0, 0.0));
        assert!((d.cameras[2].1.vfov_deg - 0.9f32.to_degrees()).abs() < 1e-4);
        assert_eq!(d.camera.as_ref(), Some(&d.cameras[0].1));
    }

    #[test]
    fn strips_and_fans_triangulate_with_consistent_winding() {
        assert_eq!(triangulate(Mode::TriangleStrip, &[0, 1, 2, 3]), vec![[0, 1, 2], [2, 1, 3]]);
        assert_eq!(triangulate(Mode::TriangleFan, &[0, 1, 2, 3]), vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(triangulate(Mode::Triangles, &[0, 1, 2, 3]), vec![[0, 1, 2]]);
        assert!(triangulate(Mode::TriangleStrip, &[0, 1]).is_empty());
    }

    #[test]
    fn percent_decode_handles_escapes_and_rejects_garbage() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("%FF"), None);
        assert_eq!(percent_decode("%2"), None);
        assert_eq!(percent_decode("%zz"), None);
    }

    #[test]
    fn read_elements_checks_bounds_and_decodes_little_endian() {
        let bytes: Vec<u8> = [1.0f32, 2.0, 3.0].iter().flat_map(|f| f.to_le_bytes()).collect();
        assert_eq!(read_elements(&bytes, 0, 1, 12, DataType::F32, 3), Some(vec![1.0, 2.0, 3.0]));
        assert_eq!(read_elements(&bytes, 4, 1, 12, DataType::F32, 3), None);
        assert_eq!(read_elements(&bytes, 0, usize::MAX, 12, DataType::F32, 3), None);
    }
}
