//! Triangles: pool, bounds, watertight intersection, normal, light sampling.
//!
//! Scene keys (read in `scene::desc`): `a`, `b`, `c` for a triangle; a mesh (`path`)
//! compiles to triangles.

use super::{Aabb, Ray};
use crate::lanes::{Lane, V3};
use glam::{Vec3, Vec4};
use std::marker::PhantomData;

/// Triangles, structure-of-arrays, stored as their three vertices, each vertex as one
/// array per axis: `a[axis][i]`. The watertight test reads the axes in the order its ray
/// permutation gives, so it indexes `a[kx]` directly instead of building vectors.
#[derive(Clone, Debug, Default)]
pub struct TrianglePool {
    pub a: [Vec<f32>; 3],
    pub b: [Vec<f32>; 3],
    pub c: [Vec<f32>; 3],
    /// Scene-wide primitive id (closest-hit tie-breaker).
    pub id: Vec<u32>,
    /// The scene object each triangle belongs to (all triangles of a mesh share one).
    pub object: Vec<u32>,
    /// The unit shading normals of each triangle's corners a, b, c, interpolated across
    /// it (a mesh with `normals = "smooth"`); zero for a flat triangle. Empty when no
    /// triangle is smooth.
    pub normals: Vec<[Vec3; 3]>,
}

impl TrianglePool {
    pub fn len(&self) -> usize {
        self.id.len()
    }

    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Room for `more` triangles (a mesh's, before they are pushed one by one).
    pub fn reserve(&mut self, more: usize) {
        for axis in 0..3 {
            self.a[axis].reserve(more);
            self.b[axis].reserve(more);
            self.c[axis].reserve(more);
        }
        self.id.reserve(more);
        self.object.reserve(more);
    }

    pub fn push(&mut self, [a, b, c]: [Vec3; 3], id: u32, object: u32) {
        for axis in 0..3 {
            self.a[axis].push(a[axis]);
            self.b[axis].push(b[axis]);
            self.c[axis].push(c[axis]);
        }
        self.id.push(id);
        self.object.push(object);
        if !self.normals.is_empty() {
            self.normals.push([Vec3::ZERO; 3]);
        }
    }

    /// `push` a triangle shaded with the unit corner normals `normals`.
    pub fn push_smooth(&mut self, triangle: [Vec3; 3], normals: [Vec3; 3], id: u32, object: u32) {
        // The flat triangles before it get zero normals.
        self.normals.resize(self.len(), [Vec3::ZERO; 3]);
        self.normals.push(normals);
        let smooth = std::mem::take(&mut self.normals);
        self.push(triangle, id, object);
        self.normals = smooth;
    }

    /// Triangle `i` has shading normals of its own.
    #[inline]
    pub fn is_smooth(&self, i: usize) -> bool {
        self.normals.get(i).is_some_and(|n| n[0] != Vec3::ZERO)
    }

    /// Reorder (see `geometry::permute`).
    pub fn permute(&mut self, order: &[u32]) {
        for v in self
            .a
            .iter_mut()
            .chain(self.b.iter_mut())
            .chain(self.c.iter_mut())
        {
            super::permute(v, order);
        }
        super::permute(&mut self.id, order);
        super::permute(&mut self.object, order);
        if !self.normals.is_empty() {
            super::permute(&mut self.normals, order);
        }
    }

    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        let v = |p: &[Vec<f32>; 3]| Vec3::new(p[0][i], p[1][i], p[2][i]);
        [v(&self.a), v(&self.b), v(&self.c)]
    }

    pub fn bounds(&self, i: usize) -> Aabb {
        Aabb::from_points(&self.vertices(i))
    }

    /// Unit geometric normal, normalise((b − a) × (c − a)), as in the original program
    /// (flat shading).
    #[inline]
    pub fn normal(&self, i: usize) -> Vec3 {
        let [a, b, c] = self.vertices(i);
        (b - a).cross(c - a).normalize_or(Vec3::Y)
    }

    /// The watertight test on triangle `i`, reading the pool in the ray's axis order.
    #[inline(always)]
    pub fn intersect(&self, i: usize, ray: &WatertightRay, t_min: f32, t_max: f32) -> Option<f32> {
        let [kx, ky, kz] = ray.axes;
        let (a, b, c) = (&self.a, &self.b, &self.c);
        ray.intersect_permuted(
            [a[kx][i], a[ky][i], a[kz][i]],
            [b[kx][i], b[ky][i], b[kz][i]],
            [c[kx][i], c[ky][i], c[kz][i]],
            t_min,
            t_max,
        )
    }
}

