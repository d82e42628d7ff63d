//! The README's gallery is what the program renders: every built-in scene has an image in
//! `docs/gallery/`, shown by the README, and each image is rendered again here by the
//! real binary at the gallery's settings (`raytracer NAME --width 240 --spp 32`, the
//! default sampler and packet width) and compared pixel for pixel, bit for bit, with the
//! committed PNG. The decoded 8-bit pixels are compared, not the files' bytes, which an
//! update of the PNG encoder may change.
//!
//! Renders are the same bits for any thread count and packet width, so the images hold
//! on any machine. A change that moves pixels makes this test fail; render the gallery
//! again (from the repository's root) and say in the commit why the pixels moved:
//!
//! ```sh
//! cargo build --release
//! for s in $(target/release/raytracer --list | cut -d' ' -f1); do
//!     target/release/raytracer "$s" --width 240 --spp 32 -q -o "docs/gallery/$s.png"
//! done
//! ```

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");
/// The gallery's settings.
const WIDTH: &str = "240";
const SPP: &str = "32";
/// A gallery image stays small in the repository.
const MAX_BYTES: u64 = 64 * 1024;
/// The scenes with a test of their own below: every built-in scene.
const SCENES: [&str; 9] = [
    "bunny",
    "bunny-closeup",
    "cornell",
    "cornell-area-light",
    "cornell-point-light",
    "mixed",
    "quads",
    "spheres",
    "spheres-defocus",
];

fn gallery() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/gallery")
}

/// The built-in scenes, as `--list` names them.
fn builtin_names() -> Vec<String> {
    let out = Command::new(BIN)
        .arg("--list")
        .output()
        .expect("run --list");
    assert!(out.status.success());
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(String::from))
        .collect()
}

#[test]
fn every_builtin_scene_is_in_the_gallery_and_the_readme() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let mut names = builtin_names();
    names.sort();
    assert_eq!(
        names, SCENES,
        "a built-in scene without its gallery test below"
    );
    for name in &names {
        let file = gallery().join(format!("{name}.png"));
        let len = std::fs::metadata(&file).map_or(0, |m| m.len());
        assert!(len > 0, "{} is missing", file.display());
        assert!(len <= MAX_BYTES, "{}: {len} bytes", file.display());
        let link = format!("(docs/gallery/{name}.png)");
        assert!(readme.contains(&link), "the README does not show {link}");
    }
    // No image of a scene that no longer exists.
    for entry in std::fs::read_dir(gallery()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "png") {
            let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
            assert!(
                names.contains(&stem),
                "{} is no built-in scene",
                path.display()
            );
        }
    }
}

/// Render `name` at the gallery's settings and compare with its committed image.
fn renders_as_committed(name: &str) {
    let committed = image::open(gallery().join(format!("{name}.png")))
        .unwrap_or_else(|e| panic!("docs/gallery/{name}.png: {e}"))
        .to_rgb8();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join(format!("{name}.png"));
    let run = Command::new(BIN)
        .args([name, "--width", WIDTH, "--spp", SPP, "-q", "-o"])
        .arg(&out)
        .output()
        .expect("run the binary");
    assert!(
        run.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let rendered = image::open(&out).unwrap().to_rgb8();
    assert_eq!(
        rendered.dimensions(),
        committed.dimensions(),
        "{name}: size"
    );
    let (mut differ, mut worst) = (0usize, 0u8);
    for (a, b) in rendered.as_raw().iter().zip(committed.as_raw()) {
        if a != b {
            differ += 1;
            worst = worst.max(a.abs_diff(*b));
        }
    }
    assert!(
        differ == 0,
        "{name}: {differ} channels differ from docs/gallery/{name}.png (by up to {worst}); \
         if the change is meant, render the gallery again (see tests/gallery.rs)"
    );
}

#[test]
fn bunny() {
    renders_as_committed("bunny");
}

#[test]
fn bunny_closeup() {
    renders_as_committed("bunny-closeup");
}

#[test]
fn cornell() {
    renders_as_committed("cornell");
}

#[test]
fn cornell_area_light() {
    renders_as_committed("cornell-area-light");
}

#[test]
fn cornell_point_light() {
    renders_as_committed("cornell-point-light");
}

#[test]
fn mixed() {
    renders_as_committed("mixed");
}

#[test]
fn quads() {
    renders_as_committed("quads");
}

#[test]
fn spheres() {
    renders_as_committed("spheres");
}

#[test]
fn spheres_defocus() {
    renders_as_committed("spheres-defocus");
}
