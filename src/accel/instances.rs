//! The level above the instances' meshes (`scene::instance`): after the tree over the
//! scene's pools, each instance whose box a ray meets before its closest hit so far
//! gets the ray moved into the mesh's space (`ToObject::apply`, the same operations on
//! every lane) and asks the mesh's own tree. The closest hit is the smallest `(t, id)`
//! over both levels, whatever the order, so packets of every width and single rays
//! agree bit for bit: a packet's lanes in an instance are a packet of the moved rays
//! through the mesh's tree.
//!
//! The instances' boxes are in a tree of their own (`InstanceTree`, built by the same
//! binned SAH as the pools' trees: binary for packets, collapsed to the pools' 8-wide
//! nodes for single rays), traversed nearest child first so that a near instance's hit
//! prunes the ones behind it. Instances are never lights: a shadow ray
//! asks the light's own nearest hit (as the tree over the pools does), then whether an
//! instance's primitive beats it.

use super::build::{self, BuildTree, NodeId, PrimRef};
use super::bvh::{collapse, decode_leaf, light_hits, BoxRay8, Node8, Shape, Wide, LEAF};
use super::packet::RayPacket;
use super::packet::{PacketHits, PacketQuery};
use super::stack::{self, TraversalStack, STACK8};
use super::{Accel, Context, ShadowLanes, ShadowQuery, Tree};
use crate::geometry::aabb::SLAB_FAR_SCALE;
use crate::geometry::{keep_closest, Aabb, Hit, PrimKind, Ray};
use crate::lanes::{set_lanes, Lane, Mask, MAX_WIDTH};
use crate::scene::{Instance, Light, Scene};
use glam::{Vec3A, Vec4};
use std::cell::Cell;
use std::mem::MaybeUninit;

/// A packet's lanes that enter an instance this few or fewer go in as single rays: a
/// packet's set-up in the mesh's space (its moved rays, reciprocals and box constants)
/// pays only for more. Herd of `benches/instances`, render instructions, callgrind,
/// x86-64-v3 build: at 320 px 4-wide -4.5%, 8-wide -1.4%, 16-wide -1.1% against one
/// (at 640 px -1.6%, -0.8%, -0.7%); every lane alone gives more where instances cover
/// many pixels (16-wide at 640 px +21%).
const LONE: u32 = 3;

/// The prototype of `inst` and the ray moved into its space with the distance its
/// origin was advanced by (the ray itself and 0 for the identity).
#[inline]
fn moved(inst: &Instance, ray: &Ray) -> (Ray, f32) {
    match &inst.to_object {
        None => (*ray, 0.0),
        Some(m) => m.ray(ray),
    }
}

/// A shadow query of the scene in a prototype's terms: its distances less `dt`, the
/// light's id relative to the instance's first (0 when the light's id is below every
/// one of the instance's: then only a nearer hit beats it), and no object of the
/// prototype's is the light's.
#[inline]
fn query_in(inst: &Instance, t_min: f32, t_light: f32, id_light: u32, dt: f32) -> ShadowQuery {
    ShadowQuery {
        t_min,
        t_light: t_light - dt,
        id_light: id_light.saturating_sub(inst.first_id),
        object: u32::MAX,
    }
}

impl Accel {
    /// The instances' hits that beat `best` in `[t_min, t_max]`, kept in it; `inv`: the
    /// reciprocals of the ray's direction, from `InstanceTree::entered_by`.
    #[inline(never)]
    pub(super) fn instances_closest(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        inv: Vec4,
        t_min: f32,
        t_max: f32,
        best: &mut Option<Hit>,
    ) {
        let scene = cx.scene;
        let best_t = Cell::new(best.map_or(t_max, |h| h.t));
        let nodes = self.instances.for_each_single(
            &BoxRay8::from_inv(ray, inv),
            t_min,
            || best_t.get(),
            |i| {
                let inst = &scene.instances[i as usize];
                let bound = best_t.get();
                let (tree, proto) = self.prototype(scene, inst);
                let (moved, dt) = moved(inst, ray);
                // A hit at t + dt ≤ bound has t ≤ bound (dt ≥ 0): the bound loses none.
                let cx = Context::new(proto, cx.stats);
                if let Some(hit) = tree.closest_hit(cx, &moved, t_min, bound) {
                    keep_closest(best, inst.world_hit(hit, dt));
                    best_t.set(best.map_or(t_max, |h| h.t));
                }
                true
            },
        );
        cx.stats.nodes += nodes;
    }

