//! Quads (parallelograms): pool, bounds, intersection, normal, light sampling.
//!
//! Scene keys (read in `scene::desc`): `corner`, `u`, `v` for a quad; a box (`min`, `max`)
//! compiles to six quads.
//!
//! The hit test is watertight: whether a ray passes through the quad is decided by the
//! triangles' watertight edge functions (`triangle::shear`, `edge_functions`) on the
//! quad's two halves (A, B, C) and (A, C, D), whose four vertices are computed once, when
//! the scene is compiled. Quads that share an edge in the scene share its two vertices bit
//! for bit (a box's corners are its exact min and max components), so the edge's function
//! has the same sign, negated, on both and a ray through the edge hits at least one of
//! them. The distance is the original program's, from the plane (see `plane_distance`).
//!
//! One file past 700 lines (140 of them tests): the pool, the one-quad and eight-quad
//! groups and their edge test must give the same bits, so they sit together.

use super::triangle::{edge_functions, edge_functions_f64, inside_edges, shear, WatertightRay};
use super::{Aabb, Ray};
use crate::lanes::{set_lanes, Lane, Mask, V3};
use glam::{Vec3, Vec4, Vec4Swizzles};
use std::ops::Range;
use wide::f32x8;

/// The original program's parallel-ray threshold on `|n · d|`.
pub const PARALLEL_EPSILON: f32 = 1e-8;

/// Quads, structure-of-arrays. Each holds the corner Q, edges u and v and
/// w = (u × v) / |u × v|², which turns a point on the plane into its (α, β) coordinates
/// along u and v (hit points, `spawn::planar_point`); and what the hit test reads, each
/// together: the four vertices A = Q, B = Q + u, C = Q + u + v, D = Q + v,
/// `vertices[i][k][axis]` (the edge test reads all twelve, in the ray's axis order), and
/// the plane, `plane[i]` = [n, D], the unit normal n = normalise(u × v) and D = n · Q.
#[derive(Clone, Debug, Default)]
pub struct QuadPool {
    pub qx: Vec<f32>,
    pub qy: Vec<f32>,
    pub qz: Vec<f32>,
    pub ux: Vec<f32>,
    pub uy: Vec<f32>,
    pub uz: Vec<f32>,
    pub vx: Vec<f32>,
    pub vy: Vec<f32>,
    pub vz: Vec<f32>,
    pub wx: Vec<f32>,
    pub wy: Vec<f32>,
    pub wz: Vec<f32>,
    pub vertices: Vec<[[f32; 3]; 4]>,
    /// The same vertices by axis, `rows[i][axis]` = that coordinate of A, B, C, D: what
    /// one ray's edge test reads (`passes_through`).
    pub rows: Vec<[Vec4; 3]>,
    pub plane: Vec<[f32; 4]>,
    /// Scene-wide primitive id (closest-hit tie-breaker).
    pub id: Vec<u32>,
    /// The scene object each quad belongs to (the six faces of a box share one).
    pub object: Vec<u32>,
}

/// A quad's corner, edges, plane vector and unit normal (`QuadPool::frame`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadFrame {
    pub corner: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub w: Vec3,
    pub normal: Vec3,
}

/// The per-quad constants, gathered (used by the scalar path and by light sampling).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quad {
    pub corner: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub normal: Vec3,
    pub plane_d: f32,
    pub w: Vec3,
    /// A = Q, B = Q + u, C = Q + u + v, D = Q + v, as the edge test sees them.
    pub vertices: [Vec3; 4],
    /// The vertices by axis (`QuadPool::rows`).
    pub rows: [Vec4; 3],
}

impl Quad {
    /// Precompute the plane, and the vertices Q, Q + u, (Q + u) + v and Q + v. `None` for
    /// a degenerate (zero-area or non-finite) quad.
    pub fn new(corner: Vec3, u: Vec3, v: Vec3) -> Option<Self> {
        let vertices = [corner, corner + u, corner + u + v, corner + v];
        Self::with_vertices(corner, u, v, vertices)
    }

