//! OBJ text → `parse_obj` and `parse_obj_smooth`. Refused with an error naming the file,
//! or triangles that are finite, within the coordinate limit and of non-zero area, and
//! (smooth) a unit normal at every corner; never a panic. The same text as an MTL
//! library → `parse_mtl`: refused naming the file, or materials that map.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raytracer::geometry::triangle::is_proper_triangle;
use raytracer::scene::limits::MAX_COORDINATE;
use raytracer::scene::mesh::{parse_obj, parse_obj_smooth};
use raytracer::scene::mtl::{parse_mtl, to_material};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for smooth in [false, true] {
        let parsed = if smooth {
            parse_obj_smooth("fuzz.obj", text)
        } else {
            parse_obj("fuzz.obj", text)
        };
        match parsed {
            Ok(mesh) => {
                assert!(!mesh.triangles.is_empty());
                for &t in &mesh.triangles {
                    assert!(is_proper_triangle(t));
                    let inside = t
                        .iter()
                        .all(|p| p.abs().max_element() as f64 <= MAX_COORDINATE);
                    assert!(inside, "{t:?}");
                }
                if smooth {
                    assert_eq!(mesh.normals.len(), mesh.triangles.len());
                    for n in mesh.normals.iter().flatten() {
                        assert!((n.length() - 1.0).abs() < 1e-5, "{n}");
                    }
                } else {
                    assert!(mesh.normals.is_empty());
                }
            }
            Err(e) => assert!(e.to_string().starts_with("fuzz.obj"), "{e}"),
        }
    }
    match parse_mtl("fuzz.mtl", text) {
        Ok(library) => {
            for m in &library.materials {
                let _ = to_material(m);
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.mtl"), "{e}"),
    }
});
