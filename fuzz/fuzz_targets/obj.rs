//! OBJ text → `parse_obj`. Refused with an error naming the file, or triangles that are
//! finite, within the coordinate limit and of non-zero area; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raytracer::geometry::triangle::is_proper_triangle;
use raytracer::scene::limits::MAX_COORDINATE;
use raytracer::scene::mesh::parse_obj;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_obj("fuzz.obj", text) {
        Ok(mesh) => {
            assert!(!mesh.triangles.is_empty());
            for &t in &mesh.triangles {
                assert!(is_proper_triangle(t));
                let inside = t
                    .iter()
                    .all(|p| p.abs().max_element() as f64 <= MAX_COORDINATE);
                assert!(inside, "{t:?}");
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.obj"), "{e}"),
    }
});
