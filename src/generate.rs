//! Mesh generators for tests and benchmarks, so that no large mesh file lives in the
//! repository: 1-to-4 midpoint subdivision (the bunny at 4 968 → 19 872 → 79 488 →
//! 317 952 → 1 271 808 triangles) and an icosphere.
//!
//! Both work on triangle soups and stay watertight: a shared edge's midpoint is computed
//! from the same two vertices by the same operations in both triangles (`a + b` equals
//! `b + a` in floating point), so neighbours agree to the bit.

use glam::Vec3;

/// Split every triangle into four at its edge midpoints.
pub fn subdivide(triangles: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
    let mut out = Vec::with_capacity(triangles.len() * 4);
    for &[a, b, c] in triangles {
        let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
        out.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    out
}

/// `subdivide` applied `levels` times.
pub fn subdivide_times(triangles: &[[Vec3; 3]], levels: u32) -> Vec<[Vec3; 3]> {
    let mut t = triangles.to_vec();
    for _ in 0..levels {
        t = subdivide(&t);
    }
    t
}

/// The icosahedron's faces, wound outward, as indices into its twelve vertices
/// (−1, φ, 0), (1, φ, 0), (−1, −φ, 0), (1, −φ, 0), (0, −1, φ), (0, 1, φ), (0, −1, −φ),
/// (0, 1, −φ), (φ, 0, −1), (φ, 0, 1), (−φ, 0, −1), (−φ, 0, 1), φ the golden ratio.
pub const ICOSAHEDRON_FACES: [[usize; 3]; 20] = [
    [0, 11, 5],
    [0, 5, 1],
    [0, 1, 7],
    [0, 7, 10],
    [0, 10, 11],
    [1, 5, 9],
    [5, 11, 4],
    [11, 10, 2],
    [10, 7, 6],
    [7, 1, 8],
    [3, 9, 4],
    [3, 4, 2],
    [3, 2, 6],
    [3, 6, 8],
    [3, 8, 9],
    [4, 9, 5],
    [2, 4, 11],
    [6, 2, 10],
    [8, 6, 7],
    [9, 8, 1],
];

/// A closed unit icosphere around `center` with radius `radius`: the icosahedron
/// subdivided `levels` times, new vertices pushed onto the sphere (20 · 4^levels
/// triangles, wound outward).
pub fn icosphere(levels: u32, center: Vec3, radius: f32) -> Vec<[Vec3; 3]> {
    let p = (1.0 + 5.0f32.sqrt()) / 2.0;
    let v: Vec<Vec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[Vec3; 3]> = ICOSAHEDRON_FACES
        .iter()
        .map(|f| [v[f[0]], v[f[1]], v[f[2]]])
        .collect();
    for _ in 0..levels {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for &[a, b, c] in &tris {
            let (ab, bc, ca) = (
                ((a + b) * 0.5).normalize(),
                ((b + c) * 0.5).normalize(),
                ((c + a) * 0.5).normalize(),
            );
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
    }
    tris.iter()
        .map(|t| t.map(|p| center + p * radius))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Every edge of a closed mesh is shared by exactly two triangles, bit for bit.
    fn closed(tris: &[[Vec3; 3]]) -> bool {
        let key = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        let mut edges: HashMap<([u32; 3], [u32; 3]), u32> = HashMap::new();
        for t in tris {
            for i in 0..3 {
                let (a, b) = (key(t[i]), key(t[(i + 1) % 3]));
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        edges.values().all(|&n| n == 2)
    }

    #[test]
    fn counts_and_closedness() {
        let ico = icosphere(2, Vec3::ZERO, 1.0);
        assert_eq!(ico.len(), 320);
        assert!(closed(&ico));
        assert!(closed(&subdivide(&ico)));
        assert_eq!(subdivide_times(&ico, 2).len(), 320 * 16);
        // Outward winding: the normal points away from the centre.
        for [a, b, c] in &ico {
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }
}
