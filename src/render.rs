//! Rendering a compiled scene: the whole frame into a film, or a region of it (a part of
//! a farmed frame, or a crop window) into its own pixels. Tiles run in parallel (rayon)
//! and write straight into the output; every pixel is the mean of its samples summed in
//! sample order, so the image is the same for any thread count, tile order or region.

use crate::accel::Accel;
use crate::adaptive::{self, Adaptive, Outcome, PassProgress, Stop, TileSums, FIRST_PASS_SPP};
use crate::error::{Error, Result};
use crate::farm::region::{Rect, Region, TILE};
pub use crate::film::Film;
use crate::integrator::{footprint, PacketPixels, RayCounts, Regrouping, Tracer};
use crate::lanes::{set_lanes, F32x16, Lane, V3};
use crate::sampling::Sampler;
use crate::scene::Scene;
pub use crate::settings::{PacketWidth, RenderSettings};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::ops::ControlFlow;
use wide::f32x8;

/// A film and the rays traced to make it.
#[derive(Debug)]
pub struct Rendered {
    /// The image.
    pub film: Film,
    /// Rays by kind and the traversal work they took.
    pub counts: RayCounts,
    /// What an adaptive render did: passes, the estimated error, the samples each pixel
    /// took (`None` for a render of `spp` samples a pixel).
    pub adaptive: Option<Outcome>,
}

/// The pixels of a region of the frame: its rectangles' pixels one after another, each
/// row by row (`Region::rects`).
#[derive(Debug)]
pub struct RenderedRegion {
    /// The region.
    pub region: Region,
    /// Its rectangles, in the order of `pixels`.
    pub rects: Vec<Rect>,
    /// Linear RGB.
    pub pixels: Vec<Vec3>,
    /// Rays by kind and the traversal work they took.
    pub counts: RayCounts,
    /// What an adaptive render did (`None` for a render of `spp` samples a pixel).
    pub adaptive: Option<Outcome>,
}

/// The number of work tiles (and `on_tile` calls) of a render of `rects`.
pub fn tile_count(rects: &[Rect]) -> u64 {
    rects
        .iter()
        .map(|r| r.width().div_ceil(TILE) as u64 * r.height().div_ceil(TILE) as u64)
        .sum()
}

/// Render the whole frame on the current rayon pool. `on_tile` is called after each
/// tile (progress).
pub fn render(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    on_tile: &(dyn Fn() + Sync),
) -> Result<Rendered> {
    let (width, height) = (scene.camera.width, scene.camera.height);
    let mut film = Film::new(width, height)?;
    let rects = [Rect::new(0, 0, width, height)];
    let counts = render_rects(scene, accel, settings, &rects, &mut film.pixels, on_tile);
    Ok(Rendered {
        film,
        counts,
        adaptive: None,
    })
}

/// Render the whole frame adaptively (`adaptive`) on the current rayon pool: `on_tile`
/// after each tile of each pass, `on_pass` after each pass (which may end the render).
pub fn render_adaptive(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    adaptive: &Adaptive,
    on_tile: &(dyn Fn() + Sync),
    on_pass: &mut dyn FnMut(&PassProgress) -> ControlFlow<()>,
) -> Result<Rendered> {
    let (width, height) = (scene.camera.width, scene.camera.height);
    let mut film = Film::new(width, height)?;
    let rects = [Rect::new(0, 0, width, height)];
    let (counts, outcome) = render_rects_adaptive(
        scene,
        accel,
        settings,
        &rects,
        &mut film.pixels,
        on_tile,
        (adaptive, on_pass),
    );
    Ok(Rendered {
        film,
        counts,
        adaptive: Some(outcome),
    })
}

/// Render a region of the frame on the current rayon pool: only its pixels are
/// allocated and computed, and they have the bits of the same pixels of the whole frame.
pub fn render_region(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    region: Region,
    on_tile: &(dyn Fn() + Sync),
) -> Result<RenderedRegion> {
    render_region_sampled(scene, accel, settings, region, Sampling::Uniform, on_tile)
}

/// [`render_region`], uniform or adaptive (`mode`).
pub fn render_region_sampled(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    region: Region,
    mode: Sampling,
    on_tile: &(dyn Fn() + Sync),
) -> Result<RenderedRegion> {
    let (width, height) = (scene.camera.width, scene.camera.height);
    let rects = region.rects(width, height)?;
    let n: u64 = rects.iter().map(Rect::pixel_count).sum();
    let mut pixels = crate::film::zeroed_pixels(n as usize).map_err(|_| Error::ImageTooLarge {
        width,
        height,
        bytes: n as u128 * std::mem::size_of::<Vec3>() as u128,
    })?;
    let (counts, adaptive) = match mode {
        Sampling::Uniform => (
            render_rects(scene, accel, settings, &rects, &mut pixels, on_tile),
            None,
        ),
        Sampling::Adaptive(adaptive, on_pass) => {
            let (counts, outcome) = render_rects_adaptive(
                scene,
                accel,
                settings,
                &rects,
                &mut pixels,
                on_tile,
                (adaptive, on_pass),
            );
            (counts, Some(outcome))
        }
    };
    Ok(RenderedRegion {
        region,
        rects,
        pixels,
        counts,
        adaptive,
    })
}

/// How a region is sampled: `spp` samples every pixel, or adaptively (with the callback
/// after each pass).
pub enum Sampling<'a> {
    /// The scene's `spp` samples a pixel.
    Uniform,
    /// [`Adaptive`] passes.
    Adaptive(
        &'a Adaptive,
        &'a mut dyn FnMut(&PassProgress) -> ControlFlow<()>,
    ),
}

