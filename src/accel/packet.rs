//! Packet traversal of the BVH's 4-wide nodes (a camera packet's frustum descends the
//! 8-wide ones): 4 or 8 rays, one per lane, tested against each child box and each leaf
//! primitive in one pass of the lane kernels (`lanes`), with an active mask for
//! divergence (ARCHITECTURE.md, "Packets").
//!
//! Every lane gets exactly the scalar answer: the primitive kernels are the scalar ones
//! run over lanes (same operations, same bits), the box tests are conservative for each
//! lane (the same margins as the scalar test), and the closest hit is the smallest
//! `(t, id)` whatever the visiting order. A subtree entered by few lanes
//! (`RayPacket::fallback`) is finished one ray at a time by the scalar traversal.

use super::bvh4::{
    decode_leaf, plane_rows, slab, Bvh4, Node4, Node8, RayConsts, Wide, EMPTY, FAR_SCALE, LEAF,
    NEAR_SCALE,
};
use super::cull::Cull;
use super::shadow::Candidates;
use super::stack::{TraversalStack, STACK4, STACK8};
use super::{ShadowQuery, TraversalStats};
use crate::geometry::quad::Quad;
use crate::geometry::quad::{inside_quad, outer_edge_is_zero, plane_distance, quad_edge_functions};
use crate::geometry::sphere::sphere_distance;
use crate::geometry::triangle::{
    edge_functions, inside_edges, shear, watertight_distance, Columns, TrianglePool, WatertightRay,
};
use crate::geometry::{beats, Aabb, Hit, PrimKind, Ray};
use crate::lanes::{set_lanes, Lane, Mask, V3};
use crate::scene::{Light, LightShape, Scene};
use std::mem::MaybeUninit;
use wide::f32x8;

/// The widest packet.
pub const MAX_WIDTH: usize = 8;

/// A packet of rays with the per-lane constants of the box and sphere tests, computed
/// lane-wise with the scalar constructors' operations (`BoxRay::new`, `SphereRay::new`),
/// so each lane holds the scalar values; `WatertightRay::new`'s are made at the
/// packet's first triangle or quad test (`triangle_lanes`).
#[derive(Clone, Debug)]
pub struct RayPacket<L: Lane> {
    /// Lanes holding a ray (bit i: lane i). Other lanes copy an active ray and are never
    /// reported.
    pub active: u32,
    origin: V3<L>,
    dir: V3<L>,
    inv_near: [L; 3],
    inv_far: [L; 3],
    /// Per axis: every lane's direction has this sign (then the box planes need no
    /// per-lane select).
    uniform_sign: [Option<bool>; 3],
    negative: [L::Mask; 3],
    sphere_a: L,
    sphere_inv_a: L,
    /// When every axis has a uniform sign: the rows of `Node4` (as `[[f32; 4]; 8]`)
    /// holding each axis' near and far planes, as `BoxRay` picks them, so a child's box
    /// test is six broadcast loads with no per-axis select.
    box_rows: Option<([usize; 3], [usize; 3])>,
    /// What the packet's rays may hit (`cull`): the closest-hit traversal skips the
    /// rest. `Cull::ALL` unless a caller knows better (`with_cull`).
    cull: Cull,
}

impl<L: Lane> RayPacket<L> {
    /// A packet of `rays[i]` for the lanes `i` set in `active` (`active` must not be
    /// empty).
    pub fn new(rays: &[Ray; MAX_WIDTH], active: u32) -> Self {
        debug_assert!(active != 0 && active < (1 << L::WIDTH));
        let first = active.trailing_zeros() as usize;
        // A transpose through six lane arrays, each lane's source ray picked by a select:
        // per-component `from_fn` with a branch per lane held 17% of the 8-wide
        // `bunny-closeup` bench (perf).
        let mut c = [[0.0f32; MAX_WIDTH]; 6];
        for i in 0..L::WIDTH {
            let r = &rays[if active >> i & 1 != 0 { i } else { first }];
            let v = [
                r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z,
            ];
            for (col, x) in c.iter_mut().zip(v) {
                col[i] = x;
            }
        }
        let lanes = |k: usize| L::from_fn(|i| c[k][i]);
        Self::from_lanes(
            V3::new(lanes(0), lanes(1), lanes(2)),
            V3::new(lanes(3), lanes(4), lanes(5)),
            active,
        )
    }

    /// A packet from rays in lanes of which only the lanes of `active` hold a ray (not
    /// empty): the others get a copy of the first active lane, as `new` gives them.
    #[inline]
    pub fn from_active_lanes(origin: V3<L>, dir: V3<L>, active: u32) -> Self {
        debug_assert!(active != 0 && active < (1 << L::WIDTH));
        if active == (1 << L::WIDTH) - 1 {
            return Self::from_lanes(origin, dir, active);
        }
        let first = active.trailing_zeros() as usize;
        let m = L::Mask::from_bits(active);
        let fill = |v: V3<L>| V3::select(m, v, V3::splat(v.lane(first)));
        Self::from_lanes(fill(origin), fill(dir), active)
    }

    /// The rays' origins, lane by lane.
    #[inline]
    pub fn origin(&self) -> V3<L> {
        self.origin
    }

    /// The rays' directions, lane by lane.
    #[inline]
    pub fn dir(&self) -> V3<L> {
        self.dir
    }

    /// A packet from rays already in lanes; every lane, active or not, must hold a
    /// finite ray (inactive lanes are tested but never reported).
    pub fn from_lanes(origin: V3<L>, dir: V3<L>, active: u32) -> Self {
        let zero = L::splat(0.0);
        // BoxRay::new, lane-wise. (1/d is never −0, so `< 0` is its sign bit; a NaN
        // direction hits nothing whichever planes it picks.)
        let one = L::splat(1.0);
        let inv = [one / dir.x, one / dir.y, one / dir.z];
        let (near_scale, far_scale) = (L::splat(NEAR_SCALE), L::splat(FAR_SCALE));
        let negative = inv.map(|x| x.lt(zero));
        let uniform_sign = negative.map(|m| uniform::<L>(m.bits()));
        // SphereRay::new, lane-wise.
        let sphere_a = dir.dot(dir);
        Self {
            active,
            origin,
            dir,
            inv_near: inv.map(|x| x * near_scale),
            inv_far: inv.map(|x| x * far_scale),
            uniform_sign,
            box_rows: match uniform_sign {
                [Some(x), Some(y), Some(z)] => Some(plane_rows([x, y, z].map(usize::from))),
                _ => None,
            },
            negative,
            sphere_a,
            sphere_inv_a: one / sphere_a,
            cull: Cull::ALL,
        }
    }

    /// This packet, its closest-hit traversal skipping what `cull` rules out. The
    /// caller vouches that none of the packet's rays can hit what is ruled out
    /// (`cull::Cone`).
    #[inline]
    pub fn with_cull(mut self, cull: Cull) -> Self {
        self.cull = cull;
        self
    }

