//! The hostile sweep: the binary run over each class of attack on its contract (mutated
//! scenes, every key with hostile values, mutated OBJ files, extreme flags, output
//! faults, signals, concurrent writers), counting exits other than 0 and 2, temporary
//! files left behind and outputs clobbered. All three counts must be zero.
//!
//! Every run writes a PPM over an earlier file of other bytes: after an exit 0 it must
//! be a complete image of the size the header gives, after anything else the earlier
//! bytes. `cargo test` runs a sample of each class (a few hundred runs); set
//! `RAYTRACER_SWEEP_SCALE=N` for N times as many, e.g. `RAYTRACER_SWEEP_SCALE=20 cargo
//! test --release --test hostile_sweep -- --nocapture`, which prints the counts.
#![cfg(unix)]

use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

const BIN: &str = env!("CARGO_BIN_EXE_raytracer");
const SENTINEL: &[u8] = b"an earlier file: kept unless a run succeeds\n";
/// A run longer than this is counted as a hang.
const TIMEOUT: Duration = Duration::from_secs(120);

/// A small scene with a mesh; every `key = value` line is a target of the key class.
const BASE: &str = r#"description = "a hostile test scene"
background = [0.1, 0.1, 0.1]
ambient = [0.05, 0.05, 0.05]

[camera]
width = 8
aspect_ratio = 1.0
samples_per_pixel = 1
max_depth = 2
vfov = 90
look_from = [0, 0, 0]
look_at = [0, 0, -1]
up = [0, 1, 0]

[materials.red]
type = "phong"
albedo = [0.8, 0.1, 0.1]
shininess = 10

[materials.mirror]
type = "phong_mirror"
albedo = [0.9, 0.9, 0.9]
shininess = 100
index = 1.5

[materials.glass]
type = "dielectric"
index = 1.5

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

[[objects]]
type = "quad"
corner = [-2, -1, -3]
u = [4, 0, 0]
v = [0, 0, 2]
material = "mirror"

[[objects]]
type = "triangle"
a = [-1, 0, -1.5]
b = [-0.5, 0, -1.5]
c = [-1, 0.5, -1.5]
material = "glass"

[[objects]]
type = "box"
corners = [[0.5, -1, -3], [1, -0.5, -2.5]]
material = "lamp"

[[objects]]
type = "mesh"
path = "mesh.obj"
material = "red"
"#;

const OBJ: &str = "o a\nv 0 0 -2\nv 1 0 -2\nv 0 1 -2\nv 1 1 -2.5\nvt 0 0\nvn 0 0 1\n\
f 1 2 3\nf 2/1/1 4/1/1 3/1/1\nf -3//1 -2//1 -1//1\n";

const HOSTILE_VALUES: &[&str] = &[
    "1e39",
    "-1e39",
    "3e38",
    "1e30",
    "1e20",
    "nan",
    "inf",
    "-inf",
    "-0.0",
    "0",
    "-1",
    "4294967296",
    "1e-45",
    "\"x\"",
    "true",
    "[]",
    "[1, 2]",
    "[1, 2, 3, 4]",
    "[0.1, 0.2, 0.3, \"junk\", [1]]",
    "[3e38, 3e38, 3e38]",
    "[1e30, 1e30, 1e30]",
    "[nan, 0, 0]",
    "[0, 0, 0]",
    "{ a = 1 }",
    "\"../assets/bunny.obj\"",
    "\"/dev/zero\"",
    "\"\"",
    "10001",
    "65537",
];

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Text with one to three byte-level mutations.
fn mutate(rng: &mut Rng, text: &[u8], tokens: &[&str]) -> Vec<u8> {
    let mut t = text.to_vec();
    for _ in 0..1 + rng.below(3) {
        let at = rng.below(t.len() + 1);
        match rng.below(6) {
            0 if !t.is_empty() => {
                let end = (at + 1 + rng.below(16)).min(t.len());
                t.drain(at.min(end)..end);
            }
            1 => t.insert(at, rng.next() as u8),
            2 => {
                let token = rng.pick(tokens).as_bytes();
                t.splice(at..at, token.iter().copied());
            }
            3 => t.truncate(at),
            4 if !t.is_empty() => {
                let i = rng.below(t.len());
                t[i] = *rng.pick(b"0123456789-+.e[]=\"\n\r\x00\xff#,/ ");
            }
            _ => {
                // Repeat a line.
                let s = String::from_utf8_lossy(&t).into_owned();
                let lines: Vec<&str> = s.lines().collect();
                if !lines.is_empty() {
                    let line = format!("{}\n", rng.pick(&lines));
                    t.splice(at..at, line.bytes());
                }
            }
        }
    }
    t
}

