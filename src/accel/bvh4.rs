//! The BVH: node layout (`Node<W>`), the collapse of the binary build to 4-wide nodes and
//! to 8-wide ones (`node8`), and the scalar traversals: closest hit and the any-hit
//! occlusion test of shadow rays over the 8-wide nodes, and the lanes a packet finishes
//! alone over the 4-wide ones, which packets traverse too (`packet`).
//!
//! A node holds the boxes of its children structure-of-arrays (`min_x[W]`, …), so one
//! ray tests them all in one pass. Leaves hold up to four primitives of one kind,
//! contiguous in that kind's pool (the pools are reordered after the build), and both
//! widths share them.

use super::build::{self, BuildTree, NodeId, PrimRef};
use super::stack::{TraversalStack, STACK4, STACK8};
use super::{ShadowQuery, TraversalStats};
use crate::geometry::quad::{OneQuad, QuadLanes};
use crate::geometry::spawn::gamma;
use crate::geometry::sphere::{sphere_distance, sphere_intersect_with, SpherePool, SphereRay};
use crate::geometry::triangle::{Columns, WatertightRay};
use crate::geometry::{beats, Aabb, Hit, PrimKind, Ray};
use crate::lanes::{set_lanes, Lane, Mask, V3};
use crate::scene::{Light, LightShape, Scene};
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::mem::MaybeUninit;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use wide::f32x8;

mod node8;
pub use node8::BoxRay8;

/// A node width of the scalar traversal (`Bvh4::traverse`): `Node4`, which packets trace
/// too, and `Node8`, for single rays.
pub(crate) trait Wide: Copy {
    const WIDTH: usize;
    /// The per-ray constants of the box test.
    type Ray;
    /// The children's entry distances.
    type Entries: Copy + AsRef<[f32]>;
    /// Entry distances of the children and the mask of those overlapping
    /// `[t_min, t_max]` (`BoxRay::test`).
    fn test(&self, ray: &Self::Ray, t_min: f32, t_max: f32) -> (Self::Entries, u32);
    /// Child `i`'s code (`i` < `WIDTH`).
    fn child(&self, i: usize) -> u32;
    /// Of the children in `mask` (at least one), push all but the nearest by their
    /// entries `e` (positive) onto `stack`, farthest first, with their entries, and
    /// return the nearest's slot (`push_keys` on `nearest_first`'s keys).
    fn push_farther<const C: usize>(
        &self,
        mask: u32,
        e: &Self::Entries,
        stack: &mut TraversalStack<'_, (u32, f32), C>,
    ) -> usize;
}

impl Wide for Node4 {
    const WIDTH: usize = 4;
    type Ray = BoxRay;
    type Entries = [f32; 4];

    #[inline(always)]
    fn test(&self, ray: &BoxRay, t_min: f32, t_max: f32) -> ([f32; 4], u32) {
        let (e, mask) = ray.test(self, t_min, t_max);
        (e.to_array(), mask)
    }

    #[inline(always)]
    fn child(&self, i: usize) -> u32 {
        self.child[i & 3]
    }

    #[inline(always)]
    fn push_farther<const C: usize>(
        &self,
        mask: u32,
        e: &[f32; 4],
        stack: &mut TraversalStack<'_, (u32, f32), C>,
    ) -> usize {
        push_keys(nearest_first(mask, e), mask, &self.child, e, stack)
    }
}

/// A node of `W` children: their boxes structure-of-arrays, then their codes. `Node4`
/// (128 bytes, two cache lines) serves packets; `Node8` (256 bytes) single rays and
/// camera packets' frustums.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node<const W: usize> {
    pub min_x: [f32; W],
    pub min_y: [f32; W],
    pub min_z: [f32; W],
    pub max_x: [f32; W],
    pub max_y: [f32; W],
    pub max_z: [f32; W],
    /// Inner node index (into the nodes of this width), a leaf code (`LEAF` bit set) or
    /// `EMPTY`.
    pub child: [u32; W],
    pub _pad: [u32; W],
}

pub type Node4 = Node<4>;
pub type Node8 = Node<8>;

const _: () = assert!(std::mem::size_of::<Node4>() == 128);
const _: () = assert!(std::mem::size_of::<Node8>() == 256);

// SAFETY: `repr(C)`, eight arrays of `W` 4-byte plain numbers (any bit pattern valid)
// and nothing else; for W = 4 and 8 their 32·W bytes are a multiple of the 64-byte
// alignment, so there is no padding (both sizes asserted above).
unsafe impl Zeroable for Node4 {}
unsafe impl Pod for Node4 {}
unsafe impl Zeroable for Node8 {}
unsafe impl Pod for Node8 {}

/// Child codes: bit 31 marks a leaf; bits 29–30 its kind, 27–28 its count − 1, 0–26 the
/// first primitive in the kind's pool.
pub const LEAF: u32 = 1 << 31;
pub const EMPTY: u32 = u32::MAX;
const START_BITS: u32 = 27;
pub const MAX_POOL_FOR_BVH: usize = 1 << START_BITS;

#[inline]
pub fn encode_leaf(kind: PrimKind, start: u32, count: u32) -> u32 {
    debug_assert!((1..=4).contains(&count) && start < (1 << START_BITS));
    LEAF | (kind.slot() as u32) << 29 | (count - 1) << START_BITS | start
}

#[inline]
pub fn decode_leaf(code: u32) -> (PrimKind, u32, u32) {
    (
        PrimKind::of_slot((code >> 29) & 3),
        code & ((1 << START_BITS) - 1),
        ((code >> START_BITS) & 3) + 1,
    )
}

impl<const W: usize> Node<W> {
    pub const EMPTY: Self = Node {
        min_x: [f32::INFINITY; W],
        min_y: [f32::INFINITY; W],
        min_z: [f32::INFINITY; W],
        max_x: [f32::NEG_INFINITY; W],
        max_y: [f32::NEG_INFINITY; W],
        max_z: [f32::NEG_INFINITY; W],
        child: [EMPTY; W],
        _pad: [0; W],
    };

    /// Row `r` of the node seen as `[[f32; W]; 8]` (min x, y, z, max x, y, z: one plane
    /// of each child per row), as the box tests pick the near and far planes by row.
    /// `& 7`: the rows are 0..6, and the mask lets the compiler drop the bounds check.
    #[inline(always)]
    pub(crate) fn row(&self, r: usize) -> [f32; W]
    where
        Self: Pod,
        [[f32; W]; 8]: Pod,
    {
        let rows: &[[f32; W]; 8] = bytemuck::cast_ref(self);
        rows[r & 7]
    }

    /// The box of child `i` as (min, max) corners.
    #[inline(always)]
    pub fn child_box(&self, i: usize) -> ([f32; 3], [f32; 3]) {
        (
            [self.min_x[i], self.min_y[i], self.min_z[i]],
            [self.max_x[i], self.max_y[i], self.max_z[i]],
        )
    }

