//! One ray through the BVH: the closest hit and the shadow rays' any-hit query
//! (`ShadowQuery`) over the 8-wide nodes, the primitives beside the tree, and the lanes a
//! packet finishes alone over the 4-wide nodes (`closest_hit_from`, `occluded_from`).
//!
//! One file of about 710 lines, all code (its tests are in `tests/bvh.rs` and
//! `tests/stress.rs`): the one-ray query context (`RayQuery`, `Closest`) and the
//! two traversals that use it, whose leaf loops and primitives beside the tree are
//! shared between the 8-wide and the 4-wide nodes.

use super::node::{decode_leaf, BoxRay, Wide, LEAF};
use super::node8::BoxRay8;
use super::{Beside, Bvh, LIGHT_PRIMITIVES_SCANNED, SPHERE_GROUP};
use crate::accel::packet::ids;
use crate::accel::stack::{TraversalStack, STACK4, STACK8};
use crate::accel::{Context, ShadowQuery, TraversalStats};
use crate::geometry::sphere::{sphere_intersect_with, SphereRay};
use crate::geometry::triangle::{Columns, WatertightRay};
use crate::geometry::{beats, Hit, PrimKind, Ray};
use crate::lanes::set_lanes;
use crate::scene::{Light, LightShape, Scene};
use glam::Vec4;
use std::mem::MaybeUninit;
use std::ops::Range;

/// What one ray's traversal carries down to its leaf loops: the scene, the counts of the
/// work done, and the ray's constants of the primitive tests and `BoxRay` (the same IEEE
/// quotients as their own constructors, so the same bits), the triangle test's computed
/// at the first triangle leaf: most camera rays of `bunny` miss the mesh's box, and the
/// axis choice, its two divisions and the pool pointers they select cost ~100
/// instructions a ray (callgrind). 1/dx, 1/dy, 1/dz and 1/(d·d) are one vector divide.
/// Shadow rays (`Bvh::light_visible`) share them between the light's own hit and the
/// occluders.
#[derive(Debug)]
pub(crate) struct RayQuery<'r, 's> {
    scene: &'r Scene,
    pub(crate) stats: &'s mut TraversalStats,
    /// Borrowed, not copied: a copy was stored in pieces and read back whole, a failed
    /// store-to-load forward on every ray (perf: 11% of the `bunny` camera-ray time).
    ray: &'r Ray,
    sphere: SphereRay,
    triangle: Option<WatertightRay>,
}

impl<'r, 's: 'r> RayQuery<'r, 's> {
    /// The query, and the box test's constants for the 4-wide tree (which the lanes a
    /// packet finishes alone traverse).
    #[inline(always)]
    pub(crate) fn with_box4(cx: Context<'s>, ray: &'r Ray) -> (Self, BoxRay) {
        let (rq, q) = Self::with_reciprocals(cx, ray);
        (rq, BoxRay::from_inv(ray, q.truncate()))
    }

    /// The query and (1/dx, 1/dy, 1/dz, 1/(d·d)).
    #[inline(always)]
    pub(crate) fn with_reciprocals(cx: Context<'s>, ray: &'r Ray) -> (Self, Vec4) {
        let d = ray.dir;
        let a = d.dot(d);
        let q = Vec4::ONE / Vec4::new(d.x, d.y, d.z, a);
        let sphere = SphereRay {
            origin: ray.origin.into(),
            dir: d.into(),
            a,
            inv_a: q.w,
        };
        let rq = RayQuery {
            scene: cx.scene,
            stats: cx.stats,
            ray,
            sphere,
            triangle: None,
        };
        (rq, q)
    }
}

impl<'r, 's> RayQuery<'r, 's> {
    /// The ray's watertight constants, made in line at the first quad test that needs
    /// them. Made out of line (`watertight_ray`) and copied out of its return slot, the
    /// copy's wide loads read what the callee had just stored a field at a time, which
    /// store-to-load forwarding does not serve: the scalar `cornell` render took 18%
    /// longer, `quads` 7% (perf, render phase).
    #[inline(always)]
    fn triangle(&mut self) -> &WatertightRay {
        let ray = self.ray;
        self.triangle.get_or_insert_with(|| make_watertight(ray))
    }