#[derive(Default, Debug)]
struct Tally {
    runs: usize,
    ok: usize,
    refused: usize,
    signalled: usize,
    /// Exits other than 0 and 2 (and, outside the signal class, any death by a signal).
    other: Vec<String>,
    temporaries: Vec<String>,
    clobbered: Vec<String>,
}

/// One case's directory: the scene, the mesh and an earlier `out.ppm`.
struct Case {
    dir: TempDir,
}

impl Case {
    fn new(scene: &[u8], obj: &[u8]) -> Case {
        let dir = TempDir::new().unwrap();
        std::fs::write(dir.path().join("scene.toml"), scene).unwrap();
        std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
        std::fs::write(dir.path().join("out.ppm"), SENTINEL).unwrap();
        Case { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn spawn(&self, args: &[String]) -> Child {
        Command::new(BIN)
            .args(args)
            .current_dir(self.dir.path())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    }
}

fn wait(child: &mut Child) -> Option<ExitStatus> {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return Some(status);
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// A complete binary PPM: its header, then exactly width × height × 3 bytes.
fn is_complete_ppm(bytes: &[u8]) -> bool {
    header_size(bytes).is_some_and(|(header, pixels)| bytes.len() == header + pixels)
}

/// (header length, pixel bytes) of a `P6\nW H\n255\n` header.
fn header_size(bytes: &[u8]) -> Option<(usize, usize)> {
    let mut fields = Vec::new();
    let mut i = 0;
    while fields.len() < 4 {
        while bytes.get(i)?.is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while !bytes.get(i)?.is_ascii_whitespace() {
            i += 1;
        }
        fields.push(std::str::from_utf8(&bytes[start..i]).ok()?.to_string());
    }
    if fields[0] != "P6" || fields[3] != "255" {
        return None;
    }
    let (w, h): (usize, usize) = (fields[1].parse().ok()?, fields[2].parse().ok()?);
    Some((i + 1, w * h * 3))
}

/// Temporary files of any run left in `dir` and its subdirectories.
fn temporaries(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            found.extend(temporaries(&entry.path()));
        } else if name.starts_with(".raytracer-") || name.ends_with(".tmp") {
            found.push(name);
        }
    }
    found
}

impl Tally {
    /// Count one finished run of `case`; `signal_allowed`: a death by SIGINT/SIGTERM is
    /// expected (the signal class).
    fn record(&mut self, what: &str, case: &Case, status: Option<ExitStatus>, allowed: bool) {
        self.runs += 1;
        let out = std::fs::read(case.path("out.ppm")).unwrap_or_default();
        match status {
            None => self.other.push(format!("{what}: ran past {TIMEOUT:?}")),
            Some(s) if s.code() == Some(0) => {
                self.ok += 1;
                if out != SENTINEL && !is_complete_ppm(&out) {
                    self.clobbered
                        .push(format!("{what}: exit 0, an incomplete image"));
                }
            }
            Some(s) => {
                match (s.code(), s.signal()) {
                    (Some(2), _) => self.refused += 1,
                    (None, Some(2 | 15)) if allowed => self.signalled += 1,
                    _ => self.other.push(format!("{what}: {s}")),
                }
                if out != SENTINEL && !(allowed && is_complete_ppm(&out)) {
                    self.clobbered.push(format!("{what}: {s}, out.ppm changed"));
                }
            }
        }
        for t in temporaries(case.dir.path()) {
            self.temporaries.push(format!("{what}: {t}"));
        }
    }

