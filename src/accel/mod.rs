//! Acceleration structures: which primitives a ray has to test.
//!
//! - `linear`: the original program's algorithm: every sphere and quad, every triangle of
//!   a mesh whose bounding box is hit. Kept so the BVH's gain is measurable in one run.
//! - `bvh`: a binned-SAH BVH (`build`) collapsed to 4-wide nodes (packets) and 8-wide
//!   nodes (single rays: closest hits and shadow rays); the default.
//!
//! Both answer the same two questions with the same bits: the closest hit by the
//! `(t, primitive id)` rule, and whether a shadow ray reaches a given light.

pub mod build;
pub mod bvh;
pub mod cull;
mod instances;
pub mod linear;
pub mod packet;
pub mod shadow;
mod stack;

use crate::geometry::{Hit, Ray};
use crate::lanes::{lanes_where, set_lanes, Lane};
use crate::scene::{Light, Scene};
use bvh::{Bvh, ShadowLanes};
pub use instances::InstanceTree;
use linear::LinearScan;
use packet::{PacketHits, RayPacket};
use shadow::Among;

/// Rays that reach a traversal are finite: a NaN or infinite origin or direction makes
/// the slab test read every plane as "no constraint", so every slot of a node is
/// entered, empty ones too. The scene's load-time limits (`scene::limits`) keep them
/// finite; debug builds (the tests', the fuzzer's) check it at every query.
#[inline(always)]
fn debug_assert_finite(ray: &Ray) {
    debug_assert!(
        ray.origin.is_finite() && ray.dir.is_finite(),
        "a non-finite ray reached the traversal: {ray:?}"
    );
}

/// `debug_assert_finite` of the rays of `lanes` of `p`. Only in debug builds: in release
/// the empty loop over the lanes stayed in the code.
#[inline(always)]
fn debug_assert_lanes_finite<L: Lane>(p: &RayPacket<L>, lanes: u32) {
    if cfg!(debug_assertions) {
        set_lanes(lanes).for_each(|k| debug_assert_finite(&p.ray(k)));
    }
}

/// Which acceleration structure to build. Both give the same image, bit for bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelKind {
    /// Brute force, with the mesh bounding-box pre-test (the original program's
    /// algorithm): to measure what the BVH gains.
    Linear,
    /// A bounding volume hierarchy built by binned SAH (the default): 4-wide nodes for
    /// packets and shadow rays, the same tree 8-wide for single rays' closest hits; small
    /// pools of spheres and quads are tested in a loop beside it.
    #[default]
    Bvh,
}

impl AccelKind {
    /// The lowercase name (`linear`, `bvh`).
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Linear => "linear",
            AccelKind::Bvh => "bvh",
        }
    }
}

/// What a shadow ray asks, by the original program's rule (lit when the nearest hit is the
/// light's): is there a primitive of another object than the light's `object` in
/// `[t_min, t_light]` that beats the light's own nearest hit `(t_light, id_light)` by the
/// `(t, id)` rule? Every any-hit traversal answers it: one ray's (`Bvh::occluded`), and
/// a packet's lanes (`packet::ShadowLanes`, whose `lane` is this for one lane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowQuery {
    pub t_min: f32,
    pub t_light: f32,
    pub id_light: u32,
    pub object: u32,
}

impl ShadowQuery {
    /// Does a hit at `t` (within `[t_min, t_light]`) of primitive `id`, of `object`,
    /// occlude the light?
    #[inline(always)]
    pub fn occludes(&self, t: f32, id: u32, object: u32) -> bool {
        object != self.object && self.beats_light(t, id)
    }

    /// Does a hit at `t` (within `[t_min, t_light]`) of primitive `id` beat the light's
    /// own, nearer or as near with a smaller id?
    #[inline(always)]
    pub fn beats_light(&self, t: f32, id: u32) -> bool {
        t < self.t_light || id < self.id_light
    }
}