    /// `triangle` for a quad test, made only if called (past the quad's plane test) and
    /// borrowed where it is kept. A copy of it was read back with wide loads from the
    /// fields just stored, which store-to-load forwarding does not serve: the scalar
    /// `spheres` render took 6% longer.
    #[inline(always)]
    fn lazy_triangle<'q>(&'q mut self) -> impl FnOnce() -> &'q WatertightRay + use<'q, 'r, 's> {
        move || {
            let rq = self;
            rq.triangle()
        }
    }

    /// `triangle` made out of line, for the tree's triangle leaves: inlined there it
    /// made the traversal loop slower (`bunny-closeup`, scalar, 7%).
    #[inline(always)]
    fn triangle_at_leaf(&mut self) -> &WatertightRay {
        let ray = self.ray;
        self.triangle.get_or_insert_with(|| watertight_ray(ray))
    }
}

/// `make_watertight` out of line.
#[inline(never)]
fn watertight_ray(ray: &Ray) -> WatertightRay {
    make_watertight(ray)
}

/// `WatertightRay::new` with its three divisions in one vector divide.
#[inline(always)]
fn make_watertight(ray: &Ray) -> WatertightRay {
    let axes @ [kx, ky, kz] = WatertightRay::axes(ray.dir);
    let d = ray.dir.to_array();
    let o = ray.origin.to_array();
    let q = Vec4::new(d[kx], d[ky], 1.0, 1.0) / Vec4::new(d[kz], d[kz], d[kz], 1.0);
    WatertightRay {
        axes,
        origin: [o[kx], o[ky], o[kz]],
        sx: q.x,
        sy: q.y,
        sz: q.z,
    }
}

/// The closest hit so far of one scalar traversal, in plain fields (no `Option<Hit>`
/// moved per candidate). No hit yet is `(t, id) = (+∞, u32::MAX)`, which every candidate
/// beats (a candidate has t ≤ `t_max` and an id below `u32::MAX`: ids count primitives).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Closest {
    pub(crate) t_max: f32,
    t: f32,
    id: u32,
    kind: PrimKind,
    index: u32,
}

impl Closest {
    #[inline(always)]
    pub(crate) fn new(t_max: f32, best: &Option<Hit>) -> Self {
        match best {
            Some(h) => Closest {
                t_max,
                t: h.t,
                id: h.id,
                kind: h.kind,
                index: h.index,
            },
            None => Closest {
                t_max,
                t: f32::INFINITY,
                id: u32::MAX,
                kind: PrimKind::Triangle,
                index: 0,
            },
        }
    }

    /// `keep_closest` then `t_max = t`.
    #[inline(always)]
    fn offer(&mut self, t: f32, id: u32, kind: PrimKind, index: usize) {
        if beats((t, id), (self.t, self.id)) {
            self.t = t;
            self.id = id;
            self.kind = kind;
            self.index = index as u32;
        }
        self.t_max = t;
    }

