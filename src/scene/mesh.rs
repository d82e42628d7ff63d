//! OBJ meshes, read with `tobj`, checked, and turned into triangles.
//!
//! tobj reports what is wrong but not where, and resolves face indices only when an
//! object ends; its index arithmetic overflows on indices near `isize::MIN` (a panic in
//! a build with overflow checks). So the text is checked first, line by line, as tobj
//! reads it: every vertex (three numbers, finite in f32 after an optional w, within the
//! scene's coordinate limit) and every face's vertex references (at most v/vt/vn, each
//! in range). tobj then reads text it accepts; a failure it still finds is placed at the
//! line it was reading (`LineCounter`). Lines end at LF or CR LF, or at a lone CR (old
//! Mac OS files, which tobj would read as one line).

mod parallel;

use super::input;
use super::limits::MAX_COORDINATE;
use crate::error::{Error, Result};
use crate::geometry::triangle::is_proper_triangle;
use glam::{DVec3, Vec3};
use std::borrow::Cow;
use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

/// A loaded mesh: its proper triangles and how many degenerate ones (zero area) were
/// dropped. Zero-area triangles can never be hit and must not reach the BVH.
#[derive(Debug)]
pub struct MeshTriangles {
    pub triangles: Vec<[Vec3; 3]>,
    /// The unit vertex normals of each triangle's corners, when read for smooth shading
    /// (`parse_obj_smooth`); else empty.
    pub normals: Vec<[Vec3; 3]>,
    /// Each triangle's material when read with material names (`ObjOptions::materials`):
    /// 0 for none (faces before any `usemtl`), else 1 + its index in those names; else
    /// empty.
    pub material: Vec<u32>,
    pub degenerate: usize,
}

/// What `read_obj` reads beside the triangles.
#[derive(Clone, Copy, Debug, Default)]
pub struct ObjOptions<'a> {
    /// Vertex normals for smooth shading (`parse_obj_smooth`).
    pub smooth: bool,
    /// The names of the materials the file's libraries define: each triangle's
    /// `usemtl` among them (`MeshTriangles::material`).
    pub materials: Option<&'a [String]>,
}

impl MeshTriangles {
    /// Keep the triangles (and their normals) that `keep` accepts; how many went.
    pub fn retain(&mut self, keep: impl Fn(&[Vec3; 3]) -> bool) -> usize {
        let before = self.triangles.len();
        if self.normals.is_empty() && self.material.is_empty() {
            self.triangles.retain(keep);
        } else {
            let mut k = 0;
            for i in 0..before {
                if keep(&self.triangles[i]) {
                    self.triangles[k] = self.triangles[i];
                    if !self.normals.is_empty() {
                        self.normals[k] = self.normals[i];
                    }
                    if !self.material.is_empty() {
                        self.material[k] = self.material[i];
                    }
                    k += 1;
                }
            }
            self.triangles.truncate(k);
            self.normals.truncate(k.min(self.normals.len()));
            self.material.truncate(k.min(self.material.len()));
        }
        before - self.triangles.len()
    }

    /// Split every triangle 1-to-4 at its edge midpoints `levels` times
    /// (`generate::subdivide`); each child's corner normals interpolate its parent's,
    /// and it keeps its parent's material.
    pub fn subdivide(&mut self, levels: u32) {
        self.triangles = crate::generate::subdivide_times(&self.triangles, levels);
        if !self.normals.is_empty() {
            let normals = crate::generate::subdivide_times(&self.normals, levels);
            self.normals = unit_normals(&self.triangles, &normals);
        }
        if !self.material.is_empty() {
            let children = 1usize << (2 * levels);
            self.material = (self.material.iter())
                .flat_map(|&m| std::iter::repeat_n(m, children))
                .collect();
        }
    }
}

