//! What a scene file may cost: the per-scene memory budget, the rules for files a scene refers to, the
//! coordinate range the BVH build accepts, and the panic guard around third-party parsers.
//!
//! Every loader charges the budget **before** it allocates, so a small file that claims a large amount of
//! data (a 1 KB glTF whose 50 nodes share one huge accessor, a view-less accessor of 10⁹ zeros) is refused
//! with an error naming the file and the budget, never by the allocator aborting the process. The budget
//! is per scene: a manifest and every file it includes share one.

use std::cell::Cell;
use std::path::{Component, Path, PathBuf};

use glam::Vec3;

use crate::error::{Error, Result};

/// Default [`LoadOptions::max_memory`]: 8 GiB. Far above any committed or hand-made scene (the largest,
/// a 2 M-triangle mesh, is charged ≈ 0.6 GB), below the memory of the machines the project targets, so a
/// hostile file is refused before the operating system has to kill the process.
pub const DEFAULT_MAX_MEMORY: u64 = 8 << 30;

/// Largest magnitude of a coordinate the loaders accept (scene units). obvhs's build panics once spans
/// reach ≈ 1e25 (issue 16), and the watertight test's products and the default light's intensity (the
/// square of ten bounding radii) must stay finite in f32 (max ≈ 3.4e38): 1e18 leaves a margin for both.
pub const MAX_COORDINATE: f32 = 1e18;

/// Largest spectrum CSV a scene may refer to. A 1 nm table from 300 to 830 nm with a dozen columns is
/// ≈ 50 KB; 16 MiB leaves room for any measured data while keeping the CSV parser's working set small.
pub(crate) const MAX_SPECTRUM_FILE_BYTES: u64 = 16 << 20;

/// Largest photometric file (IES, LDT) a scene may refer to. A full 0.5° web (721 × 361 values) written
/// as text is ≈ 2 MB; real files are a few KB to a few hundred.
pub(crate) const MAX_PHOTOMETRIC_FILE_BYTES: u64 = 8 << 20;

/// Most intensities a goniometric web may have (C planes × vertical angles, after its symmetry is
/// expanded): a full 0.25° web is ≈ 1.04 M; checked on the counts a file claims, before anything is allocated.
pub(crate) const MAX_WEB_VALUES: u64 = 1 << 21;

/// Memory charged per intensity of a web: the value and its angles as read (≈ 12 B), the renderer's
/// expanded copy and its sampling distribution (≈ 20 B, and as much again of headroom).
pub(crate) const BYTES_PER_WEB_VALUE: u64 = 64;

/// Memory charged per triangle that reaches the renderer: its indices in the mesh (12 B), what the
/// scene keeps of it (≈ 60 B: its share of the wide nodes and of the leaves, a 40-byte single or a
/// share of a 160-byte four-triangle packet), and the build's transient peak (padded bounds, obvhs's
/// Morton codes and binary nodes, the collapse's cost tables). Measured with a counting allocator
/// on 1M-triangle meshes (a terrain and two triangle soups), session 14: peak 320 B per triangle
/// above the mesh (372 B with obvhs's CWBVH before), kept 59–62 B (64 B before). So a mesh at this
/// charge's limit can transiently need ≈ 25 % more than charged; the charge bounds hostile files,
/// not exact use.
pub(crate) const BYTES_PER_TRIANGLE: u64 = 256;

/// Memory charged per vertex: position, normal and UV (32 B), twice (the file's copy and the world-space
/// copy a node or manifest transform makes).
pub(crate) const BYTES_PER_VERTEX: u64 = 64;

/// What a mesh of `vertices` vertices and `triangles` triangles is charged ([`BYTES_PER_VERTEX`],
/// [`BYTES_PER_TRIANGLE`]), saturating. One formula for every loader, so that the plain-OBJ fast path
/// refuses exactly what the checked path refuses.
pub(crate) fn mesh_charge(vertices: u64, triangles: u64) -> u64 {
    vertices.saturating_mul(BYTES_PER_VERTEX).saturating_add(triangles.saturating_mul(BYTES_PER_TRIANGLE))
}

