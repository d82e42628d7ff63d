//! Binned SAH build of a binary BVH over primitive references (any kind).
//!
//! - 16 bins per axis, all three axes; a split costs Σ area·⌈count/4⌉ (`blocks`).
//! - Leaves hold at most `MAX_LEAF` primitives, all of one kind; a node of at most
//!   `MAX_LEAF` references of one kind is a leaf (one block costs less than a node
//!   visit plus any split's blocks).
//! - Deterministic: every split depends only on the references of its node, partitions
//!   are in place with fixed rules, and the two halves of a large node are built in
//!   parallel with `rayon::join` on disjoint slices, so the tree is the same for any
//!   thread count. The parallel bounds and binning passes of large nodes combine their
//!   chunks with min, max and integer sums, which are exact in any order.
//!
//! Speed. `cargo bench --bench bvh -- build` (criterion medians, three alternating runs on
//! a shared 2-core machine): the bunny (4 968 triangles, one thread) builds in 1.5–1.9 ms
//! and the bunny subdivided to 1 271 808 triangles (two threads) in 0.29–0.32 s, where a
//! plain build (a bounds pass, a kind pass and one binning pass per axis at every node, a
//! branch per reference in the partition, a box per node) takes 6.1–7.4 ms and
//! 0.91–1.15 s for the same tree (same splits, same node boxes; `splits_are_the_plain_builds`
//! below). In order of gain:
//!
//! - A node reads its references twice: one pass bins them on all three axes at once,
//!   one partitions them and collects both sides' centroid bounds. The sides' bounds
//!   are unions of bins, so a child never makes a bounds pass of its own.
//! - The partition has no data-dependent branch (Lomuto's, swapping every element):
//!   whether a reference goes left is a coin toss to the branch predictor, and its
//!   misses were a third of the build.
//! - One set of bins serves a whole sequential subtree: a node empties only the bins it
//!   filled, and the sweep visits only those. Most nodes hold a few references, and
//!   clearing and sweeping 3 × 16 bins cost them more than their references did.
//! - Boxes are eight SIMD lanes with the maximum negated (`Box8`), so a union is one
//!   min; a reference is one aligned load (`PrimRef`).
//! - Nodes of two references (a third of all nodes) skip the bins (`best_split_pair`).
//! - Large nodes bin their odd references into a second set of bins: neighbours mostly
//!   share bins, and each union waited on the store of the one before (the 1.27M build
//!   on one thread: 487 → 378 ms, `benches/embree/run.sh`'s `vs_embree ... build`).
//! - Nodes go to arrays in pre-order (`BuildTree`), not one `Box` each, and a half built
//!   in parallel keeps its own array instead of being copied into its parent's. Page
//!   faults cost about 3 µs each on this machine, so new memory matters: a large build
//!   still spends about a fifth of its time faulting in the references, the nodes and
//!   the reordered pools.
//! - The root's bounds and the bins of nodes above `PARALLEL_BIN_THRESHOLD` references
//!   are computed in parallel chunks.
//!
//! Tried and dropped (slower, measured): sorting small nodes' references by bin instead
//! of binning them; deciding the binary nodes while collapsing to 4-wide nodes (no
//! stored binary tree), which moved large structs around and copied the parallel parts;
//! masks of the non-empty bins computed from the counts (a wide load of counts just
//! stored narrow stalls on store forwarding).
//!
//! One file past 700 lines (nearly a third of it the tests that rebuild each node by a
//! plain reference): the binning, the split decision, the in-place partitions and the
//! parallel recursion share the invariants that make the tree the same for any thread
//! count, and read best side by side.

use crate::geometry::{Aabb, PrimKind};
use glam::Vec3;
use rayon::prelude::*;
use wide::{f32x4, f32x8, i32x4, i32x8, CmpLt};

pub const BINS: usize = 16;
// `Grid::bins` masks bin indices with `BINS - 1`.
const _: () = assert!(BINS.is_power_of_two());
pub const MAX_LEAF: usize = 4;
/// The largest pool of one kind the tree holds: a leaf's code has 27 bits for its first
/// primitive (`bvh::node`). Larger pools stay beside the tree.
pub const MAX_POOL_FOR_BVH: usize = 1 << 27;

