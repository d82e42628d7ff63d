//! Scenes: loading a scene file (`desc`), and the compiled, render-ready `Scene` with its
//! structure-of-arrays primitive pools, material table, light list and `Features`.
//!
//! `compile` is the one place where descriptions become render objects: it checks every
//! value, expands boxes into quads and meshes into triangles, and gives every primitive
//! a scene-wide id in file order.

pub mod builtin;
mod compile;
pub mod desc;
pub mod input;
pub mod instance;
mod light;
pub mod limits;
pub mod mesh;
pub mod mtl;
mod source;
pub mod transform;

use crate::budget::{Budget, MemoryEstimate};
use crate::camera::Camera;
use crate::error::Result;
use crate::geometry::{Aabb, QuadPool, SpherePool, TrianglePool};
use crate::material::Material;
pub(crate) use compile::checked_camera;
pub use compile::{compile, compile_within, MIN_FOCUS, MIN_FOCUS_RELATIVE};
use glam::Vec3;
pub use instance::{Instance, Prototype};
pub use light::{Light, LightShape};
pub use source::SceneSource;

/// Samples per area light (quad, triangle, box or mesh light), as in the original program.
pub const AREA_LIGHT_SAMPLES: u32 = 10;

/// The cells an area light's samples are spread over, one sample a cell (`Light::
/// stratum`): five by two on a face, or ten bands of the primitives' order.
pub const AREA_LIGHT_STRATA: (u32, u32) = (5, 2);
const _: () = assert!(AREA_LIGHT_STRATA.0 * AREA_LIGHT_STRATA.1 == AREA_LIGHT_SAMPLES);

/// Most 1-to-4 subdivisions of a mesh (4⁶ = 4096 times the triangles).
pub const MAX_SUBDIVIDE: u32 = 6;

/// The largest image the renderer accepts, in pixels (the film alone needs 12 bytes a pixel).
pub const MAX_PIXELS: u64 = 1 << 28;

/// Command-line settings that replace the scene file's.
#[derive(Clone, Copy, Debug, Default)]
pub struct Overrides {
    pub width: Option<u32>,
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
}

/// What a scene contains; the integrator skips what is absent (ARCHITECTURE.md,
/// "Specialisation").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    pub has_spheres: bool,
    pub has_quads: bool,
    pub has_triangles: bool,
    pub has_point_lights: bool,
    pub has_area_lights: bool,
    /// PhongMirror present: mirror rays are traced.
    pub has_mirror: bool,
    /// Diffuse, Metal or Dielectric present: the path-tracing loop is needed.
    pub has_path_traced: bool,
    /// Phong or PhongMirror present: some paths end at their first vertex.
    pub has_phong: bool,
}

impl Features {
    pub fn has_lights(&self) -> bool {
        self.has_point_lights || self.has_area_lights
    }
}

