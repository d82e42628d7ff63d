//! The most any allocation of samples over the frame could gain over uniform Sobol: an
//! oracle that knows every tile's (and every pixel's) error at every power of two
//! (docs/adaptive.md, "The most an allocation can gain").
//!
//! ```sh
//! raytracer reference cornell --width 256 --threads 1    # target/reference/cornell-w256-4096spp.exr
//! cargo run --release --example adaptive_ceiling -- cornell --width 256 \
//!     --choose-seeds 1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16 --adaptive
//! ```
//!
//! Renders uniform Sobol (seed `--seed`, one thread) at n = 1, 2, 4, …, `--max-spp`, one
//! tile of the adaptive renderer's 16x16 lattice at a time (a crop window, whose pixels
//! have the bits of the whole frame's: checked), and keeps per pixel the relMSE terms
//! against the reference (the sum over channels of (x − r)² / (r² + 0.01)) and per tile
//! the rays it traced. A pixel's rays are its tile's, split in the proportion of each
//! pixel's own rays at `--pixel-spp` samples (1x1 crops, one ray at a time).
//!
//! The oracle picks n ∈ {`--min-spp`, …, `--max-spp`} (powers of two) per tile, or per
//! pixel, to minimise the rays for a total error: for each λ every unit takes the n
//! minimising E(n) + λ·rays(n), which traces the lower convex hull of (rays, error);
//! between two vertices of the hull the cost is interpolated linearly (a lower bound on
//! the best whole choice). Its cost for a target relative RMSE is compared with the rays
//! uniform Sobol takes for the same relMSE, interpolated in log-log between the uniform
//! points as `raytracer sweep` does.
//!
//! - fitted: chosen on the render it is measured on, so fitted to its noise (optimistic);
//! - mean (`--choose-seeds`): chosen and measured on the mean errors of other seeds'
//!   renders, against their mean uniform series (less noise to fit);
//! - held out: chosen on that mean, measured on `--seed`'s render (a choice that knows
//!   the error only as well as those renders tell it: pessimistic).
//!
//! `--adaptive` also runs the adaptive renderer at the targets, checks that its image is
//! one of the oracle's choices (its error and rays are the sums of its tiles' entries at
//! the samples they took), and compares its gain with the oracle's at the error it
//! reached.

use anyhow::Context as _;
use clap::Parser;
use raytracer::accel::{Accel, AccelKind};
use raytracer::render::{self, Film};
use raytracer::scene::{Overrides, Scene};
use raytracer::{Adaptive, PacketWidth, Rect, Region, RenderSettings, SamplerKind};
use std::path::{Path, PathBuf};
use std::time::Instant;

const TILE: u32 = 16;
const EPS: f64 = raytracer::metrics::REL_MSE_EPSILON;

#[derive(Parser)]
struct Args {
    /// A built-in scene name or a `.toml` scene file.
    scene: String,
    /// Image width.
    #[arg(long)]
    width: u32,
    /// The most samples a pixel (a power of two).
    #[arg(long, default_value_t = 1024)]
    max_spp: u32,
    /// The fewest samples a pixel the oracle may give (the adaptive renderer's first pass).
    #[arg(long, default_value_t = 4)]
    min_spp: u32,
    /// Seed of the renders (a sweep's default).
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// The reference (default target/reference/STEM-wW-4096spp.exr).
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Target relative RMSEs, in %.
    #[arg(long, value_delimiter = ',', default_value = "10,5,2,1")]
    targets: Vec<f64>,
    /// Samples a pixel of the 1x1 crops that split a tile's rays among its pixels.
    #[arg(long, default_value_t = 16)]
    pixel_spp: u32,
    /// Also choose on the mean errors and rays of these seeds' renders and measure the
    /// choices on `--seed`'s: an oracle that does not fit the noise of the render it is
    /// measured on (and knows the error only as well as these renders tell it).
    #[arg(long, value_delimiter = ',')]
    choose_seeds: Vec<u32>,
    /// Also run the adaptive renderer at the targets (budget `--max-spp`).
    #[arg(long)]
    adaptive: bool,
}