    /// `WatertightRay::new`'s constants lane-wise. When every lane picks the same axes,
    /// with that order and the triangle columns in it; else (only for a scene with quads:
    /// `None` without) with each lane's order as masks, through which the quad test reads
    /// the vertices (triangles are then tested one lane at a time by the scalar test,
    /// which makes its own constants). Made at a packet's first triangle or quad test
    /// (`LazyTriangles`): most `bunny` packets never reach one, and these are three
    /// divisions a packet. Inlined into `LazyTriangles::make`, which stores them in
    /// place: returned, they were copied twice (`OnceCell`), a 450-byte memcpy each.
    #[inline(always)]
    fn triangle_lanes<'a>(
        &self,
        pool: &'a TrianglePool,
        quads: bool,
    ) -> Option<TriangleLanes<'a, L>> {
        let uniform = uniform::<L>;
        let (zero, one) = (L::splat(0.0), L::splat(1.0));
        let (dir, origin) = (self.dir, self.origin);
        let (ax, ay, az) = (dir.x.abs(), dir.y.abs(), dir.z.abs());
        let x_over_y = ax.gt(ay);
        let kz_x = x_over_y & ax.gt(az);
        let kz_y = !x_over_y & ay.gt(az);
        let d = [dir.x, dir.y, dir.z];
        let o = [origin.x, origin.y, origin.z];
        let kz = match (uniform(kz_x.bits()), uniform(kz_y.bits())) {
            (Some(true), _) => Some(0),
            (Some(false), Some(true)) => Some(1),
            (Some(false), Some(false)) => Some(2),
            _ => None,
        };
        let negative = kz.and_then(|kz| uniform(d[kz].lt(zero).bits()));
        if let (Some(kz), Some(negative)) = (kz, negative) {
            let axes @ [kx, ky, kz] = if negative {
                [(kz + 2) % 3, (kz + 1) % 3, kz]
            } else {
                [(kz + 1) % 3, (kz + 2) % 3, kz]
            };
            return Some(TriangleLanes {
                // No columns without triangles (quad-only scenes): nine slices checked.
                order: Order::Uniform(axes, (!pool.is_empty()).then(|| pool.columns(axes))),
                origin: [o[kx], o[ky], o[kz]],
                sx: d[kx] / d[kz],
                sy: d[ky] / d[kz],
                sz: one / d[kz],
            });
        }
        if !quads {
            return None;
        }
        // `WatertightRay::axes` lane by lane: kz, then kx and ky the next two axes in
        // cyclic order, swapped where d[kz] < 0.
        let kz_z = !(kz_x | kz_y);
        let neg = pick(d, [kz_x, kz_y]).lt(zero);
        let pos = !neg;
        let picks = [
            [(kz_y & neg) | (kz_z & pos), (kz_x & pos) | (kz_z & neg)],
            [(kz_y & pos) | (kz_z & neg), (kz_x & neg) | (kz_z & pos)],
            [kz_x, kz_y],
        ];
        let (dx, dy, dz) = (pick(d, picks[0]), pick(d, picks[1]), pick(d, picks[2]));
        Some(TriangleLanes {
            order: Order::PerLane(picks),
            origin: [pick(o, picks[0]), pick(o, picks[1]), pick(o, picks[2])],
            sx: dx / dz,
            sy: dy / dz,
            sz: one / dz,
        })
    }

    /// The sphere test on every lane, `SpherePool::intersect`'s bits: distances and the
    /// lanes of `lanes` that hit in `[t_min, t_max]`.
    #[inline]
    pub fn sphere(
        &self,
        center: glam::Vec3,
        radius: f32,
        t_min: f32,
        t_max: f32,
        lanes: u32,
    ) -> (L, u32) {
        let (t, hit) = sphere_distance::<L>(
            V3::splat(center),
            L::splat(radius),
            self.origin,
            self.dir,
            self.sphere_a,
            self.sphere_inv_a,
            L::splat(t_min),
            L::splat(t_max),
        );
        (t, hit.bits() & lanes)
    }

    /// `Light::nearest_hit` of a light made of the quads `quads` (ids from `first_id`), on
    /// the lanes of `lanes`, by the quad test over lanes (`tris`: the packet's watertight
    /// lanes; the scalar test where they ask for it): per lane the nearest `(t, id)` by
    /// the `(t, id)` rule, the id in the bits of an f32 lane, and the lanes that hit. The
    /// same bits as `nearest_hit` lane by lane.
    #[inline(always)]
    fn quad_light_hits(
        &self,
        quads: &[Quad],
        first_id: u32,
        t_min: f32,
        lanes: u32,
        tris: &mut LazyTriangles<'_, L>,
    ) -> (L, L, u32) {
        let (mut best_t, mut best_id) = (L::splat(0.0), L::splat(0.0));
        let mut found = 0u32;
        let (t_min_l, far) = (L::splat(t_min), L::splat(f32::INFINITY));
        for (k, q) in quads.iter().enumerate() {
            let v = q.vertices.map(|p| p.to_array());
            let plane = q.normal.extend(q.plane_d).to_array();
            let (mut t, mut bits, redo) = self.quad(tris, &v, plane, [t_min_l, far], lanes);
            if redo != 0 {
                let (t_redo, hit) = self.redo_light_quad(q, t_min, redo);
                t = L::select(L::Mask::from_bits(hit), t_redo, t);
                bits |= hit;
            }
            // Ids grow with k, so a later quad takes a lane only if it is nearer.
            let win = bits & !(found & !t.lt(best_t).bits());
            if win == 0 {
                continue;
            }
            let m = L::Mask::from_bits(win);
            best_t = L::select(m, t, best_t);
            best_id = L::select(m, L::splat(f32::from_bits(first_id + k as u32)), best_id);
            found |= win;
        }
        (best_t, best_id, found)
    }

    /// The lanes `redo` of `quad_light_hits`, one at a time with the scalar test.
    #[cold]
    #[inline(never)]
    fn redo_light_quad(&self, q: &Quad, t_min: f32, redo: u32) -> (L, u32) {
        let mut out = [0.0; MAX_WIDTH];
        let mut bits = 0;
        for j in set_lanes(redo) {
            if let Some(tj) = q.intersect(&self.ray(j), t_min, f32::INFINITY) {
                out[j] = tj;
                bits |= 1 << j;
            }
        }
        (L::from_fn(|k| out[k]), bits)
    }

    /// The quad test on the lanes of `lanes`, for the quad with vertices `q` and plane
    /// `plane` (n, D): distances, the lanes that hit, and the lanes that the scalar test
    /// must redo (`TriangleLanes::quad_edges`). The plane first, as the scalar test
    /// (`QuadPool::intersect_lazy`): the edge test, and the packet's watertight lanes
    /// (`tris`), only for the lanes that meet the plane in `[t_min, t_max]`. Both masks
    /// are empty when none does.
    #[inline(always)]
    fn quad(
        &self,
        tris: &mut LazyTriangles<'_, L>,
        q: &[[f32; 3]; 4],
        plane: [f32; 4],
        [t_min, t_max]: [L; 2],
        lanes: u32,
    ) -> (L, u32, u32) {
        let [nx, ny, nz, d] = plane.map(L::splat);
        let n = V3::new(nx, ny, nz);
        let (t, hit) = plane_distance(n, d, self.origin, self.dir, t_min, t_max);
        let near = hit.bits() & lanes;
        if near == 0 {
            return (t, 0, 0);
        }
        let (inside, exact_zero) = Self::quad_edges(tris, q, near);
        (t, inside, exact_zero)
    }

    /// `quad`'s edge test on the lanes `near`. Out of line: the whole test inlined into
    /// the packet loops cost `bunny`, which has no quad, 1.3% more render instructions
    /// (8 wide, callgrind).
    #[inline(never)]
    fn quad_edges(tris: &mut LazyTriangles<'_, L>, q: &[[f32; 3]; 4], near: u32) -> (u32, u32) {
        // A scene with quads always gets the lanes; `None` would redo every lane.
        match tris.get(PrimKind::Quad) {
            Some(tri) => tri.quad_edges(q, near),
            None => (0, near),
        }
    }

    /// The ray of lane `k` (an inactive lane holds a copy of an active one).
    #[inline]
    pub fn ray(&self, k: usize) -> Ray {
        Ray::new(self.origin.lane(k), self.dir.lane(k))
    }

    /// The lanes whose ray meets `b` in `[t_min, t_max]` (the traversal's conservative
    /// box test).
    #[inline]
    pub fn hits_box(&self, b: &Aabb, t_min: f32, t_max: f32) -> u32 {
        let (_, bits) = self.test_box(
            b.min.to_array(),
            b.max.to_array(),
            L::splat(t_min),
            L::splat(t_max),
        );
        bits
    }

    /// Subtrees entered by at most this many lanes are finished one ray at a time: a
    /// lone lane of 8 (none of 4). Measured (benches/probes/packet_probe.rs, callgrind, 400x225x2
    /// camera rays, 8 wide; instructions for bunny-closeup / bunny): finishing alone at
    /// ≤ 0 lanes 171.6M / 110.1M, ≤ 1: 178.1M / 112.9M, ≤ 2: 182.1M / 113.8M, ≤ 3 (the
    /// design's starting point): 188.9M / 115.7M, ≤ 5: 213.5M / 119.7M; whole renders,
    /// one thread, 5 alternating runs, medians ≤ 0 vs ≤ 3: closeup 1.07 vs 1.15 s, bunny
    /// 0.66 vs 0.70 s. Empty lanes cost less than leaving the packet; a lone lane is
    /// kept scalar (a few percent of instructions, within the noise in time).
    #[inline]
    pub fn fallback() -> u32 {
        L::WIDTH as u32 / 8
    }

    /// Entry distances and hit lanes of one box, for lanes with `t_max` (−∞ for lanes not
    /// tested).
    #[inline(always)]
    fn test_box(&self, lo: [f32; 3], hi: [f32; 3], t_min: L, t_max: L) -> (L, u32) {
        let mut near = [L::splat(0.0); 3];
        let mut far = [L::splat(0.0); 3];
        for a in 0..3 {
            let (l, h) = (L::splat(lo[a]), L::splat(hi[a]));
            (near[a], far[a]) = match self.uniform_sign[a] {
                Some(false) => (l, h),
                Some(true) => (h, l),
                None => (
                    L::select(self.negative[a], h, l),
                    L::select(self.negative[a], l, h),
                ),
            };
        }
        let o = [self.origin.x, self.origin.y, self.origin.z];
        let (enter, hit) = slab(near, far, o, self.inv_near, self.inv_far, t_min, t_max);
        (enter, hit.bits())
    }

    /// `test_box` of child `c` of `node`.
    #[inline(always)]
    fn test_child(&self, node: &Node4, c: usize, t_min: L, t_max: L) -> (L, u32) {
        match self.box_rows {
            Some((near_row, far_row)) => {
                let plane = |r: usize| L::splat(node.row(r)[c & 3]);
                let o = [self.origin.x, self.origin.y, self.origin.z];
                let (enter, hit) = slab(
                    near_row.map(plane),
                    far_row.map(plane),
                    o,
                    self.inv_near,
                    self.inv_far,
                    t_min,
                    t_max,
                );
                (enter, hit.bits())
            }
            None => {
                let (lo, hi) = node.child_box(c);
                self.test_box(lo, hi, t_min, t_max)
            }
        }
    }

    /// Distances and hit lanes (of `lanes`) of one primitive, with `t_max` per lane.
    /// Triangle and quad lanes whose (outer) edge function rounds to zero, or packets whose
    /// lanes order the axes differently, are tested one lane at a time by the scalar test.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn test_prim(
        &self,
        scene: &Scene,
        kind: PrimKind,
        i: usize,
        t_min: f32,
        t_max_l: L,
        lanes: u32,
        tris: &mut LazyTriangles<'_, L>,
    ) -> (L, u32) {
        let t_min_l = L::splat(t_min);
        let (t, mut bits, mut redo) = match kind {
            PrimKind::Sphere => {
                let s = &scene.spheres;
                let (t, hit) = sphere_distance::<L>(
                    V3::splat(s.center(i)),
                    L::splat(s.radius[i]),
                    self.origin,
                    self.dir,
                    self.sphere_a,
                    self.sphere_inv_a,
                    t_min_l,
                    t_max_l,
                );
                (t, hit.bits(), 0)
            }
            PrimKind::Quad => {
                let qs = &scene.quads;
                let window = [t_min_l, t_max_l];
                let (t, hit, exact_zero) =
                    self.quad(tris, &qs.vertices[i], qs.plane[i], window, lanes);
                if hit | exact_zero == 0 {
                    return (L::splat(0.0), 0);
                }
                (t, hit, exact_zero)
            }
            PrimKind::Triangle => match tris.get(kind) {
                Some(
                    tri @ TriangleLanes {
                        order: Order::Uniform(_, Some(cols)),
                        ..
                    },
                ) => {
                    let vertex = |m: usize| {
                        let v = [
                            L::splat(cols.at(m, i)),
                            L::splat(cols.at(m + 1, i)),
                            L::splat(cols.at(m + 2, i)),
                        ];
                        shear(v, tri.origin, tri.sx, tri.sy)
                    };
                    let (a, b, c) = (vertex(0), vertex(3), vertex(6));
                    let [u, v, w] = edge_functions(a, b, c);
                    let zero = L::splat(0.0);
                    let exact_zero = (u.eq(zero) | v.eq(zero) | w.eq(zero)).bits();
                    if (inside_edges([u, v, w]).bits() | exact_zero) & lanes == 0 {
                        // No lane inside the edges: no distance (and no division) needed.
                        return (L::splat(0.0), 0);
                    }
                    let (t, hit) =
                        watertight_distance([u, v, w], a, b, c, tri.sz, t_min_l, t_max_l);
                    (t, hit.bits() & !exact_zero, exact_zero)
                }
                _ => (L::splat(0.0), 0, lanes),
            },
        };
        bits &= lanes;
        redo &= lanes;
        if redo != 0 {
            let (t_redo, hit) = self.redo_lanes(scene, kind, i, t_min, t_max_l, redo);
            bits |= hit;
            return (L::select(L::Mask::from_bits(hit), t_redo, t), bits);
        }
        (t, bits)
    }

    /// The lanes `redo` of `test_prim` (a triangle or quad), one at a time with the scalar
    /// test: the distances (in the lanes that hit) and the lanes that hit. Out of line:
    /// rare, and with the two scalar tests inlined the packet loops around `test_prim`
    /// cost 2.0% more render instructions on `bunny` and 1.8% on `cornell` (8 wide,
    /// callgrind).
    #[cold]
    #[inline(never)]
    fn redo_lanes(
        &self,
        scene: &Scene,
        kind: PrimKind,
        i: usize,
        t_min: f32,
        t_max: L,
        redo: u32,
    ) -> (L, u32) {
        let mut out = [0.0; MAX_WIDTH];
        let mut bits = 0;
        for k in set_lanes(redo) {
            let ray = self.ray(k);
            let w = WatertightRay::new(&ray);
            let hit = match kind {
                PrimKind::Quad => scene.quads.intersect(i, &ray, &w, t_min, t_max.lane(k)),
                _ => scene.triangles.intersect(i, &w, t_min, t_max.lane(k)),
            };
            if let Some(tk) = hit {
                out[k] = tk;
                bits |= 1 << k;
            }
        }
        (L::from_fn(|k| out[k]), bits)
    }
}

