//! Special functions the NDFs and Fresnel terms need, in f64.

use std::f64::consts::PI;

// SAFETY: `erf` and `erfc` are the C99 math-library functions: pure functions
// of one double, thread-safe, touching no memory of ours. The C math library is
// linked by std on every supported target.
unsafe extern "C" {
    #[link_name = "erf"]
    safe fn c_erf(x: f64) -> f64;
    #[link_name = "erfc"]
    safe fn c_erfc(x: f64) -> f64;
}

/// 1 / sqrt(pi).
pub const FRAC_1_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// The error function.
#[inline]
pub fn erf(x: f64) -> f64 {
    c_erf(x)
}

/// The complementary error function, accurate in the tail.
#[inline]
pub fn erfc(x: f64) -> f64 {
    c_erfc(x)
}

/// Scaled complementary error function `exp(x^2) erfc(x)` for `x >= 0`
/// (its asymptotic series beyond 25, where `erfc` underflows).
pub fn erfcx_pos(x: f64) -> f64 {
    debug_assert!(x >= 0.0 || x.is_nan());
    if x < 25.0 {
        (x * x).exp() * erfc(x)
    } else {
        let r = 1.0 / (x * x);
        FRAC_1_SQRT_PI / x * (1.0 - 0.5 * r + 0.75 * r * r - 1.875 * r * r * r)
    }
}

/// Inverse error function on (-1, 1): Giles' single-precision polynomial
/// ("Approximating the erfinv function", 2010) refined by two Newton steps.
pub fn erfinv(x: f64) -> f64 {
    let mut y = erfinv_fast(x);
    if !y.is_finite() {
        return y;
    }
    for _ in 0..2 {
        let e = erf(y) - x;
        y -= e / (2.0 * FRAC_1_SQRT_PI * (-y * y).exp());
    }
    y
}

/// Giles' single-precision inverse error function without refinement
/// (relative error about 1e-6): enough where the result becomes an f32 or
/// a Newton starting point.
pub fn erfinv_fast(x: f64) -> f64 {
    if x <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if x >= 1.0 {
        return f64::INFINITY;
    }
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let mut p;
    if w < 5.0 {
        w -= 2.5;
        p = 2.810_226_36e-08;
        p = 3.432_739_39e-07 + p * w;
        p = -3.523_387_7e-06 + p * w;
        p = -4.391_506_54e-06 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725_03 + p * w;
        p = -0.004_177_681_64 + p * w;
        p = 0.246_640_727 + p * w;
        p = 1.501_409_41 + p * w;
    } else {
        w = w.sqrt() - 3.0;
        p = -0.000_200_214_257;
        p = 0.000_100_950_558 + p * w;
        p = 0.001_349_343_22 + p * w;
        p = -0.003_673_428_44 + p * w;
        p = 0.005_739_507_73 + p * w;
        p = -0.007_622_461_3 + p * w;
        p = 0.009_438_870_47 + p * w;
        p = 1.001_674_06 + p * w;
        p = 2.832_976_82 + p * w;
    }
    p * x
}

/// ln Gamma(x) for x > 0 (Lanczos, g = 7, n = 9; relative error ~1e-15).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The Beta function B(a, b) = Gamma(a) Gamma(b) / Gamma(a + b), a, b > 0.
pub fn beta(a: f64, b: f64) -> f64 {
    (ln_gamma(a) + ln_gamma(b) - ln_gamma(a + b)).exp()
}

/// The `x` in `[lo, hi]` where the increasing function `f` reaches `y`, by
/// 60 bisection steps (to f64 precision for intervals of order 1; `lo` or
/// `hi` when `y` lies outside `f`'s range there). For tables built once,
/// not for eval.
pub fn invert_increasing(f: impl Fn(f64) -> f64, y: f64, lo: f64, hi: f64) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < y {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfinv_inverts_erf() {
        for i in -99..100 {
            let x = i as f64 / 100.0;
            let y = erfinv(x);
            assert!((erf(y) - x).abs() < 1e-13, "x = {x}");
        }
    }

    #[test]
    fn fast_erfinv_is_single_precision() {
        for i in -999..1000 {
            let x = i as f64 / 1000.0;
            let y = erfinv_fast(x);
            assert!((y - erfinv(x)).abs() <= 2e-6 * (1.0 + y.abs()), "x = {x}");
        }
    }

    #[test]
    fn erfcx_continuous_at_switch() {
        let a = (25.0f64 * 25.0).exp() * erfc(25.0);
        let b = erfcx_pos(25.0);
        assert!((a - b).abs() / b < 1e-9);
    }

    #[test]
    fn gamma_known_values() {
        // Gamma(5) = 24, Gamma(1/2) = sqrt(pi), B(2, 3) = 1/12.
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        assert!((beta(2.0, 3.0) - 1.0 / 12.0).abs() < 1e-13);
    }
}
