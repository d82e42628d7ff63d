//! Farming a frame: region renders (`--region`, `--crop`, `Renderer::render_part`), part
//! files and `merge`.
//!
//! The merged frame must be the bits of a one-process render for any split, sampler and
//! packet width; a region's pixels the bits of the same pixels of the frame; a part file
//! the same bytes whatever the settings that never change a pixel (packet width, threads,
//! accelerator, specialisation); and every bad part input must end with exit code 2, one
//! line naming the part file, and no file written or changed.

mod support;

use proptest::prelude::*;
use raytracer::accel::{Accel, AccelKind};
use raytracer::farm::part;
use raytracer::render::{render, render_region};
use raytracer::{
    merge_parts, PacketWidth, Rect, Region, RenderSettings, Renderer, SamplerKind, SceneFile,
    SceneOptions,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use support::{bits, builtin};
use tempfile::TempDir;

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");

/// The scene the command-line tests render: `bunny` (a mesh, three spheres, an area
/// light), 100x56 pixels (7x4 tiles, the last column and row partial), 2 spp.
const SCENE: [&str; 5] = ["bunny", "--width", "100", "--spp", "2"];

struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

fn run_in(dir: &Path, args: &[&str]) -> Run {
    let out = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("run the raytracer binary");
    Run {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Run and require success.
fn ok(dir: &Path, args: &[&str]) {
    let run = run_in(dir, args);
    assert_eq!(run.code, Some(0), "raytracer {args:?}: {}", run.stderr);
}

/// Render `SCENE` with `extra` arguments.
fn render_scene(dir: &Path, extra: &[&str]) {
    let mut args = SCENE.to_vec();
    args.extend_from_slice(extra);
    args.push("-q");
    ok(dir, &args);
}

fn read(path: impl AsRef<Path>) -> Vec<u8> {
    std::fs::read(path.as_ref()).unwrap_or_else(|e| panic!("read {}: {e}", path.as_ref().display()))
}

// ---------------------------------------------------------------------------------------
// The merged frame is the one-process frame.

/// 8-wide packets with the default sampler (Sobol), and the scalar tracer with the
/// original program's sampling.
const CONFIGS: [&[&str]; 2] = [
    &["--packet-width", "8"],
    &["--packet-width", "1", "--sampler", "independent"],
];

#[test]
fn merge_is_the_one_process_render_for_every_split_and_width() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    for (c, config) in CONFIGS.iter().enumerate() {
        let mut full = config.to_vec();
        full.extend(["-o", "full.exr"]);
        render_scene(d, &full);
        let full = read(d.join("full.exr"));
        for n in [1u32, 2, 3, 4, 7, 16] {
            let mut args = vec!["merge".to_string()];
            for i in 0..n {
                let name = format!("p{i}of{n}-c{c}.part");
                let region = format!("{i}/{n}");
                let mut part = config.to_vec();
                part.extend(["--region", &region, "-o", &name]);
                render_scene(d, &part);
                args.push(name);
            }
            let out = format!("merged-{n}-c{c}.exr");
            args.extend(["-o".into(), out.clone(), "-q".into()]);
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            ok(d, &args);
            assert!(
                read(d.join(&out)) == full,
                "{n} parts with {config:?}: the merged EXR differs from the one-process EXR"
            );
        }
    }
}

#[test]
fn parts_of_different_widths_crops_and_png_merge() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    render_scene(d, &["-o", "full.exr"]);
    render_scene(d, &["-o", "full.png"]);
    // Packet widths 1, 4, 8, 16, threads 1 and 2, both accelerators, specialisation on
    // and off, in one frame.
    let settings: [&[&str]; 5] = [
        &["--packet-width", "1", "--threads", "1", "--accel", "linear"],
        &["--packet-width", "4", "--threads", "2", "--no-specialize"],
        &["--packet-width", "8", "--threads", "1"],
        &["--packet-width", "8", "--threads", "2", "--accel", "linear"],
        &["--packet-width", "16", "--threads", "2"],
    ];
    for (i, setting) in settings.iter().enumerate() {
        let region = format!("{i}/5");
        let name = format!("p{i}.part");
        let mut args = setting.to_vec();
        args.extend(["--region", &region, "-o", &name]);
        render_scene(d, &args);
    }
    ok(
        d,
        &[
            "merge", "p0.part", "p1.part", "p2.part", "p3.part", "p4.part", "-o", "m.exr", "-q",
        ],
    );
    assert!(read(d.join("m.exr")) == read(d.join("full.exr")));
    ok(
        d,
        &[
            "merge", "p3.part", "p1.part", "p4.part", "p0.part", "p2.part", "-o", "m.png", "-q",
        ],
    );
    assert!(read(d.join("m.png")) == read(d.join("full.png")));

    // Two crops at odd offsets and a whole-frame part file.
    render_scene(
        d,
        &[
            "--packet-width",
            "8",
            "--crop",
            "0,0,100,27",
            "-o",
            "top.part",
        ],
    );
    render_scene(
        d,
        &[
            "--packet-width",
            "4",
            "--crop",
            "0,27,37,56",
            "-o",
            "left.part",
        ],
    );
    render_scene(d, &["--crop", "37,27,100,56", "-o", "right.part"]);
    ok(
        d,
        &[
            "merge",
            "left.part",
            "top.part",
            "right.part",
            "-o",
            "c.exr",
            "-q",
        ],
    );
    assert!(read(d.join("c.exr")) == read(d.join("full.exr")));
    render_scene(d, &["-o", "whole.part"]);
    ok(d, &["merge", "whole.part", "-o", "w.exr", "-q"]);
    assert!(read(d.join("w.exr")) == read(d.join("full.exr")));
}

#[test]
fn a_region_has_the_bits_of_the_same_pixels_of_the_frame() {
    // `mixed` has path-traced bounces, `spheres-defocus` a lens; 37 px wide so packets
    // straddle tile edges.
    for name in ["mixed", "cornell", "bunny-closeup", "spheres-defocus"] {
        let mut scene = builtin(name, 37, 2);
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let (w, h) = (scene.camera.width, scene.camera.height);
        for sampler in SamplerKind::ALL {
            let at = |packet_width| RenderSettings {
                packet_width,
                sampler,
                ..RenderSettings::new(3)
            };
            let frame = render(&scene, &accel, &at(PacketWidth::Scalar), &|| {})
                .unwrap()
                .film;
            let regions = [
                Region::Crop(Rect::new(1, 3, 36, h - 1)),
                Region::Crop(Rect::new(17, 0, 18, h)),
                Region::Part { index: 2, count: 3 },
                Region::Part { index: 0, count: 1 },
                Region::Frame,
            ];
            for region in regions {
                for (packet_width, threads) in [
                    (PacketWidth::Scalar, 1),
                    (PacketWidth::Four, 2),
                    (PacketWidth::Eight, 2),
                    (PacketWidth::Sixteen, 1),
                ] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let r = pool
                        .install(|| {
                            render_region(&scene, &accel, &at(packet_width), region, &|| {})
                        })
                        .unwrap();
                    assert_eq!(r.rects, region.rects(w, h).unwrap());
                    let mut expected = Vec::new();
                    for rect in &r.rects {
                        for y in rect.y0..rect.y1 {
                            for x in rect.x0..rect.x1 {
                                expected.push(frame.get(x, y).to_array().map(f32::to_bits));
                            }
                        }
                    }
                    let got: Vec<[u32; 3]> = r
                        .pixels
                        .iter()
                        .map(|p| p.to_array().map(f32::to_bits))
                        .collect();
                    assert!(
                        got == expected,
                        "{name} {region}, {sampler:?} at width {packet_width} on {threads} threads"
                    );
                }
            }
        }
    }
}