/// Render `rects` into `out`, which holds their pixels one rectangle after another, each
/// row by row. Each rectangle is cut into bands of `TILE` rows and each band into tiles;
/// a tile writes into its own rows of `out`, so no pixel is copied after the render.
fn render_rects(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    rects: &[Rect],
    out: &mut [Vec3],
    on_tile: &(dyn Fn() + Sync),
) -> RayCounts {
    let sampler = Sampler::new(settings.sampler, settings.seed, scene.spp);
    let mut tracer = Tracer::with_sampler(scene, accel, sampler);
    tracer.specialize = settings.specialize;
    let tracer = &tracer;
    let packet_width = settings.packet_width;

    // One work item a band of `TILE` rows of a rectangle.
    let mut bands = Vec::new();
    let mut rest = out;
    for rect in rects {
        let (pixels, next) = rest.split_at_mut(rect.pixel_count() as usize);
        rest = next;
        let row = rect.width() as usize;
        for (band, rows) in pixels.chunks_mut(row * TILE as usize).enumerate() {
            bands.push((*rect, rect.y0 + band as u32 * TILE, rows));
        }
    }
    bands
        .into_par_iter()
        .map(|(rect, y0, rows)| {
            let y1 = (y0 + TILE).min(rect.y1);
            let row = rect.width() as usize;
            // The band's tiles, each as its rows' slices.
            let mut tiles: Vec<Vec<&mut [Vec3]>> = (0..rect.width().div_ceil(TILE))
                .map(|_| Vec::with_capacity((y1 - y0) as usize))
                .collect();
            for line in rows.chunks_mut(row) {
                for (tile, piece) in tiles.iter_mut().zip(line.chunks_mut(TILE as usize)) {
                    tile.push(piece);
                }
            }
            tiles
                .into_par_iter()
                .enumerate()
                .map(|(k, mut tile_rows)| {
                    let x0 = rect.x0 + k as u32 * TILE;
                    let tile = Rect::new(x0, y0, (x0 + TILE).min(rect.x1), y1);
                    let counts = render_tile(tracer, packet_width, tile, &mut tile_rows);
                    on_tile();
                    counts
                })
                .reduce(RayCounts::default, sum_counts)
        })
        .reduce(RayCounts::default, sum_counts)
}

/// Render `rects` (their pixels one rectangle after another into `out`, as
/// `render::render_rects`) adaptively. Each tile of the frame's lattice that meets a
/// rectangle is rendered whole, so a crop's pixels are those of the frame. `on_tile` is
/// called after each tile of each pass, `on_pass` after each pass; it may end the
/// render (then the outcome's stop is `Stop::Passes`).
/// What an adaptive render calls after each pass: `Break` ends the render there.
pub type OnPass<'a> = dyn FnMut(&PassProgress) -> ControlFlow<()> + 'a;

/// Rows of a band, the work item of an adaptive pass after the first: a multiple of the
/// packets' footprints (2 rows), a quarter of a tile.
const BAND: u32 = 4;

/// A pass of fewer tiles than this goes in bands of `BAND` rows; the count depends on
/// the tiles' estimates alone, so the ray counts do not depend on the thread count.
const FEW_TILES: usize = 32;

