//! Acceleration structures: which primitives a ray has to test.
//!
//! `--accel linear` is the seed's algorithm: every sphere and quad, and every triangle
//! group, a mesh's triangles only after its bounding box is hit.

pub mod linear;

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

/// The `--accel` choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AccelKind {
    /// Brute force, with the mesh bounding-box pre-test (the seed's algorithm).
    Linear,
    /// Bounding volume hierarchy.
    Bvh,
}

/// A built acceleration structure over a compiled scene.
#[derive(Clone, Debug)]
pub enum Accel {
    Linear,
}

impl Accel {
    pub fn build(_scene: &Scene, kind: AccelKind) -> Accel {
        match kind {
            AccelKind::Linear | AccelKind::Bvh => Accel::Linear,
        }
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Accel::Linear => AccelKind::Linear,
        }
    }

    /// The closest hit in `[t_min, t_max]` by the `(t, primitive id)` rule.
    #[inline]
    pub fn closest_hit(&self, scene: &Scene, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        match self {
            Accel::Linear => linear::closest_hit(scene, ray, t_min, t_max),
        }
    }
}