/// Per unit (tile or pixel): error and rays at each level n = 1, 2, 4, ….
struct Unit {
    err: Vec<f64>,
    rays: Vec<f64>,
}

/// A step of the oracle: unit `unit` going from level `from` to level `to`, the next
/// vertex of its hull.
struct Step {
    unit: usize,
    from: usize,
    to: usize,
    /// Error less a ray more.
    slope: f64,
}

/// The lower convex hull of a unit's points (rays, error) at levels `first..`, from the
/// cheapest: the levels of its vertices (error falling, rays rising, the error a ray
/// falling less at each step).
fn unit_hull(u: &Unit, first: usize) -> Vec<usize> {
    let mut hull: Vec<usize> = vec![first];
    for i in first + 1..u.err.len() {
        let last = *hull.last().unwrap();
        // Only points that lower the error on the last vertex; rays rise with n.
        if u.err[i] >= u.err[last] || u.rays[i] <= u.rays[last] {
            continue;
        }
        while hull.len() >= 2 {
            let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            // Keep b if the slope a->b is steeper (more negative) than a->i.
            let cross = (u.rays[b] - u.rays[a]) * (u.err[i] - u.err[a])
                - (u.err[b] - u.err[a]) * (u.rays[i] - u.rays[a]);
            if cross <= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(i);
    }
    hull
}

/// The oracle's choices over all units, from every unit at level `first`: each step of
/// every unit's hull, the most error less a ray first (within a unit, by convexity, in
/// the order of its hull).
fn oracle_steps(units: &[Unit], first: usize) -> Vec<Step> {
    let mut steps = Vec::new();
    for (k, u) in units.iter().enumerate() {
        for w in unit_hull(u, first).windows(2) {
            let (from, to) = (w[0], w[1]);
            steps.push(Step {
                unit: k,
                from,
                to,
                slope: (u.err[from] - u.err[to]) / (u.rays[to] - u.rays[from]),
            });
        }
    }
    steps.sort_by(|a, b| b.slope.total_cmp(&a.slope));
    steps
}

/// The (rays, error sum) of `units` after each of `steps` in turn, from every unit at
/// level `first`: with the units the steps were chosen on, the lower convex hull.
fn replay(units: &[Unit], first: usize, steps: &[Step]) -> Vec<(f64, f64)> {
    let mut rays: f64 = units.iter().map(|u| u.rays[first]).sum();
    let mut err: f64 = units.iter().map(|u| u.err[first]).sum();
    let mut curve = vec![(rays, err)];
    for s in steps {
        let u = &units[s.unit];
        rays += u.rays[s.to] - u.rays[s.from];
        err += u.err[s.to] - u.err[s.from];
        curve.push((rays, err));
    }
    curve
}

/// The rays at which a falling (rays, error) curve reaches `target`, linear between its
/// points; `None` if it never does.
fn cost_at(curve: &[(f64, f64)], target: f64) -> Option<f64> {
    // The curve's sums are of the same terms as the uniform series' in another order.
    let target = target * (1.0 + 1e-9);
    if curve[0].1 <= target {
        return Some(curve[0].0);
    }
    curve.windows(2).find(|w| w[1].1 <= target).map(|w| {
        let t = (w[0].1 - target) / (w[0].1 - w[1].1);
        w[0].0 + t * (w[1].0 - w[0].0)
    })
}

/// The rays at which the uniform series reaches relMSE `target`, log-log between its
/// points (as `raytracer sweep`); `None` outside the series.
fn uniform_cost(series: &[(f64, f64)], target: f64) -> Option<f64> {
    let l = target.ln();
    series.windows(2).find_map(|w| {
        let (x0, y0) = (w[0].1.ln(), w[0].0.ln());
        let (x1, y1) = (w[1].1.ln(), w[1].0.ln());
        ((x0 >= l && l >= x1) || (x1 >= l && l >= x0)).then(|| {
            let t = if x1 == x0 { 0.0 } else { (l - x0) / (x1 - x0) };
            (y0 + t * (y1 - y0)).exp()
        })
    })
}

/// The relMSE terms of each pixel (summed over channels).
fn terms(pixels: &[raytracer::Vec3], reference: &Film, rect: Rect) -> Vec<f64> {
    let mut out = Vec::with_capacity(pixels.len());
    let mut i = 0;
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            let r = reference.pixels[(y * reference.width + x) as usize];
            let p = pixels[i];
            i += 1;
            let mut s = 0.0;
            for c in 0..3 {
                let (a, b) = (f64::from(p[c]), f64::from(r[c]));
                s += (a - b) * (a - b) / (b * b + EPS);
            }
            out.push(s);
        }
    }
    out
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    anyhow::ensure!(
        args.max_spp.is_power_of_two() && args.min_spp.is_power_of_two(),
        "--max-spp and --min-spp must be powers of two"
    );
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    pool.install(|| run(&args))
}

