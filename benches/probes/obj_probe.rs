//! OBJ loading: writes the bunny subdivided `LEVELS` times (`generate::subdivide`) as an
//! indexed OBJ file (each distinct vertex once, in the order first met, at full f32
//! precision, then one `f` line a triangle; level 4 is 1 271 808 triangles in 53 MB),
//! and times `read_obj` on a file against the checked tobj path alone
//! (`read_obj_checked`, what `read_obj` falls back to), on a pool of `THREADS` threads:
//! the text read once beforehand, an untimed pass of each, then `PASSES` rounds that
//! alternate the two, and each one's median.
//! docs/performance.md, "Loading", has the figures.
//!
//! ```sh
//! cargo run --release --example obj_probe -- write 4 /tmp/bunny4.obj
//! cargo run --release --example obj_probe -- read /tmp/bunny4.obj 1 5
//! ```

use raytracer::scene::mesh::{parse_obj, read_obj, read_obj_checked, MeshTriangles, ObjOptions};
use std::collections::HashMap;
use std::io::Write;
use std::time::Instant;

fn usage() -> ! {
    eprintln!("usage: obj_probe write LEVELS OUT.obj | obj_probe read FILE.obj [THREADS] [PASSES]");
    std::process::exit(2)
}

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let number = |i: usize, default: usize| match args.get(i).map(|s| s.parse::<usize>()) {
        None => default,
        Some(Ok(n)) if n > 0 => n,
        Some(_) => usage(),
    };
    match (args.first().map(String::as_str), args.get(2)) {
        (Some("write"), Some(out)) => write(number(1, 4) as u32, out),
        (Some("read"), None) | (Some("read"), Some(_)) if args.len() >= 2 => {
            read(&args[1], number(2, 1), number(3, 5))
        }
        _ => usage(),
    }
}

fn write(levels: u32, out: &str) -> std::io::Result<()> {
    let text = include_str!("../../assets/bunny.obj");
    let mut mesh = parse_obj("bunny.obj", text).unwrap_or_else(|e| {
        eprintln!("obj_probe: {e}");
        std::process::exit(2);
    });
    mesh.subdivide(levels);
    let mut index: HashMap<[u32; 3], usize> = HashMap::new();
    let mut vertices = Vec::new();
    let mut faces = Vec::with_capacity(mesh.triangles.len());
    for t in &mesh.triangles {
        faces.push(t.map(|p| {
            *index
                .entry(p.to_array().map(f32::to_bits))
                .or_insert_with(|| {
                    vertices.push(p);
                    vertices.len()
                })
        }));
    }
    let mut w = std::io::BufWriter::new(std::fs::File::create(out)?);
    writeln!(w, "# the bunny subdivided {levels} times")?;
    for p in &vertices {
        writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for [a, b, c] in &faces {
        writeln!(w, "f {a} {b} {c}")?;
    }
    w.flush()?;
    println!(
        "{out}: {} vertices, {} triangles",
        vertices.len(),
        faces.len()
    );
    Ok(())
}

fn read(path: &str, threads: usize, passes: usize) -> std::io::Result<()> {
    let text = std::fs::read_to_string(path)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(std::io::Error::other)?;
    type Reader = fn(&str, &str, ObjOptions) -> raytracer::Result<MeshTriangles>;
    let readers: [(&str, Reader); 2] = [("read_obj", read_obj), ("checked", read_obj_checked)];
    let once = |reader: Reader| {
        let t = Instant::now();
        let mesh = pool.install(|| reader(path, &text, ObjOptions::default()));
        let mesh = mesh.unwrap_or_else(|e| {
            eprintln!("obj_probe: {e}");
            std::process::exit(2);
        });
        (t.elapsed().as_secs_f64() * 1e3, mesh)
    };
    let (_, want) = once(read_obj);
    let (_, checked) = once(read_obj_checked);
    assert!(
        want.triangles == checked.triangles && want.degenerate == checked.degenerate,
        "the two readers differ"
    );
    println!(
        "{path}: {} triangles ({} degenerate), {threads} thread(s), ms a pass:",
        want.triangles.len(),
        want.degenerate
    );
    // The readers alternate, so a change of load falls on both.
    let mut times = vec![Vec::new(); readers.len()];
    for _ in 0..passes {
        for (t, (_, reader)) in times.iter_mut().zip(readers) {
            t.push(once(reader).0);
        }
    }
    for (t, (name, _)) in times.iter_mut().zip(readers) {
        let each: Vec<String> = t.iter().map(|t| format!("{t:.1}")).collect();
        t.sort_by(f64::total_cmp);
        println!("{name:<9} {}; median {:.1}", each.join(" "), t[passes / 2]);
    }
    Ok(())
}
