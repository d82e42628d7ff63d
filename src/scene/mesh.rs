//! OBJ meshes, read with `tobj`, checked, and turned into triangles.
//!
//! tobj reports what is wrong but not where; when it fails, or when a vertex is not
//! finite, the text is scanned again to name the offending line.

use crate::error::{Error, Result};
use crate::geometry::triangle::is_proper_triangle;
use glam::Vec3;

/// A loaded mesh: its proper triangles and how many degenerate ones (zero area) were
/// dropped. Zero-area triangles can never be hit and must not reach the BVH.
#[derive(Debug)]
pub struct MeshTriangles {
    pub triangles: Vec<[Vec3; 3]>,
    pub degenerate: usize,
}

/// Parse OBJ text. `path` is only used in messages.
pub fn parse_obj(path: &str, text: &str) -> Result<MeshTriangles> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(text.as_bytes());
    let (models, _) = tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()))
        .map_err(|e| Error::Obj {
            path: path.to_string(),
            line: find_bad_line(text),
            message: format!("malformed OBJ ({e})"),
        })?;
    let mut triangles = Vec::new();
    let mut degenerate = 0;
    for model in &models {
        let mesh = &model.mesh;
        if let Some(k) = mesh.positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::Obj {
                path: path.to_string(),
                line: nth_vertex_line(text, k / 3),
                message: "vertex coordinate is not a finite number".into(),
            });
        }
        let vertex = |i: u32| {
            let i = i as usize * 3;
            Vec3::new(
                mesh.positions[i],
                mesh.positions[i + 1],
                mesh.positions[i + 2],
            )
        };
        for f in mesh.indices.chunks_exact(3) {
            let tri = [vertex(f[0]), vertex(f[1]), vertex(f[2])];
            if is_proper_triangle(tri) {
                triangles.push(tri);
            } else {
                degenerate += 1;
            }
        }
    }
    if triangles.is_empty() {
        return Err(Error::Obj {
            path: path.to_string(),
            line: 0,
            message: format!("no usable triangles ({degenerate} degenerate faces)"),
        });
    }
    Ok(MeshTriangles {
        triangles,
        degenerate,
    })
}

/// 1-based line of the `k`-th (0-based) `v` statement.
fn nth_vertex_line(text: &str, k: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("v "))
        .nth(k)
        .map_or(0, |(n, _)| n + 1)
}

/// Find the first line tobj would reject: a vertex without three numbers, or a face with a
/// missing, unparsable or out-of-range vertex index. 0 if none is found.
fn find_bad_line(text: &str) -> usize {
    let vertex_count = text
        .lines()
        .filter(|l| l.trim_start().starts_with("v "))
        .count() as i64;
    let mut seen = 0i64;
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                seen += 1;
                let ok = words.take(3).filter(|w| w.parse::<f32>().is_ok()).count() == 3;
                if !ok {
                    return n + 1;
                }
            }
            Some("f") => {
                let mut count = 0;
                for w in words {
                    count += 1;
                    let index = w.split('/').next().unwrap_or("").parse::<i64>();
                    let in_range = match index {
                        Ok(i) if i > 0 => i <= vertex_count,
                        Ok(i) if i < 0 => -i <= seen,
                        _ => false,
                    };
                    if !in_range {
                        return n + 1;
                    }
                }
                if count < 3 {
                    return n + 1;
                }
            }
            _ => {}
        }
    }
    0
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
