//! Instances: a mesh stored once (`[meshes.NAME]`) and placed by `type = "instance"`
//! objects, against the same triangles flattened into the scene as mesh objects: the
//! same bits where the transform is the identity, within a relMSE of 1e-4 otherwise
//! (rays moved into the mesh's space round differently from moved vertices), no leak
//! through a closed instanced mesh, the same bits at every width, thread count and
//! acceleration structure, and errors at their line.

mod support;

use glam::Vec3;
use raytracer::accel::{Accel, AccelKind};
use raytracer::generate::icosphere;
use raytracer::geometry::Ray;
use raytracer::integrator::{RayCounts, Tracer};
use raytracer::metrics::rel_mse;
use raytracer::scene::Scene;
use raytracer::{PacketWidth, RenderSettings};
use support::{bits, obj_text, render_settings, scene_with_files, Rng};

/// The scene around the meshes: a floor quad, a point light, a panel light (shadow
/// rays of both kinds), a Phong and a mirror material, and `objects` after them.
fn scene(width: u32, meshes: &str, objects: &str) -> String {
    format!(
        r#"
ambient = [0.1, 0.1, 0.1]
[camera]
width = {width}
samples_per_pixel = 2
max_depth = 4
look_from = [0, 2.5, 7]
look_at = [0, 0.3, 0]
vfov = 40
[materials.white]
type = "phong"
albedo = [0.8, 0.8, 0.8]
shininess = 30
[materials.red]
type = "phong"
albedo = [0.8, 0.2, 0.1]
shininess = 300
[materials.chrome]
type = "phong_mirror"
albedo = [0.9, 0.9, 0.9]
shininess = 500
index = 2.5
[materials.lamp]
type = "light"
color = [1, 1, 1]
[[objects]]
type = "quad"
corner = [-5, -1, 5]
u = [10, 0, 0]
v = [0, 0, -10]
material = "white"
[[objects]]
type = "sphere"
center = [3, 4, 4]
radius = 0.2
material = "lamp"
[[objects]]
type = "quad"
corner = [-1, 4, -1]
u = [1, 0, 0]
v = [0, 0, 1]
material = "lamp"
{objects}
{meshes}
"#
    )
}

/// The placements of the tests: (material, transform keys).
const PLACES: [(&str, &str); 4] = [
    ("red", "translate = [-1.6, 0, 0]"),
    ("chrome", "scale = 0.8\nrotate = [{ axis = [0, 1, 0], degrees = 30 }]\ntranslate = [0, 0, 0.4]"),
    ("white", "scale = [1, 0.5, 1.2]\nrotate = [{ axis = [1, 0, 1], degrees = -20 }]\ntranslate = [1.7, -0.3, -0.6]"),
    ("red", "matrix = [[0.5, 0, 0, 0.2], [0, 0.5, 0, 1.6], [0, 0, 0.5, -1.5], [0, 0, 0, 1]]"),
];

/// The same meshes as mesh objects (`flat`) and as instances of one `[meshes.ball]`.
fn pair(width: u32, places: &[(&str, &str)], normals: &str) -> (String, String) {
    let mut flat = String::new();
    let mut placed = String::new();
    for (material, keys) in places {
        flat += &format!(
            "[[objects]]\ntype = \"mesh\"\npath = \"ball.obj\"\nmaterial = \"{material}\"\nnormals = \"{normals}\"\n{keys}\n"
        );
        placed +=
            &format!("[[objects]]\ntype = \"instance\"\nmesh = \"ball\"\nmaterial = \"{material}\"\n{keys}\n");
    }
    let mesh = format!(
        "[meshes.ball]\npath = \"ball.obj\"\nmaterial = \"white\"\nnormals = \"{normals}\"\n"
    );
    (scene(width, "", &flat), scene(width, &mesh, &placed))
}

/// The icosphere of `levels` of radius 1 at the origin.
fn sphere(levels: u32) -> Vec<[Vec3; 3]> {
    icosphere(levels, Vec3::ZERO, 1.0)
}

fn ball() -> Vec<(&'static str, String)> {
    vec![("ball.obj", obj_text(&sphere(2)))]
}

fn film(scene: &Scene, width: PacketWidth, threads: usize, accel: AccelKind) -> Vec<Vec3> {
    let settings = RenderSettings {
        packet_width: width,
        ..RenderSettings::default()
    };
    render_settings(scene, accel, threads, &settings)
        .film
        .pixels
}

