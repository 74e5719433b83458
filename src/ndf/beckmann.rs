//! Beckmann microfacet distribution, anisotropic, with exact visible-normal
//! sampling over the full sphere of view directions (slope-space method of
//! Heitz and d'Eon 2014, solved in f64 in a scaled form that stays finite
//! for up-welling views whose visible area is tiny).

use crate::math::{FRAC_1_SQRT_PI, erf, erfc, erfcx_pos, erfinv_fast};
use glam::Vec3;
use std::f32::consts::PI;

/// D(m) for a unit normal `m` (0 below the macro-surface).
#[inline]
pub fn d(ax: f32, ay: f32, m: Vec3) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let z2 = m.z * m.z;
    let e = ((m.x / ax).powi(2) + (m.y / ay).powi(2)) / z2;
    (-e).exp() / (PI * ax * ay * z2 * z2)
}

/// Projected area `sigma(v) = (1 + Lambda(v)) v.z`; one analytic expression
/// covers the whole sphere:
/// `z (1 + erf(a)) / 2 + alpha_w s exp(-a^2) / (2 sqrt(pi))`,
/// `a = z / (alpha_w s)`, `s = sin(theta)`.
pub fn sigma(ax: f32, ay: f32, v: Vec3) -> f32 {
    let z = v.z as f64;
    let r = (((ax * v.x) as f64).powi(2) + ((ay * v.y) as f64).powi(2)).sqrt();
    if r == 0.0 {
        return z.max(0.0) as f32;
    }
    let a = z / r;
    let s = if a >= 0.0 {
        0.5 * z * (2.0 - erfc(a)) + 0.5 * r * FRAC_1_SQRT_PI * (-a * a).exp()
    } else {
        // exp(-a^2) [z erfcx(|a|) + r / sqrt(pi)] / 2, no cancellation.
        0.5 * (-a * a).exp() * (z * erfcx_pos(-a) + r * FRAC_1_SQRT_PI)
    };
    s.max(0.0) as f32
}

/// Smith Lambda of the unit direction `v` for `v.z > 0` (infinite at z = 0).
pub fn lambda_upper(ax: f32, ay: f32, v: Vec3) -> f32 {
    let z = v.z as f64;
    if z <= 0.0 {
        return f32::INFINITY;
    }
    let r = (((ax * v.x) as f64).powi(2) + ((ay * v.y) as f64).powi(2)).sqrt();
    if r == 0.0 {
        return 0.0;
    }
    let a = z / r;
    // (erf(a) - 1)/2 + exp(-a^2)/(2 a sqrt(pi)) = exp(-a^2) (1/(a sqrt(pi)) - erfcx(a)) / 2
    let l = 0.5 * (-a * a).exp() * (FRAC_1_SQRT_PI / a - erfcx_pos(a));
    l.max(0.0) as f32
}

/// log of the unnormalised CDF of the visible slope x for `cot(theta) = a`:
/// `F(x) = integral_{-inf}^{x} (a - t) exp(-t^2) / sqrt(pi) dt`, `x <= a`.
fn log_cdf(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        let inner = a * erfcx_pos(-x) + FRAC_1_SQRT_PI;
        -x * x + (0.5 * inner).max(1e-300).ln()
    } else {
        let f = 0.5 * a * (1.0 + erf(x)) + 0.5 * FRAC_1_SQRT_PI * (-x * x).exp();
        f.max(1e-300).ln()
    }
}

/// `log F(x)` and `d/dx log F(x)` together (they share the special functions).
#[inline]
fn log_cdf_and_slope(a: f64, x: f64) -> (f64, f64) {
    if x <= 0.0 {
        let inner = (a * erfcx_pos(-x) + FRAC_1_SQRT_PI).max(1e-300);
        (
            -x * x + (0.5 * inner).ln(),
            2.0 * (a - x) * FRAC_1_SQRT_PI / inner,
        )
    } else {
        let g = FRAC_1_SQRT_PI * (-x * x).exp();
        let f = (0.5 * a * (1.0 + erf(x)) + 0.5 * g).max(1e-300);
        (f.ln(), (a - x) * g / f)
    }
}