/// The SAH's intersection cost of `count` primitives: the blocks of `MAX_LEAF` they fill.
/// A leaf's primitives are tested in one 4-lane pass (`intersect4`) whether it holds one
/// or four, so the cost counts passes, as Embree's block-size SAH does; counting
/// primitives made leaves of 1.8 triangles on average (bunny) and a deeper tree.
///
/// With a node visit costing at least a block test, a node of at most `MAX_LEAF`
/// references of one kind is always a leaf: one block is cheaper than a visit plus the
/// blocks of any split. Only the choice among splits uses the areas, so no traversal
/// cost constant is needed.
#[inline(always)]
fn blocks(count: u32) -> f32 {
    count.div_ceil(MAX_LEAF as u32) as f32
}
/// Nodes with more references than this build their halves in parallel.
const PARALLEL_THRESHOLD: usize = 16 * 1024;
/// Nodes with more references than this bin (and the root takes its bounds) in parallel,
/// in chunks of `CHUNK` references. Below it the halves' own parallelism keeps the
/// threads busy.
const PARALLEL_BIN_THRESHOLD: usize = 256 * 1024;
const CHUNK: usize = 32 * 1024;
/// Nodes of at least this many references bin them in two sets (`Bins::add`).
const PAIRED_BINNING: usize = 256;
/// Past this depth nodes are split at the median, which bounds the depth (and the
/// traversal stack) even for pathological inputs.
pub const MAX_SAH_DEPTH: u32 = 48;
/// The most inner nodes on a path from the root to a leaf: `MAX_SAH_DEPTH` levels, then
/// at most two splits by kind (the left side of one has a single kind) and the halvings
/// that take fewer than 2^29 references to a leaf of `MAX_LEAF` (`stack` asserts the
/// 27). A collapsed tree is no deeper (a wide node's child is at least one level down);
/// `Bvh::build` checks both.
pub const MAX_DEPTH: usize = MAX_SAH_DEPTH as usize + 2 + 27;

/// One primitive to place: its bounds, kind and index in its kind's pool.
///
/// Stored as the eight lanes of a `Box8`, (min x, y, z, index, −max x, y, z, kind), the
/// fourth and eighth holding integer bits: one aligned load and one mask give the box,
/// in each of the two passes over every reference at every level of the tree.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub struct PrimRef(f32x8);

/// Keeps the coordinate lanes of a `PrimRef`.
const COORDS: f32x8 = {
    let (y, n) = (f32::from_bits(!0), 0.0);
    f32x8::new([y, y, y, n, y, y, y, n])
};

impl PrimRef {
    pub fn new(bounds: Aabb, kind: PrimKind, index: u32) -> PrimRef {
        let (lo, hi) = (bounds.min, bounds.max);
        let kind = kind.slot() as u32;
        PrimRef(f32x8::new([
            lo.x,
            lo.y,
            lo.z,
            f32::from_bits(index),
            -hi.x,
            -hi.y,
            -hi.z,
            f32::from_bits(kind),
        ]))
    }

    pub fn bounds(&self) -> Aabb {
        self.lanes().aabb()
    }

    #[inline]
    pub fn kind(&self) -> PrimKind {
        PrimKind::of_slot(self.0.to_array()[7].to_bits())
    }

    #[inline]
    pub fn index(&self) -> u32 {
        self.0.to_array()[3].to_bits()
    }

    #[inline(always)]
    fn lanes(&self) -> Box8 {
        Box8(self.0 & COORDS)
    }
}

/// A node of the binary build tree (see `BuildTree`). Leaves name a range of the
/// reference array.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildNode {
    pub bounds: Aabb,
    /// Leaf: the first reference. Inner node: where the right child is, relative (so a
    /// subtree built on its own can go anywhere unchanged): `first_or_right` nodes
    /// further on in the segment, or with `far` the first node of the segment
    /// `first_or_right` segments further on.
    pub first_or_right: u32,
    /// References in a leaf; 0 for an inner node.
    pub count: u16,
    /// Inner node: the right child starts another segment.
    pub far: bool,
    /// The kind of a leaf's references (unused for inner nodes).
    pub kind: PrimKind,
}

/// A node of a `BuildTree`: (segment, index in the segment).
pub type NodeId = (usize, usize);

/// The binary tree, in segments: the root's, then one per half built in parallel, each
/// in pre-order (an inner node's left child is the next node). The halves are not
/// copied into their parents' arrays: on the 1.27M-triangle bunny those copies, and the
/// page faults of the arrays they filled, cost about a tenth of the build. The root is
/// node (0, 0).
#[derive(Clone, Debug, PartialEq)]
pub struct BuildTree {
    pub segments: Vec<Vec<BuildNode>>,
}

impl BuildTree {
    pub const ROOT: NodeId = (0, 0);

    #[inline]
    pub fn node(&self, (s, i): NodeId) -> &BuildNode {
        &self.segments[s][i]
    }

    /// The children of a node, `None` for a leaf.
    #[inline]
    pub fn children(&self, (s, i): NodeId) -> Option<[NodeId; 2]> {
        let n = self.node((s, i));
        let far = n.first_or_right as usize;
        (n.count == 0).then(|| [(s, i + 1), if n.far { (s + far, 0) } else { (s, i + far) }])
    }
}

/// Build over `refs`, reordering them so that every leaf is a contiguous range.
/// `None` for no references.
pub fn build(refs: &mut [PrimRef]) -> Option<BuildTree> {
    build_with_leaves(refs, MAX_LEAF)
}

