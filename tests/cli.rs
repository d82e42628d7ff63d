//! The command line, end to end: the real binary on bad input and on tiny renders.
//!
//! Every bad-input case must exit with code 2 and one line on stderr that names the file
//! (and line) or the flag, must not panic, must not create any file and must leave an
//! existing output file byte-for-byte as it was. Each case runs twice, in a fresh
//! directory: once without the output file and once with a pre-existing one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");

/// A run that takes longer than this is a failure (a bad case must fail before rendering;
/// the good ones are 8 pixels wide).
const TIMEOUT: Duration = Duration::from_secs(120);

/// Bytes of a pre-existing output file, which a failing run must leave alone.
const SENTINEL: &[u8] = b"not an image: must survive a failed run\n";

/// A tiny valid scene; the line numbers are part of the expected messages.
const BASE: &str = r#"description = "a tiny test scene"
background = [0.1, 0.1, 0.1]

[camera]
width = 8
aspect_ratio = 1.0
samples_per_pixel = 1
max_depth = 2
vfov = 90
look_from = [0, 0, 0]
look_at = [0, 0, -1]

[materials.red]
type = "phong"
albedo = [0.8, 0.1, 0.1]
shininess = 10

[materials.lamp]
type = "light"
color = [1, 1, 1]

[[objects]]
type = "sphere"
center = [0, 0, -2]
radius = 0.5
material = "red"

[[objects]]
type = "sphere"
center = [1, 1, -1]
radius = 0.1
material = "lamp"
"#;

// Lines of BASE that messages point at.
const CAMERA_LINE: &str = "bad.toml:4:1:";
const RED_LINE: &str = "bad.toml:13:1:";
const FIRST_OBJECT_LINE: &str = "bad.toml:22:1:";
/// The header of an object added by `with_object`.
const EXTRA_OBJECT_LINE: &str = "bad.toml:34:1:";

/// BASE with one exact, unique piece of text replaced.
fn edit(from: &str, to: &str) -> String {
    assert_eq!(
        BASE.matches(from).count(),
        1,
        "'{from}' must occur once in BASE"
    );
    BASE.replace(from, to)
}

/// BASE with a third object (an `[[objects]]` table without its header).
fn with_object(body: &str) -> String {
    format!("{BASE}\n[[objects]]\n{body}")
}

/// A small OBJ triangle in front of the camera of BASE.
const GOOD_OBJ: &str = "v 0 0 -2\nv 1 0 -2\nv 0 1 -2\nf 1 2 3\n";

fn mesh_object() -> String {
    with_object("type = \"mesh\"\npath = \"mesh.obj\"\nmaterial = \"red\"\n")
}

// ---------------------------------------------------------------------------------------
// Running the binary.

#[derive(Debug)]
struct Run {
    /// `None` when the process was killed by a signal (an abort, for one).
    code: Option<i32>,
    stdout: String,
    stderr: String,
    /// Standard output as bytes (an image written to `-o -`).
    stdout_bytes: Vec<u8>,
}

/// Run the binary in `dir` with a time limit; stdout and stderr go to files elsewhere.
fn run_in(dir: &Path, args: &[String]) -> Run {
    let logs = TempDir::new().expect("temporary directory");
    let out_path = logs.path().join("stdout");
    let err_path = logs.path().join("stderr");
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out_path).expect("stdout file"))
        .stderr(std::fs::File::create(&err_path).expect("stderr file"))
        .spawn()
        .expect("start the raytracer binary");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for the binary") {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("raytracer {args:?} ran for more than {TIMEOUT:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let read =
        |p: &Path| String::from_utf8_lossy(&std::fs::read(p).unwrap_or_default()).into_owned();
    Run {
        code: status.code(),
        stdout: read(&out_path),
        stderr: read(&err_path),
        stdout_bytes: std::fs::read(&out_path).unwrap_or_default(),
    }
}

/// Every file and directory under `dir`, with the bytes of the files.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    fn walk(root: &Path, dir: &Path, into: &mut BTreeMap<PathBuf, Option<Vec<u8>>>) {
        for entry in std::fs::read_dir(dir).expect("read the test directory") {
            let path = entry.expect("directory entry").path();
            let rel = path.strip_prefix(root).expect("inside root").to_path_buf();
            if path.is_dir() {
                into.insert(rel, None);
                walk(root, &path, into);
            } else {
                into.insert(rel, Some(std::fs::read(&path).expect("read a test file")));
            }
        }
    }
    let mut files = BTreeMap::new();
    walk(dir, dir, &mut files);
    files
}

/// Files, directories and arguments of one run.
#[derive(Clone, Debug, Default)]
struct Case {
    files: Vec<(String, Vec<u8>)>,
    dirs: Vec<String>,
    args: Vec<String>,
}

impl Case {
    fn new(args: &[&str]) -> Self {
        Case {
            args: args.iter().map(|a| a.to_string()).collect(),
            ..Case::default()
        }
    }

    /// `bad.toml` with `text`, rendered to `out.png`.
    fn scene(text: &str) -> Self {
        Case::new(&["bad.toml", "-o", "out.png"]).file("bad.toml", text)
    }

    /// The built-in `spheres`, tiny, to `out.png`, with `extra` arguments.
    fn spheres(extra: &[&str]) -> Self {
        let mut args = vec!["spheres", "--width", "8", "--spp", "1", "-o", "out.png"];
        args.extend_from_slice(extra);
        Case::new(&args)
    }

    fn file(mut self, name: &str, contents: impl AsRef<[u8]>) -> Self {
        self.files.push((name.into(), contents.as_ref().to_vec()));
        self
    }

    /// The arguments with `extra` after them.
    fn args(mut self, extra: &[&str]) -> Self {
        self.args.extend(extra.iter().map(|a| a.to_string()));
        self
    }

    fn dir(mut self, name: &str) -> Self {
        self.dirs.push(name.into());
        self
    }

