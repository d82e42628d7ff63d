//! OBJ text read in parallel: the text split at line ends into chunks that rayon parses
//! at once, then the chunks' relative indices resolved by the counts of the chunks
//! before them and the triangles assembled in file order.
//!
//! A fast path beside tobj, not a second reader of the format: it accepts only what it
//! reads exactly as the checked tobj path does (`read_obj`) and gives up (`None`) on
//! anything else, so every error, and every file it does not fully understand, is still
//! the checked path's, with its messages and lines. It takes `v` lines of exactly three
//! numbers, finite and within the coordinate limit; `vt` and `vn` lines (numbers tobj
//! parses); `f` lines of at least three `v`, `v/vt`, `v//vn` or `v/vt/vn` references,
//! each naming one defined above it; `usemtl NAME` at the start of a line; `mtllib`,
//! `o`, `g` and any other statement (ignored, as tobj ignores it, or without effect on
//! the triangles: tobj's objects split the faces but keep their order). It gives up on
//! `l` lines (tobj makes a triangle of three points), vertex weights and colours,
//! forward references, and any non-ASCII byte where a statement's words are.
//!
//! What it returns is what `read_obj` returns through tobj, bit for bit: faces in file
//! order, each fanned from its first vertex as tobj triangulates, positions parsed by
//! the same `str::parse::<f32>`, the same degenerate count, normals and material groups
//! (`same_as_the_checked_path` below, and the `obj` fuzz target, compare the two).

use super::{area_weighted_normals, unit_normals, MeshTriangles, ObjOptions};
use crate::geometry::triangle::is_proper_triangle;
use crate::scene::limits::MAX_COORDINATE;
use glam::Vec3;
use rayon::prelude::*;

/// Chunks of about this many bytes are parsed in parallel; a smaller text is one chunk.
pub(super) const CHUNK_BYTES: usize = 1 << 20;

/// A corner's normal when its face vertex names none.
const NO_NORMAL: u32 = u32::MAX;

/// Why the fast path gives up: the checked path reads the file instead.
struct GiveUp;

type Parse<T> = std::result::Result<T, GiveUp>;

/// The state of `usemtl` for the triangles from a chunk's `first` on.
#[derive(Clone, Copy)]
struct MaterialRun {
    first: usize,
    /// 1 + the material's index in the names, 0 for none.
    group: u32,
    /// Whether an `mtllib` came before the `usemtl` in this chunk: tobj knows a
    /// material's name only after a library is loaded.
    library_before: bool,
}

/// What one chunk of lines holds.
#[derive(Default)]
struct Chunk {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    /// `[v, vt, vn]` statements in the chunk.
    counts: [usize; 3],
    /// Three vertex indices a triangle (fanned from each face's first vertex): absolute,
    /// or for the slots in `pending`, relative to the chunk's first vertex (as `i32`
    /// bits).
    corners: Vec<u32>,
    /// Three normal indices a triangle, as `corners`, when reading normals.
    normal_corners: Vec<u32>,
    /// Slots of `corners` (kind 0) and `normal_corners` (kind 2) that hold a negative
    /// reference resolved relative to the chunk's start.
    pending: Vec<(usize, usize)>,
    /// Per kind, the least chunk-relative index of a negative reference (must be
    /// resolved to at least 0) and the largest excess of a positive reference over the
    /// chunk's count so far (must be less than the count before the chunk).
    least_relative: [i64; 3],
    most_excess: [i64; 3],
    /// Whether every face vertex names a normal.
    faces_name_normals: bool,
    /// The `usemtl` statements' runs, in order.
    materials: Vec<MaterialRun>,
    /// Whether the chunk has an `mtllib`.
    library: bool,
}