/// `build` with leaves of at most `max_leaf` references (1 to `MAX_LEAF`).
pub fn build_with_leaves(refs: &mut [PrimRef], max_leaf: usize) -> Option<BuildTree> {
    debug_assert!((1..=MAX_LEAF).contains(&max_leaf));
    if refs.is_empty() {
        return None;
    }
    let all = if refs.len() > PARALLEL_BIN_THRESHOLD {
        refs.par_chunks(CHUNK)
            .map(Side::of)
            .reduce(|| Side::of(&[]), Side::union)
    } else {
        Side::of(refs)
    };
    // A binary tree over n references has at most 2n − 1 nodes: never reallocates.
    let (mut nodes, mut later) = (Vec::with_capacity(2 * refs.len() - 1), Vec::new());
    build_node(
        refs,
        0,
        0,
        &all,
        &mut Bins::new(),
        &mut nodes,
        &mut later,
        max_leaf,
    );
    later.insert(0, nodes);
    Some(BuildTree { segments: later })
}

/// A box as eight lanes: (min x, y, z, ·, −max x, y, z, ·). With the maximum negated, a
/// union is one SIMD min over all eight lanes.
///
/// The plain SIMD min is exact here: a reference's bounds are never NaN (the pools'
/// coordinates are finite, and `Aabb::from_points` skips a NaN sum), and without NaN it
/// gives the bits of `Aabb::union` in any order. A centroid can be NaN (a box from −∞ to
/// +∞): `grow` skips it as `Aabb::grow` does.
#[derive(Clone, Copy)]
struct Box8(f32x8);

impl Box8 {
    const EMPTY: Box8 = Box8(f32x8::new([f32::INFINITY; 8]));

    #[inline(always)]
    fn union(self, o: Box8) -> Box8 {
        Box8(self.0.fast_min(o.0))
    }

    /// Grow to a point, skipping a NaN point: the point goes first because SSE's and
    /// AVX's min return their second operand if either is NaN.
    #[inline(always)]
    fn grow(self, c: f32x4) -> Box8 {
        let point: f32x8 = bytemuck::cast([c, -c]);
        Box8(point.fast_min(self.0))
    }

    /// The centroid as `Aabb::centroid` computes it, lane by lane (x − (−y) is x + y).
    #[inline(always)]
    fn centroid(self) -> f32x4 {
        let [min, neg_max]: [f32x4; 2] = bytemuck::cast(self.0);
        (min - neg_max) * f32x4::splat(0.5)
    }

    /// `Aabb::surface_area` of a non-empty box, from s = −max + min = −(max − min): the
    /// products of two extents are those of two s, so this is the same value (at most the
    /// sign of a zero differs, which no comparison sees).
    #[inline(always)]
    fn area(&self) -> f32 {
        let [min, neg_max]: [f32x4; 2] = bytemuck::cast(self.0);
        let s = (neg_max + min).to_array();
        2.0 * (s[0] * s[1] + s[1] * s[2] + s[2] * s[0])
    }

    fn aabb(&self) -> Aabb {
        let v = self.0.to_array();
        Aabb::new(Vec3::new(v[0], v[1], v[2]), Vec3::new(-v[4], -v[5], -v[6]))
    }
}

/// What a node needs from its parent: the bounds and the centroid bounds of its
/// references.
#[derive(Clone, Copy)]
struct Side {
    bounds: Box8,
    centroids: Box8,
}

impl Side {
    fn of(refs: &[PrimRef]) -> Side {
        let (mut bounds, mut centroids) = (Box8::EMPTY, Box8::EMPTY);
        for r in refs {
            let b = r.lanes();
            bounds = bounds.union(b);
            centroids = centroids.grow(b.centroid());
        }
        Side { bounds, centroids }
    }

    fn union(self, o: Side) -> Side {
        Side {
            bounds: self.bounds.union(o.bounds),
            centroids: self.centroids.union(o.centroids),
        }
    }
}

fn leaf(refs: &[PrimRef], offset: usize, bounds: Aabb) -> BuildNode {
    BuildNode {
        bounds,
        first_or_right: offset as u32,
        count: refs.len() as u16,
        far: false,
        kind: refs[0].kind(),
    }
}

fn single_kind(refs: &[PrimRef]) -> bool {
    let kind = refs[0].kind();
    refs.iter().all(|r| r.kind() == kind)
}