/// The material libraries an OBJ file names (`mtllib` lines), relative to its directory:
/// files that belong with the mesh (read with `materials = "mtl"`). None if the
/// file cannot be read as a mesh (loading it reports why).
pub fn material_libraries(obj: &Path) -> Vec<PathBuf> {
    let Ok(size) = input::check_file(obj, input::MAX_MESH_BYTES, "mesh") else {
        return Vec::new();
    };
    let Ok(file) = std::fs::File::open(obj) else {
        return Vec::new();
    };
    let dir = obj.parent().unwrap_or(Path::new(""));
    let mut libraries = Vec::new();
    let mut look = |line: &[u8]| {
        let text = String::from_utf8_lossy(line);
        let mut words = text.split_whitespace();
        if words.next() == Some("mtllib") {
            libraries.extend(words.map(|name| dir.join(name)));
        }
    };
    // The file is read in blocks; only the lines that hold the bytes "mtllib" are split
    // into words (splitting every line of a 53 MB mesh took 70 ms). A line of `LINE`
    // bytes or more is not read, so one long line takes no memory.
    const LINE: usize = 4096;
    let finder = memchr::memmem::Finder::new(b"mtllib");
    let mut reader = file.take(size);
    let mut block = vec![0u8; 1 << 20];
    let mut filled = 0;
    // In a line too long to read, to its end.
    let mut skipping = false;
    loop {
        let n = match reader.read(&mut block[filled..]) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(_) => return libraries,
        };
        filled += n;
        // The complete lines, up to the last LF (all of it at the end of the file).
        let end = if n == 0 {
            filled
        } else {
            match memchr::memrchr(b'\n', &block[..filled]) {
                Some(i) => i + 1,
                None => 0,
            }
        };
        let mut start = 0;
        if skipping && end > 0 {
            start = memchr::memchr(b'\n', &block[..end]).map_or(end, |i| i + 1);
            skipping = false;
        }
        let mut at = start;
        while let Some(i) = finder.find(&block[at..end]) {
            let hit = at + i;
            let line_start =
                memchr::memrchr(b'\n', &block[start..hit]).map_or(start, |j| start + j + 1);
            let line_end = memchr::memchr(b'\n', &block[hit..end]).map_or(end, |j| hit + j);
            if line_end - line_start < LINE {
                look(&block[line_start..line_end]);
            }
            at = line_end.min(end - 1) + 1;
            if at >= end {
                break;
            }
        }
        if n == 0 {
            return libraries;
        }
        // The start of a line the next block ends; or, if too long to read, skipped.
        let rest = filled - end;
        if rest >= LINE {
            skipping = true;
            filled = 0;
        } else {
            block.copy_within(end..filled, 0);
            filled = rest;
        }
    }
}

/// An OBJ file's material statements, with their 1-based lines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialStatements {
    /// Each file name of each `mtllib` (one statement may name several).
    pub libraries: Vec<(String, usize)>,
    /// Each `usemtl`'s material name (the rest of its line, as tobj reads it).
    pub uses: Vec<(String, usize)>,
}

/// The `mtllib` and `usemtl` statements of OBJ text.
pub fn material_statements(text: &str) -> MaterialStatements {
    let text = with_lf_line_ends(text);
    let mut found = MaterialStatements::default();
    for (n, line) in text.split('\n').enumerate() {
        let line = line.trim();
        let mut words = line.split_whitespace();
        match words.next() {
            Some("mtllib") => found
                .libraries
                .extend(words.map(|name| (name.to_string(), n + 1))),
            Some("usemtl") => {
                let name = line["usemtl".len()..].trim();
                if !name.is_empty() {
                    found.uses.push((name.to_string(), n + 1));
                }
            }
            _ => {}
        }
    }
    found
}

/// Parse OBJ text. `path` is only used in messages.
pub fn parse_obj(path: &str, text: &str) -> Result<MeshTriangles> {
    read_obj(path, text, ObjOptions::default())
}

/// Parse OBJ text with vertex normals for smooth shading: the file's `vn` normals where
/// every face vertex names one (each `vn` then must be three finite numbers), else
/// area-weighted normals: at each vertex position the sum of the cross products of the
/// triangles that meet there (each twice its triangle's area along its normal), so
/// vertices at one position share a normal whatever the file's groups or indices. A
/// normal of no direction falls back to its triangle's own.
pub fn parse_obj_smooth(path: &str, text: &str) -> Result<MeshTriangles> {
    let options = ObjOptions {
        smooth: true,
        ..ObjOptions::default()
    };
    read_obj(path, text, options)
}