/// Whether a mask over the `L::WIDTH` lanes is all clear (`Some(false)`), all set
/// (`Some(true)`) or mixed (`None`).
#[inline(always)]
fn uniform<L: Lane>(bits: u32) -> Option<bool> {
    match bits {
        0 => Some(false),
        b if b == (1u32 << L::WIDTH) - 1 => Some(true),
        _ => None,
    }
}

/// A packet's watertight constants and triangle columns (`RayPacket::triangle_lanes`),
/// made at its first triangle or quad test: most `bunny` packets never reach one.
pub(crate) struct TriangleLanes<'a, L: Lane> {
    order: Order<'a, L>,
    origin: [L; 3],
    sx: L,
    sy: L,
    sz: L,
}

impl<L: Lane> TriangleLanes<'_, L> {
    /// The quad's edge test (`geometry::quad`'s lane steps) on the lanes of `lanes`, for
    /// the vertices `q`: the lanes that pass through the quad, and those that the scalar
    /// test must redo (an outer edge function exactly zero; not in the first mask).
    #[inline(always)]
    fn quad_edges(&self, q: &[[f32; 3]; 4], lanes: u32) -> (u32, u32) {
        let v = match &self.order {
            Order::Uniform([kx, ky, kz], _) => {
                // `& 3`: the axes are 0..2; the mask drops the bounds checks.
                let (kx, ky, kz) = (kx & 3, ky & 3, kz & 3);
                let vertex = |m: usize| {
                    let p = q[m];
                    let p = [L::splat(p[kx]), L::splat(p[ky]), L::splat(p[kz])];
                    shear(p, self.origin, self.sx, self.sy)
                };
                [vertex(0), vertex(1), vertex(2), vertex(3)]
            }
            Order::PerLane(m) => {
                let vertex = |k: usize| {
                    let p = q[k];
                    let p = [L::splat(p[0]), L::splat(p[1]), L::splat(p[2])];
                    let p = [pick(p, m[0]), pick(p, m[1]), pick(p, m[2])];
                    shear(p, self.origin, self.sx, self.sy)
                };
                [vertex(0), vertex(1), vertex(2), vertex(3)]
            }
        };
        let e = quad_edge_functions(v[0], v[1], v[2], v[3]);
        let exact_zero = outer_edge_is_zero(e).bits() & lanes;
        (inside_quad(e).bits() & lanes & !exact_zero, exact_zero)
    }
}