/// How much a scene may cost to load, which files it may refer to, and what to change in a manifest.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoadOptions {
    /// Upper bound on the memory a scene's data may take (bytes): files read, decoded accessors, vertices and
    /// triangles (with their share of the BVH). Default [`DEFAULT_MAX_MEMORY`].
    pub max_memory: u64,
    /// Whether a scene may refer to files by absolute path (`"file": "/data/mesh.obj"`, a buffer URI
    /// `file:///…`, `mtllib /…`). Off by default: a scene is a folder that can be moved or shared, and a
    /// file it did not come with is more likely a mistake (or a probe) than intended.
    pub allow_absolute_paths: bool,
    /// A mesh placed several times (glTF nodes sharing a mesh, `EXT_mesh_gpu_instancing`) is copied into
    /// world space per placement while the copies beyond the first add at most this many triangles;
    /// beyond, it is kept once and placed by transforms (a two-level BVH). Default
    /// [`DEFAULT_FLATTEN_TRIANGLES`].
    pub flatten_triangles: u64,
    /// `--frame` and `--set`: changes to a manifest's document before it is read (a glTF or OBJ file
    /// given them is refused: [`crate::Error::VariationNeedsManifest`]).
    pub variation: crate::overrides::Variation,
}

/// Default [`LoadOptions::flatten_triangles`]: 2²⁰ extra triangles (≈ 256 MiB at [`BYTES_PER_TRIANGLE`]).
/// Below it, world-space copies cost little memory and keep the faster one-level traversal; above, the
/// two-level BVH keeps memory in proportion to the distinct meshes (10⁴ placements of a 100k-triangle
/// mesh: 10⁹ triangles, 256 GB as copies, ~30 MB as instances).
pub const DEFAULT_FLATTEN_TRIANGLES: u64 = 1 << 20;

/// Bytes charged per placement of an instanced mesh: its transforms (object to world, world to object,
/// the normal matrix: 136 bytes) and its share of the top-level BVH, rounded up.
pub(crate) const BYTES_PER_INSTANCE: u64 = 512;

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            max_memory: DEFAULT_MAX_MEMORY,
            allow_absolute_paths: false,
            flatten_triangles: DEFAULT_FLATTEN_TRIANGLES,
            variation: crate::overrides::Variation::default(),
        }
    }
}

/// What a loaded scene has been charged and its budget ([`LoadOptions::max_memory`]), carried in the
/// [`crate::SceneDescription`]: the loaders charge what they allocate, the assembly step charges what it
/// decodes afterwards (texture images, an environment map) against the same budget, before decoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    /// Bytes charged so far.
    pub used: u64,
    /// The budget (bytes).
    pub limit: u64,
}

impl MemoryBudget {
    /// Nothing charged yet, of `limit` bytes.
    pub fn new(limit: u64) -> Self {
        Self { used: 0, limit }
    }

    /// Charges `bytes` for `what` (e.g. `decoding a 4096×4096 image`) of `path` (the file or image it
    /// comes from), or refuses with [`Error::OverBudget`] when that would pass the limit; a refused
    /// charge is not counted.
    pub fn charge(&mut self, path: &Path, what: impl FnOnce() -> String, bytes: u64) -> Result<()> {
        self.fits(path, what, bytes)?;
        self.used = self.used.saturating_add(bytes);
        Ok(())
    }

    /// Checks that `bytes` more would fit without charging them: for working memory that is freed
    /// again before the next charge (a decoder's output before conversion, a hash table while
    /// counting colours).
    pub fn fits(&self, path: &Path, what: impl FnOnce() -> String, bytes: u64) -> Result<()> {
        if self.used.saturating_add(bytes) > self.limit {
            return Err(Error::OverBudget {
                path: path.to_path_buf(),
                what: what(),
                requested: bytes,
                used: self.used,
                limit: self.limit,
            });
        }
        Ok(())
    }
}

impl Default for MemoryBudget {
    /// Nothing charged, of [`DEFAULT_MAX_MEMORY`] (a description built in code).
    fn default() -> Self {
        Self::new(DEFAULT_MAX_MEMORY)
    }
}

/// The running cost of one scene load, checked against [`LoadOptions`].
#[derive(Debug)]
pub(crate) struct Budget {
    pub(crate) options: LoadOptions,
    used: Cell<u64>,
    /// (length, XXH64) of every file read, in order: the scene's content digest.
    sources: std::cell::RefCell<Vec<(u64, u64)>>,
    /// Every file read or checked to be read later (spectrum CSVs, an environment map), in order:
    /// what a render must not write over.
    files: std::cell::RefCell<Vec<PathBuf>>,
}

impl Budget {
    pub(crate) fn new(options: LoadOptions) -> Self {
        Self {
            options,
            used: Cell::new(0),
            sources: std::cell::RefCell::new(Vec::new()),
            files: std::cell::RefCell::new(Vec::new()),
        }
    }

