//! `compile`: a scene description checked value by value and turned into the
//! render-ready `Scene` (boxes into quads, meshes into triangles, ids in file order).

use super::desc::MeshMaterialsDesc;
use super::desc::{AspectDesc, MaterialDesc, NormalsDesc, ObjectDesc, SceneDesc};
use super::input::ReadError;
use super::instance::{self, Instance, Prototype, ToObject};
use super::limits::{SampleBound, MAX_CAMERA_COORDINATE, MAX_COORDINATE};
use super::mesh::MeshTriangles;
use super::mtl;
use super::transform::Transform;
use super::{
    builtin, desc, input, limits, mesh, Features, Light, LightShape, Overrides, Scene, SceneSource,
    MAX_PIXELS, MAX_SUBDIVIDE,
};
use crate::budget::{Budget, MemoryEstimate, OBJ_BYTES_PER_FILE_BYTE};
use crate::camera::{image_height, Camera, CameraPose, Lens};
use crate::error::{Error, Result};
use crate::geometry::quad::{box_faces, Quad};
use crate::geometry::triangle::is_proper_triangle;
use crate::geometry::{Aabb, QuadPool, SpherePool, TrianglePool};
use crate::material::{Material, Phong};
use glam::{DVec3, Vec3};
use std::borrow::Cow;
use std::collections::HashMap;

/// Check values and build the render-ready scene, within the machine's free memory
/// (`Budget::machine`).
pub fn compile(source: &SceneSource, desc: &SceneDesc, overrides: Overrides) -> Result<Scene> {
    compile_within(source, desc, overrides, Budget::machine())
}

