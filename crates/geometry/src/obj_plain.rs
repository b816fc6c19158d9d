//! A parallel fast path for plain OBJ files: `v x y z` and `f` lines of plain vertex indices
//! (what scanners and terrain exporters write), parsed in chunks of lines on every core.
//!
//! tobj reads a line at a time into a `String` and, with `single_index`, looks every face corner
//! up in a `HashMap` of (position, uv, normal) triples; on a 60 MB, 1.6M-triangle terrain that was
//! 0.75 s of the 2.85 s `spectrace info` took, and the line-by-line pre-scan that guards it
//! another 0.2 s (`docs/perf.md`, "Loading and building"). Lines here are split by byte
//! offsets, parsed in parallel with the standard library's exactly rounded `f32` parser (the one
//! tobj uses), and the corners numbered in one pass over an array.
//!
//! The result is what tobj gives for the same text — one object, its positions in the order faces
//! first use them (unused ones dropped), polygons as fans from their first corner — so a file
//! loads the same whichever path reads it (the tests compare both on every OBJ fixture). Anything
//! else — normals, texture coordinates, colours, `w`, relative or malformed indices, faces of fewer
//! than three corners, materials, groups after faces, any other statement, a value that is not a
//! finite number, an index out of range — returns `None`, and the caller reads the file with tobj
//! behind the line-by-line checks, whose errors name the file and line. This path never reports
//! an error of its own.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use crate::limits::mesh_charge;

/// A plain OBJ file as tobj would load it (`single_index`, triangulated).
#[derive(Debug)]
pub(crate) struct Plain {
    /// The object's name: the last `o`/`g` line's, or tobj's `unnamed_object`.
    pub(crate) name: String,
    /// Positions in the order the faces first refer to them.
    pub(crate) positions: Vec<Vec3>,
    pub(crate) indices: Vec<[u32; 3]>,
    /// Face corners on `f` lines (the pre-scan's count, for the budget).
    pub(crate) corners: u64,
    /// Triangles after fan triangulation.
    pub(crate) triangles: u64,
}

/// Bytes of text per parallel task (cut at the next line end): 1 MB is a few milliseconds of
/// parsing, many tasks for any core count on large files, one task on small ones.
const CHUNK_BYTES: usize = 1 << 20;

/// Lines a task parses between looks at the shared charge.
const LINES_PER_CHARGE: usize = 4096;

/// What one chunk of lines holds.
#[derive(Debug, Default)]
struct Chunk {
    positions: Vec<Vec3>,
    /// Fan triangles, 0-based indices into the whole file's positions.
    triangles: Vec<[u32; 3]>,
    corners: u64,
    /// The largest (1-based index − vertices this chunk defined before the line): a face may only
    /// refer to vertices defined above it, so the vertices of the chunks before must be at least this.
    excess: i64,
    /// The last `o`/`g` line's name in the chunk.
    name: Option<String>,
    /// An `o`/`g` line after a face of this chunk (tobj would start a second object).
    named_after_face: bool,
}