/// Work done by traversals: boxes (nodes) visited and primitives tested.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Nodes visited (a packet's visit counts once).
    pub nodes: u64,
    /// Primitive tests (a packet's test counts once per lane it is run for).
    pub prims: u64,
    /// Node visits by packets, and the lanes active at those visits (occupancy).
    pub packet_nodes: u64,
    /// Active lanes summed over the packets' node visits.
    pub packet_lanes: u64,
    /// Lanes a packet handed to the single-ray traversal: a subtree entered by one lane
    /// (`RayPacket::fallback`), a shadow ray to a light of many primitives.
    pub single_lanes: u64,
    /// Leaves a camera packet's frustum met, and the lanes that entered them.
    pub frustum_leaves: u64,
    pub frustum_leaf_lanes: u64,
}

/// What every query of an acceleration structure reads and writes besides its rays: the
/// scene the structure was built for, and the statistics its work adds to. One value
/// through the whole query; the traversals start their own contexts from it
/// (`bvh::single::RayQuery` for one ray, `packet::PacketQuery` for a packet). Passed by
/// value (two pointers, in two registers): `reborrow` for each of several calls.
#[derive(Debug)]
pub struct Context<'a> {
    pub scene: &'a Scene,
    pub stats: &'a mut TraversalStats,
}

impl<'a> Context<'a> {
    #[inline(always)]
    pub fn new(scene: &'a Scene, stats: &'a mut TraversalStats) -> Self {
        Context { scene, stats }
    }

    /// The same scene and statistics for one call, `self` usable again after it.
    #[inline(always)]
    pub fn reborrow(&mut self) -> Context<'_> {
        Context {
            scene: self.scene,
            stats: self.stats,
        }
    }
}

impl TraversalStats {
    /// Add `o`'s counts to these.
    pub fn add(&mut self, o: &TraversalStats) {
        self.nodes += o.nodes;
        self.prims += o.prims;
        self.packet_nodes += o.packet_nodes;
        self.packet_lanes += o.packet_lanes;
        self.single_lanes += o.single_lanes;
        self.frustum_leaves += o.frustum_leaves;
        self.frustum_leaf_lanes += o.frustum_leaf_lanes;
    }
}

/// A built acceleration structure over a compiled scene: a tree over its pools, and
/// one over each mesh its instances place (`instances`: the level above them).
#[derive(Clone, Debug)]
pub struct Accel {
    pub tree: Tree,
    /// The tree of each of `Scene::prototypes`, over its scene, of the same kind.
    pub prototypes: Vec<Tree>,
    /// The tree over the instances' boxes.
    pub instances: InstanceTree,
}

/// An acceleration structure over one scene's pools.
// One a render, built once and borrowed by every tile: the BVH's inline fields (the
// lone quad beside it among them) are read on every ray without a pointer to follow.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Tree {
    Linear(LinearScan),
    Bvh(Bvh),
}

impl Accel {
    /// Build for `scene` (and for each mesh its instances place). The BVH reorders the
    /// pools (ids and objects move with their primitives, so images do not change).
    pub fn build(scene: &mut Scene, kind: AccelKind) -> Accel {
        let prototypes = (scene.prototypes.iter_mut())
            .map(|p| Tree::build(&mut p.scene, kind))
            .collect();
        Accel {
            tree: Tree::build(scene, kind),
            prototypes,
            instances: InstanceTree::build(scene),
        }
    }

    /// One line for `--stats`: what was built.
    pub fn describe(&self, scene: &Scene) -> String {
        let mut line = self.tree.describe(scene);
        if !scene.instances.is_empty() {
            let triangles: usize = (scene.prototypes.iter())
                .map(|p| p.scene.triangles.len())
                .sum();
            line += &format!(
                "; {} instances of {} meshes ({triangles} triangles stored once), each mesh with a tree of its own",
                scene.instances.len(),
                scene.prototypes.len(),
            );
        }
        line
    }

