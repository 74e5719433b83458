//! PCG32 random numbers, bit-identical to the reference `pcg32_random_r` /
//! `pcg32_srandom_r` (O'Neill's minimal C implementation) and to
//! `rand_pcg::Pcg32`.
//!
//! Every stochastic model draws its random numbers from an [`Rng`] owned by the
//! caller, so the same build, seed, stream and inputs give the same bits on any
//! thread.

const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

/// A PCG32 generator (XSH-RR output, 64-bit LCG state).
///
/// The layout (`state`, `inc`) is the one of `pcg32_random_t`, so the state can
/// be serialised or handed to C code unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Rng {
    /// LCG state.
    pub state: u64,
    /// LCG increment; always odd.
    pub inc: u64,
}

impl Rng {
    /// Seeds as `pcg32_srandom_r(rng, seed, stream)`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// Next 32 random bits, as `pcg32_random_r`.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc | 1);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in `[0, 1)`: the top 24 bits of [`Rng::next_u32`] times
    /// 2^-24, so 1.0 is never returned (a plain `x * 2^-32` can round to 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        unit_f32(self.next_u32())
    }

    /// A uniform double in `[0, 1)` built from two outputs (53 bits).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() >> 5) as u64; // 27 bits
        let lo = (self.next_u32() >> 6) as u64; // 26 bits
        ((hi << 26) | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }
}

/// Maps 32 random bits to `[0, 1)`: the top 24 bits times 2^-24.
#[inline]
fn unit_f32(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_values_seed42_stream54() {
        let mut r = Rng::new(42, 54);
        let got: Vec<u32> = (0..6).map(|_| r.next_u32()).collect();
        // pcg32-demo output for pcg32_srandom_r(&rng, 42u, 54u).
        assert_eq!(
            got,
            [
                0xa15c02b7, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e
            ]
        );
    }

    #[test]
    fn floats_in_unit_interval() {
        let mut r = Rng::new(1, 2);
        for _ in 0..100_000 {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            let y = r.next_f64();
            assert!((0.0..1.0).contains(&y));
        }
        // next_f32 is exactly the mapping of next_u32 ...
        let (mut a, mut b) = (Rng::new(7, 3), Rng::new(7, 3));
        for _ in 0..1000 {
            assert_eq!(a.next_f32(), unit_f32(b.next_u32()));
        }
        // ... whose extremes stay in [0, 1): an all-ones output maps to the
        // largest f32 below 1 (a plain `x * 2^-32` would round to 1.0).
        assert_eq!(unit_f32(u32::MAX), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(unit_f32(0), 0.0);
        assert_eq!(unit_f32(255), 0.0);
        assert_eq!(unit_f32(256), 1.0 / 16_777_216.0);
        assert_eq!(u32::MAX as f32 * (1.0 / 4_294_967_296.0), 1.0);
    }
}