/// A compiled, render-ready scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub description: String,
    pub camera: Camera,
    pub spp: u32,
    pub max_depth: u32,
    pub background: Vec3,
    pub ambient: Vec3,
    pub spheres: SpherePool,
    pub quads: QuadPool,
    pub triangles: TrianglePool,
    pub materials: Vec<Material>,
    /// Material index of each object.
    pub object_material: Vec<u32>,
    pub lights: Vec<Light>,
    pub features: Features,
    pub bounds: Aabb,
    /// Zero-area mesh triangles left out.
    pub degenerate_triangles: usize,
    /// The meshes stored once (`[meshes.NAME]`) that `instances` place.
    pub prototypes: Vec<Prototype>,
    /// The placed meshes, in file order.
    pub instances: Vec<Instance>,
    /// Each object's instance (index into `instances`), `u32::MAX` for an object of
    /// the pools; empty when there are no instances.
    pub object_instance: Vec<u32>,
    /// What the scene's files say that the renderer does not use (an MTL statement it
    /// has no mapping for), one message each, for the user.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Load and compile a built-in scene name or a scene file path (`SceneSource::resolve`)
    /// within the machine's free memory; for the tests and benchmarks, which edit the
    /// compiled scene (the public way in is `SceneFile` and `Renderer`).
    pub fn load(arg: &str, overrides: Overrides) -> Result<Scene> {
        Self::load_within(arg, overrides, Budget::machine())
    }

    /// `load` within a memory budget (`compile_within`).
    pub fn load_within(arg: &str, overrides: Overrides, budget: Budget) -> Result<Scene> {
        let source = SceneSource::resolve(arg)?;
        let desc = source.parse()?;
        compile_within(&source, &desc, overrides, budget)
    }

    /// A scene of `triangles` alone (a prototype's, in its own space): no lights, no
    /// materials, `camera` only to fill the field.
    pub fn of_triangles(
        name: &str,
        camera: Camera,
        triangles: TrianglePool,
        bounds: Aabb,
    ) -> Scene {
        Scene {
            name: name.to_string(),
            description: String::new(),
            camera,
            spp: 1,
            max_depth: 1,
            background: Vec3::ZERO,
            ambient: Vec3::ZERO,
            spheres: SpherePool::default(),
            quads: QuadPool::default(),
            triangles,
            materials: Vec::new(),
            object_material: Vec::new(),
            lights: Vec::new(),
            features: Features {
                has_triangles: true,
                ..Features::default()
            },
            bounds,
            degenerate_triangles: 0,
            warnings: Vec::new(),
            prototypes: Vec::new(),
            instances: Vec::new(),
            object_instance: Vec::new(),
        }
    }

    pub fn primitive_count(&self) -> usize {
        self.spheres.len() + self.quads.len() + self.triangles.len()
    }

    /// The instance `object` belongs to, if any.
    #[inline]
    pub fn instance_of(&self, object: u32) -> Option<&Instance> {
        let i = *self.object_instance.get(object as usize)?;
        self.instances.get(i as usize)
    }

    /// The world vertices of triangle `index` of `object` (of the pool, or of an
    /// instance's prototype, placed).
    #[inline]
    pub fn triangle_vertices(&self, object: u32, index: usize) -> [Vec3; 3] {
        match self.instance_of(object) {
            None => self.triangles.vertices(index),
            Some(inst) => {
                let pool = &self.prototypes[inst.prototype as usize].scene.triangles;
                inst.world_triangle(pool.vertices(index))
            }
        }
    }

    /// The world corner normals of triangle `index` of `object` if it is smooth.
    #[inline]
    pub fn triangle_normals(&self, object: u32, index: usize) -> Option<[Vec3; 3]> {
        match self.instance_of(object) {
            None => self
                .triangles
                .is_smooth(index)
                .then(|| self.triangles.normals[index]),
            Some(inst) => {
                let pool = &self.prototypes[inst.prototype as usize].scene.triangles;
                pool.is_smooth(index)
                    .then(|| inst.world_normals(pool.normals[index]))
            }
        }
    }

    /// Whether any triangle may be smooth (the pool's or a prototype's).
    pub fn has_smooth_triangles(&self) -> bool {
        !self.triangles.normals.is_empty()
            || (self.prototypes.iter()).any(|p| !p.scene.triangles.normals.is_empty())
    }

    /// The memory of this scene rendered and written, with or without the BVH (`--accel
    /// linear` builds none): what `Renderer::new` checks before the build.
    pub fn memory_estimate(&self, bvh: bool) -> MemoryEstimate {
        let camera = &self.camera;
        let mut e = MemoryEstimate::image(camera.width as u64 * camera.height as u64);
        e.add_primitives(
            self.spheres.len() as u64,
            self.quads.len() as u64,
            self.triangles.len() as u64,
            bvh,
        );
        e.add_triangle_normals(self.triangles.normals.len() as u64);
        for p in &self.prototypes {
            let pool = &p.scene.triangles;
            e.add_primitives(0, 0, pool.len() as u64, bvh);
            e.add_triangle_normals(pool.normals.len() as u64);
        }
        for light in &self.lights {
            if let LightShape::Triangles(t) = &light.shape {
                e.add_light_triangles(t.len() as u64);
            }
        }
        e
    }

    #[inline]
    pub fn material_of(&self, object: u32) -> &Material {
        &self.materials[self.object_material[object as usize] as usize]
    }
}
