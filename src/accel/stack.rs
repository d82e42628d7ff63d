//! The stack of every tree traversal: the nodes still to visit, with what each traversal
//! keeps beside them (an entry distance, a packet's lanes).

use super::build::{MAX_DEPTH, MAX_LEAF, MAX_POOL_FOR_BVH};
use std::mem::MaybeUninit;

/// The entries a traversal of `W`-wide nodes can hold at once: it pops a node and pushes
/// at most all its children, or visits one child next and pushes the others, so the
/// stack holds at most all but one child of each inner node on the path to the node
/// being visited, plus one: (W − 1) · `MAX_DEPTH` + 1. `Bvh::build` checks both
/// collapsed trees' depth against `MAX_DEPTH`, and `tests/bvh.rs` runs every traversal
/// on a tree as deep as the build allows. Two sizes, not the widest for all: a frame past
/// 4 KiB takes a stack probe at every call.
pub(crate) const fn capacity(w: usize) -> usize {
    (w - 1) * MAX_DEPTH + 1
}
/// The capacity for 4-wide nodes: up to 3 pushes a level.
pub(crate) const STACK4: usize = capacity(4);
/// The capacity for 8-wide nodes: up to 7 pushes a level.
pub(crate) const STACK8: usize = capacity(8);

// `MAX_DEPTH` counts 27 halvings, enough for fewer than 2^29 references (three kinds of
// at most `MAX_POOL_FOR_BVH`) to reach leaves of `MAX_LEAF`.
const _: () = assert!(3 * MAX_POOL_FOR_BVH <= MAX_LEAF << 27);

/// A stack of at most `C` entries (`STACK4` or `STACK8`) in `slots`, which the caller owns
/// and need not initialise: clearing 2 KiB per ray cost ~20% of the camera-ray rate on
/// `bunny` (perf, benches/bvh.rs). The slots are borrowed, not owned, so the length stays in a
/// register: in one struct with the array, every push and pop loaded and stored it.
/// A push checks its bound (a compare and a branch never taken; without it the packet
/// traversal's code came out 0.6% longer, `packet_probe`), so a pop needs none.
pub(crate) struct TraversalStack<'s, T: Copy, const C: usize> {
    slots: &'s mut MaybeUninit<[T; C]>,
    len: usize,
}

impl<'s, T: Copy, const C: usize> TraversalStack<'s, T, C> {
    #[inline(always)]
    pub fn new(slots: &'s mut MaybeUninit<[T; C]>) -> Self {
        TraversalStack { slots, len: 0 }
    }

    #[inline(always)]
    pub fn push(&mut self, entry: T) {
        assert!(self.len < C);
        // SAFETY: `len` < `C`, so the slot is inside the array.
        unsafe {
            self.slots
                .as_mut_ptr()
                .cast::<T>()
                .add(self.len)
                .write(entry)
        };
        self.len += 1;
    }

    #[inline(always)]
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: slot `len` < `C` (pushes keep the length within it) is inside
        // the array, and it was written when the length passed it.
        Some(unsafe { self.slots.as_ptr().cast::<T>().add(self.len).read() })
    }
}
