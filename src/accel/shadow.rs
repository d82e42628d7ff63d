//! Shadow candidates: the primitives that can stand between a group of surface points
//! and a light. A shaded packet sends its shadow rays from the same points to the same
//! light once per light sample (ten for an area light), so the primitives that none of
//! those rays can meet are ruled out once, by boxes, and the samples test only the
//! others: in a small scene every primitive, without the tree; in a scene with a tree the
//! primitives beside it (a ground quad, the lights' own spheres), and the tree as one
//! box. Only misses are skipped: the image is the same bits (`tests/packets.rs` renders
//! with and without specialisation).
//!
//! Why boxes are enough: a shadow ray from origin o towards the light counts a primitive
//! only at a distance in `[t_min, t]`, t its own hit on the light, so the point it meets
//! lies on the segment from o to a point of the light. Every such segment lies in the
//! convex hull of the origins' box and the light's box (the shaft: the box of both, cut
//! by up to twelve side planes, `Shaft`), and the point in the primitive's box. A
//! primitive's box outside the shaft grown by a margin (`PAD`) far above the rounding of
//! a computed hit point means no hit. The margin does not cover a distance that rounding
//! moves by more than that, which only a ray within about 1e-3° of a quad's plane
//! suffers; the tree's box tests, which bound the same distances, share that limit.
//!
//! The side planes matter where the origins are far from a light much larger than
//! them: `cornell`'s floor under its ceiling light, whose box of the two takes in both
//! blocks, while the shaft passes beside them. They rule out 70% of the box tests that
//! the box alone leaves (`cornell` at 200 px: 399.5M render instructions without them,
//! 365.7M with, callgrind).

use crate::geometry::{Aabb, PrimKind};
use crate::lanes::{Lane, Mask, V3};
use crate::scene::{LightShape, Scene};
use glam::Vec3;
use std::ops::Range;
use wide::f32x8;

/// Scenes with more primitives than this take the tree for every shadow ray.
pub const MAX_PRIMITIVES: usize = 64;

/// The margin added to a region, relative to its largest coordinate: 2⁻¹² (about
/// 2.4e-4), over a thousand times the relative rounding of a hit point (about 1e-7).
const PAD: f32 = 1.0 / 4096.0;

/// The boxes of a scene's primitives, eight to an `f32x8`, in one numbering (`Layout`):
/// every primitive of a scene of at most `MAX_PRIMITIVES`, or those beside a tree and
/// the tree's box. The lights' boxes and own primitives alike.
#[derive(Clone, Debug)]
pub struct ShadowBoxes {
    /// `lo[axis][g]`, `hi[axis][g]`: boxes 8g to 8g + 7 (a padding lane holds an empty
    /// box, which overlaps nothing).
    lo: [Vec<f32x8>; 3],
    hi: [Vec<f32x8>; 3],
    layout: Layout,
    /// Per light: its box, and its own primitives (never occluders).
    lights: Vec<(Aabb, u64)>,
    /// Every box, in the numbering: the shaft's tests, and a candidate quad's box, which
    /// a packet tests before its edges (`Candidates::quad_box`).
    boxes: Vec<Aabb>,
}

/// What the numbering of `ShadowBoxes` counts.
#[derive(Clone, Copy, Debug)]
enum Layout {
    /// Every primitive: the spheres, then the quads from `quads`, then the triangles
    /// from `triangles`, each in pool order.
    Pools { quads: u32, triangles: u32 },
    /// The primitives beside a tree, kind by kind (sphere, quad, triangle): `len[k]` of
    /// kind k (at most 32) from `first[k]`, in the order `Bvh::beside_runs` reads them;
    /// then the tree's box, when there is a tree, at `tree`.
    Beside {
        first: [u32; 3],
        len: [u32; 3],
        tree: Option<u32>,
    },
}

