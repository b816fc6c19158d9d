//! Film files: a [`Film`] with the facts that say which render it belongs to, so the parts of
//! a render split over processes or machines can be checked and merged ([`merge_parts`]), and
//! an interrupted render resumed. The layout is `docs/film-format.md`: little-endian, a
//! versioned header, the exact fixed-point sums as they are in memory, an XXH64 checksum.

use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::film::splat::SplatSums;
use crate::film::{Film, ObjectId, PixelSums};
use crate::limits::{MAX_PIXELS, MAX_SIDE};
use crate::options::RenderOptions;
use crate::spectral::{MAX_BINS, SpectralMode};

/// The first 8 bytes of every film file.
pub const FILM_MAGIC: [u8; 8] = *b"SPTRFILM";
/// The newest layout version this build writes and reads: version 4 adds splat sums (flag bit
/// 2), and is written only for a film that has them; others are written as version 3, whose
/// layout is version 4's without them, so films of renders without splats keep their bytes.
/// Version 2 is version 3 without the half-film sums (flag bit 1).
pub const FILM_VERSION: u32 = 4;
/// The version of a film without splat sums.
const VERSION_WITHOUT_SPLATS: u32 = 3;
/// The oldest layout version this build reads.
const OLDEST_READ_VERSION: u32 = 2;
/// Header flag: pixel sample 0's hits are recorded.
const FLAG_FIRST_SAMPLE: u32 = 1;
/// Header flag: the film keeps half-film sums (three i128 per pixel after the spectral sums).
const FLAG_HALVES: u32 = 2;
/// Header flag (version 4): the film keeps splat sums (after the half-film sums: three i128 per
/// pixel, then one per pixel and wavelength, then, with flag bit 1, three per pixel of the
/// second half-film's).
const FLAG_SPLATS: u32 = 4;
/// Bytes per pixel of the sums: a u32 count and four i128 (Σ X, Σ Y, Σ Z, Σ Y²).
const PIXEL_BYTES: usize = 4 + 4 * 16;
/// Fixed part of the header after the length field (see `docs/film-format.md`).
const FIXED_HEADER_BYTES: usize = 3 * 8 + 7 * 4 + 2 * 8;
/// Longest text field of a header (the option line is about 120 bytes).
const MAX_TEXT: usize = 4096;

/// What a film file says about the render it is (a part of).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FilmHeader {
    /// Digest of the scene's files ([`RenderScene::source_hash`]).
    pub scene_hash: u64,
    /// [`RenderOptions::result_key`]: every option that changes the result.
    pub options: String,
    /// XXH64 of `options`.
    pub options_hash: u64,
    /// Seed of the random numbers.
    pub seed: u64,
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// The sample indices this film is for; pixel p holds the first `count(p)` of them.
    pub samples: Range<u32>,
    /// The spectral mode rendered (`auto` resolved), e.g. `bins:16` or `hero:8`.
    pub spectral: String,
    /// The program that wrote the file, e.g. `spectrace 0.1.0`.
    pub writer: String,
    /// How the render's PNG is shown ([`crate::ViewPlan`]'s text, e.g. `exposure auto; tonemap
    /// pbr-neutral`): decided with the scene, so `merge` repeats it. The film itself holds sums only.
    pub view: String,
}

impl FilmHeader {
    /// The header of a render with `options` (its sample range, or all samples) of the scene whose
    /// files digest to `scene_hash` ([`crate::RenderScene::source_hash`]).
    pub fn new(scene_hash: u64, options: &RenderOptions, spectral: SpectralMode, view: String) -> Self {
        let key = options.result_key();
        Self {
            scene_hash,
            options_hash: geometry::xxh64(key.as_bytes(), 0),
            options: key,
            seed: options.seed,
            spp: options.spp,
            samples: options.samples.clone().unwrap_or(0..options.spp),
            spectral: spectral.to_string(),
            writer: format!("spectrace {}", env!("CARGO_PKG_VERSION")),
            view,
        }
    }
}

/// A film and its header: what a `.film` file holds.
#[derive(Debug, Clone, PartialEq)]
pub struct FilmFile {
    /// Which render and which samples.
    pub header: FilmHeader,
    /// The sums.
    pub film: Film,
}