    pub fn kind(&self) -> AccelKind {
        self.tree.kind()
    }

    /// The BVH over the scene's pools, if that is what was built.
    pub fn bvh(&self) -> Option<&Bvh> {
        match &self.tree {
            Tree::Bvh(b) => Some(b),
            Tree::Linear(_) => None,
        }
    }

    /// The closest hit in `[t_min, t_max]` by the `(t, primitive id)` rule.
    #[inline]
    pub fn closest_hit(&self, cx: Context<'_>, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.closest_hit_inlined(cx, ray, t_min, t_max)
    }

    /// `closest_hit`, always inlined: for the scalar tracer's camera and bounce rays,
    /// where the call cost 2–5% of the render's instructions (callgrind, `mixed`,
    /// `quads`, `spheres`, `bunny`); inlined at every call, the packets' fallbacks grew
    /// and their renders took 1–4% more.
    #[inline(always)]
    pub fn closest_hit_inlined(
        &self,
        mut cx: Context<'_>,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        debug_assert_finite(ray);
        let mut best = self.tree.closest_hit(cx.reborrow(), ray, t_min, t_max);
        if !cx.scene.instances.is_empty() {
            let bound = best.map_or(t_max, |h| h.t);
            if let Some(inv) = self.instances.entered_by(ray, t_min, bound) {
                self.instances_closest(cx, ray, inv, t_min, t_max, &mut best);
            }
        }
        best
    }

    /// The original program's shadow test: is the nearest hit of the ray (from `t_min`,
    /// unbounded) a primitive of `light`'s object? The linear scan answers with a
    /// closest-hit query; the BVH finds the light's own nearest hit and then looks for any
    /// occluder before it.
    #[inline]
    pub fn light_visible(&self, mut cx: Context<'_>, ray: &Ray, t_min: f32, light: &Light) -> bool {
        debug_assert_finite(ray);
        if cx.scene.instances.is_empty() {
            return self.tree.light_visible(cx, ray, t_min, light);
        }
        if light.primitives() > bvh::LIGHT_PRIMITIVES_SCANNED {
            // As the tree asks it: is the closest hit, over both levels, the light's?
            return self
                .closest_hit(cx, ray, t_min, f32::INFINITY)
                .is_some_and(|h| h.object == light.object);
        }
        let Some(query) = self.tree.light_query(cx.reborrow(), ray, t_min, light) else {
            return false;
        };
        match self.instances.entered_by(ray, t_min, query.t_light) {
            Some(inv) => !self.instances_occlude(cx, ray, inv, query),
            None => true,
        }
    }

    /// Whether a packet's queries test boxes, so its rays need the box constants
    /// (`RayPacket::from_active_lanes_with`): through a tree, or an instance's box.
    pub fn packet_boxes(&self) -> bool {
        self.tree.packet_boxes() || !self.prototypes.is_empty()
    }

    /// `closest_hit` (from `t_min`, unbounded) for every active lane of a packet.
    #[inline]
    pub fn closest_hit_packet<L: Lane>(
        &self,
        mut cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
    ) -> PacketHits<L> {
        debug_assert_lanes_finite(p, p.active);
        let mut hits = self.tree.closest_hit_packet(cx.reborrow(), p, t_min);
        if !cx.scene.instances.is_empty() {
            self.instances_closest_packet(cx, p, t_min, &mut hits);
        }
        hits
    }