/// Read `text` (its lone CRs already made LFs) as `read_obj` would, or `None` where the
/// checked path must read it.
pub(super) fn read(text: &str, options: ObjOptions, chunk_bytes: usize) -> Option<MeshTriangles> {
    let bytes = text.as_bytes();
    let chunks = line_chunks(bytes, chunk_bytes);
    let names = options.materials.unwrap_or(&[]);
    let mut parsed: Vec<Chunk> = chunks
        .par_iter()
        .map(|&(start, end)| parse_chunk(text, start, end, options.smooth, names))
        .collect::<Parse<_>>()
        .ok()?;

    // Each chunk's references against the counts before it.
    let mut before = [0usize; 3];
    let mut library_before = false;
    let mut group_before = 0u32;
    let mut starts = Vec::with_capacity(parsed.len());
    let mut groups_before = Vec::with_capacity(parsed.len());
    for chunk in &parsed {
        let (least, most) = (chunk.least_relative, chunk.most_excess);
        for ((b, least), most) in before.iter().zip(least).zip(most) {
            if *b as i64 + least < 0 || most >= *b as i64 {
                return None;
            }
        }
        starts.push(before);
        groups_before.push((group_before, library_before));
        if let Some(last) = chunk.materials.last() {
            group_before = if last.library_before || library_before {
                last.group
            } else {
                0
            };
        }
        library_before |= chunk.library;
        for (b, count) in before.iter_mut().zip(chunk.counts) {
            *b += count;
        }
    }
    parsed
        .par_iter_mut()
        .zip(&starts)
        .for_each(|(chunk, start)| {
            for &(slot, kind) in &chunk.pending {
                let list = if kind == 0 {
                    &mut chunk.corners
                } else {
                    &mut chunk.normal_corners
                };
                list[slot] = (start[kind] as i64 + list[slot] as i32 as i64) as u32;
            }
        });

    let positions: Vec<Vec3> = parsed.iter().flat_map(|c| &c.positions).copied().collect();
    let smooth = options.smooth;
    let file_normals = smooth && parsed.iter().all(|c| c.faces_name_normals);
    let normal_values: Vec<Vec3> = if file_normals {
        parsed.iter().flat_map(|c| &c.normals).copied().collect()
    } else {
        Vec::new()
    };

    // Every chunk's triangles into its own range of the output, the proper ones first.
    let counts: Vec<usize> = parsed.iter().map(|c| c.corners.len() / 3).collect();
    let total: usize = counts.iter().sum();
    let mut triangles = vec![[Vec3::ZERO; 3]; total];
    let mut corner_normals = vec![[Vec3::ZERO; 3]; if file_normals { total } else { 0 }];
    let with_material = options.materials.is_some();
    let mut material = vec![0u32; if with_material { total } else { 0 }];
    let mut ranges = Vec::with_capacity(parsed.len());
    {
        let (mut t, mut n, mut m) = (
            &mut triangles[..],
            &mut corner_normals[..],
            &mut material[..],
        );
        for &count in &counts {
            let (t0, t1) = t.split_at_mut(count);
            let (n0, n1) = n.split_at_mut(if file_normals { count } else { 0 });
            let (m0, m1) = m.split_at_mut(if with_material { count } else { 0 });
            ranges.push((t0, n0, m0));
            (t, n, m) = (t1, n1, m1);
        }
    }
    let kept: Vec<usize> = ranges
        .into_par_iter()
        .zip(&parsed)
        .zip(&groups_before)
        .map(
            |(((tri_out, normal_out, material_out), chunk), &(group, library))| {
                let mut runs = chunk.materials.iter().peekable();
                let mut group = group;
                let mut k = 0;
                for (i, c) in chunk.corners.chunks_exact(3).enumerate() {
                    while let Some(run) = runs.next_if(|r| r.first == i) {
                        group = if run.library_before || library {
                            run.group
                        } else {
                            0
                        };
                    }
                    let tri = [c[0], c[1], c[2]].map(|v| positions[v as usize]);
                    if !is_proper_triangle(tri) {
                        continue;
                    }
                    tri_out[k] = tri;
                    if file_normals {
                        let n = &chunk.normal_corners[3 * i..3 * i + 3];
                        normal_out[k] = [n[0], n[1], n[2]].map(|v| normal_values[v as usize]);
                    }
                    if with_material {
                        material_out[k] = group;
                    }
                    k += 1;
                }
                k
            },
        )
        .collect();
    drop(parsed);
    // Close the gaps the degenerate triangles left.
    let mut to = 0;
    let mut from = 0;
    for (&count, &kept) in counts.iter().zip(&kept) {
        if to != from {
            triangles.copy_within(from..from + kept, to);
            if file_normals {
                corner_normals.copy_within(from..from + kept, to);
            }
            if with_material {
                material.copy_within(from..from + kept, to);
            }
        }
        to += kept;
        from += count;
    }
    triangles.truncate(to);
    corner_normals.truncate(to);
    material.truncate(to);
    if triangles.is_empty() {
        return None;
    }
    let normals = match (smooth, file_normals) {
        (false, _) => Vec::new(),
        (true, true) => unit_normals(&triangles, &corner_normals),
        (true, false) => unit_normals(&triangles, &area_weighted_normals(&triangles)),
    };
    Some(MeshTriangles {
        degenerate: total - triangles.len(),
        triangles,
        normals,
        material,
    })
}