/// A little-endian reader that reports running off the end as `None`.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let slice = self.bytes.get(self.at..end)?;
        self.at = end;
        Some(slice)
    }
    fn u32(&mut self) -> Option<u32> {
        self.take(4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()))
    }
    fn u64(&mut self) -> Option<u64> {
        self.take(8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
    }
    fn i128(&mut self) -> Option<i128> {
        self.take(16).map(|b| i128::from_le_bytes(b.try_into().unwrap_or_default()))
    }
    fn text(&mut self) -> Option<String> {
        let n = self.u32()? as usize;
        if n > MAX_TEXT {
            return None;
        }
        String::from_utf8(self.take(n)?.to_vec()).ok()
    }
}

fn put_text(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

/// A material id as stored: 0 background, 1 the default material, 2 + k material k.
fn id_code(id: ObjectId) -> u32 {
    match id {
        ObjectId::Background => 0,
        ObjectId::Material(None) => 1,
        ObjectId::Material(Some(k)) => k.saturating_add(2),
    }
}

fn id_from_code(code: u32) -> ObjectId {
    match code {
        0 => ObjectId::Background,
        1 => ObjectId::Material(None),
        k => ObjectId::Material(Some(k - 2)),
    }
}

/// The header fields after the length, and the dimensions they announce.
struct Parsed {
    header: FilmHeader,
    width: u32,
    height: u32,
    lanes: usize,
    has_first_sample: bool,
    halves: bool,
    splats: bool,
    nonfinite: u64,
    clamped: u64,
    wavelengths: Vec<f32>,
}

impl Parsed {
    /// Bytes of the payload the header announces (`None` if beyond any real film).
    fn payload_bytes(&self) -> Option<usize> {
        let pixels = (self.width as usize).checked_mul(self.height as usize)?;
        let halves = if self.halves { 3 * 16 } else { 0 };
        let splats = if self.splats { 3 * 16 + 16 * self.lanes + halves } else { 0 };
        let per_pixel = PIXEL_BYTES + 4 + 16 * self.lanes + halves + splats;
        pixels.checked_mul(per_pixel)
    }
}

fn parse_header(r: &mut Reader<'_>) -> Option<Parsed> {
    let scene_hash = r.u64()?;
    let options_hash = r.u64()?;
    let seed = r.u64()?;
    let spp = r.u32()?;
    let start = r.u32()?;
    let end = r.u32()?;
    let width = r.u32()?;
    let height = r.u32()?;
    let lanes = r.u32()? as usize;
    let flags = r.u32()?;
    let nonfinite = r.u64()?;
    let clamped = r.u64()?;
    if lanes > MAX_BINS {
        return None;
    }
    let spectral = r.text()?;
    let options = r.text()?;
    let writer = r.text()?;
    let view = r.text()?;
    let wavelengths = (0..lanes)
        .map(|_| r.take(4).map(|b| f32::from_le_bytes(b.try_into().unwrap_or_default())))
        .collect::<Option<_>>()?;
    let header =
        FilmHeader { scene_hash, options, options_hash, seed, spp, samples: start..end, spectral, writer, view };
    if flags & !(FLAG_FIRST_SAMPLE | FLAG_HALVES | FLAG_SPLATS) != 0 {
        return None;
    }
    Some(Parsed {
        header,
        width,
        height,
        lanes,
        has_first_sample: flags & FLAG_FIRST_SAMPLE != 0,
        halves: flags & FLAG_HALVES != 0,
        splats: flags & FLAG_SPLATS != 0,
        nonfinite,
        clamped,
        wavelengths,
    })
}

/// The header of a film file of `file_len` bytes from its first bytes (`bytes`: the whole file,
/// or at least [`MAX_PREFIX_BYTES`] of it), and where its payload starts; errors name `path`:
/// not a film file, another version, a damaged header, or a length other than the one the header
/// announces.
fn read_header(bytes: &[u8], file_len: u64, path: &Path) -> Result<(Parsed, usize)> {
    let bad = |message: String| Error::FilmFile { path: path.to_owned(), message };
    if bytes.len() < 8 || bytes[..8] != FILM_MAGIC {
        return Err(bad("not a spectrace film file (no SPTRFILM magic number)".to_owned()));
    }
    let mut r = Reader { bytes, at: 8 };
    let version = r.u32().ok_or_else(|| bad(format!("truncated: {file_len} bytes, ends in the header")))?;
    if !(OLDEST_READ_VERSION..=FILM_VERSION).contains(&version) {
        return Err(bad(format!(
            "film format version {version}, but this build reads versions {OLDEST_READ_VERSION} to {FILM_VERSION} only (merge with the spectrace that rendered it)"
        )));
    }
    let header_len = r.u32().ok_or_else(|| bad(format!("truncated: {file_len} bytes, ends in the header")))? as usize;
    // The header has its own checksum, so the size it announces can be trusted: a short
    // file is then "truncated", a damaged one "corrupted".
    let header_end = 16usize.saturating_add(header_len);
    if header_end as u64 + 8 > MAX_PREFIX_BYTES {
        return Err(bad(format!("corrupted: a header of {header_len} bytes, longer than any film's")));
    }
    let (Some(header), Some(stored)) =
        (bytes.get(16..header_end), header_end.checked_add(8).and_then(|end| bytes.get(header_end..end)))
    else {
        return Err(bad(format!("truncated: {file_len} bytes, ends in the header")));
    };
    let stored = u64::from_le_bytes(stored.try_into().unwrap_or_default());
    if geometry::xxh64(&bytes[..header_end], 0) != stored {
        return Err(bad("corrupted: the header's checksum does not match".to_owned()));
    }
    let mut hr = Reader { bytes: header, at: 0 };
    let p = parse_header(&mut hr)
        .filter(|_| hr.at == header.len())
        .ok_or_else(|| bad("corrupted: the header does not parse".to_owned()))?;
    if p.splats && version < FILM_VERSION {
        return Err(bad(format!("corrupted: splat sums (flag bit 2) in a version {version} file, which has none")));
    }
    let payload_at = header_end + 8;
    let expected = p.payload_bytes().and_then(|payload| payload.checked_add(payload_at + 8));
    match expected.map(|e| e as u64) {
        Some(e) if file_len < e => Err(bad(format!("truncated: {file_len} bytes of the {e} its header announces"))),
        Some(e) if file_len > e => Err(bad(format!("corrupted: {file_len} bytes, but its header announces {e}"))),
        Some(_) => Ok((p, payload_at)),
        None => Err(bad("corrupted: the header announces an impossible size".to_owned())),
    }
}

/// Longest header (magic, version, length, the fields, four texts of [`MAX_TEXT`] bytes and
/// [`MAX_BINS`] wavelengths, its checksum): the prefix [`FilmFile::read`] reads first.
const MAX_PREFIX_BYTES: u64 = (16 + FIXED_HEADER_BYTES + 4 * (4 + MAX_TEXT) + 4 * MAX_BINS + 8) as u64;

/// Largest film file a valid header can announce: [`MAX_PIXELS`] pixels of sums, material ids,
/// [`MAX_BINS`] per-wavelength sums, half-film sums and the splat sums of each, after the
/// longest header, and the checksum (≈ 441 GB).
pub(crate) const MAX_FILM_BYTES: u64 =
    MAX_PREFIX_BYTES + MAX_PIXELS * (PIXEL_BYTES + 4 + 2 * 16 * MAX_BINS + 3 * 48) as u64 + 8;

impl FilmHeader {
    /// Write `film` with this header to `path` atomically (a temporary beside it, fsynced,
    /// then renamed): what a checkpoint does without copying the film.
    pub fn write_film(&self, film: &Film, path: &Path) -> Result<()> {
        crate::files::write_bytes_atomically(path, &encode(self, film))
    }
}

/// The bytes of a film file (layout: `docs/film-format.md`).
fn encode(h: &FilmHeader, f: &Film) -> Vec<u8> {
    let mut header = Vec::with_capacity(FIXED_HEADER_BYTES + 256);
    for v in [h.scene_hash, h.options_hash, h.seed] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    let flags = if f.has_first_sample { FLAG_FIRST_SAMPLE } else { 0 }
        | if f.has_halves() { FLAG_HALVES } else { 0 }
        | if f.has_splats() { FLAG_SPLATS } else { 0 };
    let lanes = f.wavelengths.len() as u32;
    for v in [h.spp, h.samples.start, h.samples.end, f.width, f.height, lanes, flags] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    for v in [f.nonfinite, f.clamped] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    put_text(&mut header, &h.spectral);
    put_text(&mut header, &h.options);
    put_text(&mut header, &h.writer);
    put_text(&mut header, &h.view);
    for w in &f.wavelengths {
        header.extend_from_slice(&w.to_le_bytes());
    }
    let n = f.pixels.len();
    let mut out = Vec::with_capacity(24 + header.len() + n * (PIXEL_BYTES + 4) + f.spectral.len() * 16 + 8);
    out.extend_from_slice(&FILM_MAGIC);
    let version = if f.has_splats() { FILM_VERSION } else { VERSION_WITHOUT_SPLATS };
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(header.len() as u32).to_le_bytes());
    out.extend_from_slice(&header);
    let header_checksum = geometry::xxh64(&out, 0);
    out.extend_from_slice(&header_checksum.to_le_bytes());
    for p in &f.pixels {
        out.extend_from_slice(&p.count.to_le_bytes());
        for s in [p.xyz[0], p.xyz[1], p.xyz[2], p.y2] {
            out.extend_from_slice(&s.to_le_bytes());
        }
    }
    for id in &f.ids {
        out.extend_from_slice(&id_code(*id).to_le_bytes());
    }
    for s in &f.spectral {
        out.extend_from_slice(&s.to_le_bytes());
    }
    for h in &f.halves {
        for s in h {
            out.extend_from_slice(&s.to_le_bytes());
        }
    }
    for s in f.splats.xyz.iter().flatten().chain(&f.splats.spectral).chain(f.splats.halves.iter().flatten()) {
        out.extend_from_slice(&s.to_le_bytes());
    }
    let checksum = geometry::xxh64(&out, 0);
    out.extend_from_slice(&checksum.to_le_bytes());
    out
}

