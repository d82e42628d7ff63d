//! Scene descriptions: serde structs that mirror a scene file, word for word.
//!
//! Reads every key of a scene file; `scenes/README.md` documents them. Unknown keys are
//! errors (`deny_unknown_fields`). Numbers are kept as TOML gives them (f64): whether
//! they fit the renderer's f32 is checked in `scene::compile`, which reports the line of
//! the offending table through the spans kept here.

use serde::de::{self, Deserializer, IgnoredAny, SeqAccess, Visitor};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use toml::Spanned;

/// A point, vector or colour: exactly three numbers. (serde's `[T; 3]` reads the first
/// three elements of a longer array and ignores the rest, of any type.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3(pub [f64; 3]);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_seq(ThreeNumbers)
    }
}

struct ThreeNumbers;

impl<'de> Visitor<'de> for ThreeNumbers {
    type Value = V3;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an array of three numbers")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<V3, A::Error> {
        let mut v = [0.0; 3];
        for (i, x) in v.iter_mut().enumerate() {
            *x = seq.next_element::<f64>()?.ok_or_else(|| three_numbers(i))?;
        }
        let mut len = 3;
        while seq.next_element::<IgnoredAny>()?.is_some() {
            len += 1;
        }
        if len > 3 {
            return Err(three_numbers(len));
        }
        Ok(V3(v))
    }
}

fn three_numbers<E: de::Error>(len: usize) -> E {
    E::custom(format!(
        "expected an array of three numbers, got {len} element{}",
        if len == 1 { "" } else { "s" }
    ))
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// One line shown by `--list`.
    #[serde(default)]
    pub description: String,
    /// Colour of rays that hit nothing.
    pub background: Option<Spanned<V3>>,
    /// Ambient light colour for Phong's ambient term.
    pub ambient: Option<Spanned<V3>>,
    pub camera: Option<Spanned<CameraDesc>>,
    #[serde(default)]
    pub materials: BTreeMap<String, Spanned<MaterialDesc>>,
    /// Meshes stored once and placed by `type = "instance"` objects, by name.
    #[serde(default)]
    pub meshes: BTreeMap<String, Spanned<MeshDesc>>,
    #[serde(default)]
    pub objects: Vec<Spanned<ObjectDesc>>,
}

/// A `[meshes.NAME]` table: an OBJ mesh loaded once, in its own space, for instances.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    /// The OBJ file, relative to the scene file.
    pub path: String,
    #[serde(default)]
    pub subdivide: u32,
    /// The faces' material (before any `usemtl` with `materials = "mtl"`).
    pub material: String,
    #[serde(default)]
    pub normals: NormalsDesc,
    #[serde(default)]
    pub materials: MeshMaterialsDesc,
}

impl SceneDesc {
    /// No key at all: an empty, blank or comment-only file.
    pub fn sets_nothing(&self) -> bool {
        self.description.is_empty()
            && self.background.is_none()
            && self.ambient.is_none()
            && self.camera.is_none()
            && self.materials.is_empty()
            && self.meshes.is_empty()
            && self.objects.is_empty()
    }
}

/// The aspect ratio: a number (width / height) or a string "W:H".
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum AspectDesc {
    Ratio(f64),
    Text(String),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    #[serde(default = "defaults::width")]
    pub width: i64,
    #[serde(default = "defaults::aspect")]
    pub aspect_ratio: AspectDesc,
    #[serde(default = "defaults::spp")]
    pub samples_per_pixel: i64,
    #[serde(default = "defaults::max_depth")]
    pub max_depth: i64,
    #[serde(default = "defaults::vfov")]
    pub vfov: f64,
    #[serde(default = "defaults::look_from")]
    pub look_from: V3,
    #[serde(default = "defaults::look_at")]
    pub look_at: V3,
    #[serde(default = "defaults::up")]
    pub up: V3,
    /// Degrees (0: a pinhole); the lens disk's radius is `focus_dist · tan(angle / 2)`.
    /// Spanned, so that a bad value's message points at it.
    #[serde(default)]
    pub defocus_angle: Option<Spanned<f64>>,
    /// Distance of the plane in focus, which holds the viewport (default 1).
    #[serde(default)]
    pub focus_dist: Option<Spanned<f64>>,
}

impl Default for CameraDesc {
    fn default() -> Self {
        Self {
            width: defaults::width(),
            aspect_ratio: defaults::aspect(),
            samples_per_pixel: defaults::spp(),
            max_depth: defaults::max_depth(),
            vfov: defaults::vfov(),
            look_from: defaults::look_from(),
            look_at: defaults::look_at(),
            up: defaults::up(),
            defocus_angle: None,
            focus_dist: None,
        }
    }
}

