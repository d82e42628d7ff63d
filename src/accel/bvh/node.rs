//! A BVH node of `W` children (`Node<W>`: `Node4` for packets, `Node8` for single rays in
//! `node8`), structure-of-arrays, and one ray's box test of its children: the leaf codes,
//! the slab test with its margins, `BoxRay`, and the nearest-first order of the children
//! a ray enters.

use crate::accel::build::MAX_POOL_FOR_BVH;
use crate::accel::stack::TraversalStack;
use crate::geometry::spawn::gamma;
use crate::geometry::{Aabb, PrimKind, Ray};
use crate::lanes::Lane;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};

/// A node width of the scalar traversal (`Bvh::traverse`): `Node4`, which packets trace
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

const START_BITS: u32 = MAX_POOL_FOR_BVH.trailing_zeros();

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

    pub(super) fn set_child(&mut self, i: usize, b: Aabb, code: u32) {
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
    pub(super) fn from_inv(ray: &Ray, inv: Vec3) -> Self {
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