/// The lanes' axis order [kx, ky, kz].
enum Order<'a, L: Lane> {
    /// The same in every lane, with the triangle columns in that order.
    Uniform([usize; 3], Option<Columns<'a>>),
    /// Per lane: for kx, ky and kz, the lanes where it is x and those where it is y (else
    /// it is z).
    PerLane([[L::Mask; 2]; 3]),
}

/// Lane by lane, the component of `v` that the masks `[is_x, is_y]` pick (else z).
#[inline(always)]
fn pick<L: Lane>(v: [L; 3], [is_x, is_y]: [L::Mask; 2]) -> L {
    L::select(is_x, v[0], L::select(is_y, v[1], v[2]))
}

/// A packet's `TriangleLanes`, made at its first triangle or quad test (`get`).
struct LazyTriangles<'a, L: Lane> {
    packet: &'a RayPacket<L>,
    tri: &'a TrianglePool,
    quads: bool,
    made: bool,
    lanes: Option<TriangleLanes<'a, L>>,
}

impl<'a, L: Lane> LazyTriangles<'a, L> {
    #[inline(always)]
    fn new(packet: &'a RayPacket<L>, scene: &'a Scene) -> Self {
        Self {
            packet,
            tri: &scene.triangles,
            quads: !scene.quads.is_empty(),
            made: false,
            lanes: None,
        }
    }

    /// The watertight lanes for a triangle or quad test (`None` for spheres, or when the
    /// lanes order the axes differently in a scene without quads).
    #[inline(always)]
    fn get(&mut self, kind: PrimKind) -> Option<&TriangleLanes<'a, L>> {
        if kind == PrimKind::Sphere {
            return None;
        }
        if !self.made {
            self.make();
        }
        self.lanes.as_ref()
    }

    #[inline(never)]
    fn make(&mut self) {
        self.lanes = self.packet.triangle_lanes(self.tri, self.quads);
        self.made = true;
    }
}

/// Pool data of a primitive for a `Hit`.
#[inline(always)]
fn ids(scene: &Scene, kind: PrimKind, i: usize) -> (u32, u32) {
    match kind {
        PrimKind::Sphere => (scene.spheres.id[i], scene.spheres.object[i]),
        PrimKind::Quad => (scene.quads.id[i], scene.quads.object[i]),
        PrimKind::Triangle => (scene.triangles.id[i], scene.triangles.object[i]),
    }
}

/// `ShadowQuery` in lanes: per lane the light object's own nearest hit `(t_light,
/// id_light)` (the id in an f32's bits), the object, and the kind of its primitives when
/// it is a light (an object is one sphere, quads or triangles; `None`: any kind may be
/// the object's).
#[derive(Clone, Copy, Debug)]
pub struct ShadowLanes<L> {
    t_min: f32,
    t_light: L,
    id_light: L,
    object: u32,
    kind: Option<PrimKind>,
}

impl<L: Lane> ShadowLanes<L> {
    /// Lane `k` asks `query(k)`, of the same `t_min` and `object`.
    #[inline(always)]
    pub fn from_fn(t_min: f32, object: u32, query: impl Fn(usize) -> (f32, u32)) -> Self {
        ShadowLanes {
            t_min,
            t_light: L::from_fn(|k| query(k).0),
            id_light: L::from_fn(|k| f32::from_bits(query(k).1)),
            object,
            kind: None,
        }
    }

    /// Lane `k`'s question.
    #[inline(always)]
    pub fn lane(&self, k: usize) -> ShadowQuery {
        ShadowQuery {
            t_min: self.t_min,
            t_light: self.t_light.lane(k),
            id_light: self.id_light.lane(k).to_bits(),
            object: self.object,
        }
    }
}

/// The lanes of `lanes` for which a primitive of `range` (of `kind`) occludes `light`
/// (`Bvh4::occluded_lanes`) within `t_max`.
/// Inlined into the traversal (a closure call cost `cornell`'s shadow packets 12% more
/// instructions, `packet_probe cornell 8 shadow`), one loop per kind: with the kind
/// known, each loop holds only its kind's test (the tree's leaves, whose kind is not
/// known, take `occluders_of` with all three: a copy per kind there cost more).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn occluders<L: Lane>(
    scene: &Scene,
    p: &RayPacket<L>,
    light: ShadowLanes<L>,
    kind: PrimKind,
    range: std::ops::Range<usize>,
    lanes: u32,
    t_max: L,
    tris: &mut LazyTriangles<'_, L>,
) -> u32 {
    let (s, r, l) = (scene, range, lanes);
    match kind {
        PrimKind::Sphere => occluders_of(s, p, light, PrimKind::Sphere, r, l, t_max, tris),
        PrimKind::Quad => occluders_of(s, p, light, PrimKind::Quad, r, l, t_max, tris),
        PrimKind::Triangle => occluders_of(s, p, light, PrimKind::Triangle, r, l, t_max, tris),
    }
}

