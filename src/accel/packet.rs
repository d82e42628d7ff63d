//! A packet of 4 or 8 rays, one per lane (`RayPacket`), and its tests of a box and of
//! each primitive kind in one pass of the lane kernels (`lanes`), with an active mask
//! for divergence (ARCHITECTURE.md, "Packets"). The BVH's packet traversals
//! (`bvh::packet_closest`, `bvh::packet_shadow`) are made of them.
//!
//! Every lane gets exactly the scalar answer: the primitive kernels are the scalar ones
//! run over lanes (same operations, same bits), the box tests are conservative for each
//! lane (the same margins as the scalar test), and the closest hit is the smallest
//! `(t, id)` whatever the visiting order. A subtree entered by few lanes
//! (`RayPacket::fallback`) is finished one ray at a time by the scalar traversal.
//!
//! One file of about 750 lines, all code (its tests are `tests/packets.rs`): the packet
//! and every lane-wise test the traversals run on it, with the watertight lanes that
//! the quad and triangle tests share (`LazyTriangles`) and the traversal context
//! (`PacketQuery`), which only exist for those tests.

use super::bvh::{plane_rows, slab, Node4, FAR_SCALE, NEAR_SCALE};
pub use super::bvh::{PacketHits, ShadowLanes};
use crate::accel::cull::Cull;
use crate::accel::{Context, TraversalStats};
use crate::geometry::quad::{
    inside_quad, outer_edge_is_zero, plane_distance, quad_edge_functions, Quad,
};
use crate::geometry::sphere::sphere_distance;
use crate::geometry::triangle::{
    edge_functions, inside_edges, shear, watertight_distance, Columns, TrianglePool, WatertightRay,
};
use crate::geometry::{Aabb, PrimKind, Ray};
use crate::lanes::MAX_WIDTH;
use crate::lanes::{set_lanes, Lane, Mask, V3};
use crate::scene::Scene;
use glam::Vec3;