/// `(start, end)` byte ranges of about `chunk_bytes`, each ending after an LF (the last
/// at the text's end).
fn line_chunks(bytes: &[u8], chunk_bytes: usize) -> Vec<(usize, usize)> {
    let mut chunks = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        let guess = (start + chunk_bytes).min(bytes.len());
        let end = match memchr::memchr(b'\n', &bytes[guess..]) {
            Some(i) => guess + i + 1,
            None => bytes.len(),
        };
        chunks.push((start, end));
        start = end;
    }
    chunks
}

/// The ASCII characters `char::is_whitespace` accepts (tobj splits words with it).
#[inline(always)]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')
}

/// The lines of one chunk, read a word at a time.
struct Cursor<'t> {
    text: &'t str,
    bytes: &'t [u8],
    at: usize,
    end: usize,
}

impl<'t> Cursor<'t> {
    /// Past the blanks (white space but LF) before the next word.
    #[inline(always)]
    fn skip_blanks(&mut self) {
        while self.at < self.end && self.bytes[self.at] != b'\n' && is_space(self.bytes[self.at]) {
            self.at += 1;
        }
    }

    /// The next word of the line (empty at its end), split at ASCII white space; a
    /// non-ASCII byte in it gives up (Unicode white space would split it where tobj
    /// does).
    #[inline(always)]
    fn word(&mut self) -> Parse<&'t [u8]> {
        self.skip_blanks();
        let start = self.at;
        while self.at < self.end && !is_space(self.bytes[self.at]) {
            if self.bytes[self.at] >= 0x80 {
                return Err(GiveUp);
            }
            self.at += 1;
        }
        Ok(&self.bytes[start..self.at])
    }

    /// The next word as an `f32`, as `str::parse` reads it.
    #[inline(always)]
    fn number(&mut self) -> Parse<f32> {
        let start = self.at;
        let word = self.word()?;
        if let Some(x) = decimal(word) {
            return Ok(x);
        }
        // The word's ends are ASCII, so on char boundaries.
        let word = self.text.get(start..self.at).ok_or(GiveUp)?.trim_start();
        word.parse().map_err(|_| GiveUp)
    }

    /// Whether the line has no more words.
    #[inline(always)]
    fn at_line_end(&mut self) -> bool {
        self.skip_blanks();
        self.at == self.end || self.bytes[self.at] == b'\n'
    }

    /// To the next line's start.
    #[inline(always)]
    fn next_line(&mut self) {
        self.at = match memchr::memchr(b'\n', &self.bytes[self.at..self.end]) {
            Some(i) => self.at + i + 1,
            None => self.end,
        };
    }
}