/// What a packet's shadow rays to a light can meet (`ShadowBoxes::candidates`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Among<'a> {
    /// In a small scene: these primitives, without the tree.
    Only(Candidates<'a>),
    /// In a scene with a tree: of the primitives beside it, those of `kept` (bit j of
    /// `kept[k]`: kind k's j-th, as `Bvh::beside_runs` reads them); the tree only when
    /// `tree`.
    Beside { kept: [u32; 3], tree: bool },
}

impl Among<'_> {
    /// How many candidates there are, the tree counting as one.
    pub fn len(&self) -> usize {
        match self {
            Among::Only(c) => c.len(),
            Among::Beside { kept, tree } => {
                kept.iter().map(|k| k.count_ones() as usize).sum::<usize>() + *tree as usize
            }
        }
    }

    /// Nothing can occlude.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Primitives a bundle of shadow rays may meet, as runs of one kind: (kind, first and
/// end index in its pool).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidates<'a> {
    runs: [(PrimKind, u8, u8); MAX_RUNS],
    len: u8,
    /// The quads' boxes by pool index.
    quad_boxes: &'a [Aabb],
}

/// Candidates in more runs than this take the tree.
const MAX_RUNS: usize = 12;

impl ShadowBoxes {
    /// The boxes of `scene`'s primitives, `None` for a scene of more than
    /// `MAX_PRIMITIVES`.
    pub fn new(scene: &Scene) -> Option<Self> {
        let n = scene.primitive_count();
        if n > MAX_PRIMITIVES {
            return None;
        }
        let (ns, nq) = (scene.spheres.len(), scene.quads.len());
        let boxes: Vec<Aabb> = (0..ns)
            .map(|i| scene.spheres.bounds(i))
            .chain((0..nq).map(|i| scene.quads.bounds(i)))
            .chain((0..scene.triangles.len()).map(|i| scene.triangles.bounds(i)))
            .collect();
        let objects: Vec<u32> = (scene.spheres.objects().iter())
            .chain(&scene.quads.object)
            .chain(&scene.triangles.object)
            .copied()
            .collect();
        let layout = Layout::Pools {
            quads: ns as u32,
            triangles: (ns + nq) as u32,
        };
        Some(Self::of_boxes(scene, boxes, &objects, layout))
    }

    /// The boxes of the primitives of `scene` beside its tree (`beside[k]`: the pool
    /// indices of kind k) and of the tree (`tree`, its box when there is one); `None`
    /// when they do not fit the numbering (a kind's mask is a `u32`, the whole a `u64`).
    pub fn beside(scene: &Scene, beside: &[Range<usize>; 3], tree: Option<Aabb>) -> Option<Self> {
        let count = beside.iter().map(|r| r.len()).sum::<usize>() + tree.is_some() as usize;
        if beside.iter().any(|r| r.len() > 32) || count > 64 {
            return None;
        }
        let (mut boxes, mut objects) = (Vec::new(), Vec::new());
        let (mut first, mut len) = ([0; 3], [0; 3]);
        for (k, range) in beside.iter().enumerate() {
            first[k] = boxes.len() as u32;
            len[k] = range.len() as u32;
            for i in range.clone() {
                let (b, o) = match PrimKind::ALL[k] {
                    PrimKind::Sphere => (scene.spheres.bounds(i), scene.spheres.objects()[i]),
                    PrimKind::Quad => (scene.quads.bounds(i), scene.quads.object[i]),
                    PrimKind::Triangle => (scene.triangles.bounds(i), scene.triangles.object[i]),
                };
                boxes.push(b);
                objects.push(o);
            }
        }
        let tree = tree.map(|b| {
            boxes.push(b);
            // No light's object: the tree's box is never a light's own.
            objects.push(u32::MAX);
            boxes.len() as u32 - 1
        });
        let layout = Layout::Beside { first, len, tree };
        Some(Self::of_boxes(scene, boxes, &objects, layout))
    }