/// `compile` within `budget`: the image, the geometry and the BVH it will need are
/// estimated before they are made (a mesh before it is read and before it is
/// subdivided), and a larger estimate is an `OutOfMemory` error.
pub fn compile_within(
    source: &SceneSource,
    desc: &SceneDesc,
    overrides: Overrides,
    budget: Budget,
) -> Result<Scene> {
    let err = |offset: usize, msg: String| source.error_at(offset, msg);

    // Camera. The file's values are checked even where a flag replaces them.
    let default_camera = desc::CameraDesc::default();
    let (cam, cam_at) = match &desc.camera {
        Some(c) => (c.get_ref(), c.span().start),
        None => (&default_camera, 0),
    };
    let in_range = |key: &str, v: i64, max: i64| -> Result<i64> {
        if (1..=max).contains(&v) {
            Ok(v)
        } else {
            Err(err(cam_at, format!("{key} must be 1 to {max}, got {v}")))
        }
    };
    in_range("camera width", cam.width, 65_536)?;
    in_range("samples_per_pixel", cam.samples_per_pixel, 1 << 20)?;
    in_range("max_depth", cam.max_depth, 10_000)?;
    let width = in_range(
        "camera width",
        overrides.width.map_or(cam.width, i64::from),
        65_536,
    )? as u32;
    let spp = in_range(
        "samples_per_pixel",
        overrides.spp.map_or(cam.samples_per_pixel, i64::from),
        1 << 20,
    )? as u32;
    let max_depth = in_range(
        "max_depth",
        overrides.max_depth.map_or(cam.max_depth, i64::from),
        10_000,
    )? as u32;
    let aspect = match &cam.aspect_ratio {
        AspectDesc::Ratio(r) => *r,
        AspectDesc::Text(t) => parse_aspect(t).ok_or_else(|| {
            err(
                cam_at,
                format!("camera aspect_ratio must be a number or \"W:H\", got \"{t}\""),
            )
        })?,
    };
    if !(aspect.is_finite() && aspect > 0.0) {
        return Err(err(
            cam_at,
            format!("camera aspect_ratio must be positive, got {aspect}"),
        ));
    }
    let height = match &cam.aspect_ratio {
        // "W:H" is exact in integers: 800 at 16:9 is 450. Up to 2^36, so kept in u64.
        AspectDesc::Text(t) => {
            let (w, h) = parse_aspect_parts(t).unwrap_or((1, 1));
            (width as u64 * h / w).max(1)
        }
        AspectDesc::Ratio(_) => image_height(width, aspect) as u64,
    };
    if height > 65_536 || width as u64 * height > MAX_PIXELS {
        return Err(err(
            cam_at,
            format!(
                "image {width}x{height} is too large (at most 65536 a side, {MAX_PIXELS} pixels)"
            ),
        ));
    }
    let height = height as u32;
    // The film is the first large allocation.
    let mut estimate = MemoryEstimate::image(width as u64 * height as u64);
    budget.check(
        &estimate,
        &format!("{}: a {width}x{height} image", source.display),
    )?;
    // The lens: a bad value is reported where it is set.
    let value = |v: &Option<toml::Spanned<f64>>, default| {
        v.as_ref()
            .map_or((default, cam_at), |v| (*v.get_ref(), v.span().start))
    };
    let (defocus_angle, angle_at) = value(&cam.defocus_angle, Lens::PINHOLE.defocus_angle);
    let (focus_dist, focus_at) = value(&cam.focus_dist, Lens::PINHOLE.focus_dist);
    let pose = CameraPose {
        look_from: cam.look_from.0,
        look_at: cam.look_at.0,
        up: cam.up.0,
        vfov: cam.vfov,
        defocus_angle,
        focus_dist,
    };
    let camera = checked_camera(width, height, &pose).map_err(|(key, msg)| {
        let at = match key {
            CameraKey::DefocusAngle => angle_at,
            CameraKey::FocusDist => focus_at,
            CameraKey::Camera => cam_at,
        };
        err(at, msg)
    })?;

    // Background and ambient.
    let mut bound = SampleBound::default();
    let colour = |c: &Option<toml::Spanned<desc::V3>>, key: &str| -> Result<(Vec3, usize)> {
        match c {
            None => Ok((Vec3::ZERO, 0)),
            Some(s) => limits::colour(key, *s.get_ref())
                .map(|c| (c, s.span().start))
                .map_err(|msg| err(s.span().start, msg)),
        }
    };
    let (background, background_at) = colour(&desc.background, "background")?;
    let (ambient, _) = colour(&desc.ambient, "ambient")?;
    bound.end(
        background.max_element() as f64,
        background_at,
        format!("background {}", show(background)),
    );

    // Materials.
    let mut materials = Vec::new();
    let mut material_index = HashMap::new();
    let mut material_at = Vec::new();
    for (name, m) in &desc.materials {
        let at = m.span().start;
        let material = compile_material(m.get_ref())
            .map_err(|msg| err(at, format!("material '{name}': {msg}")))?;
        material_index.insert(name.as_str(), materials.len() as u32);
        materials.push(material);
        material_at.push((format!("material '{name}'"), at));
    }

    // Meshes stored once, for instances: each in a scene of its own, in its own space.
    let mut warnings = Vec::new();
    let mut degenerate_triangles = 0;
    let mut prototypes: Vec<Prototype> = Vec::new();
    let mut prototype_index = HashMap::new();
    for (name, m) in &desc.meshes {
        let (at, span) = (m.span().start, m.span());
        let m = m.get_ref();
        let what = format!("mesh '{name}'");
        let &material = material_index.get(m.material.as_str()).ok_or_else(|| {
            err(
                at,
                format!(
                    "{what}: unknown material '{}' (materials: {})",
                    m.material,
                    sorted_names(&material_index)
                ),
            )
        })?;
        let keys = MeshKeys {
            path: &m.path,
            subdivide: m.subdivide,
            normals: m.normals,
            materials: m.materials,
        };
        let place = Place {
            what: &what,
            span,
            estimate: &estimate,
            budget,
            light: false,
        };
        let (mesh, library, degenerate) =
            load_mesh(source, &keys, &Transform::IDENTITY, &place, &mut warnings)?;
        degenerate_triangles += degenerate;
        let mut group_materials = vec![material];
        for l in library.iter().flatten() {
            group_materials.push(materials.len() as u32);
            materials.push(mtl::to_material(l));
            material_at.push((format!("material '{}' of {}", l.name, l.library), at));
        }
        // The triangles of each group in turn, as a mesh object orders them.
        let mut pool = TrianglePool::default();
        let mut by_group = vec![Vec::new(); group_materials.len()];
        for i in 0..mesh.triangles.len() {
            by_group[mesh.material.get(i).map_or(0, |&g| g as usize)].push(i);
        }
        let group_used = by_group.iter().map(|g| !g.is_empty()).collect();
        let mut mesh_bounds = Aabb::EMPTY;
        let mut id = 0;
        for (group, in_group) in by_group.into_iter().enumerate() {
            for i in in_group {
                let tri = mesh.triangles[i];
                match mesh.normals.get(i) {
                    Some(&n) => pool.push_smooth(tri, n, id, group as u32),
                    None => pool.push(tri, id, group as u32),
                }
                mesh_bounds = mesh_bounds.union(Aabb::from_points(&tri));
                id += 1;
            }
        }
        estimate.add_primitives(0, 0, pool.len() as u64, true);
        if m.normals == NormalsDesc::Smooth {
            estimate.add_triangle_normals(pool.len() as u64);
        }
        prototype_index.insert(name.as_str(), prototypes.len() as u32);
        prototypes.push(Prototype {
            hull: instance::hull_points(&mesh.triangles, &mesh_bounds),
            name: name.clone(),
            scene: Scene::of_triangles(name, camera, pool, mesh_bounds),
            group_materials,
            group_used,
        });
    }
    let mut placed = vec![false; prototypes.len()];
    let mut instances: Vec<Instance> = Vec::new();
    let mut object_instance: Vec<u32> = Vec::new();

    // Objects.
    let mut spheres = SpherePool::default();
    let mut quads = QuadPool::default();
    let mut triangles = TrianglePool::default();
    let mut object_material = Vec::new();
    let mut lights = Vec::new();
    let mut bounds = Aabb::EMPTY;
    let mut next_id = 0u32;
    for (index, o) in desc.objects.iter().enumerate() {
        let (at, span) = (o.span().start, o.span());
        let o = o.get_ref();
        // Objects are numbered in file order; a mesh's MTL materials add objects after
        // it (one a material).
        let object = object_material.len() as u32;
        let what = format!("object {} ({})", index + 1, o.kind_name());
        let oerr = |msg: String| err(at, format!("{what}: {msg}"));
        let material = |name: &str| {
            material_index.get(name).copied().ok_or_else(|| {
                oerr(format!(
                    "unknown material '{name}' (materials: {})",
                    sorted_names(&material_index)
                ))
            })
        };
        if let ObjectDesc::Instance {
            mesh,
            material: replaced,
            scale,
            rotate,
            translate,
            matrix,
        } = o
        {
            let &p = prototype_index.get(mesh.as_str()).ok_or_else(|| {
                oerr(format!(
                    "unknown mesh '{mesh}' (meshes: {})",
                    sorted_names(&prototype_index)
                ))
            })?;
            let replaced = replaced.as_deref().map(material).transpose()?;
            let transform = Transform::from_keys(*scale, rotate, *translate, matrix.as_deref())
                .map_err(|(key, msg)| {
                    err(source.key_at(span.clone(), key), format!("{what}: {msg}"))
                })?;
            let proto = &prototypes[p as usize];
            placed[p as usize] = true;
            for (&group_material, &used) in proto.group_materials.iter().zip(&proto.group_used) {
                let m = replaced.unwrap_or(group_material);
                if used && matches!(materials[m as usize], Material::Light { .. }) {
                    return Err(oerr(format!(
                        "an instance cannot be a light (mesh '{mesh}' in a light material): \
                         place the mesh with a mesh object to make it one"
                    )));
                }
                object_material.push(m);
            }
            let (min, max) = instance::world_bounds(&proto.hull, &transform);
            let reach = min.abs().max(max.abs()).max_element();
            if reach.is_nan() || reach > MAX_COORDINATE {
                return Err(oerr(format!(
                    "the transform moves mesh '{mesh}' to the box [{:e}, {:e}, {:e}] to \
                     [{:e}, {:e}, {:e}]: the scene must lie within ±{MAX_COORDINATE:e} on \
                     every axis (f32 intersection tests overflow beyond)",
                    min.x, min.y, min.z, max.x, max.y, max.z
                )));
            }
            let count = proto.scene.triangles.len() as u32;
            let first_id = next_id;
            next_id = next_id
                .checked_add(count)
                .filter(|&n| n < u32::MAX)
                .ok_or_else(|| oerr("too many primitives".into()))?;
            let instance_bounds = instance::outward(min, max);
            bounds = bounds.union(instance_bounds);
            object_instance.resize(object as usize, u32::MAX);
            object_instance.resize(object_material.len(), instances.len() as u32);
            instances.push(Instance {
                prototype: p,
                first_object: object,
                first_id,
                to_object: (!transform.is_identity()).then(|| ToObject::new(&transform)),
                to_world: transform,
                bounds: instance_bounds,
            });
            continue;
        }
        let Some(name) = o.material() else {
            unreachable!("only an instance may leave its material out")
        };
        let m = material(name)?;
        object_material.push(m);
        let light_radiance = match materials[m as usize] {
            Material::Light { color, intensity } => Some(color * intensity),
            _ => None,
        };
        let first_id = next_id;
        let mut id = || {
            next_id += 1;
            next_id - 1
        };
        let shape = match o {
            ObjectDesc::Sphere { center, radius, .. } => {
                let center = limits::point("center", *center).map_err(oerr)?;
                let radius = limits::positive("radius", *radius).map_err(oerr)?;
                spheres.push(center, radius, id(), object);
                let b = spheres.bounds(spheres.len() - 1);
                limits::derived_points("center ± radius", &[b.min, b.max]).map_err(oerr)?;
                bounds = bounds.union(b);
                LightShape::Point { center, radius }
            }
            ObjectDesc::Quad { corner, u, v, .. } => {
                let corner = limits::point("corner", *corner).map_err(oerr)?;
                let u = limits::point("u", *u).map_err(oerr)?;
                let v = limits::point("v", *v).map_err(oerr)?;
                let q = Quad::new(corner, u, v).ok_or_else(|| {
                    oerr("zero area: u and v must be non-zero and not parallel".into())
                })?;
                limits::derived_points("corner + u + v", &q.vertices).map_err(oerr)?;
                // The edge test sees the vertices rounded to f32: far from the origin a
                // small quad's collapse onto a line (a 4-unit quad at z = 1e10).
                let [a, b, c, d] = q.vertices;
                if !(is_proper_triangle([a, b, c]) && is_proper_triangle([a, c, d])) {
                    return Err(oerr(format!(
                        "zero area in f32: the corners round to {} (u and v too small for \
                         the quad's distance from the origin)",
                        show_points(&q.vertices)
                    )));
                }
                quads.push(&q, id(), object);
                bounds = bounds.union(q.bounds());
                LightShape::Quads(vec![q])
            }
            ObjectDesc::Triangle { a, b, c, .. } => {
                let tri = [
                    limits::point("a", *a).map_err(oerr)?,
                    limits::point("b", *b).map_err(oerr)?,
                    limits::point("c", *c).map_err(oerr)?,
                ];
                if !is_proper_triangle(tri) {
                    return Err(oerr("zero area: the vertices are collinear".into()));
                }
                triangles.push(tri, id(), object);
                bounds = bounds.union(Aabb::from_points(&tri));
                LightShape::Triangles(vec![tri])
            }
            ObjectDesc::Box { corners, .. } => {
                let [p, q] = corners[..] else {
                    return Err(oerr(format!(
                        "corners must be two points, got {}",
                        corners.len()
                    )));
                };
                let p = limits::point("corners", p).map_err(oerr)?;
                let q = limits::point("corners", q).map_err(oerr)?;
                let (min, max) = (p.min(q), p.max(q));
                if !(min.cmplt(max).all()) {
                    return Err(oerr("the two corners must differ on every axis".into()));
                }
                let faces = box_faces(min, max);
                for f in &faces {
                    quads.push(f, id(), object);
                }
                bounds = bounds.union(Aabb::new(min, max));
                LightShape::Quads(faces)
            }
            ObjectDesc::Mesh {
                path,
                subdivide,
                scale,
                rotate,
                translate,
                matrix,
                normals,
                materials: mesh_materials,
                ..
            } => {
                if *subdivide > MAX_SUBDIVIDE {
                    return Err(oerr(format!(
                        "subdivide must be 0 to {MAX_SUBDIVIDE}, got {subdivide}"
                    )));
                }
                let transform = Transform::from_keys(*scale, rotate, *translate, matrix.as_deref())
                    .map_err(|(key, msg)| {
                        err(source.key_at(span.clone(), key), format!("{what}: {msg}"))
                    })?;
                let keys = MeshKeys {
                    path,
                    subdivide: *subdivide,
                    normals: *normals,
                    materials: *mesh_materials,
                };
                let place = Place {
                    what: &what,
                    span: span.clone(),
                    estimate: &estimate,
                    budget,
                    light: light_radiance.is_some(),
                };
                let (mesh, library, degenerate) =
                    load_mesh(source, &keys, &transform, &place, &mut warnings)?;
                degenerate_triangles += degenerate;
                // The triangles of each material in turn, each material's an object
                // of its own (the faces before any `usemtl` are this object's), so a
                // light's primitives keep consecutive ids.
                let mut by_group = vec![Vec::new(); library.as_ref().map_or(1, |l| l.len() + 1)];
                for i in 0..mesh.triangles.len() {
                    by_group[mesh.material.get(i).map_or(0, |&g| g as usize)].push(i);
                }
                let mut own = Vec::new();
                triangles.reserve(mesh.triangles.len());
                for (group, in_group) in by_group.into_iter().enumerate() {
                    if in_group.is_empty() {
                        continue;
                    }
                    let (owner, radiance) = match &library {
                        Some(l) if group > 0 => {
                            let m = &l[group - 1];
                            let material = mtl::to_material(m);
                            let owner = object_material.len() as u32;
                            object_material.push(materials.len() as u32);
                            material_at
                                .push((format!("material '{}' of {}", m.name, m.library), at));
                            materials.push(material);
                            let radiance = match material {
                                Material::Light { color, intensity } => Some(color * intensity),
                                _ => None,
                            };
                            (owner, radiance)
                        }
                        _ => (object, None),
                    };
                    // A light's shape: a copy of its triangles, only for a light.
                    let is_light = radiance.is_some() || light_radiance.is_some();
                    let mut shape = Vec::with_capacity(if is_light { in_group.len() } else { 0 });
                    let mut first = None;
                    for i in in_group {
                        let (tri, primitive) = (mesh.triangles[i], id());
                        first.get_or_insert(primitive);
                        match mesh.normals.get(i) {
                            Some(&n) => triangles.push_smooth(tri, n, primitive, owner),
                            None => triangles.push(tri, primitive, owner),
                        }
                        bounds = bounds.union(Aabb::from_points(&tri));
                        if is_light {
                            shape.push(tri);
                        }
                    }
                    match (owner == object, radiance, first) {
                        (true, _, _) => own = shape,
                        (false, Some(radiance), Some(first_id)) => {
                            estimate.add_light_triangles(shape.len() as u64);
                            lights.push(Light {
                                object: owner,
                                radiance,
                                shape: LightShape::Triangles(shape),
                                first_id,
                            })
                        }
                        _ => {}
                    }
                }
                LightShape::Triangles(own)
            }
            ObjectDesc::Instance { .. } => unreachable!("an instance is placed above"),
        };
        // Running totals (a mesh's were added above, before it was made).
        match o {
            ObjectDesc::Sphere { .. } => estimate.add_primitives(1, 0, 0, true),
            ObjectDesc::Quad { .. } => estimate.add_primitives(0, 1, 0, true),
            ObjectDesc::Triangle { .. } => estimate.add_primitives(0, 0, 1, true),
            ObjectDesc::Box { .. } => estimate.add_primitives(0, 6, 0, true),
            ObjectDesc::Instance { .. } => unreachable!("an instance is placed above"),
            ObjectDesc::Mesh { normals, .. } => {
                let n = (next_id - first_id) as u64;
                estimate.add_primitives(0, 0, n, true);
                if light_radiance.is_some() {
                    estimate.add_light_triangles(n);
                }
                if *normals == NormalsDesc::Smooth {
                    estimate.add_triangle_normals(n);
                }
            }
        }
        // A mesh all of whose faces took materials of its library holds none of the
        // object's own: no light then.
        let empty = matches!(&shape, LightShape::Triangles(t) if t.is_empty());
        if let Some(radiance) = light_radiance.filter(|_| !empty) {
            lights.push(Light {
                object,
                radiance,
                shape,
                first_id,
            });
        }
    }
    if next_id == u32::MAX {
        return Err(err(0, "too many primitives".into()));
    }
    for (name, _) in desc.meshes.keys().zip(&placed).filter(|(_, &p)| !p) {
        warnings.push(format!("mesh '{name}' is placed by no instance"));
    }
    if !instances.is_empty() {
        object_instance.resize(object_material.len(), u32::MAX);
    }

    // The largest value a sample can take, against f32's range.
    for light in &lights {
        // In f64: color · intensity may overflow f32 (refused below).
        if let Material::Light { color, intensity } =
            materials[object_material[light.object as usize] as usize]
        {
            bound.light(
                color.max_element() as f64 * intensity as f64,
                light.samples(),
            );
        }
    }
    for (material, (name, at)) in materials.iter().zip(&material_at) {
        let named = |what: &str| format!("{what} of {name}");
        match *material {
            Material::Phong(p) | Material::PhongMirror { phong: p, .. } => bound.phong(
                ambient.max_element() as f64,
                &p,
                *at,
                &format!(
                    "Phong shading of material '{name}' (the lights' radiance times their samples sums to {:.3e})",
                    bound.light_sum
                ),
            ),
            Material::Diffuse { albedo } | Material::Metal { albedo, .. } => {
                let a = albedo.max_element() as f64;
                bound.end(a, *at, named(&format!("albedo {}", show(albedo))));
                bound.path_albedo(a, *at, &named(&format!("albedo {}", show(albedo))));
            }
            Material::Dielectric { .. } => bound.end(1.0, *at, named("white")),
            Material::Light { color, intensity } => {
                bound.end(
                    color.max_element() as f64,
                    *at,
                    named(&format!("color {}", show(color))),
                );
                bound.end(
                    color.max_element() as f64 * intensity as f64,
                    *at,
                    named("color · intensity"),
                );
            }
        }
    }
    bound
        .check(spp, max_depth)
        .map_err(|(at, msg)| err(at, msg))?;

    let features = Features {
        has_spheres: !spheres.is_empty(),
        has_quads: !quads.is_empty(),
        has_triangles: !triangles.is_empty() || !instances.is_empty(),
        has_point_lights: lights.iter().any(Light::is_point),
        has_area_lights: lights.iter().any(|l| !l.is_point()),
        has_mirror: materials
            .iter()
            .any(|m| matches!(m, Material::PhongMirror { .. })),
        has_path_traced: materials.iter().any(Material::is_path_traced),
        has_phong: materials
            .iter()
            .any(|m| matches!(m, Material::Phong(_) | Material::PhongMirror { .. })),
    };

    Ok(Scene {
        name: source.name.clone(),
        description: desc.description.clone(),
        camera,
        spp,
        max_depth,
        background,
        ambient,
        spheres,
        quads,
        triangles,
        materials,
        object_material,
        lights,
        features,
        bounds,
        degenerate_triangles,
        warnings,
        prototypes,
        instances,
        object_instance,
    })
}