/// Powers of ten exact in f64.
const POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// A decimal number of at most 19 significant digits whose value `str::parse::<f32>` gives without
/// its slow paths, else `None` (the caller then asks `str::parse`): `[+-]digits[.digits]
/// [e[+-]digits]` (or `.digits`). The digits m, at most 2^53, and the power of ten p, at
/// most 22 either way, are exact in f64, so m · 10^p (or m / 10^-p) is the exact value
/// rounded once, to f64 (Clinger's fast path); rounding that to f32 is the exact value
/// rounded to f32, as `str::parse` gives it, unless the f64 fell exactly halfway between
/// two f32s (a second rounding could then go the wrong way: left to `str::parse`) or
/// outside f32's normal range.
#[inline(always)]
fn decimal(word: &[u8]) -> Option<f32> {
    let (negative, mut rest) = match word.first()? {
        b'-' => (true, &word[1..]),
        b'+' => (false, &word[1..]),
        _ => (false, word),
    };
    let mut mantissa = 0u64;
    // Significant digits (leading zeros are not), and whether there is any digit.
    let mut digits = 0usize;
    let mut any = false;
    let mut fraction = 0i32;
    let mut seen_point = false;
    loop {
        match rest.first() {
            Some(&d) if d.is_ascii_digit() => {
                if digits == 19 {
                    return None;
                }
                mantissa = mantissa * 10 + (d - b'0') as u64;
                digits += (mantissa != 0) as usize;
                any = true;
                fraction += seen_point as i32;
            }
            Some(b'.') if !seen_point => seen_point = true,
            _ => break,
        }
        rest = &rest[1..];
    }
    if !any {
        return None;
    }
    let mut exponent = 0i32;
    if let Some((b'e' | b'E', tail)) = rest.split_first() {
        let (negative, tail) = match tail.first() {
            Some(b'-') => (true, &tail[1..]),
            Some(b'+') => (false, &tail[1..]),
            _ => (false, tail),
        };
        if tail.is_empty() || tail.len() > 4 || !tail.iter().all(u8::is_ascii_digit) {
            return None;
        }
        let e = tail.iter().fold(0, |e, &d| e * 10 + (d - b'0') as i32);
        exponent = if negative { -e } else { e };
        rest = &[];
    }
    if !rest.is_empty() || mantissa > 1 << 53 {
        return None;
    }
    let power = exponent - fraction;
    let m = mantissa as f64;
    let x = match power {
        0..=22 => m * POWERS_OF_TEN[power as usize],
        -22..=-1 => m / POWERS_OF_TEN[-power as usize],
        _ => return None,
    };
    // Halfway between two f32s: the 29 bits f32 drops are 1000…0.
    const DROPPED: u64 = (1 << 29) - 1;
    let halfway = x.to_bits() & DROPPED == 1 << 28;
    let normal = x == 0.0 || (f32::MIN_POSITIVE as f64..=f32::MAX as f64).contains(&x);
    if halfway || !normal {
        return None;
    }
    let x = x as f32;
    Some(if negative { -x } else { x })
}

/// A face index as `isize::from_str` reads it: an optional sign and decimal digits.
#[inline(always)]
fn index(word: &[u8]) -> Parse<i64> {
    let (negative, digits) = match word.first() {
        Some(b'-') => (true, &word[1..]),
        Some(b'+') => (false, &word[1..]),
        _ => (false, word),
    };
    if digits.is_empty() || digits.len() > 12 {
        return Err(GiveUp);
    }
    let mut value = 0i64;
    for &d in digits {
        if !d.is_ascii_digit() {
            return Err(GiveUp);
        }
        value = value * 10 + (d - b'0') as i64;
    }
    Ok(if negative { -value } else { value })
}

fn parse_chunk(
    text: &str,
    start: usize,
    end: usize,
    smooth: bool,
    names: &[String],
) -> Parse<Chunk> {
    let mut chunk = Chunk {
        faces_name_normals: true,
        most_excess: [i64::MIN; 3],
        ..Chunk::default()
    };
    // Vertex lines and face lines of a mesh file are about 30 bytes each.
    chunk.positions.reserve((end - start) / 64);
    chunk.corners.reserve((end - start) / 8);
    let mut face: Vec<(Slot, Option<Slot>)> = Vec::new();
    let mut line = Cursor {
        text,
        bytes: text.as_bytes(),
        at: start,
        end,
    };
    while line.at < end {
        let line_start = line.at;
        match line.word()? {
            b"v" => {
                let p = Vec3::new(line.number()?, line.number()?, line.number()?);
                if !line.at_line_end()
                    || !p.is_finite()
                    || p.abs().max_element() as f64 > MAX_COORDINATE
                {
                    return Err(GiveUp);
                }
                chunk.positions.push(p);
                chunk.counts[0] += 1;
            }
            b"vt" => {
                line.number()?;
                line.number()?;
                chunk.counts[1] += 1;
            }
            b"vn" => {
                let n = Vec3::new(line.number()?, line.number()?, line.number()?);
                if smooth {
                    if !n.is_finite() {
                        return Err(GiveUp);
                    }
                    chunk.normals.push(n);
                }
                chunk.counts[2] += 1;
            }
            b"f" => {
                face.clear();
                loop {
                    let word = line.word()?;
                    if word.is_empty() {
                        break;
                    }
                    face.push(reference(&mut chunk, word, smooth)?);
                }
                if face.len() < 3 {
                    return Err(GiveUp);
                }
                for i in 1..face.len() - 1 {
                    for corner in [face[0], face[i], face[i + 1]] {
                        push_corner(&mut chunk, corner, smooth);
                    }
                }
            }
            b"l" => return Err(GiveUp),
            b"mtllib" => chunk.library = true,
            b"usemtl" => {
                // tobj takes the name after the line's first space.
                let line_end = memchr::memchr(b'\n', &text.as_bytes()[line_start..end])
                    .map_or(end, |i| line_start + i);
                let name = text[line_start..line_end]
                    .strip_prefix("usemtl ")
                    .ok_or(GiveUp)?
                    .trim();
                if name.is_empty() {
                    return Err(GiveUp);
                }
                let group = names
                    .iter()
                    .position(|n| n == name)
                    .map_or(0, |i| i as u32 + 1);
                chunk.materials.push(MaterialRun {
                    first: chunk.corners.len() / 3,
                    group,
                    library_before: chunk.library,
                });
            }
            _ => {}
        }
        line.next_line();
    }
    Ok(chunk)
}

