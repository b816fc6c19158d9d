//! A parallel fast path for plain OBJ files: `v x y z` (or `v x y z r g b` on every line),
//! `vt u v`, `vn x y z` and `f` lines whose corners take one form per object, `v`, `v/vt`,
//! `v//vn` or `v/vt/vn`, and `o`, `g`, `s`, `mtllib` and `usemtl` lines (what Blender, scanners,
//! terrain and CAD exporters write), parsed in chunks of lines on every core.
//!
//! tobj reads a line at a time into a `String` and, with `single_index`, looks every face corner
//! up in a `HashMap` of (position, uv, normal) triples; on a 60 MB, 1.6M-triangle terrain that was
//! 0.75 s of the 2.85 s `spectrace info` took, and the line-by-line pre-scan that guards it
//! another 0.2 s (`docs/perf.md`, "Loading and building"). Lines here are split by byte
//! offsets, parsed in parallel with the standard library's exactly rounded `f32` parser (the one
//! tobj uses), and the corners numbered in one pass over an array (with a map only for the
//! triples after a position's first: the seams of texture coordinates or normals).
//!
//! The result is what tobj gives for the same text — an object for each run of faces between
//! `o`/`g` lines and changes of material, a vertex for each distinct (position, texture
//! coordinate, normal) triple in the order the object's faces first use them (unused ones
//! dropped), polygons as fans from their first corner — so a file loads the same whichever path
//! reads it (the tests compare both on every OBJ fixture). The `o`/`g`, `mtllib` and `usemtl`
//! lines are kept with their place among the faces, for the caller to read the materials as
//! tobj would and end objects where tobj does ([`Plain::into_objects`]). Anything else — a
//! change of corner form without an `o`/`g` line before it, colours on some `v` lines only, `w`,
//! relative or malformed indices, faces of fewer than three corners, any other statement, a
//! value that is not a finite number, an index out of range — returns `None`, and the caller
//! reads the file with tobj behind the line-by-line checks, whose errors name the file and line.
//! This path never reports an error of its own.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::limits::mesh_charge;

/// A plain OBJ file, parsed: its `v`, `vt` and `vn` lists, its faces as fan triangles, and the
/// lines that divide them into objects. [`Plain::into_objects`] numbers each object's vertices
/// as tobj does (`single_index`, triangulated), once the caller has decided where objects end
/// (which needs the materials a `usemtl` line names: [`Mark`]).
#[derive(Debug)]
pub(crate) struct Plain {
    positions: Vec<Vec3>,
    /// The positions' colours (`v x y z r g b`), or empty if no `v` line has one.
    colors: Vec<Vec3>,
    /// Empty unless some corners have texture coordinates.
    texcoords: Vec<Vec2>,
    /// Empty unless some corners have normals.
    normals: Vec<Vec3>,
    /// The corners' form ([`TEXCOORD`], [`NORMAL`]) from each triangle on where it changes: the
    /// first face's, then only at `o`/`g` lines (the start of an object).
    forms: Vec<(usize, u8)>,
    /// The union of `forms`: the attributes some corner has.
    any_form: u8,
    /// The fan triangles, chunk by chunk in file order: position, texture coordinate and normal
    /// indices into the lists above (the last two where the triangles' form has them).
    parts: Vec<[Vec<[u32; 3]>; 3]>,
    /// The `o`/`g`, `mtllib` and `usemtl` lines in file order, each with the number of triangles
    /// above it.
    pub(crate) marks: Vec<(usize, Mark)>,
    /// Face corners on `f` lines (the pre-scan's count, for the budget).
    pub(crate) corners: u64,
    /// Triangles after fan triangulation.
    pub(crate) triangles: u64,
}

/// A line that may end an object, with tobj's reading of its argument: the line after its first
/// character (`o`/`g`) or its first space (`mtllib`/`usemtl`), trimmed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Mark {
    /// `o NAME` or `g NAME` (possibly empty).
    Name(String),
    /// `mtllib FILE`.
    Library(String),
    /// `usemtl NAME` (never empty: tobj refuses that).
    Use(String),
}

/// One object's mesh as tobj gives it: a vertex for each distinct (position, texture coordinate,
/// normal) triple, in the order the object's faces first use them.
#[derive(Debug, PartialEq)]
pub(crate) struct Object {
    pub(crate) positions: Vec<Vec3>,
    /// The vertices' colours as written (linear RGB), where the file's `v` lines have them.
    pub(crate) colors: Option<Vec<Vec3>>,
    /// The vertices' texture coordinates as written (v up), where the corners have them.
    pub(crate) texcoords: Option<Vec<Vec2>>,
    /// The vertices' normals as written, where the corners have them.
    pub(crate) normals: Option<Vec<Vec3>>,
    pub(crate) indices: Vec<[u32; 3]>,
}