    /// A budget with the default memory limit that also allows absolute paths (for unit tests, whose inputs
    /// may name files by absolute path).
    #[cfg(test)]
    pub(crate) fn allowing_absolute_paths() -> Self {
        Self::new(LoadOptions { allow_absolute_paths: true, ..LoadOptions::default() })
    }

    /// Bytes charged so far.
    #[cfg(test)]
    pub(crate) fn used(&self) -> u64 {
        self.used.get()
    }

    /// Charges `bytes` for `what` in `path`, or refuses when that would pass the budget.
    pub(crate) fn charge(&self, path: &Path, what: impl FnOnce() -> String, bytes: u64) -> Result<()> {
        let mut memory = self.memory();
        memory.charge(path, what, bytes)?;
        self.used.set(memory.used);
        Ok(())
    }

    /// What has been charged so far, and the limit: handed on to the assembly step.
    pub(crate) fn memory(&self) -> MemoryBudget {
        MemoryBudget { used: self.used.get(), limit: self.options.max_memory }
    }

    /// Charges `count` items of `each` bytes (saturating, so a claimed count near `usize::MAX` is refused).
    pub(crate) fn charge_items(&self, path: &Path, what: impl FnOnce() -> String, count: u64, each: u64) -> Result<()> {
        self.charge(path, what, count.saturating_mul(each))
    }

    /// Resolves a file a scene refers to, as written (`reference`), against `base`: refuses absolute paths
    /// unless allowed. `referrer` is the file that names it.
    pub(crate) fn resolve(&self, referrer: &Path, base: &Path, reference: &str) -> Result<PathBuf> {
        let written = Path::new(reference);
        let absolute = written.is_absolute() || written.components().any(|c| matches!(c, Component::Prefix(_)));
        if absolute && !self.options.allow_absolute_paths {
            return Err(Error::AbsolutePath { path: referrer.to_path_buf(), reference: reference.to_owned() });
        }
        Ok(base.join(written))
    }

    /// Reads a file a scene refers to (or the scene file itself): it must be a regular file (no device, FIFO
    /// or directory: `/dev/zero` would never end) that fits in what is left of the budget, which is charged
    /// its size before reading.
    pub(crate) fn read(&self, referrer: &Path, file: &Path) -> Result<Vec<u8>> {
        let size = self.check_file(referrer, file, u64::MAX)?;
        self.charge(referrer, || format!("reading {}", file.display()), size)?;
        let bytes = std::fs::read(file).map_err(|cause| Error::ReadFile { path: file.to_path_buf(), cause })?;
        // The file may have grown between the check and the read; charge the difference.
        let extra = (bytes.len() as u64).saturating_sub(size);
        self.charge(referrer, || format!("reading {}", file.display()), extra)?;
        self.record(&bytes);
        Ok(bytes)
    }

    /// Adds `bytes` (a file read, or a manifest given as text) to the scene's content digest.
    pub(crate) fn record(&self, bytes: &[u8]) {
        self.sources.borrow_mut().push((bytes.len() as u64, crate::hash::xxh64(bytes, 0)));
    }

    /// The digest of everything recorded: XXH64 over each input's length and digest, in the
    /// order read. Paths are left out, so a scene folder moved or copied to another machine
    /// keeps its digest; any changed byte of any file changes it.
    pub(crate) fn content_hash(&self) -> u64 {
        let bytes: Vec<u8> =
            self.sources.borrow().iter().flat_map(|(n, h)| [n.to_le_bytes(), h.to_le_bytes()]).flatten().collect();
        crate::hash::xxh64(&bytes, 0)
    }

    /// The files read or checked so far ([`Budget::check_file`]), each once, in the order first met.
    pub(crate) fn files(&self) -> Vec<PathBuf> {
        self.files.borrow().clone()
    }

    /// Checks that `file` is a regular file of at most `max_bytes` (without reading it); returns its size.
    pub(crate) fn check_file(&self, referrer: &Path, file: &Path, max_bytes: u64) -> Result<u64> {
        // A file the scene refers to names the scene file too: which file asked for it.
        let meta = std::fs::metadata(file).map_err(|cause| {
            if referrer == file {
                Error::ReadFile { path: file.to_path_buf(), cause }
            } else {
                Error::ReadReferenced { path: referrer.to_path_buf(), file: file.to_path_buf(), cause }
            }
        })?;
        if !meta.is_file() {
            return Err(Error::NotRegularFile { path: referrer.to_path_buf(), file: file.to_path_buf() });
        }
        let limit = max_bytes.min(self.options.max_memory);
        if meta.len() > limit {
            return Err(Error::FileTooLarge {
                path: referrer.to_path_buf(),
                file: file.to_path_buf(),
                size: meta.len(),
                limit,
            });
        }
        // Every file a loader reads passes here first (`read` too), so this is the list of inputs.
        let mut files = self.files.borrow_mut();
        if !files.iter().any(|f| f == file) {
            files.push(file.to_path_buf());
        }
        Ok(meta.len())
    }
}