/// A face vertex's position or normal index: absolute, or (`relative`) relative to the
/// chunk's first, as `i32` bits.
#[derive(Clone, Copy)]
struct Slot {
    value: u32,
    relative: bool,
}

/// One face vertex: its position's and (when reading normals and it names one) its
/// normal's slot.
fn reference(chunk: &mut Chunk, word: &[u8], smooth: bool) -> Parse<(Slot, Option<Slot>)> {
    let mut parts = word.split(|&b| b == b'/');
    let mut slots = [None, None];
    for k in 0..3 {
        let part = parts.next().unwrap_or(&[]);
        if part.is_empty() {
            match k {
                0 => return Err(GiveUp),
                2 => chunk.faces_name_normals = false,
                _ => {}
            }
            continue;
        }
        let x = index(part)?;
        let so_far = chunk.counts[k] as i64;
        let slot = if x > 0 {
            chunk.most_excess[k] = chunk.most_excess[k].max(x - 1 - so_far);
            Slot {
                value: u32::try_from(x - 1).map_err(|_| GiveUp)?,
                relative: false,
            }
        } else if x < 0 {
            let relative = so_far + x;
            chunk.least_relative[k] = chunk.least_relative[k].min(relative);
            Slot {
                value: i32::try_from(relative).map_err(|_| GiveUp)? as u32,
                relative: true,
            }
        } else {
            return Err(GiveUp);
        };
        match k {
            0 => slots[0] = Some(slot),
            2 if smooth => slots[1] = Some(slot),
            _ => {}
        }
    }
    match (parts.next(), slots) {
        (None, [Some(position), normal]) => Ok((position, normal)),
        _ => Err(GiveUp),
    }
}

fn push_corner(chunk: &mut Chunk, (v, n): (Slot, Option<Slot>), smooth: bool) {
    if v.relative {
        chunk.pending.push((chunk.corners.len(), 0));
    }
    chunk.corners.push(v.value);
    if smooth {
        let n = n.unwrap_or(Slot {
            value: NO_NORMAL,
            relative: false,
        });
        if n.relative {
            chunk.pending.push((chunk.normal_corners.len(), 2));
        }
        chunk.normal_corners.push(n.value);
    }
}

#[cfg(test)]
mod tests {
    use super::super::{read_obj_checked, read_obj_parallel};
    use super::*;

    /// The two readers agree: where the checked path refuses the text the parallel one
    /// gives up, and where it reads a mesh the parallel one (when it takes the text)
    /// reads the same bits, at every chunk size. Whether the parallel one took it.
    fn agree(text: &str, names: &[String], chunk_sizes: &[usize]) -> bool {
        let mut took = false;
        for smooth in [false, true] {
            for materials in [None, Some(names)] {
                let options = ObjOptions { smooth, materials };
                let checked = read_obj_checked("t.obj", text, options);
                for &size in chunk_sizes {
                    let parallel = read_obj_parallel(text, options, size);
                    match (&checked, parallel) {
                        (_, None) => {}
                        (Err(e), Some(_)) => {
                            panic!("taken, but the checked path says {e}: {text:?}")
                        }
                        (Ok(want), Some(got)) => {
                            took = true;
                            let bits = |t: &[[Vec3; 3]]| -> Vec<[[u32; 3]; 3]> {
                                t.iter()
                                    .map(|c| c.map(|p| p.to_array().map(f32::to_bits)))
                                    .collect()
                            };
                            assert_eq!(bits(&got.triangles), bits(&want.triangles), "{text:?}");
                            assert_eq!(bits(&got.normals), bits(&want.normals), "{text:?}");
                            assert_eq!(got.material, want.material, "{text:?}");
                            assert_eq!(got.degenerate, want.degenerate, "{text:?}");
                        }
                    }
                }
            }
        }
        took
    }