    fn set_child(&mut self, i: usize, b: Aabb, code: u32) {
        self.min_x[i] = b.min.x;
        self.min_y[i] = b.min.y;
        self.min_z[i] = b.min.z;
        self.max_x[i] = b.max.x;
        self.max_y[i] = b.max.y;
        self.max_z[i] = b.max.z;
        self.child[i] = code;
    }
}

/// Traversal box tests shrink the entry and widen the exit distance by this relative
/// margin, so a primitive whose computed t lies a few ulps outside its box (its test
/// rounds differently from the box's) is never culled: the BVH then returns exactly what
/// the brute-force scan returns.
pub(crate) const NEAR_SCALE: f32 = 1.0 - 2.0 * gamma(8);
pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(8);

/// The slab test over lanes: entry distance, and whether `[entry, exit]` overlaps
/// `[t_min, t_max]`. The scalar traversal runs it on one ray and four child boxes, the
/// packet traversal on a packet of rays and one box. `near` and `far` are the planes the
/// ray's direction signs pick; `inv_near` and `inv_far` the reciprocal direction with
/// the margins. `Lane::max`/`min` drop a NaN in their first operand.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn slab<L: Lane>(
    near: [L; 3],
    far: [L; 3],
    origin: [L; 3],
    inv_near: [L; 3],
    inv_far: [L; 3],
    t_min: L,
    t_max: L,
) -> (L, L::Mask) {
    let near_x = (near[0] - origin[0]) * inv_near[0];
    let near_y = (near[1] - origin[1]) * inv_near[1];
    let near_z = (near[2] - origin[2]) * inv_near[2];
    let far_x = (far[0] - origin[0]) * inv_far[0];
    let far_y = (far[1] - origin[1]) * inv_far[1];
    let far_z = (far[2] - origin[2]) * inv_far[2];
    let enter = near_z.max(near_y).max(near_x.max(t_min));
    let exit = far_z.min(far_y).min(far_x.min(t_max));
    (enter, enter.le(exit))
}

/// Primitive pools with at most this many primitives of a kind stay out of the tree and
/// are tested in a plain loop beside the traversal: big analytic primitives (the bunny
/// scene's ground sphere) would otherwise cover the whole tree.
pub const LINEAR_LIMIT: usize = 16;

/// A primitive of a kind in the tree whose box has at least this fraction of the surface
/// area of the scene's bounds (a ground sphere of radius 1000 under small spheres, a
/// ground quad under a mesh) is tested beside the tree, like a kind of at most
/// `LINEAR_LIMIT`: in the tree its box would hold most others, so most rays entering the
/// tree would test it anyway, and the nodes above it would be as large as the scene. At
/// most `LINEAR_LIMIT` of them, and never all of the tree's primitives.
pub const HUGE_FRACTION: f32 = 0.5;

#[derive(Clone, Debug)]
pub struct Bvh4 {
    pub nodes: Vec<Node4>,
    /// Code of the root (an inner node index or a leaf), `None` when no kind is in the tree.
    pub root: Option<u32>,
    /// The same tree collapsed to 8-wide nodes (the same leaves), which single rays
    /// trace (`closest_hit`, `occluded`), and its root's code.
    pub nodes8: Vec<Node8>,
    pub root8: Option<u32>,
    /// The primitives of each kind tested in a loop beside the tree (index: sphere,
    /// quad, triangle): the whole pool of a kind of at most `LINEAR_LIMIT`, the pool's
    /// end for the huge primitives of a kind in the tree (`HUGE_FRACTION`), else empty.
    pub linear: [Range<usize>; 3],
    pub depth: u32,
    pub leaves: u32,
    /// The spheres beside the tree (`linear[0]`), eight an `f32x8` (the last group
    /// padded with radius-0 spheres, masked off): one load per component instead of four
    /// gathered through `load4`'s short-tail path on every ray (the bunny scene's three
    /// spheres cost ~130 instructions a ray that way, callgrind), and the five of
    /// `spheres` and `mixed` in one test, not two `Vec4` ones (the same lane-wise
    /// operations, so the same bits).
    linear_spheres: Vec<SphereLanes>,
    /// The quads beside the tree (`linear[1]`), eight a group: one ray tests a group
    /// with one 8-lane edge test (the `quads` scene's six quads in one pass; one at a
    /// time they were 37% of its scalar render, callgrind).
    linear_quads: Vec<QuadLanes>,
    /// What besides spheres lies beside the tree, so a single ray takes the cheapest
    /// path: one value it reads instead of two ranges.
    beside: Beside,
    /// The quad beside the tree when it is the only quad or triangle there
    /// (`Beside::OneQuad`; else unread).
    one_quad: OneQuad,
    /// The box of the tree's primitives (`Aabb::EMPTY` without a tree): what the
    /// camera's cones test before the tree (`cull::CullTargets`).
    pub tree_box: Aabb,
    /// Packets test `tree_box` before the root's four children: the tree is small in
    /// the scene (`TREE_BOX_FIRST`), so most packets pass beside it.
    pub tree_box_first: bool,
}

/// A tree whose box has less than this fraction of the surface area of the scene's
/// bounds is entered by packets through one test of its box (`Bvh4::tree_box_first`):
/// 75% of `bunny`'s shadow packets miss its mesh's box (render instructions −4.3%),
/// while in `cornell` the tree holds the room and every ray is inside it (+1.0%).
pub const TREE_BOX_FIRST: f32 = 0.5;

/// The quads and triangles beside the tree, as the scalar traversals test them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Beside {
    /// None (`linear[1]` and `linear[2]` empty).
    Nothing,
    /// One quad and no triangle (`spheres`' backdrop): `Bvh4`'s `one_quad`, tested
    /// inline, without the pools' loops.
    OneQuad,
    /// Anything else: the quads eight at a time (`QuadLanes`), the triangles four.
    Pools,
}

/// Eight spheres, structure-of-arrays in `f32x8` lanes.
#[derive(Clone, Copy, Debug)]
struct SphereLanes {
    center: V3<f32x8>,
    radius: f32x8,
    /// The lanes holding a sphere (the last group's padding is off).
    valid: u32,
}

/// Spheres a `SphereLanes` holds.
const SPHERE_GROUP: usize = 8;

/// The rows of `Node4` (as `[[f32; 4]; 8]`: min x, y, z, max x, y, z) holding each
/// axis' near and far planes, for a direction whose axis a is negative when
/// `negative[a]` is 1: min for a positive direction, max for a negative one.
#[inline(always)]
pub(crate) const fn plane_rows(negative: [usize; 3]) -> ([usize; 3], [usize; 3]) {
    let mut rows = ([0; 3], [0; 3]);
    let mut a = 0;
    while a < 3 {
        rows.0[a] = a + 3 * negative[a];
        rows.1[a] = a + 3 - 3 * negative[a];
        a += 1;
    }
    rows
}