impl FilmFile {
    /// The file's bytes (layout: `docs/film-format.md`).
    pub fn to_bytes(&self) -> Vec<u8> {
        encode(&self.header, &self.film)
    }

    /// Read a film file from `bytes`; errors name `path`: not a film file, another version,
    /// truncated, corrupted (checksum), or impossible values.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let bad = |message: String| Error::FilmFile { path: path.to_owned(), message };
        let (p, payload_at) = read_header(bytes, bytes.len() as u64, path)?;
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        let stored = u64::from_le_bytes(tail.try_into().unwrap_or_default());
        let computed = geometry::xxh64(body, 0);
        if stored != computed {
            return Err(bad(format!(
                "corrupted: checksum {computed:016x} of the content does not match the stored {stored:016x}"
            )));
        }
        let h = &p.header;
        let pixels = u64::from(p.width) * u64::from(p.height);
        let sane = p.width > 0
            && p.height > 0
            && p.width <= MAX_SIDE
            && p.height <= MAX_SIDE
            && pixels <= MAX_PIXELS
            && h.samples.start < h.samples.end
            && h.samples.end <= h.spp
            && h.options_hash == geometry::xxh64(h.options.as_bytes(), 0);
        if !sane {
            return Err(bad(format!(
                "impossible header: {}x{} pixels, samples {}..{} of {} spp",
                p.width, p.height, h.samples.start, h.samples.end, h.spp
            )));
        }
        let n = pixels as usize;
        let mut r = Reader { bytes: body, at: payload_at };
        let truncated = || bad("truncated payload".to_owned());
        let mut sums = Vec::with_capacity(n);
        let range = h.samples.len() as u32;
        for i in 0..n {
            let count = r.u32().ok_or_else(truncated)?;
            if count > range {
                return Err(bad(format!("pixel {i} holds {count} samples, more than its range's {range}")));
            }
            let mut v = [0i128; 4];
            for s in &mut v {
                *s = r.i128().ok_or_else(truncated)?;
            }
            sums.push(PixelSums { xyz: [v[0], v[1], v[2]], y2: v[3], count });
        }
        let ids = r.take(4 * n).ok_or_else(truncated)?;
        let ids = ids.chunks_exact(4).map(|b| id_from_code(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))).collect();
        let spectral = r.take(16 * n * p.lanes).ok_or_else(truncated)?;
        let spectral =
            spectral.chunks_exact(16).map(|b| i128::from_le_bytes(b.try_into().unwrap_or_default())).collect();
        let halves = if p.halves {
            let bytes = r.take(3 * 16 * n).ok_or_else(truncated)?;
            let sums: Vec<i128> =
                bytes.chunks_exact(16).map(|b| i128::from_le_bytes(b.try_into().unwrap_or_default())).collect();
            sums.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        } else {
            Vec::new()
        };
        let splats = if p.splats {
            let mut read = |count: usize| -> Result<Vec<i128>> {
                let bytes = r.take(16 * count).ok_or_else(truncated)?;
                Ok(bytes.chunks_exact(16).map(|b| i128::from_le_bytes(b.try_into().unwrap_or_default())).collect())
            };
            let triples = |sums: Vec<i128>| sums.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let xyz = triples(read(3 * n)?);
            let spectral = read(n * p.lanes)?;
            let halves = if p.halves { triples(read(3 * n)?) } else { Vec::new() };
            SplatSums { xyz, spectral, halves }
        } else {
            SplatSums::default()
        };
        let film = Film {
            halves,
            splats,
            width: p.width,
            height: p.height,
            pixels: sums,
            wavelengths: p.wavelengths,
            spectral,
            ids,
            has_first_sample: p.has_first_sample,
            nonfinite: p.nonfinite,
            clamped: p.clamped,
        };
        Ok(Self { header: p.header, film })
    }

    /// Read a film file: a regular file (a FIFO would block the read, a device never end it) of
    /// the length its header announces, which is checked before the payload is read.
    pub fn read(path: &Path) -> Result<Self> {
        use std::io::Read as _;
        let fail = |message: String| Error::FilmFile { path: path.to_owned(), message };
        // The metadata before opening: opening a FIFO blocks until a writer comes.
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        if !meta.is_file() {
            return Err(fail("not a regular file (a device, FIFO or folder cannot be a film)".to_owned()));
        }
        let len = meta.len();
        if len > MAX_FILM_BYTES {
            return Err(fail(format!("{len} bytes, more than any film can have ({MAX_FILM_BYTES})")));
        }
        let mut file = std::fs::File::open(path).map_err(|e| fail(e.to_string()))?;
        // The header says how long the file must be: a damaged or foreign file is refused
        // before its bulk is read.
        let mut bytes = Vec::new();
        (&mut file).take(MAX_PREFIX_BYTES.min(len)).read_to_end(&mut bytes).map_err(|e| fail(e.to_string()))?;
        read_header(&bytes, len, path)?;
        // The file may have grown since the metadata was read: never read past its length.
        bytes.reserve_exact((len as usize).saturating_sub(bytes.len()));
        file.take(len - bytes.len() as u64).read_to_end(&mut bytes).map_err(|e| fail(e.to_string()))?;
        Self::from_bytes(&bytes, path)
    }

    /// Write the file atomically (a temporary beside it, fsynced, then renamed).
    pub fn write(&self, path: &Path) -> Result<()> {
        self.header.write_film(&self.film, path)
    }

    /// Whether every pixel holds all the samples of the range.
    pub fn is_complete(&self) -> bool {
        self.film.min_sample_count() == self.header.samples.len() as u32
    }

    /// The film, to resume a render whose header would be `expected` (same scene, options,
    /// seed, sample range and size); errors name `path`.
    pub fn resumable(self, expected: &FilmHeader, width: u32, height: u32, path: &Path) -> Result<Film> {
        let h = &self.header;
        let differs = |what: &str, was: String, now: String| Error::FilmFile {
            path: path.to_owned(),
            message: format!("cannot resume: rendered with {what} {was}, this render has {now}"),
        };
        if h.scene_hash != expected.scene_hash {
            return Err(differs(
                "a different scene: digest",
                format!("{:016x}", h.scene_hash),
                format!("{:016x}", expected.scene_hash),
            ));
        }
        if h.options != expected.options {
            return Err(differs("other options:", format!("`{}`", h.options), format!("`{}`", expected.options)));
        }
        if h.seed != expected.seed {
            return Err(differs("seed", h.seed.to_string(), expected.seed.to_string()));
        }
        if h.spectral != expected.spectral {
            return Err(differs("spectral mode", h.spectral.clone(), expected.spectral.clone()));
        }
        if h.samples != expected.samples {
            return Err(differs("samples", format!("{:?}", h.samples), format!("{:?}", expected.samples)));
        }
        if (self.film.width, self.film.height) != (width, height) {
            return Err(differs(
                "size",
                format!("{}x{}", self.film.width, self.film.height),
                format!("{width}x{height}"),
            ));
        }
        Ok(self.film)
    }
}