/// Four lanes of `values[start..start + n]` (n ≤ 4); lanes past `n` hold whatever follows
/// (or 0 at the end of the pool) and must be masked by the caller.
#[inline(always)]
pub(crate) fn load4(values: &[f32], start: usize, n: usize) -> Vec4 {
    match values.get(start..start + 4) {
        Some(s) => Vec4::from_slice(s),
        None => load4_tail(values, start, n),
    }
}

/// `load4` at the end of a pool (out of the hot path).
#[cold]
#[inline(never)]
fn load4_tail(values: &[f32], start: usize, n: usize) -> Vec4 {
    // Lane by lane: a copy of `n` values was a call to `memcpy` (half the cost of a
    // linear scan's test of one sphere, callgrind).
    let tail = &values[start..start + n];
    Vec4::from_array(std::array::from_fn(|k| tail.get(k).copied().unwrap_or(0.0)))
}

/// The pool's nine vertex columns (a, b, c; each in a ray's axis order kx, ky, kz),
/// resolved once a ray or packet instead of at every test: through the pool each read
/// costs an axis check, two pointer loads and a bounds check (callgrind: a third of a
/// packet's triangle test). One length for the nine: as slices they were eighteen words
/// to store on every ray or packet that reaches a triangle, nine of them the same length.
#[derive(Clone, Copy, Debug)]
pub struct Columns<'s> {
    cols: [*const f32; 9],
    len: usize,
    pool: PhantomData<&'s [f32]>,
}

impl<'s> Columns<'s> {
    /// Coordinate `m` (vertex `m / 3`, axis `m % 3` of the order) of triangle `i`.
    #[inline(always)]
    pub fn at(&self, m: usize, i: usize) -> f32 {
        assert!(i < self.len);
        // SAFETY: every column has `len` elements (`TrianglePool::columns`), borrowed for 's.
        unsafe { *self.cols[m].add(i) }
    }

    /// Column `m` as the slice it points into.
    #[inline(always)]
    fn column(&self, m: usize) -> &'s [f32] {
        // SAFETY: every column has `len` elements (`TrianglePool::columns`), borrowed for 's.
        unsafe { std::slice::from_raw_parts(self.cols[m], self.len) }
    }

    /// `load4` of column `m`.
    #[inline(always)]
    fn load4(&self, m: usize, start: usize, n: usize) -> Vec4 {
        if start + 4 <= self.len {
            // SAFETY: start + 4 ≤ len, the length of every column.
            Vec4::from_slice(unsafe { self.column(m).get_unchecked(start..start + 4) })
        } else {
            load4_tail(self.column(m), start, n)
        }
    }
}

impl TrianglePool {
    /// The vertex columns in the axis order `axes` (a permutation of 0, 1, 2).
    #[inline]
    pub fn columns(&self, [kx, ky, kz]: [usize; 3]) -> Columns<'_> {
        let len = self.len();
        let pools = [&self.a, &self.b, &self.c];
        let cols: [&[f32]; 9] = std::array::from_fn(|m| &pools[m / 3][[kx, ky, kz][m % 3]][..]);
        assert!(cols.iter().all(|c| c.len() == len));
        Columns {
            cols: cols.map(<[f32]>::as_ptr),
            len,
            pool: PhantomData,
        }
    }
}

