//! Meshes as users bring them: placed by a transform (`scale`, `rotate`, `translate`,
//! `matrix`), each vertex moved in f64 and checked against an f64 oracle written here.

mod support;

use glam::{DVec3, Vec3};
use raytracer::scene::{Overrides, Scene};
use support::{obj_text, Rng};

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