/// Per-ray constants of the box test.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    pub(crate) origin: [Vec4; 3],
    /// 1/d scaled by `NEAR_SCALE` and `FAR_SCALE`: the margins cost no multiply per node.
    pub(crate) inv_near: [Vec4; 3],
    pub(crate) inv_far: [Vec4; 3],
    /// Per axis, the row of `Node4` (seen as `[[f32; 4]; 8]`: min x, y, z, max x, y, z)
    /// holding the near and the far planes: min for a positive direction, max for a
    /// negative one (the sign bit, so −0 picks max like −x does). A row index instead of
    /// a branch per axis and node.
    pub(crate) near_row: [usize; 3],
    pub(crate) far_row: [usize; 3],
}

impl BoxRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = Vec3::new(1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z);
        Self::from_inv(ray, inv)
    }

    /// From the reciprocal direction `inv` = 1/d (computed by the caller).
    #[inline(always)]
    fn from_inv(ray: &Ray, inv: Vec3) -> Self {
        let near = inv * NEAR_SCALE;
        let far = inv * FAR_SCALE;
        let (near_row, far_row) = plane_rows([
            inv.x.is_sign_negative() as usize,
            inv.y.is_sign_negative() as usize,
            inv.z.is_sign_negative() as usize,
        ]);
        Self {
            origin: [
                Vec4::splat(ray.origin.x),
                Vec4::splat(ray.origin.y),
                Vec4::splat(ray.origin.z),
            ],
            inv_near: [
                Vec4::splat(near.x),
                Vec4::splat(near.y),
                Vec4::splat(near.z),
            ],
            inv_far: [Vec4::splat(far.x), Vec4::splat(far.y), Vec4::splat(far.z)],
            near_row,
            far_row,
        }
    }

    /// Entry distances of the four children and the mask of those overlapping
    /// `[t_min, t_max]`. The near plane of each axis is chosen by the ray's sign, so an
    /// empty slot (min = +∞, max = −∞) enters at +∞ and never hits. A NaN (0·∞, a ray in
    /// a slab plane) is dropped by `Vec4::max`/`min`, which return their second operand
    /// when the first is NaN: that axis leaves the interval unconstrained.
    #[inline(always)]
    fn test(&self, n: &Node4, t_min: f32, t_max: f32) -> (Vec4, u32) {
        let row = |r: usize| Vec4::from(n.row(r));
        let (enter, hit) = slab(
            self.near_row.map(row),
            self.far_row.map(row),
            self.origin,
            self.inv_near,
            self.inv_far,
            Vec4::splat(t_min),
            Vec4::splat(t_max),
        );
        (enter, hit.bitmask())
    }
}

/// The per-ray constants of a scalar traversal: `PrimRay`'s and `BoxRay`'s values (the
/// same IEEE quotients, so the same bits), with the triangle test's computed at the first
/// triangle leaf: most camera rays of `bunny` miss the mesh's box, and the axis choice,
/// its two divisions and the pool pointers they select cost ~100 instructions a ray
/// (callgrind). 1/dx, 1/dy, 1/dz and 1/(d·d) are one vector divide. Shadow rays
/// (`Bvh4::light_visible`) share them between the light's own hit and the occluders.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayConsts<'r> {
    /// Borrowed, not copied: a copy was stored in pieces and read back whole, a failed
    /// store-to-load forward on every ray (perf: 11% of the `bunny` camera-ray time).
    ray: &'r Ray,
    sphere: SphereRay,
    triangle: Option<WatertightRay>,
}

impl<'r> RayConsts<'r> {
    /// The constants, and the box test's for the 4-wide tree (which the lanes a packet
    /// finishes alone traverse).
    #[inline(always)]
    pub(crate) fn with_box4(ray: &'r Ray) -> (RayConsts<'r>, BoxRay) {
        let (consts, q) = Self::with_reciprocals(ray);
        (consts, BoxRay::from_inv(ray, q.truncate()))
    }

    /// The constants and (1/dx, 1/dy, 1/dz, 1/(d·d)).
    #[inline(always)]
    fn with_reciprocals(ray: &'r Ray) -> (RayConsts<'r>, Vec4) {
        let d = ray.dir;
        let a = d.dot(d);
        let q = Vec4::ONE / Vec4::new(d.x, d.y, d.z, a);
        let sphere = SphereRay {
            origin: ray.origin,
            dir: d,
            a,
            inv_a: q.w,
        };
        let consts = RayConsts {
            ray,
            sphere,
            triangle: None,
        };
        (consts, q)
    }

    #[inline(always)]
    fn triangle(&mut self) -> &WatertightRay {
        let ray = self.ray;
        self.triangle.get_or_insert_with(|| watertight_ray(ray))
    }
}

/// `WatertightRay::new` with its three divisions in one vector divide.
#[inline(never)]
fn watertight_ray(ray: &Ray) -> WatertightRay {
    let axes @ [kx, ky, kz] = WatertightRay::axes(ray.dir);
    let d = ray.dir.to_array();
    let o = ray.origin.to_array();
    let q = Vec4::new(d[kx], d[ky], 1.0, 1.0) / Vec4::new(d[kz], d[kz], d[kz], 1.0);
    WatertightRay {
        axes,
        origin: [o[kx], o[ky], o[kz]],
        sx: q.x,
        sy: q.y,
        sz: q.z,
    }
}

/// The closest hit so far of one scalar traversal, in plain fields (no `Option<Hit>`
/// moved per candidate). No hit yet is `(t, id) = (+∞, u32::MAX)`, which every candidate
/// beats (a candidate has t ≤ `t_max` and an id below `u32::MAX`: ids count primitives).
#[derive(Clone, Copy, Debug)]
struct Closest {
    t_max: f32,
    t: f32,
    id: u32,
    kind: PrimKind,
    index: u32,
}

impl Closest {
    #[inline(always)]
    fn new(t_max: f32, best: &Option<Hit>) -> Self {
        match best {
            Some(h) => Closest {
                t_max,
                t: h.t,
                id: h.id,
                kind: h.kind,
                index: h.index,
            },
            None => Closest {
                t_max,
                t: f32::INFINITY,
                id: u32::MAX,
                kind: PrimKind::Triangle,
                index: 0,
            },
        }
    }

    /// `keep_closest` then `t_max = t`, as `linear::intersect_range` does for a hit.
    #[inline(always)]
    fn offer(&mut self, t: f32, id: u32, kind: PrimKind, index: usize) {
        if beats((t, id), (self.t, self.id)) {
            self.t = t;
            self.id = id;
            self.kind = kind;
            self.index = index as u32;
        }
        self.t_max = t;
    }