    /// The quad `corner`, `u`, `v` whose edge test uses `vertices` (A, B, C, D): these
    /// must be Q, Q + u, Q + u + v and Q + v up to rounding (`box_faces` gives a box's
    /// corners exactly). `None` as `new`.
    pub fn with_vertices(corner: Vec3, u: Vec3, v: Vec3, vertices: [Vec3; 4]) -> Option<Self> {
        let n = u.cross(v);
        let nn = n.dot(n);
        if nn <= 0.0 || !nn.is_finite() || !vertices.iter().all(|p| p.is_finite()) {
            return None;
        }
        let normal = n / nn.sqrt();
        Some(Self {
            corner,
            u,
            v,
            normal,
            plane_d: normal.dot(corner),
            w: n / nn,
            vertices,
            rows: vertex_rows(&vertices),
        })
    }

    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.vertices)
    }

    /// The quad test (two-sided, edges inclusive, watertight) for one ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        self.intersect_watertight(ray, &WatertightRay::new(ray), t_min, t_max)
    }

    /// `intersect` with the ray's watertight constants `w` already made.
    #[inline(always)]
    pub fn intersect_watertight(
        &self,
        ray: &Ray,
        w: &WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<f32> {
        // The plane first (`QuadPool::intersect`).
        let v = V3::splat;
        let (o, dir) = (v(ray.origin), v(ray.dir));
        let (t, hit) = plane_distance(v(self.normal), self.plane_d, o, dir, t_min, t_max);
        (hit && passes_through(w, &self.rows)).then_some(t)
    }

    /// A point uniform over the quad's area from two uniform numbers in [0, 1).
    #[inline]
    pub fn sample(&self, xi1: f32, xi2: f32) -> Vec3 {
        self.corner + self.u * xi1 + self.v * xi2
    }
}

impl QuadPool {
    pub fn len(&self) -> usize {
        self.id.len()
    }

    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    pub fn push(&mut self, q: &Quad, id: u32, object: u32) {
        self.qx.push(q.corner.x);
        self.qy.push(q.corner.y);
        self.qz.push(q.corner.z);
        self.ux.push(q.u.x);
        self.uy.push(q.u.y);
        self.uz.push(q.u.z);
        self.vx.push(q.v.x);
        self.vy.push(q.v.y);
        self.vz.push(q.v.z);
        self.wx.push(q.w.x);
        self.wy.push(q.w.y);
        self.wz.push(q.w.z);
        self.vertices.push(q.vertices.map(|p| p.to_array()));
        self.rows.push(q.rows);
        self.plane.push(q.normal.extend(q.plane_d).to_array());
        self.id.push(id);
        self.object.push(object);
    }

