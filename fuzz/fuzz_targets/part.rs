//! Part-file bytes → `parse_header`, `parse_part` and `merge_parts_within`. Refused with
//! a one-line message, or a part whose rectangles lie in its image
//! and hold exactly its pixel count, 12 bytes each; a frame merged from one part has the
//! header's size and the part's pixels. Never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raytracer::budget::Budget;
use raytracer::merge_parts_within;
use raytracer::farm::part::{parse_header, parse_part};

fuzz_target!(|data: &[u8]| {
    let header = parse_header(data);
    if let Ok(h) = &header {
        let s = &h.header.settings;
        let mut area = 0u64;
        for r in &h.rects {
            assert!(r.x0 < r.x1 && r.y0 < r.y1, "{r:?}");
            assert!(
                r.x1 <= s.width && r.y1 <= s.height,
                "{r:?} in {}x{}",
                s.width,
                s.height
            );
            area += r.pixel_count();
        }
        assert_eq!(area, h.header.pixels);
    }
    let part = parse_part(data);
    if let Ok(p) = &part {
        let h = header
            .as_ref()
            .expect("a part whose header alone is refused");
        assert_eq!(p.rects, h.rects);
        assert_eq!(p.payload.len() as u64, 12 * p.header.pixels);
        assert_eq!(p.pixels().count() as u64, p.header.pixels);
    }
    // The merge of this one file: it reads the file itself, within a budget.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.part");
    std::fs::write(&path, data).unwrap();
    match merge_parts_within(&[&path], Budget::cap(256 << 20)) {
        Ok(merged) => {
            let p = part.expect("a merge of a part that parse_part refuses");
            let s = &p.header.settings;
            assert_eq!((merged.film.width, merged.film.height), (s.width, s.height));
            assert_eq!(p.header.pixels, s.width as u64 * s.height as u64);
            for (a, b) in merged.film.pixels.iter().zip(p.pixels()) {
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits)
                );
            }
        }
        Err(e) => {
            // One line: the file and what is wrong with it, the missing pixels, or the
            // memory it would take.
            let message = e.to_string();
            assert!(!message.is_empty() && !message.contains('\n'), "{message}");
        }
    }
});