/// The public way: `Renderer::render_part`, `Part::write`, `merge_parts`, against
/// `Renderer::render`, at the defaults and the original program's sampling.
#[test]
fn parts_through_the_library_merge_to_the_frame() {
    let file = SceneFile::builtin("bunny").unwrap();
    let options = SceneOptions {
        width: Some(61),
        spp: Some(2),
        ..SceneOptions::default()
    };
    let renderer = Renderer::new(&file, &options).unwrap();
    let dir = TempDir::new().unwrap();
    for settings in [
        RenderSettings::default(),
        RenderSettings::original_sampling(5),
    ] {
        let frame = renderer.render(&settings).unwrap();
        let count = 5;
        let mut files = Vec::new();
        for index in (0..count).rev() {
            let region = Region::Part { index, count };
            let part = renderer.render_part(&settings, region).unwrap();
            assert_eq!(part.region(), region);
            let (w, h) = (renderer.width(), renderer.height());
            assert_eq!(part.rects(), region.rects(w, h).unwrap());
            assert_eq!(part.non_finite_count(), 0);
            let path = dir.path().join(format!("{index}.part"));
            part.write(&path).unwrap();
            files.push(path);
        }
        let merged = merge_parts(&files).unwrap();
        assert_eq!((merged.scene.as_str(), merged.spp), ("bunny", 2));
        assert_eq!(bits(&merged.film), bits(&frame), "{settings:?}");
        // A missing part is an error that names it (the files are in the order 4, 3, .. 0).
        let message = merge_parts(&files[1..]).unwrap_err().to_string();
        assert!(message.contains("missing region 4/5"), "{message}");
    }
}