#[test]
fn an_identity_instance_is_its_mesh_object_bit_for_bit() {
    let (flat, placed) = pair(48, &[("red", ""), ("chrome", "")], "flat");
    let (flat, placed) = (
        scene_with_files(&flat, &ball()),
        scene_with_files(&placed, &ball()),
    );
    assert_eq!(placed.instances.len(), 2);
    assert!(
        placed.triangles.is_empty(),
        "the mesh is stored once, apart"
    );
    for width in PacketWidth::ALL {
        let want = film(&flat, width, 1, AccelKind::Bvh);
        let got = film(&placed, width, 2, AccelKind::Bvh);
        assert!(
            want == got,
            "{width:?}: the instances differ from the mesh objects"
        );
    }
}

#[test]
fn placed_instances_are_within_1e4_of_their_flattened_meshes() {
    for normals in ["flat", "smooth"] {
        let (flat, placed) = pair(64, &PLACES, normals);
        let (flat, placed) = (
            scene_with_files(&flat, &ball()),
            scene_with_files(&placed, &ball()),
        );
        let want = film(&flat, PacketWidth::Scalar, 1, AccelKind::Bvh);
        let got = film(&placed, PacketWidth::Scalar, 1, AccelKind::Bvh);
        let e = rel_mse(&got, &want);
        assert!(e <= 1e-4, "{normals}: relMSE {e:e}");
        let lit = want.iter().filter(|p| p.max_element() > 0.05).count();
        assert!(lit > want.len() / 4, "the meshes and floor are lit");
    }
}

#[test]
fn instances_render_the_same_bits_at_every_width_thread_count_and_structure() {
    let (_, placed) = pair(40, &PLACES, "smooth");
    let placed = scene_with_files(&placed, &ball());
    let reference = film(&placed, PacketWidth::Scalar, 1, AccelKind::Bvh);
    assert!(reference.iter().all(|p| p.is_finite()));
    for width in PacketWidth::ALL {
        let got = film(&placed, width, 2, AccelKind::Bvh);
        assert!(got == reference, "{width:?} differs");
    }
    let linear = film(&placed, PacketWidth::Scalar, 1, AccelKind::Linear);
    assert!(linear == reference, "the linear scan differs");
    let settings = RenderSettings::default();
    let a = render_settings(&placed, AccelKind::Bvh, 1, &settings).film;
    let b = render_settings(&placed, AccelKind::Bvh, 2, &settings).film;
    assert_eq!(bits(&a), bits(&b));
}

/// Rays from random points outside the ball (radius 1, placed at `keys`) towards
/// random points inside it: every one must hit an instance, none pass through.
#[test]
fn no_ray_leaks_through_a_placed_closed_mesh() {
    let keys = "scale = [1.5, 0.7, 1.1]\nrotate = [{ axis = [1, 2, 3], degrees = 37 }]\ntranslate = [0.3, 0.1, -0.2]";
    // The instance alone: nothing else in the rays' way.
    let text = format!(
        "[materials.white]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [meshes.ball]\npath = \"ball.obj\"\nmaterial = \"white\"\n\
         [[objects]]\ntype = \"instance\"\nmesh = \"ball\"\n{keys}\n"
    );
    let mut scene = scene_with_files(&text, &ball());
    let inst = scene.instances[0].clone();
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let tracer = Tracer::new(&scene, &accel, 1);
    let mut counts = RayCounts::default();
    let mut rng = Rng(7);
    let object = inst.first_object;
    // The icosphere of level 2 holds the sphere of radius 0.9 (its faces' distance).
    let inside = |rng: &mut Rng| {
        let p = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        p * (0.85 / p.length().max(1.0))
    };
    for _ in 0..20_000 {
        let target = inst.to_world.point(inside(&mut rng)).as_vec3();
        let from = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        )
        .normalize()
            * 6.0;
        let ray = Ray::new(from, (target - from).normalize());
        let hit = tracer.closest_hit(&ray, &mut counts);
        assert!(
            hit.is_some_and(|h| h.object == object),
            "{ray:?} passed through the instance"
        );
    }
}