    /// `offer` for each lane of `mask` whose `t` is still within `t_max`: primitive
    /// `first + k` of `kind`, its id from `ids` (lanes in pool order, as the scan offers).
    #[inline(always)]
    fn offer_lanes(&mut self, t: &[f32], mut mask: u32, first: usize, ids: &[u32], kind: PrimKind) {
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if t[k] <= self.t_max {
                let i = first + k;
                self.offer(t[k], ids[i], kind, i);
            }
        }
    }

    #[inline(always)]
    fn hit(&self, scene: &Scene) -> Option<Hit> {
        if self.id == u32::MAX {
            return None;
        }
        let i = self.index as usize;
        let object = match self.kind {
            PrimKind::Sphere => scene.spheres.object[i],
            PrimKind::Quad => scene.quads.object[i],
            PrimKind::Triangle => scene.triangles.object[i],
        };
        Some(Hit {
            t: self.t,
            id: self.id,
            kind: self.kind,
            index: self.index,
            object,
        })
    }

    /// Triangles `start..start + n` (n ≤ 4) in one `intersect4`, hits in pool order.
    #[inline(always)]
    fn triangles4(
        &mut self,
        scene: &Scene,
        start: usize,
        n: usize,
        ray: &WatertightRay,
        cols: &Columns,
        t_min: f32,
    ) {
        let tri = &scene.triangles;
        let (t, mask) = tri.intersect4_in(cols, start, n, ray, t_min, self.t_max);
        self.offer_lanes(&t, mask, start, &tri.id, PrimKind::Triangle);
    }

    /// `linear::intersect_range` on this state: spheres and triangles four at a time,
    /// quads one at a time. The triangle test's constants are made only for quads and
    /// triangles: a sphere leaf needs none of them (two divisions and the axis choice, 11%
    /// of the instructions of a scene of 486 spheres in the tree, `trace_probe`).
    #[inline(never)]
    fn range(
        &mut self,
        scene: &Scene,
        kind: PrimKind,
        range: Range<usize>,
        consts: &mut RayConsts<'_>,
        t_min: f32,
    ) {
        let mut start = range.start;
        match kind {
            PrimKind::Sphere => {
                let s = &scene.spheres;
                while start < range.end {
                    let n = (range.end - start).min(4);
                    let (t, mask) = s.intersect4(start, n, &consts.sphere, t_min, self.t_max);
                    self.offer_lanes(&t, mask, start, &s.id, kind);
                    start += n;
                }
            }
            PrimKind::Quad => {
                let (q, ray) = (&scene.quads, consts.ray);
                for i in range {
                    let w = || *consts.triangle();
                    if let Some(t) = q.intersect_lazy(i, ray, w, t_min, self.t_max) {
                        self.offer(t, q.id[i], kind, i);
                    }
                }
            }
            PrimKind::Triangle => {
                let tri = *consts.triangle();
                let cols = scene.triangles.columns(tri.axes);
                while start < range.end {
                    let n = (range.end - start).min(4);
                    self.triangles4(scene, start, n, &tri, &cols, t_min);
                    start += n;
                }
            }
        }
    }
}

impl Bvh4 {
    /// Build over the scene's pools (kinds above `LINEAR_LIMIT`), reordering those pools
    /// so every leaf is a contiguous range.
    pub fn build(scene: &mut Scene) -> Bvh4 {
        let counts = [
            scene.spheres.len(),
            scene.quads.len(),
            scene.triangles.len(),
        ];
        let in_tree = counts.map(|n| n > LINEAR_LIMIT && n <= MAX_POOL_FOR_BVH);
        let mut refs = Vec::with_capacity(
            counts
                .iter()
                .zip(in_tree)
                .filter(|(_, t)| *t)
                .map(|(n, _)| n)
                .sum(),
        );
        // In parallel (25 ms for 1.27M triangles on two threads, mostly page faults): an
        // indexed `par_extend` keeps the order, so the references are the same for any
        // thread count.
        let s = &*scene;
        // Counted on the way (a separate pass cost 5% of the 1.27M-triangle build).
        let huge_area = HUGE_FRACTION * s.bounds.surface_area();
        let huge_count = AtomicUsize::new(0);
        for k in (0..3).filter(|&k| in_tree[k]) {
            refs.par_extend((0..counts[k]).into_par_iter().map(|i| {
                let kind = PrimKind::ALL[k];
                let bounds = match kind {
                    PrimKind::Sphere => s.spheres.bounds(i),
                    PrimKind::Quad => s.quads.bounds(i),
                    PrimKind::Triangle => s.triangles.bounds(i),
                };
                if bounds.surface_area() >= huge_area {
                    huge_count.fetch_add(1, Ordering::Relaxed);
                }
                PrimRef::new(bounds, kind, i as u32)
            }));
        }
        let huge_count = huge_count.into_inner();
        let huge = if huge_count > 0 && huge_count <= LINEAR_LIMIT && huge_count < refs.len() {
            let (huge, rest) = refs
                .iter()
                .partition(|r| r.bounds().surface_area() >= huge_area);
            refs = rest;
            huge
        } else {
            Vec::new()
        };
        let tree = build::build(&mut refs);

        // Reorder the pools in reference order, and note each reference's new position
        // (with one kind in the tree that is its place in the reference array).
        let mut order: [Vec<u32>; 3] =
            [0, 1, 2].map(|k| Vec::with_capacity(counts[k] * in_tree[k] as usize));
        let several_kinds = in_tree.iter().filter(|&&t| t).count() > 1;
        let mut position = Vec::with_capacity(if several_kinds { refs.len() } else { 0 });
        for r in &refs {
            let k = r.kind().slot();
            if several_kinds {
                position.push(order[k].len() as u32);
            }
            order[k].push(r.index());
        }
        let position = several_kinds.then_some(&position[..]);
        // The huge primitives go to the end of their pools, after every leaf's range.
        let linear = [0, 1, 2].map(|k| {
            if !in_tree[k] {
                return 0..counts[k];
            }
            let start = order[k].len();
            order[k].extend(
                huge.iter()
                    .filter(|r| r.kind().slot() == k)
                    .map(|r| r.index()),
            );
            start..counts[k]
        });

        let mut bvh = Bvh4 {
            nodes: Vec::new(),
            root: None,
            nodes8: Vec::new(),
            root8: None,
            linear,
            depth: 0,
            leaves: 0,
            linear_spheres: Vec::new(),
            linear_quads: Vec::new(),
            beside: Beside::Nothing,
            one_quad: OneQuad::default(),
            tree_box: tree
                .as_ref()
                .map_or(Aabb::EMPTY, |t| t.node(BuildTree::ROOT).bounds),
            tree_box_first: false,
        };
        bvh.tree_box_first = !bvh.tree_box.is_empty()
            && bvh.tree_box.surface_area() < TREE_BOX_FIRST * scene.bounds.surface_area();
        // The collapse reads only the tree and `position`, so it runs beside the pool
        // reordering: on the 1.27M-triangle bunny each takes about 60 ms (mostly page
        // faults on their new arrays), a sixth of the whole build.
        rayon::join(
            || {
                if in_tree[0] {
                    scene.spheres.permute(&order[0]);
                }
                if in_tree[1] {
                    scene.quads.permute(&order[1]);
                }
                if in_tree[2] {
                    scene.triangles.permute(&order[2]);
                }
            },
            || {
                if let Some(tree) = &tree {
                    // About one node per 3.5 references (the subdivided bunny: 1 271 808
                    // references, 360 189 nodes).
                    bvh.nodes.reserve(refs.len() / 3);
                    bvh.root = Some(bvh.collapse(tree, BuildTree::ROOT, position, 1));
                    // About 0.7 of the 4-wide node count (the closeup bunny: 622 and 450).
                    bvh.nodes8.reserve(bvh.nodes.len() * 3 / 4);
                    let mut shape = Shape::default();
                    let root = collapse(
                        &mut bvh.nodes8,
                        tree,
                        BuildTree::ROOT,
                        position,
                        1,
                        &mut shape,
                    );
                    bvh.root8 = Some(root);
                    // The traversal stacks' capacity (`stack::capacity`) rests on it: a
                    // leaf at depth d has d − 1 inner nodes above it.
                    let depth = bvh.depth.max(shape.depth) as usize;
                    assert!(depth <= build::MAX_DEPTH + 1, "BVH depth {depth}");
                }
            },
        );
        bvh.linear_spheres = pack_spheres(&scene.spheres, bvh.linear[0].clone());
        bvh.linear_quads = QuadLanes::pack(&scene.quads, bvh.linear[1].clone());
        let (quads, triangles) = (bvh.linear[1].clone(), bvh.linear[2].clone());
        (bvh.beside, bvh.one_quad) = match (quads.len(), triangles.len()) {
            (0, 0) => (Beside::Nothing, OneQuad::default()),
            (1, 0) => (Beside::OneQuad, OneQuad::new(&scene.quads, quads.start)),
            _ => (Beside::Pools, OneQuad::default()),
        };
        bvh
    }