/// The keys of `index`, sorted, for messages: `a, b, c`.
fn sorted_names(index: &HashMap<&str, u32>) -> String {
    let mut names: Vec<_> = index.keys().copied().collect();
    names.sort_unstable();
    names.join(", ")
}

/// Which `[camera]` key a camera error is about, so that the message points at it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CameraKey {
    /// The table as a whole (`vfov`, `look_from`, `look_at`, `up`).
    Camera,
    DefocusAngle,
    FocusDist,
}

/// The camera of a `width` x `height` image placed by `pose`, every value checked as the
/// scene file's are: the message for a bad one, and the key it is about.
pub(crate) fn checked_camera(
    width: u32,
    height: u32,
    pose: &CameraPose,
) -> std::result::Result<Camera, (CameraKey, String)> {
    let table = |msg: String| (CameraKey::Camera, msg);
    if !(pose.vfov.is_finite() && pose.vfov > 0.0 && pose.vfov < 180.0) {
        return Err(table(format!(
            "vfov must be between 0 and 180 degrees, got {}",
            pose.vfov
        )));
    }
    for (key, v) in [
        ("look_from", pose.look_from),
        ("look_at", pose.look_at),
        ("up", pose.up),
    ] {
        if !v.iter().all(|x| x.is_finite()) {
            return Err(table(format!("camera {key} must be finite, got {v:?}")));
        }
    }
    let defocus_angle = pose.defocus_angle;
    if !(0.0..180.0).contains(&defocus_angle) {
        return Err((
            CameraKey::DefocusAngle,
            format!("camera defocus_angle must be at least 0 and below 180 degrees, got {defocus_angle}"),
        ));
    }
    let focus_dist = pose.focus_dist;
    if !(focus_dist.is_finite() && focus_dist > 0.0) {
        return Err((
            CameraKey::FocusDist,
            format!("camera focus_dist must be finite and positive, got {focus_dist}"),
        ));
    }
    let lens = Lens {
        focus_dist,
        defocus_angle,
    };
    if let Some(x) = pose
        .look_from
        .iter()
        .find(|x| x.abs() > MAX_CAMERA_COORDINATE)
    {
        return Err(table(format!(
            "camera look_from {:?}: {x:e} is too large: the camera must lie within ±{MAX_CAMERA_COORDINATE:e} on every axis (its rays are made in f32; move the scene nearer the origin)",
            pose.look_from
        )));
    }
    let camera = Camera::new(
        width,
        height,
        pose.vfov,
        DVec3::from(pose.look_from),
        DVec3::from(pose.look_at),
        DVec3::from(pose.up),
        lens,
    )
    .ok_or_else(|| {
        table("camera look_from and look_at must differ, and up must not be parallel to the view direction".into())
    })?;
    check_focus(&camera, lens).map_err(|msg| (CameraKey::FocusDist, msg))?;
    let extent = limits::camera_extent(&camera);
    if extent.is_nan() || extent > MAX_CAMERA_COORDINATE {
        return Err(table(format!(
            "camera image plane reaches {extent:.3e}: the camera and its image plane (focus_dist in front of look_from, default 1, as wide as vfov makes it) must lie within ±{MAX_CAMERA_COORDINATE:e} on every axis (its rays are made in f32; narrow vfov or shorten focus_dist)"
        )));
    }
    Ok(camera)
}