#[test]
fn settings_that_never_change_a_pixel_give_the_same_part_file() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let settings: [&[&str]; 4] = [
        &["--packet-width", "1", "--threads", "1"],
        &["--packet-width", "4", "--threads", "2", "--accel", "linear"],
        &["--packet-width", "8", "--threads", "1", "--no-specialize"],
        &[],
    ];
    for (i, setting) in settings.iter().enumerate() {
        let mut args = setting.to_vec();
        let name = format!("s{i}.part");
        args.extend(["--region", "2/3", "-o", &name]);
        render_scene(d, &args);
    }
    let first = read(d.join("s0.part"));
    for i in 1..settings.len() {
        assert!(
            read(d.join(format!("s{i}.part"))) == first,
            "{:?} made another part file than {:?}",
            settings[i],
            settings[0]
        );
    }
}

#[test]
fn parts_share_the_work_fairly() {
    // Work per part measured as boxes visited plus primitives tested (it does not depend
    // on the machine), 16 parts, 800 px wide, 1 spp: the lattice gives the busiest part
    // 1.06x (bunny-closeup) and 1.02x (cornell) the mean; 16 bands of rows, 1.31x and
    // 1.36x.
    for name in ["bunny-closeup", "cornell"] {
        let mut scene = builtin(name, 800, 1);
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let settings = RenderSettings {
            packet_width: PacketWidth::Eight,
            ..RenderSettings::new(0)
        };
        let (w, h) = (scene.camera.width, scene.camera.height);
        let work = |region: Region| {
            let r = render_region(&scene, &accel, &settings, region, &|| {}).unwrap();
            r.counts.traversal.nodes + r.counts.traversal.prims
        };
        let busiest = |work: &[u64]| {
            let mean = work.iter().sum::<u64>() as f64 / work.len() as f64;
            *work.iter().max().unwrap() as f64 / mean
        };
        let count = 16;
        let parts: Vec<u64> = (0..count)
            .map(|index| work(Region::Part { index, count }))
            .collect();
        let bands: Vec<u64> = (0..count)
            .map(|i| {
                work(Region::Crop(Rect::new(
                    0,
                    h * i / count,
                    w,
                    h * (i + 1) / count,
                )))
            })
            .collect();
        assert!(busiest(&parts) <= 1.1, "{name}: parts {parts:?}");
        assert!(
            busiest(&bands) >= 1.2,
            "{name}: the measure sees rows' imbalance: {bands:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Bad part input: exit 2, one line naming the file, nothing written or changed.

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            files.insert(path.clone(), read(&path));
        }
    }
    files
}

/// Good parts of `SCENE`: `p0.part` .. `p3.part` (4 parts), made once a test.
fn good_parts(d: &Path) {
    for i in 0..4 {
        let region = format!("{i}/4");
        render_scene(d, &["--region", &region, "-o", &format!("p{i}.part")]);
    }
}