    fn file(path: &str) -> String {
        let bytes = std::fs::read(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
        String::from_utf8_lossy(&bytes).into_owned()
    }

    #[test]
    fn takes_the_models_and_reads_them_as_the_checked_path_does() {
        let names: Vec<String> = ["brass", "glass", "lamp", "missing"]
            .map(String::from)
            .to_vec();
        for path in [
            "assets/bunny.obj",
            "scenes/models/gem.obj",
            "scenes/models/lamp.obj",
            "scenes/models/pawn.obj",
        ] {
            assert!(
                agree(&file(path), &names, &[1, 100, 4096, CHUNK_BYTES]),
                "{path}"
            );
        }
    }

    #[test]
    fn agrees_on_the_fuzz_seeds() {
        let dir = format!("{}/fuzz/seeds/obj", env!("CARGO_MANIFEST_DIR"));
        for entry in std::fs::read_dir(dir).unwrap() {
            let text = String::from_utf8_lossy(&std::fs::read(entry.unwrap().path()).unwrap())
                .into_owned();
            agree(&text, &["x".into(), "a".into()], &[1, 7, 64, CHUNK_BYTES]);
        }
    }

    #[test]
    fn takes_what_meshes_commonly_hold() {
        let names: Vec<String> = vec!["red".into(), "blue".into()];
        let cases = [
            // Negative references, some reaching into earlier chunks.
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 0\nf -4 -2 -1\nf -1 -3 -2\n",
            // Quads and a polygon, fanned from the first vertex; a degenerate face.
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nf 1 2 3 4\nf 1 2 3 5 4\nf 1 1 2\n",
            // Texture coordinates and normals, tabs and CR LF.
            "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nvt 0 0\r\nvt 1 0 0.5\r\nvn 0 0 1\r\nvn\t0 0.6 0.8\r\n\
             f 1/1/1 2/2/2 3/1/1\r\nf 3//2 2//1 1//1\r\nf 1/2 3/1 2/1\r\n",
            // Materials: before any library, unknown, repeated, across objects and groups.
            "usemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nmtllib a.mtl\no one\nf 1 3 2\n\
             usemtl blue\ng two\nf 2 3 1\nusemtl nothing\nf 3 1 2\nusemtl red\nusemtl red\nf 1 2 3\n\
             mtllib b.mtl\nf 2 1 3\nusemtl blue\nf 3 2 1\n",
            // Comments in UTF-8, unknown statements, blank lines, no final LF.
            "# modèle\nv 0 0 0\ns off\n\nv 1e0 0 0\nv 0 +1.0 0\np 1\nf 1 2 3",
            // Numbers std reads its slow way: many digits, large exponents, halfway cases.
            "v 0.1000000000000000055511151231257827 3.4e-38 1e-45\nv 16777217 1 0\n\
             v 0.000000059604644775390625 7e9 -0\nf 1 2 3\n",
        ];
        for text in cases {
            assert!(
                agree(text, &names, &[1, 5, 16, 64, CHUNK_BYTES]),
                "{text:?}"
            );
        }
    }

    #[test]
    fn leaves_the_rest_to_the_checked_path() {
        let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for tail in [
            "f 1 2 4\n",                // out of range
            "f 4 1 2\nv 1 1 0\n",       // a forward reference (tobj resolves it)
            "f 1 2 0\n",                // index 0
            "f 1 2\n",                  // two vertices
            "f 1 2 3/1/1/1\n",          // four parts
            "f 1 2 /1\n",               // no vertex index
            "l 1 2 3\n",                // tobj makes a triangle of it
            "v 1 1 0 2\nf 1 2 4\n",     // a weight
            "v 1 1 0 1 0 0\nf 1 2 4\n", // a colour
            "v 1 nan 0\nf 1 2 4\n",
            "v 1 2e10 0\nf 1 2 4\n",
            "vt 1\nf 1 2 3\n",
            "vn 0 0 x\nf 1 2 3\n",
            " usemtl red\nf 1 2 3\n",
            "usemtl\tred\nf 1 2 3\n",
            "usemtl \nf 1 2 3\n",
            "f 1 2 3\u{a0}\n",
            "f 1 1 1\n", // nothing but degenerate faces
        ] {
            let text = format!("{head}{tail}");
            assert!(
                !agree(&text, &["red".into()], &[1, 8, CHUNK_BYTES]),
                "{text:?}"
            );
        }
        // Normals tobj would read, but not as finite numbers: the checked path's error
        // when smooth.
        let text = format!("{head}vn 0 0 1e39\nf 1//1 2//1 3//1\n");
        let smooth = ObjOptions {
            smooth: true,
            materials: None,
        };
        assert!(read_obj_parallel(&text, smooth, 8).is_none());
        assert!(read_obj_parallel(&text, ObjOptions::default(), 8).is_some());
    }

    /// Small changes to small files, each read both ways (a deterministic fuzzer).
    #[test]
    fn mutations_agree() {
        let seeds = [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf -1 -2 -3 -4\n",
            "mtllib m.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\ng g\nf 1 2 3\nusemtl blue\nf 3 2 1\n",
        ];
        let pieces = [
            " ", "\n", "\r", "\t", "/", "-", "+", "0", "1", "2", "3", "9", ".", "e", "f", "v",
            "vn", "vt", "l", "g", "o", "usemtl ", "mtllib", "#", "nan", "inf", "1e40", "\u{a0}",
            "é",
        ];
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as usize
        };
        let mut taken = 0;
        for _ in 0..1500 {
            let mut text = seeds[next(seeds.len())].to_string();
            for _ in 0..1 + next(3) {
                let mut at = next(text.len() + 1);
                while !text.is_char_boundary(at) {
                    at -= 1;
                }
                match next(3) {
                    0 => text.insert_str(at, pieces[next(pieces.len())]),
                    1 => {
                        let mut to = (at + 1 + next(3)).min(text.len());
                        while !text.is_char_boundary(to) {
                            to += 1;
                        }
                        text.replace_range(at..to, "");
                    }
                    _ => {
                        let mut to = (at + 1).min(text.len());
                        while !text.is_char_boundary(to) {
                            to += 1;
                        }
                        text.replace_range(at..to, pieces[next(pieces.len())]);
                    }
                }
            }
            taken += agree(&text, &["red".into(), "blue".into()], &[1, 4, 64]) as usize;
        }
        // A fair share of the changes leave a file the parallel reader takes.
        assert!(taken > 200, "{taken}");
    }