/// In-place partition: elements satisfying `left` first. Returns the split point.
///
/// Lomuto's scheme without a branch: every element is swapped with the first right one
/// (itself while there is none), and the split point moves past it if it goes left.
/// Whether an element goes left is a coin toss to the branch predictor, whose misses
/// cost more than the swap; and the element tested next never depends on this test.
fn partition(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> usize {
    let mut split = 0;
    for i in 0..refs.len() {
        let is_left = left(&refs[i]);
        refs.swap(i, split);
        split += is_left as usize;
    }
    split
}

/// `partition` by bin that also returns the centroid bounds of both sides, each
/// reference's centroid blended into its side's bounds (again no branch, and no store
/// for the next reference to wait on).
fn partition_by_bin(
    refs: &mut [PrimRef],
    grid: &Grid,
    axis: usize,
    bin: usize,
) -> (usize, Box8, Box8) {
    let (mut left, mut right) = (Box8::EMPTY, Box8::EMPTY);
    let mut split = 0;
    for i in 0..refs.len() {
        let c = refs[i].lanes().centroid();
        let is_left = grid.below(c, axis, bin);
        let mask: f32x8 = bytemuck::cast(i32x8::splat(-(is_left as i32)));
        left.0 = mask.blend(left.grow(c).0, left.0);
        right.0 = mask.blend(right.0, right.grow(c).0);
        refs.swap(i, split);
        split += is_left as usize;
    }
    (split, left, right)
}

/// Where centroids fall: bin = (c − min) · BINS / extent, per axis.
struct Grid {
    min: f32x4,
    scale: f32x4,
}

impl Grid {
    fn new(centroids: &Aabb) -> Grid {
        let extent = centroids.max - centroids.min;
        let scale = Vec3::splat(BINS as f32) / extent;
        // An axis with no extent gets an infinite or NaN scale: its references all land in
        // bin 0 and `best_split` does not look at it.
        Grid {
            min: f32x4::new([centroids.min.x, centroids.min.y, centroids.min.z, 0.0]),
            scale: f32x4::new([scale.x, scale.y, scale.z, 0.0]),
        }
    }

    /// The bin of centroid `c` on each axis: `((c − min) · scale) as usize`, at most
    /// `BINS − 1`. Clamped as floats, so the plain conversion is exact; SSE's max returns
    /// its second operand for a NaN, which lands in bin 0 as with `as`.
    #[inline(always)]
    fn lanes(&self, c: f32x4) -> i32x4 {
        ((c - self.min) * self.scale)
            .fast_max(f32x4::ZERO)
            .fast_min(f32x4::splat((BINS - 1) as f32))
            .fast_trunc_int()
    }

    /// `lanes` as indices. They are in range already; the mask tells the compiler, which
    /// then checks no bounds in the binning loop.
    #[inline(always)]
    fn bins(&self, c: f32x4) -> [usize; 4] {
        self.lanes(c).to_array().map(|b| b as usize & (BINS - 1))
    }

    /// Is the bin of `c` on `axis` below `bin`? (A compare and a mask, no round trip
    /// through memory to pick the lane.)
    #[inline(always)]
    fn below(&self, c: f32x4, axis: usize, bin: usize) -> bool {
        let below = self.lanes(c).cmp_lt(i32x4::splat(bin as i32)).move_mask();
        (below >> axis) & 1 != 0
    }
}

/// The bins of all three axes (bounds and counts), with a mask of the non-empty ones.
///
/// Between nodes every bin is empty: a node adds its references, reads the bins and
/// empties the ones it filled (`clear`), so a sequential subtree shares one `Bins`.
struct Bins {
    bounds: [[Box8; BINS]; 3],
    count: [[u32; BINS]; 3],
    /// Bit b of `full[axis]`: bin b is not empty.
    full: [u32; 3],
}

impl Bins {
    fn new() -> Box<Bins> {
        Box::new(Bins {
            bounds: [[Box8::EMPTY; BINS]; 3],
            count: [[0; BINS]; 3],
            full: [0; 3],
        })
    }

    /// One pass over `refs` fills the bins of all three axes.
    fn add(&mut self, refs: &[PrimRef], grid: &Grid) {
        if refs.len() < PAIRED_BINNING {
            self.add_one_by_one(refs, grid);
            return;
        }
        // Neighbouring references mostly fall in the same bins, and each union or count
        // there waits for the store of the one before: the odd references go to a
        // second set of bins, merged at the end (unions and integer sums, exact in any
        // order, so the same bins).
        let mut odd = Bins::new();
        let pairs = refs.chunks_exact(2);
        let rest = pairs.remainder();
        for pair in pairs {
            let (a, b) = (pair[0].lanes(), pair[1].lanes());
            let (bins_a, bins_b) = (grid.bins(a.centroid()), grid.bins(b.centroid()));
            for axis in 0..3 {
                let (i, j) = (bins_a[axis], bins_b[axis]);
                self.bounds[axis][i] = self.bounds[axis][i].union(a);
                odd.bounds[axis][j] = odd.bounds[axis][j].union(b);
                self.count[axis][i] += 1;
                odd.count[axis][j] += 1;
                self.full[axis] |= 1 << i;
                odd.full[axis] |= 1 << j;
            }
        }
        self.add_one_by_one(rest, grid);
        for axis in 0..3 {
            for b in bits(odd.full[axis]) {
                self.bounds[axis][b] = self.bounds[axis][b].union(odd.bounds[axis][b]);
                self.count[axis][b] += odd.count[axis][b];
            }
            self.full[axis] |= odd.full[axis];
        }
    }

    fn add_one_by_one(&mut self, refs: &[PrimRef], grid: &Grid) {
        for r in refs {
            let bounds = r.lanes();
            let bins = grid.bins(bounds.centroid());
            for (axis, &b) in bins[..3].iter().enumerate() {
                self.bounds[axis][b] = self.bounds[axis][b].union(bounds);
                self.count[axis][b] += 1;
                self.full[axis] |= 1 << b;
            }
        }
    }

    fn merge(mut self: Box<Bins>, o: Box<Bins>) -> Box<Bins> {
        for axis in 0..3 {
            for b in 0..BINS {
                self.bounds[axis][b] = self.bounds[axis][b].union(o.bounds[axis][b]);
                self.count[axis][b] += o.count[axis][b];
            }
            self.full[axis] |= o.full[axis];
        }
        self
    }

    /// Empty the bins that are not.
    fn clear(&mut self) {
        for axis in 0..3 {
            for b in bits(self.full[axis]) {
                self.bounds[axis][b] = Box8::EMPTY;
                self.count[axis][b] = 0;
            }
            self.full[axis] = 0;
        }
    }

    /// The bounds of the bins of `axis` below `bin`, and of those from `bin` on.
    fn sides(&self, axis: usize, bin: usize) -> (Box8, Box8) {
        let below = (1u32 << bin) - 1;
        let union = |mask| bits(mask).fold(Box8::EMPTY, |s, b| s.union(self.bounds[axis][b]));
        (
            union(self.full[axis] & below),
            union(self.full[axis] & !below),
        )
    }
}

/// The set bits of `mask`, lowest first.
fn bits(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let b = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            b
        })
    })
}