/// A uniform series of one seed: per tile its error and rays at each level, per tile
/// its pixels' terms at each level, and the frame's (rays, relMSE) at each level.
struct Series {
    tiles: Vec<Unit>,
    pixel_terms: Vec<Vec<Vec<f64>>>,
    uniform: Vec<(f64, f64)>,
}

/// Render uniform Sobol at every level, a tile at a time.
fn series(c: &Context, scene: &mut Scene, seed: u32) -> anyhow::Result<Series> {
    let settings = RenderSettings { seed, ..c.settings };
    let denom = c.denom();
    let mut s = Series {
        tiles: c
            .tiles
            .iter()
            .map(|_| Unit {
                err: vec![],
                rays: vec![],
            })
            .collect(),
        pixel_terms: c.tiles.iter().map(|_| Vec::new()).collect(),
        uniform: Vec::new(),
    };
    for &n in &c.levels {
        scene.spp = n;
        let start = Instant::now();
        let (mut rays_sum, mut err_sum) = (0.0, 0.0);
        for (k, &t) in c.tiles.iter().enumerate() {
            let r = render::render_region(scene, c.accel, &settings, Region::Crop(t), &|| {})?;
            let e = terms(&r.pixels, c.reference, t);
            let (rays, err) = (r.counts.total() as f64, e.iter().sum::<f64>());
            s.tiles[k].err.push(err);
            s.tiles[k].rays.push(rays);
            s.pixel_terms[k].push(e);
            rays_sum += rays;
            err_sum += err;
        }
        // The tiles' pixels and rays are the whole frame's: check once.
        if n == c.min_spp {
            let whole = render::render(scene, c.accel, &settings, &|| {})?;
            let same = c.tiles.iter().enumerate().all(|(k, &t)| {
                terms(&crop(&whole.film, t), c.reference, t) == s.pixel_terms[k][c.first]
            });
            anyhow::ensure!(same, "the tiles' pixels differ from the frame's");
            anyhow::ensure!(
                whole.counts.total() as f64 == rays_sum,
                "the tiles' rays {rays_sum} differ from the frame's {}",
                whole.counts.total()
            );
        }
        eprintln!(
            "  seed {seed} {n:>5} spp: relMSE {:.4e} ({:.3}%), {:.4e} rays, {:.1} s",
            err_sum / denom,
            (err_sum / denom).sqrt() * 100.0,
            rays_sum,
            start.elapsed().as_secs_f64()
        );
        s.uniform.push((rays_sum, err_sum / denom));
    }
    Ok(s)
}

/// The oracle's curves (rays, relMSE) chosen on the mean errors of other seeds.
struct Others {
    /// Their mean uniform series.
    uniform: Vec<(f64, f64)>,
    /// Measured on that mean.
    tile_fitted: Vec<(f64, f64)>,
    pixel_fitted: Vec<(f64, f64)>,
    /// Measured on `--seed`'s render.
    tile_held_out: Vec<(f64, f64)>,
    pixel_held_out: Vec<(f64, f64)>,
}