    /// `boxes` (each of the object `objects[i]`) in the numbering `layout`, with the
    /// boxes and own primitives of `scene`'s lights.
    fn of_boxes(scene: &Scene, boxes: Vec<Aabb>, objects: &[u32], layout: Layout) -> Self {
        debug_assert!(boxes.len() <= 64 && boxes.len() == objects.len());
        let groups = boxes.len().div_ceil(8);
        let column = |f: &dyn Fn(&Aabb) -> f32, empty: f32| -> Vec<f32x8> {
            (0..groups)
                .map(|g| {
                    f32x8::new(std::array::from_fn(|k| {
                        boxes.get(8 * g + k).map_or(empty, f)
                    }))
                })
                .collect()
        };
        let lights = scene
            .lights
            .iter()
            .map(|light| {
                let b = match &light.shape {
                    LightShape::Point { center, radius } => Aabb::new(
                        *center - Vec3::splat(*radius),
                        *center + Vec3::splat(*radius),
                    ),
                    LightShape::Quads(qs) => {
                        qs.iter().fold(Aabb::EMPTY, |b, q| b.union(q.bounds()))
                    }
                    LightShape::Triangles(ts) => ts
                        .iter()
                        .fold(Aabb::EMPTY, |b, t| b.union(Aabb::from_points(t))),
                };
                let own = (objects.iter().enumerate())
                    .filter(|&(_, &o)| o == light.object)
                    .fold(0u64, |m, (i, _)| m | 1 << i);
                (b, own)
            })
            .collect();
        ShadowBoxes {
            lo: [
                column(&|b| b.min.x, f32::INFINITY),
                column(&|b| b.min.y, f32::INFINITY),
                column(&|b| b.min.z, f32::INFINITY),
            ],
            hi: [
                column(&|b| b.max.x, f32::NEG_INFINITY),
                column(&|b| b.max.y, f32::NEG_INFINITY),
                column(&|b| b.max.z, f32::NEG_INFINITY),
            ],
            boxes,
            layout,
            lights,
        }
    }

    /// The primitives other than light `light`'s own (and the tree) whose box meets the
    /// shaft from `origins` to the light's box, both padded: all that a shadow ray from a
    /// point of `origins` to the light can meet. `None` when they are too scattered to
    /// pay (`MAX_RUNS`).
    pub fn candidates(&self, light: usize, origins: &Aabb) -> Option<Among<'_>> {
        let (light_box, own) = self.lights[light];
        let region = origins.union(light_box);
        let scale = region.min.abs().max(region.max.abs()).max_element();
        let pad = scale * PAD;
        let (lo, hi) = (region.min - pad, region.max + pad);
        let (lo_a, hi_a) = (lo.to_array(), hi.to_array());
        let mut mask = 0u64;
        for g in 0..self.lo[0].len() {
            let mut meets = 0xff;
            for a in 0..3 {
                let (l, h) = (f32x8::splat(lo_a[a]), f32x8::splat(hi_a[a]));
                meets &= (self.lo[a][g].le(h) & self.hi[a][g].ge(l)).bits();
            }
            mask |= (meets as u64) << (8 * g);
        }
        mask &= !own;
        // The boxes that meet the region, against the shaft's sides: each clipped to
        // the region first (the shaft lies in it), so every coordinate a plane test
        // reads is within the region's scale.
        if mask != 0 {
            let shaft = Shaft::new(origins, &light_box, pad);
            let mut left = mask;
            while left != 0 {
                let i = left.trailing_zeros() as usize;
                left &= left - 1;
                let b = &self.boxes[i];
                if shaft.excludes(b.min.max(lo), b.max.min(hi)) {
                    mask &= !(1 << i);
                }
            }
        }
        match self.layout {
            Layout::Pools { quads, triangles } => {
                let (quads, triangles) = (quads as usize, triangles as usize);
                Candidates::of_mask(mask, quads, triangles, &self.boxes[quads..triangles])
                    .map(Among::Only)
            }
            Layout::Beside { first, len, tree } => Some(Among::Beside {
                kept: std::array::from_fn(|k| ((mask >> first[k]) & ((1u64 << len[k]) - 1)) as u32),
                tree: tree.is_some_and(|t| mask >> t & 1 != 0),
            }),
        }
    }
}