fn render_rects_adaptive(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    rects: &[Rect],
    out: &mut [Vec3],
    on_tile: &(dyn Fn() + Sync),
    (adaptive, on_pass): (&Adaptive, &mut OnPass),
) -> (RayCounts, Outcome) {
    // The stratified sampler spreads a pixel's draws over its sample count: the budget.
    let sampler = Sampler::new(settings.sampler, settings.seed, adaptive.max_spp);
    let mut tracer = Tracer::with_sampler(scene, accel, sampler);
    tracer.specialize = settings.specialize;
    let tracer = &tracer;
    let (width, height) = (scene.camera.width, scene.camera.height);

    // The lattice's tiles that meet the rectangles, each once, with its pixels' places.
    let mut index = std::collections::BTreeMap::new();
    let mut pieces = Vec::new(); // (state, rectangle, offset of the rectangle in `out`)
    let mut offset = 0usize;
    for rect in rects {
        for ty in rect.y0 / TILE..rect.y1.div_ceil(TILE) {
            for tx in rect.x0 / TILE..rect.x1.div_ceil(TILE) {
                let next = index.len();
                let i = *index.entry((ty, tx)).or_insert(next);
                pieces.push((i, *rect, offset));
            }
        }
        offset += rect.pixel_count() as usize;
    }
    let mut tiles: Vec<TileSums> = Vec::with_capacity(index.len());
    let mut order: Vec<_> = index.iter().map(|(&k, &i)| (i, k)).collect();
    order.sort_unstable();
    for (_, (ty, tx)) in order {
        let (x0, y0) = (tx * TILE, ty * TILE);
        tiles.push(TileSums::new(
            Rect::new(x0, y0, (x0 + TILE).min(width), (y0 + TILE).min(height)),
            0,
        ));
    }
    for &(i, rect, _) in &pieces {
        tiles[i].weight += adaptive::intersect(tiles[i].tile, rect).pixel_count();
    }

    // Where each tile keeps the sums of its pixels: a tile that lies whole in one
    // rectangle in its own rows of `out`, where its means go, so that no sum is copied
    // and no memory but the output's is touched; a tile that the region's edge cuts (a
    // crop's) in `side`, whose means are copied out at the end.
    let mut home = vec![true; tiles.len()];
    let mut seen = vec![false; tiles.len()];
    for &(i, rect, _) in &pieces {
        home[i] &= !seen[i] && adaptive::intersect(tiles[i].tile, rect) == tiles[i].tile;
        seen[i] = true;
    }
    let mut slot = vec![usize::MAX; tiles.len()];
    let mut sides = 0;
    for (i, _) in home.iter().enumerate().filter(|(_, &h)| !h) {
        slot[i] = sides;
        sides += 1;
    }
    let mut side = vec![Vec3::ZERO; sides * (TILE * TILE) as usize];
    // Every tile's rows, tile after tile: tile i's from `first[i]`.
    let mut first = Vec::with_capacity(tiles.len() + 1);
    first.push(0);
    for t in &tiles {
        first.push(first.last().unwrap() + t.tile.height() as usize);
    }
    let mut flat: Vec<&mut [Vec3]> = (0..first[tiles.len()])
        .map(|_| <&mut [Vec3]>::default())
        .collect();
    let mut rest = &mut *out;
    let mut piece = 0;
    for rect in rects {
        let (pixels, next) = rest.split_at_mut(rect.pixel_count() as usize);
        rest = next;
        // The rectangle's tiles are its pieces, row by row of the lattice.
        let (tx0, ty0) = (rect.x0 / TILE, rect.y0 / TILE);
        let columns = (rect.x1.div_ceil(TILE) - tx0) as usize;
        for (y, mut line) in (rect.y0..).zip(pixels.chunks_mut(rect.width() as usize)) {
            let lattice_row = piece + (y / TILE - ty0) as usize * columns;
            let mut x = rect.x0;
            while !line.is_empty() {
                let end = ((x / TILE + 1) * TILE).min(rect.x1);
                let (segment, after) = std::mem::take(&mut line).split_at_mut((end - x) as usize);
                line = after;
                let i = pieces[lattice_row + (x / TILE - tx0) as usize].0;
                if home[i] {
                    flat[first[i] + (y - tiles[i].tile.y0) as usize] = segment;
                }
                x = end;
            }
        }
        piece += columns * (rect.y1.div_ceil(TILE) - ty0) as usize;
    }
    for (chunk, (i, _)) in side
        .chunks_mut((TILE * TILE) as usize)
        .zip(home.iter().enumerate().filter(|(_, &h)| !h))
    {
        let t = tiles[i].tile;
        for (row, line) in flat[first[i]..first[i + 1]]
            .iter_mut()
            .zip(chunk.chunks_mut(t.width() as usize))
        {
            *row = line;
        }
    }
    let mut tile_rows: Vec<&mut [&mut [Vec3]]> = Vec::with_capacity(tiles.len());
    let mut rest = flat.as_mut_slice();
    for t in &tiles {
        let (rows, next) = rest.split_at_mut(t.tile.height() as usize);
        tile_rows.push(rows);
        rest = next;
    }

    let kind = settings.sampler;
    let max = adaptive.max_spp;
    let target = adaptive.target_rel_mse();
    // A tile that pass 0 leaves final (at the target or the budget, or the last pass)
    // has its means written at once, while its rows are in the cache.
    let last = adaptive.passes.is_some_and(|p| p <= 1);
    let mut means = vec![false; tiles.len()];
    // Pass 0: every tile to FIRST_PASS_SPP in one sweep over its pixels, with the terms
    // of its estimates at 2 and 4 samples taken on the way. The terms' buffer is a
    // worker's, not a tile's: the sweep overwrites it whole.
    let buffers = || vec![0.0f32; 2 * (TILE * TILE) as usize];
    tiles
        .par_iter_mut()
        .zip(tile_rows.par_iter_mut())
        .zip(means.par_iter_mut().zip(home.par_iter()))
        .for_each_init(buffers, |terms, ((t, rows), (mean, &home))| {
            let pw = settings.packet_width;
            let counts = first_pass_tile(tracer, pw, t.tile, rows, terms);
            let len = t.tile.pixel_count() as usize;
            let (at2, at4) = terms.split_at(TERMS_AT4);
            t.first_pass(&at2[..len], &at4[..len], &counts, kind);
            if home && (last || t.n >= max || t.estimate <= target) {
                divide_rows(rows, t.n);
                *mean = true;
            }
            on_tile();
        });
    let pixels: u64 = tiles.iter().map(|t| t.tile.pixel_count()).sum();
    let mut samples = pixels * FIRST_PASS_SPP as u64;
    let mut pass = 0;
    let stop = loop {
        let open = |t: &TileSums| t.n < max && t.estimate > target;
        let done = !tiles.iter().any(open);
        let threshold = adaptive.threshold(pass + 1);
        let takes = |t: &TileSums| t.n < max && t.estimate > threshold;
        let next_samples = tiles
            .iter()
            .filter(|t| takes(t))
            .map(|t| t.tile.pixel_count() * ((2 * t.n).min(max) - t.n) as u64)
            .sum();
        let next_tiles = tiles.iter().filter(|t| takes(t)).count();
        let progress = PassProgress {
            pass,
            estimate: adaptive::estimate(&tiles),
            spp_mean: adaptive::spp_mean(&tiles),
            samples,
            next_samples,
            next_tiles,
            done,
        };
        let asked = on_pass(&progress);
        if done {
            let above = tiles
                .iter()
                .filter(|t| t.estimate > target || target == 0.0)
                .count();
            break if above == 0 {
                Stop::Target
            } else {
                Stop::MaxSpp { above }
            };
        }
        if asked.is_break() || adaptive.passes.is_some_and(|p| pass + 1 >= p) {
            break Stop::Passes;
        }
        pass += 1;
        // A late pass has few tiles: then each tile's rows go in bands of `BAND` rows,
        // one work item a band, so that threads do not wait for the few (a band's
        // pixels are its own, and each pixel's samples are added in the same order). A
        // pass of many tiles keeps them whole: a band sets up its own camera cone and
        // packets.
        let mut pass_tiles: Vec<_> = tiles
            .iter_mut()
            .zip(tile_rows.iter_mut())
            .filter(|(t, _)| takes(t))
            .collect();
        let band = if pass_tiles.len() < FEW_TILES {
            BAND
        } else {
            TILE
        };
        pass_tiles.par_iter_mut().for_each(|(t, rows)| {
            let n = (2 * t.n).min(max);
            t.start_step(rows);
            let (tile, from) = (t.tile, t.n);
            let counts = rows
                .par_chunks_mut(band as usize)
                .enumerate()
                .map(|(k, rows)| {
                    let y0 = tile.y0 + k as u32 * band;
                    let part = Rect::new(tile.x0, y0, tile.x1, (y0 + band).min(tile.y1));
                    let mut sums = TileOut::Sums { rows };
                    tile_sums(tracer, settings.packet_width, part, from..n, &mut sums)
                })
                .reduce(RayCounts::default, sum_counts);
            t.end_step(n, rows, &counts, kind);
            on_tile();
        });
        samples = next_samples;
    };

    // The pixels: the means of the tiles in `out` in place, those of `side` copied to
    // the rectangles' places.
    for (i, (t, rows)) in tiles.iter().zip(tile_rows.iter_mut()).enumerate() {
        if home[i] && !means[i] {
            divide_rows(rows, t.n);
        }
    }
    drop(tile_rows);
    drop(flat);
    let mut spp = vec![0u32; out.len()];
    for &(i, rect, offset) in &pieces {
        let t = &tiles[i];
        let part = adaptive::intersect(t.tile, rect);
        let len = part.width() as usize;
        for y in part.y0..part.y1 {
            let at = offset + ((y - rect.y0) * rect.width() + (part.x0 - rect.x0)) as usize;
            spp[at..at + len].fill(t.n);
            if home[i] {
                continue;
            }
            let from = slot[i] * (TILE * TILE) as usize
                + ((y - t.tile.y0) * t.tile.width() + (part.x0 - t.tile.x0)) as usize;
            let n = t.n as f32;
            for (pixel, sum) in out[at..at + len].iter_mut().zip(&side[from..from + len]) {
                *pixel = *sum / n;
            }
        }
    }
    let mut counts = RayCounts::default();
    for t in &tiles {
        counts.add(&t.counts);
    }
    // The samples a pixel from the tiles' (a tile's pixels in the region: its weight).
    let region = tiles.iter().filter(|t| t.weight > 0);
    let total: u64 = region.clone().map(|t| t.n as u64 * t.weight).sum();
    (
        counts,
        Outcome {
            passes: pass + 1,
            stop,
            estimate: adaptive::estimate(&tiles),
            spp_min: region.clone().map(|t| t.n).min().unwrap_or(0),
            spp_max: region.map(|t| t.n).max().unwrap_or(0),
            spp_mean: total as f64 / spp.len().max(1) as f64,
            spp,
        },
    )
}