/// `merge ARGS -o out.exr` fails with exit 2, one line that holds every `expected`
/// text, and leaves every file as it was: with no output, and with an existing one.
fn merge_fails(d: &Path, parts: &[&str], expected: &[&str]) {
    for existing in [false, true] {
        let out = d.join("out.exr");
        if existing {
            std::fs::write(&out, b"existing output").unwrap();
        } else if out.exists() {
            std::fs::remove_file(&out).unwrap();
        }
        let before = snapshot(d);
        let mut args = vec!["merge"];
        args.extend_from_slice(parts);
        args.extend(["-o", "out.exr"]);
        let run = run_in(d, &args);
        let context = format!("raytracer {args:?}: exit {:?}\n{}", run.code, run.stderr);
        assert_eq!(run.code, Some(2), "{context}");
        assert!(run.stdout.is_empty(), "{context}");
        let message = run.stderr.trim_end();
        assert!(message.starts_with("error: "), "{context}");
        assert!(!message.contains('\n'), "not one line: {context}");
        for e in expected {
            assert!(message.contains(e), "message lacks '{e}': {context}");
        }
        assert!(snapshot(d) == before, "files changed: {context}");
    }
}

/// A copy of `p{i}.part` as `name`, changed by `f`.
fn edited(d: &Path, i: u32, name: &str, f: impl FnOnce(&mut Vec<u8>)) {
    let mut bytes = read(d.join(format!("p{i}.part")));
    f(&mut bytes);
    std::fs::write(d.join(name), bytes).unwrap();
}

/// The header line of a part's bytes, and its byte range.
fn header_of(bytes: &[u8]) -> (String, std::ops::Range<usize>) {
    let start = part::MAGIC.len();
    let end = start + bytes[start..].iter().position(|&b| b == b'\n').unwrap();
    (
        String::from_utf8(bytes[start..end].to_vec()).unwrap(),
        start..end,
    )
}

/// A copy of `p{i}.part` whose header has `from` replaced by `to` (once).
fn with_header(d: &Path, i: u32, name: &str, from: &str, to: &str) {
    edited(d, i, name, |bytes| {
        let (header, range) = header_of(bytes);
        assert_eq!(header.matches(from).count(), 1, "'{from}' in {header}");
        bytes.splice(range, header.replace(from, to).into_bytes());
    });
}

#[test]
fn good_parts_merge_control() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    ok(
        d,
        &[
            "merge", "p0.part", "p1.part", "p2.part", "p3.part", "-o", "out.exr",
        ],
    );
}

#[test]
fn missing_regions_are_named() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    merge_fails(
        d,
        &["p0.part", "p1.part", "p3.part"],
        &["missing region 2/4"],
    );
    merge_fails(d, &["p3.part", "p0.part"], &["missing regions 1/4, 2/4"]);
    // Crops: the missing pixels' count, first pixel and bounds.
    render_scene(d, &["--crop", "0,0,100,50", "-o", "top.part"]);
    merge_fails(d, &["top.part"], &["600 pixels", "(0, 50)", "0,50,100,56"]);
}

#[test]
fn overlaps_name_both_files() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    merge_fails(
        d,
        &["p0.part", "p1.part", "p1.part", "p2.part", "p3.part"],
        &["p1.part: region 1/4 overlaps p1.part", "given twice"],
    );
    render_scene(d, &["--crop", "20,20,40,40", "-o", "crop.part"]);
    merge_fails(
        d,
        &["p0.part", "p1.part", "p2.part", "p3.part", "crop.part"],
        &["crop.part: crop 20,20,40,40 overlaps p", "(20, 20)"],
    );
}

