//! A packet's closest hits through the BVH (`Bvh::closest_hit_packet`): the lane-wise
//! traversal of the 4-wide nodes, and the frustum of a camera packet over the 8-wide ones.

use super::node::{decode_leaf, Node8, Wide, EMPTY, LEAF};
use super::single::RayQuery;
use super::Bvh;
use crate::accel::packet::{ids, in_play, PacketQuery, RayPacket};
use crate::accel::stack::{TraversalStack, STACK4, STACK8};
use crate::accel::Context;
use crate::geometry::{beats, Hit, PrimKind};
use crate::lanes::MAX_WIDTH;
use crate::lanes::{lanes_where, set_lanes, Lane, Mask};
use std::mem::MaybeUninit;
use wide::f32x8;

/// A packet whose rays share their origin and each axis' direction sign, bounded as one
/// frustum: per axis the smallest and largest of the lanes' margin reciprocals. One
/// 4-wide pass then tests a node's four children for the whole packet
/// (`Frustum::test`), where the lane-wise test costs four 8-wide passes and the masks'
/// bookkeeping (camera packets of `bunny-closeup`).
///
/// Why it is conservative: a lane's slab test computes `(plane − o) · inv` for its own
/// `inv`, and for a fixed `plane − o` the rounded product is monotone in `inv` (rounding
/// is monotone), so the smaller of the products with the smallest and the largest `inv`
/// is at most every lane's entry on that axis, and the larger at least every lane's
/// exit. With every lane's `t_max` at most `t_far`, a box the bounds reject is missed by
/// every lane. The reciprocals must be finite and nonzero: no 0 · ∞ (a NaN the lane test
/// treats as "no constraint") can arise then.
#[derive(Clone, Copy, Debug)]
struct Frustum {
    origin: [f32; 3],
    /// (smallest, largest) over the lanes of `inv_near` and of `inv_far`, per axis.
    near: [(f32, f32); 3],
    far: [(f32, f32); 3],
    rows: ([usize; 3], [usize; 3]),
}

impl Frustum {
    /// `None` unless every lane has the origin of lane 0 and the same direction signs,
    /// and all reciprocals are finite and nonzero. Every lane counts, active or not (the
    /// bounds then hold for more rays than needed, which is still conservative).
    fn new<L: Lane>(p: &RayPacket<L>) -> Option<Frustum> {
        let rows = p.box_rows?;
        let all = (1u32 << L::WIDTH) - 1;
        let o = [p.origin.x, p.origin.y, p.origin.z];
        let mut origin = [0.0; 3];
        let mut near = [(0.0, 0.0); 3];
        let mut far = [(0.0, 0.0); 3];
        let usable = |v: L| {
            let a = v.abs();
            a.lt(L::splat(f32::INFINITY)).bits() & a.gt(L::splat(0.0)).bits() == all
        };
        let range = |v: L| (v.reduce_min(), v.reduce_max());
        for a in 0..3 {
            let o0 = o[a].lane(0);
            if o[a].eq(L::splat(o0)).bits() != all {
                return None;
            }
            if !usable(p.inv_near[a]) || !usable(p.inv_far[a]) {
                return None;
            }
            origin[a] = o0;
            near[a] = range(p.inv_near[a]);
            far[a] = range(p.inv_far[a]);
        }
        Some(Frustum {
            origin,
            near,
            far,
            rows,
        })
    }

    /// Lower bounds of the lanes' entry distances into the eight children of `node`,
    /// and the children some lane may enter within `[t_min, t_far]`.
    #[inline(always)]
    fn test(&self, node: &Node8, t_min: f32, t_far: f32) -> ([f32; 8], u32) {
        let (e, mask) = self.bounds(|r| f32x8::from(node.row(r)), t_min, t_far);
        (e.to_array(), mask)
    }