    /// Reorder (see `geometry::permute`).
    pub fn permute(&mut self, order: &[u32]) {
        for v in [
            &mut self.qx,
            &mut self.qy,
            &mut self.qz,
            &mut self.ux,
            &mut self.uy,
            &mut self.uz,
            &mut self.vx,
            &mut self.vy,
            &mut self.vz,
            &mut self.wx,
            &mut self.wy,
            &mut self.wz,
        ] {
            super::permute(v, order);
        }
        super::permute(&mut self.vertices, order);
        super::permute(&mut self.rows, order);
        super::permute(&mut self.plane, order);
        super::permute(&mut self.id, order);
        super::permute(&mut self.object, order);
    }

    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 4] {
        let [a, b, c, d] = self.vertices[i];
        [a, b, c, d].map(Vec3::from_array)
    }

    #[inline]
    pub fn get(&self, i: usize) -> Quad {
        Quad {
            corner: Vec3::new(self.qx[i], self.qy[i], self.qz[i]),
            u: Vec3::new(self.ux[i], self.uy[i], self.uz[i]),
            v: Vec3::new(self.vx[i], self.vy[i], self.vz[i]),
            normal: self.normal(i),
            plane_d: self.plane[i][3],
            w: Vec3::new(self.wx[i], self.wy[i], self.wz[i]),
            vertices: self.vertices(i),
            rows: self.rows[i],
        }
    }

    /// What a hit point on quad `i` is rebuilt from (`spawn::planar_point`) and its
    /// normal: the corner Q, the edges u and v, the plane vector w and the unit normal.
    /// Five loads of three columns each, where `get` gathers the whole quad (its
    /// vertices and rows too) out of line: surfaces need only these.
    #[inline(always)]
    pub fn frame(&self, i: usize) -> QuadFrame {
        QuadFrame {
            corner: Vec3::new(self.qx[i], self.qy[i], self.qz[i]),
            u: Vec3::new(self.ux[i], self.uy[i], self.uz[i]),
            v: Vec3::new(self.vx[i], self.vy[i], self.vz[i]),
            w: Vec3::new(self.wx[i], self.wy[i], self.wz[i]),
            normal: self.normal(i),
        }
    }

    #[inline]
    pub fn normal(&self, i: usize) -> Vec3 {
        let [x, y, z, _] = self.plane[i];
        Vec3::new(x, y, z)
    }

    pub fn bounds(&self, i: usize) -> Aabb {
        Aabb::from_points(&self.vertices(i))
    }

    /// The quad test on quad `i` (`w`: the ray's watertight constants).
    #[inline(always)]
    pub fn intersect(
        &self,
        i: usize,
        ray: &Ray,
        w: &WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<f32> {
        self.intersect_lazy(i, ray, || w, t_min, t_max)
    }

    /// `intersect` with the watertight constants from `w`, called only when the ray
    /// meets the quad's plane in `[t_min, t_max]`. The plane first: it is the cheaper
    /// half (one dot product pair and a division against the edge test's four sheared
    /// vertices and five edge functions), most quads a ray is tested against fail it
    /// (shadow rays end at their light), and the answer is the same in either order: a
    /// hit needs both.
    #[inline(always)]
    pub fn intersect_lazy<'w>(
        &self,
        i: usize,
        ray: &Ray,
        w: impl FnOnce() -> &'w WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<f32> {
        let [nx, ny, nz, d] = self.plane[i];
        let n = V3::splat(Vec3::new(nx, ny, nz));
        let v = V3::splat;
        let (t, hit) = plane_distance(n, d, v(ray.origin), v(ray.dir), t_min, t_max);
        (hit && passes_through(w(), &self.rows[i])).then_some(t)
    }
}

/// One quad of a pool with what one ray's test of it reads, copied out of the pool once
/// (the quad kept beside the BVH when it is the only one: `spheres`' backdrop): no
/// group loop, and the pool's columns are read only for a hit's id and object.
#[derive(Clone, Copy, Debug, Default)]
pub struct OneQuad {
    /// `QuadPool::plane` and `QuadPool::rows` of the quad.
    plane: [f32; 4],
    rows: [Vec4; 3],
    /// Its pool index.
    pub index: usize,
}

impl OneQuad {
    /// Quad `i` of `pool`.
    pub fn new(pool: &QuadPool, i: usize) -> Self {
        OneQuad {
            plane: pool.plane[i],
            rows: pool.rows[i],
            index: i,
        }
    }

    /// `QuadPool::intersect_lazy` of this quad: the same steps on the same values.
    #[inline(always)]
    pub fn intersect_lazy<'w>(
        &self,
        ray: &Ray,
        w: impl FnOnce() -> &'w WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> Option<f32> {
        let [nx, ny, nz, d] = self.plane;
        let n = V3::splat(Vec3::new(nx, ny, nz));
        let v = V3::splat;
        let (t, hit) = plane_distance(n, d, v(ray.origin), v(ray.dir), t_min, t_max);
        (hit && self.passes_through(w())).then_some(t)
    }

    /// `passes_through` for this quad, out of line: the plane test above is inlined
    /// into the traversals, the edge test (for the rays that meet the plane) is not.
    #[inline(never)]
    fn passes_through(&self, w: &WatertightRay) -> bool {
        passes_through(w, &self.rows)
    }
}

/// Eight quads of a pool, structure-of-arrays in `f32x8` lanes, for one ray to test
/// them at once (the quads kept beside the BVH): the vertices, `vertices[k][axis]`, and
/// the planes. A group past the pool's end is padded with copies of its last quad,
/// masked off by `count`.
#[derive(Clone, Copy, Debug)]
pub struct QuadLanes {
    vertices: [[f32x8; 3]; 4],
    normal: V3<f32x8>,
    plane_d: f32x8,
    /// The pool index of lane 0 (the others follow) and the lanes that hold a quad.
    first: usize,
    count: usize,
}