/// The smallest `focus_dist`, relative to the camera's largest coordinate C (`look_from`
/// and the lens disk's reach): f32 numbers near C are at most 2⁻²³·C apart, so the
/// viewport, at least `focus_dist` from every lens point, stays 8 such steps away and no
/// camera ray's direction rounds to zero. (With the default `focus_dist = 1`, any
/// `look_from` within ±2²⁰.)
pub const MIN_FOCUS_RELATIVE: f64 = 1.0 / (1 << 20) as f64;

/// The smallest `focus_dist` at all: the viewport's f32 values stay normal numbers.
pub const MIN_FOCUS: f64 = 1e-20;

/// The f32 camera is finite and its viewport far enough from its lens for f32
/// (`MIN_FOCUS_RELATIVE`, `MIN_FOCUS`).
fn check_focus(camera: &Camera, lens: Lens) -> Result<(), String> {
    let reach = camera.origin.abs() + camera.lens_u.abs() + camera.lens_v.abs();
    let parts = [
        camera.corner,
        camera.pixel_du,
        camera.pixel_dv,
        camera.lens_u,
        camera.lens_v,
    ];
    if !parts.iter().all(|v| v.is_finite()) || !reach.is_finite() {
        return Err(format!(
            "camera focus_dist {} and defocus_angle {} make the viewport or the lens too large for f32",
            lens.focus_dist, lens.defocus_angle
        ));
    }
    let least = (reach.max_element() as f64 * MIN_FOCUS_RELATIVE).max(MIN_FOCUS);
    if lens.focus_dist < least {
        return Err(format!(
            "camera focus_dist must be at least {least:e} here (2^-20 of the camera's largest coordinate, and 1e-20), got {}",
            lens.focus_dist
        ));
    }
    Ok(())
}

