//! Render a scene file (or a built-in scene) to an image with the library.
//!
//! ```sh
//! cargo run --release --example render_file -- scenes/cornell.toml cornell.png
//! cargo run --release --example render_file -- bunny bunny.exr 400
//! ```
//!
//! Arguments: a `.toml` scene file or a built-in scene name, the output image (`.png`,
//! `.ppm` or `.exr`, by extension), and optionally the image width.

use raytracer::{RenderSettings, Renderer, SceneFile, SceneOptions};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (scene, output, width) = match args.as_slice() {
        [scene, output] => (scene, output, None),
        [scene, output, width] => (scene, output, Some(width.parse()?)),
        _ => return Err("usage: render_file SCENE.toml|NAME OUTPUT.png|.ppm|.exr [WIDTH]".into()),
    };
    let file = if scene.ends_with(".toml") {
        SceneFile::from_path(scene)?
    } else {
        SceneFile::builtin(scene)?
    };
    let options = SceneOptions {
        width,
        ..SceneOptions::default()
    };
    let renderer = Renderer::new(&file, &options)?;
    let start = Instant::now();
    let film = renderer.render(&RenderSettings::default())?;
    println!(
        "{}: {}x{}, {} spp in {:.3} s",
        renderer.name(),
        film.width,
        film.height,
        renderer.spp(),
        start.elapsed().as_secs_f64()
    );
    film.write(output)?;
    Ok(())
}