impl QuadLanes {
    /// The quads `range` of `pool`, eight a group.
    pub fn pack(pool: &QuadPool, range: Range<usize>) -> Vec<QuadLanes> {
        range
            .clone()
            .step_by(8)
            .map(|first| {
                let count = (range.end - first).min(8);
                let i = |k: usize| first + k.min(count - 1);
                let lanes = |f: &dyn Fn(usize) -> f32| f32x8::new(std::array::from_fn(|k| f(i(k))));
                QuadLanes {
                    vertices: std::array::from_fn(|m| {
                        std::array::from_fn(|a| lanes(&|j| pool.vertices[j][m][a]))
                    }),
                    normal: V3::new(
                        lanes(&|j| pool.plane[j][0]),
                        lanes(&|j| pool.plane[j][1]),
                        lanes(&|j| pool.plane[j][2]),
                    ),
                    plane_d: lanes(&|j| pool.plane[j][3]),
                    first,
                    count,
                }
            })
            .collect()
    }

    /// The pool indices of the group's quads.
    #[inline(always)]
    pub fn indices(&self) -> Range<usize> {
        self.first..self.first + self.count
    }

    /// Whether the group holds one quad only: then the scalar test is cheaper.
    #[inline(always)]
    pub fn is_single(&self) -> bool {
        self.count == 1
    }

    /// `QuadPool::intersect` of the group's quads with one ray: each lane's distance
    /// and the mask of the quads hit in `[t_min, t_max]`, the bits of the scalar test's
    /// (its steps on lanes of quads; a lane whose outer edge function rounds to zero
    /// is redone by the scalar edge test, as the packets' are). As there, the planes
    /// first, and the edge test (and `w`, the ray's watertight constants) only if some
    /// quad's plane is met in `[t_min, t_max]`.
    #[inline(always)]
    pub fn intersect<'w>(
        &self,
        pool: &QuadPool,
        ray: &Ray,
        w: impl FnOnce() -> &'w WatertightRay,
        t_min: f32,
        t_max: f32,
    ) -> ([f32; 8], u32) {
        let s = f32x8::splat;
        let (t, hit) = plane_distance(
            self.normal,
            self.plane_d,
            V3::splat(ray.origin),
            V3::splat(ray.dir),
            s(t_min),
            s(t_max),
        );
        let near = hit.bits() & ((1u32 << self.count) - 1);
        if near == 0 {
            return ([0.0; 8], 0);
        }
        let w = w();
        let [kx, ky, kz] = w.axes;
        let o = w.origin.map(s);
        let (sx, sy) = (s(w.sx), s(w.sy));
        let v = &self.vertices;
        let vertex = |m: usize| shear([v[m][kx], v[m][ky], v[m][kz]], o, sx, sy);
        let e = quad_edge_functions(vertex(0), vertex(1), vertex(2), vertex(3));
        let mut inside = inside_quad(e).bits();
        let redo = outer_edge_is_zero(e).bits() & near;
        for k in set_lanes(redo) {
            let through = passes_through(w, &pool.rows[self.first + k]);
            inside = (inside & !(1 << k)) | ((through as u32) << k);
        }
        (t.to_array(), inside & near)
    }
}

/// The scalar edge test: does the ray (`w`, its watertight constants) pass through the
/// quad whose vertices A, B, C, D are `rows` (by axis, `QuadPool::rows`), edges
/// inclusive? The lane steps below (`shear`, `quad_edge_functions`, `inside_quad`) with
/// the four vertices in the lanes of one `Vec4`: the same operations on the same
/// values, so the same answer, in about a third of the instructions (the outer edges
/// are each vertex against the next, one rotation of the lanes). An outer edge function
/// that rounds to exactly zero is recomputed in f64, as the triangles' (so its sign is
/// exact and the same on every quad that shares the edge).
#[inline(always)]
pub fn passes_through(w: &WatertightRay, rows: &[Vec4; 3]) -> bool {
    let [kx, ky, kz] = w.axes;
    // One check for the three reads below.
    assert!(kx < 3 && ky < 3 && kz < 3);
    let o = w.origin.map(Vec4::splat);
    // `shear`, lane-wise.
    let z = rows[kz] - o[2];
    let x = (rows[kx] - o[0]) - Vec4::splat(w.sx) * z;
    let y = (rows[ky] - o[1]) - Vec4::splat(w.sy) * z;
    // The outer edges AB, BC, CD, DA, `quad_edge_functions`' w1, u1, u2, v2: each the
    // next vertex's x times this one's y, less the next one's y times this one's x.
    let outer = x.yzwx() * y - y.yzwx() * x;
    // The diagonal AC, its v1: a.x c.y − a.y c.x.
    let v1 = x.x * y.z - y.x * x.z;
    if outer.cmpeq(Vec4::ZERO).any() {
        return passes_through_f64(x, y);
    }
    // `inside_quad`: the half (A, B, C) has edges w1, u1 (lanes 0, 1) and v1, the half
    // (A, C, D) u2, v2 (lanes 2, 3) and −v1; a half is passed when no two of its edge
    // functions have strictly opposite signs.
    let (lt, gt) = (
        outer.cmplt(Vec4::ZERO).bitmask(),
        outer.cmpgt(Vec4::ZERO).bitmask(),
    );
    let (v1_lt, v1_gt) = (v1 < 0.0, v1 > 0.0);
    let first = !((lt & 0b0011 != 0 || v1_lt) && (gt & 0b0011 != 0 || v1_gt));
    let second = !((lt & 0b1100 != 0 || v1_gt) && (gt & 0b1100 != 0 || v1_lt));
    first || second
}