    /// `offer` for each lane of `mask` whose `t` is still within `t_max`: primitive
    /// `first + k` of `kind`, its id from `ids` (lanes in pool order, as the scan offers).
    #[inline(always)]
    fn offer_lanes(&mut self, t: &[f32], mut mask: u32, first: usize, ids: &[u32], kind: PrimKind) {
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if t[k] <= self.t_max {
                let i = first + k;
                self.offer(t[k], ids[i], kind, i);
            }
        }
    }

    #[inline(always)]
    pub(crate) fn hit(&self, scene: &Scene) -> Option<Hit> {
        if self.id == u32::MAX {
            return None;
        }
        let i = self.index as usize;
        let object = match self.kind {
            PrimKind::Sphere => scene.spheres.object(i),
            PrimKind::Quad => scene.quads.object[i],
            PrimKind::Triangle => scene.triangles.object[i],
        };
        Some(Hit {
            t: self.t,
            id: self.id,
            kind: self.kind,
            index: self.index,
            object,
        })
    }

    /// Triangles `start..start + n` (n ≤ 4) in one `intersect4`, hits in pool order.
    #[inline(always)]
    fn triangles4(
        &mut self,
        scene: &Scene,
        start: usize,
        n: usize,
        ray: &WatertightRay,
        cols: &Columns,
        t_min: f32,
    ) {
        let tri = &scene.triangles;
        let (t, mask) = tri.intersect4_in(cols, start, n, ray, t_min, self.t_max);
        self.offer_lanes(&t, mask, start, &tri.id, PrimKind::Triangle);
    }

    /// The primitives `range` of `kind` (a leaf, or a pool of the linear scan): spheres
    /// and triangles four at a time, quads one at a time. The triangle test's constants
    /// are made only for quads and triangles: a sphere leaf needs none of them (two
    /// divisions and the axis choice, 11% of the instructions of a scene of 486 spheres
    /// in the tree, `trace_probe`).
    #[inline(never)]
    pub(crate) fn range(
        &mut self,
        rq: &mut RayQuery<'_, '_>,
        kind: PrimKind,
        range: Range<usize>,
        t_min: f32,
    ) {
        let scene = rq.scene;
        let mut start = range.start;
        match kind {
            PrimKind::Sphere => {
                let s = &scene.spheres;
                while start < range.end {
                    let n = (range.end - start).min(4);
                    let (t, mask) = s.intersect4(start, n, &rq.sphere, t_min, self.t_max);
                    self.offer_lanes(&t, mask, start, s.ids(), kind);
                    start += n;
                }
            }
            PrimKind::Quad => {
                let (q, ray) = (&scene.quads, rq.ray);
                for i in range {
                    let w = rq.lazy_triangle();
                    if let Some(t) = q.intersect_lazy(i, ray, w, t_min, self.t_max) {
                        self.offer(t, q.id[i], kind, i);
                    }
                }
            }
            PrimKind::Triangle => {
                let tri = *rq.triangle_at_leaf();
                let cols = scene.triangles.columns(tri.axes);
                while start < range.end {
                    let n = (range.end - start).min(4);
                    self.triangles4(scene, start, n, &tri, &cols, t_min);
                    start += n;
                }
            }
        }
    }
}

impl Bvh {
    /// Closest hit in `[t_min, t_max]` by the `(t, id)` rule. Inlined into each caller:
    /// as a call of its own (once a mesh light's shadow rays called it too) the scalar
    /// renders took 3–5% more instructions.
    #[inline(always)]
    pub fn closest_hit(&self, cx: Context<'_>, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let scene = cx.scene;
        let (mut rq, q) = RayQuery::with_reciprocals(cx, ray);
        let mut c = Closest::new(t_max, &None);
        // The tree first, the spheres beside it after: their test (a square root and a
        // division) then does not delay the root's box test, which would wait for the
        // `t_max` it produces; the ground sphere never pruned a node (same node counts on
        // `bunny` and `bunny-closeup`), and 2.5% fewer instructions a closeup ray.
        if let Some(root) = self.root8 {
            // The box constants only for a tree (`mixed`, `spheres` and `quads` have
            // none: 1.3% of `mixed`'s scalar render made them for nothing, callgrind).
            let bray = BoxRay8::from_inv(ray, q);
            traverse::<_, STACK8>(&self.nodes8, &mut rq, root, &bray, t_min, &mut c);
        }
        self.beside(&mut rq, t_min, &mut c);
        c.hit(scene)
    }

