//! The rules of `lanes` checked on every width: min, max and the masks by the same
//! rules, the reductions the scalar tree's bits, broadcasts, `next_up`/`next_down`
//! against std's at the edges and on a sweep of all floats.

use super::*;

/// The 8- and 16-wide reductions give the default tree's bits (the scalar
/// `a < b ? a : b` pairwise), signed zeros and infinities included.
#[test]
fn wide_reductions_are_the_default_tree() {
    fn tree<const N: usize>(v: [f32; N], pick: fn(f32, f32) -> f32) -> f32 {
        let mut v = v;
        let mut w = N;
        while w > 1 {
            w /= 2;
            for i in 0..w {
                v[i] = pick(v[i], v[i + w]);
            }
        }
        v[0]
    }
    let values = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        2.5,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1e-40,
    ];
    let mut state = 1u64;
    for _ in 0..20_000 {
        let v: [f32; 16] = std::array::from_fn(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            values[(state >> 61) as usize]
        });
        let lo: [f32; 8] = std::array::from_fn(|i| v[i]);
        let (x8, x16) = (f32x8::from(lo), F32x16::from_fn(|i| v[i]));
        let less = |a: f32, b: f32| if a < b { a } else { b };
        let more = |a: f32, b: f32| if a > b { a } else { b };
        assert_eq!(
            x8.reduce_min().to_bits(),
            tree(lo, less).to_bits(),
            "{lo:?}"
        );
        assert_eq!(
            x8.reduce_max().to_bits(),
            tree(lo, more).to_bits(),
            "{lo:?}"
        );
        assert_eq!(x16.reduce_min().to_bits(), tree(v, less).to_bits(), "{v:?}");
        assert_eq!(x16.reduce_max().to_bits(), tree(v, more).to_bits(), "{v:?}");
    }
}

/// `broadcast(i)` puts lane i's bits in every lane (−0, NaN payloads, subnormals),
/// at every width.
#[test]
fn broadcast_copies_one_lanes_bits() {
    let bits = [
        0x8000_0000u32,
        0x7fc0_1234,
        0x0000_0001,
        0x3f80_0000,
        0xff80_0000,
        0x4049_0fdb,
        0x8000_0002,
        0x7f80_0000,
        0x0000_0000,
        0xffc0_0001,
        0x3f80_0001,
        0x807f_ffff,
        0x7f7f_ffff,
        0xbf80_0000,
        0x0040_0000,
        0x4120_0000,
    ];
    fn check<L: Lane>(bits: &[u32; 16]) {
        let v = L::from_fn(|k| f32::from_bits(bits[k]));
        for (i, &want) in bits.iter().enumerate().take(L::WIDTH) {
            let b = v.broadcast(i);
            for k in 0..L::WIDTH {
                assert_eq!(b.lane(k).to_bits(), want, "width {} lane {i}", L::WIDTH);
            }
        }
    }
    check::<f32>(&bits);
    check::<Vec4>(&bits);
    check::<f32x8>(&bits);
    check::<F32x16>(&bits);
}

/// Only the first `width` entries count, and any single differing bit is seen.
#[test]
fn all_equal_looks_at_the_first_width_entries() {
    let mut xs = [7u32; 8];
    assert!(all_equal(&xs, 8) && all_equal(&xs, 1));
    xs[5] = 7 ^ (1 << 31);
    assert!(all_equal(&xs, 5) && !all_equal(&xs, 6) && !all_equal(&xs, 8));
    assert!(!all_equal(&[1usize, 0, 1, 1], 4) && all_equal(&[0usize; 4], 4));
}