/// `occluders` for primitives of `kind`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn occluders_of<L: Lane>(
    scene: &Scene,
    p: &RayPacket<L>,
    light: ShadowLanes<L>,
    kind: PrimKind,
    range: std::ops::Range<usize>,
    lanes: u32,
    t_max: L,
    tris: &mut LazyTriangles<'_, L>,
) -> u32 {
    let mut found = 0;
    let t_min = light.t_min;
    // Primitives of the object's own kind are skipped before their test (the light's
    // quads are dear to test); the others cannot be the object's, and their ids are
    // looked up only when some lane hits them.
    let (t_light, object) = (light.t_light, light.object);
    let check_first = light.kind.is_none_or(|k| k == kind);
    for i in range {
        if check_first && ids(scene, kind, i).1 == object {
            continue;
        }
        let (t, bits) = p.test_prim(scene, kind, i, t_min, t_max, lanes & !found, tris);
        if bits == 0 {
            continue;
        }
        let (id, obj) = ids(scene, kind, i);
        if obj == object {
            continue;
        }
        // `beats` lane-wise: nearer than the light, or as near with a smaller id.
        found |= t.lt(t_light).bits() & bits;
        for k in set_lanes(t.eq(t_light).bits() & bits) {
            if id < light.id_light.lane(k).to_bits() {
                found |= 1 << k;
            }
        }
        if found == lanes {
            break;
        }
    }
    found
}

/// The lanes of `lanes` whose shadow ray a primitive of `among` occludes
/// (`Bvh4::occluded_lanes` over the shadow candidates only, without the tree). A quad's
/// box is tested before its edges, as a leaf's box is in the tree (and as safely: the
/// slab test's scaled reciprocals keep every lane the quad test accepts).
#[inline(always)]
fn occluded_among<L: Lane>(
    scene: &Scene,
    p: &RayPacket<L>,
    light: ShadowLanes<L>,
    lanes: u32,
    among: Candidates<'_>,
    tris: &mut LazyTriangles<'_, L>,
    stats: &mut TraversalStats,
) -> u32 {
    let mut remaining = lanes & p.active;
    let t_max = in_play(remaining, light.t_light);
    let t_min_l = L::splat(light.t_min);
    for (kind, range) in among.runs() {
        if kind == PrimKind::Quad {
            for i in range {
                let (lo, hi) = among.quad_box(i);
                let inside = p.test_box(lo, hi, t_min_l, t_max).1 & remaining;
                if inside == 0 {
                    continue;
                }
                stats.prims += inside.count_ones() as u64;
                let quad = PrimKind::Quad;
                remaining &= !occluders(scene, p, light, quad, i..i + 1, inside, t_max, tris);
                if remaining == 0 {
                    return lanes & p.active;
                }
            }
            continue;
        }
        stats.prims += (range.len() * remaining.count_ones() as usize) as u64;
        remaining &= !occluders(scene, p, light, kind, range, remaining, t_max, tris);
        if remaining == 0 {
            break;
        }
    }
    lanes & p.active & !remaining
}

/// The kind of a light's primitives.
#[inline(always)]
fn light_kind(shape: &LightShape) -> PrimKind {
    match shape {
        LightShape::Point { .. } => PrimKind::Sphere,
        LightShape::Quads(_) => PrimKind::Quad,
        LightShape::Triangles(_) => PrimKind::Triangle,
    }
}

/// `t` in the lanes of `lanes`, −∞ in the others (no box or primitive test passes).
#[inline(always)]
fn in_play<L: Lane>(lanes: u32, t: L) -> L {
    L::select(L::Mask::from_bits(lanes), t, L::splat(f32::NEG_INFINITY))
}

/// A packet whose rays share their origin and each axis' direction sign, bounded as one
/// frustum: per axis the smallest and largest of the lanes' margin reciprocals. One
/// 4-wide pass then tests a node's four children for the whole packet
/// (`Frustum::test`), where the lane-wise test costs four 8-wide passes and the masks'
/// bookkeeping (camera packets of `bunny-closeup`).
///
/// Why it is conservative: a lane's slab test computes `(plane − o) · inv` for its own
/// `inv`, and for a fixed `plane − o` the rounded product is monotone in `inv` (rounding
/// is monotone), so the smaller of the products with the smallest and the largest `inv`
/// is at most every lane's entry on that axis, and the larger at least every lane's
/// exit. With every lane's `t_max` at most `t_far`, a box the bounds reject is missed by
/// every lane. The reciprocals must be finite and nonzero: no 0 · ∞ (a NaN the lane test
/// treats as "no constraint") can arise then.
#[derive(Clone, Copy, Debug)]
struct Frustum {
    origin: [f32; 3],
    /// (smallest, largest) over the lanes of `inv_near` and of `inv_far`, per axis.
    near: [(f32, f32); 3],
    far: [(f32, f32); 3],
    rows: ([usize; 3], [usize; 3]),
}

impl Frustum {
    /// `None` unless every lane has the origin of lane 0 and the same direction signs,
    /// and all reciprocals are finite and nonzero. Every lane counts, active or not (the
    /// bounds then hold for more rays than needed, which is still conservative).
    fn new<L: Lane>(p: &RayPacket<L>) -> Option<Frustum> {
        let rows = p.box_rows?;
        let all = (1u32 << L::WIDTH) - 1;
        let o = [p.origin.x, p.origin.y, p.origin.z];
        let mut origin = [0.0; 3];
        let mut near = [(0.0, 0.0); 3];
        let mut far = [(0.0, 0.0); 3];
        let usable = |v: L| {
            let a = v.abs();
            a.lt(L::splat(f32::INFINITY)).bits() & a.gt(L::splat(0.0)).bits() == all
        };
        let range = |v: L| (v.reduce_min(), v.reduce_max());
        for a in 0..3 {
            let o0 = o[a].lane(0);
            if o[a].eq(L::splat(o0)).bits() != all {
                return None;
            }
            if !usable(p.inv_near[a]) || !usable(p.inv_far[a]) {
                return None;
            }
            origin[a] = o0;
            near[a] = range(p.inv_near[a]);
            far[a] = range(p.inv_far[a]);
        }
        Some(Frustum {
            origin,
            near,
            far,
            rows,
        })
    }

    /// Lower bounds of the lanes' entry distances into the eight children of `node`,
    /// and the children some lane may enter within `[t_min, t_far]`.
    #[inline(always)]
    fn test(&self, node: &Node8, t_min: f32, t_far: f32) -> ([f32; 8], u32) {
        let (e, mask) = self.bounds(|r| f32x8::from(node.row(r)), t_min, t_far);
        (e.to_array(), mask)
    }

    /// `test` on rows in `V`'s lanes: `row(r)` is row `r` of the node (one plane of
    /// every child). Generic so that `min` and `max` are `Lane`'s (`vminps`, `vmaxps`),
    /// not `f32x8`'s own, which handle NaNs (none here: the reciprocals are finite and
    /// nonzero) at a cost.
    #[inline(always)]
    fn bounds<V: Lane>(&self, row: impl Fn(usize) -> V, t_min: f32, t_far: f32) -> (V, u32) {
        let (mut enter, mut exit) = (V::splat(t_min), V::splat(t_far));
        for a in 0..3 {
            let o = V::splat(self.origin[a]);
            let dn = row(self.rows.0[a]) - o;
            let (lo, hi) = (V::splat(self.near[a].0), V::splat(self.near[a].1));
            enter = enter.max((dn * lo).min(dn * hi));
            let df = row(self.rows.1[a]) - o;
            let (lo, hi) = (V::splat(self.far[a].0), V::splat(self.far[a].1));
            exit = exit.min((df * lo).max(df * hi));
        }
        (enter, enter.le(exit).bits())
    }
}