/// A colour as the file would write it (`Debug` writes 3e38, where `Display` writes
/// 39 digits).
fn show(c: Vec3) -> String {
    format!("[{:?}, {:?}, {:?}]", c.x, c.y, c.z)
}

fn parse_aspect_parts(t: &str) -> Option<(u64, u64)> {
    let (w, h) = t.split_once(':')?;
    let (w, h) = (w.trim().parse::<u64>().ok()?, h.trim().parse::<u64>().ok()?);
    (w > 0 && h > 0 && w <= 1 << 20 && h <= 1 << 20).then_some((w, h))
}

fn parse_aspect(t: &str) -> Option<f64> {
    parse_aspect_parts(t).map(|(w, h)| w as f64 / h as f64)
}

/// The mesh text: an embedded asset for a built-in scene, else a file relative to the
/// scene file, whose loading must fit the budget beside `estimate`.
fn read_mesh(
    source: &SceneSource,
    path: &str,
    estimate: &MemoryEstimate,
    budget: Budget,
) -> Result<(String, Cow<'static, str>)> {
    match &source.dir {
        None => builtin::asset(path)
            .map(|t| (format!("{path} (built-in)"), Cow::Borrowed(t)))
            .ok_or_else(|| Error::Io {
                path: path.to_string(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such built-in asset"),
            }),
        Some(dir) => {
            let full = dir.join(path);
            let display = full.display().to_string();
            if let Ok(size) = input::check_file(&full, input::MAX_MESH_BYTES, "mesh") {
                let mut loading = *estimate;
                loading.loading = size.saturating_mul(OBJ_BYTES_PER_FILE_BYTE);
                budget.check(&loading, &format!("{display} ({size} bytes)"))?;
            }
            let text =
                input::read_text(&full, input::MAX_MESH_BYTES, "mesh").map_err(|e| match e {
                    ReadError::Io(source) => Error::Io {
                        path: display.clone(),
                        source,
                    },
                    ReadError::Utf8 { line, column, byte } => Error::Obj {
                        path: display.clone(),
                        line,
                        message: format!("column {column}: {}", ReadError::utf8_message(byte)),
                    },
                })?;
            Ok((display, Cow::Owned(text)))
        }
    }
}

/// A mesh's keys: what is loaded, as a mesh object or a `[meshes.NAME]` table gives it.
struct MeshKeys<'a> {
    path: &'a str,
    subdivide: u32,
    normals: NormalsDesc,
    materials: MeshMaterialsDesc,
}