    /// The value of `-o`/`--output`, if any.
    fn output(&self) -> Option<&str> {
        let i = self
            .args
            .iter()
            .position(|a| a == "-o" || a == "--output")?;
        self.args.get(i + 1).map(String::as_str)
    }

    fn setup(&self, dir: &Path) {
        for d in &self.dirs {
            std::fs::create_dir_all(dir.join(d)).expect("create a test directory");
        }
        for (name, contents) in &self.files {
            std::fs::write(dir.join(name), contents).expect("write a test file");
        }
    }

    /// Run in a fresh directory; the directory is returned to look at the outputs.
    fn run(&self) -> (TempDir, Run) {
        let dir = TempDir::new().expect("temporary directory");
        self.setup(dir.path());
        let run = run_in(dir.path(), &self.args);
        (dir, run)
    }

    /// A bad case rejected by the program: exit 2 and one line that contains every
    /// `expected` text.
    fn fails_with(&self, expected: &[&str]) {
        self.check_failure(expected, true);
    }

    /// A bad flag, rejected by clap: exit 2 and a message (clap's, with a usage hint on
    /// further lines) that names the flag.
    fn fails_in_clap(&self, flag: &str) {
        self.check_failure(&[flag], false);
    }

    fn check_failure(&self, expected: &[&str], one_line: bool) {
        for preexisting in [false, true] {
            let dir = TempDir::new().expect("temporary directory");
            self.setup(dir.path());
            if preexisting {
                match self.output().map(|o| dir.path().join(o)) {
                    // Only an output the directory can hold (not `/nonexistent-dir/x.png`)
                    // and that the case has not made already (a directory named out.png).
                    Some(out)
                        if out.starts_with(dir.path())
                            && out.parent().is_some_and(Path::is_dir)
                            && !out.exists() =>
                    {
                        std::fs::write(&out, SENTINEL).expect("write the existing output")
                    }
                    _ => continue,
                }
            }
            let before = snapshot(dir.path());
            let run = run_in(dir.path(), &self.args);
            let context = format!(
                "raytracer {:?} (existing output: {preexisting})\nexit: {:?}\nstderr:\n{}",
                self.args, run.code, run.stderr
            );
            assert_eq!(run.code, Some(2), "exit code must be 2: {context}");
            assert!(!run.stderr.contains("panicked"), "panic: {context}");
            assert!(
                run.stdout.is_empty(),
                "stdout must be empty: {context}\nstdout:\n{}",
                run.stdout
            );
            let message = run.stderr.trim_end();
            assert!(
                message.starts_with("error: "),
                "no error message: {context}"
            );
            if one_line {
                assert!(!message.contains('\n'), "not one line: {context}");
            }
            for e in expected {
                assert!(message.contains(e), "message lacks '{e}': {context}");
            }
            let after = snapshot(dir.path());
            assert!(
                before == after,
                "files changed: {context}\nbefore: {:?}\nafter: {:?}",
                before.keys().collect::<Vec<_>>(),
                after.keys().collect::<Vec<_>>()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Controls: the fixtures the bad cases start from are good.

#[test]
fn control_base_scene_renders() {
    let (dir, run) = Case::scene(BASE).run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(dir.path().join("out.png").is_file());
}

#[test]
fn control_mesh_scene_renders() {
    let (dir, run) = Case::scene(&mesh_object()).file("mesh.obj", GOOD_OBJ).run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(dir.path().join("out.png").is_file());
}

// ---------------------------------------------------------------------------------------
// The scene argument.

#[test]
fn unknown_scene_name_lists_the_builtin_scenes() {
    Case::new(&["nosuch", "-o", "out.png"])
        .fails_with(&["'nosuch'", "bunny", "cornell", "spheres"]);
}

#[test]
fn missing_toml_file() {
    let case = Case::new(&["missing.toml", "-o", "out.png"]);
    case.fails_with(&["cannot read missing.toml: "]);
    // The reason once, not twice ("missing.toml: No such file…: No such file…").
    let (_dir, run) = case.run();
    assert_eq!(run.stderr.matches("os error").count(), 1, "{}", run.stderr);
}

#[test]
fn missing_toml_file_in_missing_directory() {
    Case::new(&["no-such-dir/scene.toml", "-o", "out.png"]).fails_with(&["no-such-dir/scene.toml"]);
}

#[test]
fn unreadable_toml_is_a_directory() {
    Case::new(&["dir.toml", "-o", "out.png"])
        .dir("dir.toml")
        .fails_with(&["dir.toml"]);
}

#[test]
fn unreadable_toml_is_not_utf8() {
    Case::new(&["binary.toml", "-o", "out.png"])
        .file("binary.toml", b"description = \"\xff\xfe\"\n")
        .fails_with(&["binary.toml", "UTF-8"]);
}

// ---------------------------------------------------------------------------------------
// TOML syntax and unknown keys.

#[test]
fn toml_syntax_error_names_line_and_column() {
    // Line 9 becomes `vfov = ` with no value.
    Case::scene(&edit("vfov = 90", "vfov = ")).fails_with(&["bad.toml:9:8:"]);
}

#[test]
fn toml_unclosed_table_header_is_one_line() {
    Case::scene(&edit("[materials.lamp]", "[materials.lamp"))
        .fails_with(&["bad.toml:18:16:", "table header"]);
}

/// Text a bad file quotes into its message (an unknown key) cannot break the message's
/// line or send the terminal an escape sequence: control characters are escaped.
#[test]
fn quoted_control_characters_are_escaped() {
    Case::scene(&edit("vfov = 90", "vfov = 90\n\"x\\u001b[31my\" = 1"))
        .fails_with(&["bad.toml:10:1:", "unknown field `x\\u{1b}[31my`"]);
}

#[test]
fn toml_duplicate_key() {
    Case::scene(&edit("radius = 0.5\n", "radius = 0.5\nradius = 0.6\n"))
        .fails_with(&["bad.toml:26:", "duplicate key `radius`"]);
}

#[test]
fn toml_wrong_type() {
    Case::scene(&edit(
        "samples_per_pixel = 1",
        "samples_per_pixel = \"one\"",
    ))
    .fails_with(&["bad.toml:7:21:", "invalid type"]);
}

#[test]
fn unknown_key_at_top_level() {
    Case::scene(&edit("background =", "backgroud ="))
        .fails_with(&["bad.toml:2:1:", "unknown field `backgroud`"]);
}

#[test]
fn unknown_key_in_camera() {
    Case::scene(&edit("vfov = 90", "fov = 90"))
        .fails_with(&["bad.toml:9:1:", "unknown field `fov`"]);
}

#[test]
fn unknown_key_in_material() {
    Case::scene(&edit("shininess = 10", "shininess = 10\nroughness = 0.5"))
        .fails_with(&["bad.toml:17:1:", "unknown field `roughness`"]);
}

#[test]
fn unknown_key_in_object() {
    Case::scene(&edit("center = [0, 0, -2]", "centre = [0, 0, -2]"))
        .fails_with(&["bad.toml:24:1:", "unknown field `centre`"]);
}

#[test]
fn unknown_key_in_inline_object() {
    let text = "objects = [{ type = \"sphere\", center = [0, 0, -2], radius = 1, material = \"m\", scale = 2 }]\n";
    Case::scene(text).fails_with(&["bad.toml:1:", "unknown field `scale`"]);
}

#[test]
fn unknown_material_type() {
    Case::scene(&edit("type = \"phong\"", "type = \"lambert\""))
        .fails_with(&["bad.toml:14:", "lambert"]);
}

// ---------------------------------------------------------------------------------------
// Invalid values.

#[test]
fn negative_radius() {
    Case::scene(&edit("radius = 0.5", "radius = -0.5")).fails_with(&[
        FIRST_OBJECT_LINE,
        "radius",
        "-0.5",
    ]);
}

#[test]
fn zero_radius() {
    Case::scene(&edit("radius = 0.5", "radius = 0")).fails_with(&[FIRST_OBJECT_LINE, "radius"]);
}

#[test]
fn zero_area_quad_with_parallel_edges() {
    let text = with_object(
        "type = \"quad\"\ncorner = [0, 0, -2]\nu = [1, 0, 0]\nv = [2, 0, 0]\nmaterial = \"red\"\n",
    );
    Case::scene(&text).fails_with(&[EXTRA_OBJECT_LINE, "object 3 (quad)", "zero area"]);
}

#[test]
fn zero_area_triangle_with_collinear_vertices() {
    let text = with_object(
        "type = \"triangle\"\na = [0, 0, -2]\nb = [1, 1, -2]\nc = [2, 2, -2]\nmaterial = \"red\"\n",
    );
    Case::scene(&text).fails_with(&[EXTRA_OBJECT_LINE, "object 3 (triangle)", "collinear"]);
}

#[test]
fn box_with_corners_equal_on_one_axis() {
    let text =
        with_object("type = \"box\"\ncorners = [[0, 0, -3], [1, 0, -2]]\nmaterial = \"red\"\n");
    Case::scene(&text).fails_with(&[EXTRA_OBJECT_LINE, "object 3 (box)", "every axis"]);
}

#[test]
fn box_whose_extent_overflows() {
    let text = with_object(
        "type = \"box\"\ncorners = [[-3e38, 0, -3], [3e38, 1, -2]]\nmaterial = \"red\"\n",
    );
    Case::scene(&text).fails_with(&[EXTRA_OBJECT_LINE, "object 3 (box)", "too large"]);
}

#[test]
fn samples_per_pixel_zero() {
    Case::scene(&edit("samples_per_pixel = 1", "samples_per_pixel = 0"))
        .fails_with(&[CAMERA_LINE, "samples_per_pixel"]);
}

#[test]
fn width_zero() {
    Case::scene(&edit("width = 8", "width = 0")).fails_with(&[CAMERA_LINE, "width"]);
}

#[test]
fn width_negative() {
    Case::scene(&edit("width = 8", "width = -8")).fails_with(&[CAMERA_LINE, "width"]);
}

#[test]
fn max_depth_zero() {
    Case::scene(&edit("max_depth = 2", "max_depth = 0")).fails_with(&[CAMERA_LINE, "max_depth"]);
}

#[test]
fn vfov_zero() {
    Case::scene(&edit("vfov = 90", "vfov = 0")).fails_with(&[CAMERA_LINE, "vfov"]);
}

#[test]
fn vfov_180() {
    Case::scene(&edit("vfov = 90", "vfov = 180")).fails_with(&[CAMERA_LINE, "vfov"]);
}

#[test]
fn vfov_nan() {
    Case::scene(&edit("vfov = 90", "vfov = nan")).fails_with(&[CAMERA_LINE, "vfov"]);
}

/// The lens keys out of range: exit 2, the message at the value's line and column
/// (line 12 of BASE with the key added after `look_at`).
#[test]
fn lens_values_out_of_range() {
    let cases = [
        ("defocus_angle = -1", "12:17:", "defocus_angle"),
        ("defocus_angle = -1e-300", "12:17:", "defocus_angle"),
        ("defocus_angle = 180", "12:17:", "defocus_angle"),
        ("defocus_angle = 1e9", "12:17:", "defocus_angle"),
        ("defocus_angle = nan", "12:17:", "defocus_angle"),
        ("defocus_angle = inf", "12:17:", "defocus_angle"),
        ("focus_dist = 0", "12:14:", "focus_dist"),
        ("focus_dist = -0.0", "12:14:", "focus_dist"),
        ("focus_dist = -2", "12:14:", "focus_dist"),
        ("focus_dist = nan", "12:14:", "focus_dist"),
        ("focus_dist = inf", "12:14:", "focus_dist"),
        ("focus_dist = -inf", "12:14:", "focus_dist"),
        // The viewport overflows f32; it lies too near the eye for f32 to tell apart.
        ("focus_dist = 1e300", "12:14:", "too large"),
        ("focus_dist = 1e-30", "12:14:", "at least"),
    ];
    for (line, at, what) in cases {
        let text = edit(
            "look_at = [0, 0, -1]",
            &format!("look_at = [0, 0, -1]\n{line}"),
        );
        Case::scene(&text).fails_with(&[&format!("bad.toml:{at}"), what]);
    }
    // Relative to the camera's coordinates: 2⁻²⁰ of 1000 is about 9.5e-4.
    let far = edit("look_from = [0, 0, 0]", "look_from = [1000, 0, 0]");
    let near = far.replace(
        "look_at = [0, 0, -1]",
        "look_at = [0, 0, -1]\nfocus_dist = 1e-4",
    );
    Case::scene(&near).fails_with(&["bad.toml:12:14:", "focus_dist", "at least"]);
    // A wide lens reaches far from the eye: the same rule.
    let wide = near.replace(
        "focus_dist = 1e-4",
        "focus_dist = 0.01\ndefocus_angle = 179.9999",
    );
    Case::scene(&wide).fails_with(&["bad.toml:12:14:", "focus_dist", "at least"]);
}

#[test]
fn aspect_ratio_zero() {
    Case::scene(&edit("aspect_ratio = 1.0", "aspect_ratio = 0.0"))
        .fails_with(&[CAMERA_LINE, "aspect_ratio"]);
}

#[test]
fn aspect_ratio_malformed_text() {
    Case::scene(&edit("aspect_ratio = 1.0", "aspect_ratio = \"16/9\""))
        .fails_with(&[CAMERA_LINE, "aspect_ratio"]);
}

#[test]
fn nan_in_sphere_centre() {
    Case::scene(&edit("center = [0, 0, -2]", "center = [0, nan, -2]"))
        .fails_with(&[FIRST_OBJECT_LINE, "finite"]);
}

#[test]
fn inf_in_sphere_centre() {
    Case::scene(&edit("center = [0, 0, -2]", "center = [-inf, 0, -2]"))
        .fails_with(&[FIRST_OBJECT_LINE, "finite"]);
}

#[test]
fn nan_in_material_colour() {
    Case::scene(&edit(
        "albedo = [0.8, 0.1, 0.1]",
        "albedo = [0.8, nan, 0.1]",
    ))
    .fails_with(&[RED_LINE, "material 'red'", "albedo"]);
}

#[test]
fn inf_in_light_colour() {
    Case::scene(&edit("color = [1, 1, 1]", "color = [1, +inf, 1]")).fails_with(&[
        "bad.toml:18:1:",
        "material 'lamp'",
        "color",
    ]);
}

#[test]
fn nan_in_background() {
    Case::scene(&edit(
        "background = [0.1, 0.1, 0.1]",
        "background = [nan, 0.1, 0.1]",
    ))
    .fails_with(&["bad.toml:2:", "background"]);
}

#[test]
fn negative_colour() {
    Case::scene(&edit(
        "albedo = [0.8, 0.1, 0.1]",
        "albedo = [0.8, -0.1, 0.1]",
    ))
    .fails_with(&[RED_LINE, "albedo"]);
}

#[test]
fn unknown_material_name() {
    Case::scene(&edit("material = \"red\"", "material = \"blue\"")).fails_with(&[
        FIRST_OBJECT_LINE,
        "unknown material 'blue'",
        "lamp, red",
    ]);
}

#[test]
fn look_from_equals_look_at() {
    Case::scene(&edit("look_at = [0, 0, -1]", "look_at = [0, 0, 0]"))
        .fails_with(&[CAMERA_LINE, "look_at"]);
}

#[test]
fn up_parallel_to_view_direction() {
    Case::scene(&edit(
        "look_at = [0, 0, -1]",
        "look_at = [0, 0, -1]\nup = [0, 0, 1]",
    ))
    .fails_with(&[CAMERA_LINE, "up"]);
}

#[test]
fn image_too_large_by_aspect_ratio() {
    // 65536 at 1:65536 is 65536 x 2^32: the height must not wrap around to a small number.
    let text = edit(
        "width = 8\naspect_ratio = 1.0",
        "width = 65536\naspect_ratio = \"1:65536\"",
    );
    Case::scene(&text).fails_with(&[CAMERA_LINE, "too large"]);
}

#[test]
fn image_too_large_by_pixel_count() {
    let text = edit("width = 8", "width = 65536");
    Case::scene(&text).fails_with(&[CAMERA_LINE, "65536x65536", "too large"]);
}

#[test]
fn image_too_large_by_width_flag() {
    Case::new(&["bad.toml", "--width", "65536", "-o", "out.png"])
        .file("bad.toml", BASE)
        .fails_with(&[CAMERA_LINE, "too large"]);
}

#[test]
fn image_too_large_builtin_scene() {
    Case::new(&["spheres", "--width", "65536", "--spp", "1", "-o", "out.png"]).fails_with(&[
        "spheres",
        "65536x36864",
        "too large",
    ]);
}

// ---------------------------------------------------------------------------------------
// Meshes.

#[test]
fn missing_obj_file() {
    Case::scene(&mesh_object()).fails_with(&[EXTRA_OBJECT_LINE, "object 3 (mesh)", "mesh.obj"]);
}

#[test]
fn obj_face_index_out_of_range() {
    let obj = "v 0 0 -2\nv 1 0 -2\nv 0 1 -2\n# a comment\nf 1 2 9\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj:5:", "index"]);
}

#[test]
fn obj_face_index_zero() {
    let obj = "v 0 0 -2\nv 1 0 -2\nv 0 1 -2\nf 0 1 2\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj:4:"]);
}