    /// `light_visible` for the lanes of `lanes`: the mask of those that see the light.
    /// `among`: the only primitives of the scene's pools that can occlude, when known
    /// (`shadow::ShadowBoxes::candidates` of the lanes' origins, for the BVH whose scene
    /// they were made for; the linear scan tests everything).
    #[inline]
    pub fn light_visible_packet<L: Lane>(
        &self,
        mut cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        light: &Light,
        lanes: u32,
        among: Option<Among<'_>>,
    ) -> u32 {
        let lanes = lanes & p.active;
        debug_assert_lanes_finite(p, lanes);
        let instances = !cx.scene.instances.is_empty();
        if instances && light.primitives() > bvh::LIGHT_PRIMITIVES_SCANNED {
            cx.stats.single_lanes += lanes.count_ones() as u64;
            return lanes_where(lanes, |k| {
                self.light_visible(cx.reborrow(), &p.ray(k), t_min, light)
            });
        }
        let visible =
            (self.tree).light_visible_packet(cx.reborrow(), p, t_min, light, lanes, among);
        if !instances || visible == 0 {
            return visible;
        }
        visible & !self.instances_occlude_packet(cx, p, t_min, light, visible)
    }
}

impl Tree {
    /// Build for `scene` (`Accel::build`).
    pub fn build(scene: &mut Scene, kind: AccelKind) -> Tree {
        match kind {
            AccelKind::Linear => Tree::Linear(LinearScan::build(scene)),
            AccelKind::Bvh => Tree::Bvh(Bvh::build(scene)),
        }
    }

    /// Whether every ray tests every primitive: a linear scan, or a BVH with none of the
    /// scene's primitives in its tree (all in the loops beside it).
    pub fn tests_everything(&self) -> bool {
        match self {
            Tree::Linear(_) => true,
            Tree::Bvh(b) => b.root.is_none(),
        }
    }