    /// Turn the binary subtree at `node` into 4-wide nodes (`collapse`), counting the
    /// leaves and the depth.
    fn collapse(
        &mut self,
        tree: &BuildTree,
        node: NodeId,
        position: Option<&[u32]>,
        depth: u32,
    ) -> u32 {
        let mut shape = Shape::default();
        let root = collapse(&mut self.nodes, tree, node, position, depth, &mut shape);
        self.leaves += shape.leaves;
        self.depth = self.depth.max(shape.depth);
        root
    }

    /// Closest hit in `[t_min, t_max]` by the `(t, id)` rule.
    #[inline]
    pub fn closest_hit(
        &self,
        scene: &Scene,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<Hit> {
        let (mut consts, q) = RayConsts::with_reciprocals(ray);
        let mut c = Closest::new(t_max, &None);
        // The tree first, the spheres beside it after: their test (a square root and a
        // division) then does not delay the root's box test, which would wait for the
        // `t_max` it produces; the ground sphere never pruned a node (same node counts on
        // `bunny` and `bunny-closeup`), and 2.5% fewer instructions a closeup ray.
        if let Some(root) = self.root8 {
            // The box constants only for a tree (`mixed`, `spheres` and `quads` have
            // none: 1.3% of `mixed`'s scalar render made them for nothing, callgrind).
            let bray = BoxRay8::from_inv(ray, q);
            traverse::<_, STACK8>(
                &self.nodes8,
                scene,
                root,
                &mut consts,
                &bray,
                t_min,
                &mut c,
                stats,
            );
        }
        self.linear_kinds(scene, &mut consts, t_min, &mut c, stats);
        c.hit(scene)
    }

    /// The kinds beside the tree: the spheres pre-packed eight an `f32x8` (the bunny scene's
    /// three in one pass), quads and triangles out of line.
    #[inline(always)]
    fn linear_kinds(
        &self,
        scene: &Scene,
        consts: &mut RayConsts<'_>,
        t_min: f32,
        c: &mut Closest,
        stats: &mut TraversalStats,
    ) {
        let spheres = &self.linear[0];
        let n = spheres.len();
        if n > 0 {
            stats.prims += n as u64;
            // `SpherePool::intersect4` on the pre-packed lanes (`pack_spheres` packs
            // exactly `linear[0]`).
            debug_assert_eq!(self.linear_spheres.len(), n.div_ceil(SPHERE_GROUP));
            let s = &scene.spheres;
            let r = &consts.sphere;
            for (g, lanes) in self.linear_spheres.iter().enumerate() {
                let (t, hit) = sphere_distance(
                    lanes.center,
                    lanes.radius,
                    V3::splat(r.origin),
                    V3::splat(r.dir),
                    f32x8::splat(r.a),
                    f32x8::splat(r.inv_a),
                    f32x8::splat(t_min),
                    f32x8::splat(c.t_max),
                );
                // A larger `t_max` than the scan's for the group's later spheres gives
                // the same hits: a lane beyond the current `t_max` is not offered.
                let first = SPHERE_GROUP * g;
                let mask = hit.bits() & lanes.valid;
                c.offer_lanes(
                    &t.to_array(),
                    mask,
                    spheres.start + first,
                    &s.id,
                    PrimKind::Sphere,
                );
            }
        }
        match self.beside {
            Beside::OneQuad => {
                let q = &self.one_quad;
                stats.prims += 1;
                let ray = consts.ray;
                let w = || *consts.triangle();
                if let Some(t) = q.intersect_lazy(ray, w, t_min, c.t_max) {
                    c.offer(t, q.id, PrimKind::Quad, q.index);
                }
            }
            Beside::Nothing => {}
            Beside::Pools => self.linear_quads_triangles(scene, consts, t_min, c, stats),
        }
    }

    #[inline(never)]
    fn linear_quads_triangles(
        &self,
        scene: &Scene,
        consts: &mut RayConsts<'_>,
        t_min: f32,
        c: &mut Closest,
        stats: &mut TraversalStats,
    ) {
        if !self.linear[1].is_empty() {
            stats.prims += self.linear[1].len() as u64;
            let (q, ray) = (&scene.quads, consts.ray);
            for group in &self.linear_quads {
                let w = || *consts.triangle();
                if group.is_single() {
                    let i = group.indices().start;
                    if let Some(t) = q.intersect_lazy(i, ray, w, t_min, c.t_max) {
                        c.offer(t, q.id[i], PrimKind::Quad, i);
                    }
                    continue;
                }
                let (t, mask) = group.intersect(q, ray, w, t_min, c.t_max);
                c.offer_lanes(&t, mask, group.indices().start, &q.id, PrimKind::Quad);
            }
        }
        let range = self.linear[2].clone();
        if !range.is_empty() {
            stats.prims += range.len() as u64;
            c.range(scene, PrimKind::Triangle, range, consts, t_min);
        }
    }

    /// Closest hit in the subtree `root` (a node or leaf code), improving on `best` and
    /// shrinking `t_max`. The packet traversal finishes lanes with it.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn closest_hit_from(
        &self,
        scene: &Scene,
        root: u32,
        consts: &mut RayConsts<'_>,
        bray: &BoxRay,
        t_min: f32,
        t_max: &mut f32,
        best: &mut Option<Hit>,
        stats: &mut TraversalStats,
    ) {
        let mut c = Closest::new(*t_max, best);
        traverse::<_, STACK4>(&self.nodes, scene, root, consts, bray, t_min, &mut c, stats);
        *t_max = c.t_max;
        if let Some(h) = c.hit(scene) {
            *best = Some(h);
        }
    }