    /// The primitives beside the tree for one ray, the loop of both its queries: the
    /// spheres eight at a time (pre-packed, the bunny scene's three in one pass), then
    /// the one quad in line, or the quads and triangles out of line (`beside_pools`).
    /// `q` takes each test's hits in pool order (`HitQuery`); the answer is whether
    /// it ended the loop.
    #[inline(always)]
    fn beside<Q: HitQuery>(&self, rq: &mut RayQuery<'_, '_>, t_min: f32, q: &mut Q) -> bool {
        let scene = rq.scene;
        let spheres = &self.linear[0];
        let n = spheres.len();
        if n > 0 {
            rq.stats.prims += n as u64;
            // `SpherePool::intersect4` on the pre-packed lanes (`pack_spheres` packs
            // exactly `linear[0]`).
            debug_assert_eq!(self.linear_spheres.len(), n.div_ceil(SPHERE_GROUP));
            for (g, lanes) in self.linear_spheres.iter().enumerate() {
                let (t, mask) = lanes.intersect(&rq.sphere, t_min, q.t_max());
                // A larger `t_max` than the scan's for the group's later spheres gives
                // the same hits: a lane beyond the current `t_max` is not offered.
                let first = spheres.start + SPHERE_GROUP * g;
                if q.take(scene, PrimKind::Sphere, &t, mask, first) {
                    return true;
                }
            }
        }
        match self.beside {
            Beside::Nothing => false,
            Beside::OneQuad => {
                let one = &self.one_quad;
                rq.stats.prims += 1;
                let ray = rq.ray;
                let w = rq.lazy_triangle();
                one.intersect_lazy(ray, w, t_min, q.t_max())
                    .is_some_and(|t| q.take(scene, PrimKind::Quad, &[t], 1, one.index))
            }
            Beside::Pools if Q::POOLS_OUT_OF_LINE => {
                out_of_line(|| self.beside_pools(rq, t_min, q))
            }
            Beside::Pools => self.beside_pools(rq, t_min, q),
        }
    }

    /// `beside`'s quads, by their groups, and triangles, four at a time.
    #[inline(always)]
    fn beside_pools<Q: HitQuery>(&self, rq: &mut RayQuery<'_, '_>, t_min: f32, q: &mut Q) -> bool {
        let scene = rq.scene;
        if !self.linear[1].is_empty() {
            rq.stats.prims += self.linear[1].len() as u64;
            let (quads, ray) = (&scene.quads, rq.ray);
            for group in &self.linear_quads {
                let first = group.indices().start;
                let w = rq.lazy_triangle();
                let stop = if group.is_single() {
                    quads
                        .intersect_lazy(first, ray, w, t_min, q.t_max())
                        .is_some_and(|t| q.take(scene, PrimKind::Quad, &[t], 1, first))
                } else {
                    let (t, mask) = group.intersect(quads, ray, w, t_min, q.t_max());
                    q.take(scene, PrimKind::Quad, &t, mask, first)
                };
                if stop {
                    return true;
                }
            }
        }
        let range = self.linear[2].clone();
        if !range.is_empty() {
            rq.stats.prims += range.len() as u64;
            let (tris, w) = (&scene.triangles, *rq.triangle_at_leaf());
            let cols = tris.columns(w.axes);
            for start in range.clone().step_by(4) {
                let n = (range.end - start).min(4);
                let (t, mask) = tris.intersect4_in(&cols, start, n, &w, t_min, q.t_max());
                if q.take(scene, PrimKind::Triangle, &t, mask, start) {
                    return true;
                }
            }
        }
        false
    }

    /// Closest hit in the subtree `root` (a node or leaf code), improving on `best` and
    /// shrinking `t_max`. The packet traversal finishes lanes with it.
    #[inline]
    pub(crate) fn closest_hit_from(
        &self,
        rq: &mut RayQuery<'_, '_>,
        root: u32,
        bray: &BoxRay,
        t_min: f32,
        t_max: &mut f32,
        best: &mut Option<Hit>,
    ) {
        let mut c = Closest::new(*t_max, best);
        traverse::<_, STACK4>(&self.nodes, rq, root, bray, t_min, &mut c);
        *t_max = c.t_max;
        if let Some(h) = c.hit(rq.scene) {
            *best = Some(h);
        }
    }

    /// Does a primitive occlude the light by `query`'s rule (`ShadowQuery`)? Stops at
    /// the first occluder.
    pub fn occluded(&self, cx: Context<'_>, ray: &Ray, query: ShadowQuery) -> bool {
        let (mut rq, q) = RayQuery::with_reciprocals(cx, ray);
        self.occluded_consts(&mut rq, q, query)
    }