/// The merge of the parts of one render ([`merge_parts`]).
#[derive(Debug)]
pub struct Merged {
    /// The merged film and its header (sample range: from the first part's start to the last
    /// part's end).
    pub file: FilmFile,
    /// Sample indices of `0..spp` no part is for.
    pub missing: Vec<Range<u32>>,
    /// Parts that do not hold all of their range in every pixel (an interrupted render):
    /// their path, and the fewest and most samples a pixel holds of the range's length.
    pub incomplete: Vec<(PathBuf, u32, u32, u32)>,
}

impl Merged {
    /// Whether the merged film is the whole render.
    pub fn is_complete(&self) -> bool {
        self.missing.is_empty() && self.incomplete.is_empty()
    }

    /// The gaps in words, one per line.
    pub fn gaps(&self) -> Vec<String> {
        let mut lines: Vec<String> =
            self.missing.iter().map(|r| format!("samples {}..{} are in no part", r.start, r.end)).collect();
        lines.extend(self.incomplete.iter().map(|(path, lo, hi, len)| {
            format!(
                "{}: pixels hold {lo}..={hi} of its {len} samples (an interrupted render: --resume it)",
                path.display()
            )
        }));
        lines
    }
}

fn mismatch(path: &Path, other: &Path, message: String) -> Error {
    Error::FilmMismatch { path: path.to_owned(), other: other.to_owned(), message }
}