/// `passes_through` with the edge functions in f64 (`quad_edge_functions_f64`), from
/// the sheared vertices' x and y lanes.
#[cold]
#[inline(never)]
fn passes_through_f64(x: Vec4, y: Vec4) -> bool {
    let v = |k: usize| [x[k], y[k], 0.0];
    inside_quad(quad_edge_functions_f64(v(0), v(1), v(2), v(3)))
}

/// The vertices `p` (A, B, C, D) by axis: `rows[axis]` holds that coordinate of each.
pub fn vertex_rows(p: &[Vec3; 4]) -> [Vec4; 3] {
    [0, 1, 2].map(|a| Vec4::new(p[0][a], p[1][a], p[2][a], p[3][a]))
}

// The quad test in steps over `Lane`, as the triangle's: the scalar tests above and a
// quad against a packet of rays (`accel::packet`).

/// The edge functions of the quad's halves (A, B, C) and (A, C, D), from its sheared
/// vertices: `edge_functions` of each. Their outer edges are the quad's: BC, AB (the
/// first's u and w), CD, DA (the second's u and v), each the difference of the same two
/// products of the same two sheared vertices wherever that edge is tested, so its sign
/// agrees (negated) on every quad or triangle sharing it. The diagonal (the first's v,
/// the second's w) is computed once and negated, so the two halves agree on it too.
#[inline(always)]
pub fn quad_edge_functions<L: Lane>(a: [L; 3], b: [L; 3], c: [L; 3], d: [L; 3]) -> [[L; 3]; 2] {
    let [u1, v1, w1] = edge_functions(a, b, c);
    // `edge_functions(a, c, d)` without its third, c × a = −(a × c).
    let u2 = d[0] * c[1] - d[1] * c[0];
    let v2 = a[0] * d[1] - a[1] * d[0];
    [[u1, v1, w1], [u2, v2, v1.flip_sign()]]
}

/// `quad_edge_functions` in f64 (`edge_functions_f64`), for a ray where an outer edge
/// function rounded to zero.
#[inline(never)]
pub fn quad_edge_functions_f64(
    a: [f32; 3],
    b: [f32; 3],
    c: [f32; 3],
    d: [f32; 3],
) -> [[f32; 3]; 2] {
    let [u1, v1, w1] = edge_functions_f64(a, b, c);
    let [u2, v2, _] = edge_functions_f64(a, c, d);
    [[u1, v1, w1], [u2, v2, -v1]]
}

/// The lanes where one of the quad's four outer edge functions is exactly zero: those
/// are recomputed in f64 (the scalar test; a packet redoes such lanes with it). A zero
/// diagonal needs no such care: both halves include it, and no other quad shares it.
#[inline(always)]
pub fn outer_edge_is_zero<L: Lane>([[u1, _, w1], [u2, v2, _]]: [[L; 3]; 2]) -> L::Mask {
    let zero = L::splat(0.0);
    u1.eq(zero) | w1.eq(zero) | u2.eq(zero) | v2.eq(zero)
}