/// Parse OBJ text with what `options` asks for beside the triangles: read in parallel
/// (`parallel`) where that reader takes the file, else by the checked tobj path
/// (`read_obj_checked`), which gives every error. Both give the same mesh.
pub fn read_obj(path: &str, text: &str, options: ObjOptions) -> Result<MeshTriangles> {
    let text = with_lf_line_ends(text);
    match parallel::read(&text, options, parallel::CHUNK_BYTES) {
        Some(mesh) => Ok(mesh),
        None => read_obj_checked(path, &text, options),
    }
}

/// The parallel reader alone, in chunks of about `chunk_bytes`: `None` where it leaves
/// the file to the checked path. For tests and the fuzz target, which compare the two.
pub fn read_obj_parallel(
    text: &str,
    options: ObjOptions,
    chunk_bytes: usize,
) -> Option<MeshTriangles> {
    parallel::read(&with_lf_line_ends(text), options, chunk_bytes.max(1))
}

/// The checked tobj path alone: the text checked line by line (`check_obj`), then read
/// by tobj.
pub fn read_obj_checked(path: &str, text: &str, options: ObjOptions) -> Result<MeshTriangles> {
    let smooth = options.smooth;
    let fail = |line: usize, message: String| Error::Obj {
        path: path.to_string(),
        line,
        message,
    };
    let text = with_lf_line_ends(text);
    let faces_name_normals =
        check_obj(&text, smooth).map_err(|(line, message)| fail(line, message))?;
    let load = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = LineCounter {
        text: text.as_bytes(),
        position: 0,
    };
    // Materials by name only: `scene::mtl` reads the libraries themselves. Each
    // `mtllib` gives tobj every name, so a `usemtl` anywhere after one finds its own.
    let names = options.materials.unwrap_or(&[]);
    let loader = |_: &std::path::Path| -> tobj::MTLLoadResult {
        let materials = names
            .iter()
            .map(|name| tobj::Material {
                name: name.clone(),
                ..tobj::Material::default()
            })
            .collect();
        let index = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        Ok((materials, index))
    };
    let (models, materials) = tobj::load_obj_buf(&mut reader, &load, loader)
        .map_err(|e| fail(reader.line(), format!("malformed OBJ ({e})")))?;
    let materials = materials.unwrap_or_default();
    let mut material = Vec::new();
    let mut triangles = Vec::new();
    let mut file_normals = Vec::new();
    let mut degenerate = 0;
    // The file's normals where every face names one and tobj kept them all, for every
    // face and in range (a line tobj reads differently from `check_obj` can leave a
    // group without them); else normals computed from the triangles.
    let use_file_normals = smooth
        && faces_name_normals
        && models.iter().all(|m| {
            let mesh = &m.mesh;
            mesh.normal_indices.len() == mesh.indices.len()
                && (mesh.normal_indices.iter()).all(|&n| n as usize * 3 + 2 < mesh.normals.len())
        });
    for model in &models {
        let mesh = &model.mesh;
        let vertex = |i: u32| {
            let i = i as usize * 3;
            Vec3::new(
                mesh.positions[i],
                mesh.positions[i + 1],
                mesh.positions[i + 2],
            )
        };
        let normal = |i: u32| {
            let i = i as usize * 3;
            Vec3::new(mesh.normals[i], mesh.normals[i + 1], mesh.normals[i + 2])
        };
        // 1 + the material's index in `names`, 0 for none.
        let group = mesh
            .material_id
            .and_then(|id| materials.get(id))
            .and_then(|m| names.iter().position(|n| *n == m.name))
            .map_or(0, |i| i as u32 + 1);
        for (f, face) in mesh.indices.chunks_exact(3).enumerate() {
            let tri = [vertex(face[0]), vertex(face[1]), vertex(face[2])];
            if is_proper_triangle(tri) {
                triangles.push(tri);
                if options.materials.is_some() {
                    material.push(group);
                }
                if use_file_normals {
                    let n = &mesh.normal_indices[3 * f..3 * f + 3];
                    file_normals.push([normal(n[0]), normal(n[1]), normal(n[2])]);
                }
            } else {
                degenerate += 1;
            }
        }
    }
    if triangles.is_empty() {
        return Err(fail(
            0,
            format!("no usable triangles ({degenerate} degenerate faces)"),
        ));
    }
    let normals = match (smooth, use_file_normals) {
        (false, _) => Vec::new(),
        (true, true) => unit_normals(&triangles, &file_normals),
        (true, false) => unit_normals(&triangles, &area_weighted_normals(&triangles)),
    };
    Ok(MeshTriangles {
        triangles,
        normals,
        material,
        degenerate,
    })
}

