//! `raytracer merge PART... -o OUT`: check the part files, put them together, write the
//! frame and one summary line.

use super::options::MergeOptions;
use raytracer::budget::Budget;
use std::time::Instant;

/// Merge `o.parts` into `o.output`; nothing is written if any part is refused.
pub fn run(o: &MergeOptions) -> anyhow::Result<()> {
    let start = Instant::now();
    let budget = o.max_memory.map_or_else(Budget::machine, Budget::cap);
    let merged =
        raytracer::merge_parts_within(&o.parts, budget).map_err(super::name_the_memory_cap)?;
    if super::options::is_stdout(&o.output) {
        super::image_to_stdout(&merged.film, o.format)?;
    } else {
        merged.film.write(&o.output)?;
    }
    if o.notes {
        to_stderr!(
            "merged {} parts of {} ({}x{}, {} spp) in {:.3} s -> {}",
            o.parts.len(),
            merged.scene,
            merged.film.width,
            merged.film.height,
            merged.spp,
            start.elapsed().as_secs_f64(),
            super::output_name(&o.output)
        );
    }
    Ok(())
}