/// The first point with a coordinate that is not finite or beyond [`MAX_COORDINATE`] (index and value), if
/// any. Written as "not all within" rather than "any beyond": NaN compares false with everything, and a
/// transform can make one from finite inputs (∞ − ∞).
fn first_far_point(points: &[Vec3]) -> Option<(usize, Vec3)> {
    let limit = Vec3::splat(MAX_COORDINATE);
    points.iter().position(|p| !p.abs().cmple(limit).all()).map(|i| (i, points[i]))
}

/// The coordinate rule of every object: refuses the points of an object of `path` (a mesh's vertices, a
/// quad's corners, a sphere's bounding-box corners; `context` names it) when one is not finite or beyond
/// [`MAX_COORDINATE`], with [`Error::CoordinateTooLarge`].
pub(crate) fn check_coordinates(points: &[Vec3], path: &Path, context: &str) -> Result<()> {
    match first_far_point(points) {
        None => Ok(()),
        Some((vertex, value)) => Err(Error::CoordinateTooLarge {
            path: path.to_path_buf(),
            context: context.to_owned(),
            vertex,
            value: value.to_array(),
            limit: MAX_COORDINATE,
        }),
    }
}

/// Runs a third-party parser, turning a panic inside it into [`Error::ParserPanic`] so no input can crash
/// the program. Our own code must not rely on this: the loaders validate before calling (see the fuzz tests,
/// which fail on this variant).
pub(crate) fn guard_panic<T>(path: &Path, library: &'static str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_owned());
            Err(Error::ParserPanic { path: path.to_path_buf(), library, message })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budget_refuses_before_passing_the_limit_and_names_the_file() {
        let b = Budget::new(LoadOptions { max_memory: 100, ..LoadOptions::default() });
        assert!(b.charge(Path::new("a.gltf"), || "x".into(), 60).is_ok());
        let e = b.charge(Path::new("a.gltf"), || "accessor 3".into(), 41).err().map(|e| e.to_string());
        let e = e.unwrap_or_default();
        assert!(e.contains("a.gltf") && e.contains("accessor 3") && e.contains("100"), "{e}");
        // The refused charge is not counted.
        assert_eq!(b.used(), 60);
        assert!(b.charge_items(Path::new("a"), || "n".into(), u64::MAX, 12).is_err());
    }

    #[test]
    fn devices_directories_and_absolute_paths_are_refused() {
        let b = Budget::new(LoadOptions::default());
        let referrer = Path::new("scene.json");
        let dev = b.read(referrer, Path::new("/dev/zero")).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(dev.contains("/dev/zero") && dev.contains("regular file"), "{dev}");
        assert!(b.read(referrer, Path::new("/")).is_err());
        let abs = b.resolve(referrer, Path::new("."), "/etc/hostname").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(abs.contains("scene.json") && abs.contains("/etc/hostname"), "{abs}");
        let allowed = Budget::new(LoadOptions { allow_absolute_paths: true, ..LoadOptions::default() });
        assert_eq!(allowed.resolve(referrer, Path::new("."), "/etc/hostname").ok(), Some("/etc/hostname".into()));
        assert_eq!(b.resolve(referrer, Path::new("dir"), "a/b.bin").ok(), Some("dir/a/b.bin".into()));
    }

    #[test]
    fn far_points_are_found() {
        assert_eq!(first_far_point(&[Vec3::ZERO, Vec3::splat(1e17)]), None);
        assert_eq!(first_far_point(&[Vec3::ZERO, Vec3::new(0.0, -2e18, 0.0)]), Some((1, Vec3::new(0.0, -2e18, 0.0))));
    }

    #[test]
    fn non_finite_points_count_as_far() {
        // NaN compares false with everything, so a `> limit` test would let it through.
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let found = first_far_point(&[Vec3::ZERO, Vec3::new(1.0, bad, 0.0)]).map(|(i, _)| i);
            assert_eq!(found, Some(1), "{bad}");
        }
        // The limit itself is allowed.
        assert_eq!(first_far_point(&[Vec3::splat(MAX_COORDINATE), Vec3::splat(-MAX_COORDINATE)]), None);
    }
}
