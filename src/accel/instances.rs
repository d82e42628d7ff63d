//! The level above the instances' meshes (`scene::instance`): after the tree over the
//! scene's pools, each instance whose box a ray meets before its closest hit so far
//! gets the ray moved into the mesh's space (`ToObject::apply`, the same operations on
//! every lane) and asks the mesh's own tree. The closest hit is the smallest `(t, id)`
//! over both levels, whatever the order, so packets of every width and single rays
//! agree bit for bit: a packet's lanes in an instance are a packet of the moved rays
//! through the mesh's tree.
//!
//! The instances' boxes are in a binary tree of their own (`InstanceTree`, built by the
//! same binned SAH as the pools' trees; single rays take its levels two at a time, four
//! boxes in one test), traversed nearest child first so that a near instance's hit
//! prunes the ones behind it. Instances are never lights: a shadow ray
//! asks the light's own nearest hit (as the tree over the pools does), then whether an
//! instance's primitive beats it.

use super::build::{self, BuildTree, NodeId, PrimRef};
use super::bvh::light_hits;
use super::packet::RayPacket;
use super::packet::{PacketHits, PacketQuery};
use super::{Accel, Context, ShadowLanes, ShadowQuery, Tree};
use crate::geometry::aabb::SLAB_FAR_SCALE;
use crate::geometry::{keep_closest, Aabb, Hit, PrimKind, Ray};
use crate::lanes::{set_lanes, Lane, Mask, MAX_WIDTH};
use crate::scene::{Instance, Light, Scene};
use glam::{Vec3A, Vec4};
use std::cell::Cell;

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
    /// The instances' hits that beat `best` in `[t_min, t_max]`, kept in it.
    #[inline(never)]
    pub(super) fn instances_closest(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        best: &mut Option<Hit>,
    ) {
        let scene = cx.scene;
        let slab = BoxTest::new(ray);
        let best_t = Cell::new(best.map_or(t_max, |h| h.t));
        let nodes = self.instances.for_each_single(
            &slab,
            t_min,
            || best_t.get(),
            |i| {
                let inst = &scene.instances[i as usize];
                let bound = best_t.get();
                if slab.enter(&inst.bounds, t_min, bound).is_none() {
                    return true;
                }
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

    /// Whether an instance's primitive beats the light's own nearest hit on `ray`, for a
    /// ray that the scene's pools leave lit. A light of many primitives asks for the
    /// closest hit over both levels instead, as the tree does.
    #[inline(never)]
    pub(super) fn instances_occlude(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        t_min: f32,
        light: &Light,
    ) -> bool {
        let scene = cx.scene;
        let Some((t_light, id_light)) = light.nearest_hit(ray, t_min) else {
            return true;
        };
        let slab = BoxTest::new(ray);
        let mut occluded = false;
        let nodes = self.instances.for_each_single(
            &slab,
            t_min,
            || t_light,
            |i| {
                let inst = &scene.instances[i as usize];
                if slab.enter(&inst.bounds, t_min, t_light).is_none() {
                    return true;
                }
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
                let (q, dt) = moved_packet(p, inst, tree, lanes);
                // Bounded by each lane's best hit so far: as for one ray, a hit at
                // t + dt ≤ bound has t ≤ bound.
                let within = PacketHits::within(lanes, t.get());
                let cx = Context::new(proto, cx.stats);
                let found = tree.closest_hit_packet_within(cx, &q, t_min, within);
                for k in set_lanes(found.found & lanes) {
                    let Some(hit) = found.hit(k) else { continue };
                    let hit = inst.world_hit(hit, dt.lane(k));
                    let mut best = hits.hit(k);
                    keep_closest(&mut best, hit);
                    if best == Some(hit) {
                        hits.set(k, hit.t, Some(hit));
                    }
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
                if enter != 0 {
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

/// One ray's box test of the instance level: `Aabb::hit`'s robust slab test (a NaN
/// from 0 · ∞ leaves its axis unconstrained, the far distance widened by
/// `SLAB_FAR_SCALE`) on the three axes at once. Only a cull: conservative is enough.
struct BoxTest {
    origin: Vec3A,
    inv: Vec3A,
}

impl BoxTest {
    #[inline(always)]
    fn new(ray: &Ray) -> BoxTest {
        BoxTest {
            origin: ray.origin.into(),
            inv: Vec3A::ONE / Vec3A::from(ray.dir),
        }
    }

    /// `enter` for the four boxes of `node`: their entry distances and the slots met.
    #[inline(always)]
    fn enter4(&self, node: &TopNode4, t_min: f32, t_max: f32) -> ([f32; 4], u32) {
        let mut enter = Vec4::splat(t_min);
        let mut exit = Vec4::splat(t_max);
        for axis in 0..3 {
            let (o, inv) = (Vec4::splat(self.origin[axis]), Vec4::splat(self.inv[axis]));
            let lo = (node.lo[axis] - o) * inv;
            let hi = (node.hi[axis] - o) * inv;
            let nan = lo.is_nan_mask() | hi.is_nan_mask();
            let near = Vec4::select(nan, Vec4::NEG_INFINITY, lo.min(hi));
            let far = Vec4::select(nan, Vec4::INFINITY, lo.max(hi) * SLAB_FAR_SCALE);
            enter = enter.max(near);
            exit = exit.min(far);
        }
        (enter.to_array(), enter.cmple(exit).bitmask() & node.valid)
    }

    /// The entry distance into `b` within `[t_min, t_max]`, if the ray meets it there.
    #[inline(always)]
    fn enter(&self, b: &Aabb, t_min: f32, t_max: f32) -> Option<f32> {
        let lo = (Vec3A::from(b.min) - self.origin) * self.inv;
        let hi = (Vec3A::from(b.max) - self.origin) * self.inv;
        let nan = lo.is_nan_mask() | hi.is_nan_mask();
        let near = Vec3A::select(nan, Vec3A::NEG_INFINITY, lo.min(hi));
        let far = Vec3A::select(nan, Vec3A::INFINITY, lo.max(hi) * SLAB_FAR_SCALE);
        let enter = near.max_element().max(t_min);
        let exit = far.min_element().min(t_max);
        (enter <= exit).then_some(enter)
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

/// Four children of `InstanceTree::wide`: their boxes by axis (lane `c` child `c`),
/// their codes (a wide node's index, or `TOP_LEAF` and a binary leaf's index), and
/// which slots hold one.
#[derive(Clone, Copy, Debug)]
struct TopNode4 {
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    child: [u32; 4],
    valid: u32,
}

/// A child code of `TopNode4` that names a leaf of the binary tree.
const TOP_LEAF: u32 = 1 << 31;

/// A binary tree over the instances' world boxes, in pre-order (packets traverse it), and
/// the same tree with its levels taken two at a time into 4-wide nodes (single rays).
#[derive(Clone, Debug, Default)]
pub struct InstanceTree {
    nodes: Vec<TopNode>,
    wide: Vec<TopNode4>,
    /// The code of the 4-wide tree's root (`TOP_LEAF` and 0 when the root is a leaf).
    root4: Option<u32>,
    /// Instance indices, each leaf's a contiguous range.
    order: Vec<u32>,
}

/// Deepest path of an `InstanceTree` a traversal's stack holds (the SAH build's bound).
const TOP_STACK: usize = build::MAX_DEPTH + 2;

impl InstanceTree {
    pub fn build(scene: &Scene) -> InstanceTree {
        let mut refs: Vec<PrimRef> = (scene.instances.iter().enumerate())
            .map(|(i, inst)| PrimRef::new(inst.bounds, PrimKind::Triangle, i as u32))
            .collect();
        let Some(tree) = build::build(&mut refs) else {
            return InstanceTree::default();
        };
        let mut t = InstanceTree {
            nodes: Vec::new(),
            wide: Vec::new(),
            root4: None,
            order: refs.iter().map(PrimRef::index).collect(),
        };
        t.flatten(&tree, BuildTree::ROOT);
        t.root4 = Some(t.widen(0));
        t
    }

    /// The 4-wide code of binary node `at`: a leaf's, or a wide node over its
    /// grandchildren (its children where they are leaves).
    fn widen(&mut self, at: u32) -> u32 {
        let n = self.nodes[at as usize];
        if n.right == 0 {
            return TOP_LEAF | at;
        }
        let mut kids = Vec::with_capacity(4);
        for c in [at + 1, n.right] {
            let k = self.nodes[c as usize];
            if k.right == 0 {
                kids.push(c);
            } else {
                kids.extend([c + 1, k.right]);
            }
        }
        let index = self.wide.len();
        self.wide.push(TopNode4 {
            lo: [Vec4::ZERO; 3],
            hi: [Vec4::ZERO; 3],
            child: [0; 4],
            valid: 0,
        });
        let mut node = self.wide[index];
        for (slot, &k) in kids.iter().enumerate() {
            let b = self.nodes[k as usize].bounds;
            for axis in 0..3 {
                node.lo[axis][slot] = b.min[axis];
                node.hi[axis][slot] = b.max[axis];
            }
            node.child[slot] = self.widen(k);
            node.valid |= 1 << slot;
        }
        self.wide[index] = node;
        index as u32
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

    /// Each instance in a leaf whose box `ray` meets within `[t_min, bound()]`, nearest
    /// subtree first, through the 4-wide nodes, while `visit(instance)` returns true;
    /// the number of boxes tested.
    #[inline(always)]
    fn for_each_single(
        &self,
        ray: &BoxTest,
        t_min: f32,
        bound: impl Fn() -> f32,
        mut visit: impl FnMut(u32) -> bool,
    ) -> u64 {
        let Some(root) = self.root4 else {
            return 0;
        };
        let mut tested = 0;
        let mut stack = [0u32; TOP_STACK];
        stack[0] = root;
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let code = stack[top];
            if code & TOP_LEAF != 0 {
                let n = &self.nodes[(code & !TOP_LEAF) as usize];
                for &i in &self.order[n.start as usize..(n.start + n.count) as usize] {
                    if !visit(i) {
                        return tested;
                    }
                }
                continue;
            }
            let node = &self.wide[code as usize];
            tested += node.valid.count_ones() as u64;
            let (enter, hit) = ray.enter4(node, t_min, bound());
            // The children met, farthest pushed first.
            let mut met = [(0.0f32, 0u32); 4];
            let mut n = 0;
            for c in set_lanes(hit) {
                met[n] = (enter[c], node.child[c]);
                n += 1;
            }
            met[..n].sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            for &(_, child) in &met[..n] {
                stack[top] = child;
                top += 1;
            }
        }
        tested
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
        let mut stack = [(0u32, 0u32); TOP_STACK];
        stack[0] = (0, lanes);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (at, lanes) = stack[top];
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
                    stack[top] = (node, m);
                    top += 1;
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