/// At each corner the sum, over the triangles that have a vertex at its position (to
/// the bit), of their cross products (b − a) × (c − a), in f64.
fn area_weighted_normals(triangles: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
    let key = |p: Vec3| p.to_array().map(f32::to_bits);
    let mut sums: HashMap<[u32; 3], DVec3> = HashMap::with_capacity(triangles.len());
    for &[a, b, c] in triangles {
        let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
        for (p, q, r) in [(a, b, c), (b, c, a), (c, a, b)] {
            let (e1, e2) = (q - p, r - p);
            let n = e1.cross(e2) / (e1.length_squared() * e2.length_squared());
            *sums.entry(key(p.as_vec3())).or_default() += n;
        }
    }
    triangles
        .iter()
        .map(|t| t.map(|p| sums[&key(p)].as_vec3()))
        .collect()
}

/// `normals` made unit length in f64 (each rounded once to f32); a corner whose normal
/// has no direction takes its triangle's geometric normal.
pub(crate) fn unit_normals(triangles: &[[Vec3; 3]], normals: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
    triangles
        .iter()
        .zip(normals)
        .map(|(&[a, b, c], corners)| {
            let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            let own = (b - a).cross(c - a).normalize_or_zero();
            corners.map(|n| {
                let n = n.as_dvec3();
                let unit = n / n.length();
                if unit.is_finite() { unit } else { own }.as_vec3()
            })
        })
        .collect()
}

/// The text with every lone CR (not followed by LF) made an LF.
fn with_lf_line_ends(text: &str) -> Cow<'_, str> {
    let bytes = text.as_bytes();
    let lone_cr = |i: usize| bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n');
    if !memchr::memchr_iter(b'\r', bytes).any(lone_cr) {
        return Cow::Borrowed(text);
    }
    // A CR is one byte of one char: replacing chars keeps the text UTF-8.
    let lf = |(i, c): (usize, char)| if lone_cr(i) { '\n' } else { c };
    Cow::Owned(text.char_indices().map(lf).collect())
}

/// A reader over the text that knows the line of the last byte tobj took: tobj reads a
/// line at a time and stops at the first it cannot parse.
struct LineCounter<'t> {
    text: &'t [u8],
    position: usize,
}

impl LineCounter<'_> {
    /// 1-based line of the last byte read.
    fn line(&self) -> usize {
        let end = self.position.saturating_sub(1);
        1 + self.text[..end].iter().filter(|&&b| b == b'\n').count()
    }
}

impl Read for LineCounter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = (&self.text[self.position..]).read(buf)?;
        self.position += n;
        Ok(n)
    }
}

impl BufRead for LineCounter<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.text[self.position..])
    }

    fn consume(&mut self, amount: usize) {
        self.position = (self.position + amount).min(self.text.len());
    }
}