    /// The original program's shadow test (`Accel::light_visible`): the light's own
    /// nearest hit, then any occluder before it. The ray's constants are made once for
    /// both; the watertight ones only for a quad or triangle that needs them (a point
    /// light, the spheres and a quad whose plane the ray does not meet before the light
    /// need none: `mixed` and `spheres` shadow rays test no triangle or quad edges at
    /// all).
    pub fn light_visible(&self, cx: Context<'_>, ray: &Ray, t_min: f32, light: &Light) -> bool {
        if light.primitives() > LIGHT_PRIMITIVES_SCANNED {
            return self.nearest_is_light(cx, ray, t_min, light);
        }
        self.light_query(cx, ray, t_min, light).is_some()
    }

    /// `light_visible` for a light of at most `LIGHT_PRIMITIVES_SCANNED` primitives, with
    /// the question it answered: the light's own nearest hit, when nothing of this tree
    /// occludes it (what an instance level asks next).
    #[inline(always)]
    pub fn light_query(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        t_min: f32,
        light: &Light,
    ) -> Option<ShadowQuery> {
        let (mut rq, q) = RayQuery::with_reciprocals(cx, ray);
        let own = match light.shape {
            LightShape::Point { center, radius } => {
                sphere_intersect_with(center, radius, &rq.sphere, t_min, f32::INFINITY)
                    .map(|t| (t, light.first_id))
            }
            _ => light.nearest_hit_watertight(ray, rq.triangle(), t_min),
        };
        let (t_light, id_light) = own?;
        let query = ShadowQuery {
            t_min,
            t_light,
            id_light,
            object: light.object,
        };
        (!self.occluded_consts(&mut rq, q, query)).then_some(query)
    }

    /// `light_visible` for a light of many primitives (`LIGHT_PRIMITIVES_SCANNED`): is
    /// the ray's closest hit the light's? Out of line, so the shadow test of the other
    /// lights stays small (inlined, the scalar `box-light` of `benches/corpus` took 1.2%
    /// more render instructions).
    #[inline(never)]
    pub(crate) fn nearest_is_light(
        &self,
        cx: Context<'_>,
        ray: &Ray,
        t_min: f32,
        light: &Light,
    ) -> bool {
        self.closest_hit(cx, ray, t_min, f32::INFINITY)
            .is_some_and(|h| h.object == light.object)
    }

    /// `occluded` with the ray's constants and reciprocals `q` (`with_reciprocals`)
    /// made: beside the tree, then through the 8-wide tree (fewer nodes a ray than the
    /// 4-wide one, as for closest hits), whose box constants are made only then.
    #[inline(always)]
    fn occluded_consts(&self, rq: &mut RayQuery<'_, '_>, q: Vec4, mut query: ShadowQuery) -> bool {
        if self.beside(rq, query.t_min, &mut query) {
            return true;
        }
        let Some(root) = self.root8 else { return false };
        let bray = BoxRay8::from_inv(rq.ray, q);
        occluded_in::<_, STACK8>(&self.nodes8, rq, root, &bray, query)
    }

    /// `occluded` in the subtree `root` (of the 4-wide tree) only: the packets' lanes
    /// that finish alone. Out of line: inlined into the shading loop with the packet
    /// traversal, it cost the 8-wide renders up to 1.4% more instructions (callgrind).
    #[inline(never)]
    pub(crate) fn occluded_from(
        &self,
        rq: &mut RayQuery<'_, '_>,
        root: u32,
        bray: &BoxRay,
        query: ShadowQuery,
    ) -> bool {
        occluded_in::<_, STACK4>(&self.nodes, rq, root, bray, query)
    }
}

/// The scalar any-hit traversal of `tree` from `root` (`ShadowQuery`). Of the children
/// a node's box test hits, the leaves are tested there and the inner nodes pushed (no
/// order: the first occluder ends the search), so a leaf costs no push and pop.
#[inline(always)]
fn occluded_in<N: Wide, const C: usize>(
    tree: &[N],
    rq: &mut RayQuery<'_, '_>,
    root: u32,
    bray: &N::Ray,
    query: ShadowQuery,
) -> bool {
    // The triangle columns in this ray's axis order, at the first triangle leaf.
    let mut cols = None;
    if root & LEAF != 0 {
        return leaf_occludes(rq, root, &mut cols, query);
    }
    let mut slots = MaybeUninit::<[u32; C]>::uninit();
    let mut stack = TraversalStack::new(&mut slots);
    let mut code = root;
    loop {
        rq.stats.nodes += 1;
        let node = &tree[code as usize];
        let (_, mut mask) = node.test(bray, query.t_min, query.t_light);
        while mask != 0 {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let child = node.child(i);
            if child & LEAF == 0 {
                stack.push(child);
            } else if leaf_occludes(rq, child, &mut cols, query) {
                return true;
            }
        }
        let Some(next) = stack.pop() else {
            return false;
        };
        code = next;
    }
}

