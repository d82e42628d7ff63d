//! Meshes as users bring them: placed by a transform (`scale`, `rotate`, `translate`,
//! `matrix`), each vertex moved in f64 and checked against an f64 oracle written here;
//! shaded smooth (`normals = "smooth"`), checked against the sphere an icosphere
//! approximates, for leaks through the surface, and bit for bit at every width.

mod support;

use glam::{DVec3, Vec3};
use raytracer::accel::{Accel, AccelKind};
use raytracer::generate::icosphere;
use raytracer::geometry::Ray;
use raytracer::integrator::{scatter, RayCounts, Surface, Tracer};
use raytracer::material::Material;
use raytracer::metrics::rel_mse;
use raytracer::render::render;
use raytracer::sampling::SampleKey;
use raytracer::scene::{Overrides, Scene};
use raytracer::{PacketWidth, RenderSettings};
use support::{bits, obj_text, Rng};

/// A scene of one mesh object (`mesh.obj`) with `keys` added to it, and a point light.
fn mesh_scene(keys: &str) -> String {
    format!(
        r#"
[camera]
width = 24
samples_per_pixel = 2
look_from = [0, 0, 9]
[materials.white]
type = "phong"
albedo = [0.8, 0.8, 0.8]
shininess = 20
[materials.lamp]
type = "light"
color = [1, 1, 1]
[[objects]]
type = "sphere"
center = [3, 4, 6]
radius = 0.2
material = "lamp"
[[objects]]
type = "mesh"
path = "mesh.obj"
material = "white"
{keys}
"#
    )
}

/// `count` random triangles in the cube [−1, 1]³.
fn random_mesh(count: usize, seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = Rng(seed);
    (0..count)
        .map(|_| {
            std::array::from_fn(|_| {
                Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                )
            })
        })
        .collect()
}

/// The mesh's triangles as compiled, in id order.
fn triangles(scene: &Scene) -> Vec<[Vec3; 3]> {
    (0..scene.triangles.len())
        .map(|i| scene.triangles.vertices(i))
        .collect()
}