    /// Whether an instance's primitive beats the light's own nearest hit on `ray`
    /// (`query`, from a tree over the scene's pools that leaves the ray lit). A light of
    /// many primitives asks for the closest hit over both levels instead, as the tree
    /// does.
    #[inline(never)]
    pub(super) fn instances_occlude(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        inv: Vec4,
        query: ShadowQuery,
    ) -> bool {
        let scene = cx.scene;
        let ShadowQuery {
            t_min,
            t_light,
            id_light,
            ..
        } = query;
        let mut occluded = false;
        let nodes = self.instances.for_each_single(
            &BoxRay8::from_inv(ray, inv),
            t_min,
            || t_light,
            |i| {
                let inst = &scene.instances[i as usize];
                let (tree, proto) = self.prototype(scene, inst);
                let (moved, dt) = moved(inst, ray);
                let query = query_in(inst, t_min, t_light, id_light, dt);
                occluded = tree.occluded(Context::new(proto, cx.stats), &moved, query);
                !occluded
            },
        );
        cx.stats.nodes += nodes;
        occluded
    }

    /// `instances_closest` for the active lanes of `p`, into `hits`.
    #[inline(never)]
    pub(super) fn instances_closest_packet<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        hits: &mut PacketHits<L>,
    ) {
        let scene = cx.scene;
        let nodes = Cell::new(0);
        let t = Cell::new(hits.t);
        let boxes = p.has_boxes();
        self.instances.for_each_lanes(
            p.active,
            |b, lanes| {
                nodes.set(nodes.get() + 1);
                entering(p, boxes, b, t_min, t.get(), lanes)
            },
            |i, lanes| {
                let inst = &scene.instances[i as usize];
                let (_, lanes) = entering(p, boxes, &inst.bounds, t_min, t.get(), lanes);
                if lanes == 0 {
                    return true;
                }
                let (tree, proto) = self.prototype(scene, inst);
                let mut keep = |k: usize, hit: Hit| {
                    let mut best = hits.hit(k);
                    keep_closest(&mut best, hit);
                    if best == Some(hit) {
                        hits.set(k, hit.t, Some(hit));
                    }
                };
                if lanes.count_ones() <= LONE {
                    // A few lanes as single rays (`instances_closest`'s steps, the same
                    // bits): a packet's set-up in the mesh's space costs more (`LONE`).
                    for k in set_lanes(lanes) {
                        let (moved, dt) = moved(inst, &p.ray(k));
                        let cx = Context::new(proto, &mut *cx.stats);
                        if let Some(hit) = tree.closest_hit(cx, &moved, t_min, t.get().lane(k)) {
                            keep(k, inst.world_hit(hit, dt));
                        }
                    }
                } else {
                    let (q, dt) = moved_packet(p, inst, tree, lanes);
                    // Bounded by each lane's best hit so far: as for one ray, a hit at
                    // t + dt ≤ bound has t ≤ bound.
                    let within = PacketHits::within(lanes, t.get());
                    let cx = Context::new(proto, &mut *cx.stats);
                    let found = tree.closest_hit_packet_within(cx, &q, t_min, within);
                    hits.keep_placed(&found, lanes, dt, inst.first_id, inst.first_object);
                }
                t.set(hits.t);
                true
            },
        );
        cx.stats.nodes += nodes.get();
    }

    /// `instances_occlude` for the lanes of `lanes` of `p`: those an instance occludes.
    #[inline(never)]
    pub(super) fn instances_occlude_packet<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        light: &Light,
        lanes: u32,
    ) -> u32 {
        let mut cx = cx;
        let scene = cx.scene;
        // The light's own nearest hits, lane-wise (`Light::nearest_hit`'s bits); a lane
        // without one is not lit.
        let (t_light, id_light, reach) =
            light_hits(&mut PacketQuery::new(cx.reborrow(), p), light, t_min, lanes);
        let occluded = lanes & !reach;
        let t_light = L::select(
            L::Mask::from_bits(reach),
            t_light,
            L::splat(f32::NEG_INFINITY),
        );
        // The light's ids, the same on every lane but for a light of several primitives.
        let first = reach.trailing_zeros() as usize % L::WIDTH;
        let one_id = (0..L::WIDTH)
            .all(|k| reach >> k & 1 == 0 || id_light.lane(k) == id_light.lane(first))
            .then(|| id_light.lane(first).to_bits());
        let nodes = Cell::new(0);
        let done = Cell::new(occluded);
        let boxes = p.has_boxes();
        let asked = lanes & !occluded;
        self.instances.for_each_lanes(
            asked,
            |b, lanes| {
                nodes.set(nodes.get() + 1);
                entering(p, boxes, b, t_min, t_light, lanes & !done.get())
            },
            |i, lanes| {
                let inst = &scene.instances[i as usize];
                let lanes = lanes & !done.get();
                let (_, enter) = entering(p, boxes, &inst.bounds, t_min, t_light, lanes);
                if enter != 0 && enter.count_ones() <= LONE {
                    // A few lanes as single rays (`instances_occlude`'s steps, the same
                    // bits).
                    let (tree, proto) = self.prototype(scene, inst);
                    for k in set_lanes(enter) {
                        let (moved, dt) = moved(inst, &p.ray(k));
                        let id = id_light.lane(k).to_bits();
                        let query = query_in(inst, t_min, t_light.lane(k), id, dt);
                        if tree.occluded(Context::new(proto, &mut *cx.stats), &moved, query) {
                            done.set(done.get() | 1 << k);
                        }
                    }
                } else if enter != 0 {
                    let (tree, proto) = self.prototype(scene, inst);
                    let (q, dt) = moved_packet(p, inst, tree, enter);
                    // `query_in` lane-wise: the same subtraction on every lane.
                    let relative = |id: u32| f32::from_bits(id.saturating_sub(inst.first_id));
                    let ids = match one_id {
                        Some(id) => L::splat(relative(id)),
                        None => L::from_fn(|k| relative(id_light.lane(k).to_bits())),
                    };
                    let asks = ShadowLanes::from_lanes(t_min, u32::MAX, t_light - dt, ids);
                    let found =
                        tree.occluded_packet(Context::new(proto, cx.stats), &q, asks, enter);
                    done.set(done.get() | found);
                }
                // On while a lane asked is not yet occluded.
                asked & !done.get() != 0
            },
        );
        cx.stats.nodes += nodes.get();
        done.get()
    }

    /// The tree and the scene of `inst`'s prototype.
    #[inline(always)]
    fn prototype<'s>(&'s self, scene: &'s Scene, inst: &Instance) -> (&'s Tree, &'s Scene) {
        let p = inst.prototype as usize;
        (&self.prototypes[p], &scene.prototypes[p].scene)
    }
}