fn refused(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), obj_text(&sphere(1))).unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    match Scene::load(path.to_str().unwrap(), Default::default()) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_instances_are_refused_at_their_line() {
    let mesh = "[meshes.ball]\npath = \"ball.obj\"\nmaterial = \"white\"\n";
    let instance = |keys: &str| format!("[[objects]]\ntype = \"instance\"\n{keys}\n");
    for (meshes, object, want) in [
        (
            mesh,
            instance("mesh = \"cube\""),
            "unknown mesh 'cube' (meshes: ball)",
        ),
        (
            mesh,
            instance("mesh = \"ball\"\nmaterial = \"gold\""),
            "unknown material 'gold'",
        ),
        (
            mesh,
            instance("mesh = \"ball\"\nmaterial = \"lamp\""),
            "an instance cannot be a light",
        ),
        (
            mesh,
            instance("mesh = \"ball\"\nscale = 0"),
            "scale must be finite and non-zero",
        ),
        (
            mesh,
            instance("mesh = \"ball\"\ntranslate = [1e11, 0, 0]"),
            "within ±1e10",
        ),
        (
            mesh,
            instance("mesh = \"ball\"\ncolour = 1"),
            "unknown field `colour`",
        ),
        (
            "[meshes.ball]\npath = \"none.obj\"\nmaterial = \"white\"\n",
            instance("mesh = \"ball\""),
            "cannot read mesh",
        ),
        (
            "[meshes.ball]\npath = \"ball.obj\"\nmaterial = \"ivory\"\n",
            instance("mesh = \"ball\""),
            "mesh 'ball': unknown material 'ivory'",
        ),
    ] {
        let text = scene(8, meshes, &object);
        let message = refused(&text);
        assert!(message.contains(want), "{message}\nwanted: {want}");
        assert!(message.contains("scene.toml:"), "{message} names no line");
    }
}

#[test]
fn a_mesh_no_instance_places_is_a_warning() {
    let text = scene(
        8,
        "[meshes.ball]\npath = \"ball.obj\"\nmaterial = \"white\"\n",
        "",
    );
    let scene = scene_with_files(&text, &ball());
    assert_eq!(scene.warnings, ["mesh 'ball' is placed by no instance"]);
    assert!(scene.instances.is_empty());
}

/// Memory: a hundred instances hold one copy of the mesh and its tree.
#[test]
fn instances_store_their_mesh_once() {
    let places: Vec<(&str, String)> = (0..100)
        .map(|i| ("white", format!("translate = [{}, 0, {}]", i % 10, i / 10)))
        .collect();
    let objects: String = places
        .iter()
        .map(|(m, k)| {
            format!("[[objects]]\ntype = \"instance\"\nmesh = \"ball\"\nmaterial = \"{m}\"\n{k}\n")
        })
        .collect();
    let text = scene(
        8,
        "[meshes.ball]\npath = \"ball.obj\"\nmaterial = \"white\"\n",
        &objects,
    );
    let mut scene = scene_with_files(&text, &ball());
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    assert_eq!(scene.instances.len(), 100);
    assert_eq!(scene.prototypes.len(), 1);
    assert_eq!(accel.prototypes.len(), 1);
    assert_eq!(scene.prototypes[0].scene.triangles.len(), sphere(2).len());
    // Ids: each instance's follow the one before, in file order.
    for (a, b) in scene.instances.iter().zip(&scene.instances[1..]) {
        assert_eq!(b.first_id - a.first_id, sphere(2).len() as u32);
        assert_eq!(b.first_object, a.first_object + 1);
    }
}

/// Twenty-four instances: the instance level is a tree of several levels, which single
/// rays traverse 4-wide and packets 2-wide; every width, the linear scan and the
/// flattened meshes agree.
#[test]
fn many_instances_agree_at_every_width_and_with_their_flattened_meshes() {
    let keys: Vec<String> = (0..24)
        .map(|i| {
            let (x, z) = ((i % 6) as f32 * 0.9 - 2.2, (i / 6) as f32 * -0.9 + 0.5);
            format!(
                "scale = {}\nrotate = [{{ axis = [0, 1, 1], degrees = {} }}]\ntranslate = [{x}, -0.4, {z}]",
                0.3 + 0.02 * (i % 5) as f32,
                i * 23
            )
        })
        .collect();
    let places: Vec<(&str, &str)> = keys
        .iter()
        .enumerate()
        .map(|(i, k)| (["red", "white", "chrome"][i % 3], k.as_str()))
        .collect();
    let (flat, placed) = pair(48, &places, "smooth");
    let (flat, placed) = (
        scene_with_files(&flat, &ball()),
        scene_with_files(&placed, &ball()),
    );
    let reference = film(&placed, PacketWidth::Scalar, 1, AccelKind::Bvh);
    for width in PacketWidth::ALL {
        assert!(
            film(&placed, width, 2, AccelKind::Bvh) == reference,
            "{width:?} differs"
        );
    }
    let linear = film(&placed, PacketWidth::Scalar, 1, AccelKind::Linear);
    assert!(linear == reference, "the linear scan differs");
    let want = film(&flat, PacketWidth::Scalar, 1, AccelKind::Bvh);
    let e = rel_mse(&reference, &want);
    assert!(e <= 1e-4, "relMSE {e:e}");
}