#[test]
fn parts_of_another_scene_setting_or_program_are_refused() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    // SCENE but for one setting.
    let others: [(&str, [&str; 4], &str); 5] = [
        (
            "seed.part",
            ["--seed", "1", "--spp", "2"],
            "rendered with seed 1, p0.part with seed 0",
        ),
        (
            "spp.part",
            ["--width", "100", "--spp", "3"],
            "rendered with spp 3, p0.part with spp 2",
        ),
        (
            "depth.part",
            ["--max-depth", "3", "--spp", "2"],
            "max depth 3",
        ),
        (
            "sampler.part",
            ["--sampler", "independent", "--spp", "2"],
            "rendered with sampler independent, p0.part with sampler sobol",
        ),
        (
            "size.part",
            ["--width", "101", "--spp", "2"],
            "image size 101x56",
        ),
    ];
    for (name, setting, expected) in others {
        let mut args = vec!["bunny", "--region", "1/4", "-o", name, "-q"];
        if !setting.contains(&"--width") {
            args.extend(["--width", "100"]);
        }
        args.extend_from_slice(&setting);
        ok(d, &args);
        merge_fails(
            d,
            &["p0.part", name, "p2.part", "p3.part"],
            &[name, expected],
        );
    }
    // Another scene at the same size and settings: the digest differs.
    ok(
        d,
        &[
            "bunny-closeup",
            "--width",
            "100",
            "--spp",
            "2",
            "--region",
            "1/4",
            "-o",
            "closeup.part",
            "-q",
        ],
    );
    merge_fails(
        d,
        &["p0.part", "closeup.part", "p2.part", "p3.part"],
        &["closeup.part: rendered from another scene than p0.part"],
    );
    // A scene file whose one material differs from the built-in scene's.
    let text = raytracer::scene::builtin::scene("bunny").unwrap();
    let edited_text = text.replacen("shininess = 500", "shininess = 7", 1);
    assert_ne!(edited_text, text);
    for sub in ["scenes", "assets"] {
        std::fs::create_dir(d.join(sub)).unwrap();
    }
    std::fs::write(d.join("scenes/bunny.toml"), edited_text).unwrap();
    let mesh = raytracer::scene::builtin::asset("../assets/bunny.obj").unwrap();
    std::fs::write(d.join("assets/bunny.obj"), mesh).unwrap();
    ok(
        d,
        &[
            "scenes/bunny.toml",
            "--width",
            "100",
            "--spp",
            "2",
            "--region",
            "1/4",
            "-o",
            "file.part",
            "-q",
        ],
    );
    merge_fails(
        d,
        &["p0.part", "file.part", "p2.part", "p3.part"],
        &["file.part: rendered from another scene"],
    );
    // Another program version.
    with_header(d, 1, "version.part", part::PROGRAM, "raytracer 0.0.1");
    merge_fails(
        d,
        &["p0.part", "version.part", "p2.part", "p3.part"],
        &["version.part: made by raytracer 0.0.1, p0.part by raytracer"],
    );
}

#[test]
fn malformed_parts_are_refused() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    let rest = ["p0.part", "p2.part", "p3.part"];
    let with = |name: &'static str| -> Vec<&'static str> {
        let mut v = vec![name];
        v.extend_from_slice(&rest);
        v
    };
    let good = read(d.join("p1.part"));
    let (header, range) = header_of(&good);
    let payload_start = range.end + 1;

    merge_fails(d, &with("absent.part"), &["cannot read absent.part"]);
    std::fs::create_dir(d.join("dir.part")).unwrap();
    merge_fails(d, &with("dir.part"), &["cannot read dir.part"]);
    std::fs::remove_dir(d.join("dir.part")).unwrap();
    edited(d, 1, "empty.part", Vec::clear);
    merge_fails(
        d,
        &with("empty.part"),
        &["empty.part: not a raytracer part file"],
    );
    render_scene(d, &["-o", "image.png"]);
    merge_fails(
        d,
        &with("image.png"),
        &["image.png: not a raytracer part file"],
    );
    edited(d, 1, "v2.part", |b| b[part::MAGIC.len() - 2] = b'2');
    merge_fails(d, &with("v2.part"), &["v2.part: part file format 2"]);
    edited(d, 1, "cut-header.part", |b| b.truncate(range.start + 40));
    merge_fails(d, &with("cut-header.part"), &["cut-header.part: truncated"]);
    edited(d, 1, "cut-pixels.part", |b| b.truncate(b.len() - 1));
    merge_fails(d, &with("cut-pixels.part"), &["cut-pixels.part: truncated"]);
    edited(d, 1, "no-pixels.part", |b| b.truncate(payload_start));
    merge_fails(
        d,
        &with("no-pixels.part"),
        &["no-pixels.part: truncated: 0 bytes"],
    );
    edited(d, 1, "long.part", |b| b.extend_from_slice(&[0; 12]));
    merge_fails(d, &with("long.part"), &["long.part: 12 bytes after its"]);
    edited(d, 1, "flip.part", |b| {
        let i = b.len() - 100;
        b[i] ^= 0x10;
    });
    merge_fails(d, &with("flip.part"), &["flip.part: corrupt"]);
    edited(d, 1, "json.part", |b| b[range.start + 1] = b'[');
    merge_fails(d, &with("json.part"), &["json.part: malformed header"]);
    // A field name with a newline and an escape sequence: quoted escaped, on one line
    // (found by the `part` fuzz target).
    with_header(d, 1, "quote.part", "\"scene\":", "\"sc\\ne\\u001b[31m\":");
    merge_fails(
        d,
        &with("quote.part"),
        &["quote.part: malformed header: unknown field `sc\\ne\\u{1b}[31m`"],
    );
    with_header(
        d,
        1,
        "unknown-key.part",
        "\"pixels\":",
        "\"colour\":1,\"pixels\":",
    );
    merge_fails(
        d,
        &with("unknown-key.part"),
        &["unknown-key.part: malformed header", "colour"],
    );
    let pixels = header.split("\"pixels\":").nth(1).unwrap();
    let pixels: u64 = pixels.split(',').next().unwrap().parse().unwrap();
    with_header(
        d,
        1,
        "count.part",
        &format!("\"pixels\":{pixels},"),
        &format!("\"pixels\":{},", pixels + 1),
    );
    merge_fails(
        d,
        &with("count.part"),
        &["count.part: header", "region 1/4"],
    );
    with_header(d, 1, "index.part", "\"index\":1", "\"index\":4");
    merge_fails(
        d,
        &with("index.part"),
        &["index.part: header", "part 4/4 does not exist"],
    );
    with_header(d, 1, "tile.part", "\"tile\":16", "\"tile\":32");
    merge_fails(
        d,
        &with("tile.part"),
        &["tile.part: header", "tiles of 32 pixels"],
    );
    with_header(d, 1, "size.part", "\"width\":100", "\"width\":100000");
    merge_fails(
        d,
        &with("size.part"),
        &["size.part: header: image size 100000x56"],
    );
    with_header(
        d,
        1,
        "sum.part",
        "\"pixels_sha256\":\"",
        "\"pixels_sha256\":\"0",
    );
    merge_fails(d, &with("sum.part"), &["sum.part: corrupt"]);
    // The first part is checked as well as the others.
    merge_fails(
        d,
        &["flip.part", "p0.part", "p2.part", "p3.part"],
        &["flip.part: corrupt"],
    );
}