/// The lanes that pass through the quad: inside one of its halves (`inside_edges` of
/// either, edges inclusive).
#[inline(always)]
pub fn inside_quad<L: Lane>([e1, e2]: [[L; 3]; 2]) -> L::Mask {
    inside_edges(e1) | inside_edges(e2)
}

/// The original program's distance to the quad's plane (n, D), t = (D − n · o) / (n · d),
/// and the lanes where it counts: t in `[t_min, t_max]` and |n · d| ≥ `PARALLEL_EPSILON`.
/// Not the watertight test's own distance, interpolated from the vertices' depths: its
/// error grows with the quad's size (up to ~1e-4 for a 555-unit Cornell wall), which made
/// rays spawned off a wall meet that wall again; the plane's t is exact for axis-aligned
/// quads.
#[inline(always)]
pub fn plane_distance<L: Lane>(
    normal: V3<L>,
    plane_d: L,
    origin: V3<L>,
    dir: V3<L>,
    t_min: L,
    t_max: L,
) -> (L, L::Mask) {
    let denom = normal.dot(dir);
    let parallel = denom.abs().lt(L::splat(PARALLEL_EPSILON));
    let t = (plane_d - normal.dot(origin)) / denom;
    (t, !parallel & t.ge(t_min) & t.le(t_max))
}