/// The original program's camera defaults and Phong's ka = kd = ks = 0.5
/// (`docs/seed-semantics.md`, "Camera").
mod defaults {
    use super::{AspectDesc, V3};
    pub fn width() -> i64 {
        100
    }
    pub fn aspect() -> AspectDesc {
        AspectDesc::Ratio(1.0)
    }
    pub fn spp() -> i64 {
        10
    }
    pub fn max_depth() -> i64 {
        10
    }
    pub fn vfov() -> f64 {
        90.0
    }
    pub fn look_from() -> V3 {
        V3([0.0, 0.0, 0.0])
    }
    pub fn look_at() -> V3 {
        V3([0.0, 0.0, -1.0])
    }
    pub fn up() -> V3 {
        V3([0.0, 1.0, 0.0])
    }
    pub fn half() -> f64 {
        0.5
    }
    pub fn one() -> f64 {
        1.0
    }
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialDesc {
    Phong {
        albedo: V3,
        shininess: f64,
        #[serde(default = "defaults::half")]
        ka: f64,
        #[serde(default = "defaults::half")]
        kd: f64,
        #[serde(default = "defaults::half")]
        ks: f64,
    },
    PhongMirror {
        albedo: V3,
        shininess: f64,
        index: f64,
        #[serde(default = "defaults::half")]
        ka: f64,
        #[serde(default = "defaults::half")]
        kd: f64,
        #[serde(default = "defaults::half")]
        ks: f64,
    },
    Diffuse {
        albedo: V3,
    },
    Metal {
        albedo: V3,
        #[serde(default)]
        fuzz: f64,
    },
    Dielectric {
        index: f64,
    },
    Light {
        color: V3,
        #[serde(default = "defaults::one")]
        intensity: f64,
    },
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ObjectDesc {
    Sphere {
        center: V3,
        radius: f64,
        material: String,
    },
    /// A parallelogram: corner Q and edges u, v.
    Quad {
        corner: V3,
        u: V3,
        v: V3,
        material: String,
    },
    Triangle {
        a: V3,
        b: V3,
        c: V3,
        material: String,
    },
    /// An axis-aligned box given by two opposite corners.
    Box {
        /// Two points (a `Vec`, so that a third is reported rather than ignored).
        corners: Vec<V3>,
        material: String,
    },
    /// An OBJ mesh, path relative to the scene file, optionally split 1-to-4 at its edge
    /// midpoints `subdivide` times (for tests and benchmarks of large meshes).
    Mesh {
        path: String,
        #[serde(default)]
        subdivide: u32,
        material: String,
        /// A number, or one per axis; applied first.
        #[serde(default)]
        scale: Option<ScaleDesc>,
        /// Rotations applied in the order written, after `scale`.
        #[serde(default)]
        rotate: Vec<RotationDesc>,
        /// Applied last.
        #[serde(default)]
        translate: Option<V3>,
        /// Four rows of four numbers, instead of `scale`, `rotate` and `translate`.
        #[serde(default)]
        matrix: Option<Vec<Vec<f64>>>,
        /// The shading normal: the triangle's own, or interpolated vertex normals.
        #[serde(default)]
        normals: NormalsDesc,
        /// Every face in `material`, or each in its MTL material.
        #[serde(default)]
        materials: MeshMaterialsDesc,
    },
    /// A mesh of `[meshes]` placed by a transform (the keys of a mesh object), stored
    /// once however many instances place it.
    Instance {
        mesh: String,
        /// Every face in this material instead of the mesh's.
        #[serde(default)]
        material: Option<String>,
        #[serde(default)]
        scale: Option<ScaleDesc>,
        #[serde(default)]
        rotate: Vec<RotationDesc>,
        #[serde(default)]
        translate: Option<V3>,
        #[serde(default)]
        matrix: Option<Vec<Vec<f64>>>,
    },
}

/// A mesh's `materials`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeshMaterialsDesc {
    /// Every face in the object's `material`.
    #[default]
    Object,
    /// Each face in the material its `usemtl` names, from the libraries the OBJ file
    /// names (`mtllib`), mapped by `scene::mtl`; faces before any `usemtl` in `material`.
    Mtl,
}

/// A mesh's `normals`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NormalsDesc {
    /// Each triangle shaded with its geometric normal (the original program's way).
    #[default]
    Flat,
    /// The file's `vn` normals, or area-weighted vertex normals where it gives none,
    /// interpolated across each triangle.
    Smooth,
}

/// A mesh's `scale`: one number for every axis, or three.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScaleDesc {
    Uniform(f64),
    PerAxis(V3),
}

impl<'de> Deserialize<'de> for ScaleDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumberOrThree)
    }
}

struct NumberOrThree;

impl<'de> Visitor<'de> for NumberOrThree {
    type Value = ScaleDesc;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number or an array of three numbers")
    }

    fn visit_f64<E: de::Error>(self, x: f64) -> Result<ScaleDesc, E> {
        Ok(ScaleDesc::Uniform(x))
    }

    fn visit_i64<E: de::Error>(self, x: i64) -> Result<ScaleDesc, E> {
        Ok(ScaleDesc::Uniform(x as f64))
    }

    fn visit_u64<E: de::Error>(self, x: u64) -> Result<ScaleDesc, E> {
        Ok(ScaleDesc::Uniform(x as f64))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<ScaleDesc, A::Error> {
        ThreeNumbers.visit_seq(seq).map(ScaleDesc::PerAxis)
    }
}

/// One rotation of a mesh: `degrees` about `axis` (right-handed: counter-clockwise
/// seen from the axis's tip).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationDesc {
    pub axis: V3,
    pub degrees: f64,
}

impl ObjectDesc {
    /// The object's material; an instance's override, if it has one.
    pub fn material(&self) -> Option<&str> {
        match self {
            ObjectDesc::Sphere { material, .. }
            | ObjectDesc::Quad { material, .. }
            | ObjectDesc::Triangle { material, .. }
            | ObjectDesc::Box { material, .. }
            | ObjectDesc::Mesh { material, .. } => Some(material),
            ObjectDesc::Instance { material, .. } => material.as_deref(),
        }
    }

    pub fn kind_name(&self) -> &'static str {
        match self {
            ObjectDesc::Sphere { .. } => "sphere",
            ObjectDesc::Quad { .. } => "quad",
            ObjectDesc::Triangle { .. } => "triangle",
            ObjectDesc::Box { .. } => "box",
            ObjectDesc::Mesh { .. } => "mesh",
            ObjectDesc::Instance { .. } => "instance",
        }
    }
}