/// Where a mesh is loaded: its table in the scene (for messages, `what` and `span`), the
/// scene's memory so far and its budget, and whether its triangles are a light.
struct Place<'a> {
    what: &'a str,
    span: std::ops::Range<usize>,
    estimate: &'a MemoryEstimate,
    budget: Budget,
    light: bool,
}

/// Load a mesh: the OBJ read and checked, its MTL libraries with `materials = "mtl"`,
/// placed by `transform`, subdivided, within the budget. The triangles, the libraries'
/// materials (for the faces' groups) and how many triangles were dropped as degenerate.
fn load_mesh(
    source: &SceneSource,
    keys: &MeshKeys<'_>,
    transform: &Transform,
    place: &Place<'_>,
    warnings: &mut Vec<String>,
) -> Result<(MeshTriangles, Option<Vec<mtl::MtlMaterial>>, usize)> {
    let err = |offset: usize, msg: String| source.error_at(offset, msg);
    let (what, span) = (place.what, place.span.clone());
    let oerr = |msg: String| err(span.start, format!("{what}: {msg}"));
    let subdivide = keys.subdivide;
    if subdivide > MAX_SUBDIVIDE {
        return Err(oerr(format!(
            "subdivide must be 0 to {MAX_SUBDIVIDE}, got {subdivide}"
        )));
    }
    let (display, text) =
        read_mesh(source, keys.path, place.estimate, place.budget).map_err(|e| match e {
            Error::Io { path: p, source: s } => oerr(format!("cannot read mesh {p}: {s}")),
            other => other,
        })?;
    // The libraries' materials, when the mesh takes its own.
    let library = match keys.materials {
        MeshMaterialsDesc::Object => None,
        MeshMaterialsDesc::Mtl => Some(read_libraries(source, &display, &text, warnings).map_err(
            |e| match e {
                Error::Options(message) => err(
                    source.key_at(span.clone(), "materials"),
                    format!("{what}: {message}"),
                ),
                other => other,
            },
        )?),
    };
    let names: Option<Vec<String>> = library
        .as_ref()
        .map(|l| l.iter().map(|m| m.name.clone()).collect());
    let options = mesh::ObjOptions {
        smooth: keys.normals == NormalsDesc::Smooth,
        materials: names.as_deref(),
    };
    let mut mesh = mesh::read_obj(&display, &text, options)?;
    drop(text);
    let mut degenerate = mesh.degenerate;
    if !transform.is_identity() {
        degenerate +=
            place_mesh(&mut mesh, transform).map_err(|msg| oerr(format!("{display}: {msg}")))?;
    }
    // What the subdivided mesh will cost, before it is made.
    let count = (mesh.triangles.len() as u64).saturating_mul(1 << (2 * subdivide));
    let mut after = *place.estimate;
    after.add_primitives(0, 0, count, true);
    if place.light {
        after.add_light_triangles(count);
    }
    if keys.normals == NormalsDesc::Smooth {
        after.add_triangle_normals(count);
    }
    let subdivided = if subdivide > 0 {
        format!(", subdivided {subdivide} times")
    } else {
        String::new()
    };
    place
        .budget
        .check(&after, &format!("{display}: {count} triangles{subdivided}"))?;
    if subdivide > 0 {
        mesh.subdivide(subdivide);
        // Midpoints round to f32: far from the origin a small child may collapse onto a
        // line, and is dropped like a degenerate face.
        degenerate += mesh.retain(|&t| is_proper_triangle(t));
        if mesh.triangles.is_empty() {
            return Err(oerr(format!(
                "{display}: no usable triangles after subdividing (each rounds to zero \
                 area in f32)"
            )));
        }
    }
    Ok((mesh, library, degenerate))
}