#[test]
fn obj_vertex_with_two_coordinates() {
    let obj = "v 0 0 -2\nv 1 0\nv 0 1 -2\nf 1 2 3\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj:2:"]);
}

#[test]
fn obj_nan_vertex() {
    let obj = "# header\nv 0 0 -2\nv 1 nan 0\nv 0 1 -2\nf 1 2 3\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj:3:", "finite"]);
}

#[test]
fn obj_inf_vertex() {
    let obj = "v 0 0 -2\nv 1 inf 0\nv 0 1 -2\nf 1 2 3\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj:2:", "finite"]);
}

#[test]
fn obj_without_faces() {
    let obj = "v 0 0 -2\nv 1 0 -2\nv 0 1 -2\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj", "triangles"]);
}

#[test]
fn obj_with_only_degenerate_faces() {
    let obj = "v 0 0 -2\nv 1 1 -2\nv 2 2 -2\nf 1 2 3\n";
    Case::scene(&mesh_object())
        .file("mesh.obj", obj)
        .fails_with(&["mesh.obj", "1 degenerate"]);
}

#[test]
fn obj_empty_file() {
    Case::scene(&mesh_object())
        .file("mesh.obj", "")
        .fails_with(&["mesh.obj", "triangles"]);
}

// ---------------------------------------------------------------------------------------
// Flags (clap).