/// Bytes of text per parallel task (cut at the next line end): 1 MB is a few milliseconds of
/// parsing, many tasks for any core count on large files, one task on small ones.
const CHUNK_BYTES: usize = 1 << 20;

/// What an `o`/`g`, `mtllib` or `usemtl` line is charged besides its argument: its entry among the
/// marks, and the object it may end (its range, name and material, and a mesh's fixed part).
const MARK_BYTES: u64 = 256;

/// Lines a task parses between looks at the shared charge.
const LINES_PER_CHARGE: usize = 4096;

/// A face corner's form: whether it has a texture coordinate index (`TEXCOORD`), a normal index
/// (`NORMAL`), both or neither.
const TEXCOORD: u8 = 1;
const NORMAL: u8 = 2;

/// What one chunk of lines holds.
#[derive(Debug, Default)]
struct Chunk {
    positions: Vec<Vec3>,
    /// The colours of the chunk's `v` lines that have one.
    colors: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    normals: Vec<Vec3>,
    /// Fan triangles, 0-based indices into the whole file's positions.
    triangles: Vec<[u32; 3]>,
    /// The same triangles' texture coordinate and normal indices, where their form has them (and
    /// `[0; 3]` before, where another form did not: empty if none has).
    texcoord_triangles: Vec<[u32; 3]>,
    normal_triangles: Vec<[u32; 3]>,
    /// The last face's form (`None`: no faces yet).
    form: Option<u8>,
    /// The form from each triangle on where it changes (the first face's included).
    forms: Vec<(usize, u8)>,
    corners: u64,
    /// Per attribute (position, texture coordinate, normal), the largest (1-based index − those
    /// this chunk defined before the line): a face may only refer to what is defined above it, so
    /// the chunks before must define at least this many.
    excess: [i64; 3],
    /// The chunk's `o`/`g`, `mtllib` and `usemtl` lines, each with the chunk's triangles above it.
    marks: Vec<(usize, Mark)>,
}