    /// Does a primitive occlude the light by `query`'s rule (`ShadowQuery`)? Stops at
    /// the first occluder.
    pub fn occluded(
        &self,
        scene: &Scene,
        ray: &Ray,
        query: ShadowQuery,
        stats: &mut TraversalStats,
    ) -> bool {
        let (mut consts, q) = RayConsts::with_reciprocals(ray);
        self.occluded_consts(scene, &mut consts, q, query, stats)
    }

    /// The original program's shadow test (`Accel::light_visible`): the light's own
    /// nearest hit, then any occluder before it. The ray's constants are made once for
    /// both; the watertight ones only for a quad or triangle that needs them (a point
    /// light, the spheres and a quad whose plane the ray does not meet before the light
    /// need none: `mixed` and `spheres` shadow rays test no triangle or quad edges at
    /// all).
    pub fn light_visible(
        &self,
        scene: &Scene,
        ray: &Ray,
        t_min: f32,
        light: &Light,
        stats: &mut TraversalStats,
    ) -> bool {
        let (mut consts, q) = RayConsts::with_reciprocals(ray);
        let own = match light.shape {
            LightShape::Point { center, radius } => {
                sphere_intersect_with(center, radius, &consts.sphere, t_min, f32::INFINITY)
                    .map(|t| (t, light.first_id))
            }
            _ => light.nearest_hit_watertight(ray, consts.triangle(), t_min),
        };
        let Some((t_light, id_light)) = own else {
            return false;
        };
        let query = ShadowQuery {
            t_min,
            t_light,
            id_light,
            object: light.object,
        };
        !self.occluded_consts(scene, &mut consts, q, query, stats)
    }

    /// `occluded` with the ray's constants and reciprocals `q` (`with_reciprocals`)
    /// made: beside the tree, then through the 8-wide tree (fewer nodes a ray than the
    /// 4-wide one, as for closest hits), whose box constants are made only then.
    #[inline(always)]
    fn occluded_consts(
        &self,
        scene: &Scene,
        consts: &mut RayConsts<'_>,
        q: Vec4,
        query: ShadowQuery,
        stats: &mut TraversalStats,
    ) -> bool {
        if self.occluded_beside(scene, consts, query, stats) {
            return true;
        }
        let Some(root) = self.root8 else { return false };
        let bray = BoxRay8::from_inv(consts.ray, q);
        occluded_in::<_, STACK8>(&self.nodes8, scene, root, consts, &bray, query, stats)
    }

    /// `occluded` among the primitives beside the tree: the spheres and the quads eight
    /// at a time (the packed groups of `linear_kinds`), the triangles by the scan.
    #[inline(always)]
    fn occluded_beside(
        &self,
        scene: &Scene,
        consts: &mut RayConsts<'_>,
        query: ShadowQuery,
        stats: &mut TraversalStats,
    ) -> bool {
        let ShadowQuery { t_min, t_light, .. } = query;
        let spheres = &self.linear[0];
        if !spheres.is_empty() {
            stats.prims += spheres.len() as u64;
            let (s, r) = (&scene.spheres, &consts.sphere);
            for (g, lanes) in self.linear_spheres.iter().enumerate() {
                let (t, hit) = sphere_distance(
                    lanes.center,
                    lanes.radius,
                    V3::splat(r.origin),
                    V3::splat(r.dir),
                    f32x8::splat(r.a),
                    f32x8::splat(r.inv_a),
                    f32x8::splat(t_min),
                    f32x8::splat(t_light),
                );
                let first = spheres.start + SPHERE_GROUP * g;
                let mask = hit.bits() & lanes.valid;
                let t = t.to_array();
                let occludes =
                    |k: usize| query.occludes(t[k], s.id[first + k], s.object[first + k]);
                if set_lanes(mask).any(occludes) {
                    return true;
                }
            }
        }
        match self.beside {
            Beside::Nothing => return false,
            Beside::OneQuad => {
                let q = &self.one_quad;
                stats.prims += 1;
                let ray = consts.ray;
                let w = || *consts.triangle();
                return q.object != query.object
                    && q.intersect_lazy(ray, w, t_min, t_light)
                        .is_some_and(|t| query.beats_light(t, q.id));
            }
            Beside::Pools => {}
        }
        if !self.linear[1].is_empty() {
            stats.prims += self.linear[1].len() as u64;
            let (q, ray) = (&scene.quads, consts.ray);
            for group in &self.linear_quads {
                let first = group.indices().start;
                let w = || *consts.triangle();
                if group.is_single() {
                    let hit = q.intersect_lazy(first, ray, w, t_min, t_light);
                    if hit.is_some_and(|t| query.occludes(t, q.id[first], q.object[first])) {
                        return true;
                    }
                    continue;
                }
                let (t, mask) = group.intersect(q, ray, w, t_min, t_light);
                let occludes =
                    |k: usize| query.occludes(t[k], q.id[first + k], q.object[first + k]);
                if set_lanes(mask).any(occludes) {
                    return true;
                }
            }
        }
        let range = self.linear[2].clone();
        if !range.is_empty() {
            stats.prims += range.len() as u64;
            let mut cols = None;
            if occludes_range(scene, PrimKind::Triangle, range, consts, &mut cols, query) {
                return true;
            }
        }
        false
    }

    /// `occluded` in the subtree `root` (of the 4-wide tree) only: the packets' lanes
    /// that finish alone. Out of line: inlined into the shading loop with the packet
    /// traversal, it cost the 8-wide renders up to 1.4% more instructions (callgrind).
    #[inline(never)]
    pub(crate) fn occluded_from(
        &self,
        scene: &Scene,
        root: u32,
        consts: &mut RayConsts<'_>,
        bray: &BoxRay,
        query: ShadowQuery,
        stats: &mut TraversalStats,
    ) -> bool {
        occluded_in::<_, STACK4>(&self.nodes, scene, root, consts, bray, query, stats)
    }
}

/// The scalar any-hit traversal of `tree` from `root` (`ShadowQuery`). Of the children
/// a node's box test hits, the leaves are tested there and the inner nodes pushed (no
/// order: the first occluder ends the search), so a leaf costs no push and pop.
#[inline(always)]
fn occluded_in<N: Wide, const C: usize>(
    tree: &[N],
    scene: &Scene,
    root: u32,
    consts: &mut RayConsts<'_>,
    bray: &N::Ray,
    query: ShadowQuery,
    stats: &mut TraversalStats,
) -> bool {
    // The triangle columns in this ray's axis order, at the first triangle leaf.
    let mut cols = None;
    if root & LEAF != 0 {
        return leaf_occludes(scene, root, consts, &mut cols, query, stats);
    }
    let mut slots = MaybeUninit::<[u32; C]>::uninit();
    let mut stack = TraversalStack::new(&mut slots);
    let mut code = root;
    loop {
        stats.nodes += 1;
        let node = &tree[code as usize];
        let (_, mut mask) = node.test(bray, query.t_min, query.t_light);
        while mask != 0 {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let child = node.child(i);
            if child & LEAF == 0 {
                stack.push(child);
            } else if leaf_occludes(scene, child, consts, &mut cols, query, stats) {
                return true;
            }
        }
        let Some(next) = stack.pop() else {
            return false;
        };
        code = next;
    }
}

