//! The BVH: the collapse of the binary build (`build`) to 4-wide nodes, which packets
//! traverse (`packet_closest`, `packet_shadow`), and to 8-wide ones, which single rays
//! traverse (`single`: closest hit, and the any-hit query of shadow rays); the node
//! layouts are in `node` and `node8`, and the primitives kept beside the tree here.
//!
//! A node holds the boxes of its children structure-of-arrays (`min_x[W]`, …), so one
//! ray tests them all in one pass. Leaves hold up to four primitives of one kind,
//! contiguous in that kind's pool (the pools are reordered after the build), and both
//! widths share them.

use super::build::{self, BuildTree, NodeId, PrimRef, MAX_POOL_FOR_BVH};
use crate::geometry::quad::{OneQuad, QuadLanes};
use crate::geometry::sphere::{sphere_distance, SpherePool, SphereRay};
use crate::geometry::{Aabb, PrimKind};
use crate::lanes::{Mask, V3};
use crate::scene::Scene;
pub use node::{decode_leaf, encode_leaf, slab, BoxRay, Node, Node4, Node8, EMPTY, LEAF};
pub(crate) use node::{plane_rows, Wide, FAR_SCALE, NEAR_SCALE};
pub use node8::BoxRay8;
pub use packet_closest::PacketHits;
pub(crate) use packet_shadow::light_hits;
pub use packet_shadow::ShadowLanes;
use rayon::prelude::*;
pub(crate) use single::{Closest, RayQuery};
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use wide::f32x8;

mod node;
mod node8;
mod packet_closest;
mod packet_shadow;
mod single;

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

/// A light of more primitives than this answers a shadow ray by one closest-hit query
/// through the tree: lit when the nearest hit belongs to the light's object. By the
/// `(t, id)` rule that is the answer of the light's own nearest hit followed by an
/// occluder search (the linear scan answers every light so), but its cost grows with the
/// log of the light's primitives, not their number: a mesh light's own nearest hit, one
/// primitive after another, tested all of its triangles on every shadow ray.
pub const LIGHT_PRIMITIVES_SCANNED: usize = 8;

#[derive(Clone, Debug)]
pub struct Bvh {
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
/// bounds is entered by packets through one test of its box (`Bvh::tree_box_first`):
/// 75% of `bunny`'s shadow packets miss its mesh's box (render instructions −4.3%),
/// while in `cornell` the tree holds the room and every ray is inside it (+1.0%).
pub const TREE_BOX_FIRST: f32 = 0.5;

/// The quads and triangles beside the tree, as the scalar traversals test them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Beside {
    /// None (`linear[1]` and `linear[2]` empty).
    Nothing,
    /// One quad and no triangle (`spheres`' backdrop): `Bvh`'s `one_quad`, tested
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

impl SphereLanes {
    /// `SpherePool::intersect4` of one ray on the eight: the distances, and the mask of
    /// the spheres hit within `[t_min, t_max]`.
    #[inline(always)]
    fn intersect(&self, r: &SphereRay, t_min: f32, t_max: f32) -> ([f32; 8], u32) {
        let (v, s) = (V3::splat, f32x8::splat);
        let (t, hit) = sphere_distance(
            self.center,
            self.radius,
            v(r.origin.into()),
            v(r.dir.into()),
            s(r.a),
            s(r.inv_a),
            s(t_min),
            s(t_max),
        );
        (t.to_array(), hit.bits() & self.valid)
    }
}

/// Spheres a `SphereLanes` holds.
const SPHERE_GROUP: usize = 8;

impl Bvh {
    /// The packet traversals' loop over the primitives beside the tree: `visit(kind,
    /// run)` for each run of one kind that `kept` keeps (bit i of `kept[k]`: the i-th
    /// primitive of kind k beside the tree, those past the 32nd always kept;
    /// `Cull::ALL`'s all-ones keeps whole pools), in pool order, until `visit` returns
    /// false. Inlined with its closure, each call's kind is a constant where the caller
    /// specialises on it (`PrimKind::specialize`).
    #[inline(always)]
    pub(super) fn beside_runs(
        &self,
        kept: &[u32; 3],
        mut visit: impl FnMut(PrimKind, Range<usize>) -> bool,
    ) {
        for (k, &kind) in PrimKind::ALL.iter().enumerate() {
            let range = self.linear[k].clone();
            // (Not for an empty range: an empty pool must not make the watertight
            // lanes, `LazyTriangles::get`.)
            if range.is_empty() {
                continue;
            }
            if kept[k] == u32::MAX {
                if !visit(kind, range) {
                    return;
                }
                continue;
            }
            let first = range.start;
            let n = range.len().min(32);
            let mut bits = kept[k] & if n == 32 { u32::MAX } else { (1 << n) - 1 };
            while bits != 0 {
                let i = first + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if !visit(kind, i..i + 1) {
                    return;
                }
            }
            if range.len() > 32 && !visit(kind, first + 32..range.end) {
                return;
            }
        }
    }

    /// Build over the scene's pools (kinds above `LINEAR_LIMIT`), reordering those pools
    /// so every leaf is a contiguous range.
    pub fn build(scene: &mut Scene) -> Bvh {
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

        let mut bvh = Bvh {
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
}

/// Leaves and depth of a collapsed tree.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Shape {
    leaves: u32,
    depth: u32,
}

/// Turn the binary subtree at `node` into `W`-wide nodes appended to `nodes`
/// (pre-order, so the layout is deterministic) and return its code. `position`: each
/// reference's index in its kind's reordered pool (`None`: the reference's own index).
pub(crate) fn collapse<const W: usize>(
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

/// The spheres `range` eight an `f32x8`, the last group padded with radius-0 spheres (which
/// `Bvh::beside` masks off).
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
            let ([cx, cy, cz, radius], ..) = sp.columns();
            SphereLanes {
                center: V3::new(v8(cx), v8(cy), v8(cz)),
                radius: v8(radius),
                valid: (1u32 << (range.end - start).min(SPHERE_GROUP)) - 1,
            }
        })
        .collect()
}