/// Parses `text` if it is a plain OBJ file. `allowance`: the bytes the budget still allows; the
/// parse gives up (`None`) once the faces it has read would be charged more (`BYTES_PER_VERTEX`
/// per corner, `BYTES_PER_TRIANGLE` per triangle, as the caller then charges), so that an
/// over-budget file is refused by the checked path before this one allocates for it.
///
/// Positions are not charged as they are read: a `v` line of at least 8 bytes of text becomes a
/// 12-byte position, so they take at most about 4.5× the text at the peak (the chunks' vectors, up
/// to twice their length, while the whole array is joined), and the text was charged when it was
/// read. Faces are charged as read because what they cost (a triangle's share of the BVH) is not
/// bounded by their text's size.
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
    let chunks: Vec<Chunk> = if starts.len() > 2 {
        starts.par_windows(2).map(parse).collect::<Option<Vec<Chunk>>>()?
    } else {
        starts.windows(2).map(parse).collect::<Option<Vec<Chunk>>>()?
    };

    // Faces refer only to vertices above them; `o`/`g` only before the first face.
    let (mut before, mut faces_above, mut name) = (0i64, false, None);
    for chunk in &chunks {
        if chunk.name.is_some() {
            if faces_above || chunk.named_after_face {
                return None;
            }
            name.clone_from(&chunk.name);
        }
        if !chunk.triangles.is_empty() && chunk.excess > before {
            return None;
        }
        before += chunk.positions.len() as i64;
        faces_above |= !chunk.triangles.is_empty();
    }
    if before > i64::from(u32::MAX) {
        return None;
    }
    let corners = chunks.iter().map(|c| c.corners).sum();
    let triangles: usize = chunks.iter().map(|c| c.triangles.len()).sum();
    let mut file_positions = Vec::with_capacity(before as usize);
    let mut parts = Vec::with_capacity(chunks.len());
    for chunk in chunks {
        file_positions.extend(chunk.positions);
        parts.push(chunk.triangles);
    }
    // tobj's numbering: a position gets the next index when a face first uses it.
    let mut number = vec![u32::MAX; file_positions.len()];
    let mut positions = Vec::with_capacity(file_positions.len());
    let mut indices = Vec::with_capacity(triangles);
    for part in parts {
        for triangle in part {
            indices.push(triangle.map(|i| {
                let n = &mut number[i as usize];
                if *n == u32::MAX {
                    *n = positions.len() as u32;
                    positions.push(file_positions[i as usize]);
                }
                *n
            }));
        }
    }
    Some(Plain {
        name: name.filter(|n| !n.is_empty()).unwrap_or_else(|| "unnamed_object".to_owned()),
        positions,
        indices,
        corners,
        triangles: triangles as u64,
    })
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
    let mut chunk = Chunk { excess: i64::MIN, ..Default::default() };
    let mut corners: Vec<u32> = Vec::new();
    let (mut charge, mut lines) = (0u64, 0usize);
    for line in text.lines() {
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
                let mut p = [0f32; 3];
                for c in &mut p {
                    *c = words.next()?.parse().ok()?;
                }
                if words.next().is_some() || !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
                    return None;
                }
                chunk.positions.push(Vec3::from_array(p));
            }
            "f" => {
                corners.clear();
                for word in words {
                    let index: u32 = word.parse().ok()?;
                    if index == 0 {
                        return None;
                    }
                    chunk.excess = chunk.excess.max(i64::from(index) - chunk.positions.len() as i64);
                    corners.push(index - 1);
                }
                if corners.len() < 3 {
                    return None;
                }
                chunk.corners += corners.len() as u64;
                charge += mesh_charge(corners.len() as u64, corners.len() as u64 - 2);
                let first = corners[0];
                chunk.triangles.extend(corners.windows(2).skip(1).map(|bc| [first, bc[0], bc[1]]));
            }
            "o" | "g" => {
                // tobj's name: the line after its first character, trimmed.
                let first = line.chars().next().map_or(0, char::len_utf8);
                chunk.name = Some(line[first..].trim().to_owned());
                chunk.named_after_face |= !chunk.triangles.is_empty();
            }
            // Smoothing groups change nothing tobj returns.
            "s" => {}
            _ if key.starts_with('#') => {}
            _ => return None,
        }
    }
    let total = charged.fetch_add(charge, Ordering::Relaxed) + charge;
    (total <= allowance).then_some(chunk)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_and_polygons_are_fans_and_positions_are_numbered_by_first_use() {
        let text = "# a comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nv 0.5 2 0\nf 3 4 1 2\nf 1 2 6 3 4\n";
        let plain = parse(text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        // Vertex 5 is never used: dropped, as tobj drops it.
        assert_eq!(plain.positions.len(), 5);
        assert_eq!(plain.positions[0], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(plain.indices, vec![[0, 1, 2], [0, 2, 3], [2, 3, 4], [2, 4, 0], [2, 0, 1]]);
        assert_eq!((plain.corners, plain.triangles), (9, 5));
        assert_eq!(plain.name, "unnamed_object");
    }

    #[test]
    fn anything_else_goes_to_the_checked_path() {
        let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for rest in [
            "f 1 2 4\n",          // out of range
            "f 1 2\n",            // too few corners
            "f -3 -2 -1\n",       // relative
            "f 1/1 2/2 3/3\n",    // with texture coordinates
            "f 1 2 3 # x\n",      // trailing comment
            "vn 0 0 1\n",         // normals
            "v 1 2 3 4\n",        // w
            "v 1 nan 0\n",        // not finite
            "v 1 1e39 0\n",       // overflows to infinity
            "usemtl a\n",         // materials
            "f 1 2 3\no b\n",     // a second object
            "l 1 2\n",            // a line element
            "f 1 2 3\nf 0 1 2\n", // index 0
        ] {
            assert!(parse(&format!("{v}{rest}"), u64::MAX).is_none(), "{rest:?}");
        }
        // A face above the vertices it names.
        assert!(parse("v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n", u64::MAX).is_none());
        // Over the allowance: one triangle is charged 3 corners and 1 triangle.
        let text = format!("{v}f 1 2 3\n");
        let charge = mesh_charge(3, 1);
        assert!(parse(&text, charge - 1).is_none());
        assert!(parse(&text, charge).is_some());
    }

    #[test]
    fn names_before_faces_and_crlf_lines_are_read() {
        let plain = parse("o  terrain \r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\ns off\r\nf 1 2 3\r\n", u64::MAX)
            .unwrap_or_else(|| panic!("plain"));
        assert_eq!(plain.name, "terrain");
        assert_eq!(plain.indices, vec![[0, 1, 2]]);
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
        let plain = parse(&text, u64::MAX).unwrap_or_else(|| panic!("plain"));
        assert_eq!(plain.indices.len(), 2 * n);
        assert_eq!(plain.positions.len(), n + 3);
        for k in 0..n {
            let last = plain.indices[2 * k][2] as usize;
            assert_eq!(plain.positions[last], Vec3::new(k as f32, 0.5, k as f32 * 0.25));
            assert_eq!(plain.indices[2 * k + 1], [3, last as u32, 0]);
        }
    }
}