/// Each pixel of `rows` divided by `n`, channel by channel: the sums of `n` samples
/// become their means, with the bits of `TileOut::Means`'s division in lanes.
fn divide_rows(rows: &mut [&mut [Vec3]], n: u32) {
    let n = n as f32;
    for row in rows.iter_mut() {
        for c in bytemuck::cast_slice_mut::<Vec3, f32>(row) {
            *c /= n;
        }
    }
}

fn sum_counts(mut a: RayCounts, b: RayCounts) -> RayCounts {
    a.add(&b);
    a
}

/// Render the pixels of `tile` into `rows` (`rows[y - y0][x - x0]`): each pixel the mean
/// of its `spp` samples, summed in lanes from zero and written once.
fn render_tile(
    tracer: &Tracer,
    packet_width: PacketWidth,
    tile: Rect,
    rows: &mut [&mut [Vec3]],
) -> RayCounts {
    let spp = tracer.scene.spp;
    let mut means = TileOut::Means {
        rows,
        spp: spp as f32,
    };
    tile_sums(tracer, packet_width, tile, 0..spp, &mut means)
}

/// Add the samples `samples` of each pixel of `tile` (at most `TILE` x `TILE`), in
/// sample order, to its sum in `sums` (row by row, `tile.width()` a row). Summing the
/// samples `0..n` in one call or in consecutive ranges gives the same bits.
pub(crate) fn accumulate_tile(
    tracer: &Tracer,
    packet_width: PacketWidth,
    tile: Rect,
    samples: std::ops::Range<u32>,
    sums: &mut [Vec3],
) -> RayCounts {
    let mut lines = sums.chunks_mut(tile.width() as usize);
    let mut rows: [&mut [Vec3]; TILE as usize] =
        std::array::from_fn(|_| lines.next().unwrap_or_default());
    let mut out = TileOut::Sums {
        rows: &mut rows[..tile.height() as usize],
    };
    tile_sums(tracer, packet_width, tile, samples, &mut out)
}