fn check_rules<L: Lane>() {
    let (nan, inf, tiny) = (f32::NAN, f32::INFINITY, f32::from_bits(1));
    let a = [
        nan, 1.0, 3.0, -0.0, 2.0, nan, 7.0, 0.0, -inf, 0.5, tiny, -3.0, inf, 1e30, 0.0, -2.5,
    ];
    let b = [
        2.0, nan, 1.0, 0.0, 2.0, nan, 8.0, -0.0, 1.0, -inf, 3.0, -tiny, inf, 1e-30, 0.0, 7.0,
    ];
    let (a, b) = (L::from_fn(|i| a[i]), L::from_fn(|i| b[i]));
    let min = a.min(b);
    let max = a.max(b);
    for i in 0..L::WIDTH {
        let (x, y) = (a.lane(i), b.lane(i));
        let want_min = if x < y { x } else { y };
        let want_max = if x > y { x } else { y };
        assert_eq!(min.lane(i).to_bits(), want_min.to_bits(), "min lane {i}");
        assert_eq!(max.lane(i).to_bits(), want_max.to_bits(), "max lane {i}");
    }
    let (lt, le, gt, ge) = (a.lt(b), a.le(b), a.gt(b), a.ge(b));
    let (eq, ne, neg) = (a.eq(b), a.ne(b), a.flip_sign());
    let arithmetic = [
        a + b,
        a - b,
        a * b,
        a / b,
        a.sqrt(),
        a.abs(),
        a.add_bits(-3),
    ];
    for i in 0..L::WIDTH {
        let (x, y) = (a.lane(i), b.lane(i));
        assert_eq!(lt.bits() >> i & 1 != 0, x < y, "lt lane {i}");
        assert_eq!(le.bits() >> i & 1 != 0, x <= y, "le lane {i}");
        assert_eq!(gt.bits() >> i & 1 != 0, x > y, "gt lane {i}");
        assert_eq!(ge.bits() >> i & 1 != 0, x >= y, "ge lane {i}");
        assert_eq!(eq.bits() >> i & 1 != 0, x == y, "eq lane {i}");
        assert_eq!(ne.bits() >> i & 1 != 0, x != y, "ne lane {i}");
        assert_eq!(neg.lane(i).to_bits(), (-x).to_bits(), "flip_sign lane {i}");
        let want = [
            x + y,
            x - y,
            x * y,
            x / y,
            x.sqrt(),
            x.abs(),
            x.add_bits(-3),
        ];
        for (op, (got, want)) in arithmetic.iter().zip(want).enumerate() {
            // NaN payloads may differ between instructions; NaN-ness may not.
            let (g, w) = (got.lane(i), want);
            assert!(
                g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                "operation {op} lane {i}: {g:e} against {w:e}"
            );
        }
    }
    let bits = 0b0110_1001_1010_0110 & ((1u64 << L::WIDTH) - 1) as u32;
    assert_eq!(L::Mask::from_bits(bits).bits(), bits);
    let s = L::select(L::Mask::from_bits(bits), L::splat(1.0), L::splat(2.0));
    for i in 0..L::WIDTH {
        assert_eq!(s.lane(i), if bits >> i & 1 != 0 { 1.0 } else { 2.0 });
    }
}

fn check_reduce_min<L: Lane>() {
    // Every position of the minimum, with ties and infinities among the others.
    let base = [
        3.0,
        f32::INFINITY,
        5.5,
        3.0,
        -1.0,
        9.0,
        f32::NEG_INFINITY,
        0.25,
        4.0,
        -0.0,
        12.0,
        f32::NEG_INFINITY,
        1.5,
        0.0,
        -1.5,
        f32::INFINITY,
    ];
    for at in 0..L::WIDTH {
        let v = L::from_fn(|i| if i == at { -7.5 } else { base[i].max(-2.0) });
        assert_eq!(v.reduce_min(), -7.5, "minimum in lane {at}");
    }
    let v = L::from_fn(|i| base[i]);
    let want = base[..L::WIDTH]
        .iter()
        .copied()
        .fold(f32::INFINITY, f32::min);
    assert_eq!(v.reduce_min(), want);
}

#[test]
fn reduce_min_finds_the_smallest_lane_at_every_width() {
    check_reduce_min::<f32>();
    check_reduce_min::<Vec4>();
    check_reduce_min::<f32x8>();
    check_reduce_min::<F32x16>();
}