#[test]
fn flag_spp_zero() {
    Case::new(&["spheres", "--width", "8", "--spp", "0", "-o", "out.png"]).fails_in_clap("--spp");
}

#[test]
fn flag_width_zero() {
    Case::new(&["spheres", "--width", "0", "--spp", "1", "-o", "out.png"]).fails_in_clap("--width");
}

#[test]
fn flag_width_too_large() {
    Case::new(&["spheres", "--width", "65537", "--spp", "1", "-o", "out.png"])
        .fails_in_clap("--width");
}

#[test]
fn flag_max_depth_zero() {
    Case::spheres(&["--max-depth", "0"]).fails_in_clap("--max-depth");
}

#[test]
fn flag_packet_width_3() {
    Case::spheres(&["--packet-width", "3"]).fails_in_clap("--packet-width");
}

#[test]
fn flag_accel_foo() {
    Case::spheres(&["--accel", "foo"]).fails_in_clap("--accel");
}

#[test]
fn flag_threads_zero() {
    Case::spheres(&["--threads", "0"]).fails_in_clap("--threads");
}

#[test]
fn flag_seed_not_a_number() {
    Case::spheres(&["--seed", "x"]).fails_in_clap("--seed");
}

#[test]
fn flag_unknown() {
    Case::spheres(&["--bogus"]).fails_in_clap("--bogus");
}