/// The closest hits of a packet's lanes (`closest_hit_packet`), all in lanes: while
/// traversing, a winning primitive costs four selects, not a loop over its lanes.
#[derive(Clone, Copy, Debug)]
pub struct PacketHits<L> {
    /// The lanes with a hit.
    pub found: u32,
    /// The lanes' hit distance (during traversal, the best so far): +∞ without a hit,
    /// −∞ for lanes not traced.
    pub t: L,
    /// The lanes' primitive (its index in its kind's pool), its id and its object,
    /// each in the bits of an f32. Only moved by splats and selects, never computed
    /// with, so the bits stay as written.
    index: L,
    id: L,
    object: L,
    /// The lanes whose hit is a sphere, a quad, a triangle (`PrimKind::slot`).
    kinds: [u32; 3],
}

impl<L: Lane> PacketHits<L> {
    /// No hits: the lanes of `active` at +∞, the others at −∞.
    #[inline(always)]
    pub fn none(active: u32) -> Self {
        Self {
            found: 0,
            t: L::select(
                L::Mask::from_bits(active),
                L::splat(f32::INFINITY),
                L::splat(f32::NEG_INFINITY),
            ),
            index: L::splat(0.0),
            id: L::splat(0.0),
            object: L::splat(0.0),
            kinds: [0; 3],
        }
    }

    /// Lane `k`'s hit.
    #[inline(always)]
    pub fn hit(&self, k: usize) -> Option<Hit> {
        if self.found >> k & 1 == 0 {
            return None;
        }
        let kind = if self.kinds[0] >> k & 1 != 0 {
            PrimKind::Sphere
        } else if self.kinds[1] >> k & 1 != 0 {
            PrimKind::Quad
        } else {
            PrimKind::Triangle
        };
        Some(Hit {
            t: self.t.lane(k),
            id: self.id.lane(k).to_bits(),
            kind,
            index: self.index.lane(k).to_bits(),
            object: self.object.lane(k).to_bits(),
        })
    }

    /// Every lane's hit, as `closest_hit` gives it.
    #[inline(always)]
    pub fn to_array(&self) -> [Option<Hit>; MAX_WIDTH] {
        let mut out = [None; MAX_WIDTH];
        for k in set_lanes(self.found) {
            out[k] = self.hit(k);
        }
        out
    }

    /// Lane `k`'s object (meaningful in the lanes of `found`).
    #[inline(always)]
    pub fn object_of(&self, k: usize) -> u32 {
        self.object.lane(k).to_bits()
    }

    /// The lanes of `found` whose object is `object`, by one lane compare: the bits of
    /// an object number below 2³¹ − 2²³ are a float's that equals only itself (not a
    /// NaN, and no object number has −0's bits).
    #[inline(always)]
    pub fn of_object(&self, object: u32) -> u32 {
        debug_assert!(object < 0x7f80_0000);
        self.object.eq(L::splat(f32::from_bits(object))).bits() & self.found
    }

    /// The lanes whose hit is of `kind`.
    #[inline(always)]
    pub fn of_kind(&self, kind: PrimKind) -> u32 {
        self.kinds[kind.slot()]
    }

    /// The lanes' objects (meaningful in the lanes of `found`).
    #[inline(always)]
    pub fn objects(&self) -> [u32; MAX_WIDTH] {
        std::array::from_fn(|k| {
            if k < L::WIDTH {
                self.object.lane(k).to_bits()
            } else {
                0
            }
        })
    }

    /// The lanes' primitives' indices in their kind's pool (meaningful in the lanes of
    /// `found`).
    #[inline(always)]
    pub fn indices(&self) -> [usize; MAX_WIDTH] {
        std::array::from_fn(|k| {
            if k < L::WIDTH {
                self.index.lane(k).to_bits() as usize
            } else {
                0
            }
        })
    }

    /// The lanes of `lanes` now hit a primitive of `kind`.
    #[inline(always)]
    fn set_kind(&mut self, kind: PrimKind, lanes: u32) {
        for (slot, m) in self.kinds.iter_mut().enumerate() {
            *m = if slot == kind.slot() {
                *m | lanes
            } else {
                *m & !lanes
            };
        }
    }

    /// Lane `k` takes distance bound `t` and best hit `best` (from the scalar traversal).
    #[inline(always)]
    pub fn set(&mut self, k: usize, t: f32, best: Option<Hit>) {
        let m = L::Mask::from_bits(1 << k);
        self.t = L::select(m, L::splat(t), self.t);
        if let Some(h) = best {
            self.index = L::select(m, L::splat(f32::from_bits(h.index)), self.index);
            self.id = L::select(m, L::splat(f32::from_bits(h.id)), self.id);
            self.object = L::select(m, L::splat(f32::from_bits(h.object)), self.object);
            self.found |= 1 << k;
            self.set_kind(h.kind, 1 << k);
        }
    }

    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn leaf(
        &mut self,
        scene: &Scene,
        p: &RayPacket<L>,
        kind: PrimKind,
        range: std::ops::Range<usize>,
        t_min: f32,
        lanes: u32,
        tris: &mut LazyTriangles<'_, L>,
    ) {
        // One loop per kind, each with its kind's test only.
        let (r, l) = (range, lanes);
        match kind {
            PrimKind::Sphere => self.leaf_of(scene, p, PrimKind::Sphere, r, t_min, l, tris),
            PrimKind::Quad => self.leaf_of(scene, p, PrimKind::Quad, r, t_min, l, tris),
            PrimKind::Triangle => self.leaf_of(scene, p, PrimKind::Triangle, r, t_min, l, tris),
        }
    }

    /// `leaf` for primitives of `kind`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn leaf_of(
        &mut self,
        scene: &Scene,
        p: &RayPacket<L>,
        kind: PrimKind,
        range: std::ops::Range<usize>,
        t_min: f32,
        lanes: u32,
        tris: &mut LazyTriangles<'_, L>,
    ) {
        for i in range {
            let (t, bits) = p.test_prim(scene, kind, i, t_min, self.t, lanes, tris);
            if bits == 0 {
                continue;
            }
            // A hit lane has t ≤ t_max: the nearer wins (`beats`); at an equal distance
            // to a hit already found, the smaller id.
            let (id, object) = ids(scene, kind, i);
            let mut win = bits;
            let tie = t.eq(self.t).bits() & bits & self.found;
            for k in set_lanes(tie) {
                if !beats((t.lane(k), id), (t.lane(k), self.id.lane(k).to_bits())) {
                    win &= !(1 << k);
                }
            }
            let m = L::Mask::from_bits(win);
            let bits_of = |x: u32| L::splat(f32::from_bits(x));
            self.t = L::select(m, t, self.t);
            self.index = L::select(m, bits_of(i as u32), self.index);
            self.id = L::select(m, bits_of(id), self.id);
            self.object = L::select(m, bits_of(object), self.object);
            self.found |= win;
            self.set_kind(kind, win);
        }
    }
}

impl Bvh4 {
    /// The lanes whose ray may enter the tree: those that meet its box within
    /// `[t_min, t_max]` if `tree_box_first`, else all those with `t_max ≥ t_min` (the
    /// root's children are tested anyway).
    #[inline(always)]
    fn enters_tree<L: Lane>(&self, p: &RayPacket<L>, t_min: f32, t_max: L) -> u32 {
        if !self.tree_box_first {
            return t_max.ge(L::splat(t_min)).bits();
        }
        let b = &self.tree_box;
        let (_, bits) = p.test_box(b.min.to_array(), b.max.to_array(), L::splat(t_min), t_max);
        bits
    }

