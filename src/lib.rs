//! A CPU ray tracer built on SIMD ray packets: structure-of-arrays primitive pools, an
//! 8-wide BVH for single rays and a 4-wide one for packets, watertight triangles,
//! error-bounded ray offsets, and counter-based random numbers, so that every image is
//! the same bits for any thread count and packet width.
//!
//! A scene is a TOML file (its keys are documented in `scenes/README.md`): read it into a
//! [`SceneFile`], compile it with its acceleration structure into a [`Renderer`], render
//! with [`RenderSettings`] into a [`Film`] of linear RGB, and write or inspect the film.
//!
//! ```
//! use raytracer::{RenderSettings, Renderer};
//!
//! let renderer = Renderer::from_toml(r#"
//!     camera = { width = 32, aspect_ratio = 2.0, samples_per_pixel = 4 }
//!     materials.red = { type = "phong", albedo = [0.8, 0.1, 0.1], shininess = 10 }
//!     materials.lamp = { type = "light", color = [1, 1, 1] }
//!     objects = [
//!         { type = "sphere", center = [0, 0, -2], radius = 0.5, material = "red" },
//!         { type = "sphere", center = [1, 1, -1], radius = 0.1, material = "lamp" },
//!     ]
//! "#)?;
//! let film = renderer.render(&RenderSettings::default())?;
//! assert_eq!((film.width, film.height), (32, 16));
//! let centre = film.get(16, 8); // the red sphere, lit
//! assert!(centre.x > centre.y && centre.y > 0.0);
//! film.write(std::env::temp_dir().join("raytracer-example.png"))?;
//! # Ok::<(), raytracer::Error>(())
//! ```
//!
//! [`SceneFile::builtin`] loads the scenes the `raytracer` command knows by name, and
//! [`SceneOptions`] replaces a scene's width, samples per pixel or depth.
//! [`Renderer::render`] runs on the current rayon thread pool.
//! [`Renderer::render_adaptive`] renders to an error instead of a sample count
//! ([`Adaptive`]): passes that give more samples to the tiles whose estimated error is
//! still above the target. [`Renderer::render_pass`] renders one sample a pixel at a
//! time into a [`Progressive`] render, to show the image as it refines, and
//! [`Renderer::set_camera_pose`] moves the camera between passes.
//!
//! A frame can be farmed out: [`Renderer::render_part`] renders one [`Region`] of it (part
//! I of N, or a crop window) into a [`Part`], written as a part file anywhere, and
//! [`merge_parts`] checks the part files and puts them together into the frame's bits.

#![warn(missing_docs)]

mod error;
mod film;
mod progressive;
mod renderer;
mod settings;

pub use accel::AccelKind;
pub use adaptive::{Adaptive, Outcome, PassProgress, Stop, FIRST_PASS_SPP};
pub use camera::CameraPose;
#[doc(hidden)]
pub use error::one_line;
pub use error::{Error, Result};
pub use farm::merge::{merge_parts, merge_parts_within, Merged};
pub use farm::part::Part;
pub use farm::region::{Rect, Region};
pub use film::Film;
pub use glam::Vec3;
pub use integrator::RayCounts;
pub use progressive::Progressive;
pub use render::Rendered;
pub use renderer::{Renderer, SceneFile, SceneOptions};
pub use sampling::SamplerKind;
pub use settings::{PacketWidth, RenderSettings};

// The internals: public only so that the integration tests, the benchmarks and the probes
// can check and measure the kernels directly (bit-identity between packet widths,
// primitives against f64 oracles, the BVH against the linear scan), and so that the
// command line can print its statistics. Hidden from the documentation and not part of
// the API: they change without notice. In the order of the data flow (ARCHITECTURE.md):

// The foundations every stage is written over: lanes and the counter-based samplers.
#[doc(hidden)]
pub mod lanes;
#[doc(hidden)]
pub mod sampling;

// Scene → acceleration structure → integrator → tiles → film and output files.
#[doc(hidden)]
pub mod accel;
mod adaptive;
#[doc(hidden)]
pub mod camera;
#[doc(hidden)]
pub mod geometry;
#[doc(hidden)]
pub mod integrator;
#[doc(hidden)]
pub mod material;
#[doc(hidden)]
pub mod output;
#[doc(hidden)]
pub mod render;
#[doc(hidden)]
pub mod scene;

// A frame in parts, and the memory a run may take.
#[doc(hidden)]
pub mod budget;
#[doc(hidden)]
pub mod farm;

// Measures and test meshes.
#[doc(hidden)]
pub mod generate;
#[doc(hidden)]
pub mod metrics;