/// `occludes_range` on the leaf `code`'s primitives.
#[inline(always)]
fn leaf_occludes<'r>(
    rq: &mut RayQuery<'r, '_>,
    code: u32,
    cols: &mut Option<Columns<'r>>,
    query: ShadowQuery,
) -> bool {
    let (kind, start, count) = decode_leaf(code);
    rq.stats.prims += count as u64;
    let range = start as usize..(start + count) as usize;
    occludes_range(rq, kind, range, cols, query)
}

/// Does a primitive in `range` occlude by `query`'s rule? Spheres and quads one at a
/// time (a quad's plane first, `QuadPool::intersect_lazy`), triangles four at a time
/// through the columns `cols` of the ray's axis order (looked up at the ray's first
/// triangle leaf).
#[inline(always)]
fn occludes_range<'r>(
    rq: &mut RayQuery<'r, '_>,
    kind: PrimKind,
    range: Range<usize>,
    cols: &mut Option<Columns<'r>>,
    mut query: ShadowQuery,
) -> bool {
    let scene = rq.scene;
    let ShadowQuery {
        t_min,
        t_light,
        object,
        ..
    } = query;
    match kind {
        // Plain loops: as `Iterator::any` the quads' loop was left out of line, a call
        // per leaf (callgrind, the scalar `cornell` render).
        PrimKind::Sphere => {
            let s = &scene.spheres;
            for i in range {
                if s.object(i) != object
                    && s.intersect(i, &rq.sphere, t_min, t_light)
                        .is_some_and(|t| query.beats_light(t, s.id(i)))
                {
                    return true;
                }
            }
            false
        }
        PrimKind::Quad => {
            let (q, ray) = (&scene.quads, rq.ray);
            for i in range {
                if q.object[i] != object
                    && q.intersect_lazy(i, ray, rq.lazy_triangle(), t_min, t_light)
                        .is_some_and(|t| query.beats_light(t, q.id[i]))
                {
                    return true;
                }
            }
            false
        }
        PrimKind::Triangle => {
            let tri = &scene.triangles;
            let w = *rq.triangle_at_leaf();
            let cols = cols.get_or_insert_with(|| tri.columns(w.axes));
            let mut start = range.start;
            while start < range.end {
                let n = (range.end - start).min(4);
                let (t, mask) = tri.intersect4_in(cols, start, n, &w, t_min, t_light);
                if query.take(scene, kind, &t, mask, start) {
                    return true;
                }
                start += n;
            }
            false
        }
    }
}

/// What a single ray's query does with a test's hits, beside the tree (`Bvh::beside`)
/// and in its triangle leaves: the closest hit (`Closest`) keeps the nearest, the
/// shadow test (`ShadowQuery`) stops at an occluder.
trait HitQuery {
    /// Whether the quads and triangles are tested out of line: for the closest hit
    /// (in line, the scalar `quads`, `spheres` and `mixed` renders took 7–9% more
    /// instructions, callgrind), not for the shadow test (out of line too, `quads` took
    /// 6% more).
    const POOLS_OUT_OF_LINE: bool;
    /// The far end of the tests to come.
    fn t_max(&self) -> f32;
    /// Take a test's hits in pool order (bit k of `mask`: primitive `first + k` of
    /// `kind`, hit at `t[k]`); true ends the loop.
    fn take(&mut self, scene: &Scene, kind: PrimKind, t: &[f32], mask: u32, first: usize) -> bool;
}

impl HitQuery for Closest {
    const POOLS_OUT_OF_LINE: bool = true;

    fn t_max(&self) -> f32 {
        self.t_max
    }

    #[inline(always)]
    fn take(&mut self, scene: &Scene, kind: PrimKind, t: &[f32], mask: u32, first: usize) -> bool {
        self.offer_lanes(t, mask, first, id_column(scene, kind), kind);
        false
    }
}