/// The side planes of the convex hull of two boxes (Haines and Wallace's shaft, 1991)
/// beyond the faces of their union. In the projection onto a pair of axes (i, j), the
/// hull's outline joins a corner of one box's rectangle to the same corner of the
/// other's wherever one box reaches further on that corner's side of i and the other
/// further on its side of j; that edge, extended along the third axis, is a plane that
/// every segment from one box to the other stays inside. Three pairs of axes and four
/// corners give at most twelve planes, held here as the lanes of two `f32x8`s; a corner
/// without a side plane gets one no point is outside of.
#[derive(Clone, Copy, Debug)]
struct Shaft {
    /// Normals (one component zero), and offsets: points with n · x > offset are
    /// outside.
    normal: [V3<f32x8>; 2],
    offset: [f32x8; 2],
}

impl Shaft {
    /// The shaft between `a` and `b`, each grown by `pad` on every side. Each offset is
    /// moved out by `pad` times its normal's 1-norm as well: the rounding of a plane
    /// test of a point within the region (a few ulps of its coordinates) is far below
    /// that.
    fn new(a: &Aabb, b: &Aabb, pad: f32) -> Self {
        let (a_lo, a_hi) = ((a.min - pad).to_array(), (a.max + pad).to_array());
        let (b_lo, b_hi) = ((b.min - pad).to_array(), (b.max + pad).to_array());
        let mut n = [[0.0f32; 16]; 3];
        let mut offset = [f32::INFINITY; 16];
        for (pair, (i, j)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
            for corner in 0..4 {
                let (up_i, up_j) = (corner & 1 != 0, corner & 2 != 0);
                // The corner of each box's rectangle, and whether `a` reaches further
                // than `b` there on each axis (a tie on either axis: no side plane).
                let pick = |lo: &[f32; 3], hi: &[f32; 3], axis: usize, up: bool| {
                    if up {
                        hi[axis]
                    } else {
                        lo[axis]
                    }
                };
                let p = (pick(&a_lo, &a_hi, i, up_i), pick(&a_lo, &a_hi, j, up_j));
                let q = (pick(&b_lo, &b_hi, i, up_i), pick(&b_lo, &b_hi, j, up_j));
                let sign = |up: bool| if up { 1.0f32 } else { -1.0 };
                let (si, sj) = (sign(up_i), sign(up_j));
                let (further_i, further_j) = ((p.0 - q.0) * si, (p.1 - q.1) * sj);
                if further_i == 0.0 || further_j == 0.0 || (further_i > 0.0) == (further_j > 0.0) {
                    continue;
                }
                // The edge from p to q runs diagonally (one box further on i, the other
                // on j), so its normal, turned outwards, points to the corner's side on
                // both axes.
                let (ni, nj) = ((q.1 - p.1).abs() * si, (q.0 - p.0).abs() * sj);
                let k = 4 * pair + corner;
                n[i][k] = ni;
                n[j][k] = nj;
                offset[k] = ni * p.0 + nj * p.1 + (ni.abs() + nj.abs()) * pad;
            }
        }
        let lanes = |v: &[f32; 16], h: usize| {
            f32x8::from(<[f32; 8]>::try_from(&v[8 * h..8 * h + 8]).unwrap())
        };
        Shaft {
            normal: std::array::from_fn(|h| {
                V3::new(lanes(&n[0], h), lanes(&n[1], h), lanes(&n[2], h))
            }),
            offset: std::array::from_fn(|h| lanes(&offset, h)),
        }
    }