impl TrianglePool {
    /// Triangles `start..start + n` (n ≤ 4, a BVH leaf) against one ray in one `Vec4` pass:
    /// lane for lane the operations of `WatertightRay::intersect_permuted`, so the same
    /// bits. Lanes whose edge function rounds to zero are redone one at a time (with that
    /// test's f64 fallback). Returns the distances and the mask of lanes that hit.
    ///
    /// Always inlined (it is the scalar traversal's leaf test): as a call, with its vertex
    /// loads in a closure that was not inlined either, it cost ~30% more instructions per
    /// camera ray on `bunny-closeup` (callgrind, `benches/probes/trace_probe.rs`).
    #[inline(always)]
    pub fn intersect4(
        &self,
        start: usize,
        n: usize,
        ray: &WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 4], u32) {
        let [kx, ky, kz] = ray.axes;
        let (a, b, c) = (&self.a, &self.b, &self.c);
        let v = [
            load4(&a[kx], start, n),
            load4(&a[ky], start, n),
            load4(&a[kz], start, n),
            load4(&b[kx], start, n),
            load4(&b[ky], start, n),
            load4(&b[kz], start, n),
            load4(&c[kx], start, n),
            load4(&c[ky], start, n),
            load4(&c[kz], start, n),
        ];
        self.intersect4_loaded(v, start, n, ray, t_min, t_max)
    }

    /// `intersect4` through the columns of `ray.axes` (`columns`), for callers that test
    /// many leaves with one ray.
    #[inline(always)]
    pub fn intersect4_in(
        &self,
        cols: &Columns,
        start: usize,
        n: usize,
        ray: &WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 4], u32) {
        let v = std::array::from_fn(|m| cols.load4(m, start, n));
        self.intersect4_loaded(v, start, n, ray, t_min, t_max)
    }

    /// `intersect4` of the nine coordinate lanes `v` (a, b, c; each in the ray's axis
    /// order) of triangles `start..start + n`.
    #[inline(always)]
    fn intersect4_loaded(
        &self,
        v: [Vec4; 9],
        start: usize,
        n: usize,
        ray: &WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 4], u32) {
        let o = ray.origin.map(Vec4::splat);
        let (sx, sy, sz) = (
            Vec4::splat(ray.sx),
            Vec4::splat(ray.sy),
            Vec4::splat(ray.sz),
        );
        let a = shear([v[0], v[1], v[2]], o, sx, sy);
        let b = shear([v[3], v[4], v[5]], o, sx, sy);
        let c = shear([v[6], v[7], v[8]], o, sx, sy);
        let [u, v, w] = edge_functions(a, b, c);
        let zero = Vec4::ZERO;
        let lanes = (1u32 << n) - 1;
        let exact_zero = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask() & lanes;
        if inside_edges([u, v, w]).bitmask() & lanes == 0 && exact_zero == 0 {
            // No lane inside the edges: no distance (and no division) needed.
            return ([0.0; 4], 0);
        }
        let (t, hit) = watertight_distance(
            [u, v, w],
            a,
            b,
            c,
            sz,
            Vec4::splat(t_min),
            Vec4::splat(t_max),
        );
        let mask = hit.bitmask() & lanes & !exact_zero;
        let out = t.to_array();
        if exact_zero != 0 {
            return self.redo_exact_zero(start, ray, t_min, t_max, (out, mask), exact_zero);
        }
        (out, mask)
    }

    /// The lanes `redo` of `intersect4` (whose edge function rounded to zero) redone one
    /// at a time with the scalar test (and its f64 fallback), into the other lanes' `hits`
    /// (distances and mask, as `intersect4` returns them). Rare: kept out of line.
    #[cold]
    #[inline(never)]
    fn redo_exact_zero(
        &self,
        start: usize,
        ray: &WatertightRay,
        t_min: f32,
        t_max: f32,
        hits: ([f32; 4], u32),
        mut redo: u32,
    ) -> ([f32; 4], u32) {
        let (mut out, mut mask) = hits;
        while redo != 0 {
            let k = redo.trailing_zeros() as usize;
            redo &= redo - 1;
            if let Some(tk) = self.intersect(start + k, ray, t_min, t_max) {
                out[k] = tk;
                mask |= 1 << k;
            }
        }
        (out, mask)
    }
}

/// Is the triangle usable: finite and of non-zero area?
pub fn is_proper_triangle([a, b, c]: [Vec3; 3]) -> bool {
    let n = (b - a).cross(c - a);
    a.is_finite() && b.is_finite() && c.is_finite() && n.length_squared() > 0.0
}

/// A point uniform over the triangle from two uniform numbers in [0, 1): fold the unit
/// square onto the triangle (if ξ1 + ξ2 > 1 use 1 − ξ1, 1 − ξ2), as in the original
/// program.
#[inline]
pub fn sample_triangle([a, b, c]: [Vec3; 3], xi1: f32, xi2: f32) -> Vec3 {
    sample_triangle_lanes::<f32>([a, b, c].map(V3::splat), xi1, xi2).lane(0)
}

/// `sample_triangle` lane by lane.
#[inline(always)]
pub fn sample_triangle_lanes<L: Lane>([a, b, c]: [V3<L>; 3], xi1: L, xi2: L) -> V3<L> {
    let one = L::splat(1.0);
    let flip = (xi1 + xi2).gt(one);
    let s = L::select(flip, one - xi1, xi1);
    let t = L::select(flip, one - xi2, xi2);
    a + (b - a).scale(s) + (c - a).scale(t)
}