impl HitQuery for ShadowQuery {
    const POOLS_OUT_OF_LINE: bool = false;

    fn t_max(&self) -> f32 {
        self.t_light
    }

    #[inline(always)]
    fn take(&mut self, scene: &Scene, kind: PrimKind, t: &[f32], mask: u32, first: usize) -> bool {
        // A plain loop: as `Iterator::any` it was left out of line.
        for k in set_lanes(mask) {
            let (id, object) = ids(scene, kind, first + k);
            if self.occludes(t[k], id, object) {
                return true;
            }
        }
        false
    }
}

/// `f()` in a call of its own: a cold or large path kept out of its caller's loop.
#[inline(never)]
fn out_of_line<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// The ids of the pool of `kind`.
#[inline(always)]
fn id_column(scene: &Scene, kind: PrimKind) -> &[u32] {
    match kind {
        PrimKind::Sphere => scene.spheres.ids(),
        PrimKind::Quad => &scene.quads.id,
        PrimKind::Triangle => &scene.triangles.id,
    }
}

/// The scalar closest-hit traversal. The current node stays in a register: of the
/// children a node's box test hits, the nearest is visited next and only the others
/// are pushed (farthest first), so a node with one hit child costs no push or pop.
#[inline(always)]
fn traverse<N: Wide, const C: usize>(
    tree: &[N],
    rq: &mut RayQuery<'_, '_>,
    root: u32,
    bray: &N::Ray,
    t_min: f32,
    c: &mut Closest,
) {
    let scene = rq.scene;
    // As a root popped from the stack at entry t_min would be.
    if t_min > c.t_max {
        return;
    }
    let mut slots = MaybeUninit::<[(u32, f32); C]>::uninit();
    let mut stack = TraversalStack::new(&mut slots);
    let (mut nodes, mut prims) = (0u64, 0u64);
    let mut code = root;
    // The triangle columns in this ray's axis order, at the first triangle leaf.
    let mut cols: Option<Columns> = None;
    'visit: loop {
        if code & LEAF == 0 {
            nodes += 1;
            let node = &tree[code as usize];
            let (entry, mask) = node.test(bray, t_min, c.t_max);
            if mask != 0 {
                let i = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                if rest == 0 {
                    code = node.child(i);
                    continue 'visit;
                }
                let e = entry.as_ref();
                // Slots below `WIDTH` (a power of two): the mask lets the bounds checks go.
                let (i, j) = (
                    i & (N::WIDTH - 1),
                    rest.trailing_zeros() as usize & (N::WIDTH - 1),
                );
                if rest & (rest - 1) == 0 {
                    // Two: push the farther. Which is nearer is a coin toss for the
                    // branch predictor, so it is a select, not a branch.
                    let (ci, cj) = (node.child(i), node.child(j));
                    let swap = e[j] < e[i];
                    let (near, far) = if swap { (cj, ci) } else { (ci, cj) };
                    let far_e = if swap { e[i] } else { e[j] };
                    stack.push((far, far_e));
                    code = near;
                    continue 'visit;
                }
                // Three or more: sort nearest first (branch-free: `nearest_first`,
                // `nearest_first8`), push all but the nearest (farthest first).
                code = node.child(node.push_farther(mask, &entry, &mut stack));
                continue 'visit;
            }
        } else {
            let (kind, start, count) = decode_leaf(code);
            prims += count as u64;
            if kind == PrimKind::Triangle {
                let tri = *rq.triangle_at_leaf();
                let cols = cols.get_or_insert_with(|| scene.triangles.columns(tri.axes));
                c.triangles4(scene, start as usize, count as usize, &tri, cols, t_min);
            } else {
                let range = start as usize..(start + count) as usize;
                c.range(rq, kind, range, t_min);
            }
        }
        // Pop the next node still nearer than the best hit.
        while let Some((next, enter)) = stack.pop() {
            if enter <= c.t_max {
                code = next;
                continue 'visit;
            }
        }
        break;
    }
    rq.stats.nodes += nodes;
    rq.stats.prims += prims;
}
