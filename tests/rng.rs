//! PCG32: bit-identical to the reference generator and to rand_pcg.

use msbsdf::Rng;
use rand_core::RngCore;

#[test]
fn stream_equals_rand_pcg_for_a_million_outputs() {
    let mut ours = Rng::new(42, 54);
    let mut oracle = rand_pcg::Pcg32::new(42, 54);
    for i in 0..1_000_000 {
        assert_eq!(ours.next_u32(), oracle.next_u32(), "output {i}");
    }
    // Another seed and stream, including the high bit of the stream.
    let mut ours = Rng::new(0xdead_beef, 1 << 62);
    let mut oracle = rand_pcg::Pcg32::new(0xdead_beef, 1 << 62);
    for i in 0..10_000 {
        assert_eq!(ours.next_u32(), oracle.next_u32(), "output {i}");
    }
}

#[test]
fn first_outputs_match_pcg32_demo() {
    let mut r = Rng::new(42, 54);
    let expect = [
        0xa15c02b7u32,
        0x7b47f409,
        0xba1d3330,
        0x83d2f293,
        0xbfa4784b,
        0xcbed606e,
    ];
    for e in expect {
        assert_eq!(r.next_u32(), e);
    }
}

#[test]
fn floats_are_in_unit_interval_and_uniform() {
    let mut r = Rng::new(3, 4);
    let n = 1_000_000;
    let mut bins = [0u32; 10];
    for _ in 0..n {
        let x = r.next_f32();
        assert!((0.0..1.0).contains(&x), "{x}");
        bins[(x * 10.0) as usize] += 1;
    }
    // Each decile holds n/10 +- 4 sigma (sigma = sqrt(n p (1-p)) = 300).
    for b in bins {
        assert!((b as f64 - 100_000.0).abs() < 1200.0, "{bins:?}");
    }
}