/// Merges the films of disjoint sample ranges of one render, one at a time (so only the sum
/// and the part being added are in memory). Refuses parts of different scenes, options,
/// seeds, sizes, spectral modes or program versions when they are added, and overlapping
/// ranges when finished (each error names the two files); samples no part covers are
/// reported in [`Merged::missing`], not refused.
#[derive(Debug, Default)]
pub struct Merger {
    /// The sum so far, and the first part's path (what later parts are compared with).
    sum: Option<(PathBuf, FilmFile)>,
    /// Every part's path, range, and fewest and most samples held.
    ranges: Vec<(PathBuf, Range<u32>, u32, u32)>,
}

impl Merger {
    /// An empty merge.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add one part.
    pub fn add(&mut self, path: PathBuf, part: FilmFile) -> Result<()> {
        let range =
            (path.clone(), part.header.samples.clone(), part.film.min_sample_count(), part.film.max_sample_count());
        match &mut self.sum {
            None => self.sum = Some((path, part)),
            Some((first_path, sum)) => {
                let (h, reference) = (&part.header, &sum.header);
                let size = (sum.film.width, sum.film.height);
                if h.scene_hash != reference.scene_hash {
                    return Err(mismatch(
                        &path,
                        first_path,
                        format!("a different scene (digest {:016x}, not {:016x})", h.scene_hash, reference.scene_hash),
                    ));
                }
                if h.options != reference.options {
                    return Err(mismatch(
                        &path,
                        first_path,
                        format!("other options (`{}`, not `{}`)", h.options, reference.options),
                    ));
                }
                if h.seed != reference.seed {
                    return Err(mismatch(
                        &path,
                        first_path,
                        format!("another seed ({}, not {})", h.seed, reference.seed),
                    ));
                }
                if h.spectral != reference.spectral || (part.film.width, part.film.height) != size {
                    return Err(mismatch(
                        &path,
                        first_path,
                        format!(
                            "another size or spectral mode ({}x{} {}, not {}x{} {})",
                            part.film.width, part.film.height, h.spectral, size.0, size.1, reference.spectral
                        ),
                    ));
                }
                if h.view != reference.view {
                    return Err(mismatch(
                        &path,
                        first_path,
                        format!("another view of the image (`{}`, not `{}`)", h.view, reference.view),
                    ));
                }
                if h.writer != reference.writer {
                    // Same options and scene but another build: the numbers may differ.
                    return Err(mismatch(
                        &path,
                        first_path,
                        format!("another program ({}, not {})", h.writer, reference.writer),
                    ));
                }
                sum.film.merge(&part.film).map_err(|e| mismatch(&path, first_path, e.to_string()))?;
            }
        }
        self.ranges.push(range);
        Ok(())
    }