/// What every series shares.
struct Context<'a> {
    accel: &'a Accel,
    reference: &'a Film,
    settings: RenderSettings,
    tiles: Vec<Rect>,
    levels: Vec<u32>,
    min_spp: u32,
    first: usize,
    pixels: usize,
}

impl Context<'_> {
    /// relMSE = the sum of the terms / (3 · pixels).
    fn denom(&self) -> f64 {
        3.0 * self.pixels as f64
    }
}

/// Per pixel of each tile (in tile order, each row by row), its share of its tile's rays:
/// its own rays at `spp` samples, one ray at a time.
fn pixel_shares(c: &Context, scene: &mut Scene, spp: u32) -> anyhow::Result<Vec<Vec<f64>>> {
    scene.spp = spp;
    let scalar = RenderSettings {
        packet_width: PacketWidth::Scalar,
        ..c.settings
    };
    let mut shares = Vec::new();
    for &t in &c.tiles {
        let mut own = Vec::new();
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                let window = Region::Crop(Rect::new(x, y, x + 1, y + 1));
                let r = render::render_region(scene, c.accel, &scalar, window, &|| {})?;
                own.push(r.counts.total() as f64);
            }
        }
        let total: f64 = own.iter().sum();
        let n = own.len() as f64;
        shares.push(
            own.iter()
                .map(|o| if total > 0.0 { o / total } else { 1.0 / n })
                .collect(),
        );
    }
    Ok(shares)
}

/// The pixels of a series as units: their terms, and their share of their tile's rays.
fn pixel_units(s: &Series, shares: &[Vec<f64>]) -> Vec<Unit> {
    let mut units = Vec::new();
    for (k, tile_shares) in shares.iter().enumerate() {
        for (i, share) in tile_shares.iter().enumerate() {
            units.push(Unit {
                err: s.pixel_terms[k].iter().map(|e| e[i]).collect(),
                rays: s.tiles[k].rays.iter().map(|r| r * share).collect(),
            });
        }
    }
    units
}