#[test]
fn flag_missing_scene() {
    Case::new(&["-o", "out.png"]).fails_in_clap("<SCENE>");
}

// ---------------------------------------------------------------------------------------
// Output and report paths.

#[test]
fn output_unsupported_extension() {
    Case::new(&["spheres", "--width", "8", "--spp", "1", "-o", "out.jpg"])
        .fails_with(&["out.jpg", ".png or .ppm"]);
}

#[test]
fn output_without_extension() {
    Case::new(&["spheres", "--width", "8", "--spp", "1", "-o", "out"])
        .fails_with(&["out", ".png or .ppm"]);
}

#[test]
fn output_in_nonexistent_absolute_directory() {
    assert!(!Path::new("/nonexistent-dir").exists());
    Case::new(&[
        "spheres",
        "--width",
        "8",
        "--spp",
        "1",
        "-o",
        "/nonexistent-dir/x.png",
    ])
    .fails_with(&["/nonexistent-dir/x.png", "does not exist"]);
}

#[test]
fn output_in_nonexistent_relative_directory() {
    Case::new(&[
        "spheres",
        "--width",
        "8",
        "--spp",
        "1",
        "-o",
        "no-such-dir/x.png",
    ])
    .fails_with(&["no-such-dir/x.png", "does not exist"]);
}

#[test]
fn output_is_a_directory() {
    Case::new(&["spheres", "--width", "8", "--spp", "1", "-o", "out.png"])
        .dir("out.png")
        .fails_with(&["out.png", "directory"]);
}

#[test]
fn report_in_nonexistent_directory_fails_before_rendering() {
    // The image is written before the report: no out.png proves the check came first.
    Case::new(&[
        "bad.toml",
        "--report",
        "no-such-dir/report.json",
        "-o",
        "out.png",
    ])
    .file("bad.toml", BASE)
    .fails_with(&["no-such-dir/report.json", "does not exist"]);
}

#[test]
fn report_is_a_directory() {
    Case::new(&["bad.toml", "--report", "report.json", "-o", "out.png"])
        .file("bad.toml", BASE)
        .dir("report.json")
        .fails_with(&["report.json", "directory"]);
}

#[test]
fn report_naming_the_scene_file_is_refused() {
    Case::new(&["bad.toml", "--report", "bad.toml", "-o", "out.png"])
        .file("bad.toml", BASE)
        .fails_with(&["bad.toml", "--report names the scene file bad.toml"]);
}

#[test]
fn report_naming_the_image_is_refused() {
    Case::new(&["bad.toml", "--report", "./out.png", "-o", "out.png"])
        .file("bad.toml", BASE)
        .fails_with(&["./out.png", "the report would overwrite the image out.png"]);
}

#[test]
fn image_and_report_cannot_both_go_to_standard_output() {
    Case::new(&["spheres", "--width", "8", "-o", "-", "--report", "-"])
        .fails_with(&["-o - and --report - would both write to standard output"]);
}

#[test]
fn format_must_agree_with_the_output_file() {
    Case::spheres(&["--format", "exr"]).fails_with(&["--format", "out.png", "extension"]);
    Case::new(&[
        "spheres", "--region", "0/2", "-o", "p.part", "--format", "png",
    ])
    .fails_with(&["--format", "part file"]);
    Case::spheres(&["--format", "tiff"]).fails_in_clap("--format");
}