    #[test]
    fn decimals_read_as_str_parse_reads_them() {
        let check = |word: &str| {
            if let Some(x) = decimal(word.as_bytes()) {
                let want: f32 = word.parse().unwrap();
                assert_eq!(x.to_bits(), want.to_bits(), "{word}");
            }
        };
        for word in [
            "0",
            "-0",
            "+0",
            "0.",
            ".5",
            "-.5",
            "1e5",
            "1E-5",
            "1e+5",
            "1.5e22",
            "1e-22",
            "16777216",
            "16777217",
            "16777219",
            "0.1",
            "3.4028235e38",
            "1.1754944e-38",
            "9007199254740993",
            "1.00000005960464477539",
            "0.000000059604644775390625",
        ] {
            check(word);
        }
        // Every f32 printed shortest, in full, and rounded, over a spread of magnitudes.
        let mut x = 0x1234_5678u32;
        for _ in 0..200_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let v = f32::from_bits(x);
            if !v.is_finite() {
                continue;
            }
            check(&format!("{v:?}"));
            check(&format!("{v:e}"));
            check(&format!("{:.7e}", v));
            check(&format!("{:.10}", v as f64));
            let m = (x >> 8) % 100_000_000;
            check(&format!("{m}e{}", (x % 45) as i32 - 22));
            // Halfway between two f32s, and its neighbours in the last digit.
            let next = f32::from_bits(v.abs().to_bits() + 1);
            let mid = (v.abs() as f64 + next as f64) / 2.0;
            check(&format!("{mid:e}"));
            check(&format!("{:.15e}", mid));
        }
        assert_eq!(decimal(b"1.5"), Some(1.5));
        assert_eq!(decimal(b"1.2.3"), None);
        assert_eq!(decimal(b"e5"), None);
        assert_eq!(decimal(b"1e"), None);
        assert_eq!(decimal(b"nan"), None);
    }
}