/// A candidate split: (cost, axis, first bin of the right side).
type Split = (f32, usize, usize);

/// The best SAH split. Only splits between non-empty bins are tried: a split next to an
/// empty bin has the same sides, hence the same cost, as the one before that bin, and a
/// candidate replaces the best only if strictly cheaper, so of equal costs the first
/// (smallest axis, then smallest bin) wins as in a sweep over all 16 bins.
fn best_split(bins: &Bins, centroids: &Aabb) -> Option<Split> {
    let extent = centroids.max - centroids.min;
    let mut best: Option<Split> = None;
    for axis in (0..3).filter(|&a| extent[a] > 0.0) {
        // The non-empty bins in order.
        let mut full = [0usize; BINS];
        let mut len = 0;
        for b in bits(bins.full[axis]) {
            full[len] = b;
            len += 1;
        }
        let bin = |i: usize| (bins.bounds[axis][full[i]], bins.count[axis][full[i]]);
        // From the right: area times count of full[i..].
        let mut right_cost = [0.0f32; BINS];
        let (mut side, mut count) = (Box8::EMPTY, 0);
        for i in (1..len).rev() {
            let (b, n) = bin(i);
            (side, count) = (side.union(b), count + n);
            right_cost[i] = side.area() * blocks(count);
        }
        let (mut side, mut count) = (Box8::EMPTY, 0);
        for i in 1..len {
            let (b, n) = bin(i - 1);
            (side, count) = (side.union(b), count + n);
            let cost = side.area() * blocks(count) + right_cost[i];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, full[i - 1] + 1));
            }
        }
    }
    best
}

/// `best_split` for two references, without the bins (a third of all nodes have two
/// references; filling and emptying bins for them was a tenth of a small build). The
/// one candidate split puts a reference on each side; it exists on the axes where their
/// bins differ, at the same cost on each, so the first of those axes wins.
fn best_split_pair(
    refs: &[PrimRef],
    grid: &Grid,
    centroids: &Aabb,
) -> Option<(Split, (Box8, Box8))> {
    let (a, b) = (refs[0].lanes(), refs[1].lanes());
    let (bin_a, bin_b) = (grid.bins(a.centroid()), grid.bins(b.centroid()));
    let extent = centroids.max - centroids.min;
    let axis = (0..3).find(|&k| extent[k] > 0.0 && bin_a[k] != bin_b[k])?;
    let (left, right, bin) = if bin_a[axis] < bin_b[axis] {
        (a, b, bin_a[axis])
    } else {
        (b, a, bin_b[axis])
    };
    // The sweep's area · 1 + area · 1.
    let cost = left.area() + right.area();
    Some(((cost, axis, bin + 1), (left, right)))
}