/// Where pass 0's terms at 4 samples start in its terms' buffer (those at 2 at 0).
const TERMS_AT4: usize = (TILE * TILE) as usize;

/// Adaptive pass 0 of `tile`: samples `0..FIRST_PASS_SPP` of each pixel, from zero,
/// their sums into `rows` (`rows[dy][dx]`), and on the way each pixel's
/// `adaptive::pixel_term` at 2 samples against 1 into `terms[dy * w + dx]` and at 4
/// against 2 into `terms[TERMS_AT4 + dy * w + dx]` (`w` the tile's width, `terms` at
/// least `2 * TERMS_AT4` long). One sweep over the tile where separate calls would set
/// up each packet and the tile's camera cone again (pass 0 as three calls: 8.3M
/// instructions more than one on `quads` at 256 px, 12% of its render at 4 samples).
pub(crate) fn first_pass_tile(
    tracer: &Tracer,
    packet_width: PacketWidth,
    tile: Rect,
    rows: &mut [&mut [Vec3]],
    terms: &mut [f32],
) -> RayCounts {
    let stride = tile.width() as usize;
    let mut out = TileOut::First {
        rows,
        terms,
        stride,
    };
    tile_sums(tracer, packet_width, tile, 0..FIRST_PASS_SPP, &mut out)
}

/// Where the sums of a tile's pixels start and where they go, pixel (dx, dy) counted
/// from the tile's corner at `rows[dy][dx]`: a render of `spp` samples starts them at
/// zero and writes the means (no tile buffer to zero, read into lanes and write back);
/// a later adaptive pass adds to the sums kept there; pass 0 starts at zero, keeps the
/// sums and takes the terms of its estimates on the way. One type for all, so that the
/// tile's loop is compiled once a width (an instantiation each, the compiler no longer
/// inlined the camera packet's trace into them: `quads` 4.8% more render instructions
/// 8 wide, 6% scalar).
enum TileOut<'a, 'b> {
    /// Each pixel the mean of its `spp` samples.
    Means {
        rows: &'a mut [&'b mut [Vec3]],
        spp: f32,
    },
    /// Sums kept from call to call.
    Sums { rows: &'a mut [&'b mut [Vec3]] },
    /// Adaptive pass 0 (samples `0..FIRST_PASS_SPP`): the sums, and the terms at 2 and
    /// 4 samples into `terms` (`stride` a row; see `first_pass_tile`).
    First {
        rows: &'a mut [&'b mut [Vec3]],
        terms: &'a mut [f32],
        stride: usize,
    },
}

impl TileOut<'_, '_> {
    /// Whether `note` does anything.
    #[inline(always)]
    fn marked(&self) -> bool {
        matches!(self, TileOut::First { .. })
    }

    /// The sums a packet's lanes start from (`active` lanes, lane k pixel `at(k)`).
    #[inline(always)]
    fn start<L: Lane>(&self, active: u32, at: impl Fn(usize) -> (u32, u32)) -> V3<L> {
        match self {
            TileOut::Means { .. } | TileOut::First { .. } => V3::splat(Vec3::ZERO),
            TileOut::Sums { rows } => V3::from_fn(|k| {
                if active >> k & 1 != 0 {
                    let (dx, dy) = at(k);
                    rows[dy as usize][dx as usize]
                } else {
                    Vec3::ZERO
                }
            }),
        }
    }

    /// After sample `s` of a packet's pixels (`active` lanes of `sum`, lane k pixel
    /// `at(k)`): pass 0 keeps the sums at 1 and 2 samples (`halves`) and writes the
    /// terms at 2 and 4.
    #[inline(always)]
    fn note<L: Lane>(
        &mut self,
        s: u32,
        sum: V3<L>,
        halves: &mut [V3<L>; 2],
        active: u32,
        at: impl Fn(usize) -> (u32, u32),
    ) {
        if let TileOut::First { terms, stride, .. } = self {
            let (q, from) = match s {
                0 => {
                    halves[0] = sum;
                    return;
                }
                1 => {
                    let q = adaptive::pixel_term(sum, halves[0], 2, 1);
                    halves[1] = sum;
                    (q, 0)
                }
                3 => (adaptive::pixel_term(sum, halves[1], 4, 2), TERMS_AT4),
                _ => return,
            };
            let stride = *stride;
            if let Some((dx, dy)) = full_packet::<L>(active, &at) {
                let fw = footprint(L::WIDTH).0 as usize;
                for (r, k) in (0..L::WIDTH).step_by(fw).enumerate() {
                    let start = from + (dy as usize + r) * stride + dx as usize;
                    for (c, term) in terms[start..start + fw].iter_mut().enumerate() {
                        *term = q.lane(k + c);
                    }
                }
            } else {
                for k in set_lanes(active) {
                    let (dx, dy) = at(k);
                    terms[from + dy as usize * stride + dx as usize] = q.lane(k);
                }
            }
        }
    }

