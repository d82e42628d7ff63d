//! raytracer: a data-oriented SIMD packet ray tracer.
//!
//! Data flow (see `ARCHITECTURE.md`): scene file → `scene::desc` (serde) →
//! `scene::compile` → `Scene` (SoA pools, materials, lights, `Features`) →
//! `accel` → `integrator` (tracers) → `render::Film` → `output`.

pub mod accel;
pub mod camera;
pub mod error;
pub mod generate;
pub mod geometry;
pub mod integrator;
pub mod lanes;
pub mod material;
pub mod metrics;
pub mod output;
pub mod render;
pub mod rng;
pub mod scene;
mod settings;

pub use error::{Error, Result};
pub use settings::{PacketWidth, RenderSettings};