/// `occludes_range` on the leaf `code`'s primitives.
#[inline(always)]
fn leaf_occludes<'s>(
    scene: &'s Scene,
    code: u32,
    consts: &mut RayConsts<'_>,
    cols: &mut Option<Columns<'s>>,
    query: ShadowQuery,
    stats: &mut TraversalStats,
) -> bool {
    let (kind, start, count) = decode_leaf(code);
    stats.prims += count as u64;
    let range = start as usize..(start + count) as usize;
    occludes_range(scene, kind, range, consts, cols, query)
}

/// Does a primitive in `range` occlude by `query`'s rule? Spheres and quads one at a
/// time (a quad's plane first, `QuadPool::intersect_lazy`), triangles four at a time
/// through the columns `cols` of the ray's axis order (looked up at the ray's first
/// triangle leaf).
#[inline(always)]
fn occludes_range<'s>(
    scene: &'s Scene,
    kind: PrimKind,
    range: Range<usize>,
    consts: &mut RayConsts<'_>,
    cols: &mut Option<Columns<'s>>,
    query: ShadowQuery,
) -> bool {
    let ShadowQuery {
        t_min,
        t_light,
        object,
        ..
    } = query;
    match kind {
        // Plain loops: as `Iterator::any` the quads' loop was left out of line, a call
        // per leaf (callgrind, the scalar `cornell` render).
        PrimKind::Sphere => {
            let s = &scene.spheres;
            for i in range {
                if s.object[i] != object
                    && s.intersect(i, &consts.sphere, t_min, t_light)
                        .is_some_and(|t| query.beats_light(t, s.id[i]))
                {
                    return true;
                }
            }
            false
        }
        PrimKind::Quad => {
            let (q, ray) = (&scene.quads, consts.ray);
            for i in range {
                if q.object[i] != object
                    && q.intersect_lazy(i, ray, || *consts.triangle(), t_min, t_light)
                        .is_some_and(|t| query.beats_light(t, q.id[i]))
                {
                    return true;
                }
            }
            false
        }
        PrimKind::Triangle => {
            let tri = &scene.triangles;
            let w = *consts.triangle();
            let cols = cols.get_or_insert_with(|| tri.columns(w.axes));
            let mut start = range.start;
            while start < range.end {
                let n = (range.end - start).min(4);
                let (t, mut mask) = tri.intersect4_in(cols, start, n, &w, t_min, t_light);
                while mask != 0 {
                    let k = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let i = start + k;
                    if query.occludes(t[k], tri.id[i], tri.object[i]) {
                        return true;
                    }
                }
                start += n;
            }
            false
        }
    }
}

/// The scalar closest-hit traversal. The current node stays in a register: of the
/// children a node's box test hits, the nearest is visited next and only the others
/// are pushed (farthest first), so a node with one hit child costs no push or pop.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn traverse<N: Wide, const C: usize>(
    tree: &[N],
    scene: &Scene,
    root: u32,
    consts: &mut RayConsts<'_>,
    bray: &N::Ray,
    t_min: f32,
    c: &mut Closest,
    stats: &mut TraversalStats,
) {
    // As a root popped from the stack at entry t_min would be.
    if t_min > c.t_max {
        return;
    }
    let mut slots = MaybeUninit::<[(u32, f32); C]>::uninit();
    let mut stack = TraversalStack::new(&mut slots);
    let (mut nodes, mut prims) = (0u64, 0u64);
    let mut code = root;
    // The triangle columns in this ray's axis order, at the first triangle leaf.
    let mut cols: Option<Columns> = None;
    'visit: loop {
        if code & LEAF == 0 {
            nodes += 1;
            let node = &tree[code as usize];
            let (entry, mask) = node.test(bray, t_min, c.t_max);
            if mask != 0 {
                let i = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                if rest == 0 {
                    code = node.child(i);
                    continue 'visit;
                }
                let e = entry.as_ref();
                // Slots below `WIDTH` (a power of two): the mask lets the bounds checks go.
                let (i, j) = (
                    i & (N::WIDTH - 1),
                    rest.trailing_zeros() as usize & (N::WIDTH - 1),
                );
                if rest & (rest - 1) == 0 {
                    // Two: push the farther. Which is nearer is a coin toss for the
                    // branch predictor, so it is a select, not a branch.
                    let (ci, cj) = (node.child(i), node.child(j));
                    let swap = e[j] < e[i];
                    let (near, far) = if swap { (cj, ci) } else { (ci, cj) };
                    let far_e = if swap { e[i] } else { e[j] };
                    stack.push((far, far_e));
                    code = near;
                    continue 'visit;
                }
                // Three or more: sort nearest first (branch-free: `nearest_first`,
                // `nearest_first8`), push all but the nearest (farthest first).
                code = node.child(node.push_farther(mask, &entry, &mut stack));
                continue 'visit;
            }
        } else {
            let (kind, start, count) = decode_leaf(code);
            prims += count as u64;
            if kind == PrimKind::Triangle {
                let tri = *consts.triangle();
                let cols = cols.get_or_insert_with(|| scene.triangles.columns(tri.axes));
                c.triangles4(scene, start as usize, count as usize, &tri, cols, t_min);
            } else {
                let range = start as usize..(start + count) as usize;
                c.range(scene, kind, range, consts, t_min);
            }
        }
        // Pop the next node still nearer than the best hit.
        while let Some((next, enter)) = stack.pop() {
            if enter <= c.t_max {
                code = next;
                continue 'visit;
            }
        }
        break;
    }
    stats.nodes += nodes;
    stats.prims += prims;
}

/// Leaves and depth of a collapsed tree.
#[derive(Clone, Copy, Debug, Default)]
struct Shape {
    leaves: u32,
    depth: u32,
}

