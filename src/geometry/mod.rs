//! Geometry kernels and the structure-of-arrays pools they run over.
//!
//! One file per primitive kind (`sphere`, `quad`, `triangle`), each holding the pool, its
//! bounds, its intersection kernel and its normal side by side. Boxes become six quads and
//! meshes become triangles when a scene is compiled (`scene::compile`), so only these three
//! kinds exist at render time.
//!
//! Operation order inside the kernels is part of their contract: the packet tracers repeat
//! it lane for lane so that every width returns the same bits. No `mul_add`, no approximate
//! reciprocals.

pub mod aabb;
#[cfg(test)]
pub(crate) mod lane_check;
pub mod quad;
pub mod spawn;
pub mod sphere;
pub mod triangle;

pub use aabb::Aabb;
pub use quad::QuadPool;
pub use sphere::SpherePool;
pub use triangle::TrianglePool;

use glam::Vec3;

/// A ray with a unit-length direction (every ray the renderer makes is normalised).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// The primitive kinds that exist after compilation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PrimKind {
    Sphere,
    Quad,
    Triangle,
}

impl PrimKind {
    /// Every kind, in slot order.
    pub const ALL: [PrimKind; 3] = [PrimKind::Sphere, PrimKind::Quad, PrimKind::Triangle];

    /// The kind's index in per-kind tables (`ALL[kind.slot()] == kind`).
    #[inline(always)]
    pub const fn slot(self) -> usize {
        self as usize
    }

    /// The kind of slot `s` (< 3; a larger slot is a triangle).
    #[inline(always)]
    pub const fn of_slot(s: u32) -> PrimKind {
        match s {
            0 => PrimKind::Sphere,
            1 => PrimKind::Quad,
            _ => PrimKind::Triangle,
        }
    }

    /// `f(self)` with the kind a constant in each arm: inlined, each arm's call is
    /// compiled for its kind alone, so a loop over one kind's primitives holds only that
    /// kind's test (the packet traversals' loops beside the tree).
    #[inline(always)]
    pub fn specialize<R>(self, f: impl FnOnce(PrimKind) -> R) -> R {
        match self {
            PrimKind::Sphere => f(PrimKind::Sphere),
            PrimKind::Quad => f(PrimKind::Quad),
            PrimKind::Triangle => f(PrimKind::Triangle),
        }
    }
}

/// The closest hit found so far along a ray.
///
/// Closest means the smallest `(t, id)` pair: `id` is the primitive's scene-wide id, fixed
/// at compile time in scene-file order, so the answer cannot depend on the order in which
/// an acceleration structure visits primitives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Scene-wide primitive id (tie-breaker).
    pub id: u32,
    pub kind: PrimKind,
    /// Index into the pool of `kind`.
    pub index: u32,
    /// The scene object the primitive came from (a box or a mesh is one object).
    pub object: u32,
}

impl Hit {
    /// Does a candidate at `(t, id)` beat this hit?
    #[inline]
    pub fn is_beaten_by(&self, t: f32, id: u32) -> bool {
        beats((t, id), (self.t, self.id))
    }
}

/// The closest-hit rule: does `(t, id)` beat `(best_t, best_id)`? The nearer wins; at
/// equal distances, the smaller primitive id.
#[inline(always)]
pub fn beats((t, id): (f32, u32), (best_t, best_id): (f32, u32)) -> bool {
    t < best_t || (t == best_t && id < best_id)
}

/// Reorder `v` so that `v[new] = old_v[order[new]]`.
pub fn permute<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
    *v = order.iter().map(|&i| v[i as usize]).collect();
}

/// Keep `candidate` in `best` if it is closer by the `(t, id)` rule.
#[inline]
pub fn keep_closest(best: &mut Option<Hit>, candidate: Hit) {
    match best {
        Some(b) if !b.is_beaten_by(candidate.t, candidate.id) => {}
        _ => *best = Some(candidate),
    }
}
