//! Rendering a compiled scene: the whole frame into a film, or a region of it (a part of
//! a farmed frame, or a crop window) into its own pixels. Tiles run in parallel (rayon)
//! and write straight into the output; every pixel is the mean of its samples summed in
//! sample order, so the image is the same for any thread count, tile order or region.

use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::farm::region::{Rect, Region, TILE};
pub use crate::film::Film;
use crate::integrator::{footprint, RayCounts, Tracer};
use crate::lanes::{Lane, V3};
use crate::sampling::Sampler;
use crate::scene::Scene;
pub use crate::settings::{PacketWidth, RenderSettings};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use wide::f32x8;

/// A film and the rays traced to make it.
#[derive(Debug)]
pub struct Rendered {
    /// The image.
    pub film: Film,
    /// Rays by kind and the traversal work they took.
    pub counts: RayCounts,
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
    Ok(Rendered { film, counts })
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
    let (width, height) = (scene.camera.width, scene.camera.height);
    let rects = region.rects(width, height)?;
    let n: u64 = rects.iter().map(Rect::pixel_count).sum();
    let mut pixels = crate::film::zeroed_pixels(n as usize).map_err(|_| Error::ImageTooLarge {
        width,
        height,
        bytes: n as u128 * std::mem::size_of::<Vec3>() as u128,
    })?;
    let counts = render_rects(scene, accel, settings, &rects, &mut pixels, on_tile);
    Ok(RenderedRegion {
        region,
        rects,
        pixels,
        counts,
    })
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

fn sum_counts(mut a: RayCounts, b: RayCounts) -> RayCounts {
    a.add(&b);
    a
}

/// Render the pixels of `tile` into `rows` (`rows[y - y0][x - x0]`).
fn render_tile(
    tracer: &Tracer,
    packet_width: PacketWidth,
    tile: Rect,
    rows: &mut [&mut [Vec3]],
) -> RayCounts {
    match packet_width {
        PacketWidth::Eight => render_tile_packets::<f32x8>(tracer, tile, rows),
        PacketWidth::Four => render_tile_packets::<Vec4>(tracer, tile, rows),
        PacketWidth::Scalar => render_tile_scalar(tracer, tile, rows),
    }
}

/// A tile one ray at a time (the scalar reference): `sample_pixels` at `f32`, with the
/// tile's camera cone, so a tile whose cone meets nothing makes no ray, as the packets'
/// tiles do.
fn render_tile_scalar(tracer: &Tracer, tile: Rect, rows: &mut [&mut [Vec3]]) -> RayCounts {
    let spp = tracer.scene.spp;
    let mut counts = RayCounts::default();
    let cull = tracer.camera_cull(tile.x0, tile.y0, tile.x1, tile.y1);
    for (y, row) in (tile.y0..tile.y1).zip(rows.iter_mut()) {
        for (x, pixel) in (tile.x0..tile.x1).zip(row.iter_mut()) {
            let hashes = tracer.pixel_hashes::<f32>(x, y);
            let mut sum = Vec3::ZERO;
            for s in 0..spp {
                sum += tracer
                    .sample_pixels::<f32>(x, y, &hashes, 1, s, cull, &mut counts)
                    .lane(0);
            }
            *pixel = sum / spp as f32;
        }
    }
    counts
}

/// A tile in packets of `L::WIDTH` pixels (4x2 or 2x2); lanes past the tile's edge are
/// inactive. Each pixel sums its samples in sample order, as the scalar tile does.
fn render_tile_packets<L: Lane>(
    tracer: &Tracer,
    tile: Rect,
    rows: &mut [&mut [Vec3]],
) -> RayCounts {
    let Rect { x0, y0, x1, y1 } = tile;
    let spp = tracer.scene.spp;
    let (fw, fh) = footprint(L::WIDTH);
    let mut counts = RayCounts::default();
    // What the tile's camera rays may hit (the packets' footprints may reach past the
    // tile's edge: those lanes are inactive and never reported).
    let cull = tracer.camera_cull(x0, y0, x1, y1);
    let (cone_prims, cone_tree) = cull.skipped(tracer.accel);
    for py in (y0..y1).step_by(fh as usize) {
        for px in (x0..x1).step_by(fw as usize) {
            let mut active = 0u32;
            for k in 0..L::WIDTH as u32 {
                let (x, y) = (px + k % fw, py + k / fw);
                if x < x1 && y < y1 {
                    active |= 1 << k;
                }
            }
            let mut sums = V3::<L>::splat(Vec3::ZERO);
            for s in 0..spp {
                sums = sums + tracer.sample_packet::<L>(px, py, active, s, cull, &mut counts);
            }
            counts.cone_prims += cone_prims * active.count_ones() as u64 * spp as u64;
            counts.cone_trees += cone_tree as u64 * spp as u64;
            for k in 0..L::WIDTH as u32 {
                if active >> k & 1 != 0 {
                    let (x, y) = (px + k % fw, py + k / fw);
                    rows[(y - y0) as usize][(x - x0) as usize] = sums.lane(k as usize) / spp as f32;
                }
            }
        }
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
}