#[test]
fn bad_region_flags_are_refused() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let cases: [(&[&str], &str); 9] = [
        (&["--region", "4/4"], "--region"),
        (&["--region", "1-4"], "--region"),
        (&["--region", "0/0"], "--region"),
        (&["--region", "0/65537"], "--region"),
        (&["--crop", "1,2,3"], "--crop"),
        (&["--crop", "5,0,5,10"], "--crop"),
        (&["--crop", "0,0,101,10"], "--crop 0,0,101,10"),
        (&["--region", "0/2", "--crop", "0,0,4,4"], "--crop"),
        (
            &["--region", "0/2", "-o", "part.png"],
            "--region writes a part file",
        ),
    ];
    for (extra, expected) in cases {
        let mut args = SCENE.to_vec();
        args.extend_from_slice(extra);
        let before = snapshot(d);
        let run = run_in(d, &args);
        assert_eq!(run.code, Some(2), "{args:?}: {}", run.stderr);
        assert!(run.stderr.contains(expected), "{args:?}: {}", run.stderr);
        assert!(snapshot(d) == before, "{args:?} wrote a file");
        assert!(std::fs::read_dir(d).unwrap().next().is_none());
    }
}

#[test]
fn merge_output_must_be_an_image_that_can_be_written() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    let parts = ["p0.part", "p1.part", "p2.part", "p3.part"];
    for (out, expected) in [
        ("out.part", "unsupported image format"),
        ("no/out.exr", "does not exist"),
    ] {
        let mut args = vec!["merge"];
        args.extend_from_slice(&parts);
        args.extend(["-o", out]);
        let before = snapshot(d);
        let run = run_in(d, &args);
        assert_eq!(run.code, Some(2), "{}", run.stderr);
        assert!(
            run.stderr.contains(expected) && run.stderr.contains(out),
            "{}",
            run.stderr
        );
        assert!(snapshot(d) == before);
    }
}