    /// `test` on rows in `V`'s lanes: `row(r)` is row `r` of the node (one plane of
    /// every child). Generic so that `min` and `max` are `Lane`'s (`vminps`, `vmaxps`),
    /// not `f32x8`'s own, which handle NaNs (none here: the reciprocals are finite and
    /// nonzero) at a cost.
    #[inline(always)]
    fn bounds<V: Lane>(&self, row: impl Fn(usize) -> V, t_min: f32, t_far: f32) -> (V, u32) {
        let (mut enter, mut exit) = (V::splat(t_min), V::splat(t_far));
        for a in 0..3 {
            let o = V::splat(self.origin[a]);
            let dn = row(self.rows.0[a]) - o;
            let (lo, hi) = (V::splat(self.near[a].0), V::splat(self.near[a].1));
            enter = enter.max((dn * lo).min(dn * hi));
            let df = row(self.rows.1[a]) - o;
            let (lo, hi) = (V::splat(self.far[a].0), V::splat(self.far[a].1));
            exit = exit.min((df * lo).max(df * hi));
        }
        (enter, enter.le(exit).bits())
    }
}

/// The bits that every lane of `lanes` (not empty) of `v` holds, when they all hold the
/// same, by one lane compare: bits below 2³¹ − 2²³ are a float's that equals only
/// itself. At width 1, lane 0's without a compare (a compare there cost the scalar
/// `quads` render 2% more instructions, in spills).
#[inline(always)]
fn same_bits<L: Lane>(v: L, lanes: u32) -> Option<u32> {
    if L::WIDTH == 1 {
        return Some(v.lane(0).to_bits());
    }
    let first = v.broadcast(lanes.trailing_zeros() as usize);
    let bits = first.lane(0).to_bits();
    debug_assert!(bits < 0x7f80_0000);
    (v.eq(first).bits() & lanes == lanes).then_some(bits)
}

/// The closest hits of a packet's lanes (`closest_hit_packet`), all in lanes: while
/// traversing, a winning primitive costs four selects, not a loop over its lanes.
#[derive(Clone, Copy, Debug)]
pub struct PacketHits<L> {
    /// The lanes with a hit.
    pub found: u32,
    /// The lanes' hit distance (during traversal, the best so far): +∞ without a hit,
    /// −∞ for lanes not traced.
    pub t: L,
    /// The lanes' primitive (its index in its kind's pool), its id and its object,
    /// each in the bits of an f32. Only moved by splats and selects, never computed
    /// with, so the bits stay as written.
    index: L,
    id: L,
    object: L,
    /// The lanes whose hit is a sphere, a quad, a triangle (`PrimKind::slot`).
    kinds: [u32; 3],
}

impl<L: Lane> PacketHits<L> {
    /// No hits: the lanes of `active` at +∞, the others at −∞.
    #[inline(always)]
    pub fn none(active: u32) -> Self {
        Self {
            found: 0,
            t: L::select(
                L::Mask::from_bits(active),
                L::splat(f32::INFINITY),
                L::splat(f32::NEG_INFINITY),
            ),
            index: L::splat(0.0),
            id: L::splat(0.0),
            object: L::splat(0.0),
            kinds: [0; 3],
        }
    }

    /// No hits, each lane of `active` taking only a hit at a distance up to its lane of
    /// `t_max` (a hit at exactly `t_max` whatever its id); the others at −∞.
    #[inline(always)]
    pub fn within(active: u32, t_max: L) -> Self {
        Self {
            t: L::select(
                L::Mask::from_bits(active),
                t_max,
                L::splat(f32::NEG_INFINITY),
            ),
            ..Self::none(active)
        }
    }

    /// Lane `k`'s hit.
    #[inline(always)]
    pub fn hit(&self, k: usize) -> Option<Hit> {
        if self.found >> k & 1 == 0 {
            return None;
        }
        let kind = if self.kinds[0] >> k & 1 != 0 {
            PrimKind::Sphere
        } else if self.kinds[1] >> k & 1 != 0 {
            PrimKind::Quad
        } else {
            PrimKind::Triangle
        };
        Some(Hit {
            t: self.t.lane(k),
            id: self.id.lane(k).to_bits(),
            kind,
            index: self.index.lane(k).to_bits(),
            object: self.object.lane(k).to_bits(),
        })
    }

    /// Every lane's hit, as `closest_hit` gives it.
    #[inline(always)]
    pub fn to_array(&self) -> [Option<Hit>; MAX_WIDTH] {
        let mut out = [None; MAX_WIDTH];
        for k in set_lanes(self.found) {
            out[k] = self.hit(k);
        }
        out
    }

    /// Lane `k`'s object (meaningful in the lanes of `found`).
    #[inline(always)]
    pub fn object_of(&self, k: usize) -> u32 {
        self.object.lane(k).to_bits()
    }