/// The error message of a scene that must be refused.
fn refused(text: &str, mesh: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), mesh).unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    match Scene::load(path.to_str().unwrap(), Overrides::default()) {
        Ok(_) => panic!("loaded, but must be refused:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Rodrigues' rotation of `p` by `degrees` about the unit `axis`, in f64.
fn rotate(p: DVec3, axis: DVec3, degrees: f64) -> DVec3 {
    let k = axis.normalize();
    let (s, c) = degrees.to_radians().sin_cos();
    p * c + k.cross(p) * s + k * k.dot(p) * (1.0 - c)
}

/// `got` is `want` rounded to f32, within one f32 step (the oracle's own rounding in
/// f64 may fall on the other side of a halfway point).
fn assert_rounded(got: Vec3, want: DVec3) {
    for axis in 0..3 {
        let (g, w) = (got[axis] as f64, want[axis]);
        let step = (w.abs() as f32).max(f32::MIN_POSITIVE);
        let ulp = (f32::from_bits(step.to_bits() + 1) - step) as f64;
        assert!((g - w).abs() <= ulp, "axis {axis}: {g} against {w}");
    }
}

#[test]
fn scale_rotations_and_translate_move_every_vertex_as_the_oracle() {
    let mesh = random_mesh(200, 7);
    let keys = r#"scale = [2, 0.5, 3]
rotate = [{ axis = [0, 1, 0], degrees = 30 }, { axis = [1, 1, 0], degrees = -45 }]
translate = [1, -2, 0.5]"#;
    let scene = support::scene_with_files(&mesh_scene(keys), &[("mesh.obj", obj_text(&mesh))]);
    let placed = triangles(&scene);
    assert_eq!(placed.len(), mesh.len());
    for (tri, moved) in mesh.iter().zip(&placed) {
        for (v, got) in tri.iter().zip(moved) {
            let p = v.as_dvec3() * DVec3::new(2.0, 0.5, 3.0);
            let p = rotate(p, DVec3::Y, 30.0);
            let p = rotate(p, DVec3::new(1.0, 1.0, 0.0), -45.0);
            assert_rounded(*got, p + DVec3::new(1.0, -2.0, 0.5));
        }
    }
    // The rotations in the other order place the mesh elsewhere: the order is kept.
    let swapped = r#"scale = [2, 0.5, 3]
rotate = [{ axis = [1, 1, 0], degrees = -45 }, { axis = [0, 1, 0], degrees = 30 }]
translate = [1, -2, 0.5]"#;
    let other = support::scene_with_files(&mesh_scene(swapped), &[("mesh.obj", obj_text(&mesh))]);
    assert_ne!(triangles(&other), placed);
}

#[test]
fn a_matrix_places_the_mesh_as_its_keys_do() {
    let mesh = random_mesh(100, 11);
    // A rotation by 90° about z, a scale of 2 along x first, and a translation.
    let matrix = r#"matrix = [[0, -1, 0, 4], [2, 0, 0, 5], [0, 0, 1, 6], [0, 0, 0, 1]]"#;
    let keys = r#"scale = [2, 1, 1]
rotate = [{ axis = [0, 0, 1], degrees = 90 }]
translate = [4, 5, 6]"#;
    let files = [("mesh.obj", obj_text(&mesh))];
    let by_matrix = triangles(&support::scene_with_files(&mesh_scene(matrix), &files));
    let by_keys = triangles(&support::scene_with_files(&mesh_scene(keys), &files));
    for (tri, (m, k)) in mesh.iter().zip(by_matrix.iter().zip(&by_keys)) {
        for ((v, m), k) in tri.iter().zip(m).zip(k) {
            let want = DVec3::new(4.0 - v.y as f64, 5.0 + 2.0 * v.x as f64, 6.0 + v.z as f64);
            assert_rounded(*m, want);
            assert_rounded(*k, want);
        }
    }
}

#[test]
fn an_identity_transform_is_the_mesh_as_is_bit_for_bit() {
    let mesh = random_mesh(50, 3);
    let files = [("mesh.obj", obj_text(&mesh))];
    let plain = support::scene_with_files(&mesh_scene(""), &files);
    let identity = r#"scale = 1
rotate = [{ axis = [0, 1, 0], degrees = 0 }]
translate = [0, 0, 0]"#;
    let same = support::scene_with_files(&mesh_scene(identity), &files);
    assert_eq!(triangles(&same), triangles(&plain));
    assert_eq!(
        support::bits(&support::render_film(&same, 1)),
        support::bits(&support::render_film(&plain, 1))
    );
}

#[test]
fn bad_transforms_are_refused_at_their_line() {
    let mesh = obj_text(&random_mesh(4, 5));
    // The object's table starts on line 18 of `mesh_scene`; its keys follow from line 22.
    for (keys, line, words) in [
        ("scale = 0", 22, "scale must be finite and non-zero"),
        ("scale = [1, 0, 1]", 22, "scale must be finite and non-zero"),
        (
            "translate = [0, 0, 0]\nrotate = [{ axis = [0, 0, 0], degrees = 5 }]",
            23,
            "rotate 1: axis",
        ),
        (
            "matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]",
            22,
            "four rows of four",
        ),
        (
            "matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]",
            22,
            "singular",
        ),
        (
            "matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]",
            22,
            "affine",
        ),
        (
            "scale = 2\nmatrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]",
            23,
            "matrix replaces",
        ),
        // Moved past the coordinate limit: named at the object.
        ("translate = [0, 2e10, 0]", 18, "within ±1e10"),
        // So small that every triangle rounds to zero area.
        (
            "scale = 1e-30",
            18,
            "no usable triangles after the transform",
        ),
    ] {
        let message = refused(&mesh_scene(keys), &mesh);
        assert!(
            message.contains(&format!("scene.toml:{line}:")) && message.contains(words),
            "{keys}: {message}"
        );
    }
    let message = refused(&mesh_scene("scale = \"big\""), &mesh);
    assert!(
        message.contains("a number or an array of three numbers"),
        "{message}"
    );
}

/// A unit icosphere of 20 480 triangles (five subdivisions of the icosahedron).
fn sphere_mesh() -> Vec<[Vec3; 3]> {
    icosphere(5, Vec3::ZERO, 1.0)
}

/// OBJ text of `triangles` with a `vn` per corner, `normal(p)` at each vertex p.
fn obj_with_normals(triangles: &[[Vec3; 3]], normal: impl Fn(Vec3) -> Vec3) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for t in triangles {
        for p in t {
            let n = normal(*p);
            writeln!(
                s,
                "v {:?} {:?} {:?}\nvn {:?} {:?} {:?}",
                p.x, p.y, p.z, n.x, n.y, n.z
            )
            .unwrap();
        }
    }
    for i in 0..triangles.len() {
        let (a, b, c) = (3 * i + 1, 3 * i + 2, 3 * i + 3);
        writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
    }
    s
}

/// The largest angle (radians) between the shading normal at a hit and the sphere's own
/// normal there (the hit point's direction from the centre), over rays from all sides.
fn worst_normal_error(scene: &Scene, shading: bool) -> f64 {
    let mut scene = scene.clone();
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let tracer = Tracer::new(&scene, &accel, 0);
    let mut counts = RayCounts::default();
    let mut rng = Rng(99);
    let mut worst = 0.0f64;
    let mut hits = 0;
    for _ in 0..4000 {
        let origin = rng.unit_vector() * 3.0;
        let target = rng.unit_vector() * 0.7;
        let ray = Ray::new(origin, (target - origin).normalize());
        let Some(hit) = tracer.closest_hit(&ray, &mut counts) else {
            continue;
        };
        hits += 1;
        let s = tracer.surface(&ray, &hit);
        let n = if shading { s.shading } else { s.normal };
        let radial = s.point.point.as_dvec3().normalize();
        worst = worst.max(n.as_dvec3().angle_between(radial));
    }
    assert!(hits > 3000, "{hits} rays hit the sphere");
    worst
}

fn sphere_scene(object: &str) -> String {
    format!(
        r#"
ambient = [0.1, 0.1, 0.1]
[camera]
width = 64
samples_per_pixel = 4
look_from = [0, 0, 3]
vfov = 50
[materials.white]
type = "phong"
albedo = [0.8, 0.7, 0.6]
shininess = 30
[materials.lamp]
type = "light"
color = [1, 1, 1]
[[objects]]
type = "sphere"
center = [2, 3, 4]
radius = 0.1
material = "lamp"
[[objects]]
material = "white"
{object}
"#
    )
}

#[test]
fn smooth_normals_of_an_icosphere_are_the_spheres() {
    let mesh = sphere_mesh();
    let smooth = "type = \"mesh\"\npath = \"mesh.obj\"\nnormals = \"smooth\"";
    let flat = "type = \"mesh\"\npath = \"mesh.obj\"";
    // Area-weighted normals computed at load (the file has no `vn`).
    let computed =
        support::scene_with_files(&sphere_scene(smooth), &[("mesh.obj", obj_text(&mesh))]);
    let from_file = support::scene_with_files(
        &sphere_scene(smooth),
        &[("mesh.obj", obj_with_normals(&mesh, |p| p.normalize()))],
    );
    let faceted = support::scene_with_files(&sphere_scene(flat), &[("mesh.obj", obj_text(&mesh))]);
    let (computed_error, file_error) = (
        worst_normal_error(&computed, true),
        worst_normal_error(&from_file, true),
    );
    assert!(computed_error < 1e-3, "computed normals: {computed_error}");
    assert!(file_error < 1e-3, "the file's normals: {file_error}");
    // The facets' own normals are 10x further off: the test sees the difference.
    let flat_error = worst_normal_error(&faceted, true);
    assert!(flat_error > 1e-2, "flat: {flat_error}");
    // The geometric normal of a smooth mesh stays the facet's.
    assert_eq!(worst_normal_error(&computed, false), flat_error);
}

#[test]
fn a_smooth_icosphere_renders_as_the_sphere() {
    let mesh = sphere_mesh();
    let smooth = "type = \"mesh\"\npath = \"mesh.obj\"\nnormals = \"smooth\"";
    let flat = "type = \"mesh\"\npath = \"mesh.obj\"";
    let analytic = support::scene_from_toml(&sphere_scene(
        "type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1",
    ));
    let files = [("mesh.obj", obj_text(&mesh))];
    let smooth = support::scene_with_files(&sphere_scene(smooth), &files);
    let flat = support::scene_with_files(&sphere_scene(flat), &files);
    let reference = support::render_film(&analytic, 2);
    let error = |scene: &Scene| rel_mse(&support::render_film(scene, 2).pixels, &reference.pixels);
    let (smooth_error, flat_error) = (error(&smooth), error(&flat));
    assert!(smooth_error < 0.01, "smooth: relMSE {smooth_error}");
    // The facets' highlights and shading steps: the bound is no formality.
    assert!(
        flat_error > 2.0 * smooth_error,
        "flat {flat_error}, smooth {smooth_error}"
    );
}

/// A 4x4 sheet at z = 0 facing +z whose vertex normals lean 80° towards +x, lit by a
/// point light below it, seen from above.
fn leaning_sheet() -> String {
    let lean = Vec3::new(80f32.to_radians().sin(), 0.0, 80f32.to_radians().cos());
    let sheet = [
        [
            Vec3::new(-2.0, -2.0, 0.0),
            Vec3::new(2.0, -2.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
        ],
        [
            Vec3::new(-2.0, -2.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(-2.0, 2.0, 0.0),
        ],
    ];
    obj_with_normals(&sheet, |_| lean)
}

#[test]
fn no_light_reaches_a_smooth_surface_from_behind_it() {
    let scene_text = |normals: &str| {
        format!(
            r#"
ambient = [0.2, 0.2, 0.2]
[camera]
width = 16
samples_per_pixel = 1
look_from = [0, 0, 3]
look_at = [0, 0, 0]
vfov = 40
[materials.white]
type = "phong"
albedo = [1, 1, 1]
shininess = 1
[materials.lamp]
type = "light"
color = [1, 1, 1]
[[objects]]
type = "sphere"
center = [1.5, 0, -0.5]
radius = 0.01
material = "lamp"
[[objects]]
type = "mesh"
path = "sheet.obj"
material = "white"
normals = "{normals}"
"#
        )
    };
    let files = [("sheet.obj", leaning_sheet())];
    // The light is below the sheet; its shading normals lean towards it (N·L > 0 for
    // many pixels), but the surface faces away: every pixel is the ambient term alone,
    // 1 · (0.5 · 0.2), with no diffuse or specular light. (Flat, the original's
    // specular term, not gated by N·L, reaches through the open sheet.)
    for normals in ["smooth"] {
        let scene = support::scene_with_files(&scene_text(normals), &files);
        for width in PacketWidth::ALL {
            let settings = RenderSettings {
                packet_width: width,
                ..RenderSettings::new(0)
            };
            let mut scene = scene.clone();
            let accel = Accel::build(&mut scene, AccelKind::Bvh);
            let film = render(&scene, &accel, &settings, &|| {}).unwrap().film;
            for p in &film.pixels {
                assert_eq!(*p, Vec3::splat(0.5 * 0.2), "{normals}, {width:?}");
            }
        }
    }
}

#[test]
fn bounces_off_a_smooth_surface_leave_on_its_side() {
    // The geometric normal faces the ray (+z); the shading normal leans 80° off it, so
    // about the shading normal alone many directions would cross the surface.
    let lean = Vec3::new(80f32.to_radians().sin(), 0.0, 80f32.to_radians().cos());
    let s = Surface {
        point: raytracer::geometry::spawn::ErrorPoint {
            point: Vec3::ZERO,
            error: Vec3::ZERO,
        },
        normal: Vec3::Z,
        shading: lean,
        front_face: true,
        object: 0,
    };
    let mut left = [0usize; 3];
    for (m, material) in [
        Material::Diffuse { albedo: Vec3::ONE },
        Material::Metal {
            albedo: Vec3::ONE,
            fuzz: 0.5,
        },
        Material::Dielectric { index: 1.5 },
    ]
    .iter()
    .enumerate()
    {
        let mut rng = Rng(5);
        for sample in 0..2000 {
            let dir = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), -1.0).normalize();
            let ray = Ray::new(Vec3::new(0.0, 0.0, 1.0), dir);
            let key = SampleKey::new(0, 0, 0, sample);
            let Some((_, d)) = scatter(material, &ray, &s, key, 0) else {
                continue;
            };
            assert!(d.is_finite() && d.dot(Vec3::Z) != 0.0, "{material:?}: {d}");
            if d.z > 0.0 {
                left[m] += 1;
            }
            if !matches!(material, Material::Dielectric { .. }) {
                assert!(d.z > 0.0, "{material:?} crossed the surface: {d}");
            }
        }
    }
    assert!(left[0] > 1900 && left[1] > 1000, "{left:?}");
}

#[test]
fn smooth_and_placed_meshes_render_the_same_bits_at_every_width_and_thread_count() {
    let mesh = icosphere(3, Vec3::ZERO, 1.0);
    let keys = r#"normals = "smooth"
scale = [1, 0.7, 1.2]
rotate = [{ axis = [1, 0, 1], degrees = 33 }]
translate = [0.1, 0, 0]"#;
    let text = mesh_scene(keys).replace(
        "[materials.white]",
        "[materials.glass]\ntype = \"dielectric\"\nindex = 1.5\n[materials.white]",
    );
    // The placed sphere in white (Phong), and in glass beside it (path-traced bounces).
    let text = format!(
        "{text}\n[[objects]]\ntype = \"mesh\"\npath = \"mesh.obj\"\nmaterial = \"glass\"\nnormals = \"smooth\"\ntranslate = [2, 0, 0]\n"
    );
    let scene = support::scene_with_files(&text, &[("mesh.obj", obj_text(&mesh))]);
    assert!(!scene.triangles.normals.is_empty());
    let mut scene = scene;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let film = |width: PacketWidth, threads: usize| {
        let settings = RenderSettings {
            packet_width: width,
            ..RenderSettings::new(0)
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        bits(
            &pool
                .install(|| render(&scene, &accel, &settings, &|| {}))
                .unwrap()
                .film,
        )
    };
    let reference = film(PacketWidth::Scalar, 1);
    for width in PacketWidth::ALL {
        assert!(film(width, 2) == reference, "{width:?} differs");
    }
}

#[test]
fn a_bad_normal_is_refused_at_its_line_when_smooth() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn nan 0 1\nf 1//1 2//2 3//1\n";
    let message = refused(&mesh_scene("normals = \"smooth\""), text);
    assert!(
        message.contains("mesh.obj:5") && message.contains("normal"),
        "{message}"
    );
    // Flat shading never reads the normals.
    let flat = support::scene_with_files(&mesh_scene(""), &[("mesh.obj", text.to_string())]);
    assert_eq!(flat.triangles.len(), 1);
    assert!(flat.triangles.normals.is_empty());
}

/// A mesh of three groups: faces before any `usemtl` (the object's material), a red
/// Phong group and a lamp group, with its MTL library.
fn mtl_files(library: &str) -> Vec<(&'static str, String)> {
    let tri = |z: f32| {
        obj_text(&[[
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(0.0, 1.0, z),
        ]])
    };
    // Three single-triangle OBJ texts joined: each `v` block is followed by its face,
    // whose indices count from the file's start.
    let obj = format!(
        "mtllib parts.mtl\n{}usemtl red\n{}usemtl lamp\n{}",
        tri(0.0),
        tri(-1.0).replace("f 1 2 3", "f 4 5 6"),
        tri(-2.0).replace("f 1 2 3", "f 7 8 9"),
    );
    vec![("mesh.obj", obj), ("parts.mtl", library.to_string())]
}

const PARTS_MTL: &str = "newmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 40\nmap_Kd red.png\n\
                         newmtl lamp\nKe 2 2 2\nmap_Kd a.png\nmap_Ks b.png\n";

#[test]
fn mtl_materials_map_onto_the_renderers_by_the_table() {
    let scene =
        support::scene_with_files(&mesh_scene("materials = \"mtl\""), &mtl_files(PARTS_MTL));
    // The object's own material for the faces before any usemtl, then one object a
    // material of the library, in its order.
    let material_of = |z: f32| {
        let i = (0..scene.triangles.len())
            .find(|&i| scene.triangles.vertices(i)[0].z == z)
            .unwrap();
        *scene.material_of(scene.triangles.object[i])
    };
    assert!(matches!(material_of(0.0), Material::Phong(p) if p.albedo == Vec3::splat(0.8)));
    match material_of(-1.0) {
        Material::Phong(p) => {
            assert_eq!(
                (p.albedo, p.shininess, p.kd),
                (Vec3::new(0.8, 0.1, 0.1), 40.0, 1.0)
            );
            // mean(Ks) / mean(Kd) = 0.2 / (1 / 3).
            assert!((p.ks - 0.6).abs() < 1e-6, "{}", p.ks);
        }
        other => panic!("{other:?}"),
    }
    let lamp = Material::Light {
        color: Vec3::splat(2.0),
        intensity: 1.0,
    };
    assert_eq!(material_of(-2.0), lamp);
    // The lamp's triangle is a light of its own, beside the scene's point light.
    assert_eq!(scene.lights.len(), 2);
    // Each unused statement is named once, with its first line.
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    let w = &scene.warnings[0];
    assert!(
        w.ends_with("parts.mtl: not used by the renderer: map_Kd (line 5), map_Ks (line 9)"),
        "{w}"
    );
    // The same bits at every width.
    let mut scene = scene;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let films: Vec<_> = PacketWidth::ALL
        .into_iter()
        .map(|packet_width| {
            let settings = RenderSettings {
                packet_width,
                ..RenderSettings::new(0)
            };
            bits(&render(&scene, &accel, &settings, &|| {}).unwrap().film)
        })
        .collect();
    assert!(films.iter().all(|f| *f == films[0]));
}

#[test]
fn mtl_errors_name_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let load = |scene: &str, files: &[(&str, String)]| {
        for (name, body) in files {
            std::fs::write(dir.path().join(name), body).unwrap();
        }
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, scene).unwrap();
        match Scene::load(path.to_str().unwrap(), Overrides::default()) {
            Ok(_) => panic!("loaded:\n{scene}"),
            Err(e) => e
                .to_string()
                .replace(&format!("{}/", dir.path().display()), ""),
        }
    };
    let scene = mesh_scene("materials = \"mtl\"");
    let mut files = mtl_files(PARTS_MTL);
    // A missing library: named, at the OBJ's mtllib line.
    files[1].0 = "other.mtl";
    let message = load(&scene, &files);
    assert!(
        message.starts_with("mesh.obj:1: cannot read material library parts.mtl"),
        "{message}"
    );
    std::fs::remove_file(dir.path().join("other.mtl")).unwrap();
    // A usemtl that names no material of the library.
    let mut files = mtl_files(PARTS_MTL);
    files[0].1 = files[0].1.replace("usemtl lamp", "usemtl lump");
    let message = load(&scene, &files);
    assert!(
        message.contains("mesh.obj:") && message.contains("usemtl 'lump'"),
        "{message}"
    );
    // A bad value in the library: its own file and line.
    let files = mtl_files("newmtl red\nKd 1 1 1\nnewmtl lamp\nNs -4\n");
    let message = load(&scene, &files);
    assert!(message.starts_with("parts.mtl:4: Ns"), "{message}");
    // No library at all: at the scene's `materials` line.
    let files = [("mesh.obj", obj_text(&random_mesh(2, 1)))];
    let message = load(&scene, &files);
    assert!(
        message.starts_with("scene.toml:22:") && message.contains("names no material library"),
        "{message}"
    );
}