    /// The closest hit of every active lane in `[t_min, ∞)`, exactly as `closest_hit`
    /// returns it for that lane's ray.
    pub fn closest_hit_packet<L: Lane>(
        &self,
        scene: &Scene,
        p: &RayPacket<L>,
        t_min: f32,
        stats: &mut TraversalStats,
    ) -> PacketHits<L> {
        let mut tris = LazyTriangles::new(p, scene);
        let mut st = PacketHits::none(p.active);
        for (k, &kind) in PrimKind::ALL.iter().enumerate() {
            let range = self.linear[k].clone();
            // (Not for an empty range: an empty pool must not make the watertight
            // lanes, `tris.get`.)
            if range.is_empty() {
                continue;
            }
            if p.cull.beside[k] == u32::MAX {
                stats.prims += (range.len() * p.active.count_ones() as usize) as u64;
                st.leaf(scene, p, kind, range, t_min, p.active, &mut tris);
                continue;
            }
            // The primitives the cull keeps (past the 32nd, all), in pool order.
            let first = range.start;
            let n = range.len().min(32);
            let mut kept = p.cull.beside[k] & if n == 32 { u32::MAX } else { (1 << n) - 1 };
            while kept != 0 {
                let i = first + kept.trailing_zeros() as usize;
                kept &= kept - 1;
                stats.prims += p.active.count_ones() as u64;
                st.leaf(scene, p, kind, i..i + 1, t_min, p.active, &mut tris);
            }
            if range.len() > 32 {
                let rest = first + 32..range.end;
                stats.prims += (rest.len() * p.active.count_ones() as usize) as u64;
                st.leaf(scene, p, kind, rest, t_min, p.active, &mut tris);
            }
        }
        let Some(root) = self.root else {
            return st;
        };
        if !p.cull.tree {
            return st;
        }
        // As in `occluded_packet`: the tree's box first.
        let mut lanes = self.enters_tree(p, t_min, st.t) & p.active;
        if lanes == 0 {
            return st;
        }
        // Through the 8-wide nodes (built with the 4-wide ones, so present with them):
        // one 8-lane bound test a node, two thirds of the levels (`packet_probe
        // bunny-closeup 8`: 67.2M → 66.0M instructions; at 4 wide 130.4M → 123.2M).
        if let (Some(fr), Some(root8)) = (Frustum::new(p), self.root8) {
            self.closest_frustum(
                scene, p, &fr, root8, lanes, t_min, &mut st, &mut tris, stats,
            );
            return st;
        }
        let fallback = RayPacket::<L>::fallback();
        let mut slots = MaybeUninit::<[_; STACK4]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        // The node being visited and its lanes. The nearest child a node's lanes enter
        // is visited next without a trip through the stack (most nodes of a coherent
        // packet have one); the others are pushed, farthest first.
        let mut code = root;
        loop {
            if lanes != 0 && code & LEAF != 0 {
                let (kind, start, count) = decode_leaf(code);
                stats.prims += (count * lanes.count_ones()) as u64;
                st.leaf(
                    scene,
                    p,
                    kind,
                    start as usize..(start + count) as usize,
                    t_min,
                    lanes,
                    &mut tris,
                );
            } else if lanes != 0 {
                stats.nodes += 1;
                stats.packet_nodes += 1;
                stats.packet_lanes += lanes.count_ones() as u64;
                let node = &self.nodes[code as usize];
                let t_max = in_play(lanes, st.t);
                // All four boxes first, with no branch between them (an empty slot's box
                // is inverted and never hit): which children a packet enters is a coin
                // toss for the branch predictor, so it is asked once, as a 4-bit mask.
                let t_min_l = L::splat(t_min);
                let tested: [(L, u32); 4] = std::array::from_fn(|c| {
                    let (entry, bits) = p.test_child(node, c, t_min_l, t_max);
                    (entry, bits & lanes)
                });
                let entered = tested
                    .iter()
                    .enumerate()
                    .fold(0u32, |m, (c, t)| m | ((t.1 != 0) as u32) << c);
                let mut hits = [(0u32, 0u32, 0f32); 4];
                let mut finished_alone = false;
                let mut n = 0;
                for c in set_lanes(entered) {
                    let (entry, bits) = tested[c];
                    let child = node.child[c];
                    debug_assert!(child != EMPTY);
                    if bits.count_ones() <= fallback {
                        for k in set_lanes(bits) {
                            let ray = p.ray(k);
                            let (mut consts, bray) = RayConsts::with_box4(&ray);
                            let mut t_max = st.t.lane(k);
                            let mut best = st.hit(k);
                            self.closest_hit_from(
                                scene,
                                child,
                                &mut consts,
                                &bray,
                                t_min,
                                &mut t_max,
                                &mut best,
                                stats,
                            );
                            st.set(k, t_max, best);
                        }
                        finished_alone = true;
                        continue;
                    }
                    let d = L::select(L::Mask::from_bits(bits), entry, L::splat(f32::INFINITY))
                        .reduce_min();
                    // Insert sorted, farthest first, so the nearest is last.
                    let mut j = n;
                    while j > 0 && hits[j - 1].2 < d {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = (child, bits, d);
                    n += 1;
                }
                if n > 0 {
                    for h in &hits[..n - 1] {
                        stack.push(*h);
                    }
                    let (child, bits, d) = hits[n - 1];
                    code = child;
                    // The lanes' `t_max` can have changed only if some were finished alone.
                    lanes = if finished_alone {
                        st.t.ge(L::splat(d)).bits() & bits
                    } else {
                        bits
                    };
                    continue;
                }
            }
            // Pop the next subtree. Lanes whose closest hit is already nearer than the
            // box's entry (the smallest over the lanes that entered it) leave it.
            let Some((next, next_lanes, enter)) = stack.pop() else {
                break;
            };
            code = next;
            lanes = st.t.ge(L::splat(enter)).bits() & next_lanes;
        }
        st
    }

    /// `closest_hit_packet`'s tree traversal for a packet bounded by a frustum: each node
    /// tests its four children once for the whole packet (`Frustum::test`), visits the
    /// nearest next and pushes the others, farthest first (the scalar traversal's order),
    /// and a leaf tests its primitives on the lanes of `lanes` whose closest hit is not
    /// nearer than the leaf's entry bound. A subtree is skipped once its entry bound is
    /// beyond every lane's closest hit. Which nodes are visited changes, never what a
    /// lane finds: the bounds are conservative (`Frustum`) and a leaf's test is exact.
    #[allow(clippy::too_many_arguments)]
    fn closest_frustum<L: Lane>(
        &self,
        scene: &Scene,
        p: &RayPacket<L>,
        fr: &Frustum,
        root: u32,
        lanes: u32,
        t_min: f32,
        st: &mut PacketHits<L>,
        tris: &mut LazyTriangles<'_, L>,
        stats: &mut TraversalStats,
    ) {
        // The farthest closest hit of the lanes (+∞ while one has none).
        let far = |st: &PacketHits<L>| in_play(lanes, st.t).reduce_max();
        let mut t_far = far(st);
        let mut slots = MaybeUninit::<[_; STACK8]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        let (mut code, mut enter) = (root, t_min);
        'visit: loop {
            if code & LEAF != 0 {
                let (kind, start, count) = decode_leaf(code);
                let leaf_lanes = st.t.ge(L::splat(enter)).bits() & lanes;
                if leaf_lanes != 0 {
                    stats.prims += (count * leaf_lanes.count_ones()) as u64;
                    let range = start as usize..(start + count) as usize;
                    st.leaf(scene, p, kind, range, t_min, leaf_lanes, tris);
                    t_far = far(st);
                }
            } else {
                stats.nodes += 1;
                stats.packet_nodes += 1;
                stats.packet_lanes += lanes.count_ones() as u64;
                let node = &self.nodes8[code as usize];
                let (entry, mask) = fr.test(node, t_min, t_far);
                if mask != 0 {
                    // As the scalar traversal orders them (the bounds are at least
                    // t_min, so positive).
                    let s = node.push_farther(mask, &entry, &mut stack);
                    (code, enter) = (node.child(s), entry[s & 7]);
                    continue 'visit;
                }
            }
            // Pop the next subtree some lane may still find something nearer in.
            while let Some((next, e)) = stack.pop() {
                if e <= t_far {
                    (code, enter) = (next, e);
                    continue 'visit;
                }
            }
            return;
        }
    }

