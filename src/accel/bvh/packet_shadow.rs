//! A packet's shadow rays through the BVH (`ShadowLanes`, `ShadowQuery` in lanes): the
//! light's own hits lane-wise, then the occluders beside the tree and through the 4-wide
//! nodes, or only those of an area light's candidates (`shadow::Among`).

use super::node::{decode_leaf, EMPTY, LEAF};
use super::single::RayQuery;
use super::{Bvh, LIGHT_PRIMITIVES_SCANNED};
use crate::accel::packet::{ids, in_play, PacketQuery, RayPacket};
use crate::accel::shadow::{Among, Candidates};
use crate::accel::stack::{TraversalStack, STACK4};
use crate::accel::{Context, ShadowQuery};
use crate::geometry::PrimKind;
use crate::lanes::{lanes_where, set_lanes, Lane, Mask};
use crate::scene::{Light, LightShape};
use std::mem::MaybeUninit;

/// `ShadowQuery` in lanes: per lane the light object's own nearest hit `(t_light,
/// id_light)` (the id in an f32's bits), the object, and the kind of its primitives when
/// it is a light (an object is one sphere, quads or triangles; `None`: any kind may be
/// the object's).
#[derive(Clone, Copy, Debug)]
pub struct ShadowLanes<L> {
    t_min: f32,
    t_light: L,
    id_light: L,
    object: u32,
    kind: Option<PrimKind>,
}

impl<L: Lane> ShadowLanes<L> {
    /// Lane `k` asks `query(k)`, of the same `t_min` and `object`.
    #[inline(always)]
    pub fn from_fn(t_min: f32, object: u32, query: impl Fn(usize) -> (f32, u32)) -> Self {
        ShadowLanes {
            t_min,
            t_light: L::from_fn(|k| query(k).0),
            id_light: L::from_fn(|k| f32::from_bits(query(k).1)),
            object,
            kind: None,
        }
    }

    /// Lane `k` asks `(t_light.lane(k), id_light.lane(k))` (the id in an f32's bits), of
    /// the same `t_min` and `object`.
    #[inline(always)]
    pub fn from_lanes(t_min: f32, object: u32, t_light: L, id_light: L) -> Self {
        ShadowLanes {
            t_min,
            t_light,
            id_light,
            object,
            kind: None,
        }
    }

    /// Lane `k`'s question.
    #[inline(always)]
    pub fn lane(&self, k: usize) -> ShadowQuery {
        ShadowQuery {
            t_min: self.t_min,
            t_light: self.t_light.lane(k),
            id_light: self.id_light.lane(k).to_bits(),
            object: self.object,
        }
    }
}

/// The lanes of `lanes` for which a primitive of `range` (of `kind`) occludes `light`
/// (`Bvh::occluded_lanes`) within `t_max`. Inlined into the traversal (a closure call
/// cost `cornell`'s shadow packets 12% more instructions, `packet_probe cornell 8
/// shadow`). The loops beside the tree specialise it per kind (`PrimKind::specialize`),
/// each then holding only its kind's test; the tree's leaves, whose kind is not known,
/// take it with all three (a copy per kind there cost more).
#[inline(always)]
fn occluders<L: Lane>(
    q: &mut PacketQuery<'_, '_, L>,
    light: ShadowLanes<L>,
    kind: PrimKind,
    range: std::ops::Range<usize>,
    lanes: u32,
    t_max: L,
) -> u32 {
    let scene = q.scene;
    let mut found = 0;
    let t_min = light.t_min;
    // Primitives of the object's own kind are skipped before their test (the light's
    // quads are dear to test); the others cannot be the object's, and their ids are
    // looked up only when some lane hits them.
    let (t_light, object) = (light.t_light, light.object);
    let check_first = light.kind.is_none_or(|k| k == kind);
    for i in range {
        if check_first && ids(scene, kind, i).1 == object {
            continue;
        }
        let (t, bits) = q.test_prim(kind, i, t_min, t_max, lanes & !found);
        if bits == 0 {
            continue;
        }
        let (id, obj) = ids(scene, kind, i);
        if obj == object {
            continue;
        }
        // `beats` lane-wise: nearer than the light, or as near with a smaller id.
        found |= t.lt(t_light).bits() & bits;
        for k in set_lanes(t.eq(t_light).bits() & bits) {
            if id < light.id_light.lane(k).to_bits() {
                found |= 1 << k;
            }
        }
        if found == lanes {
            break;
        }
    }
    found
}