/// Samples the first slope coordinate with density proportional to
/// `(a - x) exp(-x^2)` on `x < a` by safeguarded Newton iteration on log F,
/// started from the quantile of the Gaussian truncated at `a` (exact as
/// `a -> inf`), to a tolerance of 1e-7 (below the f32 resolution of the
/// normal it produces).
fn sample_slope_x(a: f64, u: f64) -> f64 {
    let u = u.clamp(1e-12, 1.0);
    let target = log_cdf(a, a) + u.ln();
    let mut hi = a;
    let mut x = if a > -1.0 {
        erfinv_fast((u * (1.0 + erf(a)) - 1.0).clamp(-1.0 + 1e-15, 1.0 - 1e-15)).min(a)
    } else {
        // Far below: x = a - t with t ~ Gamma(2, 2|a|) to first order;
        // start at its median 1.68 / (2|a|).
        a - 1.68 / (2.0 * -a)
    };
    let mut lo = x.min(a) - 1.0;
    let mut step = 1.0;
    while log_cdf(a, lo) > target {
        step *= 2.0;
        lo -= step;
        if lo < -1e6 {
            break;
        }
    }
    if !(x > lo && x < hi) {
        x = 0.5 * (lo + hi);
    }
    for _ in 0..60 {
        let (l, dl) = log_cdf_and_slope(a, x);
        let g = l - target;
        if g > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let mut next = x - g / dl;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        let done = (next - x).abs() < 1e-7 * (1.0 + x.abs()) || hi - lo < 1e-9 * (1.0 + x.abs());
        x = next;
        if done {
            break;
        }
    }
    x
}

/// Visible normal sampling from direction `v` (any hemisphere; its visible
/// normals have density `max(0, v.m) D(m) / sigma(v)`).
pub fn sample_visible(ax: f32, ay: f32, v: Vec3, u1: f32, u2: f32) -> Vec3 {
    let vs = Vec3::new(ax * v.x, ay * v.y, v.z).as_dvec3().normalize();
    let sin_theta = (vs.x * vs.x + vs.y * vs.y).sqrt();
    let (sx, sy) = if sin_theta < 1e-7 {
        // Normal incidence: slopes are two independent N(0, 1/2).
        if vs.z <= 0.0 {
            return Vec3::Z; // nothing is visible from straight below
        }
        let r = (-(1.0 - u1 as f64).max(1e-300).ln()).sqrt();
        let phi = 2.0 * std::f64::consts::PI * u2 as f64;
        (r * phi.cos(), r * phi.sin())
    } else {
        let a = (vs.z / sin_theta).max(-1e4);
        let x = sample_slope_x(a, u1 as f64);
        let y = erfinv_fast((2.0 * u2 as f64 - 1.0).clamp(-1.0 + 1e-15, 1.0 - 1e-15));
        let (cp, sp) = (vs.x / sin_theta, vs.y / sin_theta);
        (cp * x - sp * y, sp * x + cp * y)
    };
    let m = glam::DVec3::new(-sx * ax as f64, -sy * ay as f64, 1.0).normalize();
    let m = m.as_vec3();
    if m.is_finite() { m } else { Vec3::Z }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The visible-slope sampler against its 1D density for views from above
    /// and below (a = cot theta of either sign).
    #[test]
    fn slope_sampler_matches_density() {
        for a in [-3.0f64, -1.0, -0.2, 0.0, 0.5, 2.0, 6.0] {
            let n = 200_000;
            let (lo, hi) = (a - 4.0, a);
            let bins = 40;
            let mut hist = vec![0.0f64; bins];
            for i in 0..n {
                let u = (i as f64 + 0.5) / n as f64;
                let x = sample_slope_x(a, u);
                assert!(x <= a + 1e-9, "a {a}: x {x}");
                if x >= lo {
                    let b = (((x - lo) / (hi - lo)) * bins as f64) as usize;
                    hist[b.min(bins - 1)] += 1.0;
                }
            }
            let norm = log_cdf(a, a).exp();
            for (b, h) in hist.iter().enumerate() {
                let x0 = lo + (hi - lo) * b as f64 / bins as f64;
                let x1 = lo + (hi - lo) * (b + 1) as f64 / bins as f64;
                let p = (log_cdf(a, x1).exp() - log_cdf(a, x0).exp()) / norm;
                let got = h / n as f64;
                assert!(
                    (got - p).abs() < 1e-4 + 1e-3 * p,
                    "a {a} bin {b}: {got} vs {p}"
                );
            }
        }
    }
}