/// One ray's box test of the instances' whole box: `Aabb::hit`'s robust slab
/// test (a NaN from 0 · ∞ leaves its axis unconstrained, the far distance widened by
/// `SLAB_FAR_SCALE`) on the three axes at once. Only a cull: conservative is enough.
struct BoxTest {
    origin: Vec3A,
    inv: Vec3A,
}

impl BoxTest {
    /// From the ray's origin and the reciprocals of its direction (`inv.xyz`).
    #[inline(always)]
    fn new(ray: &Ray, inv: Vec4) -> BoxTest {
        BoxTest {
            origin: ray.origin.into(),
            inv: inv.truncate().into(),
        }
    }

    /// Whether the ray meets `b` within `[t_min, t_max]`.
    #[inline(always)]
    fn meets(&self, b: &Aabb, t_min: f32, t_max: f32) -> bool {
        let lo = (Vec3A::from(b.min) - self.origin) * self.inv;
        let hi = (Vec3A::from(b.max) - self.origin) * self.inv;
        let nan = lo.is_nan_mask() | hi.is_nan_mask();
        let near = Vec3A::select(nan, Vec3A::NEG_INFINITY, lo.min(hi));
        let far = Vec3A::select(nan, Vec3A::INFINITY, lo.max(hi) * SLAB_FAR_SCALE);
        near.max_element().max(t_min) <= far.min_element().min(t_max)
    }
}

