//! Rendering a compiled scene into a film: tiles in parallel (rayon), every pixel the
//! mean of its samples summed in sample order, so the image is the same for any thread
//! count and tile order.

use crate::accel::Accel;
use crate::error::Result;
pub use crate::film::Film;
use crate::integrator::{footprint, RayCounts, Tracer};
use crate::lanes::{Lane, V3};
pub use crate::renderer::Rendered;
use crate::rng::Sampler;
use crate::scene::Scene;
pub use crate::settings::{PacketWidth, RenderSettings};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use wide::f32x8;

/// Tile edge in pixels. A multiple of the packet footprints (4x2 and 2x2).
pub const TILE: u32 = 16;

/// Tiles rendered before their pixels are copied into the film: 4096 tiles of 256
/// pixels (a 1024x1024 image in one batch).
const TILE_BATCH: usize = 4096;

/// Render on the current rayon pool. `on_tile` is called after each tile (progress).
pub fn render(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    on_tile: &(dyn Fn() + Sync),
) -> Result<Rendered> {
    render_in_batches(scene, accel, settings, on_tile, TILE_BATCH)
}

fn render_in_batches(
    scene: &Scene,
    accel: &Accel,
    settings: &RenderSettings,
    on_tile: &(dyn Fn() + Sync),
    tile_batch: usize,
) -> Result<Rendered> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut film = Film::new(w, h)?;
    let sampler = Sampler::new(settings.sampler, settings.seed, scene.spp);
    let mut tracer = Tracer::with_sampler(scene, accel, sampler);
    tracer.specialize = settings.specialize;
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let tiles: Vec<(u32, u32)> = (0..tiles_y)
        .flat_map(|ty| (0..tiles_x).map(move |tx| (tx, ty)))
        .collect();
    // Tiles in batches, each copied into the film before the next: the tiles' own
    // pixels never take more than a batch's 12 MB beside the film.
    let mut counts = RayCounts::default();
    for batch in tiles.chunks(tile_batch) {
        let results: Vec<(Vec<Vec3>, RayCounts)> = batch
            .par_iter()
            .map(|&(tx, ty)| {
                let r = render_tile(
                    &tracer,
                    settings.packet_width,
                    tx * TILE,
                    ty * TILE,
                    (tx * TILE + TILE).min(w),
                    (ty * TILE + TILE).min(h),
                );
                on_tile();
                r
            })
            .collect();
        for (&(tx, ty), (pixels, c)) in batch.iter().zip(&results) {
            counts.add(c);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let tw = (x0 + TILE).min(w) - x0;
            for (row, chunk) in pixels.chunks_exact(tw as usize).enumerate() {
                let start = ((y0 + row as u32) * w + x0) as usize;
                film.pixels[start..start + tw as usize].copy_from_slice(chunk);
            }
        }
    }
    Ok(Rendered { film, counts })
}

fn render_tile(
    tracer: &Tracer,
    packet_width: PacketWidth,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
) -> (Vec<Vec3>, RayCounts) {
    match packet_width {
        PacketWidth::Eight => render_tile_packets::<f32x8>(tracer, x0, y0, x1, y1),
        PacketWidth::Four => render_tile_packets::<Vec4>(tracer, x0, y0, x1, y1),
        PacketWidth::Scalar => render_tile_scalar(tracer, x0, y0, x1, y1),
    }
}

fn render_tile_scalar(
    tracer: &Tracer,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
) -> (Vec<Vec3>, RayCounts) {
    let spp = tracer.scene.spp;
    let mut counts = RayCounts::default();
    let mut pixels = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
    for y in y0..y1 {
        for x in x0..x1 {
            let mut sum = Vec3::ZERO;
            for s in 0..spp {
                sum += tracer.sample(x, y, s, &mut counts);
            }
            pixels.push(sum / spp as f32);
        }
    }
    (pixels, counts)
}

/// A tile in packets of `L::WIDTH` pixels (4x2 or 2x2); lanes past the tile's edge are
/// inactive. Each pixel sums its samples in sample order, as the scalar tile does.
fn render_tile_packets<L: Lane>(
    tracer: &Tracer,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
) -> (Vec<Vec3>, RayCounts) {
    let spp = tracer.scene.spp;
    let (fw, fh) = footprint(L::WIDTH);
    let tw = x1 - x0;
    let mut counts = RayCounts::default();
    let mut pixels = vec![Vec3::ZERO; (tw * (y1 - y0)) as usize];
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
                    pixels[((y - y0) * tw + (x - x0)) as usize] =
                        sums.lane(k as usize) / spp as f32;
                }
            }
        }
    }
    (pixels, counts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;
    use crate::scene::{compile, Overrides, SceneSource};

    /// Batches change when tiles are copied into the film, not what they hold: any batch
    /// size gives the same pixels, bit for bit, and the same ray counts.
    #[test]
    fn the_film_does_not_depend_on_the_tile_batch() {
        let source = SceneSource::builtin("cornell").unwrap();
        let overrides = Overrides {
            width: Some(72),
            spp: Some(2),
            max_depth: Some(3),
        };
        let mut scene = compile(&source, &source.parse().unwrap(), overrides).unwrap();
        let accel = Accel::build(&mut scene, AccelKind::Bvh);
        let settings = RenderSettings::default();
        let at = |batch| render_in_batches(&scene, &accel, &settings, &|| {}, batch).unwrap();
        let whole = at(TILE_BATCH);
        // 72 pixels wide: 5 tiles a row, the last 8 pixels wide.
        assert!(whole.film.pixels.len().div_ceil(256) < TILE_BATCH);
        for batch in [1, 3, 7] {
            let batched = at(batch);
            assert_eq!(batched.counts, whole.counts);
            let bits = |f: &Film| -> Vec<[u32; 3]> {
                f.pixels
                    .iter()
                    .map(|p| p.to_array().map(f32::to_bits))
                    .collect()
            };
            assert_eq!(bits(&batched.film), bits(&whole.film), "batch {batch}");
        }
    }
}