/// Build the subtree over `refs` (from `offset` in the whole array) into `out`, its
/// segment, and `later`, the segments after it (`later[j]` is `j + 1` segments on).
#[allow(clippy::too_many_arguments)]
fn build_node(
    refs: &mut [PrimRef],
    offset: usize,
    depth: u32,
    all: &Side,
    bins: &mut Bins,
    out: &mut Vec<BuildNode>,
    later: &mut Vec<Vec<BuildNode>>,
    max_leaf: usize,
) {
    let n = refs.len();
    let bounds = all.bounds.aabb();
    if n <= max_leaf && (n == 1 || single_kind(refs)) {
        out.push(leaf(refs, offset, bounds));
        return;
    }

    let centroids = all.centroids.aabb();
    let grid = Grid::new(&centroids);
    // The best split, and the bounds of both sides.
    let split = if depth >= MAX_SAH_DEPTH {
        None
    } else if n == 2 {
        best_split_pair(refs, &grid, &centroids)
    } else if n > PARALLEL_BIN_THRESHOLD {
        let bins = refs
            .par_chunks(CHUNK)
            .fold(Bins::new, |mut b, chunk| {
                b.add(chunk, &grid);
                b
            })
            .reduce(Bins::new, Bins::merge);
        best_split(&bins, &centroids).map(|s| (s, bins.sides(s.1, s.2)))
    } else {
        bins.add(refs, &grid);
        let split = best_split(bins, &centroids).map(|s| (s, bins.sides(s.1, s.2)));
        bins.clear();
        split
    };
    let (mid, sides) = match split {
        Some(((_, axis, bin), (lb, rb))) => {
            let (mid, lc, rc) = partition_by_bin(refs, &grid, axis, bin);
            let l = Side {
                bounds: lb,
                centroids: lc,
            };
            let r = Side {
                bounds: rb,
                centroids: rc,
            };
            (mid, Some((l, r)))
        }
        // All centroids equal (or too deep): separate the kinds, else halve.
        None if !single_kind(refs) => {
            let first = refs[0].kind();
            (partition(refs, |r| r.kind() == first), None)
        }
        None => (n / 2, None),
    };
    // A partition can only be one-sided if rounding put every centroid in one bin.
    let (mid, sides) = if mid == 0 || mid == n {
        (n / 2, None)
    } else {
        (mid, sides)
    };

    let (left, right) = refs.split_at_mut(mid);
    let (l, r) = sides.unwrap_or_else(|| (Side::of(left), Side::of(right)));
    let me = out.len();
    out.push(BuildNode {
        bounds,
        first_or_right: 0,
        count: 0,
        far: false,
        kind: PrimKind::Triangle,
    });
    if n > PARALLEL_THRESHOLD {
        let ((), (right_nodes, right_later)) = rayon::join(
            || build_node(left, offset, depth + 1, &l, bins, out, later, max_leaf),
            || {
                let (mut nodes, mut later) = (Vec::with_capacity(2 * right.len() - 1), Vec::new());
                let bins = &mut Bins::new();
                build_node(
                    right,
                    offset + mid,
                    depth + 1,
                    &r,
                    bins,
                    &mut nodes,
                    &mut later,
                    max_leaf,
                );
                (nodes, later)
            },
        );
        // The right half's segment comes after those the left half made.
        out[me].first_or_right = (later.len() + 1) as u32;
        out[me].far = true;
        later.push(right_nodes);
        later.extend(right_later);
    } else {
        build_node(left, offset, depth + 1, &l, bins, out, later, max_leaf);
        out[me].first_or_right = (out.len() - me) as u32;
        build_node(
            right,
            offset + mid,
            depth + 1,
            &r,
            bins,
            out,
            later,
            max_leaf,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x: f32, kind: PrimKind, index: u32) -> PrimRef {
        PrimRef::new(Aabb::new(Vec3::splat(x), Vec3::splat(x + 1.0)), kind, index)
    }

    fn check(tree: &BuildTree, i: NodeId, refs: &[PrimRef], seen: &mut Vec<u32>) {
        let node = tree.node(i);
        match tree.children(i) {
            None => {
                let (first, count) = (node.first_or_right as usize, node.count as usize);
                assert!(count <= MAX_LEAF && count > 0);
                for p in &refs[first..first + count] {
                    assert_eq!(p.kind(), node.kind);
                    assert_eq!(node.bounds.union(p.bounds()), node.bounds);
                    seen.push(p.index());
                }
            }
            Some(children) => {
                for c in children {
                    assert_eq!(node.bounds.union(tree.node(c).bounds), node.bounds);
                    check(tree, c, refs, seen);
                }
            }
        }
    }

    #[test]
    fn leaves_cover_every_reference_once_and_are_pure() {
        let mut refs: Vec<PrimRef> = (0..100)
            .map(|i| {
                let kind = [PrimKind::Sphere, PrimKind::Quad, PrimKind::Triangle][i % 3];
                r((i * 7 % 13) as f32, kind, i as u32)
            })
            .collect();
        let tree = build(&mut refs).unwrap();
        let mut seen = Vec::new();
        check(&tree, BuildTree::ROOT, &refs, &mut seen);
        seen.sort_unstable();
        assert_eq!(seen, (0..100).collect::<Vec<u32>>());
    }

    #[test]
    fn equal_centroids_still_make_small_leaves() {
        let mut refs: Vec<PrimRef> = (0..1000).map(|i| r(0.0, PrimKind::Triangle, i)).collect();
        let tree = build(&mut refs).unwrap();
        let mut seen = Vec::new();
        check(&tree, BuildTree::ROOT, &refs, &mut seen);
        assert_eq!(seen.len(), 1000);
    }

    /// The instances' tree: every leaf one reference, equal centroids too.
    #[test]
    fn leaves_of_one_hold_one_reference() {
        for same in [false, true] {
            let mut refs: Vec<PrimRef> = (0..300)
                .map(|i| {
                    r(
                        if same { 0.0 } else { (i * 7 % 13) as f32 },
                        PrimKind::Triangle,
                        i,
                    )
                })
                .collect();
            let tree = build_with_leaves(&mut refs, 1).unwrap();
            let mut seen = Vec::new();
            let mut leaves = vec![BuildTree::ROOT];
            while let Some(i) = leaves.pop() {
                match tree.children(i) {
                    Some(children) => leaves.extend(children),
                    None => {
                        let node = tree.node(i);
                        assert_eq!(node.count, 1);
                        seen.push(refs[node.first_or_right as usize].index());
                    }
                }
            }
            seen.sort_unstable();
            assert_eq!(seen, (0..300).collect::<Vec<u32>>());
        }
    }

    /// Pseudo-random references: boxes of many sizes, some repeated (equal centroids),
    /// the first `mixed` of mixed kinds.
    fn random_refs(n: usize, mixed: usize, seed: u64) -> Vec<PrimRef> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|i| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let e = Vec3::new(next(), next(), next()) * next().powi(4);
                let c = if i % 17 == 5 { Vec3::splat(3.0) } else { c };
                let kind = if i < mixed {
                    [PrimKind::Sphere, PrimKind::Quad, PrimKind::Triangle][i % 3]
                } else {
                    PrimKind::Triangle
                };
                PrimRef::new(Aabb::new(c - e, c + e), kind, i as u32)
            })
            .collect()
    }

    /// What the plain build decides for a node, from plain `Aabb`s: a leaf (`None`), or
    /// which references go left.
    fn reference_decision(refs: &[PrimRef], depth: u32) -> Option<Vec<bool>> {
        let n = refs.len();
        let (mut bounds, mut centroids) = (Aabb::EMPTY, Aabb::EMPTY);
        for r in refs {
            bounds = bounds.union(r.bounds());
            centroids = centroids.grow(r.bounds().centroid());
        }
        let pure = refs.iter().all(|r| r.kind() == refs[0].kind());
        if n == 1 || pure && n <= MAX_LEAF {
            return None;
        }
        let bin_of = |r: &PrimRef, axis: usize| {
            let scale = BINS as f32 / (centroids.max[axis] - centroids.min[axis]);
            let c = r.bounds().centroid()[axis];
            (((c - centroids.min[axis]) * scale) as usize).min(BINS - 1)
        };
        let mut best: Option<(f32, usize, usize)> = None;
        let extent = centroids.max - centroids.min;
        for axis in 0..3 {
            if depth >= MAX_SAH_DEPTH || extent[axis] <= 0.0 || extent[axis].is_nan() {
                continue;
            }
            let mut bins = [(Aabb::EMPTY, 0u32); BINS];
            for r in refs {
                let b = &mut bins[bin_of(r, axis)];
                *b = (b.0.union(r.bounds()), b.1 + 1);
            }
            let mut right_cost = [0.0f32; BINS];
            let (mut rb, mut rc) = (Aabb::EMPTY, 0u32);
            for i in (1..BINS).rev() {
                (rb, rc) = (rb.union(bins[i].0), rc + bins[i].1);
                right_cost[i] = rb.surface_area() * rc.div_ceil(4) as f32;
            }
            let (mut lb, mut lc) = (Aabb::EMPTY, 0u32);
            for i in 1..BINS {
                (lb, lc) = (lb.union(bins[i - 1].0), lc + bins[i - 1].1);
                if lc == 0 || lc as usize == n {
                    continue;
                }
                let cost = lb.surface_area() * lc.div_ceil(4) as f32 + right_cost[i];
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, i));
                }
            }
        }
        match best {
            Some((_, axis, bin)) => Some(refs.iter().map(|r| bin_of(r, axis) < bin).collect()),
            // The kinds apart (which kind goes left depends on the order), or halves.
            None if !pure => {
                let k = refs[0].kind();
                Some(refs.iter().map(|r| r.kind() == k).collect())
            }
            None => Some((0..n).map(|i| i < n / 2).collect()),
        }
    }

    /// The references below node `i`.
    fn count(tree: &BuildTree, i: NodeId) -> usize {
        match tree.children(i) {
            None => tree.node(i).count as usize,
            Some([l, r]) => count(tree, l) + count(tree, r),
        }
    }

    fn sorted_indices<'a>(refs: impl Iterator<Item = &'a PrimRef>) -> Vec<u32> {
        let mut v: Vec<u32> = refs.map(|r| r.index()).collect();
        v.sort_unstable();
        v
    }

    /// Every node below node `i` (over `refs[range]`, at `depth`) is what the first
    /// version decided for its references: the same bounds, leaf or not, the same sides.
    fn check_against_reference(
        tree: &BuildTree,
        i: NodeId,
        refs: &[PrimRef],
        range: (usize, usize),
        depth: u32,
    ) {
        let node = tree.node(i);
        let here = &refs[range.0..range.1];
        let bounds = here.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds()));
        assert_eq!(node.bounds, bounds);
        let decision = reference_decision(here, depth);
        let Some([l, r]) = tree.children(i) else {
            assert!(decision.is_none(), "a leaf where the reference splits");
            assert_eq!(node.first_or_right as usize, range.0);
            assert_eq!(node.count as usize, here.len());
            return;
        };
        let left = decision.expect("a split where the reference makes a leaf");
        let mid = range.0 + count(tree, l);
        let centroid = |r: &PrimRef| r.bounds().centroid();
        if here.iter().all(|r| centroid(r) == centroid(&here[0])) {
            // No SAH split: the kinds apart, else halves. Which kind or half goes left
            // depends on the order of the references, so check only that.
            if here.iter().all(|r| r.kind() == here[0].kind()) {
                assert_eq!(mid - range.0, here.len() / 2);
            } else {
                let k = refs[range.0].kind();
                assert!(refs[range.0..mid].iter().all(|r| r.kind() == k));
                assert!(refs[mid..range.1].iter().all(|r| r.kind() != k));
            }
        } else {
            let want = here.iter().zip(&left).filter(|(_, &l)| l).map(|(r, _)| r);
            assert_eq!(
                sorted_indices(refs[range.0..mid].iter()),
                sorted_indices(want)
            );
        }
        check_against_reference(tree, l, refs, (range.0, mid), depth + 1);
        check_against_reference(tree, r, refs, (mid, range.1), depth + 1);
    }

    #[test]
    fn splits_are_the_plain_builds() {
        for (n, mixed, seed) in [(3000, 0, 1), (2000, 600, 2), (40, 40, 3)] {
            let mut refs = random_refs(n, mixed, seed);
            let tree = build(&mut refs).unwrap();
            check_against_reference(&tree, BuildTree::ROOT, &refs, (0, n), 0);
        }
    }

    #[test]
    fn large_nodes_bin_in_parallel_to_the_same_tree() {
        // Above `PARALLEL_BIN_THRESHOLD`: the root's bounds and bins come from chunks.
        let refs = random_refs(PARALLEL_BIN_THRESHOLD + 40_000, 0, 4);
        let build_with = |threads| {
            let mut refs = refs.clone();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let tree = pool.install(|| build(&mut refs)).unwrap();
            (tree, refs)
        };
        let (one, refs_one) = build_with(1);
        let (two, refs_two) = build_with(2);
        assert_eq!(one, two);
        let indices = |refs: &[PrimRef]| refs.iter().map(|r| r.index()).collect::<Vec<_>>();
        assert_eq!(indices(&refs_one), indices(&refs_two));
        // The root's split is the reference's.
        let left = reference_decision(&refs, 0).unwrap();
        let want = refs.iter().zip(&left).filter(|(_, &l)| l).map(|(r, _)| r);
        let mid = count(&one, (0, 1));
        assert_eq!(sorted_indices(refs_one[..mid].iter()), sorted_indices(want));
        // And every node below, across the segments of the halves built in parallel.
        assert!(one.segments.len() > 1);
        check_against_reference(&one, BuildTree::ROOT, &refs_one, (0, refs.len()), 0);
    }

    #[test]
    fn prim_refs_round_trip() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.5), Vec3::new(3.0, 0.0, 7.0));
        for (kind, index) in [
            (PrimKind::Sphere, 0),
            (PrimKind::Quad, 12345),
            (PrimKind::Triangle, (1 << 27) - 1),
        ] {
            let r = PrimRef::new(b, kind, index);
            assert_eq!((r.bounds(), r.kind(), r.index()), (b, kind, index));
        }
    }

    #[test]
    fn empty_and_single() {
        assert!(build(&mut []).is_none());
        let mut one = [r(0.0, PrimKind::Sphere, 0)];
        let tree = build(&mut one).unwrap();
        assert_eq!(tree.segments, [[tree.segments[0][0]]]);
        assert_eq!(tree.node(BuildTree::ROOT).count, 1);
    }
}