/// A part that is not a regular file is refused before it is opened (a FIFO would block),
/// the frame may not replace one of its parts, and `--max-memory` refuses a merge that
/// needs more, naming the flag.
#[test]
fn merge_refuses_special_files_its_own_parts_and_too_little_memory() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    good_parts(d);
    std::fs::create_dir(d.join("dir.part")).unwrap();
    merge_fails(
        d,
        &["p0.part", "p1.part", "dir.part", "p3.part"],
        &["dir.part", "not a regular file (a directory)"],
    );
    #[cfg(unix)]
    {
        let fifo = d.join("fifo.part");
        let made = Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            merge_fails(
                d,
                &["p0.part", "p1.part", "fifo.part", "p3.part"],
                &["fifo.part", "not a regular file (a FIFO)"],
            );
            std::fs::remove_file(&fifo).unwrap();
        }
    }
    merge_fails(
        d,
        &[
            "p0.part",
            "p1.part",
            "p2.part",
            "p3.part",
            "--max-memory",
            "1M",
        ],
        &[
            "--max-memory",
            "not enough memory for merging 4 parts into a 100x56 frame",
        ],
    );
    // A part named like an image, and the same file as the output.
    std::fs::copy(d.join("p2.part"), d.join("p2.exr")).unwrap();
    let before = snapshot(d);
    let run = run_in(
        d,
        &[
            "merge", "p0.part", "p1.part", "p2.exr", "p3.part", "-o", "./p2.exr",
        ],
    );
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("-o names the part file p2.exr"),
        "{}",
        run.stderr
    );
    assert!(snapshot(d) == before);
}

// ---------------------------------------------------------------------------------------
// The reader on any bytes.

/// A small part file's bytes, made once.
fn sample_part() -> &'static [u8] {
    static BYTES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    BYTES.get_or_init(|| {
        let options = SceneOptions {
            width: Some(24),
            spp: Some(1),
            ..SceneOptions::default()
        };
        let renderer = Renderer::new(&SceneFile::builtin("spheres").unwrap(), &options).unwrap();
        let region = Region::Part { index: 0, count: 2 };
        let part = renderer
            .render_part(&RenderSettings::default(), region)
            .unwrap();
        let dir = TempDir::new().unwrap();
        let path = dir.path().join("p.part");
        part.write(&path).unwrap();
        read(&path)
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Truncated, extended or bit-flipped part files: the reader never panics, and what
    /// it accepts has exactly the original pixels.
    #[test]
    fn reader_accepts_only_intact_pixels(
        cut in 0usize..4000,
        flips in proptest::collection::vec((0usize..4000, 0u8..8), 0..3),
        tail in proptest::collection::vec(any::<u8>(), 0..3),
    ) {
        let good = sample_part();
        let original: Vec<[u32; 3]> = part::parse_part(good)
            .unwrap()
            .pixels()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect();
        let mut bytes = good.to_vec();
        for (at, bit) in flips {
            let i = at % bytes.len();
            bytes[i] ^= 1 << bit;
        }
        if cut < bytes.len() && cut % 3 == 0 {
            bytes.truncate(cut);
        }
        bytes.extend_from_slice(&tail);
        if let Ok(p) = part::parse_part(&bytes) {
            let pixels: Vec<[u32; 3]> = p.pixels().map(|p| p.to_array().map(f32::to_bits)).collect();
            prop_assert_eq!(pixels, original);
        }
    }
}

#[test]
fn sample_part_parses() {
    let p = part::parse_part(sample_part()).unwrap();
    assert_eq!(p.header.settings.width, 24);
    assert_eq!(p.header.program, part::PROGRAM);
    assert_eq!(p.pixels().count() as u64, p.header.pixels);
}

/// The fuzzing seeds (`fuzz/seeds/part`): the `.part` files are good part files of this
/// program, so the campaign starts from inputs that reach the pixel checks and the
/// merge; the `found-*` files, inputs that found a bug, are refused with one line.
#[test]
fn the_fuzzing_seeds_are_good_part_files_or_refused_in_one_line() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/part");
    let (mut good, mut found) = (0, 0);
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let bytes = read(&path);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.starts_with("found-") {
            let e = part::parse_part(&bytes).expect_err(&name);
            assert!(!e.contains('\n') && !e.contains('\u{1b}'), "{name}: {e}");
            found += 1;
        } else {
            let p = part::parse_part(&bytes)
                .unwrap_or_else(|e| panic!("{}: {e}; make the seeds again", path.display()));
            assert_eq!(p.header.program, part::PROGRAM, "{}", path.display());
            good += 1;
        }
    }
    assert_eq!((good, found), (3, 1));
}