/// Check what tobj would take on trust: vertices and face references, and with `smooth`
/// the normals. `Ok`: with `smooth`, whether every face vertex names a normal (`v//vn`,
/// `v/vt/vn`; not looked at otherwise).
/// `Err` is (1-based line, message).
fn check_obj(text: &str, smooth: bool) -> Result<bool, (usize, String)> {
    // Positions, texture coordinates and normals in the whole file (a positive index
    // may name one defined further on; tobj resolves them when the object ends).
    let mut totals = [0usize; 3];
    for line in text.split('\n') {
        match line.split_whitespace().next() {
            Some("v") => totals[0] += 1,
            Some("vt") => totals[1] += 1,
            Some("vn") => totals[2] += 1,
            _ => {}
        }
    }
    let mut seen = [0usize; 3];
    let mut faces_name_normals = true;
    for (n, line) in text.split('\n').enumerate() {
        let at = |message: String| (n + 1, message);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                check_vertex(words).map_err(at)?;
                seen[0] += 1;
            }
            Some("vt") => seen[1] += 1,
            Some("vn") => {
                if smooth {
                    check_normal(words).map_err(at)?;
                }
                seen[2] += 1;
            }
            Some(statement @ ("f" | "l")) => {
                let mut count = 0;
                for word in words {
                    check_reference(word, seen, totals).map_err(at)?;
                    if smooth && statement == "f" {
                        faces_name_normals &= word.split('/').nth(2).is_some_and(|w| !w.is_empty());
                    }
                    count += 1;
                }
                if statement == "f" && count < 3 {
                    return Err(at(format!(
                        "a face needs at least three vertices, got {count}"
                    )));
                }
            }
            _ => {}
        }
    }
    Ok(faces_name_normals)
}

/// A `vn` line's words after `vn`: three numbers, finite in f32.
fn check_normal<'a>(mut words: impl Iterator<Item = &'a str>) -> Result<(), String> {
    for _ in 0..3 {
        let word = words
            .next()
            .ok_or("a normal needs three numbers (vn x y z)")?;
        let x: f32 = word
            .parse()
            .map_err(|_| format!("normal '{word}' is not a number"))?;
        if !x.is_finite() {
            return Err(format!("normal '{word}' is not a finite number in f32"));
        }
    }
    Ok(())
}

/// A `v` line's words after `v`: x y z, then an optional w (tobj divides by it) or an
/// r g b colour (ignored). The position, as tobj computes it in f32, must be finite
/// and within the coordinate limit.
fn check_vertex<'a>(mut words: impl Iterator<Item = &'a str>) -> Result<(), String> {
    let mut p = [0.0f32; 3];
    for x in &mut p {
        let word = words
            .next()
            .ok_or("a vertex needs three coordinates (x y z)")?;
        *x = word
            .parse()
            .map_err(|_| format!("vertex coordinate '{word}' is not a number"))?;
    }
    let rest: Vec<&str> = words.collect();
    if let [w] = rest[..] {
        let w: f32 = w
            .parse()
            .map_err(|_| format!("vertex weight w '{w}' is not a number"))?;
        if w == 0.0 {
            return Err("vertex weight w is zero".into());
        }
        for x in &mut p {
            *x /= w;
        }
    }
    if let Some(x) = p.iter().find(|x| !x.is_finite()) {
        return Err(format!(
            "vertex coordinate is not a finite number ({x} in f32)"
        ));
    }
    if let Some(x) = p.iter().find(|x| x.abs() as f64 > MAX_COORDINATE) {
        return Err(format!(
            "vertex coordinate {x:e} is too large: the scene must lie within ±{MAX_COORDINATE:e} on every axis (f32 intersection tests overflow beyond)"
        ));
    }
    Ok(())
}