    fn run(&mut self, what: &str, case: &Case, args: &[String]) {
        let mut child = case.spawn(args);
        let status = wait(&mut child);
        self.record(what, case, status, false);
    }
}

fn args(words: &[&str]) -> Vec<String> {
    words.iter().map(|w| w.to_string()).collect()
}

/// The quick flags every scene case runs with: small and fast, over the earlier file.
fn quick(extra: &[&str]) -> Vec<String> {
    let mut a = args(&[
        "scene.toml",
        "-q",
        "-o",
        "out.ppm",
        "--width",
        "8",
        "--spp",
        "1",
    ]);
    a.extend(args(extra));
    a
}

fn scale() -> usize {
    std::env::var("RAYTRACER_SWEEP_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
}

/// A class's verdict: it ran, every run is counted once, and no run exited otherwise than
/// 0 or 2 (or, in the signal class, by SIGINT/SIGTERM), left a temporary file or
/// clobbered its output. Under `RAYTRACER_SWEEP_SCALE` the counts are printed too: how a
/// long sweep's runs split between exits 0 and 2 is for the reader, not a property of the
/// binary (either exit keeps the contract).
fn report(class: &str, t: &Tally) {
    if scale() > 1 {
        println!(
            "{class:<18} runs {:>5}: exit 0: {:>5}, exit 2: {:>5}, signalled: {:>4}; other exits: {}, temporaries left: {}, outputs clobbered: {}",
            t.runs,
            t.ok,
            t.refused,
            t.signalled,
            t.other.len(),
            t.temporaries.len(),
            t.clobbered.len()
        );
    }
    assert!(t.runs > 0, "{class}: no runs");
    assert_eq!(
        t.ok + t.refused + t.signalled + t.other.len(),
        t.runs,
        "{class}: runs miscounted"
    );
    assert!(t.other.is_empty(), "{class}: {:#?}", t.other);
    assert!(t.temporaries.is_empty(), "{class}: {:#?}", t.temporaries);
    assert!(t.clobbered.is_empty(), "{class}: {:#?}", t.clobbered);
}

#[test]
fn mutated_scenes() {
    let mut rng = Rng(0x5eed_0001);
    let mut t = Tally::default();
    let mut sources: Vec<String> = vec![BASE.to_string()];
    for name in ["cornell", "spheres", "quads", "mixed", "bunny"] {
        let text = std::fs::read_to_string(format!("scenes/{name}.toml")).unwrap();
        sources.push(text.replace(
            "../assets/",
            concat!(env!("CARGO_MANIFEST_DIR"), "/assets/"),
        ));
    }
    let tokens = [
        "1e39",
        "nan",
        "[",
        "]",
        "=",
        "\"",
        "\n[[objects]]\n",
        "-",
        "9999999999",
    ];
    for i in 0..60 * scale() {
        let from = rng.pick(&sources).clone();
        let scene = mutate(&mut rng, from.as_bytes(), &tokens);
        let case = Case::new(&scene, OBJ.as_bytes());
        t.run(&format!("mutated scene {i}"), &case, &quick(&[]));
    }
    report("mutated scenes", &t);
}

#[test]
fn every_key_with_hostile_values() {
    let mut rng = Rng(0x5eed_0002);
    let mut t = Tally::default();
    let lines: Vec<(usize, &str)> = BASE
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(" = "))
        .collect();
    // Each key with a sample of the values (all of them at a scale of 4 or more).
    let per_key = (HOSTILE_VALUES.len() * scale())
        .div_ceil(4)
        .min(HOSTILE_VALUES.len());
    for &(n, line) in &lines {
        let key = line.split(" = ").next().unwrap();
        let start = rng.below(HOSTILE_VALUES.len());
        for k in 0..per_key {
            let value = HOSTILE_VALUES[(start + k) % HOSTILE_VALUES.len()];
            let scene: String = BASE
                .lines()
                .enumerate()
                .map(|(i, l)| {
                    if i == n {
                        format!("{key} = {value}\n")
                    } else {
                        format!("{l}\n")
                    }
                })
                .collect();
            let case = Case::new(scene.as_bytes(), OBJ.as_bytes());
            // The quick flags replace the file's size and samples, which are still
            // validated.
            t.run(
                &format!("line {} {key} = {value}", n + 1),
                &case,
                &quick(&[]),
            );
        }
    }
    report("hostile values", &t);
}

#[test]
fn mutated_obj_files() {
    let mut rng = Rng(0x5eed_0003);
    let mut t = Tally::default();
    let seeds: Vec<String> = ["bunny-part.obj", "cr.obj", "indices.obj", "quad.obj"]
        .iter()
        .map(|f| std::fs::read_to_string(format!("fuzz/seeds/obj/{f}")).unwrap())
        .chain([OBJ.to_string()])
        .collect();
    let tokens = [
        "f ",
        "v ",
        "1e39",
        "-0",
        "/",
        "//",
        "nan",
        "\r",
        "4294967296",
        "-99",
    ];
    for i in 0..60 * scale() {
        let from = rng.pick(&seeds).clone();
        let obj = mutate(&mut rng, from.as_bytes(), &tokens);
        let case = Case::new(BASE.as_bytes(), &obj);
        t.run(&format!("mutated obj {i}"), &case, &quick(&[]));
    }
    report("mutated OBJ", &t);
}

#[test]
fn extreme_flags() {
    let mut t = Tally::default();
    let flags: &[&[&str]] = &[
        &["--width", "0"],
        &["--width", "1"],
        &["--width", "65537"],
        &["--width", "-1"],
        &["--width", "1e3"],
        &["--width", "99999999999999999999"],
        &["--spp", "0"],
        &["--spp", "-3"],
        &["--max-depth", "0"],
        &["--max-depth", "10001"],
        &["--max-depth", "4294967296"],
        &["--threads", "0"],
        &["--threads", "1"],
        &["--threads", "100000"],
        &["--seed", "18446744073709551615"],
        &["--seed", "18446744073709551616"],
        &["--packet-width", "3"],
        &["--packet-width", "1"],
        &["--sampler", "nope"],
        &["--accel", "linear"],
        &["--max-memory", "1"],
        &["--max-memory", "0"],
        &["--max-memory", "9E"],
        &["--max-memory", "1K"],
        &["-o", "out.bmp"],
        &["-o", ""],
        &["-o", "/"],
        &["-o", "missing/dir/out.ppm"],
        &["-o", "."],
        &["--report", "scene.toml"],
        &["--report", "out.ppm"],
        &["--report", ""],
        &["--report", "."],
        &["--stats", "--no-specialize"],
        &["--", "--width"],
    ];
    let reps = scale();
    for f in flags.iter().cycle().take(flags.len() * reps) {
        let case = Case::new(BASE.as_bytes(), OBJ.as_bytes());
        // The quick defaults, less those the case gives.
        let mut a = args(&["scene.toml", "-q"]);
        for default in [["-o", "out.ppm"], ["--spp", "1"], ["--width", "8"]] {
            if !f.contains(&default[0]) {
                a.extend(args(&default));
            }
        }
        a.extend(args(f));
        t.run(&format!("flags {f:?}"), &case, &a);
    }
    for scene in ["/dev/zero", "/dev/null", "/", "nope.toml", ""] {
        let case = Case::new(BASE.as_bytes(), OBJ.as_bytes());
        t.run(
            &format!("scene {scene}"),
            &case,
            &args(&[scene, "-q", "-o", "out.ppm"]),
        );
    }
    report("extreme flags", &t);
}

/// Output faults: a read-only directory (skipped as root, which ignores permissions), a
/// file-size limit (past which writes fail), an output that is a directory.
#[test]
fn output_faults() {
    let mut t = Tally::default();
    let has_prlimit = Command::new("prlimit").arg("--version").output().is_ok();
    for limit in [100u64, 300, 2000] {
        if !has_prlimit {
            eprintln!("skipped the file-size cases: no prlimit here");
            break;
        }
        for report in [false, true] {
            let case = Case::new(BASE.as_bytes(), OBJ.as_bytes());
            let mut a = args(&[&format!("--fsize={limit}"), BIN]);
            a.extend(quick(if report { &["--report", "r.json"] } else { &[] }));
            let mut child = Command::new("prlimit")
                .args(&a)
                .current_dir(case.dir.path())
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
            let status = wait(&mut child);
            t.record(
                &format!("fsize {limit} report {report}"),
                &case,
                status,
                false,
            );
        }
    }
    let case = Case::new(BASE.as_bytes(), OBJ.as_bytes());
    std::fs::create_dir(case.path("dir.ppm")).unwrap();
    t.run("output is a directory", &case, &quick(&["-o", "dir.ppm"]));
    report("output faults", &t);
}

/// SIGINT and SIGTERM at many moments of a run: it ends by the signal (or finishes
/// first); no temporary file is left, and out.ppm is the earlier bytes or a complete
/// image.
#[test]
fn signals_at_any_moment() {
    let mut t = Tally::default();
    let delays_ms: Vec<u64> = (0..12 * scale() as u64).map(|i| (i * 37) % 400).collect();
    for (i, &delay) in delays_ms.iter().enumerate() {
        let case = Case::new(BASE.as_bytes(), OBJ.as_bytes());
        let width = if i % 2 == 0 { "256" } else { "64" };
        let mut child = case.spawn(&args(&[
            "scene.toml",
            "-q",
            "-o",
            "out.ppm",
            "--width",
            width,
            "--spp",
            "4",
        ]));
        std::thread::sleep(Duration::from_millis(delay));
        let signal = if i % 2 == 0 { "-INT" } else { "-TERM" };
        let _ = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status();
        let status = wait(&mut child);
        t.record(&format!("{signal} after {delay} ms"), &case, status, true);
    }
    report("signals", &t);
}

/// Writers of one file at once: every run succeeds and the file is one complete image,
/// the same bytes as one writer's.
#[test]
fn concurrent_writers() {
    let mut t = Tally::default();
    for round in 0..3 * scale() {
        let case = Case::new(BASE.as_bytes(), OBJ.as_bytes());
        let seeds = ["1", "2", "3", "4"];
        let writer = |out: &str, seed: &str| {
            args(&[
                "scene.toml",
                "-q",
                "-o",
                out,
                "--width",
                "32",
                "--spp",
                "1",
                "--seed",
                seed,
            ])
        };
        let mut children: Vec<Child> = seeds
            .iter()
            .map(|s| case.spawn(&writer("out.ppm", s)))
            .collect();
        // Counted once all have ended: a running writer's temporary file is no leak.
        let statuses: Vec<Option<ExitStatus>> = children.iter_mut().map(wait).collect();
        for status in statuses {
            t.record(&format!("writers round {round}"), &case, status, false);
        }
        let shared = std::fs::read(case.path("out.ppm")).unwrap();
        let alone: Vec<Vec<u8>> = seeds
            .iter()
            .map(|s| {
                let out = format!("alone-{s}.ppm");
                let status = wait(&mut case.spawn(&writer(&out, s)));
                assert_eq!(status.and_then(|s| s.code()), Some(0));
                std::fs::read(case.path(&out)).unwrap()
            })
            .collect();
        // Different seeds, different images: the file is one writer's, whole.
        assert!(alone.iter().skip(1).any(|a| *a != alone[0]));
        if !alone.contains(&shared) {
            t.clobbered.push(format!(
                "writers round {round}: out.ppm is no writer's image"
            ));
        }
    }
    report("concurrent writers", &t);
}