    /// Is the box from `lo` to `hi` wholly outside some side plane? Its corner
    /// nearest to a plane is at its upper end on an axis where the normal is negative.
    #[inline(always)]
    fn excludes(&self, lo: Vec3, hi: Vec3) -> bool {
        let zero = f32x8::ZERO;
        (0..2).any(|h| {
            let n = &self.normal[h];
            let near = |c: f32x8, l: f32, u: f32| {
                <f32x8 as Lane>::select(c.lt(zero), f32x8::splat(u), f32x8::splat(l))
            };
            let d = n.x * near(n.x, lo.x, hi.x)
                + n.y * near(n.y, lo.y, hi.y)
                + n.z * near(n.z, lo.z, hi.z);
            d.gt(self.offset[h]).any()
        })
    }
}

/// The box of the points `point` in the lanes of `lanes` (not empty), each moved up to
/// `error`'s sum along every axis: where `spawn_origin` puts a shadow ray's origin
/// (its offset is the normal times n·error, at most that sum on any axis; the last
/// step of a bit is within `PAD`).
#[inline(always)]
pub fn origins_box<L: Lane>(point: V3<L>, error: V3<L>, lanes: u32) -> Aabb {
    let spread = error.x + error.y + error.z;
    let m = L::Mask::from_bits(lanes);
    let low = |v: L| L::select(m, v - spread, L::splat(f32::INFINITY)).reduce_min();
    let high = |v: L| L::select(m, v + spread, L::splat(f32::NEG_INFINITY)).reduce_max();
    Aabb::new(
        Vec3::new(low(point.x), low(point.y), low(point.z)),
        Vec3::new(high(point.x), high(point.y), high(point.z)),
    )
}

impl<'a> Candidates<'a> {
    /// The primitives of `mask` (spheres from bit 0, quads from bit `quads`, triangles
    /// from bit `triangles`) as runs, `None` past `MAX_RUNS`.
    fn of_mask(
        mut mask: u64,
        quads: usize,
        triangles: usize,
        quad_boxes: &'a [Aabb],
    ) -> Option<Self> {
        let mut c = Candidates {
            runs: [(PrimKind::Sphere, 0, 0); MAX_RUNS],
            len: 0,
            quad_boxes,
        };
        while mask != 0 {
            let start = mask.trailing_zeros() as usize;
            let run = (!(mask >> start)).trailing_zeros() as usize;
            let (kind, first, last) = if start < quads {
                (PrimKind::Sphere, 0, quads)
            } else if start < triangles {
                (PrimKind::Quad, quads, triangles)
            } else {
                (PrimKind::Triangle, triangles, 64)
            };
            let end = (start + run).min(last);
            mask &= !(((1u128 << end) - 1) as u64);
            if c.len as usize == MAX_RUNS {
                return None;
            }
            c.runs[c.len as usize] = (kind, (start - first) as u8, (end - first) as u8);
            c.len += 1;
        }
        Some(c)
    }