    /// A packet's sums after the samples (`active` lanes, lane k pixel `at(k)`).
    #[inline(always)]
    fn finish<L: Lane>(&mut self, sum: V3<L>, active: u32, at: impl Fn(usize) -> (u32, u32)) {
        match self {
            TileOut::Means { rows, spp } => {
                let n = L::splat(*spp);
                let mean = V3::new(sum.x / n, sum.y / n, sum.z / n);
                for k in 0..L::WIDTH {
                    if active >> k & 1 != 0 {
                        let (dx, dy) = at(k);
                        rows[dy as usize][dx as usize] = mean.lane(k);
                    }
                }
            }
            TileOut::Sums { rows } | TileOut::First { rows, .. } => {
                if let Some((dx, dy)) = full_packet::<L>(active, &at) {
                    let fw = footprint(L::WIDTH).0 as usize;
                    for (r, k) in (0..L::WIDTH).step_by(fw).enumerate() {
                        let row = &mut rows[dy as usize + r][dx as usize..dx as usize + fw];
                        for (c, pixel) in row.iter_mut().enumerate() {
                            *pixel = sum.lane(k + c);
                        }
                    }
                } else {
                    for k in set_lanes(active) {
                        let (dx, dy) = at(k);
                        rows[dy as usize][dx as usize] = sum.lane(k);
                    }
                }
            }
        }
    }
}

/// Where a full packet's first lane goes (`at(0)`), `None` for a packet with inactive
/// lanes. A full packet's lanes are its footprint's rows, `fw` pixels each, one after
/// another: each row written as one slice of the tile's row, with the lanes' offsets
/// known when the code is compiled (on `quads` at 256 px adaptive pass 0 takes 1.0M
/// instructions fewer so than testing and placing each lane).
#[inline(always)]
fn full_packet<L: Lane>(active: u32, at: &impl Fn(usize) -> (u32, u32)) -> Option<(u32, u32)> {
    (active == u32::MAX >> (32 - L::WIDTH)).then(|| at(0))
}

/// Add the samples `samples` of each pixel of `tile`, in sample order, to the sums `out`
/// starts them from, and hand `out` the sums.
fn tile_sums(
    tracer: &Tracer,
    packet_width: PacketWidth,
    tile: Rect,
    samples: std::ops::Range<u32>,
    out: &mut TileOut,
) -> RayCounts {
    match packet_width {
        PacketWidth::Sixteen if tracer.regroups::<F32x16>() => {
            accumulate_tile_regrouped::<F32x16>(tracer, tile, samples, out)
        }
        PacketWidth::Eight if tracer.regroups::<f32x8>() => {
            accumulate_tile_regrouped::<f32x8>(tracer, tile, samples, out)
        }
        PacketWidth::Four if tracer.regroups::<Vec4>() => {
            accumulate_tile_regrouped::<Vec4>(tracer, tile, samples, out)
        }
        PacketWidth::Sixteen => accumulate_tile_packets::<F32x16>(tracer, tile, samples, out),
        PacketWidth::Eight => accumulate_tile_packets::<f32x8>(tracer, tile, samples, out),
        PacketWidth::Four => accumulate_tile_packets::<Vec4>(tracer, tile, samples, out),
        PacketWidth::Scalar => accumulate_tile_scalar(tracer, tile, samples, out),
    }
}

/// A tile one ray at a time (the scalar reference): `sample_pixels` at `f32`, with the
/// tile's camera cone, so a tile whose cone meets nothing makes no ray, as the packets'
/// tiles do.
#[inline(never)]
fn accumulate_tile_scalar(
    tracer: &Tracer,
    tile: Rect,
    samples: std::ops::Range<u32>,
    out: &mut TileOut,
) -> RayCounts {
    let mut counts = RayCounts::default();
    let cull = tracer.camera_cull(tile.x0, tile.y0, tile.x1, tile.y1);
    for y in tile.y0..tile.y1 {
        for x in tile.x0..tile.x1 {
            let hashes = tracer.pixel_hashes::<f32>(x, y);
            let at = |_| (x - tile.x0, y - tile.y0);
            let mut sum = out.start::<f32>(1, at);
            let mut halves = [V3::<f32>::new(0.0, 0.0, 0.0); 2];
            for s in samples.clone() {
                sum = sum + tracer.sample_pixels::<f32>(x, y, &hashes, 1, s, cull, &mut counts);
                out.note(s, sum, &mut halves, 1, at);
            }
            out.finish(sum, 1, at);
        }
    }
    counts
}

/// A tile in packets of `L::WIDTH` pixels (4x4, 4x2 or 2x2); lanes past the tile's edge are
/// inactive. Each pixel sums its samples in sample order, as the scalar tile does.
fn accumulate_tile_packets<L: Lane>(
    tracer: &Tracer,
    tile: Rect,
    samples: std::ops::Range<u32>,
    out: &mut TileOut,
) -> RayCounts {
    let Rect { x0, y0, x1, y1 } = tile;
    let (fw, fh) = footprint(L::WIDTH);
    let taken = samples.len() as u64;
    let mut counts = RayCounts::default();
    // What the tile's camera rays may hit (the packets' footprints may reach past the
    // tile's edge: those lanes are inactive and never reported).
    let mut cull = tracer.camera_cull(x0, y0, x1, y1);
    let (cone_prims, cone_tree) = cull.skipped(tracer.accel);
    // The first packet whose frustum meets leaves decides for the tile's others.
    let mut frustum_decided = false;
    for py in (y0..y1).step_by(fh as usize) {
        for px in (x0..x1).step_by(fw as usize) {
            let seen = (
                counts.traversal.frustum_leaves,
                counts.traversal.frustum_leaf_lanes,
            );
            let mut active = 0u32;
            for k in 0..L::WIDTH as u32 {
                let (x, y) = (px + k % fw, py + k / fw);
                if x < x1 && y < y1 {
                    active |= 1 << k;
                }
            }
            let at = |k: usize| (px - x0 + k as u32 % fw, py - y0 + k as u32 / fw);
            let mut lanes = out.start::<L>(active, at);
            let mut halves = [V3::<L>::splat(Vec3::ZERO); 2];
            for s in samples.clone() {
                lanes = lanes + tracer.sample_packet::<L>(px, py, active, s, cull, &mut counts);
                out.note(s, lanes, &mut halves, active, at);
            }
            if !frustum_decided {
                let t = &counts.traversal;
                let leaves = t.frustum_leaves - seen.0;
                if leaves > 0 {
                    let entered = t.frustum_leaf_lanes - seen.1;
                    cull.frustum = frustum_pays(leaves, entered, active);
                    frustum_decided = true;
                }
            }
            counts.cone_prims += cone_prims * active.count_ones() as u64 * taken;
            counts.cone_trees += cone_tree as u64 * taken;
            out.finish(lanes, active, at);
        }
    }
    counts
}