/// Parses `text` if it is a plain OBJ file. `allowance`: the bytes the budget still allows; the
/// parse gives up (`None`) once the faces it has read would be charged more (`BYTES_PER_VERTEX`
/// per corner, `BYTES_PER_TRIANGLE` per triangle, as the caller then charges), so that an
/// over-budget file is refused by the checked path before this one allocates for it.
///
/// Positions, texture coordinates and normals are not charged as they are read: a `v` line of at
/// least 8 bytes of text becomes a 12-byte position and 8 bytes of numbering (and a colour, 12
/// more for 6 more bytes), a `vt` line of 7 bytes 8 bytes, a `vn` line of 9 bytes 12, so they
/// take at most about 7.5× the text at the peak (the chunks' vectors, up to twice their length,
/// while the whole arrays are joined), and the text was charged when it was read. Faces are
/// charged as read because what they cost (a triangle's share of the BVH; a corner's vertex, or
/// its entry among the seams) is not bounded by their text's size, and so are `o`/`g`,
/// `mtllib` and `usemtl` lines ([`MARK_BYTES`] and their argument: a line of two bytes is an
/// entry of 40, and may end an object).
pub(crate) fn parse(text: &str, allowance: u64) -> Option<Plain> {
    let bytes = text.as_bytes();
    let mut starts = vec![0];
    let mut at = 0;
    while at < bytes.len() {
        let end = (at + CHUNK_BYTES).min(bytes.len());
        // Cut after a line end ('\n' is ASCII: a character boundary).
        at = match bytes[end..].iter().position(|&b| b == b'\n') {
            Some(k) => end + k + 1,
            None => bytes.len(),
        };
        starts.push(at);
    }
    let charged = AtomicU64::new(0);
    let give_up = AtomicBool::new(false);
    let parse = |w: &[usize]| parse_chunk(&text[w[0]..w[1]], allowance, &charged, &give_up);
    // One chunk stays on this thread (starting rayon's pool costs more than a small file).
    let mut chunks: Vec<Chunk> = if starts.len() > 2 {
        starts.par_windows(2).map(parse).collect::<Option<Vec<Chunk>>>()?
    } else {
        starts.windows(2).map(parse).collect::<Option<Vec<Chunk>>>()?
    };

    // Faces refer only to what is defined above them; their corners' form changes only where an
    // `o`/`g` line starts an object.
    let (mut before, mut above) = ([0i64; 3], 0);
    let (mut marks, mut forms) = (Vec::new(), Vec::<(usize, u8)>::new());
    for chunk in &mut chunks {
        for &(at, form) in &chunk.forms {
            if forms.last().is_none_or(|&(_, last)| last != form) {
                forms.push((above + at, form));
            }
        }
        if (0..3).any(|a| chunk.excess[a] > before[a]) {
            return None;
        }
        before[0] += chunk.positions.len() as i64;
        before[1] += chunk.texcoords.len() as i64;
        before[2] += chunk.normals.len() as i64;
        marks.extend(chunk.marks.drain(..).map(|(at, mark)| (above + at, mark)));
        above += chunk.triangles.len();
    }
    if before[0] > i64::from(u32::MAX) {
        return None;
    }
    let named = |at: usize| {
        let first = marks.partition_point(|(m, _)| *m < at);
        marks[first..].iter().take_while(|(m, _)| *m == at).any(|(_, mark)| matches!(mark, Mark::Name(_)))
    };
    if forms.iter().skip(1).any(|&(at, _)| !named(at)) {
        return None;
    }
    // Colours on every `v` line or none (tobj reads colours on some lines only out of step with
    // their positions: the pre-scan refuses them).
    let colored: usize = chunks.iter().map(|c| c.colors.len()).sum();
    if colored != 0 && colored as i64 != before[0] {
        return None;
    }
    let any_form = forms.iter().fold(0, |any, &(_, form)| any | form);
    let corners = chunks.iter().map(|c| c.corners).sum();
    let mut positions = Vec::with_capacity(before[0] as usize);
    let mut colors = Vec::with_capacity(colored);
    let mut texcoords = Vec::with_capacity(if any_form & TEXCOORD != 0 { before[1] as usize } else { 0 });
    let mut normals = Vec::with_capacity(if any_form & NORMAL != 0 { before[2] as usize } else { 0 });
    let mut parts = Vec::with_capacity(chunks.len());
    for chunk in chunks {
        positions.extend(chunk.positions);
        colors.extend(chunk.colors);
        if any_form & TEXCOORD != 0 {
            texcoords.extend(chunk.texcoords);
        }
        if any_form & NORMAL != 0 {
            normals.extend(chunk.normals);
        }
        parts.push([chunk.triangles, chunk.texcoord_triangles, chunk.normal_triangles]);
    }
    let triangles = above as u64;
    Some(Plain { positions, colors, texcoords, normals, forms, any_form, parts, marks, corners, triangles })
}