/// Turn the binary subtree at `node` into `W`-wide nodes appended to `nodes`
/// (pre-order, so the layout is deterministic) and return its code. `position`: each
/// reference's index in its kind's reordered pool (`None`: the reference's own index).
fn collapse<const W: usize>(
    nodes: &mut Vec<Node<W>>,
    tree: &BuildTree,
    node: NodeId,
    position: Option<&[u32]>,
    depth: u32,
    shape: &mut Shape,
) -> u32 {
    let Some(children) = tree.children(node) else {
        let leaf = tree.node(node);
        shape.leaves += 1;
        shape.depth = shape.depth.max(depth);
        let first = leaf.first_or_right;
        let start = position.map_or(first, |p| p[first as usize]);
        return encode_leaf(leaf.kind, start, leaf.count as u32);
    };
    // Open the largest inner child until there are `W` (of equal areas the last, as
    // `Iterator::max_by` picks). An array, not a `Vec` per node.
    let mut kids = [BuildTree::ROOT; W];
    kids[..2].copy_from_slice(&children);
    let mut len = 2;
    while len < W {
        let mut widest: Option<(usize, f32)> = None;
        for (i, &k) in kids[..len].iter().enumerate() {
            if tree.children(k).is_some() {
                let area = tree.node(k).bounds.surface_area();
                if widest.is_none_or(|(_, w)| area.total_cmp(&w).is_ge()) {
                    widest = Some((i, area));
                }
            }
        }
        let Some((i, _)) = widest else { break };
        let Some([l, r]) = tree.children(kids[i]) else {
            break;
        };
        kids.copy_within(i + 1..len, i + 2);
        kids[i] = l;
        kids[i + 1] = r;
        len += 1;
    }
    let index = nodes.len();
    nodes.push(Node::EMPTY);
    let mut n = Node::EMPTY;
    for (slot, &kid) in kids[..len].iter().enumerate() {
        let code = collapse(nodes, tree, kid, position, depth + 1, shape);
        n.set_child(slot, tree.node(kid).bounds, code);
    }
    nodes[index] = n;
    index as u32
}

/// `Wide::push_farther` of a `W`-wide node with children `child`, given the keys of
/// the children in `mask` nearest first (the slot in the low bits, `key & (W − 1)`;
/// `nearest_first`, `node8::nearest_first8`).
#[inline(always)]
pub(crate) fn push_keys<const W: usize, const C: usize>(
    keys: [u32; W],
    mask: u32,
    child: &[u32; W],
    e: &[f32; W],
    stack: &mut TraversalStack<'_, (u32, f32), C>,
) -> usize {
    let k = mask.count_ones() as usize;
    for &key in keys[1..k].iter().rev() {
        let s = key as usize & (W - 1);
        stack.push((child[s], e[s]));
    }
    keys[0] as usize & (W - 1)
}

/// The slots of `mask` nearest first by their entry distances `e` (positive, so their
/// bits order as they do), as keys: the distance's bits with the slot in the low two
/// bits (`key & 3`), a slot not in `mask` `u32::MAX` (last). The dropped bits only
/// reorder near-equal entries.
#[inline(always)]
fn nearest_first(mask: u32, e: &[f32; 4]) -> [u32; 4] {
    sort4([0, 1, 2, 3].map(|s| {
        if mask >> s & 1 != 0 {
            e[s].to_bits() & !3 | s as u32
        } else {
            u32::MAX
        }
    }))
}

/// Four keys in ascending order: a sorting network of five compare-exchanges, each a
/// min and a max (conditional moves, no branches).
#[inline(always)]
fn sort4(mut k: [u32; 4]) -> [u32; 4] {
    let mut exchange = |a: usize, b: usize| {
        let (x, y) = (k[a], k[b]);
        k[a] = x.min(y);
        k[b] = x.max(y);
    };
    exchange(0, 1);
    exchange(2, 3);
    exchange(0, 2);
    exchange(1, 3);
    exchange(1, 2);
    k
}

/// The spheres `range` eight an `f32x8`, the last group padded with radius-0 spheres (which
/// `linear_kinds` masks off).
fn pack_spheres(sp: &SpherePool, range: Range<usize>) -> Vec<SphereLanes> {
    range
        .clone()
        .step_by(SPHERE_GROUP)
        .map(|start| {
            let lane = |v: &[f32], k: usize| {
                let i = start + k;
                if i < range.end {
                    v[i]
                } else {
                    0.0
                }
            };
            let v8 = |v: &[f32]| f32x8::new(std::array::from_fn(|k| lane(v, k)));
            SphereLanes {
                center: V3::new(v8(&sp.cx), v8(&sp.cy), v8(&sp.cz)),
                radius: v8(&sp.radius),
                valid: (1u32 << (range.end - start).min(SPHERE_GROUP)) - 1,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_codes_round_trip() {
        for (kind, start, count) in [
            (PrimKind::Sphere, 0, 1),
            (PrimKind::Quad, 12345, 4),
            (PrimKind::Triangle, (1 << START_BITS) - 1, 3),
        ] {
            let code = encode_leaf(kind, start, count);
            assert_ne!(code, EMPTY);
            assert_eq!(decode_leaf(code), (kind, start, count));
        }
    }

    #[test]
    fn vec4_max_min_drop_a_nan_in_the_first_operand() {
        // The box test relies on this (SSE maxps/minps semantics).
        let nan = Vec4::new(f32::NAN, 1.0, f32::NAN, 5.0);
        assert_eq!(nan.max(Vec4::splat(2.0)), Vec4::new(2.0, 2.0, 2.0, 5.0));
        assert_eq!(nan.min(Vec4::splat(2.0)), Vec4::new(2.0, 1.0, 2.0, 2.0));
    }

    #[test]
    fn sort4_sorts_every_order() {
        // Every arrangement of four keys drawn from {0, 1, 2, u32::MAX} (with repeats).
        let values = [0, 1, 2, u32::MAX];
        for code in 0..256u32 {
            let keys = [0, 1, 2, 3].map(|i| values[(code >> (2 * i) & 3) as usize]);
            let mut expected = keys;
            expected.sort_unstable();
            assert_eq!(sort4(keys), expected, "{keys:?}");
        }
    }

    #[test]
    fn empty_slots_never_hit() {
        let n = Node4::EMPTY;
        for dir in [
            Vec3::X,
            -Vec3::X,
            Vec3::new(0.0, -0.0, 1.0),
            Vec3::new(0.3, -0.5, 0.1).normalize(),
        ] {
            let r = BoxRay::new(&Ray::new(Vec3::ZERO, dir));
            assert_eq!(r.test(&n, 0.0, f32::INFINITY).1, 0);
        }
    }

    #[test]
    fn flat_and_axis_parallel_boxes() {
        let mut n = Node4::EMPTY;
        // A wall at x = 555 and a box starting exactly at the ray origin's plane y = 0.
        n.set_child(
            0,
            Aabb::new(Vec3::new(555.0, 0.0, 0.0), Vec3::new(555.0, 555.0, 555.0)),
            0,
        );
        n.set_child(
            1,
            Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 10.0, 10.0)),
            1,
        );
        let r = BoxRay::new(&Ray::new(Vec3::new(-1.0, 0.0, 5.0), Vec3::X));
        assert_eq!(r.test(&n, 0.0, f32::INFINITY).1, 0b11);
        let r = BoxRay::new(&Ray::new(
            Vec3::new(-1.0, 0.0, 5.0),
            Vec3::new(1.0, -0.0, 0.0),
        ));
        assert_eq!(r.test(&n, 0.0, f32::INFINITY).1, 0b11);
    }
}