/// A path through a regular file is refused naming that file, not as a missing
/// directory.
#[test]
fn output_under_a_regular_file_names_it() {
    Case::spheres(&[])
        .args(&["--report", "afile/r.json"])
        .file("afile", "x")
        .fails_with(&["afile/r.json", "afile is not a directory"]);
    Case::new(&["spheres", "--width", "8", "-o", "afile/sub/o.png"])
        .file("afile", "x")
        .fails_with(&["afile/sub/o.png", "afile is not a directory"]);
}

/// No output replaces a file the run reads: the scene file (whatever its name), a part
/// file's `-o` included, and a mesh or its material library.
#[test]
fn outputs_naming_an_input_are_refused() {
    Case::new(&["scene.png", "-o", "scene.png"])
        .file("scene.png", BASE)
        .fails_with(&["scene.png", "-o names the scene file scene.png"]);
    Case::new(&["scene.part", "--region", "0/2", "-o", "./scene.part"])
        .file("scene.part", BASE)
        .fails_with(&["-o names the scene file scene.part"]);
    let mesh = with_object("type = \"mesh\"\npath = \"tri.png\"\nmaterial = \"red\"\n");
    Case::new(&["bad.toml", "-o", "tri.png"])
        .file("bad.toml", &mesh)
        .file("tri.png", GOOD_OBJ)
        .fails_with(&["-o names the mesh tri.png"]);
    let obj = format!("mtllib tri.mtl other.mtl\n{GOOD_OBJ}");
    Case::new(&["bad.toml", "-o", "out.png", "--report", "other.mtl"])
        .file("bad.toml", mesh_object())
        .file("mesh.obj", &obj)
        .file("other.mtl", "newmtl x\n")
        .fails_with(&["--report names the material library other.mtl"]);
}

/// The same file under another name: a hard link to the scene file as `-o`, a symbolic
/// link to it as `--report`, a hard link to a part as merge's `-o`. Each is refused and
/// every file keeps its bytes.
#[cfg(unix)]
#[test]
fn outputs_naming_an_input_by_a_link_are_refused() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    std::fs::write(d.join("scene.toml"), BASE).unwrap();
    std::fs::hard_link(d.join("scene.toml"), d.join("out.png")).unwrap();
    std::os::unix::fs::symlink("scene.toml", d.join("link.json")).unwrap();
    let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let before = snapshot(d);
    let run = run_in(d, &args(&["scene.toml", "-o", "out.png"]));
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("-o names the scene file scene.toml"),
        "{}",
        run.stderr
    );
    let run = run_in(
        d,
        &args(&["scene.toml", "-o", "x.png", "--report", "link.json"]),
    );
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("--report names the scene file"),
        "{}",
        run.stderr
    );
    assert!(snapshot(d) == before);

    for i in 0..2 {
        let region = format!("{i}/2");
        let part = format!("p{i}.part");
        let run = run_in(
            d,
            &args(&["spheres", "--width", "8", "--region", &region, "-o", &part]),
        );
        assert_eq!(run.code, Some(0), "{}", run.stderr);
    }
    std::fs::hard_link(d.join("p1.part"), d.join("frame.exr")).unwrap();
    let before = snapshot(d);
    let run = run_in(
        d,
        &args(&["merge", "p0.part", "p1.part", "-o", "frame.exr"]),
    );
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("-o names the part file p1.part"),
        "{}",
        run.stderr
    );
    assert!(snapshot(d) == before);
}

#[test]
fn a_reference_that_is_not_an_image_is_a_read_error() {
    Case::new(&[
        "sweep",
        "spheres",
        "--width",
        "8",
        "--reference",
        "ref.exr",
        "--out",
        "sweep",
    ])
    .file("ref.exr", "not an image")
    .file("ref.json", "{}")
    .dir("sweep")
    .fails_with(&["cannot read ref.exr", "OpenExr"]);
}

#[test]
fn failed_run_leaves_existing_output_unchanged() {
    let dir = TempDir::new().unwrap();
    let existing = dir.path().join("existing.png");
    std::fs::write(&existing, SENTINEL).unwrap();
    std::fs::write(
        dir.path().join("bad.toml"),
        edit("radius = 0.5", "radius = -1"),
    )
    .unwrap();
    let args: Vec<String> = ["bad.toml", "-o", "existing.png"]
        .map(String::from)
        .to_vec();
    let run = run_in(dir.path(), &args);
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert_eq!(std::fs::read(&existing).unwrap(), SENTINEL);
    let names: Vec<_> = snapshot(dir.path()).into_keys().collect();
    assert_eq!(
        names,
        [PathBuf::from("bad.toml"), PathBuf::from("existing.png")]
    );
}

// ---------------------------------------------------------------------------------------
// Good runs.

/// The files in a directory after a good run: no `.raytracer-*.tmp` left behind.
fn file_names(dir: &Path) -> Vec<String> {
    snapshot(dir)
        .into_keys()
        .map(|p| p.to_string_lossy().into_owned())
        .collect()
}

#[test]
fn list_prints_every_builtin_scene_with_its_description() {
    let (_dir, run) = Case::new(&["--list"]).run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let scenes_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names = Vec::new();
    for entry in std::fs::read_dir(&scenes_dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            names.push(path);
        }
    }
    assert!(names.len() >= 7, "scenes/ has {} scene files", names.len());
    let lines: Vec<&str> = run.stdout.lines().collect();
    assert_eq!(
        lines.len(),
        names.len(),
        "one line per scene:\n{}",
        run.stdout
    );
    for path in names {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&path).unwrap();
        let value: toml::Table = toml::from_str(&text).unwrap();
        let description = value["description"].as_str().unwrap();
        assert!(!description.is_empty(), "{name} has no description");
        let line = lines
            .iter()
            .find(|l| l.split_whitespace().next() == Some(name.as_str()))
            .unwrap_or_else(|| panic!("--list lacks {name}:\n{}", run.stdout));
        assert!(
            line.contains(description),
            "{name}: '{line}' lacks '{description}'"
        );
    }
    for name in ["bunny", "cornell", "spheres"] {
        assert!(run.stdout.contains(name));
    }
}