/// The lanes of `lanes` whose shadow ray a primitive of `among` occludes
/// (`Bvh::occluded_lanes` over the shadow candidates only, without the tree). A quad's
/// box is tested before its edges, as a leaf's box is in the tree (and as safely: the
/// slab test's scaled reciprocals keep every lane the quad test accepts).
#[inline(always)]
fn occluded_among<L: Lane>(
    q: &mut PacketQuery<'_, '_, L>,
    light: ShadowLanes<L>,
    lanes: u32,
    among: Candidates<'_>,
) -> u32 {
    let p = q.p;
    let mut remaining = lanes & p.active;
    let t_max = in_play(remaining, light.t_light);
    let t_min_l = L::splat(light.t_min);
    for (kind, range) in among.runs() {
        if kind == PrimKind::Quad {
            for i in range {
                let (lo, hi) = among.quad_box(i);
                let inside = p.test_box(lo, hi, t_min_l, t_max).1 & remaining;
                if inside == 0 {
                    continue;
                }
                q.stats.prims += inside.count_ones() as u64;
                let quad = PrimKind::Quad;
                remaining &= !occluders(q, light, quad, i..i + 1, inside, t_max);
                if remaining == 0 {
                    return lanes & p.active;
                }
            }
            continue;
        }
        q.stats.prims += (range.len() * remaining.count_ones() as usize) as u64;
        let l = remaining;
        remaining &= !kind.specialize(|k| occluders(q, light, k, range, l, t_max));
        if remaining == 0 {
            break;
        }
    }
    lanes & p.active & !remaining
}

/// The kind of a light's primitives.
#[inline(always)]
fn light_kind(shape: &LightShape) -> PrimKind {
    match shape {
        LightShape::Point { .. } => PrimKind::Sphere,
        LightShape::Quads(_) => PrimKind::Quad,
        LightShape::Triangles(_) => PrimKind::Triangle,
    }
}

/// `Light::nearest_hit` lane-wise for the lanes of `lanes` of `q`'s packet: each lane's
/// `(t, id)` (the id in an f32's bits) and the lanes that meet the light.
#[inline(always)]
pub(crate) fn light_hits<L: Lane>(
    q: &mut PacketQuery<'_, '_, L>,
    light: &Light,
    t_min: f32,
    lanes: u32,
) -> (L, L, u32) {
    let p = q.p;
    match &light.shape {
        LightShape::Point { center, radius } => {
            let (t, hits) = p.sphere(*center, *radius, t_min, f32::INFINITY, lanes);
            (t, L::splat(f32::from_bits(light.first_id)), hits)
        }
        LightShape::Quads(qs) => p.quad_light_hits(qs, light.first_id, t_min, lanes, &mut q.tris),
        LightShape::Triangles(ts) => {
            p.triangle_light_hits(ts, light.first_id, t_min, lanes, &mut q.tris)
        }
    }
}