/// One vertex reference of a face or line, `v`, `v/vt`, `v//vn` or `v/vt/vn`: indices
/// from 1, or negative, counting back from the last defined so far. Each given index
/// must name one that exists (`seen` so far, `totals` in the file).
fn check_reference(word: &str, seen: [usize; 3], totals: [usize; 3]) -> Result<(), String> {
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let parts: Vec<&str> = word.split('/').collect();
    if parts.len() > 3 {
        return Err(format!(
            "face vertex '{word}' has {} parts: at most three, v/vt/vn",
            parts.len()
        ));
    }
    if parts[0].is_empty() {
        return Err(format!("face vertex '{word}' has no vertex index"));
    }
    for (k, part) in parts.iter().enumerate() {
        if part.is_empty() {
            continue;
        }
        let index: i64 = part
            .parse()
            .map_err(|_| format!("face vertex '{word}': '{part}' is not an index"))?;
        let in_range = if index > 0 {
            index as u64 <= totals[k] as u64
        } else {
            index < 0 && index.unsigned_abs() <= seen[k] as u64
        };
        if !in_range {
            return Err(format!(
                "face vertex '{word}': {} index {index} out of range ({} defined{})",
                KINDS[k],
                if index < 0 { seen[k] } else { totals[k] },
                if index < 0 { " so far" } else { "" }
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_triangles_and_drops_degenerate_ones() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n";
        let m = parse_obj("t.obj", text).unwrap();
        assert_eq!(m.triangles.len(), 1);
        assert_eq!(m.degenerate, 1);
    }

    #[test]
    fn quads_are_triangulated() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
        assert_eq!(parse_obj("q.obj", text).unwrap().triangles.len(), 2);
    }

    #[test]
    fn normals_tobj_left_out_are_computed_not_a_panic() {
        // A fuzzer's find: every face names a normal, but one group's normals are lost.
        let text = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fuzz/seeds/obj/lost-normals.obj"
        ))
        .unwrap();
        let text = String::from_utf8_lossy(&text);
        if let Ok(mesh) = parse_obj_smooth("lost-normals.obj", &text) {
            assert_eq!(mesh.normals.len(), mesh.triangles.len());
            assert!(mesh.normals.iter().flatten().all(|n| n.is_finite()));
        }
    }

    /// `material_libraries` as a line reader would find them: the first word of each
    /// line of fewer than 4096 bytes.
    fn libraries_line_by_line(text: &[u8]) -> Vec<PathBuf> {
        let mut found = Vec::new();
        for line in text.split(|&b| b == b'\n') {
            let line = String::from_utf8_lossy(line);
            let mut words = line.split_whitespace();
            if line.len() < 4096 && words.next() == Some("mtllib") {
                found.extend(words.map(PathBuf::from));
            }
        }
        found
    }

    #[test]
    fn material_libraries_are_the_lines_that_start_with_mtllib() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.obj");
        let long = "v 0 0 0 ".repeat(600);
        let filler = "v 0.125 0.25 0.5\n".repeat(70_000); // past the first 1 MB block
        let huge = "#".repeat(1_500_000); // longer than a block
        let text = format!(
            "mtllib first.mtl\n# mtllib not.mtl\n  mtllib\tindented.mtl two.mtl\r\n\
             {long}mtllib in-a-long-line.mtl\nmtllib {long}long.mtl\n{filler}mtllib b\u{e9}.mtl\n\
             {filler}{long}\n{long}{long}\nmtllib after-long.mtl\n{huge}mtllib in-a-huge-line.mtl\n\
             mtllib after-huge.mtl\nmtllibx no.mtl\nmtllib last.mtl"
        );
        std::fs::write(&path, &text).unwrap();
        let want: Vec<PathBuf> = libraries_line_by_line(text.as_bytes())
            .iter()
            .map(|p| dir.path().join(p))
            .collect();
        let names: Vec<String> = want
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "first.mtl",
                "indented.mtl",
                "two.mtl",
                "bé.mtl",
                "after-long.mtl",
                "after-huge.mtl",
                "last.mtl"
            ]
        );
        assert_eq!(material_libraries(&path), want);
    }

    #[test]
    fn errors_name_the_line() {
        let out_of_range = "v 0 0 0\nv 1 0 0\nv 0 1 0\n# c\nf 1 2 9\n";
        match parse_obj("a.obj", out_of_range) {
            Err(Error::Obj { line, .. }) => assert_eq!(line, 5),
            other => panic!("{other:?}"),
        }
        let nan = "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n";
        match parse_obj("b.obj", nan) {
            Err(Error::Obj { line, .. }) => assert_eq!(line, 2),
            other => panic!("{other:?}"),
        }
    }
}