    /// The lanes of `found` whose object is `object`, by one lane compare: the bits of
    /// an object number below 2³¹ − 2²³ are a float's that equals only itself (not a
    /// NaN, and no object number has −0's bits).
    #[inline(always)]
    pub fn of_object(&self, object: u32) -> u32 {
        debug_assert!(object < 0x7f80_0000);
        self.object.eq(L::splat(f32::from_bits(object))).bits() & self.found
    }

    /// The object that every lane of `lanes` (not empty) hits, when they all hit the
    /// same one, by one lane compare (`of_object`).
    #[inline(always)]
    pub fn same_object(&self, lanes: u32) -> Option<u32> {
        same_bits(self.object, lanes)
    }

    /// The primitive that every lane of `lanes` (not empty) hits, when they all hit the
    /// same one: its index, by one lane compare (an index's bits are a float's that
    /// equals only itself, as an object's are in `of_object`).
    #[inline(always)]
    pub fn same_index(&self, lanes: u32) -> Option<usize> {
        same_bits(self.index, lanes).map(|i| i as usize)
    }

    /// The lanes whose hit is of `kind`.
    #[inline(always)]
    pub fn of_kind(&self, kind: PrimKind) -> u32 {
        self.kinds[kind.slot()]
    }

    /// The lanes' objects (meaningful in the lanes of `found`).
    #[inline(always)]
    pub fn objects(&self) -> [u32; MAX_WIDTH] {
        std::array::from_fn(|k| {
            if k < L::WIDTH {
                self.object.lane(k).to_bits()
            } else {
                0
            }
        })
    }

    /// The lanes' primitives' indices in their kind's pool (meaningful in the lanes of
    /// `found`).
    #[inline(always)]
    pub fn indices(&self) -> [usize; MAX_WIDTH] {
        std::array::from_fn(|k| {
            if k < L::WIDTH {
                self.index.lane(k).to_bits() as usize
            } else {
                0
            }
        })
    }

    /// The lanes of `lanes` now hit a primitive of `kind`.
    #[inline(always)]
    fn set_kind(&mut self, kind: PrimKind, lanes: u32) {
        for (slot, m) in self.kinds.iter_mut().enumerate() {
            *m = if slot == kind.slot() {
                *m | lanes
            } else {
                *m & !lanes
            };
        }
    }

    /// The hits of `found` on the lanes of `lanes`, made in an instance's mesh at `t` of
    /// rays moved by `dt`, in the world's terms (`Instance::world_hit` lane-wise: `t +
    /// dt`, ids and objects offset by `first_id` and `first_object`), each kept where it
    /// beats the lane's hit by the `(t, id)` rule (`keep_closest`). Lane by lane, each
    /// hit taken out of the lanes and put back cost ~90 instructions.
    #[inline(always)]
    pub fn keep_placed(
        &mut self,
        found: &PacketHits<L>,
        lanes: u32,
        dt: L,
        first_id: u32,
        first_object: u32,
    ) {
        let lanes = lanes & found.found;
        if lanes == 0 {
            return;
        }
        let t = found.t + dt;
        let id = found.id.add_bits(first_id as i32);
        let nearer = t.lt(self.t).bits();
        // Equal distances (rare): the smaller id, compared as the integers it holds.
        let tie = lanes & self.found & t.eq(self.t).bits() & !nearer;
        let smaller = lanes_where(tie, |k| id.lane(k).to_bits() < self.id.lane(k).to_bits());
        let take = lanes & (!self.found | nearer | smaller);
        if take == 0 {
            return;
        }
        let m = L::Mask::from_bits(take);
        self.t = L::select(m, t, self.t);
        self.id = L::select(m, id, self.id);
        self.index = L::select(m, found.index, self.index);
        let object = found.object.add_bits(first_object as i32);
        self.object = L::select(m, object, self.object);
        self.found |= take;
        for (mine, theirs) in self.kinds.iter_mut().zip(found.kinds) {
            *mine = (*mine & !take) | (theirs & take);
        }
    }

