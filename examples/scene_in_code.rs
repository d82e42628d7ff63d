//! Build a scene in code: a grid of spheres whose colours and finishes vary by row and
//! column, lit by a quad light, written as scene TOML by the program and rendered without
//! a file. Then inspect the film: the brightest pixel and the mean colour.
//!
//! ```sh
//! cargo run --release --example scene_in_code -- grid.png
//! ```

use raytracer::{PacketWidth, RenderSettings, Renderer, SamplerKind, Vec3};
use std::fmt::Write;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let output = std::env::args().nth(1).unwrap_or_else(|| "grid.png".into());

    // Top-level keys and tables first: a key after an `[[objects]]` header would belong
    // to that object.
    let mut materials = String::new();
    let mut objects = String::new();
    // Five columns of hue, three rows of finish: matte, glossy, mirror.
    for row in 0..3 {
        for column in 0..5 {
            let hue = column as f32 / 5.0;
            let [r, g, b] = [hue, hue + 1.0 / 3.0, hue + 2.0 / 3.0]
                .map(|h| 0.5 + 0.4 * (std::f32::consts::TAU * h).cos());
            let finish = match row {
                0 => "type = \"phong\", shininess = 2",
                1 => "type = \"phong\", shininess = 200",
                _ => "type = \"phong_mirror\", shininess = 200, index = 1.5",
            };
            let name = format!("m{row}{column}");
            writeln!(
                materials,
                "{name} = {{ {finish}, albedo = [{r}, {g}, {b}] }}"
            )?;
            let (x, z) = (column as f32 - 2.0, row as f32 - 1.0);
            writeln!(
                objects,
                "[[objects]]\ntype = \"sphere\"\ncenter = [{x}, 0.4, {z}]\nradius = 0.4\nmaterial = \"{name}\""
            )?;
        }
    }
    let toml = format!(
        r#"description = "a grid of spheres under a quad light"
background = [0.02, 0.02, 0.03]
ambient = [0.05, 0.05, 0.05]

[camera]
width = 480
aspect_ratio = "16:9"
samples_per_pixel = 8
look_from = [0, 3, 6]
look_at = [0, 0.5, 0]
vfov = 40

[materials]
floor = {{ type = "phong", albedo = [0.6, 0.6, 0.6], shininess = 10 }}
lamp = {{ type = "light", color = [1, 0.95, 0.9], intensity = 1.5 }}
{materials}
[[objects]]
type = "quad"
corner = [-1, 4, -1]
u = [2, 0, 0]
v = [0, 0, 2]
material = "lamp"

[[objects]]
type = "sphere"
center = [0, -1000, 0]
radius = 1000
material = "floor"

{objects}"#
    );

    let renderer = Renderer::from_toml(&toml)?;
    let settings = RenderSettings {
        sampler: SamplerKind::Sobol,
        packet_width: PacketWidth::widest(),
        ..RenderSettings::new(1)
    };
    let film = renderer.render(&settings)?;

    let luminance = |p: Vec3| p.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    let (brightest, _) = film
        .pixels
        .iter()
        .enumerate()
        .max_by(|a, b| luminance(*a.1).total_cmp(&luminance(*b.1)))
        .ok_or("an empty film")?;
    let mean = film.pixels.iter().sum::<Vec3>() / film.pixels.len() as f32;
    println!(
        "{}x{}: brightest pixel at ({}, {}), mean colour {mean:.3}",
        film.width,
        film.height,
        brightest as u32 % film.width,
        brightest as u32 / film.width
    );
    film.write(&output)?;
    println!("-> {output}");
    Ok(())
}