/// The materials of the libraries an OBJ file names (`mtllib`), for `materials = "mtl"`:
/// each library read beside the OBJ file (`display`) and parsed (`mtl::parse_mtl`,
/// its warnings added to `warnings`); a library that cannot be read, a material that
/// two define, and a `usemtl` that names none of them are errors at the OBJ's line. An
/// OBJ that names no library is an `Error::Options` (the caller places it at the
/// scene's `materials` key).
fn read_libraries(
    source: &SceneSource,
    display: &str,
    text: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<mtl::MtlMaterial>> {
    let at = |line: usize, message: String| Error::Obj {
        path: display.to_string(),
        line,
        message,
    };
    let statements = mesh::material_statements(text);
    if statements.libraries.is_empty() {
        return Err(Error::Options(format!(
            "materials = \"mtl\", but {display} names no material library (mtllib)"
        )));
    }
    let dir = std::path::Path::new(display)
        .parent()
        .unwrap_or(std::path::Path::new(""));
    let mut materials: Vec<mtl::MtlMaterial> = Vec::new();
    for (name, line) in &statements.libraries {
        let full = dir.join(name);
        let shown = full.display().to_string();
        let library_text =
            match &source.dir {
                None => builtin::asset(&shown).map(str::to_string).ok_or_else(|| {
                    at(
                        *line,
                        format!("cannot read material library {shown}: no such built-in asset"),
                    )
                })?,
                Some(_) => input::read_text(&full, input::MAX_MESH_BYTES, "material library")
                    .map_err(|e| match e {
                        ReadError::Io(reason) => at(
                            *line,
                            format!("cannot read material library {shown}: {reason}"),
                        ),
                        ReadError::Utf8 { line, column, byte } => Error::Obj {
                            path: shown.clone(),
                            line,
                            message: format!("column {column}: {}", ReadError::utf8_message(byte)),
                        },
                    })?,
            };
        let library = mtl::parse_mtl(&shown, &library_text)?;
        warnings.extend(library.warnings);
        for m in library.materials {
            if let Some(other) = materials.iter().find(|o| o.name == m.name) {
                return Err(at(
                    *line,
                    format!(
                        "material '{}' is defined in both {} and {shown}",
                        m.name, other.library
                    ),
                ));
            }
            materials.push(m);
        }
    }
    for (name, line) in &statements.uses {
        if !materials.iter().any(|m| m.name == *name) {
            let libraries: Vec<&str> = statements
                .libraries
                .iter()
                .map(|(l, _)| l.as_str())
                .collect();
            return Err(at(
                *line,
                format!(
                    "usemtl '{name}': no such material in {}",
                    libraries.join(", ")
                ),
            ));
        }
    }
    Ok(materials)
}

fn compile_material(m: &MaterialDesc) -> Result<Material, String> {
    use super::limits::{colour, non_negative, positive};
    let phong = |albedo, shininess, ka, kd, ks| -> Result<Phong, String> {
        Ok(Phong {
            albedo: colour("albedo", albedo)?,
            shininess: non_negative("shininess", shininess)?,
            ka: non_negative("ka", ka)?,
            kd: non_negative("kd", kd)?,
            ks: non_negative("ks", ks)?,
        })
    };
    Ok(match *m {
        MaterialDesc::Phong {
            albedo,
            shininess,
            ka,
            kd,
            ks,
        } => Material::Phong(phong(albedo, shininess, ka, kd, ks)?),
        MaterialDesc::PhongMirror {
            albedo,
            shininess,
            index,
            ka,
            kd,
            ks,
        } => Material::PhongMirror {
            phong: phong(albedo, shininess, ka, kd, ks)?,
            index: positive("index", index)?,
        },
        MaterialDesc::Diffuse { albedo } => Material::Diffuse {
            albedo: colour("albedo", albedo)?,
        },
        MaterialDesc::Metal { albedo, fuzz } => Material::Metal {
            albedo: colour("albedo", albedo)?,
            fuzz: non_negative("fuzz", fuzz)?.min(1.0),
        },
        MaterialDesc::Dielectric { index } => Material::Dielectric {
            index: positive("index", index)?,
        },
        MaterialDesc::Light { color, intensity } => Material::Light {
            color: colour("color", color)?,
            intensity: non_negative("intensity", intensity)?,
        },
    })
}

/// Move a mesh's triangles by `transform` (in f64, each vertex rounded once to f32, each
/// normal by the inverse transpose) and drop those that round to zero area; how many
/// were dropped. A vertex moved beyond the coordinate limit, or every triangle dropped,
/// is an error.
fn place_mesh(mesh: &mut MeshTriangles, transform: &Transform) -> Result<usize, String> {
    for corners in mesh.normals.iter_mut() {
        for n in corners.iter_mut() {
            // A unit normal keeps a direction under a non-singular map.
            *n = transform.normal(*n).as_vec3();
        }
    }
    for tri in mesh.triangles.iter_mut() {
        for v in tri.iter_mut() {
            let p = transform.point(*v);
            if !p.is_finite() || p.abs().max_element() > MAX_COORDINATE {
                return Err(format!(
                    "the transform moves vertex [{}, {}, {}] to [{:e}, {:e}, {:e}]: the \
                     scene must lie within ±{MAX_COORDINATE:e} on every axis (f32 \
                     intersection tests overflow beyond)",
                    v.x, v.y, v.z, p.x, p.y, p.z
                ));
            }
            *v = p.as_vec3();
        }
    }
    let before = mesh.triangles.len();
    let dropped = mesh.retain(|&t| is_proper_triangle(t));
    if mesh.triangles.is_empty() {
        return Err(format!(
            "no usable triangles after the transform (all {before} round to zero area in f32)"
        ));
    }
    Ok(dropped)
}

/// Points as the renderer sees them, for messages: `[-2, -3, 1e10], [2, -3, 1e10]`.
fn show_points(points: &[Vec3]) -> String {
    let show = |p: &Vec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
    points.iter().map(show).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aspect_text() {
        assert_eq!(parse_aspect_parts("16:9"), Some((16, 9)));
        assert_eq!(parse_aspect_parts("16/9"), None);
        assert_eq!(parse_aspect_parts("0:9"), None);
    }
}