    /// Lane `k` takes distance bound `t` and best hit `best` (from the scalar traversal).
    #[inline(always)]
    pub fn set(&mut self, k: usize, t: f32, best: Option<Hit>) {
        let m = L::Mask::from_bits(1 << k);
        self.t = L::select(m, L::splat(t), self.t);
        if let Some(h) = best {
            self.index = L::select(m, L::splat(f32::from_bits(h.index)), self.index);
            self.id = L::select(m, L::splat(f32::from_bits(h.id)), self.id);
            self.object = L::select(m, L::splat(f32::from_bits(h.object)), self.object);
            self.found |= 1 << k;
            self.set_kind(h.kind, 1 << k);
        }
    }

    /// The primitives `range` of `kind` on the lanes of `lanes`: a lane takes a
    /// primitive that beats its closest hit so far by the `(t, id)` rule.
    #[inline(always)]
    fn leaf(
        &mut self,
        q: &mut PacketQuery<'_, '_, L>,
        kind: PrimKind,
        range: std::ops::Range<usize>,
        t_min: f32,
        lanes: u32,
    ) {
        let scene = q.scene;
        // The best hits in a local copy, written back once: selected into `self` in
        // place, the compiler made masked stores of them (`vmaskmovps`), slow on AMD
        // and read back past store-to-load forwarding.
        let mut best = *self;
        for i in range {
            let (t, bits) = q.test_prim(kind, i, t_min, best.t, lanes);
            if bits == 0 {
                continue;
            }
            // A hit lane has t ≤ t_max: the nearer wins (`beats`); at an equal distance
            // to a hit already found, the smaller id.
            let (id, object) = ids(scene, kind, i);
            let mut win = bits;
            let tie = t.eq(best.t).bits() & bits & best.found;
            for k in set_lanes(tie) {
                if !beats((t.lane(k), id), (t.lane(k), best.id.lane(k).to_bits())) {
                    win &= !(1 << k);
                }
            }
            let m = L::Mask::from_bits(win);
            let bits_of = |x: u32| L::splat(f32::from_bits(x));
            best.t = L::select(m, t, best.t);
            best.index = L::select(m, bits_of(i as u32), best.index);
            best.id = L::select(m, bits_of(id), best.id);
            best.object = L::select(m, bits_of(object), best.object);
            best.found |= win;
            best.set_kind(kind, win);
        }
        *self = best;
    }
}

impl Bvh {
    /// The lanes whose ray may enter the tree: those that meet its box within
    /// `[t_min, t_max]` if `tree_box_first`, else all those with `t_max ≥ t_min` (the
    /// root's children are tested anyway).
    #[inline(always)]
    pub(super) fn enters_tree<L: Lane>(&self, p: &RayPacket<L>, t_min: f32, t_max: L) -> u32 {
        if !self.tree_box_first {
            return t_max.ge(L::splat(t_min)).bits();
        }
        let b = &self.tree_box;
        let (_, bits) = p.test_box(b.min.to_array(), b.max.to_array(), L::splat(t_min), t_max);
        bits
    }

