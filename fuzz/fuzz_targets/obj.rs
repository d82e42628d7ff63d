//! OBJ text → `parse_obj` and `parse_obj_smooth`. Refused with an error naming the file,
//! or triangles that are finite, within the coordinate limit and of non-zero area, and
//! (smooth) a unit normal at every corner; never a panic. The parallel reader, in chunks
//! of 1 and 64 bytes, gives up where the checked path refuses the text, and otherwise
//! reads the same bits. The same text as an MTL
//! library → `parse_mtl`: refused naming the file, or materials that map.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raytracer::geometry::triangle::is_proper_triangle;
use raytracer::scene::limits::MAX_COORDINATE;
use raytracer::scene::mesh::{
    parse_obj, parse_obj_smooth, read_obj_checked, read_obj_parallel, MeshTriangles, ObjOptions,
};
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
    let names = ["a".to_string(), "x".to_string()];
    for smooth in [false, true] {
        for materials in [None, Some(&names[..])] {
            let options = ObjOptions { smooth, materials };
            let checked = read_obj_checked("fuzz.obj", text, options);
            for chunk in [1, 64] {
                match (&checked, read_obj_parallel(text, options, chunk)) {
                    (_, None) => {}
                    (Err(e), Some(_)) => panic!("read in parallel, but refused: {e}"),
                    (Ok(want), Some(got)) => assert_eq!(bits(&got), bits(want)),
                }
            }
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

/// A mesh's bits, for exact comparisons.
fn bits(m: &MeshTriangles) -> (Vec<u32>, Vec<u32>, Vec<u32>, usize) {
    let flat = |t: &[[glam::Vec3; 3]]| -> Vec<u32> {
        t.iter()
            .flat_map(|c| c.iter().flat_map(|p| p.to_array().map(f32::to_bits)))
            .collect()
    };
    (
        flat(&m.triangles),
        flat(&m.normals),
        m.material.clone(),
        m.degenerate,
    )
}