impl Plain {
    /// The objects whose triangles are `ranges` (in order, each non-empty, together all the
    /// file's), each numbered on its own as tobj numbers a model: a (position, texture
    /// coordinate, normal) triple gets the next index when one of the object's faces first uses
    /// it.
    pub(crate) fn into_objects(mut self, ranges: &[Range<usize>]) -> Vec<Object> {
        // Most positions come with one pair of the others: the pair a position was first
        // numbered with is kept beside it, and only the other pairs (seams) are looked up in a
        // map. `number` is reset after each object but the last, where it set it.
        let mut number = vec![u32::MAX; self.positions.len()];
        let mut first_pair = if self.any_form == 0 { Vec::new() } else { vec![[0u32; 2]; self.positions.len()] };
        let mut seams: HashMap<[u32; 3], u32> = HashMap::new();
        // Where each chunk's triangles start in the file, and the chunks (or their parts) in `range`.
        let mut part_start = Vec::with_capacity(self.parts.len() + 1);
        part_start.push(0);
        for part in &self.parts {
            part_start.push(part_start[part_start.len() - 1] + part[0].len());
        }
        let parts_in = |range: &Range<usize>| -> Vec<(usize, Range<usize>)> {
            let first = part_start.partition_point(|&start| start <= range.start) - 1;
            (first..part_start.len() - 1)
                .take_while(|&i| part_start[i] < range.end)
                .map(|i| {
                    (
                        i,
                        range.start.max(part_start[i]) - part_start[i]
                            ..range.end.min(part_start[i + 1]) - part_start[i],
                    )
                })
                .collect()
        };
        let mut objects = Vec::with_capacity(ranges.len());
        for (k, range) in ranges.iter().enumerate() {
            let last = k + 1 == ranges.len();
            // One form for the whole object: it changes only where an object starts.
            let form = self.forms[self.forms.partition_point(|&(at, _)| at <= range.start) - 1].1;
            let vertices = if ranges.len() == 1 { self.positions.len() } else { 0 };
            let mut positions = Vec::with_capacity(vertices);
            let colored = !self.colors.is_empty();
            let mut colors = Vec::with_capacity(if colored { vertices } else { 0 });
            let mut texcoords = Vec::with_capacity(if form & TEXCOORD != 0 { vertices } else { 0 });
            let mut normals = Vec::with_capacity(if form & NORMAL != 0 { vertices } else { 0 });
            let mut indices = Vec::with_capacity(range.len());
            let pieces = parts_in(range);
            for (i, local) in pieces.iter().cloned() {
                let [part, texcoord_part, normal_part] = &self.parts[i];
                if form == 0 {
                    // Positions only (the common case, kept to the one array lookup per corner).
                    for triangle in &part[local] {
                        indices.push(triangle.map(|p| {
                            let number = &mut number[p as usize];
                            if *number == u32::MAX {
                                *number = positions.len() as u32;
                                positions.push(self.positions[p as usize]);
                                if colored {
                                    colors.push(self.colors[p as usize]);
                                }
                            }
                            *number
                        }));
                    }
                } else {
                    let texcoord_part = if form & TEXCOORD != 0 { &texcoord_part[local.clone()] } else { &[] };
                    let normal_part = if form & NORMAL != 0 { &normal_part[local.clone()] } else { &[] };
                    for (k, triangle) in part[local].iter().enumerate() {
                        let mut numbered = [0u32; 3];
                        for (c, out) in numbered.iter_mut().enumerate() {
                            let p = triangle[c] as usize;
                            let t = if form & TEXCOORD != 0 { texcoord_part[k][c] } else { 0 };
                            let n = if form & NORMAL != 0 { normal_part[k][c] } else { 0 };
                            let numbered_before = positions.len();
                            let mut add = || {
                                positions.push(self.positions[p]);
                                if form & TEXCOORD != 0 {
                                    texcoords.push(self.texcoords[t as usize]);
                                }
                                if form & NORMAL != 0 {
                                    normals.push(self.normals[n as usize]);
                                }
                                (positions.len() - 1) as u32
                            };
                            *out = if number[p] == u32::MAX {
                                first_pair[p] = [t, n];
                                number[p] = add();
                                number[p]
                            } else if first_pair[p] == [t, n] {
                                number[p]
                            } else {
                                *seams.entry([p as u32, t, n]).or_insert_with(add)
                            };
                            // (Outside `add`: pushed there, the colour cost a file without
                            // colours 3 % more instructions in its whole parse, callgrind.)
                            if colored && positions.len() > numbered_before {
                                colors.push(self.colors[p]);
                            }
                        }
                        indices.push(numbered);
                    }
                }
                if last {
                    // Numbered for good: freed as the numbering goes, as the output grows.
                    self.parts[i] = Default::default();
                }
            }
            if !last {
                for (i, local) in pieces {
                    self.parts[i][0][local].iter().flatten().for_each(|&p| number[p as usize] = u32::MAX);
                    // Chunks wholly before the next object are done with.
                    if part_start[i + 1] <= ranges[k + 1].start {
                        self.parts[i] = Default::default();
                    }
                }
                seams.clear();
            }
            objects.push(Object {
                positions,
                colors: colored.then_some(colors),
                texcoords: (form & TEXCOORD != 0).then_some(texcoords),
                normals: (form & NORMAL != 0).then_some(normals),
                indices,
            });
        }
        objects
    }
}

/// `text.lines()`: lines split at `\n`, a `\r` before it dropped (a last line without `\n` is
/// kept whole). A byte loop: the standard iterator's search, set up anew for each short line,
/// was a tenth of a plain file's load.
fn text_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut start = 0;
    std::iter::from_fn(move || {
        let rest = text.as_bytes().get(start..).filter(|rest| !rest.is_empty())?;
        let Some(end) = rest.iter().position(|&b| b == b'\n').map(|k| start + k) else {
            // The last line, without a line end: kept whole, as `lines` keeps it.
            start = text.len();
            return Some(&text[text.len() - rest.len()..]);
        };
        // Slicing at `\n` (ASCII) is at a character boundary.
        let line = &text[start..end];
        start = end + 1;
        Some(line.strip_suffix('\r').unwrap_or(line))
    })
}