    /// The closest hit of every active lane in `[t_min, ∞)`, exactly as `closest_hit`
    /// returns it for that lane's ray.
    #[inline(always)]
    pub fn closest_hit_packet<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
    ) -> PacketHits<L> {
        self.closest_from(cx, p, t_min, None)
    }

    /// `closest_hit_packet` from the bounds and hits of `st` (`PacketHits::within`: a
    /// lane takes only a hit in `[t_min, st.t]`).
    #[inline(always)]
    pub fn closest_hit_packet_within<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        st: PacketHits<L>,
    ) -> PacketHits<L> {
        self.closest_from(cx, p, t_min, Some(&st))
    }

    /// `closest_hit_packet_within` from `st`, or from no hits (`PacketHits::none`) made
    /// here: a packet's hits made by its caller went through memory into the call
    /// (11 instructions a camera or secondary packet, 0.5% of `mixed` 8 wide).
    fn closest_from<L: Lane>(
        &self,
        cx: Context<'_>,
        p: &RayPacket<L>,
        t_min: f32,
        st: Option<&PacketHits<L>>,
    ) -> PacketHits<L> {
        let q = &mut PacketQuery::new(cx, p);
        let mut st = match st {
            Some(st) => *st,
            None => PacketHits::none(p.active),
        };
        self.beside_runs(
            &p.cull.beside,
            #[inline(always)]
            |kind, run| {
                q.stats.prims += (run.len() * p.active.count_ones() as usize) as u64;
                kind.specialize(|k| st.leaf(q, k, run, t_min, p.active));
                true
            },
        );
        let Some(root) = self.root else {
            return st;
        };
        if !p.cull.tree {
            return st;
        }
        // As in `occluded_packet`: the tree's box first.
        let mut lanes = self.enters_tree(p, t_min, st.t) & p.active;
        if lanes == 0 {
            return st;
        }
        // Through the 8-wide nodes (built with the 4-wide ones, so present with them):
        // one 8-lane bound test a node, two thirds of the levels (`packet_probe
        // bunny-closeup 8`: 67.2M → 66.0M instructions; at 4 wide 130.4M → 123.2M).
        if let (true, Some(fr), Some(root8)) = (p.cull.frustum, Frustum::new(p), self.root8) {
            self.closest_frustum(q, &fr, root8, lanes, t_min, &mut st);
            return st;
        }
        let fallback = RayPacket::<L>::fallback();
        let mut slots = MaybeUninit::<[_; STACK4]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        // The node being visited and its lanes. The nearest child a node's lanes enter
        // is visited next without a trip through the stack (most nodes of a coherent
        // packet have one); the others are pushed, farthest first.
        let mut code = root;
        loop {
            if lanes != 0 && code & LEAF != 0 {
                let (kind, start, count) = decode_leaf(code);
                q.stats.prims += (count * lanes.count_ones()) as u64;
                let range = start as usize..(start + count) as usize;
                kind.specialize(|k| st.leaf(q, k, range, t_min, lanes));
            } else if lanes != 0 {
                q.stats.nodes += 1;
                q.stats.packet_nodes += 1;
                q.stats.packet_lanes += lanes.count_ones() as u64;
                let node = &self.nodes[code as usize];
                let t_max = in_play(lanes, st.t);
                // All four boxes first, with no branch between them (an empty slot's box
                // is inverted and never hit): which children a packet enters is a coin
                // toss for the branch predictor, so it is asked once, as a 4-bit mask.
                let t_min_l = L::splat(t_min);
                let test = |c| {
                    let (entry, bits) = p.test_child(node, c, t_min_l, t_max);
                    (entry, bits & lanes)
                };
                let tested: [(L, u32); 4] = [test(0), test(1), test(2), test(3)];
                let entered = tested
                    .iter()
                    .enumerate()
                    .fold(0u32, |m, (c, t)| m | ((t.1 != 0) as u32) << c);
                let mut hits = [(0u32, 0u32, 0f32); 4];
                let mut finished_alone = false;
                let mut n = 0;
                for c in set_lanes(entered) {
                    let (entry, bits) = tested[c];
                    let child = node.child[c];
                    debug_assert!(child != EMPTY);
                    if bits.count_ones() <= fallback {
                        q.stats.single_lanes += bits.count_ones() as u64;
                        for k in set_lanes(bits) {
                            let ray = p.ray(k);
                            let (mut rq, bray) = RayQuery::with_box4(q.context(), &ray);
                            let mut t_max = st.t.lane(k);
                            let mut best = st.hit(k);
                            let (t_max, best) = (&mut t_max, &mut best);
                            self.closest_hit_from(&mut rq, child, &bray, t_min, t_max, best);
                            st.set(k, *t_max, *best);
                        }
                        finished_alone = true;
                        continue;
                    }
                    let d = L::select(L::Mask::from_bits(bits), entry, L::splat(f32::INFINITY))
                        .reduce_min();
                    // Insert sorted, farthest first, so the nearest is last.
                    let mut j = n;
                    while j > 0 && hits[j - 1].2 < d {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = (child, bits, d);
                    n += 1;
                }
                if n > 0 {
                    for h in &hits[..n - 1] {
                        stack.push(*h);
                    }
                    let (child, bits, d) = hits[n - 1];
                    code = child;
                    // The lanes' `t_max` can have changed only if some were finished alone.
                    lanes = if finished_alone {
                        st.t.ge(L::splat(d)).bits() & bits
                    } else {
                        bits
                    };
                    continue;
                }
            }
            // Pop the next subtree. Lanes whose closest hit is already nearer than the
            // box's entry (the smallest over the lanes that entered it) leave it.
            let Some((next, next_lanes, enter)) = stack.pop() else {
                break;
            };
            code = next;
            lanes = st.t.ge(L::splat(enter)).bits() & next_lanes;
        }
        st
    }

    /// `closest_hit_packet`'s tree traversal for a packet bounded by a frustum: each node
    /// tests its four children once for the whole packet (`Frustum::test`), visits the
    /// nearest next and pushes the others, farthest first (the scalar traversal's order),
    /// and a leaf tests its primitives on the lanes of `lanes` whose closest hit is not
    /// nearer than the leaf's entry bound. A subtree is skipped once its entry bound is
    /// beyond every lane's closest hit. Which nodes are visited changes, never what a
    /// lane finds: the bounds are conservative (`Frustum`) and a leaf's test is exact.
    fn closest_frustum<L: Lane>(
        &self,
        q: &mut PacketQuery<'_, '_, L>,
        fr: &Frustum,
        root: u32,
        lanes: u32,
        t_min: f32,
        st: &mut PacketHits<L>,
    ) {
        // The farthest closest hit of the lanes (+∞ while one has none).
        let far = |st: &PacketHits<L>| in_play(lanes, st.t).reduce_max();
        let mut t_far = far(st);
        let mut slots = MaybeUninit::<[_; STACK8]>::uninit();
        let mut stack = TraversalStack::new(&mut slots);
        let (mut code, mut enter) = (root, t_min);
        'visit: loop {
            if code & LEAF != 0 {
                let (kind, start, count) = decode_leaf(code);
                let leaf_lanes = st.t.ge(L::splat(enter)).bits() & lanes;
                if leaf_lanes != 0 {
                    q.stats.prims += (count * leaf_lanes.count_ones()) as u64;
                    let range = start as usize..(start + count) as usize;
                    kind.specialize(|k| st.leaf(q, k, range, t_min, leaf_lanes));
                    t_far = far(st);
                }
            } else {
                q.stats.nodes += 1;
                q.stats.packet_nodes += 1;
                q.stats.packet_lanes += lanes.count_ones() as u64;
                let node = &self.nodes8[code as usize];
                let (entry, mut mask) = fr.test(node, t_min, t_far);
                // A leaf child is tested here, on the lanes whose own box test enters
                // it: the frustum holds the space between the rays too, and where
                // triangles are smaller than the packet's footprint most of the leaves
                // it meets hold no lane's hit.
                for c in set_lanes(mask) {
                    let child = node.child(c);
                    if child & LEAF == 0 {
                        continue;
                    }
                    mask &= !(1 << c);
                    let (lo, hi) = node.child_box(c);
                    let t_max = in_play(lanes, st.t);
                    let (_, leaf_lanes) = q.p.test_box(lo, hi, L::splat(t_min), t_max);
                    q.stats.frustum_leaves += 1;
                    q.stats.frustum_leaf_lanes += leaf_lanes.count_ones() as u64;
                    if leaf_lanes != 0 {
                        let (kind, start, count) = decode_leaf(child);
                        q.stats.prims += (count * leaf_lanes.count_ones()) as u64;
                        let range = start as usize..(start + count) as usize;
                        kind.specialize(|k| st.leaf(q, k, range, t_min, leaf_lanes));
                        t_far = far(st);
                    }
                }
                if mask != 0 {
                    // As the scalar traversal orders them (the bounds are at least
                    // t_min, so positive).
                    let s = node.push_farther(mask, &entry, &mut stack);
                    (code, enter) = (node.child(s), entry[s & 7]);
                    continue 'visit;
                }
            }
            // Pop the next subtree some lane may still find something nearer in.
            while let Some((next, e)) = stack.pop() {
                if e <= t_far {
                    (code, enter) = (next, e);
                    continue 'visit;
                }
            }
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;

    /// `same_index` and `same_object` answer what a loop over the lanes answers, for
    /// every lane mask and lanes on numbers whose bits are subnormal floats (1, 2), zero,
    /// a normal float's and the largest allowed.
    fn same_as_a_loop<L: Lane>() {
        let numbers = [0u32, 1, 2, 0x3f80_0000, 0x7f7f_ffff];
        let width = L::WIDTH as u32;
        // Each lane's number: digits of `code` in base 5.
        for code in 0..5u32.pow(width.min(5)) {
            let of_lane = |k: u32| numbers[(code / 5u32.pow(k % 5) % 5) as usize];
            let mut hits = PacketHits::<L>::none((1 << width) - 1);
            for k in 0..width {
                let n = of_lane(k);
                let hit = Hit {
                    t: 1.0,
                    id: 0,
                    kind: PrimKind::Quad,
                    index: n,
                    object: n ^ 1,
                };
                hits.set(k as usize, 1.0, Some(hit));
            }
            for lanes in 1..1u32 << width {
                let first = of_lane(lanes.trailing_zeros());
                let same = (0..width).all(|k| lanes >> k & 1 == 0 || of_lane(k) == first);
                let index = same.then_some(first as usize);
                assert_eq!(hits.same_index(lanes), index, "{code} {lanes:b}");
                assert_eq!(hits.same_object(lanes), same.then_some(first ^ 1));
            }
        }
    }

    /// `keep_placed` keeps, on each lane, what `keep_closest` keeps of the lane's hit and
    /// the placed hit (`t + dt`, ids and objects offset): none yet, nearer, farther, and
    /// ties on `t` decided by the ids as integers (ids past 2³¹, whose bits are negative
    /// floats, among them).
    fn keep_placed_as_one_hit_at_a_time<L: Lane>() {
        let width = L::WIDTH as u32;
        let all = (1u32 << width) - 1;
        let kinds = [PrimKind::Sphere, PrimKind::Quad, PrimKind::Triangle];
        let ids = [0u32, 7, 9, 0x7000_0001];
        let hit = |t: f32, id: u32, k: u32| Hit {
            t,
            id,
            kind: kinds[(id % 3 + k) as usize % 3],
            index: id ^ k,
            object: id / 2 + k,
        };
        for (first_id, first_object) in [(0u32, 0u32), (2, 5), (0x8000_0000, 3)] {
            // Lane k's case: digit k of `code` in base 4 (no hit yet; the lane's hit
            // farther; a tie on t; the lane's hit nearer).
            for code in 0..4u32.pow(width.min(4)) {
                let case = |k: u32| code / 4u32.pow(k % 4) % 4;
                let dt = L::from_fn(|k| if case(k as u32) == 2 { 1.0 } else { 0.0 });
                let mut hits = PacketHits::<L>::none(all);
                let mut found = PacketHits::<L>::none(all);
                let mut expect = Vec::new();
                for k in 0..width {
                    let c = case(k);
                    let old = hit(
                        [0.0, 2.0, 2.0, 0.5][c as usize],
                        ids[k as usize % 4] + first_id,
                        k,
                    );
                    if c != 0 {
                        hits.set(k as usize, old.t, Some(old));
                    }
                    let new = hit(1.0, ids[(k as usize + 1) % 4], k + 1);
                    found.set(k as usize, new.t, Some(new));
                    let placed = Hit {
                        t: new.t + dt.lane(k as usize),
                        id: new.id + first_id,
                        object: new.object + first_object,
                        ..new
                    };
                    let mut best = (c != 0).then_some(old);
                    crate::geometry::keep_closest(&mut best, placed);
                    expect.push(best);
                }
                for lanes in [all, 0b1010 & all] {
                    let mut kept = hits;
                    kept.keep_placed(&found, lanes, dt, first_id, first_object);
                    for (k, &want) in expect.iter().enumerate() {
                        let want = if lanes >> k & 1 != 0 {
                            want
                        } else {
                            hits.hit(k)
                        };
                        assert_eq!(kept.hit(k), want, "lane {k}, code {code}, lanes {lanes:b}");
                    }
                }
            }
        }
    }

    #[test]
    fn keep_placed_keeps_what_one_hit_at_a_time_keeps() {
        keep_placed_as_one_hit_at_a_time::<f32>();
        keep_placed_as_one_hit_at_a_time::<Vec4>();
        keep_placed_as_one_hit_at_a_time::<f32x8>();
        keep_placed_as_one_hit_at_a_time::<crate::lanes::F32x16>();
    }

    #[test]
    fn same_index_and_object_are_a_loop_over_the_lanes() {
        same_as_a_loop::<f32>();
        same_as_a_loop::<Vec4>();
        same_as_a_loop::<f32x8>();
        same_as_a_loop::<crate::lanes::F32x16>();
    }
}