/// The six outward-facing quads of the box with the given component-wise min and max
/// corners, with their vertices made of those exact components (so faces sharing an edge
/// share its vertices bit for bit). Corners and edges as the original program's, except
/// that its z-min face pointed inward (`docs/seed-semantics.md`, "Where this renderer
/// differs"). Faces too large for `Quad::new` (|u × v|² not finite) are left out.
pub fn box_faces(min: Vec3, max: Vec3) -> Vec<Quad> {
    let dx = Vec3::new(max.x - min.x, 0.0, 0.0);
    let dy = Vec3::new(0.0, max.y - min.y, 0.0);
    let dz = Vec3::new(0.0, 0.0, max.z - min.z);
    // Corner k of the box: bit 0, 1, 2 set for max.x, max.y, max.z.
    let p = |k: usize| {
        Vec3::new(
            if k & 1 == 0 { min.x } else { max.x },
            if k & 2 == 0 { min.y } else { max.y },
            if k & 4 == 0 { min.z } else { max.z },
        )
    };
    // (u, v, A, B, C, D as corner numbers), the corner being A.
    [
        (dx, dy, [4, 5, 7, 6]),  // front, +z
        (-dz, dy, [5, 1, 3, 7]), // right, +x
        (-dx, dy, [1, 0, 2, 3]), // back, −z
        (dz, dy, [0, 4, 6, 2]),  // left, −x
        (dx, -dz, [6, 7, 3, 2]), // top, +y
        (dx, dz, [0, 1, 5, 4]),  // bottom, −y
    ]
    .into_iter()
    .filter_map(|(u, v, k)| Quad::with_vertices(p(k[0]), u, v, k.map(p)))
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_point_outward() {
        let (min, max) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 6.0, 8.0));
        let centre = (min + max) * 0.5;
        let faces = box_faces(min, max);
        assert_eq!(faces.len(), 6);
        for q in faces {
            let face_centre = q.corner + (q.u + q.v) * 0.5;
            assert!(q.normal.dot(face_centre - centre) > 0.0, "{q:?}");
        }
    }

    #[test]
    fn box_face_vertices_are_exact_corners() {
        // Extents whose sums round: Q + u is not max there, the stored vertex is.
        let (min, max) = (Vec3::new(0.1, -3.7, 1234.567), Vec3::new(0.7, 2.6, 1251.87));
        let is_corner = |p: Vec3| {
            (0..3).all(|k| p[k].to_bits() == min[k].to_bits() || p[k].to_bits() == max[k].to_bits())
        };
        let faces = box_faces(min, max);
        let mut rounded = 0;
        for q in &faces {
            let [a, b, c, d] = q.vertices;
            assert_eq!(a, q.corner);
            for (p, want) in [
                (b, q.corner + q.u),
                (c, q.corner + q.u + q.v),
                (d, q.corner + q.v),
            ] {
                assert!(is_corner(p), "{q:?}");
                assert!((p - want).abs().max_element() <= 1e-3, "{q:?}");
                rounded += (p != want) as u32;
            }
        }
        assert!(rounded > 0, "the case should need the exact corners");
        // Each box edge is an edge of exactly two faces, with the same two vertices.
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut edges = std::collections::HashMap::new();
        for q in &faces {
            for k in 0..4 {
                let (p, r) = (key(q.vertices[k]), key(q.vertices[(k + 1) % 4]));
                *edges.entry((p.min(r), p.max(r))).or_insert(0) += 1;
            }
        }
        assert_eq!(edges.len(), 12);
        assert!(edges.values().all(|&n| n == 2));
    }

    #[test]
    fn edges_are_inclusive() {
        let q = Quad::new(Vec3::ZERO, Vec3::X, Vec3::Y).unwrap();
        let down = Vec3::new(0.0, 0.0, -1.0);
        for (x, y) in [(0.0, 0.0), (1.0, 1.0), (0.5, 1.0), (0.0, 0.5)] {
            let r = Ray::new(Vec3::new(x, y, 1.0), down);
            assert_eq!(
                q.intersect(&r, 1e-4, f32::INFINITY),
                Some(1.0),
                "({x}, {y})"
            );
        }
        let r = Ray::new(Vec3::new(1.001, 0.5, 1.0), down);
        assert_eq!(q.intersect(&r, 1e-4, f32::INFINITY), None);
    }

    /// The edge test in the lane steps at `f32`, one vertex at a time, with the f64 redo
    /// of an outer edge function that rounds to zero.
    fn passes_through_by_steps(w: &WatertightRay, p: &[Vec3; 4]) -> bool {
        let [kx, ky, kz] = w.axes;
        let vertex = |m: usize| shear([p[m][kx], p[m][ky], p[m][kz]], w.origin, w.sx, w.sy);
        let (a, b, c, d) = (vertex(0), vertex(1), vertex(2), vertex(3));
        let mut e = quad_edge_functions::<f32>(a, b, c, d);
        if outer_edge_is_zero(e) {
            e = quad_edge_functions_f64(a, b, c, d);
        }
        inside_quad(e)
    }

    #[test]
    fn passes_through_is_the_lane_steps() {
        // Quads on a coarse grid, rays from grid points aimed at their vertices, edge
        // midpoints, centre and points beside them (edge functions of exactly zero, the
        // f64 redo), and at random points of random quads.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut tested, mut zero, mut inside) = (0, 0, 0);
        for case in 0..4000 {
            let coarse = case % 2 == 0;
            let mut point = |scale: f32| {
                let v = Vec3::new(next(), next(), next()) * 2.0 - 1.0;
                if coarse {
                    (v * 4.0).round() * scale
                } else {
                    v * scale * 4.0
                }
            };
            let Some(q) = Quad::new(point(1.0), point(1.0), point(1.0)) else {
                continue;
            };
            let origin = point(3.0);
            let [a, b, c, d] = q.vertices;
            let f = next();
            let aim = match case % 8 {
                0 | 1 => q.vertices[(4.0 * f) as usize % 4],
                2 | 3 => (a + b) * 0.5,
                4 => (a + c) * 0.5,
                5 => c + (d - c) * f,
                _ => a + q.u * (3.0 * f - 1.0) + q.v * (3.0 * next() - 1.0),
            };
            if aim == origin {
                continue;
            }
            let ray = Ray::new(origin, aim - origin);
            let w = WatertightRay::new(&ray);
            let [kx, ky, kz] = w.axes;
            let sheared = q
                .vertices
                .map(|p| shear([p[kx], p[ky], p[kz]], w.origin, w.sx, w.sy));
            let [sa, sb, sc, sd] = sheared;
            zero += outer_edge_is_zero(quad_edge_functions::<f32>(sa, sb, sc, sd)) as u32;
            let want = passes_through_by_steps(&w, &q.vertices);
            assert_eq!(passes_through(&w, &q.rows), want, "{q:?} {ray:?}");
            inside += want as u32;
            tested += 1;
        }
        assert!(
            tested > 3500 && zero > 500 && inside > 1000,
            "{tested} {zero} {inside}"
        );
    }

    #[test]
    fn degenerate_quads_are_rejected() {
        assert!(Quad::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0).is_none());
        assert!(Quad::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_none());
    }
}
