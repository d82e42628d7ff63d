//! Shadow candidates: in a small scene, the primitives that can stand between a group
//! of surface points and a light. A shaded packet sends its shadow rays from the same
//! points to the same light once per light sample (ten for an area light), so the
//! primitives that none of those rays can meet are ruled out once, by boxes, and the
//! samples test only the others, without the tree. Only misses are skipped: the image is
//! the same bits (`tests/packets.rs` renders with and without specialisation).
//!
//! Why a box test is enough: a shadow ray from origin o towards the light counts a
//! primitive only at a distance in `[t_min, t]`, t its own hit on the light, so the point
//! it meets lies on the segment from o to a point of the light. Every such segment lies
//! in the box of the origins and the light's box, and the point in the primitive's box.
//! Disjoint boxes, with a margin (`PAD`) far above the rounding of a computed hit point,
//! mean no hit. The margin does not cover a distance that rounding moves by more than
//! that, which only a ray within about 1e-3° of a quad's plane suffers; the tree's box
//! tests, which bound the same distances, share that limit.

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

/// The boxes of every primitive of a scene of at most `MAX_PRIMITIVES`, eight to an
/// `f32x8`, in one numbering: the spheres, then the quads, then the triangles, each in
/// pool order. The lights' boxes and own primitives alike.
#[derive(Clone, Debug)]
pub struct ShadowBoxes {
    /// `lo[axis][g]`, `hi[axis][g]`: primitives 8g to 8g + 7 (a padding lane holds an
    /// empty box, which overlaps nothing).
    lo: [Vec<f32x8>; 3],
    hi: [Vec<f32x8>; 3],
    /// Where the quads and the triangles start in the numbering.
    quads: u32,
    triangles: u32,
    /// Per light: its box, and its own primitives (never occluders).
    lights: Vec<(Aabb, u64)>,
    /// The quads' boxes by pool index, as (min, max): a packet tests a candidate quad's
    /// box before its edges (`Candidates::quad_box`).
    quad_boxes: Vec<([f32; 3], [f32; 3])>,
}

/// Primitives a bundle of shadow rays may meet, as runs of one kind: (kind, first and
/// end index in its pool).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidates<'a> {
    runs: [(PrimKind, u8, u8); MAX_RUNS],
    len: u8,
    quad_boxes: &'a [([f32; 3], [f32; 3])],
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
        let objects: Vec<u32> = (scene.spheres.object.iter())
            .chain(&scene.quads.object)
            .chain(&scene.triangles.object)
            .copied()
            .collect();
        let groups = n.div_ceil(8);
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
        Some(ShadowBoxes {
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
            quads: ns as u32,
            triangles: (ns + nq) as u32,
            lights,
            quad_boxes: (0..nq)
                .map(|i| {
                    let b = scene.quads.bounds(i);
                    (b.min.to_array(), b.max.to_array())
                })
                .collect(),
        })
    }

    /// The primitives other than light `light`'s own whose box meets the box of
    /// `origins` and the light's, padded: all that a shadow ray from a point of
    /// `origins` to the light can meet. `None` when they are too scattered to pay
    /// (`MAX_RUNS`).
    pub fn candidates(&self, light: usize, origins: &Aabb) -> Option<Candidates<'_>> {
        let (light_box, own) = self.lights[light];
        let region = origins.union(light_box);
        let scale = region.min.abs().max(region.max.abs()).max_element();
        let pad = Vec3::splat(scale * PAD);
        let (lo, hi) = (region.min - pad, region.max + pad);
        let (lo, hi) = (lo.to_array(), hi.to_array());
        let mut mask = 0u64;
        for g in 0..self.lo[0].len() {
            let mut meets = 0xff;
            for a in 0..3 {
                let m =
                    self.lo[a][g].le(f32x8::splat(hi[a])) & self.hi[a][g].ge(f32x8::splat(lo[a]));
                meets &= m.bits();
            }
            mask |= (meets as u64) << (8 * g);
        }
        let (quads, triangles) = (self.quads as usize, self.triangles as usize);
        Candidates::of_mask(mask & !own, quads, triangles, &self.quad_boxes)
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
        quad_boxes: &'a [([f32; 3], [f32; 3])],
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
        self.quad_boxes[i]
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