#[test]
fn tiny_png_render() {
    let (dir, run) = Case::spheres(&[]).run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(!run.stderr.contains("panicked"), "{}", run.stderr);
    let bytes = std::fs::read(dir.path().join("out.png")).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    let image = image::load_from_memory(&bytes).unwrap();
    // spheres is 16:9: 8 wide is 4 high.
    assert_eq!((image.width(), image.height()), (8, 4));
    assert_eq!(file_names(dir.path()), ["out.png"]);
}

#[test]
fn tiny_ppm_render() {
    let (dir, run) = Case::new(&["spheres", "--width", "8", "--spp", "1", "-o", "out.ppm"]).run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let bytes = std::fs::read(dir.path().join("out.ppm")).unwrap();
    assert!(
        bytes.starts_with(b"P6\n8 "),
        "bad PPM header: {:?}",
        &bytes[..bytes.len().min(16)]
    );
    // "P6\n<w> <h>\n255\n", then the pixels.
    let header_end = bytes
        .iter()
        .enumerate()
        .filter(|(_, &b)| b == b'\n')
        .nth(2)
        .map(|(i, _)| i + 1)
        .expect("three header lines");
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
    let fields: Vec<&str> = header.split_whitespace().collect();
    assert_eq!(fields[0], "P6");
    assert_eq!(fields[3], "255");
    let (w, h): (usize, usize) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    assert_eq!((w, h), (8, 4));
    assert_eq!(bytes.len() - header_end, 3 * w * h);
    assert_eq!(file_names(dir.path()), ["out.ppm"]);
}

/// `-o -` writes to standard output the bytes `-o FILE` writes, in `--format` (PPM by
/// default), and no file; the summary stays on stderr and names standard output.
#[test]
fn image_to_standard_output_is_the_file_bytes() {
    for (format, file) in [
        (None, "out.ppm"),
        (Some("png"), "out.png"),
        (Some("exr"), "out.exr"),
    ] {
        let base = ["spheres", "--width", "8", "--spp", "1"];
        let (dir, to_file) = Case::new(&base).args(&["-o", file]).run();
        assert_eq!(to_file.code, Some(0), "{}", to_file.stderr);
        let expected = std::fs::read(dir.path().join(file)).unwrap();
        let mut case = Case::new(&base).args(&["-o", "-"]);
        if let Some(format) = format {
            case = case.args(&["--format", format]);
        }
        let (dir, run) = case.run();
        assert_eq!(run.code, Some(0), "{}", run.stderr);
        assert!(
            run.stdout_bytes == expected,
            "{file}: standard output differs ({} bytes, the file {})",
            run.stdout_bytes.len(),
            expected.len()
        );
        assert!(run.stderr.contains("-> standard output"), "{}", run.stderr);
        assert_eq!(file_names(dir.path()), Vec::<String>::new());
    }
}

/// `--report -` prints the report on standard output and makes no file named `-`.
#[test]
fn report_to_standard_output_leaves_no_file() {
    let (dir, run) = Case::spheres(&["--report", "-"]).run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let report: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert_eq!(report["width"], 8);
    assert_eq!(file_names(dir.path()), ["out.png"]);
}