/// Whether a tile's camera packets keep the frustum traversal, from one packet's: the
/// leaves its frustum met and the lanes that entered them. Where triangles are smaller
/// than a pixel a leaf holds one lane's hit at most, and the lane-wise traversal visits
/// only the nodes some lane enters (camera packets of the 1.27M-triangle bunny from
/// afar: 64.6M instructions by the frustum, 30.7M lane-wise; close up 164.9M and
/// 193.1M). At 400 px the frustum's leaves held a median 0.8% of the lanes from afar,
/// 9% close up, 30% on `bunny` and 74% on `bunny-closeup`: below 1/32, lane-wise.
fn frustum_pays(leaves: u64, entered: u64, active: u32) -> bool {
    entered * 32 >= leaves * active.count_ones() as u64
}

/// `accumulate_tile_packets` for a scene whose surfaces are all path-traced: the
/// tile's packets traced together, one sample index at a time, their paths regrouped
/// after each vertex (`Tracer::sample_tile`). Each pixel sums its samples in sample
/// order.
fn accumulate_tile_regrouped<L: Lane>(
    tracer: &Tracer,
    tile: Rect,
    samples: std::ops::Range<u32>,
    out: &mut TileOut,
) -> RayCounts {
    let Rect { x0, y0, x1, y1 } = tile;
    let mut counts = RayCounts::default();
    let cull = tracer.camera_cull(x0, y0, x1, y1);
    let (fw, fh) = footprint(L::WIDTH);
    let taken = samples.len() as u64;
    let (cone_prims, cone_tree) = cull.skipped(tracer.accel);
    let at = |px: u32, py: u32, k: usize| (px - x0 + k as u32 % fw, py - y0 + k as u32 / fw);
    let n = ((x1 - x0).div_ceil(fw) * (y1 - y0).div_ceil(fh)) as usize;
    let (mut packets, mut lanes) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for py in (y0..y1).step_by(fh as usize) {
        for px in (x0..x1).step_by(fw as usize) {
            let mut active = 0u32;
            for k in 0..L::WIDTH as u32 {
                let (x, y) = (px + k % fw, py + k / fw);
                if x < x1 && y < y1 {
                    active |= 1 << k;
                }
            }
            let pixels = tracer.pixel_hashes::<L>(px, py);
            packets.push(PacketPixels {
                x0: px,
                y0: py,
                pixels,
                active,
            });
            lanes.push(out.start::<L>(active, |k| at(px, py, k)));
            counts.cone_prims += cone_prims * active.count_ones() as u64 * taken;
            counts.cone_trees += cone_tree as u64 * taken;
        }
    }
    let mut colors = vec![V3::<L>::splat(Vec3::ZERO); packets.len()];
    let mut work = Regrouping::<L>::with_capacity(n);
    // The first sample decides whether the others regroup (`Regrouped::pays`); they are
    // added after it, so each pixel still sums its samples in sample order.
    let mut regroup = true;
    let zero = [V3::<L>::splat(Vec3::ZERO); 2];
    let mut halves = vec![zero; if out.marked() { packets.len() } else { 0 }];
    for s in samples.clone() {
        if !regroup {
            for (i, (p, sum)) in packets.iter().zip(lanes.iter_mut()).enumerate() {
                for s in s..samples.end {
                    let (x, y, c) = (p.x0, p.y0, &mut counts);
                    *sum = *sum + tracer.sample_pixels(x, y, &p.pixels, p.active, s, cull, c);
                    if out.marked() {
                        let at = |k| at(p.x0, p.y0, k);
                        out.note(s, *sum, &mut halves[i], p.active, at);
                    }
                }
            }
            break;
        }
        let saved = tracer.sample_tile(&packets, s, cull, &mut colors, &mut work, &mut counts);
        for (sum, c) in lanes.iter_mut().zip(&colors) {
            *sum = *sum + *c;
        }
        if out.marked() {
            for ((p, sum), halves) in packets.iter().zip(&lanes).zip(&mut halves) {
                let at = |k| at(p.x0, p.y0, k);
                out.note(s, *sum, halves, p.active, at);
            }
        }
        regroup = saved.pays();
    }
    for (p, sum) in packets.iter().zip(&lanes) {
        out.finish(*sum, p.active, |k| at(p.x0, p.y0, k));
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::scene::{compile, Overrides, SceneSource};

    /// Where a pixel lands and in which order tiles are rendered change nothing: the
    /// frame rendered as its tiles in reverse order, each a rectangle of its own, has
    /// the bits and the ray counts of the frame rendered at once.
    #[test]
    fn the_film_does_not_depend_on_the_tile_order() {
        let source = SceneSource::builtin("cornell").unwrap();
        let overrides = Overrides {
            width: Some(72),
            spp: Some(2),
            max_depth: Some(3),
        };
        let mut scene = compile(&source, &source.parse().unwrap(), overrides).unwrap();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let settings = RenderSettings::default();
        let whole = render(&scene, &accel, &settings, &|| {}).unwrap();
        let (w, h) = (scene.camera.width, scene.camera.height);
        // 72 pixels wide: 5 tiles a row, the last 8 pixels wide.
        let mut tiles: Vec<Rect> = (0..h.div_ceil(TILE))
            .flat_map(|ty| {
                (0..w.div_ceil(TILE)).map(move |tx| {
                    let (x0, y0) = (tx * TILE, ty * TILE);
                    Rect::new(x0, y0, (x0 + TILE).min(w), (y0 + TILE).min(h))
                })
            })
            .collect();
        tiles.reverse();
        let mut pixels = vec![Vec3::ZERO; (w * h) as usize];
        let counts = render_rects(&scene, &accel, &settings, &tiles, &mut pixels, &|| {});
        assert_eq!(counts, whole.counts);
        let mut film = vec![Vec3::NAN; (w * h) as usize];
        let mut rest = pixels.as_slice();
        for t in &tiles {
            let (mine, next) = rest.split_at(t.pixel_count() as usize);
            rest = next;
            for (row, line) in mine.chunks_exact(t.width() as usize).enumerate() {
                let start = ((t.y0 + row as u32) * w + t.x0) as usize;
                film[start..start + line.len()].copy_from_slice(line);
            }
        }
        let bits = |p: &[Vec3]| -> Vec<[u32; 3]> {
            p.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
        };
        assert_eq!(bits(&film), bits(&whole.film.pixels));
    }

    /// The terms an adaptive pass 0 takes on the way (`first_pass_tile`) have the bits of
    /// `pixel_term` over the sums of separate renders of 1, 2 and 4 samples, at every
    /// packet width, for a tile inside the frame and one cut by its edge, through the
    /// packets' path (`cornell`) and the regrouped one (a scene of path-traced surfaces
    /// alone); and its sums, written over what the rows held, are those of the separate
    /// render of 4 samples.
    #[test]
    fn pass_0_takes_the_terms_of_fewer_samples() {
        let glass = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/benches/corpus/glass-cornell.toml"
        );
        for name in ["cornell", glass] {
            let overrides = Overrides {
                width: Some(40),
                spp: Some(4),
                max_depth: Some(3),
            };
            let mut scene = Scene::load(name, overrides).unwrap();
            let accel = Accel::build(&mut scene, AccelKind::Bvh);
            let sampler = Sampler::new(crate::sampling::SamplerKind::Sobol, 7, 4);
            let tracer = Tracer::with_sampler(&scene, &accel, sampler);
            let bits = |p: &[Vec3]| -> Vec<[u32; 3]> {
                p.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
            };
            let mut regrouped = false;
            for width in [
                PacketWidth::Scalar,
                PacketWidth::Four,
                PacketWidth::Eight,
                PacketWidth::Sixteen,
            ] {
                regrouped |= match width {
                    PacketWidth::Four => tracer.regroups::<Vec4>(),
                    PacketWidth::Eight => tracer.regroups::<f32x8>(),
                    PacketWidth::Sixteen => tracer.regroups::<F32x16>(),
                    PacketWidth::Scalar => false,
                };
                for tile in [Rect::new(16, 16, 32, 32), Rect::new(32, 0, 40, 16)] {
                    let len = tile.pixel_count() as usize;
                    let alone = |n: u32| {
                        let mut sums = vec![Vec3::ZERO; len];
                        accumulate_tile(&tracer, width, tile, 0..n, &mut sums);
                        sums
                    };
                    let (one, two, four) = (alone(1), alone(2), alone(4));
                    let terms = |sums: &[Vec3], half: &[Vec3], n| -> Vec<u32> {
                        let v3 = |v: Vec3| V3::new(v.x, v.y, v.z);
                        sums.iter()
                            .zip(half)
                            .map(|(s, h)| {
                                adaptive::pixel_term::<f32>(v3(*s), v3(*h), n, n / 2).to_bits()
                            })
                            .collect()
                    };
                    let mut buffer = vec![f32::NAN; 2 * TERMS_AT4];
                    let mut sums = vec![Vec3::NAN; len];
                    let mut rows: Vec<&mut [Vec3]> =
                        sums.chunks_mut(tile.width() as usize).collect();
                    first_pass_tile(&tracer, width, tile, &mut rows, &mut buffer);
                    let (at2, at4) = (&buffer[..len], &buffer[TERMS_AT4..TERMS_AT4 + len]);
                    let to_bits =
                        |t: &[f32]| -> Vec<u32> { t.iter().map(|t| t.to_bits()).collect() };
                    let what = format!("{name} {width:?} {tile:?}");
                    assert_eq!(to_bits(at2), terms(&two, &one, 2), "{what}");
                    assert_eq!(to_bits(at4), terms(&four, &two, 4), "{what}");
                    assert_eq!(bits(&sums), bits(&four), "{what}");
                    // The terms are not all zero: the test sees the estimate.
                    assert!(at4.iter().any(|&q| q > 0.0), "{what}");
                }
            }
            assert_eq!(regrouped, name == glass, "{name}: the path under test");
        }
    }
}