/// Per-ray constants of the watertight ray/triangle test (Woop, Benthin, Wald, "Watertight
/// Ray/Triangle Intersection", JCGT 2013): the axis permutation that makes z the dominant
/// direction axis, the origin in that order, and the shear that maps the ray onto +z.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    /// [kx, ky, kz].
    pub axes: [usize; 3],
    /// The origin's components in `axes` order.
    pub origin: [f32; 3],
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
}

impl WatertightRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir.to_array();
        let [kx, ky, kz] = Self::axes(ray.dir);
        let o = ray.origin.to_array();
        Self {
            axes: [kx, ky, kz],
            origin: [o[kx], o[ky], o[kz]],
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }

    /// The axis order [kx, ky, kz]: z the dominant direction axis, x and y swapped when
    /// that component is negative (to keep the winding).
    #[inline]
    pub fn axes(dir: Vec3) -> [usize; 3] {
        let ad = dir.abs();
        let kz = if ad.x > ad.y {
            if ad.x > ad.z {
                0
            } else {
                2
            }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        if dir[kz] < 0.0 {
            [(kz + 2) % 3, (kz + 1) % 3, kz]
        } else {
            [(kz + 1) % 3, (kz + 2) % 3, kz]
        }
    }

    /// Two-sided watertight test of the triangle `[a, b, c]`.
    #[inline]
    pub fn intersect(&self, [a, b, c]: [Vec3; 3], t_min: f32, t_max: f32) -> Option<f32> {
        let [kx, ky, kz] = self.axes;
        let p = |v: Vec3| [v[kx], v[ky], v[kz]];
        self.intersect_permuted(p(a), p(b), p(c), t_min, t_max)
    }

    /// The test on vertices already in the ray's axis order. Edges are inclusive, and a
    /// ray through a shared edge or vertex hits at least one of the triangles sharing it:
    /// the edge functions are exact in sign, with an f64 recomputation when one of them
    /// rounds to zero.
    #[inline(always)]
    pub fn intersect_permuted(
        &self,
        a: [f32; 3],
        b: [f32; 3],
        c: [f32; 3],
        t_min: f32,
        t_max: f32,
    ) -> Option<f32> {
        let o = self.origin;
        let a = shear(a, o, self.sx, self.sy);
        let b = shear(b, o, self.sx, self.sy);
        let c = shear(c, o, self.sx, self.sy);
        let [mut u, mut v, mut w] = edge_functions(a, b, c);
        if u == 0.0 || v == 0.0 || w == 0.0 {
            [u, v, w] = edge_functions_f64(a, b, c);
        }
        // The sign test alone rejects most misses: skip the division (same answer).
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let (t, hit) = watertight_distance([u, v, w], a, b, c, self.sz, t_min, t_max);
        hit.then_some(t)
    }
}

// The watertight test in three steps, written once over `Lane` for every width: the
// scalar test above, four triangles against one ray (`intersect4`) and one triangle
// against a packet of rays (`accel::packet`).

/// A vertex, in the ray's axis order, translated to the ray origin and sheared so the
/// ray runs along +z.
#[inline(always)]
pub fn shear<L: Lane>(p: [L; 3], o: [L; 3], sx: L, sy: L) -> [L; 3] {
    let z = p[2] - o[2];
    [(p[0] - o[0]) - sx * z, (p[1] - o[1]) - sy * z, z]
}

/// The three edge functions (scaled barycentrics) of sheared vertices.
#[inline(always)]
pub fn edge_functions<L: Lane>(a: [L; 3], b: [L; 3], c: [L; 3]) -> [L; 3] {
    [
        c[0] * b[1] - c[1] * b[0],
        a[0] * c[1] - a[1] * c[0],
        b[0] * a[1] - b[1] * a[0],
    ]
}

/// The edge functions recomputed in f64, for a lane where one rounded to exactly zero:
/// the products of f32 values are exact in f64, so the sign is right.
#[inline(never)]
pub fn edge_functions_f64(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    let (ax, ay, bx, by, cx, cy) = (
        a[0] as f64,
        a[1] as f64,
        b[0] as f64,
        b[1] as f64,
        c[0] as f64,
        c[1] as f64,
    );
    [
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    ]
}