/// `merge -o -` writes the merged frame to standard output, as `-o FILE` writes it.
#[test]
fn merged_frame_to_standard_output() {
    let dir = TempDir::new().unwrap();
    for i in 0..2 {
        let args: Vec<String> = ["spheres", "--width", "8", "--spp", "1", "--region"]
            .iter()
            .map(|a| a.to_string())
            .chain([format!("{i}/2"), "-o".into(), format!("p{i}.part")])
            .collect();
        let run = run_in(dir.path(), &args);
        assert_eq!(run.code, Some(0), "{}", run.stderr);
    }
    let merge = |out: &[&str]| {
        let args: Vec<String> = ["merge", "p0.part", "p1.part"]
            .iter()
            .chain(out)
            .map(|a| a.to_string())
            .collect();
        run_in(dir.path(), &args)
    };
    let run = merge(&["-o", "frame.exr"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let run = merge(&["-o", "-", "--format", "exr"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(run.stdout_bytes == std::fs::read(dir.path().join("frame.exr")).unwrap());
    assert_eq!(file_names(dir.path()), ["frame.exr", "p0.part", "p1.part"]);
}

#[test]
fn successful_render_replaces_an_existing_output() {
    let case = Case::spheres(&[]).file("out.png", SENTINEL);
    let (dir, run) = case.run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let bytes = std::fs::read(dir.path().join("out.png")).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"));
    assert_eq!(file_names(dir.path()), ["out.png"]);
}

#[test]
fn report_json_has_sizes_timings_and_ray_counts() {
    let case = Case::spheres(&["--report", "report.json", "--threads", "2"]);
    let (dir, run) = case.run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert_eq!(file_names(dir.path()), ["out.png", "report.json"]);
    let text = std::fs::read_to_string(dir.path().join("report.json")).unwrap();
    let r: serde_json::Value = serde_json::from_str(&text).unwrap();
    let uint = |v: &serde_json::Value| {
        v.as_u64()
            .unwrap_or_else(|| panic!("not an integer: {v} in {text}"))
    };
    assert_eq!(r["scene"], "spheres");
    let (w, h, spp) = (uint(&r["width"]), uint(&r["height"]), uint(&r["spp"]));
    assert_eq!((w, h, spp), (8, 4, 1));
    // The default: the widest packets the binary was compiled for.
    assert_eq!(
        uint(&r["packet_width"]),
        raytracer::PacketWidth::default().rays() as u64
    );
    assert_eq!(r["isa"], raytracer::lanes::ISA);
    assert_eq!(uint(&r["threads"]), 2);
    assert!(r["accel"].is_string(), "accel: {}", r["accel"]);
    for key in ["load", "build", "render", "write", "total"] {
        let s = r["seconds"][key]
            .as_f64()
            .unwrap_or_else(|| panic!("seconds.{key} in {text}"));
        assert!(s.is_finite() && s >= 0.0, "seconds.{key} = {s}");
    }
    let rays = &r["rays"];
    let (camera, shadow, secondary, total) = (
        uint(&rays["camera"]),
        uint(&rays["shadow"]),
        uint(&rays["secondary"]),
        uint(&rays["total"]),
    );
    assert_eq!(total, camera + shadow + secondary);
    assert_eq!(camera, w * h * spp);
    assert_eq!(uint(&r["non_finite_pixels"]), 0);
}

/// `--stats` prints the film's count of NaN or infinite pixels (0 for a built-in scene),
/// and `--report` carries it as `non_finite_pixels`. Checked it can fail: with
/// `render_tile` dividing every pixel by 0, the line reads "non-finite pixels: 32" and the
/// test fails.
#[test]
fn stats_and_report_count_non_finite_pixels() {
    let case = Case::spheres(&["--stats", "--report", "report.json"]);
    let (dir, run) = case.run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let line = run
        .stderr
        .lines()
        .find(|l| l.starts_with("stats: non-finite pixels:"))
        .unwrap_or_else(|| panic!("no non-finite line in: {}", run.stderr));
    assert_eq!(line, "stats: non-finite pixels: 0");
    let text = std::fs::read_to_string(dir.path().join("report.json")).unwrap();
    let r: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(r["non_finite_pixels"].as_u64(), Some(0), "{text}");
}

/// `--stats`' packet line names the instruction set the lanes were compiled for
/// (`lanes::ISA`), at every packet width. Checked it can fail: with the line's old
/// "(AVX2 on)" on the AVX-512 build, the test fails.
#[test]
fn stats_name_the_instruction_set_compiled_in() {
    for width in ["4", "8", "16"] {
        let case = Case::spheres(&["--stats", "--packet-width", width]);
        let (_dir, run) = case.run();
        assert_eq!(run.code, Some(0), "{}", run.stderr);
        let line = run
            .stderr
            .lines()
            .find(|l| l.contains("-wide packets"))
            .unwrap_or_else(|| panic!("no packet line in: {}", run.stderr));
        let want = format!(
            "stats: {width}-wide packets ({} build): ",
            raytracer::lanes::ISA
        );
        assert!(line.starts_with(&want), "{line}");
    }
}

#[cfg(unix)]
#[test]
fn output_files_get_ordinary_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("perm.png");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_raytracer"))
        .args(["spheres", "--width", "8", "--spp", "1", "-q", "-o"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(
        std::fs::metadata(&out).unwrap().permissions().mode() & 0o777,
        0o644
    );
    // Replacing a file keeps its permissions.
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o640)).unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_raytracer"))
        .args(["spheres", "--width", "8", "--spp", "1", "-q", "-o"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(
        std::fs::metadata(&out).unwrap().permissions().mode() & 0o777,
        0o640
    );
}

#[test]
fn tiny_exr_render_is_the_linear_film() {
    // The EXR holds what the renderer computed, bit for bit: compare with the same render
    // through the library.
    let (dir, run) = Case::new(&[
        "spheres",
        "--width",
        "8",
        "--spp",
        "2",
        "--sampler",
        "sobol",
        "-o",
        "out.exr",
    ])
    .run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert_eq!(file_names(dir.path()), ["out.exr"]);
    let film = raytracer::output::read_exr(&dir.path().join("out.exr")).unwrap();
    let o = raytracer::scene::Overrides {
        width: Some(8),
        spp: Some(2),
        max_depth: None,
    };
    let mut scene = raytracer::scene::Scene::load("spheres", o).unwrap();
    let accel = raytracer::accel::Accel::build(&mut scene, raytracer::accel::AccelKind::Bvh);
    let settings = raytracer::render::RenderSettings {
        sampler: raytracer::sampling::SamplerKind::Sobol,
        ..raytracer::render::RenderSettings::new(0)
    };
    let expected = raytracer::render::render(&scene, &accel, &settings, &|| {})
        .unwrap()
        .film;
    let bits = |f: &raytracer::render::Film| -> Vec<u32> {
        f.pixels
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!((film.width, film.height), (8, 4));
    assert_eq!(bits(&film), bits(&expected));
}

#[test]
fn bad_sampler_is_a_clap_error() {
    Case::spheres(&["--sampler", "halton"]).fails_in_clap("--sampler");
}

#[test]
fn tiny_sweep_writes_csv_chart_and_summary() {
    let (dir, run) = Case::new(&[
        "sweep",
        "spheres",
        "--width",
        "8",
        "--spp-max",
        "4",
        "--runs",
        "1",
        "--reference-spp",
        "8",
        "--reference",
        "ref.exr",
        "--out",
        "sweep",
        "--packet-widths",
        "1",
    ])
    .run();
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let names = file_names(dir.path());
    for f in [
        "ref.exr",
        "ref.json",
        "sweep",
        "sweep/spheres.csv",
        "sweep/spheres.svg",
        "sweep/spheres.txt",
    ] {
        assert!(names.iter().any(|n| n == f), "{f} missing from {names:?}");
    }
    let csv = std::fs::read_to_string(dir.path().join("sweep/spheres.csv")).unwrap();
    // A comment, the header, then 3 samplers × spp 1, 2, 4.
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 2 + 9, "{csv}");
    assert!(lines[1].starts_with("sampler,packet_width,spp,seconds_median"));
    assert!(lines[2].starts_with("independent,1,1,"), "{}", lines[2]);
    let svg = std::fs::read_to_string(dir.path().join("sweep/spheres.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("sobol") && svg.contains("stratified"));
}

#[test]
fn reference_must_be_exr() {
    Case::new(&["reference", "spheres", "--width", "8", "-o", "out.png"])
        .fails_with(&["out.png", ".exr"]);
}