    /// One line for `--stats`: what was built over the scene's pools.
    pub fn describe(&self, scene: &Scene) -> String {
        match self {
            Tree::Linear(_) => format!("linear scan over {} primitives", scene.primitive_count()),
            Tree::Bvh(b) => {
                let names = ["spheres", "quads", "triangles"];
                let pools = [
                    scene.spheres.len(),
                    scene.quads.len(),
                    scene.triangles.len(),
                ];
                let list = |in_tree: bool| {
                    let parts: Vec<String> = (0..3)
                        .map(|k| {
                            let beside = b.linear[k].len();
                            (k, if in_tree { pools[k] - beside } else { beside })
                        })
                        .filter(|&(_, n)| n > 0)
                        .map(|(k, n)| format!("{n} {}", names[k]))
                        .collect();
                    if parts.is_empty() {
                        "none".to_string()
                    } else {
                        parts.join(", ")
                    }
                };
                format!(
                    "4-wide BVH over {} ({} nodes, and {} 8-wide for single rays; {} leaves, depth {}); tested in a loop beside it: {}",
                    list(true),
                    b.nodes.len(),
                    b.nodes8.len(),
                    b.leaves,
                    b.depth,
                    list(false)
                )
            }
        }
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Tree::Linear(_) => AccelKind::Linear,
            Tree::Bvh(_) => AccelKind::Bvh,
        }
    }

    /// `Accel::closest_hit` over this tree's scene alone.
    #[inline]
    pub fn closest_hit(&self, cx: Context<'_>, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        match self {
            Tree::Linear(l) => l.closest_hit(cx, ray, t_min, t_max),
            Tree::Bvh(b) => b.closest_hit(cx, ray, t_min, t_max),
        }
    }

    /// `Accel::light_visible` over this tree's scene alone.
    #[inline]
    pub fn light_visible(&self, cx: Context<'_>, ray: &Ray, t_min: f32, light: &Light) -> bool {
        match self {
            Tree::Linear(l) => l
                .closest_hit(cx, ray, t_min, f32::INFINITY)
                .is_some_and(|h| h.object == light.object),
            Tree::Bvh(b) => b.light_visible(cx, ray, t_min, light),
        }
    }

    /// `Bvh::light_query` over this tree's scene alone: the light's own nearest hit, if
    /// nothing of the scene occludes it.
    #[inline]
    fn light_query(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        t_min: f32,
        light: &Light,
    ) -> Option<ShadowQuery> {
        match self {
            Tree::Linear(l) => {
                let lit = l
                    .closest_hit(cx, ray, t_min, f32::INFINITY)
                    .is_some_and(|h| h.object == light.object);
                let (t_light, id_light) = light.nearest_hit(ray, t_min).filter(|_| lit)?;
                Some(ShadowQuery {
                    t_min,
                    t_light,
                    id_light,
                    object: light.object,
                })
            }
            Tree::Bvh(b) => b.light_query(cx, ray, t_min, light),
        }
    }

    /// Does a primitive of this tree's scene occlude by `query`'s rule? (The linear
    /// scan's answer holds for a scene without the light's object: a prototype's.)
    #[inline]
    pub fn occluded(&self, cx: Context<'_>, ray: &Ray, query: ShadowQuery) -> bool {
        match self {
            // The closest hit in range is the smallest (t, id): if any hit beats the
            // light's, it does.
            Tree::Linear(l) => l
                .closest_hit(cx, ray, query.t_min, query.t_light)
                .is_some_and(|h| query.occludes(h.t, h.id, h.object)),
            Tree::Bvh(b) => b.occluded(cx, ray, query),
        }
    }

    /// `Accel::packet_boxes` for this tree.
    pub fn packet_boxes(&self) -> bool {
        match self {
            Tree::Linear(_) => false,
            Tree::Bvh(b) => b.root.is_some(),
        }
    }

    /// `Accel::closest_hit_packet` over this tree's scene alone.
    #[inline]
    pub fn closest_hit_packet<L: Lane>(
        &self,
        mut cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
    ) -> PacketHits<L> {
        match self {
            Tree::Linear(l) => {
                let mut hits = PacketHits::none(p.active);
                for k in set_lanes(p.active) {
                    let hit = l.closest_hit(cx.reborrow(), &p.ray(k), t_min, f32::INFINITY);
                    hits.set(k, hit.map_or(f32::INFINITY, |h| h.t), hit);
                }
                hits
            }
            Tree::Bvh(b) => b.closest_hit_packet(cx, p, t_min),
        }
    }

    /// `closest_hit_packet` from `st`'s bounds (`PacketHits::within`).
    #[inline]
    pub fn closest_hit_packet_within<L: Lane>(
        &self,
        mut cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        st: PacketHits<L>,
    ) -> PacketHits<L> {
        match self {
            Tree::Linear(l) => {
                let mut hits = st;
                for k in set_lanes(p.active) {
                    let t_max = st.t.lane(k);
                    let hit = l.closest_hit(cx.reborrow(), &p.ray(k), t_min, t_max);
                    hits.set(k, hit.map_or(t_max, |h| h.t), hit);
                }
                hits
            }
            Tree::Bvh(b) => b.closest_hit_packet_within(cx, p, t_min, st),
        }
    }

    /// `Accel::light_visible_packet` over this tree's scene alone.
    #[inline]
    pub fn light_visible_packet<L: Lane>(
        &self,
        mut cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        light: &Light,
        lanes: u32,
        among: Option<Among<'_>>,
    ) -> u32 {
        match self {
            Tree::Linear(_) => lanes_where(lanes, |k| {
                self.light_visible(cx.reborrow(), &p.ray(k), t_min, light)
            }),
            Tree::Bvh(b) => b.light_visible_packet(cx, p, t_min, light, lanes, among),
        }
    }

    /// The lanes of `lanes` that a primitive of this tree's scene occludes, lane `k`
    /// asking `light.lane(k)`.
    #[inline]
    pub fn occluded_packet<L: Lane>(
        &self,
        mut cx: Context<'_>,
        p: &RayPacket<L>,
        light: ShadowLanes<L>,
        lanes: u32,
    ) -> u32 {
        match self {
            Tree::Linear(_) => lanes_where(lanes, |k| {
                self.occluded(cx.reborrow(), &p.ray(k), light.lane(k))
            }),
            Tree::Bvh(b) => b.occluded_packet(cx, p, light, lanes),
        }
    }
}
