//! 8-wide nodes for single rays. The same binary tree as the 4-wide nodes, collapsed to
//! eight children a node (the same leaves): a ray descends about two thirds as many
//! levels, and a level's box test, one 8-lane AVX pass, costs about what a 4-wide one
//! does. A single ray's traversal is one chain of dependent steps (load a node, test its
//! boxes, pick the nearest child, load it), so fewer levels is a shorter chain. Camera
//! packets' frustums descend them too (`packet::Frustum`); other packets keep the 4-wide
//! nodes, whose lanes are the rays, not the children. `Node8` itself is `bvh::Node<8>`.

use super::node::{plane_rows, push_keys, slab, Node8, Wide, FAR_SCALE, NEAR_SCALE};
use crate::accel::stack::TraversalStack;
use crate::geometry::Ray;
use crate::lanes::Mask;
use glam::Vec4;
use wide::{f32x8, i32x8, CmpEq};

/// `BoxRay` in eight lanes: one ray against a node's eight children.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay8 {
    origin: [f32x8; 3],
    inv_near: [f32x8; 3],
    inv_far: [f32x8; 3],
    near_row: [usize; 3],
    far_row: [usize; 3],
}

impl BoxRay8 {
    /// From the reciprocal direction in `q.xyz` (1/d; `q.w` is ignored), as
    /// `BoxRay::from_inv`. The rows come from a table by the three sign bits (one
    /// `movmskps`): computing them took ~30 instructions a ray.
    #[inline(always)]
    pub(crate) fn from_inv(ray: &Ray, q: Vec4) -> Self {
        let inv = q.truncate();
        let near = inv * NEAR_SCALE;
        let far = inv * FAR_SCALE;
        let (near_row, far_row) = OCTANT_ROWS[(q.is_negative_bitmask() & 7) as usize];
        let o = ray.origin;
        Self {
            origin: [f32x8::splat(o.x), f32x8::splat(o.y), f32x8::splat(o.z)],
            inv_near: [
                f32x8::splat(near.x),
                f32x8::splat(near.y),
                f32x8::splat(near.z),
            ],
            inv_far: [
                f32x8::splat(far.x),
                f32x8::splat(far.y),
                f32x8::splat(far.z),
            ],
            near_row,
            far_row,
        }
    }
}

/// `plane_rows` for each octant (bit a set: axis a negative).
const OCTANT_ROWS: [([usize; 3], [usize; 3]); 8] = {
    let mut table = [([0; 3], [0; 3]); 8];
    let mut octant = 0;
    while octant < 8 {
        table[octant] = plane_rows([octant & 1, octant >> 1 & 1, octant >> 2 & 1]);
        octant += 1;
    }
    table
};

impl Wide for Node8 {
    const WIDTH: usize = 8;
    type Ray = BoxRay8;
    type Entries = [f32; 8];

    /// `BoxRay::test` on eight children.
    #[inline(always)]
    fn test(&self, ray: &BoxRay8, t_min: f32, t_max: f32) -> ([f32; 8], u32) {
        let row = |r: usize| f32x8::from(self.row(r));
        let (enter, hit) = slab(
            ray.near_row.map(row),
            ray.far_row.map(row),
            ray.origin,
            ray.inv_near,
            ray.inv_far,
            f32x8::splat(t_min),
            f32x8::splat(t_max),
        );
        (enter.to_array(), hit.bits())
    }

    #[inline(always)]
    fn child(&self, i: usize) -> u32 {
        self.child[i & 7]
    }

    #[inline(always)]
    fn push_farther<const C: usize>(
        &self,
        mask: u32,
        e: &[f32; 8],
        stack: &mut TraversalStack<'_, (u32, f32), C>,
    ) -> usize {
        push_keys(nearest_first8(mask, e), mask, &self.child, e, stack)
    }
}

/// `nearest_first` for eight slots: the entry's bits with the slot in the low three.
/// The keys are made in one 8-lane pass (the entries are still in a vector register),
/// then put in order by the scalar network: a network in vector registers took ~30
/// instructions instead of ~60, but each of its six layers is a permute, a min, a max
/// and a blend in sequence, and that latency sits on the path to the next node
/// (`trace_probe` closeup-mesh: 0.93x the rate).
#[inline(always)]
fn nearest_first8(mask: u32, e: &[f32; 8]) -> [u32; 8] {
    let bits: i32x8 = bytemuck::cast(f32x8::from(*e));
    let slot = i32x8::new([0, 1, 2, 3, 4, 5, 6, 7]);
    let lane_bit = i32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);
    // All ones (u32::MAX) where the slot is not in the mask.
    let miss = (i32x8::splat(mask as i32) & lane_bit).cmp_eq(i32x8::splat(0));
    let keys = (bits & i32x8::splat(!7)) | slot | miss;
    sort8(bytemuck::cast(keys))
}

/// Eight keys in ascending order: the 19 compare-exchanges of the optimal sorting
/// network for eight (Knuth, TAOCP vol. 3, 5.3.4), each a min and a max (conditional
/// moves, no branches). Written out: as a loop over a table of pairs the compiler kept
/// the loop, copying the table to the stack and checking both indices at every step.
#[inline(always)]
fn sort8(mut k: [u32; 8]) -> [u32; 8] {
    let mut exchange = |a: usize, b: usize| {
        let (x, y) = (k[a], k[b]);
        k[a] = x.min(y);
        k[b] = x.max(y);
    };
    exchange(0, 2);
    exchange(1, 3);
    exchange(4, 6);
    exchange(5, 7);
    exchange(0, 4);
    exchange(1, 5);
    exchange(2, 6);
    exchange(3, 7);
    exchange(0, 1);
    exchange(2, 3);
    exchange(4, 5);
    exchange(6, 7);
    exchange(2, 4);
    exchange(3, 5);
    exchange(1, 4);
    exchange(3, 6);
    exchange(1, 2);
    exchange(3, 4);
    exchange(5, 6);
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    /// By the 0-1 principle, a network that sorts every sequence of zeros and ones
    /// sorts every sequence.
    #[test]
    fn sort8_sorts_every_zero_one_sequence() {
        for bits in 0u32..256 {
            let k: [u32; 8] = std::array::from_fn(|i| bits >> i & 1);
            let mut want = k;
            want.sort();
            assert_eq!(sort8(k), want, "{bits:08b}");
        }
    }

    #[test]
    fn nearest_first8_orders_the_masked_slots() {
        let e = [5.0, 1.0, 7.0, 3.0, 2.0, 8.0, 0.5, 4.0];
        let keys = nearest_first8(0b1101_0110, &e);
        let slots: Vec<u32> = keys[..5].iter().map(|k| k & 7).collect();
        assert_eq!(slots, [6, 1, 4, 7, 2]);
        assert!(keys[5..].iter().all(|&k| k == u32::MAX));
    }
}