    /// The merged film, once the ranges are checked to be disjoint.
    pub fn finish(self) -> Result<Merged> {
        let Some((_, mut file)) = self.sum else {
            return Err(Error::InvalidOption {
                option: "films to merge",
                value: "none".to_owned(),
                expected: "one or more",
            });
        };
        let mut ranges = self.ranges;
        ranges.sort_by_key(|(_, r, ..)| (r.start, r.end));
        for pair in ranges.windows(2) {
            let ((pa, a, ..), (pb, b, ..)) = (&pair[0], &pair[1]);
            if b.start < a.end {
                return Err(mismatch(
                    pb,
                    pa,
                    format!(
                        "overlapping sample ranges ({}..{} and {}..{}): a sample would be counted twice",
                        b.start, b.end, a.start, a.end
                    ),
                ));
            }
        }
        let spp = file.header.spp;
        let mut missing = Vec::new();
        let mut covered = 0;
        for (_, r, ..) in &ranges {
            if r.start > covered {
                missing.push(covered..r.start);
            }
            covered = r.end;
        }
        if covered < spp {
            missing.push(covered..spp);
        }
        let incomplete = ranges
            .iter()
            .filter(|(_, r, lo, _)| *lo < r.len() as u32)
            .map(|(path, r, lo, hi)| (path.clone(), *lo, *hi, r.len() as u32))
            .collect();
        file.header.samples = ranges[0].1.start..ranges[ranges.len() - 1].1.end;
        Ok(Merged { file, missing, incomplete })
    }
}