/// A packet of rays with the per-lane constants of the box and sphere tests, computed
/// lane-wise with the scalar constructors' operations (`BoxRay::new`, `SphereRay::new`),
/// so each lane holds the scalar values; `WatertightRay::new`'s are made at the
/// packet's first triangle or quad test (`triangle_lanes`).
#[derive(Clone, Debug)]
pub struct RayPacket<L: Lane> {
    /// Lanes holding a ray (bit i: lane i). Other lanes copy an active ray and are never
    /// reported.
    pub active: u32,
    pub(crate) origin: V3<L>,
    dir: V3<L>,
    pub(crate) inv_near: [L; 3],
    pub(crate) inv_far: [L; 3],
    /// Per axis: every lane's direction has this sign (then the box planes need no
    /// per-lane select).
    uniform_sign: [Option<bool>; 3],
    negative: [L::Mask; 3],
    sphere_a: L,
    sphere_inv_a: L,
    /// When every axis has a uniform sign: the rows of `Node4` (as `[[f32; 4]; 8]`)
    /// holding each axis' near and far planes, as `BoxRay` picks them, so a child's box
    /// test is six broadcast loads with no per-axis select.
    pub(crate) box_rows: Option<([usize; 3], [usize; 3])>,
    /// What the packet's rays may hit (`cull`): the closest-hit traversal skips the
    /// rest. `Cull::ALL` unless a caller knows better (`with_cull`).
    pub(crate) cull: Cull,
    /// The box test's constants (`inv_near`, `inv_far`, the signs, `box_rows`) are
    /// made. Without (`from_active_lanes_with`), no box may be tested.
    boxes: bool,
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
        Self::from_active_lanes_with(origin, dir, active, true)
    }

    /// `from_active_lanes`, with the box test's constants only if `boxes`: an
    /// accelerator with no tree and no shadow candidates tests no box (`Accel::
    /// packet_boxes`), and the constants are three divisions a packet.
    #[inline]
    pub fn from_active_lanes_with(origin: V3<L>, dir: V3<L>, active: u32, boxes: bool) -> Self {
        debug_assert!(active != 0 && active < (1 << L::WIDTH));
        if active == (1 << L::WIDTH) - 1 {
            return Self::from_lanes_with(origin, dir, active, boxes);
        }
        let first = active.trailing_zeros() as usize;
        let m = L::Mask::from_bits(active);
        let fill = |v: V3<L>| {
            let copy = V3::new(
                v.x.broadcast(first),
                v.y.broadcast(first),
                v.z.broadcast(first),
            );
            V3::select(m, v, copy)
        };
        Self::from_lanes_with(fill(origin), fill(dir), active, boxes)
    }

    /// Whether the box test's constants are made (`from_active_lanes_with`).
    #[inline(always)]
    pub(crate) fn has_boxes(&self) -> bool {
        self.boxes
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
        Self::from_lanes_with(origin, dir, active, true)
    }

    #[inline(always)]
    fn from_lanes_with(origin: V3<L>, dir: V3<L>, active: u32, boxes: bool) -> Self {
        let one = L::splat(1.0);
        // SphereRay::new, lane-wise.
        let sphere_a = dir.dot(dir);
        if !boxes {
            let nan = [L::splat(f32::NAN); 3];
            return Self {
                active,
                origin,
                dir,
                inv_near: nan,
                inv_far: nan,
                uniform_sign: [None; 3],
                box_rows: None,
                negative: [L::Mask::from_bits(0); 3],
                sphere_a,
                sphere_inv_a: one / sphere_a,
                cull: Cull::ALL,
                boxes,
            };
        }
        let zero = L::splat(0.0);
        // BoxRay::new, lane-wise. (1/d is never −0, so `< 0` is its sign bit; a NaN
        // direction hits nothing whichever planes it picks.)
        let inv = [one / dir.x, one / dir.y, one / dir.z];
        let (near_scale, far_scale) = (L::splat(NEAR_SCALE), L::splat(FAR_SCALE));
        let negative = inv.map(|x| x.lt(zero));
        let bits = negative.map(|m| m.bits());
        // From the bits, not by matching `uniform_sign`: the match stored its three
        // bytes one by one and read them back as one word (a store-forwarding stall on
        // every packet at 16 lanes).
        let all = (1u32 << L::WIDTH) - 1;
        let box_rows = bits
            .iter()
            .all(|&b| b == 0 || b == all)
            .then(|| plane_rows(bits.map(|b| usize::from(b != 0))));
        Self {
            active,
            origin,
            dir,
            inv_near: inv.map(|x| x * near_scale),
            inv_far: inv.map(|x| x * far_scale),
            uniform_sign: bits.map(uniform::<L>),
            box_rows,
            negative,
            sphere_a,
            sphere_inv_a: one / sphere_a,
            cull: Cull::ALL,
            boxes,
        }
    }

    /// Make this packet's closest-hit traversal skip what `cull` rules out. The caller
    /// vouches that none of the packet's rays can hit what is ruled out (`cull::Cone`).
    /// (In place: a packet returned by value was copied whole, 30 instructions.)
    #[inline]
    pub fn set_cull(&mut self, cull: Cull) {
        self.cull = cull;
    }

    /// `WatertightRay::new`'s constants lane-wise. When every lane picks the same axes,
    /// with that order and the triangle columns in it; else with each lane's order as
    /// masks, through which the triangle and quad tests read the vertices. Made at a
    /// packet's first triangle or quad test (`LazyTriangles`): most `bunny` packets never
    /// reach one, and these are three divisions a packet. Inlined into
    /// `LazyTriangles::make`, and written into its slot `out`: returned, they were copied
    /// twice (`OnceCell`), a 450-byte memcpy each.
    ///
    /// The lanes whose axes differ take their constants out of line (`per_lane_lanes`).
    /// Inline, the two cases' `Order`s (axes in one, masks in the other, in the same
    /// bytes) were assembled on the stack and copied out by loads that straddled their
    /// stores: a store-forwarding stall on every packet at 16 lanes, whose masks are
    /// 2-byte `k` registers (half of `make`'s time there, `perf annotate`).
    #[inline(always)]
    fn triangle_lanes<'a>(&self, pool: &'a TrianglePool, out: &mut Option<TriangleLanes<'a, L>>) {
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
            *out = Some(TriangleLanes {
                // No columns without triangles (quad-only scenes): nine slices checked.
                order: Order::Uniform(axes, (!pool.is_empty()).then(|| pool.columns(axes))),
                origin: [o[kx], o[ky], o[kz]],
                sx: d[kx] / d[kz],
                sy: d[ky] / d[kz],
                sz: one / d[kz],
            });
        } else {
            self.per_lane_lanes([kz_x, kz_y], out);
        }
    }

    /// `triangle_lanes` where the lanes order the axes differently (`kz_x`, `kz_y`: the
    /// lanes whose kz is x, and y): each lane's order as masks.
    #[inline(never)]
    fn per_lane_lanes(&self, [kz_x, kz_y]: [L::Mask; 2], out: &mut Option<TriangleLanes<'_, L>>) {
        let one = L::splat(1.0);
        let (dir, origin) = (self.dir, self.origin);
        let d = [dir.x, dir.y, dir.z];
        let o = [origin.x, origin.y, origin.z];
        // `WatertightRay::axes` lane by lane: kz, then kx and ky the next two axes in
        // cyclic order, swapped where d[kz] < 0.
        let kz_z = !(kz_x | kz_y);
        let neg = pick(d, [kz_x, kz_y]).lt(L::splat(0.0));
        let pos = !neg;
        let picks = [
            [(kz_y & neg) | (kz_z & pos), (kz_x & pos) | (kz_z & neg)],
            [(kz_y & pos) | (kz_z & neg), (kz_x & neg) | (kz_z & pos)],
            [kz_x, kz_y],
        ];
        let (dx, dy, dz) = (pick(d, picks[0]), pick(d, picks[1]), pick(d, picks[2]));
        *out = Some(TriangleLanes {
            order: Order::PerLane(picks),
            origin: [pick(o, picks[0]), pick(o, picks[1]), pick(o, picks[2])],
            sx: dx / dz,
            sy: dy / dz,
            sz: one / dz,
        });
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
    pub(crate) fn quad_light_hits(
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

    /// `Light::nearest_hit` of a light made of the triangles `triangles` (ids from
    /// `first_id`), on the lanes of `lanes`: `quad_light_hits` for triangles, by the
    /// watertight test over lanes (`tris`: the packet's watertight lanes; the scalar
    /// test for the lanes whose edge function rounds to zero, or for every lane when the
    /// packet has no watertight lanes). The same bits as `nearest_hit` lane by lane.
    #[inline(always)]
    pub(crate) fn triangle_light_hits(
        &self,
        triangles: &[[Vec3; 3]],
        first_id: u32,
        t_min: f32,
        lanes: u32,
        tris: &mut LazyTriangles<'_, L>,
    ) -> (L, L, u32) {
        let (mut best_t, mut best_id) = (L::splat(0.0), L::splat(0.0));
        let mut found = 0u32;
        let window = [L::splat(t_min), L::splat(f32::INFINITY)];
        for (k, v) in triangles.iter().enumerate() {
            let (mut t, mut bits, redo) = match tris.get(PrimKind::Triangle) {
                Some(tri) => tri.triangle(&v.map(|p| p.to_array()), window, lanes),
                None => (L::splat(0.0), 0, lanes),
            };
            if redo != 0 {
                let (t_redo, hit) = self.redo_light_triangle(*v, t_min, redo);
                t = L::select(L::Mask::from_bits(hit), t_redo, t);
                bits |= hit;
            }
            // Ids grow with k, so a later triangle takes a lane only if it is nearer.
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

    /// The lanes `redo` of `triangle_light_hits`, one at a time with the scalar test.
    #[cold]
    #[inline(never)]
    fn redo_light_triangle(&self, v: [Vec3; 3], t_min: f32, redo: u32) -> (L, u32) {
        let mut out = [0.0; MAX_WIDTH];
        let mut bits = 0;
        for j in set_lanes(redo) {
            let w = WatertightRay::new(&self.ray(j));
            if let Some(tj) = w.intersect(v, t_min, f32::INFINITY) {
                out[j] = tj;
                bits |= 1 << j;
            }
        }
        (L::from_fn(|k| out[k]), bits)
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
    /// box test); every active lane for a packet made without the box constants.
    #[inline]
    pub fn hits_box(&self, b: &Aabb, t_min: f32, t_max: f32) -> u32 {
        if !self.boxes {
            // An early-out only: without the constants, every lane may hit.
            return self.active;
        }
        let (_, bits) = self.test_box(
            b.min.to_array(),
            b.max.to_array(),
            L::splat(t_min),
            L::splat(t_max),
        );
        bits
    }

    /// Subtrees entered by at most this many lanes are finished one ray at a time: a
    /// lone lane of 8 or 16 (none of 4). At 16, one lane rather than two: 1.09x → 1.20x
    /// 16-wide over 8-wide on `lights-over-bunny`, 1.17x → 1.27x on `triangle-light`,
    /// 0.94x → 1.00x on `big-mesh-close` (benches/corpus, one thread, Zen 4, medians). Measured (benches/probes/packet_probe.rs, callgrind, 400x225x2
    /// camera rays, 8 wide; instructions for bunny-closeup / bunny): finishing alone at
    /// ≤ 0 lanes 171.6M / 110.1M, ≤ 1: 178.1M / 112.9M, ≤ 2: 182.1M / 113.8M, ≤ 3 (the
    /// design's starting point): 188.9M / 115.7M, ≤ 5: 213.5M / 119.7M; whole renders,
    /// one thread, 5 alternating runs, medians ≤ 0 vs ≤ 3: closeup 1.07 vs 1.15 s, bunny
    /// 0.66 vs 0.70 s. Empty lanes cost less than leaving the packet; a lone lane is
    /// kept scalar (a few percent of instructions). Kept in the packet at 8 lanes
    /// (≤ 0), the corpus's renders (one thread, 11 alternated rounds, paired medians)
    /// take `sphere-field` 0.968x the time on the host's build (AVX-512) and 0.973x
    /// on an AVX2 one (2.0% more instructions), but `metal-bunny` 1.033x on AVX2 and
    /// the others 0.98–1.02x: not kept.
    #[inline]
    pub fn fallback() -> u32 {
        (L::WIDTH >= 8) as u32
    }

    /// `fallback` for shadow packets: none at 8 lanes, a lone lane at 16. A lone lane
    /// of 8 finished in the packet costs more instructions (`lights-over-bunny` +12%,
    /// callgrind) but less time, the packet's masks taking the place of the scalar
    /// traversal's branches: 8 wide, one thread, medians of 7 alternated rounds, Zen 4,
    /// `lights-over-bunny` 1.08x (AVX2 build 1.05x), `big-mesh-close` 1.08x (1.07x),
    /// `bunny` 1.01x (1.04x), `bunny-light` 0.98x, the built-ins' others and
    /// `triangle-light`, `box-light` within 1%. At 16 a lone lane still pays:
    /// `big-mesh-far` and `triangle-light` 0.94x without it.
    #[inline]
    pub fn shadow_fallback() -> u32 {
        (L::WIDTH >= 16) as u32
    }

    /// Entry distances and hit lanes of one box, for lanes with `t_max` (−∞ for lanes not
    /// tested).
    #[inline(always)]
    pub(crate) fn test_box(&self, lo: [f32; 3], hi: [f32; 3], t_min: L, t_max: L) -> (L, u32) {
        debug_assert!(
            self.boxes,
            "a box test of a packet made without box constants"
        );
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
    pub(crate) fn test_child(&self, node: &Node4, c: usize, t_min: L, t_max: L) -> (L, u32) {
        debug_assert!(
            self.boxes,
            "a box test of a packet made without box constants"
        );
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
    /// Triangle and quad lanes whose (outer) edge function rounds to zero are tested one
    /// lane at a time by the scalar test.
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
                    L::splat(s.radius(i)),
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
                Some(
                    tri @ TriangleLanes {
                        order: Order::PerLane(_),
                        ..
                    },
                ) => tri.pool_triangle(&scene.triangles, i, [t_min_l, t_max_l], lanes),
                // No columns (no triangle in the pool): never asked.
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
                    // Read in place (a copy of the vertex went through the stack).
                    let p = &q[m];
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

impl<L: Lane> TriangleLanes<'_, L> {
    /// `triangle` for triangle `i` of `pool`, for lanes that order the axes differently
    /// (each lane picks its own axes from the vertices). Out of line: inlined into the
    /// packet loops, where it is rare, it cost `bunny` 0.6% more render instructions and
    /// `big-mesh-far` 2.7% at 16 wide (callgrind) though neither takes it.
    #[inline(never)]
    fn pool_triangle(
        &self,
        pool: &TrianglePool,
        i: usize,
        window: [L; 2],
        lanes: u32,
    ) -> (L, u32, u32) {
        let v = |c: &[Vec<f32>; 3]| [c[0][i], c[1][i], c[2][i]];
        self.triangle(&[v(&pool.a), v(&pool.b), v(&pool.c)], window, lanes)
    }

    /// The watertight test of the triangle with vertices `v` on the lanes of `lanes`, in
    /// `[t_min, t_max]`: distances, the lanes that hit, and those whose edge function
    /// rounds to zero, which the scalar test must redo (not in the second mask). The
    /// operations of `test_prim`'s triangle test, the vertices read from `v`.
    #[inline(always)]
    fn triangle(&self, v: &[[f32; 3]; 3], [t_min, t_max]: [L; 2], lanes: u32) -> (L, u32, u32) {
        let vertex = |p: &[f32; 3]| {
            let p = match &self.order {
                Order::Uniform([kx, ky, kz], _) => [
                    L::splat(p[kx & 3]),
                    L::splat(p[ky & 3]),
                    L::splat(p[kz & 3]),
                ],
                Order::PerLane(m) => {
                    let p = p.map(L::splat);
                    [pick(p, m[0]), pick(p, m[1]), pick(p, m[2])]
                }
            };
            shear(p, self.origin, self.sx, self.sy)
        };
        let (a, b, c) = (vertex(&v[0]), vertex(&v[1]), vertex(&v[2]));
        let [u, w0, w1] = edge_functions(a, b, c);
        let zero = L::splat(0.0);
        let exact_zero = (u.eq(zero) | w0.eq(zero) | w1.eq(zero)).bits() & lanes;
        if (inside_edges([u, w0, w1]).bits() | exact_zero) & lanes == 0 {
            return (zero, 0, 0);
        }
        let (t, hit) = watertight_distance([u, w0, w1], a, b, c, self.sz, t_min, t_max);
        (t, hit.bits() & lanes & !exact_zero, exact_zero)
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
pub(crate) struct LazyTriangles<'a, L: Lane> {
    packet: &'a RayPacket<L>,
    tri: &'a TrianglePool,
    /// `None` until the first test asks (`make` always fills it).
    lanes: Option<TriangleLanes<'a, L>>,
}

impl<'a, L: Lane> LazyTriangles<'a, L> {
    #[inline(always)]
    fn new(packet: &'a RayPacket<L>, scene: &'a Scene) -> Self {
        Self {
            packet,
            tri: &scene.triangles,
            lanes: None,
        }
    }

    /// The watertight lanes for a triangle or quad test (`None` only for spheres).
    #[inline(always)]
    fn get(&mut self, kind: PrimKind) -> Option<&TriangleLanes<'a, L>> {
        if kind == PrimKind::Sphere {
            return None;
        }
        if self.lanes.is_none() {
            self.make();
        }
        self.lanes.as_ref()
    }

    #[inline(never)]
    fn make(&mut self) {
        self.packet.triangle_lanes(self.tri, &mut self.lanes);
    }
}

/// What a packet's traversal carries from the query down to its leaf loops: the scene,
/// the packet, its watertight lanes (`LazyTriangles`) and the counts of the work done
/// (`TraversalStats`), one argument where they were four.
pub(crate) struct PacketQuery<'a, 's, L: Lane> {
    pub(crate) scene: &'a Scene,
    pub(crate) p: &'a RayPacket<L>,
    pub(crate) tris: LazyTriangles<'a, L>,
    pub(crate) stats: &'s mut TraversalStats,
}

impl<'a, 's, L: Lane> PacketQuery<'a, 's, L> {
    #[inline(always)]
    pub(crate) fn new(cx: Context<'s>, p: &'a RayPacket<L>) -> Self
    where
        's: 'a,
    {
        let tris = LazyTriangles::new(p, cx.scene);
        PacketQuery {
            scene: cx.scene,
            p,
            tris,
            stats: cx.stats,
        }
    }

    /// The query's scene and statistics, for a lane finished alone (`RayQuery`).
    #[inline(always)]
    pub(crate) fn context(&mut self) -> Context<'_> {
        Context::new(self.scene, self.stats)
    }

    /// `RayPacket::test_prim` of primitive `i` of `kind` on the lanes of `lanes`.
    #[inline(always)]
    pub(crate) fn test_prim(
        &mut self,
        kind: PrimKind,
        i: usize,
        t_min: f32,
        t_max: L,
        lanes: u32,
    ) -> (L, u32) {
        self.p
            .test_prim(self.scene, kind, i, t_min, t_max, lanes, &mut self.tris)
    }
}

/// Pool data of a primitive for a `Hit`.
#[inline(always)]
pub(crate) fn ids(scene: &Scene, kind: PrimKind, i: usize) -> (u32, u32) {
    match kind {
        PrimKind::Sphere => (scene.spheres.id(i), scene.spheres.object(i)),
        PrimKind::Quad => (scene.quads.id[i], scene.quads.object[i]),
        PrimKind::Triangle => (scene.triangles.id[i], scene.triangles.object[i]),
    }
}

/// `t` in the lanes of `lanes`, −∞ in the others (no box or primitive test passes).
#[inline(always)]
pub(crate) fn in_play<L: Lane>(lanes: u32, t: L) -> L {
    L::select(L::Mask::from_bits(lanes), t, L::splat(f32::NEG_INFINITY))
}