/// `next_up`/`next_down` of every width against the std functions, bit for bit, on
/// `xs` (sixteen at a time; the `f32` lane is the std function itself).
fn check_next(xs: &[u32]) {
    fn check<L: Lane>(chunk: &[f32; 16]) {
        for half in chunk.chunks(L::WIDTH) {
            let v = L::from_fn(|i| half[i]);
            let (up, down) = (v.next_up(), v.next_down());
            // Towards +1, −1, 0, NaN, −0, +∞, −∞ and 3, each lane taking each in turn.
            let towards = [
                1.0,
                -1.0,
                0.0,
                f32::NAN,
                -0.0,
                f32::INFINITY,
                f32::NEG_INFINITY,
                3.0,
            ];
            for r in 0..towards.len() {
                let t = L::from_fn(|i| towards[(i + r) % towards.len()]);
                let step = v.step_towards(t);
                for (i, &x) in half.iter().enumerate() {
                    let o = towards[(i + r) % towards.len()];
                    let want = match o {
                        o if o > 0.0 => x.next_up(),
                        o if o < 0.0 => x.next_down(),
                        _ => x,
                    };
                    let w = L::WIDTH;
                    let got = step.lane(i).to_bits();
                    assert_eq!(got, want.to_bits(), "{w} step {x:e} towards {o}");
                }
            }
            for (i, &x) in half.iter().enumerate() {
                let w = L::WIDTH;
                assert_eq!(
                    up.lane(i).to_bits(),
                    x.next_up().to_bits(),
                    "{w} up {x:e} {:#x}",
                    x.to_bits()
                );
                assert_eq!(
                    down.lane(i).to_bits(),
                    x.next_down().to_bits(),
                    "{w} down {x:e} {:#x}",
                    x.to_bits()
                );
            }
        }
    }
    for c in xs.chunks(16) {
        let mut chunk = [0.0f32; 16];
        for (i, &b) in c.iter().enumerate() {
            chunk[i] = f32::from_bits(b);
        }
        check::<f32>(&chunk);
        check::<Vec4>(&chunk);
        check::<f32x8>(&chunk);
        check::<F32x16>(&chunk);
    }
}

#[test]
fn next_up_and_down_match_std_at_the_edges() {
    // ±0, subnormals, the normal boundary, one, MAX, ±∞, the NaN boundaries (quiet,
    // signalling, negative), each with its neighbourhood.
    let edges = [
        0u32,
        1,
        2,
        0x007f_fffe,
        0x007f_ffff,
        0x0080_0000,
        0x0080_0001,
        0x3f80_0000,
        0x7f7f_ffff,
        0x7f80_0000,
        0x7f80_0001,
        0x7fbf_ffff,
        0x7fc0_0000,
        0x7fff_ffff,
    ];
    let mut xs = Vec::new();
    for e in edges {
        for sign in [0, 0x8000_0000u32] {
            for d in -64i32..=64 {
                xs.push((e as i32).wrapping_add(d) as u32 | sign);
            }
        }
    }
    check_next(&xs);
}

#[test]
fn next_up_and_down_match_std_on_a_sweep_of_all_floats() {
    // Every 997th bit pattern (4.3 M floats, every exponent and both signs).
    let xs: Vec<u32> = (0..=u32::MAX / 997).map(|i| i * 997).collect();
    check_next(&xs);
}

proptest::proptest! {
    #[test]
    fn next_up_and_down_match_std_on_random_bits(bits in proptest::collection::vec(proptest::prelude::any::<u32>(), 16)) {
        check_next(&bits);
    }
}

#[test]
fn every_width_follows_the_same_min_max_and_mask_rules() {
    check_rules::<f32>();
    check_rules::<Vec4>();
    check_rules::<f32x8>();
    check_rules::<F32x16>();
}

/// `-` on 16 lanes is what `-` is on 8 (0 − x, so +0 for +0), lane for lane: generic
/// kernels that negate give the same bits at both widths.
#[test]
fn sixteen_lanes_negate_as_eight_do() {
    let v = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f32::INFINITY,
        f32::from_bits(1),
        3.5,
        -2.25,
    ];
    let eight = -f32x8::from(v);
    let sixteen = -F32x16::from_fn(|i| v[i % 8]);
    for i in 0..16 {
        assert_eq!(
            sixteen.lane(i).to_bits(),
            eight.lane(i % 8).to_bits(),
            "lane {i}"
        );
    }
    assert_eq!((-F32x16::splat(0.0)).lane(3).to_bits(), 0);
}