    /// The runs: (kind, pool indices).
    #[inline(always)]
    pub fn runs(&self) -> impl Iterator<Item = (PrimKind, Range<usize>)> + '_ {
        self.runs[..self.len as usize]
            .iter()
            .map(|&(kind, a, b)| (kind, a as usize..b as usize))
    }

    /// Quad `i`'s box (min, max).
    #[inline(always)]
    pub fn quad_box(&self, i: usize) -> ([f32; 3], [f32; 3]) {
        let b = &self.quad_boxes[i];
        (b.min.to_array(), b.max.to_array())
    }

    /// How many primitives the candidates hold.
    pub fn len(&self) -> usize {
        self.runs().map(|(_, r)| r.len()).sum()
    }

    /// No primitive can occlude.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box beside the diagonal from one box to another, inside the box of both, is
    /// outside the shaft; one on the diagonal, or touching the segments at a corner, is
    /// not.
    #[test]
    fn the_shaft_cuts_the_box_of_both() {
        let a = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let b = Aabb::new(Vec3::new(10.0, 10.0, 0.0), Vec3::new(11.0, 11.0, 1.0));
        let shaft = Shaft::new(&a, &b, 0.0);
        let beside = |lo: [f32; 3], hi: [f32; 3]| shaft.excludes(lo.into(), hi.into());
        assert!(beside([0.0, 8.0, 0.0], [2.0, 10.0, 1.0]));
        assert!(beside([8.0, 0.0, 0.0], [10.0, 2.0, 1.0]));
        assert!(!beside([5.0, 5.0, 0.0], [6.0, 6.0, 1.0]));
        // The segment from (0, 1) to (10, 11) passes the corner (4, 5) exactly.
        assert!(!beside([3.0, 5.0, 0.0], [4.0, 7.0, 1.0]));
        assert!(beside([3.0, 5.01, 0.0], [4.0, 7.0, 1.0]));
        // Boxes that reach as far on an axis (here z) give that pair no side plane.
        assert!(!beside([5.0, 5.0, -3.0], [6.0, 6.0, -2.0]));
    }

    /// No point of a segment from one box to another is outside the shaft: a tiny box
    /// around it (a point, after rounding) is never excluded, for boxes of every shape,
    /// size, position and scale, with the margin `candidates` uses.
    #[test]
    fn no_segment_leaves_the_shaft() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut unit = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut excluded_some = 0;
        for round in 0..20_000 {
            let scale = [1e-3f32, 1.0, 1e3, 1e5][round % 4];
            let mut v = || Vec3::new(unit(), unit(), unit()) * 2.0 - 1.0;
            let corner = |c: Vec3, e: Vec3| Aabb::new(c, c + e.abs() * [0.05, 1.0][round / 4 % 2]);
            let (a, b) = (
                corner(v() * scale, v() * scale),
                corner(v() * scale, v() * scale),
            );
            let region = a.union(b);
            let pad = region.min.abs().max(region.max.abs()).max_element() * PAD;
            let shaft = Shaft::new(&a, &b, pad);
            for _ in 0..8 {
                let t = v().x * 0.5 + 0.5;
                let x = a.min + (a.max - a.min) * (v() * 0.5 + 0.5);
                let y = b.min + (b.max - b.min) * (v() * 0.5 + 0.5);
                let p = x + (y - x) * t;
                assert!(!shaft.excludes(p, p), "{a:?} {b:?} {p}");
                // And a box nearby but off the segment is often excluded.
                let q = p + v() * (region.max - region.min);
                excluded_some += shaft.excludes(q, q) as u32;
            }
        }
        assert!(excluded_some > 20_000, "{excluded_some}");
    }

    /// The runs hold exactly the mask's primitives, each run of one kind, for masks of
    /// every density over every split of 64 primitives into the three kinds.
    #[test]
    fn runs_hold_the_mask() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let (mut whole, mut overflow) = (0, 0);
        for case in 0..20_000 {
            let (quads, triangles) = {
                let a = (next() % 65) as usize;
                let b = (next() % 65) as usize;
                (a.min(b), a.max(b))
            };
            // Sparse, dense and middling masks.
            let mask = match case % 3 {
                0 => next() & next() & next(),
                1 => next() | next() | next(),
                _ => next(),
            };
            let Some(c) = Candidates::of_mask(mask, quads, triangles, &[]) else {
                overflow += 1;
                continue;
            };
            whole += 1;
            let mut rebuilt = 0u64;
            for (kind, range) in c.runs() {
                let first = match kind {
                    PrimKind::Sphere => 0,
                    PrimKind::Quad => quads,
                    PrimKind::Triangle => triangles,
                };
                let last = [quads, triangles, 64][kind.slot()];
                assert!(!range.is_empty() && first + range.end <= last, "{mask:x}");
                for i in range {
                    assert_eq!(rebuilt >> (first + i) & 1, 0, "twice");
                    rebuilt |= 1 << (first + i);
                }
            }
            assert_eq!(rebuilt, mask);
            assert_eq!(c.len(), mask.count_ones() as usize);
            assert_eq!(c.is_empty(), mask == 0);
        }
        assert!(whole > 1000 && overflow > 1000, "{whole} {overflow}");
    }
}