#[test]
fn a_missing_library_exits_with_code_2_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = mtl_files(PARTS_MTL);
    files.pop();
    for (name, body) in &files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    let scene = dir.path().join("scene.toml");
    std::fs::write(&scene, mesh_scene("materials = \"mtl\"")).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raytracer"))
        .arg(&scene)
        .args(["-q", "-o"])
        .arg(dir.path().join("out.png"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("parts.mtl"), "{stderr}");
    assert!(!dir.path().join("out.png").exists());
    // With the library, the unused statements are a warning, and the render goes on.
    std::fs::write(dir.path().join("parts.mtl"), PARTS_MTL).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_raytracer"))
        .arg(&scene)
        .args(["-q", "-o"])
        .arg(dir.path().join("out.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("warning:") && stderr.contains("map_Kd (line 5)"),
        "{stderr}"
    );
}

#[test]
fn the_models_scene_places_its_models_in_their_materials() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/models/models.toml");
    let overrides = Overrides {
        width: Some(32),
        spp: Some(1),
        max_depth: Some(3),
    };
    let scene = Scene::load(path, overrides).unwrap();
    // Its library holds only what the mapping uses.
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // The sun, and the lamp's bulb (an MTL light).
    assert_eq!(scene.lights.len(), 2);
    let kinds: Vec<&str> = scene
        .materials
        .iter()
        .map(|m| match m {
            Material::Phong(_) => "phong",
            Material::PhongMirror { .. } => "mirror",
            Material::Dielectric { .. } => "glass",
            Material::Light { .. } => "light",
            _ => "other",
        })
        .collect();
    for kind in ["phong", "mirror", "glass", "light"] {
        assert!(kinds.contains(&kind), "no {kind} material: {kinds:?}");
    }
    assert!(!scene.triangles.normals.is_empty());
    // The pawn stored once, placed three times.
    assert_eq!((scene.prototypes.len(), scene.instances.len()), (1, 3));
    let mut scene = scene;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let films: Vec<_> = PacketWidth::ALL
        .into_iter()
        .map(|packet_width| {
            let settings = RenderSettings {
                packet_width,
                ..RenderSettings::new(0)
            };
            render(&scene, &accel, &settings, &|| {}).unwrap().film
        })
        .collect();
    assert_eq!(films[0].non_finite_count(), 0);
    assert!(films.iter().all(|f| bits(f) == bits(&films[0])));
}