/// A node of `InstanceTree`: its box, and either its right child (`right > 0`; the
/// left is the next node) or, in a leaf (`right == 0`), the range `start..start +
/// count` of `InstanceTree::order`.
#[derive(Clone, Copy, Debug)]
struct TopNode {
    bounds: Aabb,
    right: u32,
    start: u32,
    count: u32,
}

/// A binary tree over the instances' world boxes, in pre-order (packets traverse it), and
/// the same tree collapsed to the pools' 8-wide nodes (`Node8`, the same leaves), which
/// single rays traverse as they do the pools' tree: one 8-lane test for a node's
/// children, nearest first, a popped node skipped when a nearer hit has passed its entry.
#[derive(Clone, Debug, Default)]
pub struct InstanceTree {
    nodes: Vec<TopNode>,
    nodes8: Vec<Node8>,
    /// The code of the 8-wide tree's root: an inner node or a leaf (`LEAF`).
    root8: Option<u32>,
    /// Instance indices, each leaf's a contiguous range.
    order: Vec<u32>,
}

/// The binary traversal's stack: it pops a node and pushes at most its two children.
const TOP_STACK: usize = stack::capacity(2);

impl InstanceTree {
    /// The reciprocals of `ray`'s direction (`inv.xyz`), if it meets the box of all the
    /// instances within `[t_min, t_max]`; a single ray asks no more of the instances
    /// otherwise. Where the instances stand together most rays miss that box (the herd
    /// of `benches/instances` at 320 px: 45% of its camera rays and of its shadow
    /// rays), and this test in the caller's line saves them the call and its set-up.
    #[inline(always)]
    pub(super) fn entered_by(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Vec4> {
        let inv = Vec4::ONE / ray.dir.extend(1.0);
        let all = &self.nodes.first()?.bounds;
        BoxTest::new(ray, inv)
            .meets(all, t_min, t_max)
            .then_some(inv)
    }

    pub fn build(scene: &Scene) -> InstanceTree {
        let mut refs: Vec<PrimRef> = (scene.instances.iter().enumerate())
            .map(|(i, inst)| PrimRef::new(inst.bounds, PrimKind::Triangle, i as u32))
            .collect();
        // Leaves of one instance: a node's test then meets each instance's box, and the
        // single rays enter them nearest first.
        let Some(tree) = build::build_with_leaves(&mut refs, 1) else {
            return InstanceTree::default();
        };
        let mut t = InstanceTree {
            nodes: Vec::new(),
            nodes8: Vec::new(),
            root8: None,
            order: refs.iter().map(PrimRef::index).collect(),
        };
        t.flatten(&tree, BuildTree::ROOT);
        let mut shape = Shape::default();
        t.root8 = Some(collapse(
            &mut t.nodes8,
            &tree,
            BuildTree::ROOT,
            None,
            0,
            &mut shape,
        ));
        t
    }

    fn flatten(&mut self, tree: &BuildTree, id: NodeId) -> u32 {
        let n = tree.node(id);
        let at = self.nodes.len();
        self.nodes.push(TopNode {
            bounds: n.bounds,
            right: 0,
            start: n.first_or_right,
            count: n.count as u32,
        });
        if let Some([l, r]) = tree.children(id) {
            self.flatten(tree, l);
            let right = self.flatten(tree, r);
            self.nodes[at].right = right;
            self.nodes[at].start = 0;
        }
        at as u32
    }

    /// Each instance whose box `ray` meets within `[t_min, bound()]` (a leaf holds one,
    /// whose box is its node's child box; a lone instance's, the root, is the box the
    /// caller tested: `entered_by`), nearest first, while `visit(instance)` returns
    /// true; the number of nodes visited. As `Bvh::traverse`: the node being visited
    /// stays in a register, only the farther children are pushed, with their entries.
    #[inline(always)]
    fn for_each_single(
        &self,
        ray: &BoxRay8,
        t_min: f32,
        bound: impl Fn() -> f32,
        mut visit: impl FnMut(u32) -> bool,
    ) -> u64 {
        let Some(mut code) = self.root8 else {
            return 0;
        };
        let mut slots = MaybeUninit::<[(u32, f32); STACK8]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        let mut nodes = 0;
        loop {
            if code & LEAF == 0 {
                nodes += 1;
                let node = &self.nodes8[code as usize];
                let (entry, mask) = node.test(ray, t_min, bound());
                if mask != 0 {
                    code = if mask & (mask - 1) == 0 {
                        node.child(mask.trailing_zeros() as usize)
                    } else {
                        node.child(node.push_farther(mask, &entry, &mut stack))
                    };
                    continue;
                }
            } else {
                let (_, start, _) = decode_leaf(code);
                if !visit(self.order[start as usize]) {
                    return nodes;
                }
            }
            // The next node whose entry is still within the bound.
            loop {
                let Some((next, entry)) = stack.pop() else {
                    return nodes;
                };
                if entry <= bound() {
                    code = next;
                    break;
                }
            }
        }
    }

    /// The instances whose box the lanes `enter(box)` returns meet, with those lanes,
    /// nearest subtree first (by the first lane's entry), while `visit(instance, lanes)`
    /// returns true.
    #[inline(always)]
    fn for_each_lanes<L: Lane>(
        &self,
        lanes: u32,
        mut enter: impl FnMut(&Aabb, u32) -> (L, u32),
        mut visit: impl FnMut(u32, u32) -> bool,
    ) {
        if self.nodes.is_empty() || lanes == 0 {
            return;
        }
        let mut slots = MaybeUninit::<[(u32, u32); TOP_STACK]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        stack.push((0, lanes));
        while let Some((at, lanes)) = stack.pop() {
            let n = &self.nodes[at as usize];
            if n.right == 0 {
                for &i in &self.order[n.start as usize..(n.start + n.count) as usize] {
                    if !visit(i, lanes) {
                        return;
                    }
                }
                continue;
            }
            let (l, r) = (at + 1, n.right);
            let (tl, ml) = enter(&self.nodes[l as usize].bounds, lanes);
            let (tr, mr) = enter(&self.nodes[r as usize].bounds, lanes);
            let first = |m: u32| m.trailing_zeros() as usize;
            let right_first = ml != 0 && mr != 0 && {
                let k = first(ml & mr);
                k < MAX_WIDTH && tr.lane(k) < tl.lane(k)
            };
            let (near, far) = if right_first {
                ((r, mr), (l, ml))
            } else {
                ((l, ml), (r, mr))
            };
            for (node, m) in [far, near] {
                if m != 0 {
                    stack.push((node, m));
                }
            }
        }
    }
}

/// The entry distances and the lanes of `lanes` whose ray meets `b` within `[t_min,
/// t_max]` (per lane); every lane of `lanes` for a packet made without box constants
/// (`boxes`).
#[inline(always)]
fn entering<L: Lane>(
    p: &RayPacket<L>,
    boxes: bool,
    b: &Aabb,
    t_min: f32,
    t_max: L,
    lanes: u32,
) -> (L, u32) {
    if !boxes || lanes == 0 {
        return (L::splat(t_min), lanes);
    }
    let t_max = L::select(
        L::Mask::from_bits(lanes),
        t_max,
        L::splat(f32::NEG_INFINITY),
    );
    let (enter, hit) = p.test_box(b.min.to_array(), b.max.to_array(), L::splat(t_min), t_max);
    (enter, hit & lanes)
}

/// The lanes of `lanes` of `p` moved into `inst`'s mesh space, as a packet for `tree`,
/// and each lane's `dt` (`ToObject::apply`).
#[inline(always)]
fn moved_packet<L: Lane>(
    p: &RayPacket<L>,
    inst: &Instance,
    tree: &Tree,
    lanes: u32,
) -> (RayPacket<L>, L) {
    let (origin, dir, dt) = match &inst.to_object {
        None => (p.origin(), p.dir(), L::splat(0.0)),
        Some(m) => m.apply(p.origin(), p.dir()),
    };
    let q = RayPacket::from_active_lanes_with(origin, dir, lanes, tree.packet_boxes());
    (q, dt)
}