fn run(args: &Args) -> anyhow::Result<()> {
    let overrides = Overrides {
        width: Some(args.width),
        spp: None,
        max_depth: None,
    };
    let mut scene = Scene::load(&args.scene, overrides)?;
    let accel = Accel::build(&mut scene, AccelKind::Bvh);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let stem = Path::new(&args.scene)
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
    let ref_path = args.reference.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "target/reference/{stem}-w{}-4096spp.exr",
            args.width
        ))
    });
    let reference = raytracer::output::read_exr(&ref_path)?;
    anyhow::ensure!(
        (reference.width, reference.height) == (w, h),
        "the reference is {}x{}, the render {w}x{h}",
        reference.width,
        reference.height
    );
    let levels: Vec<u32> = std::iter::successors(Some(1u32), |n| Some(n * 2))
        .take_while(|&n| n <= args.max_spp)
        .collect();
    let c = Context {
        accel: &accel,
        reference: &reference,
        settings: RenderSettings {
            seed: args.seed,
            sampler: SamplerKind::Sobol,
            packet_width: PacketWidth::widest(),
            specialize: true,
        },
        tiles: (0..h.div_ceil(TILE))
            .flat_map(|ty| {
                (0..w.div_ceil(TILE)).map(move |tx| {
                    let (x0, y0) = (tx * TILE, ty * TILE);
                    Rect::new(x0, y0, (x0 + TILE).min(w), (y0 + TILE).min(h))
                })
            })
            .collect(),
        first: levels
            .iter()
            .position(|&n| n == args.min_spp)
            .context("--min-spp above --max-spp")?,
        levels,
        min_spp: args.min_spp,
        pixels: (w * h) as usize,
    };
    let denom = c.denom();
    eprintln!(
        "{}: {w}x{h}, {} tiles, reference {}",
        scene.name,
        c.tiles.len(),
        ref_path.display()
    );

    let a = series(&c, &mut scene, args.seed)?;
    let start = Instant::now();
    let shares = pixel_shares(&c, &mut scene, args.pixel_spp)?;
    eprintln!(
        "  pixel shares of rays at {} spp: {:.1} s",
        args.pixel_spp,
        start.elapsed().as_secs_f64()
    );
    let a_pixels = pixel_units(&a, &shares);
    let scale = |curve: Vec<(f64, f64)>| -> Vec<(f64, f64)> {
        curve.into_iter().map(|(r, e)| (r, e / denom)).collect()
    };
    // Fitted: chosen on the errors they are measured with.
    let tile_curve = scale(replay(&a.tiles, c.first, &oracle_steps(&a.tiles, c.first)));
    let pixel_curve = scale(replay(
        &a_pixels,
        c.first,
        &oracle_steps(&a_pixels, c.first),
    ));
    // On other seeds' mean errors: chosen and measured on that mean (fitted to less
    // noise), and chosen on it and measured on `--seed`'s render (held out).
    let others = if args.choose_seeds.is_empty() {
        None
    } else {
        let mut tiles: Vec<Unit> = Vec::new();
        let mut pixels: Vec<Unit> = Vec::new();
        let mut uniform = vec![(0.0, 0.0); c.levels.len()];
        let k = args.choose_seeds.len() as f64;
        for &seed in &args.choose_seeds {
            let b = series(&c, &mut scene, seed)?;
            for (u, bu) in uniform.iter_mut().zip(&b.uniform) {
                u.0 += bu.0 / k;
                u.1 += bu.1 / k;
            }
            let b_pixels = pixel_units(&b, &shares);
            for (sum, units) in [(&mut tiles, b.tiles), (&mut pixels, b_pixels)] {
                if sum.is_empty() {
                    *sum = units
                        .iter()
                        .map(|_| Unit {
                            err: vec![0.0; c.levels.len()],
                            rays: vec![0.0; c.levels.len()],
                        })
                        .collect();
                }
                for (s, u) in sum.iter_mut().zip(&units) {
                    for i in 0..c.levels.len() {
                        s.err[i] += u.err[i] / k;
                        s.rays[i] += u.rays[i] / k;
                    }
                }
            }
        }
        let (tile_steps, pixel_steps) = (
            oracle_steps(&tiles, c.first),
            oracle_steps(&pixels, c.first),
        );
        Some(Others {
            uniform,
            tile_fitted: scale(replay(&tiles, c.first, &tile_steps)),
            pixel_fitted: scale(replay(&pixels, c.first, &pixel_steps)),
            tile_held_out: scale(replay(&a.tiles, c.first, &tile_steps)),
            pixel_held_out: scale(replay(&a_pixels, c.first, &pixel_steps)),
        })
    };
    let uniform = &a.uniform;
    let rays_per_spp = uniform[c.first].0 / f64::from(args.min_spp);

    let ratio = |u: Option<f64>, o: Option<f64>| match (u, o) {
        (Some(u), Some(o)) => format!("{:.2}x", u / o),
        _ => "n/a".into(),
    };
    let spp = |c: Option<f64>| c.map_or("n/a".into(), |c| format!("{:.1}", c / rays_per_spp));
    println!(
        "{} {w}x{h}: uniform Sobol (seed {}) at 1 to {} spp against {}; the oracle's n from {} to {}",
        scene.name,
        args.seed,
        args.max_spp,
        ref_path.display(),
        args.min_spp,
        args.max_spp
    );
    println!(
        "uniform's rays for a target over the oracle's; spp: rays / rays of one sample a pixel"
    );
    println!(
        "fitted: the oracle chooses on seed {}'s errors and is measured on them",
        args.seed
    );
    if others.is_some() {
        println!(
            "mean: chooses on the mean errors of seeds {:?} and is measured on them (against their mean uniform series)",
            args.choose_seeds
        );
        println!(
            "held out: chooses on that mean and is measured on seed {}'s errors",
            args.seed
        );
    }
    let (head, rule) = if others.is_some() {
        (
            "| target | uniform spp | tile: oracle spp | tile: fitted | tile: mean | tile: held out | pixel: oracle spp | pixel: fitted | pixel: mean | pixel: held out |",
            "|---|---|---|---|---|---|---|---|---|---|",
        )
    } else {
        (
            "| target | uniform spp | tile: oracle spp | tile: fitted | pixel: oracle spp | pixel: fitted |",
            "|---|---|---|---|---|---|",
        )
    };
    println!("{head}\n{rule}");
    for &target in &args.targets {
        let t = (target / 100.0).powi(2);
        let u = uniform_cost(uniform, t);
        let ot = cost_at(&tile_curve, t);
        let op = cost_at(&pixel_curve, t);
        let (tile_more, pixel_more) = match &others {
            Some(o) => {
                let um = uniform_cost(&o.uniform, t);
                (
                    format!(
                        " {} | {} |",
                        ratio(um, cost_at(&o.tile_fitted, t)),
                        ratio(u, cost_at(&o.tile_held_out, t))
                    ),
                    format!(
                        " {} | {} |",
                        ratio(um, cost_at(&o.pixel_fitted, t)),
                        ratio(u, cost_at(&o.pixel_held_out, t))
                    ),
                )
            }
            None => (String::new(), String::new()),
        };
        println!(
            "| {target}% | {} | {} | {} |{tile_more} {} | {} |{pixel_more}",
            spp(u),
            spp(ot),
            ratio(u, ot),
            spp(op),
            ratio(u, op),
        );
    }

    if args.adaptive {
        println!(
            "adaptive Sobol (budget {}) against uniform and the oracles at the error it reaches:",
            args.max_spp
        );
        println!(
            "| target | true rel. RMSE | spp | uniform / adaptive | uniform / tile oracle: fitted | held out | uniform / pixel oracle: fitted | held out |"
        );
        println!("|---|---|---|---|---|---|---|---|");
        for &target in &args.targets {
            let ad = Adaptive::new(Some((target / 100.0) as f32), args.max_spp, None)?;
            let r = render::render_adaptive(&scene, &accel, &c.settings, &ad, &|| {}, &mut |_| {
                std::ops::ControlFlow::Continue(())
            })?;
            let outcome = r.adaptive.context("an adaptive render has an outcome")?;
            let err = terms(&r.film.pixels, &reference, Rect::new(0, 0, w, h))
                .iter()
                .sum::<f64>()
                / denom;
            let rays = r.counts.total() as f64;
            // The same image from the tables: each tile at the samples it took.
            let (mut t_err, mut t_rays) = (0.0, 0.0);
            for (k, t) in c.tiles.iter().enumerate() {
                let n = outcome.spp[(t.y0 * w + t.x0) as usize];
                let i = c
                    .levels
                    .iter()
                    .position(|&l| l == n)
                    .context("a power of two")?;
                t_err += a.tiles[k].err[i];
                t_rays += a.tiles[k].rays[i];
            }
            let same = (t_err / denom - err).abs() <= 1e-9 * err && t_rays == rays;
            let u = uniform_cost(uniform, err);
            let held = |f: fn(&Others) -> &Vec<(f64, f64)>| {
                ratio(u, others.as_ref().and_then(|o| cost_at(f(o), err)))
            };
            println!(
                "| {target}% | {:.3}% | {} | {} | {} | {} | {} | {} |{}",
                err.sqrt() * 100.0,
                spp(Some(rays)),
                ratio(u, Some(rays)),
                ratio(u, cost_at(&tile_curve, err)),
                held(|o| &o.tile_held_out),
                ratio(u, cost_at(&pixel_curve, err)),
                held(|o| &o.pixel_held_out),
                if same { "" } else { " differs from the tables" }
            );
            if !same {
                eprintln!(
                    "    adaptive relMSE {err:.6e}, rays {rays}; tables {:.6e}, {t_rays}",
                    t_err / denom
                );
            }
        }
    }
    Ok(())
}

/// The pixels of `rect` of a film, row by row.
fn crop(film: &Film, rect: Rect) -> Vec<raytracer::Vec3> {
    let mut out = Vec::new();
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            out.push(film.pixels[(y * film.width + x) as usize]);
        }
    }
    out
}
