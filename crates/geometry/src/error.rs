//! Errors of the geometry crate. Loader variants name the file (and line where known).
use std::path::PathBuf;
/// What can go wrong building or loading geometry.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Mesh or sphere data that cannot be rendered (NaN/Inf, indices out of range, …).
    #[error("invalid geometry: {0}")]
    Invalid(String),
    /// A camera that cannot be built.
    #[error("invalid camera: {0}")]
    Camera(String),
    // --- loaders ---
    /// A scene file could not be read.
    #[error("{}: cannot read: {cause}", path.display())]
    ReadFile {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
    },
    /// A file that a scene file refers to (a buffer, a spectrum CSV, a mesh) could not be read.
    #[error("{}: cannot read {}: {cause}", path.display(), file.display())]
    ReadReferenced {
        /// The scene file that refers to it.
        path: PathBuf,
        /// The file referred to.
        file: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
    },
    /// `load_scene` was given a file with an extension it does not know.
    #[error("{}: unsupported scene format `.{extension}` (expected .json, .gltf, .glb or .obj)", path.display())]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
        /// Its extension, lowercased (empty if none).
        extension: String,
    },
    /// `--frame` or `--set` was given for a glTF or OBJ file: they change a manifest's document.
    #[error(
        "{}: --frame and --set change a manifest (.json); include the file from a manifest (an object of type \"mesh\") and vary that",
        path.display()
    )]
    VariationNeedsManifest {
        /// The file.
        path: PathBuf,
    },
    /// The `gltf` crate rejected the file (JSON syntax, GLB framing, validation).
    #[error("{}: {cause}", path.display())]
    Gltf {
        /// The file.
        path: PathBuf,
        /// The `gltf` crate's error.
        cause: gltf::Error,
    },
    /// An external glTF buffer file could not be read.
    #[error("{}: buffer {buffer}: cannot read `{uri}`: {cause}", path.display())]
    GltfBuffer {
        /// The glTF file.
        path: PathBuf,
        /// Index of the buffer in the file.
        buffer: usize,
        /// The buffer's resolved file path.
        uri: String,
        /// The I/O error.
        cause: std::io::Error,
    },
    /// glTF binary data is inconsistent (accessor overruns its view, wrong accessor type, bad hierarchy).
    #[error("{}: {context}: {message}", path.display())]
    GltfData {
        /// The file.
        path: PathBuf,
        /// Where in the file (e.g. `meshes[0] primitive 1 POSITION`).
        context: String,
        /// What is wrong.
        message: String,
    },
    /// The file requires a glTF extension this loader does not read.
    #[error("{}: requires unsupported glTF extension `{extension}` (supported: {supported})", path.display())]
    UnsupportedExtension {
        /// The file.
        path: PathBuf,
        /// The required extension.
        extension: String,
        /// The extensions the loader reads.
        supported: String,
    },
    /// A vertex position is NaN or infinite.
    #[error("{}: {context}: vertex {vertex} is not finite ({value:?})", path.display())]
    NonFiniteVertex {
        /// The file.
        path: PathBuf,
        /// Where in the file (mesh/primitive or line).
        context: String,
        /// Index of the vertex.
        vertex: usize,
        /// Its coordinates.
        value: [f32; 3],
    },
    /// A face or accessor index points past the end of the vertex data.
    #[error("{}: {context}: index {index} out of range (vertex count {vertex_count})", path.display())]
    IndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// Where in the file.
        context: String,
        /// The offending index as written.
        index: u64,
        /// Number of elements it may address.
        vertex_count: usize,
    },
    /// `tobj` rejected an OBJ file.
    #[error("{}: invalid OBJ: {cause}", path.display())]
    Obj {
        /// The file.
        path: PathBuf,
        /// `tobj`'s error.
        cause: tobj::LoadError,
    },
    /// A syntax error in an OBJ or MTL file, found by the pre-scan.
    #[error("{}:{line}: {message}", path.display())]
    ObjSyntax {
        /// The OBJ or MTL file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A photometric file (IES LM-63, EULUMDAT) that cannot be read as a goniometric web.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Photometric {
        /// The `.ies` or `.ldt` file.
        path: PathBuf,
        /// 1-based line number, where the fault has one.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// Geometry read from a file was rejected by the mesh constructor.
    #[error("{}: {context}: {cause}", path.display())]
    InvalidGeometry {
        /// The file.
        path: PathBuf,
        /// Where in the file.
        context: String,
        /// The constructor's error.
        cause: Box<Error>,
    },
    /// A third-party parser panicked on this input (a bug to report upstream; turned into an error).
    #[error("{}: the {library} parser panicked: {message}", path.display())]
    ParserPanic {
        /// The file.
        path: PathBuf,
        /// `gltf` or `tobj`.
        library: &'static str,
        /// The panic message.
        message: String,
    },
    /// A scene manifest is not valid JSON or has an unknown key (the message names it, with line and column).
    #[error("{origin}: {cause}")]
    ManifestSyntax {
        /// The manifest's path or name.
        origin: String,
        /// serde_json's error, with line and column.
        cause: serde_json::Error,
    },
    /// A manifest value is out of range or of the wrong form.
    #[error("{origin}: {context}: {message}")]
    ManifestValue {
        /// The manifest's path or name.
        origin: String,
        /// Path of the value in the document, e.g. `materials.glass.ior`.
        context: String,
        /// What is wrong.
        message: String,
    },
    /// An object names a material the manifest does not define.
    #[error("{origin}: {context}: material `{name}` is not defined (defined: {available})")]
    MissingMaterial {
        /// The manifest's path or name.
        origin: String,
        /// The missing material's name.
        name: String,
        /// Where it is referenced, e.g. `objects[3]`.
        context: String,
        /// The defined material names, comma-separated.
        available: String,
    },
    /// Loading the scene would pass its memory budget ([`crate::LoadOptions::max_memory`]); checked before
    /// allocating.
    #[error(
        "{}: {what} needs {requested} bytes, over the scene's memory budget ({used} of {limit} bytes used; raise it with --max-memory)",
        path.display()
    )]
    OverBudget {
        /// The file being loaded.
        path: PathBuf,
        /// What would be allocated (e.g. `meshes[0] primitive 0 POSITION`).
        what: String,
        /// Bytes it would take.
        requested: u64,
        /// Bytes charged so far.
        used: u64,
        /// The budget.
        limit: u64,
    },
    /// A referenced file is not a regular file (a device, FIFO or directory).
    #[error("{}: `{}` is not a regular file", path.display(), file.display())]
    NotRegularFile {
        /// The file that refers to it.
        path: PathBuf,
        /// The referenced file.
        file: PathBuf,
    },
    /// A referenced file is larger than allowed.
    #[error("{}: `{}` has {size} bytes, more than the limit of {limit}", path.display(), file.display())]
    FileTooLarge {
        /// The file that refers to it.
        path: PathBuf,
        /// The referenced file.
        file: PathBuf,
        /// Its size.
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// A scene refers to a file by absolute path and [`crate::LoadOptions::allow_absolute_paths`] is off.
    #[error(
        "{}: refers to `{reference}` by absolute path; scene files must use paths relative to their folder (or allow absolute paths with --allow-absolute-paths)",
        path.display()
    )]
    AbsolutePath {
        /// The file that refers to it.
        path: PathBuf,
        /// The path as written.
        reference: String,
    },
    /// A coordinate is not finite or too large for the BVH build and the renderer's f32 arithmetic (one rule
    /// for meshes, quads and spheres).
    #[error(
        "{}: {context}: vertex {vertex} at {value:?} is not finite or beyond ±{limit:e} (the largest coordinate supported)",
        path.display()
    )]
    CoordinateTooLarge {
        /// The file.
        path: PathBuf,
        /// The object (mesh, primitive, manifest object).
        context: String,
        /// Index of the offending point: a mesh's vertex, a quad's corner (0–3 as `corner`, `+ edge_u`,
        /// `+ edge_u + edge_v`, `+ edge_v`), or a corner of a sphere's bounding box (0: centre − radius,
        /// 1: centre + radius).
        vertex: usize,
        /// Its coordinates.
        value: [f32; 3],
        /// [`crate::MAX_COORDINATE`].
        limit: f32,
    },
    /// A file has no geometry to render.
    #[error("{}: nothing to render: no geometry (no triangle or sphere could be read{detail})", path.display())]
    NoGeometry {
        /// The file.
        path: PathBuf,
        /// More about why (e.g. `; 3 lines were not OBJ statements`), or empty.
        detail: String,
    },
    /// A mesh file a manifest object includes could not be loaded.
    #[error("{origin}: {context}: {cause}")]
    IncludedFile {
        /// The manifest's path or name.
        origin: String,
        /// The object, e.g. `objects[3]`.
        context: String,
        /// The included file's error (it names that file). Part of the message, so not named `source`:
        /// thiserror would make it the error's source too, and a report that walks the chain (anyhow's
        /// `{:#}`) would state it twice.
        cause: Box<Error>,
    },
    // LOADERS-END
}
/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