/// Merge the films of disjoint sample ranges of one render (see [`Merger`]).
pub fn merge_parts(parts: Vec<(PathBuf, FilmFile)>) -> Result<Merged> {
    let mut merger = Merger::new();
    for (path, part) in parts {
        merger.add(path, part)?;
    }
    merger.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    fn sample_file() -> FilmFile {
        let mut film = Film::new(3, 2, vec![450.0, 550.0]).with_halves();
        {
            let mut rows = film.rows_mut().collect::<Vec<_>>();
            rows[0].add_sample::<4>(1, 0, [0.25, 1.5, -3.0e-9], &[0.5, 2.0, 0.0, 0.0]);
            // Index 1 is in the second half-film.
            rows[1].add_sample::<4>(1, 1, [0.5, 0.75, 0.125], &[1.0, 0.0, 0.0, 0.0]);
            rows[1].set_first_hit(2, ObjectId::Material(Some(7)));
            rows[1].set_first_hit(0, ObjectId::Material(None));
        }
        film.set_has_first_sample();
        film.add_counts(2, 1);
        let header = FilmHeader {
            scene_hash: 0x0123_4567_89ab_cdef,
            options: "path spp=4".to_owned(),
            options_hash: geometry::xxh64(b"path spp=4", 0),
            seed: 9,
            spp: 4,
            samples: 0..1,
            spectral: "bins:2".to_owned(),
            writer: "spectrace test".to_owned(),
            view: "exposure +0 EV; tonemap clamp".to_owned(),
        };
        FilmFile { header, film }
    }

    #[test]
    fn a_film_file_reads_back_exactly() {
        let file = sample_file();
        let bytes = file.to_bytes();
        assert_eq!(&bytes[..8], b"SPTRFILM");
        let back = FilmFile::from_bytes(&bytes, Path::new("a.film")).unwrap();
        assert_eq!(back, file);
        assert_eq!(back.film.nonfinite_samples(), 2);
    }

    #[test]
    fn version_2_files_read_as_films_without_halves() {
        // Version 2 is version 3's layout without the half-film sums (flag bit 1 never set).
        let mut file = sample_file();
        file.film.halves.clear();
        let mut bytes = file.to_bytes();
        bytes[8..12].copy_from_slice(&2u32.to_le_bytes());
        let header_end = 16 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let header_checksum = geometry::xxh64(&bytes[..header_end], 0);
        bytes[header_end..header_end + 8].copy_from_slice(&header_checksum.to_le_bytes());
        let body = bytes.len() - 8;
        let checksum = geometry::xxh64(&bytes[..body], 0);
        bytes[body..].copy_from_slice(&checksum.to_le_bytes());
        let back = FilmFile::from_bytes(&bytes, Path::new("v2.film")).unwrap();
        assert_eq!(back, file);
        assert!(!back.film.has_halves());
        // The halves' flag set in a file without their bytes: an announced length it lacks.
        let with = sample_file().to_bytes();
        assert_ne!(with.len(), bytes.len());
    }

    #[test]
    fn damaged_files_are_named_errors() {
        let bytes = sample_file().to_bytes();
        let err = |b: &[u8]| FilmFile::from_bytes(b, Path::new("p.film")).unwrap_err().to_string();
        // Every cut short is "truncated", never a panic or a film.
        for len in [0, 5, 12, 40, bytes.len() / 2, bytes.len() - 1] {
            let e = err(&bytes[..len]);
            assert!(
                e.starts_with("p.film: ") && (e.contains("truncated") || e.contains("not a spectrace")),
                "{len}: {e}"
            );
        }
        assert!(err(&bytes[..bytes.len() - 1]).contains("truncated"));
        // Any flipped byte after the magic and version is caught.
        for at in (16..bytes.len()).step_by(7) {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            let e = err(&b);
            assert!(e.starts_with("p.film: corrupted"), "{at}: {e}");
        }
        let mut b = bytes.clone();
        b[8] = 9;
        assert!(err(&b).contains("version 9"), "{}", err(&b));
        let mut b = bytes.clone();
        b[0] = b'X';
        assert!(err(&b).contains("not a spectrace film file"));
        let mut b = bytes.clone();
        b.push(0);
        assert!(err(&b).contains("corrupted"), "{}", err(&b));
        // A corrupted header length is not mistaken for a short file.
        let mut b = bytes.clone();
        b[12] ^= 1;
        assert!(err(&b).contains("corrupted") || err(&b).contains("truncated"), "{}", err(&b));
    }

    /// `FilmFile::read(path)`'s error, or a failure if it takes more than 5 s (a FIFO's open
    /// would block for ever: the read runs on a thread that is abandoned then).
    fn read_error_promptly(path: &Path) -> String {
        let (send, receive) = std::sync::mpsc::channel();
        let owned = path.to_owned();
        std::thread::spawn(move || send.send(FilmFile::read(&owned).map(|_| ()).map_err(|e| e.to_string())));
        match receive.recv_timeout(std::time::Duration::from_secs(5)) {
            Ok(result) => result.expect_err("not a film"),
            Err(_) => panic!("reading {} did not return within 5 s", path.display()),
        }
    }

    #[test]
    fn only_regular_files_of_the_length_their_header_announces_are_read() {
        let dir = std::env::temp_dir().join(format!("spectrace-film-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A FIFO: opening it blocked until a writer came; merge and --resume hung.
        let fifo = dir.join("fifo.film");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let e = read_error_promptly(&fifo);
            assert_eq!(
                e,
                format!("{}: not a regular file (a device, FIFO or folder cannot be a film)", fifo.display())
            );
        } else {
            eprintln!("skipped the FIFO: no mkfifo here");
        }
        // A device that never ends: it was read until the 2 GB allocation failed.
        let e = read_error_promptly(Path::new("/dev/zero"));
        assert_eq!(e, "/dev/zero: not a regular file (a device, FIFO or folder cannot be a film)");
        assert!(read_error_promptly(&dir).contains("not a regular file"));
        // A valid film with a long tail (sparse: nothing is written or read but the header):
        // refused from the header's length.
        let good = dir.join("good.film");
        let bytes = sample_file().to_bytes();
        std::fs::write(&good, &bytes).unwrap();
        assert_eq!(FilmFile::read(&good).unwrap(), sample_file());
        let long = dir.join("long.film");
        std::fs::write(&long, &bytes).unwrap();
        let file = std::fs::OpenOptions::new().write(true).open(&long).unwrap();
        file.set_len(1 << 32).unwrap();
        let e = read_error_promptly(&long);
        assert_eq!(
            e,
            format!("{}: corrupted: {} bytes, but its header announces {}", long.display(), 1u64 << 32, bytes.len())
        );
        // Beyond what any header allows: refused before opening.
        if file.set_len(MAX_FILM_BYTES + 1).is_ok() {
            let e = read_error_promptly(&long);
            assert_eq!(
                e,
                format!(
                    "{}: {} bytes, more than any film can have ({MAX_FILM_BYTES})",
                    long.display(),
                    MAX_FILM_BYTES + 1
                )
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