/// The lanes whose edge functions are all of one sign (edges inclusive): the only lanes
/// `watertight_distance` can report. Testing it first lets a leaf test skip the
/// distance, and its division, when no lane is inside (most triangles of a leaf).
#[inline(always)]
pub fn inside_edges<L: Lane>([u, v, w]: [L; 3]) -> L::Mask {
    let zero = L::splat(0.0);
    !((u.lt(zero) | v.lt(zero) | w.lt(zero)) & (u.gt(zero) | v.gt(zero) | w.gt(zero)))
}

/// Distance and hit mask from the edge functions: all of one sign (edges inclusive),
/// a non-zero determinant and t in `[t_min, t_max]`.
#[inline(always)]
pub fn watertight_distance<L: Lane>(
    [u, v, w]: [L; 3],
    a: [L; 3],
    b: [L; 3],
    c: [L; 3],
    sz: L,
    t_min: L,
    t_max: L,
) -> (L, L::Mask) {
    let zero = L::splat(0.0);
    let det = u + v + w;
    let t = (u * (sz * a[2]) + v * (sz * b[2]) + w * (sz * c[2])) / det;
    let hit = inside_edges([u, v, w]) & det.ne(zero) & t.ge(t_min) & t.le(t_max);
    (t, hit)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];

    fn hit(o: Vec3, d: Vec3) -> Option<f32> {
        WatertightRay::new(&Ray::new(o, d.normalize())).intersect(TRI, 1e-4, f32::INFINITY)
    }

    #[test]
    fn hits_both_faces_and_edges() {
        assert_eq!(hit(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z), Some(2.0));
        assert_eq!(hit(Vec3::new(0.25, 0.25, -2.0), Vec3::Z), Some(2.0));
        // Shared edge x + y = 1 and the vertices are inside.
        assert_eq!(hit(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z), Some(1.0));
        assert_eq!(hit(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z), Some(1.0));
        assert_eq!(hit(Vec3::new(0.6, 0.6, 1.0), -Vec3::Z), None);
        assert_eq!(hit(Vec3::new(-0.01, 0.5, 1.0), -Vec3::Z), None);
    }

    #[test]
    fn four_wide_test_gives_the_scalar_bits() {
        // A fan of triangles sharing edges and a vertex (exact-zero edge functions for
        // rays through them), against rays through vertices, edges and interiors.
        let mut pool = TrianglePool::default();
        let c = Vec3::new(0.0, 0.0, 0.0);
        let ring: Vec<Vec3> = (0..7)
            .map(|k| {
                let a = k as f32 * 0.9;
                Vec3::new(a.cos(), a.sin(), 0.1 * k as f32)
            })
            .collect();
        for k in 0..6 {
            pool.push([c, ring[k], ring[k + 1]], k as u32, 0);
        }
        let mut rays = 0;
        for target in ring
            .iter()
            .chain([&c])
            .flat_map(|&p| [p, p * 0.5, (p + c) * 0.25])
        {
            for origin in [
                Vec3::new(0.1, 0.2, 3.0),
                Vec3::new(-2.0, 0.5, -1.0),
                Vec3::new(0.0, 0.0, 5.0),
            ] {
                let ray = WatertightRay::new(&Ray::new(origin, (target - origin).normalize()));
                for start in [0, 2, 4] {
                    let n = (6 - start).min(4);
                    let (t, mask) = pool.intersect4(start, n, &ray, 1e-4, f32::INFINITY);
                    for (k, &tk) in t.iter().enumerate().take(n) {
                        let scalar = pool.intersect(start + k, &ray, 1e-4, f32::INFINITY);
                        let simd = (mask >> k & 1 == 1).then_some(tk);
                        assert_eq!(scalar.map(f32::to_bits), simd.map(f32::to_bits));
                        rays += 1;
                    }
                    assert_eq!(mask >> n, 0);
                }
            }
        }
        assert!(rays > 100);
    }

    #[test]
    fn ray_in_plane_misses() {
        assert_eq!(hit(Vec3::new(-1.0, 0.25, 0.0), Vec3::X), None);
    }

    #[test]
    fn sampling_stays_inside() {
        for (x1, x2) in [(0.0, 0.0), (0.9, 0.9), (0.999, 0.0), (0.3, 0.6)] {
            let p = sample_triangle(TRI, x1, x2);
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 1.0, "{p}");
        }
    }
}