    /// Shadow rays: the lanes of `lanes` that `light` (lane `k` asking `light.lane(k)`)
    /// finds occluded, exactly as `occluded` answers for each lane's ray.
    pub fn occluded_packet<L: Lane>(
        &self,
        scene: &Scene,
        p: &RayPacket<L>,
        mut light: ShadowLanes<L>,
        lanes: u32,
        stats: &mut TraversalStats,
    ) -> u32 {
        // The kind of the object's primitives when it is a light (an object is one
        // sphere, quads or triangles); `None`: any kind may be the object's.
        light.kind = scene
            .lights
            .iter()
            .find(|l| l.object == light.object)
            .map(|l| light_kind(&l.shape));
        let mut tris = LazyTriangles::new(p, scene);
        self.occluded_lanes(scene, p, light, lanes, &mut tris, stats)
    }

    /// `Accel::light_visible` for the active lanes of `p` in `lanes`: the mask of those
    /// that see `light`. The light's own hits and the occluders share the packet's
    /// watertight lanes (made once, at the first quad or triangle edge test). With
    /// `among` (`shadow::Candidates` of the lanes' origins), only those primitives are
    /// tested as occluders, without the tree.
    #[allow(clippy::too_many_arguments)]
    pub fn light_visible_packet<L: Lane>(
        &self,
        scene: &Scene,
        p: &RayPacket<L>,
        t_min: f32,
        light: &Light,
        lanes: u32,
        among: Option<Candidates<'_>>,
        stats: &mut TraversalStats,
    ) -> u32 {
        let lanes = lanes & p.active;
        let mut tris = LazyTriangles::new(p, scene);
        let (t_light, id_light, reach) = match &light.shape {
            LightShape::Point { center, radius } => {
                // `nearest_hit` of a point light, lane-wise.
                let (t, hits) = p.sphere(*center, *radius, t_min, f32::INFINITY, lanes);
                (t, L::splat(f32::from_bits(light.first_id)), hits)
            }
            LightShape::Quads(qs) => p.quad_light_hits(qs, light.first_id, t_min, lanes, &mut tris),
            LightShape::Triangles(_) => {
                let mut t_light = [0.0; MAX_WIDTH];
                let mut id_light = [0.0; MAX_WIDTH];
                let mut reach = 0;
                for k in set_lanes(lanes) {
                    if let Some((t, id)) = light.nearest_hit(&p.ray(k), t_min) {
                        t_light[k] = t;
                        id_light[k] = f32::from_bits(id);
                        reach |= 1 << k;
                    }
                }
                (
                    L::from_fn(|k| t_light[k]),
                    L::from_fn(|k| id_light[k]),
                    reach,
                )
            }
        };
        if reach == 0 {
            return 0;
        }
        let own = ShadowLanes {
            t_min,
            t_light,
            id_light,
            object: light.object,
            kind: Some(light_kind(&light.shape)),
        };
        let occluded = match among {
            Some(c) => occluded_among(scene, p, own, reach, c, &mut tris, stats),
            None => self.occluded_lanes(scene, p, own, reach, &mut tris, stats),
        };
        reach & !occluded
    }

    /// `occluded_packet` with the light as lanes.
    #[inline(always)]
    fn occluded_lanes<L: Lane>(
        &self,
        scene: &Scene,
        p: &RayPacket<L>,
        light: ShadowLanes<L>,
        lanes: u32,
        tris: &mut LazyTriangles<'_, L>,
        stats: &mut TraversalStats,
    ) -> u32 {
        let mut remaining = lanes & p.active;
        let mut occluded = 0u32;
        // Lanes not tested get t_max = −∞ (no box or primitive test passes).
        let t_min = light.t_min;
        let mut t_max = in_play(remaining, light.t_light);
        for (k, &kind) in PrimKind::ALL.iter().enumerate() {
            let range = self.linear[k].clone();
            if !range.is_empty() && remaining != 0 {
                stats.prims += (range.len() * remaining.count_ones() as usize) as u64;
                let found = occluders(scene, p, light, kind, range, remaining, t_max, tris);
                occluded |= found;
                remaining &= !found;
            }
        }
        let Some(root) = self.root else {
            return occluded;
        };
        if remaining == 0 {
            return occluded;
        }
        t_max = in_play(remaining, t_max);
        // The tree's box first (`Bvh4::tree_box_first`): most `bunny` shadow packets
        // (75%) pass beside it, and one box costs a quarter of the root's four. A ray
        // outside a box is outside every box within it (the slab test is monotone in
        // the planes), so the lanes that miss it leave the traversal.
        let entered = self.enters_tree(p, t_min, t_max) & remaining;
        if entered == 0 {
            return occluded;
        }
        let fallback = RayPacket::<L>::fallback();
        let mut slots = MaybeUninit::<[_; STACK4]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        stack.push((root, entered));
        while remaining != 0 {
            let Some((code, lanes)) = stack.pop() else {
                break;
            };
            let lanes = lanes & remaining;
            if lanes == 0 {
                continue;
            }
            let mut found = 0;
            if code & LEAF != 0 {
                let (kind, start, count) = decode_leaf(code);
                stats.prims += (count * lanes.count_ones()) as u64;
                let range = start as usize..(start + count) as usize;
                found = occluders_of(scene, p, light, kind, range, lanes, t_max, tris);
            } else {
                stats.nodes += 1;
                stats.packet_nodes += 1;
                stats.packet_lanes += lanes.count_ones() as u64;
                let node = &self.nodes[code as usize];
                let t_max_l = in_play(lanes, t_max);
                // As in `closest_hit_packet`: the four boxes, then one mask.
                let t_min_l = L::splat(t_min);
                let tested: [u32; 4] =
                    std::array::from_fn(|c| p.test_child(node, c, t_min_l, t_max_l).1 & lanes);
                let entered = tested
                    .iter()
                    .enumerate()
                    .fold(0u32, |m, (c, &b)| m | ((b != 0) as u32) << c);
                for c in set_lanes(entered) {
                    let child = node.child[c];
                    debug_assert!(child != EMPTY);
                    let bits = tested[c] & !found;
                    if bits == 0 {
                        continue;
                    }
                    if bits.count_ones() <= fallback {
                        for k in set_lanes(bits) {
                            let ray = p.ray(k);
                            let (mut consts, bray) = RayConsts::with_box4(&ray);
                            let query = light.lane(k);
                            if self.occluded_from(scene, child, &mut consts, &bray, query, stats) {
                                found |= 1 << k;
                            }
                        }
                        continue;
                    }
                    // A leaf child is tested here, without a push and pop.
                    if child & LEAF != 0 {
                        let (kind, start, count) = decode_leaf(child);
                        stats.prims += (count * bits.count_ones()) as u64;
                        let range = start as usize..(start + count) as usize;
                        found |= occluders_of(scene, p, light, kind, range, bits, t_max_l, tris);
                        continue;
                    }
                    stack.push((child, bits));
                }
            }
            if found != 0 {
                occluded |= found;
                remaining &= !found;
                t_max = in_play(remaining, t_max);
            }
        }
        occluded
    }
}