/// A face corner's 0-based (position, texture coordinate, normal) indices (0 where absent) and
/// its form, or `None` for anything but positive indices as `v`, `v/vt`, `v//vn` or `v/vt/vn`.
/// (Read by hand in one pass: `str::split('/')` was an eighth of the load of a file with
/// normals.)
#[inline]
fn corner(word: &str) -> Option<([u32; 3], u8)> {
    let bytes = word.as_bytes();
    let mut at = 0;
    let p = index(bytes, &mut at)?;
    if at == bytes.len() {
        return Some(([p, 0, 0], 0));
    }
    // `bytes[at]` is a slash.
    at += 1;
    let (t, form) = if bytes.get(at) == Some(&b'/') { (0, NORMAL) } else { (index(bytes, &mut at)?, TEXCOORD) };
    if at == bytes.len() {
        return (form == TEXCOORD).then_some(([p, t, 0], form));
    }
    at += 1;
    let n = index(bytes, &mut at)?;
    (at == bytes.len()).then_some(([p, t, n], form | NORMAL))
}

/// The 1-based OBJ index at `bytes[*at..]`, up to a slash or the end (where `*at` is left), as
/// 0-based: read as `str::parse::<u32>` reads (an optional `+`, digits, no overflow); `None`
/// for anything else and for 0.
#[inline]
fn index(bytes: &[u8], at: &mut usize) -> Option<u32> {
    if bytes.get(*at) == Some(&b'+') {
        *at += 1;
    }
    let start = *at;
    let mut value = 0u32;
    while let Some(&d) = bytes.get(*at).filter(|&&d| d != b'/') {
        if !d.is_ascii_digit() {
            return None;
        }
        value = value.checked_mul(10)?.checked_add(u32::from(d - b'0'))?;
        *at += 1;
    }
    if *at == start {
        return None;
    }
    value.checked_sub(1)
}

/// The next `N` words as finite numbers.
#[inline]
fn numbers<'a, const N: usize>(words: &mut impl Iterator<Item = &'a str>) -> Option<[f32; N]> {
    let mut values = [0f32; N];
    for v in &mut values {
        *v = words.next()?.parse().ok()?;
    }
    values.iter().all(|v| v.is_finite()).then_some(values)
}

/// One chunk's lines, or `None` for anything the fast path does not read (or once any task has
/// given up, or the shared charge passed `allowance`).
fn parse_chunk(text: &str, allowance: u64, charged: &AtomicU64, give_up: &AtomicBool) -> Option<Chunk> {
    let result = parse_lines(text, allowance, charged, give_up);
    if result.is_none() {
        give_up.store(true, Ordering::Relaxed);
    }
    result
}