impl Bvh {
    /// Shadow rays: the lanes of `lanes` that `light` (lane `k` asking `light.lane(k)`)
    /// finds occluded, exactly as `occluded` answers for each lane's ray.
    pub fn occluded_packet<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        mut light: ShadowLanes<L>,
        lanes: u32,
    ) -> u32 {
        let scene = cx.scene;
        // The kind of the object's primitives when it is a light (an object is one
        // sphere, quads or triangles); `None`: any kind may be the object's.
        light.kind = scene
            .lights
            .iter()
            .find(|l| l.object == light.object)
            .map(|l| light_kind(&l.shape));
        self.occluded_lanes(
            &mut PacketQuery::new(cx, p),
            light,
            lanes,
            &[u32::MAX; 3],
            true,
        )
    }

    /// `Accel::light_visible` for the active lanes of `p` in `lanes`: the mask of those
    /// that see `light`. The light's own hits and the occluders share the packet's
    /// watertight lanes (made once, at the first quad or triangle edge test). With
    /// `among` (`shadow::ShadowBoxes::candidates` of the lanes' origins), only those
    /// primitives are tested as occluders: without the tree in a small scene, and the
    /// tree only when the shaft meets its box in one with a tree.
    pub fn light_visible_packet<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        light: &Light,
        lanes: u32,
        among: Option<Among<'_>>,
    ) -> u32 {
        let lanes = lanes & p.active;
        if lanes == 0 {
            return 0;
        }
        if light.primitives() > LIGHT_PRIMITIVES_SCANNED {
            let mut cx = cx;
            cx.stats.single_lanes += lanes.count_ones() as u64;
            return lanes_where(lanes, |k| {
                self.nearest_is_light(cx.reborrow(), &p.ray(k), t_min, light)
            });
        }
        let mut q = PacketQuery::new(cx, p);
        let (t_light, id_light, reach) = light_hits(&mut q, light, t_min, lanes);
        if reach == 0 {
            return 0;
        }
        let own = ShadowLanes {
            t_min,
            t_light,
            id_light,
            object: light.object,
            kind: Some(light_kind(&light.shape)),
        };
        let (kept, tree) = match among {
            Some(Among::Only(c)) => return reach & !occluded_among(&mut q, own, reach, c),
            Some(Among::Beside { kept, tree }) => (kept, tree),
            None => ([u32::MAX; 3], true),
        };
        // (One call: the traversal is inlined where it is called.)
        reach & !self.occluded_lanes(&mut q, own, reach, &kept, tree)
    }

    /// `occluded_packet` with the light as lanes, over the primitives beside the tree of
    /// `kept` (`beside_runs`) and the tree when `tree`.
    #[inline(always)]
    fn occluded_lanes<L: Lane>(
        &self,
        q: &mut PacketQuery<'_, '_, L>,
        light: ShadowLanes<L>,
        lanes: u32,
        kept: &[u32; 3],
        tree: bool,
    ) -> u32 {
        let p = q.p;
        let mut remaining = lanes & p.active;
        let mut occluded = 0u32;
        // Lanes not tested get t_max = −∞ (no box or primitive test passes).
        let t_min = light.t_min;
        let mut t_max = in_play(remaining, light.t_light);
        self.beside_runs(
            kept,
            #[inline(always)]
            |kind, run| {
                if remaining == 0 {
                    return false;
                }
                q.stats.prims += (run.len() * remaining.count_ones() as usize) as u64;
                let l = remaining;
                let found = kind.specialize(|k| occluders(q, light, k, run, l, t_max));
                occluded |= found;
                remaining &= !found;
                true
            },
        );
        let Some(root) = self.root.filter(|_| tree) else {
            return occluded;
        };
        if remaining == 0 {
            return occluded;
        }
        t_max = in_play(remaining, t_max);
        // The tree's box first (`Bvh::tree_box_first`): most `bunny` shadow packets
        // (75%) pass beside it, and one box costs a quarter of the root's four. A ray
        // outside a box is outside every box within it (the slab test is monotone in
        // the planes), so the lanes that miss it leave the traversal.
        let entered = self.enters_tree(p, t_min, t_max) & remaining;
        if entered == 0 {
            return occluded;
        }
        let fallback = RayPacket::<L>::shadow_fallback();
        let mut slots = MaybeUninit::<[_; STACK4]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        stack.push((root, entered));
        while remaining != 0 {
            let Some((code, lanes)) = stack.pop() else {
                break;
            };
            let lanes = lanes & remaining;
            if lanes == 0 {
                continue;
            }
            let mut found = 0;
            if code & LEAF != 0 {
                let (kind, start, count) = decode_leaf(code);
                q.stats.prims += (count * lanes.count_ones()) as u64;
                let range = start as usize..(start + count) as usize;
                found = occluders(q, light, kind, range, lanes, t_max);
            } else {
                q.stats.nodes += 1;
                q.stats.packet_nodes += 1;
                q.stats.packet_lanes += lanes.count_ones() as u64;
                let node = &self.nodes[code as usize];
                let t_max_l = in_play(lanes, t_max);
                // As in `closest_hit_packet`: the four boxes, then one mask.
                let t_min_l = L::splat(t_min);
                let test = |c| p.test_child(node, c, t_min_l, t_max_l).1 & lanes;
                let tested: [u32; 4] = [test(0), test(1), test(2), test(3)];
                let entered = tested
                    .iter()
                    .enumerate()
                    .fold(0u32, |m, (c, &b)| m | ((b != 0) as u32) << c);
                for c in set_lanes(entered) {
                    let child = node.child[c];
                    debug_assert!(child != EMPTY);
                    let bits = tested[c] & !found;
                    if bits == 0 {
                        continue;
                    }
                    if bits.count_ones() <= fallback {
                        q.stats.single_lanes += bits.count_ones() as u64;
                        for k in set_lanes(bits) {
                            let ray = p.ray(k);
                            let (mut rq, bray) = RayQuery::with_box4(q.context(), &ray);
                            if self.occluded_from(&mut rq, child, &bray, light.lane(k)) {
                                found |= 1 << k;
                            }
                        }
                        continue;
                    }
                    // A leaf child is tested here, without a push and pop.
                    if child & LEAF != 0 {
                        let (kind, start, count) = decode_leaf(child);
                        q.stats.prims += (count * bits.count_ones()) as u64;
                        let range = start as usize..(start + count) as usize;
                        found |= occluders(q, light, kind, range, bits, t_max_l);
                        continue;
                    }
                    stack.push((child, bits));
                }
            }
            if found != 0 {
                occluded |= found;
                remaining &= !found;
                t_max = in_play(remaining, t_max);
            }
        }
        occluded
    }
}