fn parse_lines(text: &str, allowance: u64, charged: &AtomicU64, give_up: &AtomicBool) -> Option<Chunk> {
    let mut chunk = Chunk { excess: [i64::MIN; 3], ..Default::default() };
    let mut corners: Vec<[u32; 3]> = Vec::new();
    let (mut charge, mut lines) = (0u64, 0usize);
    for line in text_lines(text) {
        lines += 1;
        if lines % LINES_PER_CHARGE == 0 {
            let total = charged.fetch_add(charge, Ordering::Relaxed) + charge;
            charge = 0;
            if total > allowance || give_up.load(Ordering::Relaxed) {
                return None;
            }
        }
        let mut words = line.split_ascii_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "v" => {
                chunk.positions.push(Vec3::from_array(numbers(&mut words)?));
                // `v x y z r g b`: a vertex colour, as tobj reads it (`w` goes to tobj).
                if let Some(r) = words.next() {
                    let [r, g, b] = numbers(&mut std::iter::once(r).chain(&mut words))?;
                    chunk.colors.push(Vec3::new(r, g, b));
                    if words.next().is_some() {
                        return None;
                    }
                }
            }
            "vt" => {
                chunk.texcoords.push(Vec2::from_array(numbers(&mut words)?));
                // `vt u v w`: tobj reads u and v; the pre-scan requires w to be a finite number.
                if words.next().is_some_and(|w| !w.parse::<f32>().is_ok_and(f32::is_finite)) || words.next().is_some() {
                    return None;
                }
            }
            "vn" => {
                chunk.normals.push(Vec3::from_array(numbers(&mut words)?));
                if words.next().is_some() {
                    return None;
                }
            }
            "f" => {
                corners.clear();
                let defined = [chunk.positions.len(), chunk.texcoords.len(), chunk.normals.len()];
                let mut face_form = None;
                for word in words {
                    let (indices, form) = corner(word)?;
                    if *face_form.get_or_insert(form) != form {
                        return None;
                    }
                    let excess = |a: usize| i64::from(indices[a]) + 1 - defined[a] as i64;
                    chunk.excess[0] = chunk.excess[0].max(excess(0));
                    if form != 0 {
                        for (a, bit) in [(1, TEXCOORD), (2, NORMAL)] {
                            if form & bit != 0 {
                                chunk.excess[a] = chunk.excess[a].max(excess(a));
                            }
                        }
                    }
                    corners.push(indices);
                }
                if corners.len() < 3 {
                    return None;
                }
                chunk.corners += corners.len() as u64;
                charge += mesh_charge(corners.len() as u64, corners.len() as u64 - 2);
                let form = face_form.unwrap_or(0);
                if chunk.form != Some(form) {
                    chunk.form = Some(form);
                    chunk.forms.push((chunk.triangles.len(), form));
                }
                // The attribute lists stay aligned with the triangles.
                let above = chunk.triangles.len();
                if form & TEXCOORD != 0 && chunk.texcoord_triangles.len() < above {
                    chunk.texcoord_triangles.resize(above, [0; 3]);
                }
                if form & NORMAL != 0 && chunk.normal_triangles.len() < above {
                    chunk.normal_triangles.resize(above, [0; 3]);
                }
                let first = corners[0];
                for bc in corners.windows(2).skip(1) {
                    chunk.triangles.push([first[0], bc[0][0], bc[1][0]]);
                    if form & TEXCOORD != 0 {
                        chunk.texcoord_triangles.push([first[1], bc[0][1], bc[1][1]]);
                    }
                    if form & NORMAL != 0 {
                        chunk.normal_triangles.push([first[2], bc[0][2], bc[1][2]]);
                    }
                }
            }
            "o" | "g" => {
                // tobj's name: the line after its first character, trimmed.
                let first = line.chars().next().map_or(0, char::len_utf8);
                let name = line[first..].trim();
                charge += MARK_BYTES + name.len() as u64;
                chunk.marks.push((chunk.triangles.len(), Mark::Name(name.to_owned())));
            }
            "mtllib" | "usemtl" => {
                let argument = line.split_once(' ').unwrap_or_default().1.trim();
                if argument.is_empty() {
                    return None;
                }
                charge += MARK_BYTES + argument.len() as u64;
                let argument = argument.to_owned();
                let mark = if key == "mtllib" { Mark::Library(argument) } else { Mark::Use(argument) };
                chunk.marks.push((chunk.triangles.len(), mark));
            }
            // Smoothing groups change nothing tobj returns.
            "s" => {}
            _ if key.starts_with('#') => {}
            _ => return None,
        }
    }
    let triangles = chunk.triangles.len();
    for list in [&mut chunk.texcoord_triangles, &mut chunk.normal_triangles] {
        if !list.is_empty() {
            list.resize(triangles, [0; 3]);
        }
    }
    let total = charged.fetch_add(charge, Ordering::Relaxed) + charge;
    (total <= allowance).then_some(chunk)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The whole file as one object.
    fn whole(text: &str) -> Object {
        let plain = parse(text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        let all = 0..plain.triangles as usize;
        plain.into_objects(&[all]).pop().unwrap_or_else(|| panic!("one object"))
    }

    #[test]
    fn quads_and_polygons_are_fans_and_positions_are_numbered_by_first_use() {
        let text = "# a comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nv 0.5 2 0\nf 3 4 1 2\nf 1 2 6 3 4\n";
        let plain = parse(text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        assert_eq!((plain.corners, plain.triangles, plain.marks.len()), (9, 5, 0));
        let object = whole(text);
        // Vertex 5 is never used: dropped, as tobj drops it.
        assert_eq!(object.positions.len(), 5);
        assert_eq!(object.positions[0], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(object.indices, vec![[0, 1, 2], [0, 2, 3], [2, 3, 4], [2, 4, 0], [2, 0, 1]]);
    }

    #[test]
    fn anything_else_goes_to_the_checked_path() {
        let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for rest in [
            "f 1 2 4\n",                                  // out of range
            "f 1 2\n",                                    // too few corners
            "f -3 -2 -1\n",                               // relative
            "f 1/1 2/2 3/3\n",                            // texture coordinates not defined
            "f 1//1 2//1 3//1\n",                         // normals not defined
            "vt 0 0\nf 1/1 2/1 3/1\nf 1 2 3\n",           // corners of two forms in one object
            "vt 0 0\nf 1/1 2/1 3/1\nusemtl a\nf 1 2 3\n", // (the material may end an object, or not)
            "vt 0 0\nf 1/1 2/1 3\n",                      // corners of two forms in one face
            "vt 0 0\nf 1/1 2/1 3/2\n",                    // a texture coordinate out of range
            "vt 0 0\nf 1/-1 2/-1 3/-1\n",                 // relative
            "vt 0 0\nf 1/ 2/ 3/\n",                       // empty indices
            "usemtl\n",                                   // no name
            "usemtl \n",
            "vn 0 0 1\nf 1// 2// 3//\n",
            "vn 0 0 1\nf 1/1/ 2/1/ 3/1/\n",
            "vn 0 0 1\nf 1//1/1 2//1 3//1\n", // four parts
            "vt 0\n",                         // one component
            "vt 0 0 0 0\n",                   // four
            "vt 0 0 x\n",                     // a w that is not a number
            "vn 0 1\n",                       // two components
            "vn 0 nan 1\n",                   // not finite
            "f 1 2 3 # x\n",                  // trailing comment
            "v 1 2 3 4\n",                    // w
            "v 1 2 3 0.5 0.5\n",              // two colour components
            "v 1 2 3 0.5 0.5 0.5\n",          // a colour on one `v` line of four
            "v 1 2 3 0.5 0.5 0.5 1\n",        // four
            "v 1 2 3 0.5 nan 0.5\n",          // not finite
            "v 1 nan 0\n",                    // not finite
            "v 1 1e39 0\n",                   // overflows to infinity
            "l 1 2\n",                        // a line element
            "f 1 2 3\nf 0 1 2\n",             // index 0
        ] {
            assert!(parse(&format!("{v}{rest}"), u64::MAX).is_none(), "{rest:?}");
        }
        // A face above the vertices, texture coordinates or normals it names.
        assert!(parse("v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n", u64::MAX).is_none());
        assert!(parse(&format!("{v}vt 0 0\nf 1/1 2/1 3/2\nvt 1 1\n"), u64::MAX).is_none());
        assert!(parse(&format!("{v}f 1//1 2//1 3//1\nvn 0 0 1\n"), u64::MAX).is_none());
        // Over the allowance: one triangle is charged 3 corners and 1 triangle.
        let text = format!("{v}f 1 2 3\n");
        let charge = mesh_charge(3, 1);
        assert!(parse(&text, charge - 1).is_none());
        assert!(parse(&text, charge).is_some());
        // And each `o`/`g`, `mtllib` or `usemtl` line its entry and its argument.
        let text = format!("{v}{}usemtl ab\nf 1 2 3\n", "o x\n".repeat(10));
        let charge = charge + 11 * MARK_BYTES + 10 + 2;
        assert!(parse(&text, charge - 1).is_none());
        assert!(parse(&text, charge).is_some());
    }

    #[test]
    fn each_distinct_triple_is_a_vertex_numbered_by_first_use() {
        // Position 3 comes with texture coordinate 3 and then 4 (a seam); vertex 2 is never used.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\nvt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5 0\n\
                    f 1/1 2/2 3/3\nf 3/4 2/2 1/1\nf 3/3 1/1 2/2\n";
        let plain = whole(text);
        assert_eq!(plain.indices, vec![[0, 1, 2], [3, 1, 0], [2, 0, 1]]);
        assert_eq!(plain.positions, [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 1., 0.]].map(Vec3::from_array));
        let texcoords = [[0., 0.], [1., 0.], [0., 1.], [0.5, 0.5]].map(Vec2::from_array);
        assert_eq!(plain.texcoords.as_deref(), Some(&texcoords[..]));
        assert_eq!(plain.normals, None);
        // With normals: position 1 with normal 1 and then 2.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 1//2 3//1 2//1\n";
        let plain = whole(text);
        assert_eq!(plain.indices, vec![[0, 1, 2], [3, 2, 1]]);
        let normals = [Vec3::Z, Vec3::Z, Vec3::Z, Vec3::NEG_Z];
        assert_eq!(plain.normals.as_deref(), Some(&normals[..]));
        assert_eq!(plain.texcoords, None);
    }

    #[test]
    fn each_object_numbers_its_own_vertices() {
        // Object a: position 3 with texture coordinates 3 and then 4 (a seam). Object b starts
        // with position 4, and meets the same triples in another order: its own numbers.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n\
                    o a\nf 1/1 2/2 3/3\nf 3/4 2/2 1/1\nusemtl m\no b\nf 4/1 1/1 3/3\nf 2/2 3/3 1/1\nf 3/4 1/1 2/2\n";
        let plain = parse(text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        let marks = [(0, Mark::Name("a".into())), (2, Mark::Use("m".into())), (2, Mark::Name("b".into()))];
        assert_eq!(plain.marks, marks);
        let objects = plain.into_objects(&[0..2, 2..5]);
        let [p1, p2, p3, p4] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]].map(Vec3::from_array);
        let [t1, t2, t3, t4] = [[0., 0.], [1., 0.], [0., 1.], [1., 1.]].map(Vec2::from_array);
        assert_eq!(objects[0].indices, [[0, 1, 2], [3, 1, 0]]);
        assert_eq!(objects[0].positions, [p1, p2, p3, p3]);
        assert_eq!(objects[0].texcoords.as_deref(), Some(&[t1, t2, t3, t4][..]));
        assert_eq!(objects[1].indices, [[0, 1, 2], [3, 2, 1], [4, 1, 3]]);
        assert_eq!(objects[1].positions, [p4, p1, p3, p2, p3]);
        assert_eq!(objects[1].texcoords.as_deref(), Some(&[t1, t1, t3, t2, t4][..]));
    }

    #[test]
    fn each_object_has_its_own_form() {
        // Object a's corners have normals, b's nothing, c's texture coordinates: each object's
        // vertices have what its corners have.
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0.5 0.5\no a\nf 1//1 2//1 3//1\no b\nusemtl m\n\
                    f 3 2 1\nf 1 2 3\ng c\nf 2/1 3/1 1/1\n";
        let plain = parse(text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        assert_eq!(plain.forms, [(0, NORMAL), (1, 0), (3, TEXCOORD)]);
        let objects = plain.into_objects(&[0..1, 1..3, 3..4]);
        let has = |o: &Object| (o.normals.is_some(), o.texcoords.is_some(), o.positions.len());
        assert_eq!(
            objects.iter().map(has).collect::<Vec<_>>(),
            [(true, false, 3), (false, false, 3), (false, true, 3)]
        );
        assert_eq!(objects[1].indices, [[0, 1, 2], [2, 1, 0]]);
        assert_eq!(objects[2].texcoords.as_deref(), Some(&[Vec2::splat(0.5); 3][..]));
    }

    #[test]
    fn lines_are_the_standard_lines() {
        for text in ["", "\n", "a", "a\n", "a\r\nb", "a\n\nb\r\n", "\r\n\r", "é\nü\r\n\r\r\n", "a\rb\n"] {
            assert_eq!(text_lines(text).collect::<Vec<_>>(), text.lines().collect::<Vec<_>>(), "{text:?}");
        }
    }

    #[test]
    fn corners_read_as_the_standard_parser_reads_their_indices() {
        for word in ["1", "+1", "0", "-1", "4294967296", "4294967295", "12a", "", "+", "++1", "١"] {
            let expected = word.parse::<u32>().ok().and_then(|i| i.checked_sub(1));
            assert_eq!(index(word.as_bytes(), &mut 0), expected, "{word:?}");
        }
        assert_eq!(corner("7"), Some(([6, 0, 0], 0)));
        assert_eq!(corner("7/3"), Some(([6, 2, 0], TEXCOORD)));
        assert_eq!(corner("7//5"), Some(([6, 0, 4], NORMAL)));
        assert_eq!(corner("7/3/5"), Some(([6, 2, 4], TEXCOORD | NORMAL)));
        for word in ["7/", "7//", "7/3/", "/3", "7/3/5/1", "7///5", "7/0/5", "7/x/5", "7//5/", "7/+/5", "+/3"] {
            assert_eq!(corner(word), None, "{word:?}");
        }
    }

    #[test]
    fn names_and_crlf_lines_are_read() {
        let text = "o  terrain \r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\ns off\r\nf 1 2 3\r\ng\r\n";
        let plain = parse(text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        assert_eq!(plain.marks, [(0, Mark::Name("terrain".into())), (1, Mark::Name(String::new()))]);
        assert_eq!(whole(text).indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn chunks_join_across_line_ends_and_faces_refer_back_across_chunks() {
        // About 3 MB: four chunks. Every face refers to the first three vertices and the latest one
        // (numbered by first use: the third is numbered 3, after the first face's three).
        let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
        let n = 120_000;
        for k in 0..n {
            text.push_str(&format!("v {k} 0.5 {}\nf 1 2 {}\nf 3 {} 1\n", k as f32 * 0.25, k + 4, k + 4));
        }
        let plain = whole(&text);
        assert_eq!(plain.indices.len(), 2 * n);
        assert_eq!(plain.positions.len(), n + 3);
        for k in 0..n {
            let last = plain.indices[2 * k][2] as usize;
            assert_eq!(plain.positions[last], Vec3::new(k as f32, 0.5, k as f32 * 0.25));
            assert_eq!(plain.indices[2 * k + 1], [3, last as u32, 0]);
        }
    }
}
