//! Beckmann microfacet distribution, anisotropic, with exact visible-normal
//! sampling over the full sphere of view directions (slope-space method of
//! Heitz and d'Eon 2014, solved in f64 in a scaled form that stays finite
//! for up-welling views whose visible area is tiny).

use crate::math::{FRAC_1_SQRT_PI, erfc, erfcx_pos, erfinv_fast};
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

/// Smith `Lambda` for `v.z > 0` by the rational fit of Walter et al.
/// 2007 (eq. 27, `G1 ~ (3.535 a + 2.181 a^2) / (1 + 2.276 a + 2.577 a^2)`
/// for `a < 1.6`, 1 above, with `a = 1 / (alpha_w tan theta)`), written
/// as `Lambda = 1 / G1 - 1 = (1 - 1.259 a + 0.396 a^2) / (3.535 a + 2.181
/// a^2)`: f32 and one division, where [`lambda_upper`] needs f64 `exp`
/// and `erfcx`. For the tabulated tier's peaked lobe only, whose
/// normalisation and furnace correction are solved with this same form;
/// relative error of `G1` within about 0.4% (`tests` below).
#[inline]
pub fn lambda_rational(ax: f32, ay: f32, v: Vec3) -> f32 {
    let r2 = (ax * v.x) * (ax * v.x) + (ay * v.y) * (ay * v.y);
    // a >= 1.6 (also r = 0): Lambda = 0.
    if v.z * v.z >= 2.56 * r2 {
        return 0.0;
    }
    let a = v.z / r2.sqrt();
    (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
}

/// Split between the two forms of `H` in [`h_and_e`].
const A_FAR: f64 = -20.0;

/// `sqrt(pi)`.
const SQRT_PI: f64 = 1.772_453_850_905_516;

/// `R(X) = 1 - sqrt(pi) X erfcx(X)` for `X >= 20` by its asymptotic series
/// (`sqrt(pi) X erfcx(X) ~ sum_k (-1)^k (2k-1)!! / (2 X^2)^k`; the first
/// omitted term is below 1e-10 of the sum at X = 20).
#[inline]
fn r_tail(x: f64) -> f64 {
    let r = 1.0 / (x * x);
    r * (0.5 + r * (-0.75 + r * (1.875 + r * (-6.5625 + r * (29.531_25 + r * -162.421_875)))))
}

/// Unnormalised CDF of the visible slope as a function of `t = a - x >= 0`:
/// `H(t) = 2 int_{-inf}^{a-t} (a - s) exp(-s^2) ds
///       = a sqrt(pi) erfc(t - a) + exp(-(a - t)^2)`
/// (Heitz and d'Eon 2014, the slope CDF of the Beckmann visible normals),
/// together with `E = exp(-(a - t)^2)` so that `H'(t) = -2 t E`.
/// For `a < A_FAR` both are scaled by `exp(a^2)` and `H` is written as
/// `E (t + |a| R(|a| + t)) / (|a| + t)`, which has no cancellation (the
/// direct form loses `log10(2 a^2)` digits).
#[inline]
fn h_and_e(a: f64, t: f64) -> (f64, f64) {
    if a >= A_FAR {
        let x = a - t;
        let e = (-x * x).exp();
        (a * SQRT_PI * erfc(-x) + e, e)
    } else {
        let b = -a;
        let e = (-t * (2.0 * b + t)).exp();
        let xx = b + t;
        (e * (t + b * r_tail(xx)) / xx, e)
    }
}

/// `H(0)`, the total mass, in the same scaling as [`h_and_e`].
#[inline]
fn h_total(a: f64) -> f64 {
    if a >= 6.0 {
        // erfc(-a) = 2 - erfc(a) rounds to 2 and exp(-a^2) is below 1e-17
        // of the sum: exactly the f64 value of the full expression.
        2.0 * SQRT_PI * a
    } else if a >= A_FAR {
        a * SQRT_PI * erfc(-a) + (-a * a).exp()
    } else {
        r_tail(-a)
    }
}

/// Rows of [`GUESS`]: `q = a / (1 + |a|)` on [-1, 1].
const GUESS_NQ: usize = 33;
/// Columns of [`GUESS`]: `z = erfinv(2u - 1)` on [`GUESS_Z0`, `GUESS_Z1`].
const GUESS_NZ: usize = 39;
/// First column of [`GUESS`].
const GUESS_Z0: f64 = -5.25;
/// Last column of [`GUESS`].
const GUESS_Z1: f64 = 4.25;

/// `g(a) = sqrt(a^2 + 2) - a`, which makes `y = t g(a)` bounded in both limits
/// (`y -> 1 - z / a` as `a -> inf`; `y ->` the Gamma(2, 1) quantile as
/// `a -> -inf`, where `t ~ Gamma(2, 2|a|)`).
#[inline]
fn guess_scale(a: f64) -> f64 {
    let s = (a * a + 2.0).sqrt();
    if a > 0.0 { 2.0 / (s + a) } else { s - a }
}

/// Bilinear lookup of `ln y` in [`GUESS`] at `(a, z)`.
#[inline]
fn guess_ln_y(a: f64, z: f64) -> f64 {
    let q = a / (1.0 + a.abs());
    let last_q = (GUESS_NQ - 1) as f64;
    let last_z = (GUESS_NZ - 1) as f64;
    let fq = ((q + 1.0) * 0.5 * last_q).clamp(0.0, last_q - 1e-9);
    let fz = ((z - GUESS_Z0) / (GUESS_Z1 - GUESS_Z0) * last_z).clamp(0.0, last_z - 1e-9);
    let (i, j) = (fq as usize, fz as usize);
    let (wq, wz) = (fq - i as f64, fz - j as f64);
    let (r0, r1) = (&GUESS[i], &GUESS[(i + 1).min(GUESS_NQ - 1)]);
    let j1 = (j + 1).min(GUESS_NZ - 1);
    let v0 = r0[j] as f64 + wz * (r0[j1] as f64 - r0[j] as f64);
    let v1 = r1[j] as f64 + wz * (r1[j1] as f64 - r1[j] as f64);
    v0 + wq * (v1 - v0)
}

/// `exp(x)` to about 2e-8 relative for `|x| < 700`: range reduction by
/// `ln 2` and a degree-7 Taylor polynomial (only for the starting point).
#[inline]
fn exp_rough(x: f64) -> f64 {
    const SHIFTER: f64 = 6_755_399_441_055_744.0; // 1.5 * 2^52: rounds to an integer
    let x = x.clamp(-700.0, 700.0);
    let k = (x * std::f64::consts::LOG2_E + SHIFTER) - SHIFTER;
    let r = x - k * std::f64::consts::LN_2;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0
                    + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r / 5040.0))))));
    p * f64::from_bits(((k as i64 + 1023) as u64) << 52)
}

/// Samples the first slope coordinate with density proportional to
/// `(a - x) exp(-x^2)` on `x < a` (Heitz and d'Eon 2014) by inverting its
/// CDF exactly: Halley iteration on `H(t) = u H(0)` in `t = a - x`, started
/// from a tabulated inverse ([`GUESS`], bilinear in
/// `(a / (1 + |a|), erfinv(2u - 1))`), safeguarded by a bracket, and stopped
/// once the error predicted from the last step is below 5e-8 of the slope
/// scale `min(1 + |x|, t + 1 / (1 + 2|a|))` (below the f32 resolution of
/// the normal it produces; the second term is the width of the
/// distribution for views from far below). One evaluation of `erfc` and
/// `exp` besides `H(0)` in 99.5% of samples over the sphere of views.
///
/// Measured against bisection to 1e-14 over a in [-1e4, 1e4] and u in
/// [1e-12, 1 - 6e-8]: error at most 5.0e-8 of that scale. (The previous
/// solver, Newton on log F stopped at steps below 1e-7 (1 + |x|), was off by
/// up to 0.54 of the distribution width for a < -1000 and 5e-5 at a = -100.)
fn sample_slope_x(a: f64, u: f64) -> f64 {
    solve_slope_x(a, u).0
}

/// [`sample_slope_x`] and the number of evaluations of `H(t)` it took.
#[inline(always)]
fn solve_slope_x(a: f64, u: f64) -> (f64, u32) {
    let u = u.clamp(1e-12, 1.0);
    if u >= 1.0 {
        return (a, 0);
    }
    let target = u * h_total(a);
    let z = erfinv_fast(2.0 * u - 1.0);
    let mut t = exp_rough(guess_ln_y(a, z)) / guess_scale(a);
    let scale = 1.0 / (1.0 + 2.0 * a.abs());
    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
    let mut evals = 0;
    for _ in 0..100 {
        evals += 1;
        let (h, e) = h_and_e(a, t);
        let f = h - target;
        if f > 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        let tol = 1e-7 * (1.0 + (a - t).abs()).min(t + scale);
        // f' = -2 t E; c2 = f'' / (2 f'), c3 = f''' / (6 f') in closed form.
        let newton = f / (-2.0 * t * e);
        let c2 = (1.0 + 2.0 * t * (a - t)) / (2.0 * t);
        let den = 1.0 - newton * c2;
        let halley = den > 0.5;
        let step = if halley { newton / den } else { newton };
        let next = t - step;
        if next > lo && next < hi {
            // Predicted error of `next`: (c2^2 - c3) step^3 after Halley,
            // c2 step^2 after Newton.
            let c3 = ((a - t) * (2.0 + 4.0 * t * (a - t)) + 2.0 * a - 4.0 * t) / (6.0 * t);
            let err = if halley {
                (c2 * c2 - c3).abs() * step.abs().powi(3)
            } else {
                c2.abs() * step * step
            };
            t = next;
            if step.abs() < tol || err < 0.5 * tol {
                break;
            }
        } else {
            t = if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * t + scale
            };
            if hi - lo < tol {
                break;
            }
        }
    }
    (a - t, evals)
}

/// Visible normal sampling from direction `v` (any hemisphere; its visible
/// normals have density `max(0, v.m) D(m) / sigma(v)`).
pub fn sample_visible(ax: f32, ay: f32, v: Vec3, u1: f32, u2: f32) -> Vec3 {
    // The stretched view; only its direction matters (a = cot theta and the
    // azimuth are ratios), so it is not normalised.
    let vs = Vec3::new(ax * v.x, ay * v.y, v.z).as_dvec3();
    let r = (vs.x * vs.x + vs.y * vs.y).sqrt();
    let (sx, sy) = if r < 1e-7 * (r * r + vs.z * vs.z).sqrt() {
        // Normal incidence: slopes are two independent N(0, 1/2).
        if vs.z <= 0.0 {
            return Vec3::Z; // nothing is visible from straight below
        }
        let r = (-(1.0 - u1 as f64).max(1e-300).ln()).sqrt();
        let phi = 2.0 * std::f64::consts::PI * u2 as f64;
        (r * phi.cos(), r * phi.sin())
    } else {
        let inv_r = 1.0 / r;
        let a = (vs.z * inv_r).max(-1e4);
        let x = sample_slope_x(a, u1 as f64);
        let y = erfinv_fast((2.0 * u2 as f64 - 1.0).clamp(-1.0 + 1e-15, 1.0 - 1e-15));
        let (cp, sp) = (vs.x * inv_r, vs.y * inv_r);
        (cp * x - sp * y, sp * x + cp * y)
    };
    let m = glam::DVec3::new(-sx * ax as f64, -sy * ay as f64, 1.0).normalize();
    let m = m.as_vec3();
    if m.is_finite() { m } else { Vec3::Z }
}

/// Tabulated `ln(t g(a))` of the visible-slope quantile (see [`guess_ln_y`]);
/// regenerate with `MSBSDF_PRINT_BECKMANN_GUESS=1 cargo test --lib guess_table`.
#[rustfmt::skip]
const GUESS: [[f32; GUESS_NZ]; GUESS_NQ] = [
    [3.5281444e0, 3.4458938e0, 3.360437e0, 3.2715325e0, 3.1789124e0, 3.0822787e0, 2.9812982e0, 2.8755984e0, 2.764761e0, 2.6483145e0, 2.5257268e0, 2.3963935e0, 2.2596283e0, 2.114648e0, 1.9605566e0, 1.7963266e0, 1.6207771e0, 1.4325489e0, 1.2300766e0, 1.0115583e0, 7.7492476e-1, 5.178094e-1, 2.3752496e-1, -6.8947755e-2, -4.0495086e-1, -7.7410984e-1, -1.1802549e0, -1.6273003e0, -2.1190863e0, -2.6592042e0, -3.2508368e0, -3.8966434e0, -4.5987167e0, -5.3586125e0, -6.177433e0, -7.055931e0, -7.994619e0, -8.993848e0, -1.005387e1],
    [3.4915032e0, 3.4119277e0, 3.3290467e0, 3.2426167e0, 3.1523674e0, 3.0579994e0, 2.959178e0, 2.855529e0, 2.746633e0, 2.6320176e0, 2.5111492e0, 2.3834233e0, 2.2481532e0, 2.1045554e0, 1.9517345e0, 1.7886637e0, 1.6141634e0, 1.426876e0, 1.2252384e0, 1.007452e0, 7.714512e-1, 5.1487404e-1, 2.3503904e-1, -7.106654e-2, -4.0677723e-1, -7.757099e-1, -1.1816858e0, -1.6286094e0, -2.1203113e0, -2.6603742e0, -3.2519724e0, -3.8977587e0, -4.5998206e0, -5.3597107e0, -6.178527e0, -7.057026e0, -7.995732e0, -8.99498e0, -1.0055748e1],
    [3.3873398e0, 3.3141232e0, 3.237514e0, 3.1572535e0, 3.0730562e0, 2.9846053e0, 2.891549e0, 2.7934968e0, 2.690011e0, 2.580602e0, 2.4647188e0, 2.3417408e0, 2.210965e0, 2.0715933e0, 1.9227171e0, 1.7632979e0, 1.5921468e0, 1.4078996e0, 1.2089897e0, 9.936183e-1, 7.5972337e-1, 5.049511e-1, 2.266327e-1, -7.822737e-2, -4.129417e-1, -7.8110105e-1, -1.186497e0, -1.6330023e0, -2.1244154e0, -2.6642885e0, -3.2557683e0, -3.9014845e0, -4.6035075e0, -5.3633776e0, -6.1821847e0, -7.060677e0, -7.999361e0, -8.9985895e0, -1.0058583e1],
    [3.243979e0, 3.17733e0, 3.107396e0, 3.0339038e0, 2.956552e0, 2.8750045e0, 2.788888e0, 2.6977851e0, 2.60123e0, 2.4987001e0, 2.389609e0, 2.2732973e0, 2.1490204e0, 2.015937e0, 1.8730938e0, 1.7194082e0, 1.553648e0, 1.3744093e0, 1.1800901e0, 9.688628e-1, 7.386453e-1, 4.8707375e-1, 2.1148033e-1, -9.111678e-2, -4.2400423e-1, -7.9073524e-1, -1.195054e0, -1.6407793e0, -2.1316524e0, -2.6711695e0, -3.2624269e0, -3.908012e0, -4.609962e0, -5.369794e0, -6.188582e0, -7.067066e0, -8.005748e0, -9.004975e0, -1.0064992e1],
    [3.0887396e0, 3.027334e0, 2.9628482e0, 2.8950114e0, 2.8235207e0, 2.7480373e0, 2.6681807e0, 2.5835228e0, 2.493582e0, 2.3978148e0, 2.2956069e0, 2.1862633e0, 2.068997e0, 1.9429157e0, 1.8070067e0, 1.6601211e0, 1.5009542e0, 1.3280253e0, 1.1396556e0, 9.3394357e-1, 7.087413e-1, 4.6163172e-1, 1.8991163e-1, -1.0941487e-1, -4.3962508e-1, -8.0423933e-1, -1.2069479e0, -1.6514994e0, -2.1415563e0, -2.6805336e0, -3.2714531e0, -3.9168384e0, -4.618677e0, -5.378451e0, -6.197211e0, -7.075681e0, -8.014357e0, -9.013581e0, -1.0073604e1],
    [2.9370618e0, 2.8795578e0, 2.8191826e0, 2.755676e0, 2.6887455e0, 2.6180613e0, 2.543251e0, 2.4638927e0, 2.3795068e0, 2.2895484e0, 2.193396e0, 2.090341e0, 1.9795735e0, 1.8601671e0, 1.7310638e0, 1.591055e0, 1.4387621e0, 1.2726165e0, 1.0908393e0, 8.9142126e-1, 6.72105e-1, 4.3037093e-1, 1.6342905e-1, -1.317778e-1, -4.585553e-1, -8.204155e-1, -1.2210047e0, -1.663998e0, -2.1529639e0, -2.6912172e0, -3.281682e0, -3.926798e0, -4.628487e0, -5.3881817e0, -6.206903e0, -7.085356e0, -8.024024e0, -9.023245e0, -1.0083267e1],
    [2.796245e0, 2.7416346e0, 2.6843326e0, 2.6240926e0, 2.560636e0, 2.4936478e0, 2.4227698e0, 2.3475947e0, 2.2676568e0, 2.1824229e0, 2.091281e0, 1.9935268e0, 1.8883489e0, 1.7748114e0, 1.6518345e0, 1.5181735e0, 1.3723962e0, 1.2128608e0, 1.0376934e0, 8.447697e-1, 6.317018e-1, 3.958323e-1, 1.3423882e-1, -1.5624821e-1, -4.7901207e-1, -8.3759665e-1, -1.2356303e0, -1.6767244e0, -2.164351e0, -2.70171e0, -3.2916117e0, -3.9363935e0, -4.637896e0, -5.3974934e0, -6.2161665e0, -7.0945973e0, -8.033256e0, -9.032472e0, -1.0092488e1],
    [2.6693382e0, 2.6169116e0, 2.561941e0, 2.504192e0, 2.4434013e0, 2.3792682e0, 2.311451e0, 2.2395597e0, 2.163146e0, 2.081695e0, 1.9946122e0, 1.901209e0, 1.8006866e0, 1.6921169e0, 1.5744194e0, 1.4463375e0, 1.3064114e0, 1.1529509e0, 9.8400956e-1, 7.973631e-1, 5.9049636e-1, 3.606028e-1, 1.0460046e-1, -1.8083292e-1, -4.992056e-1, -8.5413927e-1, -1.2492808e0, -1.6882001e0, -2.174279e0, -2.710599e0, -3.299843e0, -3.944234e0, -4.645518e0, -5.405e0, -6.2236176e0, -7.102022e0, -8.040669e0, -9.039882e0, -1.0099898e1],
    [2.5571296e0, 2.5063894e0, 2.4532242e0, 2.3974116e0, 2.3387003e0, 2.276804e0, 2.211397e0, 2.142105e0, 2.0684993e0, 1.9900836e0, 1.9062836e0, 1.8164316e0, 1.7197487e0, 1.6153243e0, 1.5020912e0, 1.3787982e0, 1.2439793e0, 1.0959212e0, 9.326306e-1, 7.518083e-1, 5.5083096e-1, 3.2675138e-1, 7.6321624e-2, -2.0395602e-1, -5.1775086e-1, -8.68805e-1, -1.2608235e0, -1.6973644e0, -2.1817346e0, -2.7168992e0, -3.3054092e0, -3.9493623e0, -4.650401e0, -5.409755e0, -6.228309e0, -7.106684e0, -8.045319e0, -9.044526e0, -1.0104541e1],
    [2.459128e0, 2.409719e0, 2.3579822e0, 2.3037047e0, 2.2466464e0, 2.1865335e0, 2.1230536e0, 2.0558484e0, 1.9845057e0, 1.9085482e0, 1.8274221e0, 1.7404813e0, 1.6469691e0, 1.5459971e0, 1.436519e0, 1.3172997e0, 1.1868819e0, 1.0435475e0, 8.8528055e-1, 7.0973176e-1, 5.141946e-1, 2.9560104e-1, 5.0546307e-2, -2.2464833e-1, -5.3383476e-1, -8.809087e-1, -1.2696707e0, -1.7036986e0, -2.1862454e0, -2.7201684e0, -3.3078856e0, -3.9513645e0, -4.6521378e0, -5.411352e0, -6.229837e0, -7.1081805e0, -8.046802e0, -9.046003e0, -1.0106015e1],
    [2.3741398e0, 2.325804e0, 2.2752194e0, 2.2221823e0, 2.1664617e0, 2.1077945e0, 2.0458808e0, 1.9803758e0, 1.9108822e0, 1.8369404e0, 1.7580152e0, 1.6734812e0, 1.5826049e0, 1.4845212e0, 1.3782072e0, 1.2624501e0, 1.1358098e0, 9.965772e-1, 8.427304e-1, 6.7189205e-1, 4.8129678e-1, 2.6777923e-1, 2.7795974e-2, -2.4250571e-1, -5.4716814e-1, -8.9026284e-1, -1.2757164e0, -1.7071573e0, -2.1878076e0, -2.7204297e0, -3.3073125e0, -3.9502904e0, -4.6507826e0, -5.4098487e0, -6.228261e0, -7.1065707e0, -8.045177e0, -9.044373e0, -1.01043825e1],
    [2.300659e0, 2.2532032e0, 2.2035646e0, 2.151547e0, 2.0969272e0, 2.0394514e0, 1.9788297e0, 1.9147298e0, 1.8467679e0, 1.7744994e0, 1.6974068e0, 1.6148838e0, 1.5262182e0, 1.430568e0, 1.3269349e0, 1.2141303e0, 1.0907363e0, 9.5506096e-1, 8.050883e-1, 6.3842964e-1, 4.5228162e-1, 2.4340454e-1, 8.137851e-3, -2.5753054e-1, -5.578307e-1, -8.970215e-1, -1.2791786e0, -1.7080078e0, -2.1867242e0, -2.7180097e0, -3.3040307e0, -3.9464898e0, -4.64669e0, -5.405603e0, -6.223939e0, -7.1022143e0, -8.040805e0, -9.039995e0, -1.0100002e1],
    [2.2371206e0, 2.1903982e0, 2.1415489e0, 2.0903816e0, 2.036681e0, 1.9802005e0, 1.9206601e0, 1.8577374e0, 1.7910604e0, 1.7201984e0, 1.644649e0, 1.5638238e0, 1.47703e0, 1.3834478e0, 1.2821022e0, 1.1718297e0, 1.0512366e0, 9.186524e-1, 7.7207536e-1, 6.0911727e-1, 4.2695308e-1, 2.2228922e-1, -8.630681e-3, -2.699598e-1, -5.661064e-1, -9.015196e-1, -1.2804394e0, -1.7066712e0, -2.1834447e0, -2.7133775e0, -3.298522e0, -3.9404516e0, -4.640353e0, -5.399109e0, -6.2173676e0, -7.095607e0, -8.034183e0, -9.033365e0, -1.0093371e1],
    [2.182053e0, 2.1359503e0, 2.0877676e0, 2.0373194e0, 1.9843961e0, 1.9287586e0, 1.8701341e0, 1.8082095e0, 1.7426234e0, 1.6729568e0, 1.5987213e0, 1.519344e0, 1.4341502e0, 1.3423404e0, 1.2429618e0, 1.1348749e0, 1.0167114e0, 8.868238e-1, 7.4322957e-1, 5.835494e-1, 4.0494892e-1, 2.040973e-1, -2.2838091e-2, -2.801325e-1, -5.7235867e-1, -9.041527e-1, -1.2799273e0, -1.7036049e0, -2.178449e0, -2.7070284e0, -3.2912915e0, -3.932687e0, -4.632287e0, -5.3908834e0, -6.2090635e0, -7.087267e0, -8.025826e0, -9.025003e0, -1.0085007e1],
    [2.134147e0, 2.0885737e0, 2.0409613e0, 1.9911283e0, 1.9388703e0, 1.8839545e0, 1.8261147e0, 1.7650458e0, 1.7003956e0, 1.6317556e0, 1.5586495e0, 1.480519e0, 1.3967053e0, 1.3064272e0, 1.2087531e0, 1.1025661e0, 9.865222e-1, 8.5899854e-1, 7.180339e-1, 5.612634e-1, 3.8585263e-1, 1.8844658e-1, -3.4846637e-2, -2.8840613e-1, -5.7695377e-1, -9.053049e-1, -1.2780482e0, -1.6992351e0, -2.17218e0, -2.6994178e0, -3.2828026e0, -3.9236646e0, -4.6229625e0, -5.3813996e0, -6.199501e0, -7.0776677e0, -8.0162115e0, -9.015382e0, -1.0075382e1],
    [2.092277e0, 2.0471616e0, 2.0000417e0, 1.9507407e0, 1.899058e0, 1.8447663e0, 1.7876055e0, 1.7272774e0, 1.6634377e0, 1.5956877e0, 1.5235618e0, 1.4465141e0, 1.3639007e0, 1.2749572e0, 1.1787708e0, 1.0742465e0, 9.600634e-1, 8.346227e-1, 6.959861e-1, 5.4180634e-1, 3.6925563e-1, 1.7496507e-1, -4.5002416e-2, -2.9511318e-1, -5.802224e-1, -9.0531474e-1, -1.2751532e0, -1.6939274e0, -2.1650152e0, -2.6909325e0, -3.2734487e0, -3.9137812e0, -4.6127787e0, -5.371057e0, -6.18908e0, -7.06721e0, -8.005738e0, -9.004903e0, -1.0064901e1],
    [2.0554962e0, 2.01078e0, 1.96409e0, 1.9152528e0, 1.8640721e0, 1.810325e0, 1.753757e0, 1.6940758e0, 1.6309445e0, 1.5639725e0, 1.4927039e0, 1.4166045e0, 1.3350431e0, 1.2472707e0, 1.1523924e0, 1.0493327e0, 9.3679273e-1, 8.131972e-1, 6.76631e-1, 5.2476645e-1, 3.5478675e-1, 1.6331713e-1, -5.3613085e-2, -3.005429e-1, -5.824458e-1, -9.044638e-1, -1.2715309e0, -1.687979e0, -2.1572611e0, -2.6818852e0, -3.263547e0, -3.9033568e0, -4.6020575e0, -5.360179e0, -6.178124e0, -7.0562186e0, -7.9947314e0, -8.993889e0, -1.00538845e1],
    [2.0186875e0, 1.9743688e0, 1.928107e0, 1.8797321e0, 1.8290517e0, 1.7758477e0, 1.7198707e0, 1.6608348e0, 1.5984102e0, 1.5322148e0, 1.4618027e0, 1.3866509e0, 1.3061421e0, 1.2195427e0, 1.1259762e0, 1.024388e0, 9.135026e-1, 7.917702e-1, 6.573017e-1, 5.0779325e-1, 3.4044412e-1, 1.5187997e-1, -6.1896894e-2, -3.0549312e-1, -5.840003e-1, -9.027256e-1, -1.2667906e0, -1.6806927e0, -2.1479807e0, -2.6711674e0, -3.2518742e0, -3.8910983e0, -4.5894656e0, -5.34741e0, -6.1652684e0, -7.0433226e0, -7.9818177e0, -8.980968e0, -1.0040961e1],
    [1.9767163e0, 1.9328502e0, 1.8870757e0, 1.8392267e0, 1.7891158e0, 1.7365297e0, 1.6812255e0, 1.6229244e0, 1.5613049e0, 1.4959946e0, 1.4265589e0, 1.3524884e0, 1.2731814e0, 1.1879232e0, 1.0958583e0, 9.959575e-1, 8.869736e-1, 7.673884e-1, 6.3534606e-1, 4.8857456e-1, 3.242985e-1, 1.3915226e-1, -7.088343e-2, -3.1048456e-1, -5.848748e-1, -8.9955777e-1, -1.2598902e0, -1.6705883e0, -2.135341e0, -2.6566844e0, -3.2361603e0, -3.874626e0, -4.572561e0, -5.330276e0, -6.1480207e0, -7.026022e0, -7.9644947e0, -8.963636e0, -1.0023625e1],
    [1.9286017e0, 1.8852546e0, 1.8400389e0, 1.7927934e0, 1.7433356e0, 1.6914587e0, 1.6369267e0, 1.5794688e0, 1.5187737e0, 1.4544798e0, 1.3861663e0, 1.3133394e0, 1.2354158e0, 1.1517026e0, 1.0613705e0, 9.634201e-1, 8.5663927e-1, 7.395491e-1, 6.1033654e-1, 4.66773e-1, 3.0612102e-1, 1.2503687e-1, -8.0509625e-2, -3.1526095e-1, -5.845856e-1, -8.942198e-1, -1.2498174e0, -1.6563903e0, -2.1178358e0, -2.63675e0, -3.214591e0, -3.8520446e0, -4.549401e0, -5.306808e0, -6.1244e0, -7.0023313e0, -7.9407735e0, -8.939902e0, -9.999887e0],
    [1.8731674e0, 1.8304209e0, 1.7858521e0, 1.7393049e0, 1.6906033e0, 1.6395472e0, 1.585909e0, 1.5294278e0, 1.4698031e0, 1.4066871e0, 1.3396744e0, 1.2682896e0, 1.1919718e0, 1.1100541e0, 1.0217383e0, 9.2606175e-1, 8.218553e-1, 7.0768976e-1, 5.8180755e-1, 4.4203913e-1, 2.8570336e-1, 1.0949894e-1, -9.059604e-2, -3.1937882e-1, -5.823697e-1, -8.8557655e-1, -1.23503e0, -1.6361492e0, -2.0931475e0, -2.608751e0, -3.184341e0, -3.8203921e0, -4.5169425e0, -5.273921e0, -6.0913005e0, -6.969133e0, -7.9075317e0, -8.906644e0, -9.966622e0],
    [1.8090243e0, 1.7669803e0, 1.7231678e0, 1.6774372e0, 1.6296194e0, 1.5795228e0, 1.5269296e0, 1.47159e0, 1.4132172e0, 1.3514786e0, 1.2859877e0, 1.2162913e0, 1.1418546e0, 1.0620424e0, 9.7609407e-1, 8.8309205e-1, 7.8192097e-1, 6.7121446e-1, 5.492876e-1, 4.140513e-1, 2.6290742e-1, 9.2628196e-2, -1.00766405e-1, -3.2210013e-1, -5.77037e-1, -8.718911e-1, -1.2131674e0, -1.6068506e0, -2.0576506e0, -2.5685527e0, -3.140902e0, -3.7749147e0, -4.4702873e0, -5.226637e0, -6.0437036e0, -6.9213915e0, -7.859728e0, -8.858814e0, -9.918782e0],
    [1.7345736e0, 1.6933602e0, 1.650442e0, 1.6056765e0, 1.5589032e0, 1.5099406e0, 1.458582e0, 1.4045914e0, 1.3476974e0, 1.2875865e0, 1.223894e0, 1.1561934e0, 1.0839816e0, 1.0066617e0, 9.235189e-1, 8.3369154e-1, 7.3613113e-1, 6.295518e-1, 5.12364e-1, 3.8258818e-1, 2.377471e-1, 7.473414e-2, -1.1033294e-1, -3.2224655e-1, -5.667729e-1, -8.5054135e-1, -1.1806346e0, -1.5638225e0, -2.0056057e0, -2.5094898e0, -3.0769045e0, -3.7077706e0, -4.4013095e0, -5.1566744e0, -5.973251e0, -6.850711e0, -7.7889485e0, -8.787994e0, -9.847948e0],
    [1.6480421e0, 1.6078234e0, 1.5659755e0, 1.5223651e0, 1.4768413e0, 1.4292345e0, 1.3793517e0, 1.3269727e0, 1.2718452e0, 1.2136781e0, 1.1521332e0, 1.0868158e0, 1.0172615e0, 9.4291925e-1, 8.631312e-1, 7.771044e-1, 6.838743e-1, 5.82258e-1, 4.7079024e-1, 3.476408e-1, 2.1050578e-1, 5.64695e-2, -1.18162416e-1, -3.180434e-1, -5.489335e-1, -8.1771356e-1, -1.1321034e0, -1.4999244e0, -1.9279385e0, -2.4206927e0, -2.980041e0, -3.6056516e0, -4.296086e0, -5.049771e0, -5.865507e0, -6.7425766e0, -7.680644e0, -8.679621e0, -9.739548e0],
    [1.5475656e0, 1.5085548e0, 1.468006e0, 1.4257959e0, 1.3817862e0, 1.335821e0, 1.2877237e0, 1.2372934e0, 1.1843002e0, 1.1284797e0, 1.069526e0, 1.0070826e0, 9.4073117e-1, 8.699775e-1, 7.942323e-1, 7.1278733e-1, 6.247831e-1, 5.2916634e-1, 4.246332e-1, 3.0955255e-1, 1.8186332e-1, 3.8937848e-2, -1.225954e-1, -3.07069e-1, -5.200111e-1, -7.6832414e-1, -1.0602447e0, -1.4048264e0, -1.8107363e0, -2.284565e0, -2.8295114e0, -3.445391e0, -4.1299376e0, -4.8803906e0, -5.694499e0, -6.570808e0, -7.5085454e0, -8.507387e0, -9.567264e0],
    [1.431314e0, 1.3937922e0, 1.3548427e0, 1.3143547e0, 1.2722045e0, 1.2282529e0, 1.1823428e0, 1.1342961e0, 1.08391e0, 1.030952e0, 9.751542e-1, 9.16206e-1, 8.5374445e-1, 7.873428e-1, 7.1649474e-1, 6.4059454e-1, 5.589106e-1, 4.7055018e-1, 3.74412e-1, 2.6912165e-1, 1.5294287e-1, 2.3655847e-2, -1.2161003e-1, -2.8660107e-1, -4.762278e-1, -6.968962e-1, -9.567865e-1, -1.2658374e0, -1.6350088e0, -2.0744505e0, -2.5909553e0, -3.186277e0, -3.8577814e0, -4.600866e0, -5.4112005e0, -6.285734e0, -7.222696e0, -8.221222e0, -9.280977e0],
    [1.2976091e0, 1.2619517e0, 1.2250013e0, 1.186662e0, 1.1468271e0, 1.1053771e0, 1.0621781e0, 1.0170791e0, 9.699087e-1, 9.20472e-1, 8.685457e-1, 8.1387264e-1, 7.561545e-1, 6.95043e-1, 6.301286e-1, 5.60925e-1, 4.8685023e-1, 4.0720025e-1, 3.2111433e-1, 2.2752737e-1, 1.2510417e-1, 1.2147443e-2, -1.13532394e-1, -2.5480267e-1, -4.1547164e-1, -6.00654e-1, -8.172474e-1, -1.0744575e0, -1.3841103e0, -1.7601091e0, -2.216119e0, -2.7614498e0, -3.3976622e0, -4.119305e0, -4.918185e0, -5.787208e0, -6.7217383e0, -7.7192693e0, -8.778645e0],
    [1.1449363e0, 1.1116536e0, 1.0772418e0, 1.0416225e0, 1.0047091e0, 9.66405e-1, 9.266028e-1, 8.8518226e-1, 8.420083e-1, 7.969283e-1, 7.4976915e-1, 7.003334e-1, 6.483946e-1, 5.936913e-1, 5.359196e-1, 4.747238e-1, 4.0968394e-1, 3.4029996e-1, 2.6597026e-1, 1.8596326e-1, 9.937847e-2, 5.0924225e-3, -9.831762e-2, -2.126835e-1, -3.404068e-1, -4.846978e-1, -6.4993393e-1, -8.421953e-1, -1.0700332e0, -1.3454478e0, -1.6846969e0, -2.1076605e0, -2.6334865e0, -3.2722988e0, -4.0197625e0, -4.861752e0, -5.783805e0, -6.7761245e0, -7.8334913e0],
    [9.717358e-1, 9.415348e-1, 9.1040313e-1, 8.7828207e-1, 8.4510714e-1, 8.108075e-1, 7.753049e-1, 7.385127e-1, 7.0033467e-1, 6.6066337e-1, 6.1937857e-1, 5.76345e-1, 5.3141004e-1, 4.843999e-1, 4.3511665e-1, 3.8333258e-1, 3.2878464e-1, 2.7116647e-1, 2.1011867e-1, 1.452159e-1, 7.594999e-2, 1.7074073e-3, -7.8261435e-2, -1.6488455e-1, -2.5932822e-1, -3.6308324e-1, -4.7809237e-1, -6.069436e-1, -7.5317115e-1, -9.217367e-1, -1.1198136e0, -1.3580631e0, -1.6526003e0, -2.0273829e0, -2.514604e0, -3.146254e0, -3.9337716e0, -4.8576555e0, -5.886001e0],
    [7.759001e-1, 7.497953e-1, 7.229955e-1, 6.9546276e-1, 6.671561e-1, 6.38031e-1, 6.0803896e-1, 5.771271e-1, 5.452375e-1, 5.123067e-1, 4.782648e-1, 4.4303483e-1, 4.065314e-1, 3.6865962e-1, 3.2931378e-1, 2.883754e-1, 2.4571128e-1, 2.0117083e-1, 1.5458304e-1, 1.05752595e-1, 5.4455068e-2, 4.3087624e-4, -5.6622386e-2, -1.1705985e-1, -1.8130225e-1, -2.4985296e-1, -3.233209e-1, -4.024518e-1, -4.8817196e-1, -5.8165056e-1, -6.843907e-1, -7.9836726e-1, -9.2624044e-1, -1.0717026e0, -1.2400627e0, -1.4392802e0, -1.681879e0, -1.9885832e0, -2.3948612e0],
    [5.5389905e-1, 5.334196e-1, 5.1251346e-1, 4.911625e-1, 4.6934742e-1, 4.4704762e-1, 4.242412e-1, 4.009046e-1, 3.7701267e-1, 3.525384e-1, 3.2745284e-1, 3.0172467e-1, 2.753203e-1, 2.4820325e-1, 2.2033416e-1, 1.9167027e-1, 1.6216508e-1, 1.3176787e-1, 1.0042327e-1, 6.807054e-2, 3.464295e-2, 6.694509e-5, -3.573883e-2, -7.286466e-2, -1.1141112e-1, -1.5149067e-1, -1.9322965e-1, -2.3677059e-1, -2.8227514e-1, -3.2992762e-1, -3.7993944e-1, -4.3255466e-1, -4.8805705e-1, -5.4677916e-1, -6.0911417e-1, -6.755313e-1, -7.46597e-1, -8.23003e-1, -9.056067e-1],
    [2.9929948e-1, 2.869039e-1, 2.7435288e-1, 2.616425e-1, 2.4876864e-1, 2.3572709e-1, 2.2251338e-1, 2.0912294e-1, 1.9555096e-1, 1.8179248e-1, 1.6784227e-1, 1.5369494e-1, 1.3934486e-1, 1.24786094e-1, 1.1001252e-1, 9.501769e-2, 7.97949e-2, 6.4337105e-2, 4.863695e-2, 3.2686718e-2, 1.6478319e-2, 3.2660269e-6, -1.6747352e-2, -3.37829e-2, -5.1113233e-2, -6.874872e-2, -8.670029e-2, -1.0497946e-1, -1.2359842e-1, -1.4257e-1, -1.6190782e-1, -1.8162626e-1, -2.0174062e-1, -2.2226708e-1, -2.4322285e-1, -2.646263e-1, -2.8649688e-1, -3.0885544e-1, -3.3172426e-1],
    [5.249985e-10, 5.000005e-10, 4.7500226e-10, 4.4999893e-10, 4.250007e-10, 4.000027e-10, 3.7499936e-10, 3.5000158e-10, 3.2499847e-10, 3.0000047e-10, 2.7500224e-10, 2.499989e-10, 2.2500068e-10, 1.999978e-10, 1.7499935e-10, 1.5000157e-10, 1.2499801e-10, 9.9999564e-11, 7.5002005e-11, 4.9998894e-11, 2.5000668e-11, 2.6645353e-15, -2.500078e-11, -4.9998894e-11, -7.5001894e-11, -1.0000001e-10, -1.2499812e-10, -1.5000157e-10, -1.7499968e-10, -1.9999769e-10, -2.250008e-10, -2.4999847e-10, -2.750019e-10, -3.0000036e-10, -3.2499814e-10, -3.5000192e-10, -3.749997e-10, -3.999977e-10, -4.2500115e-10],
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The previous solver (bracket search + Newton on log F), for comparison.
    mod old {
        use crate::math::{FRAC_1_SQRT_PI, erf, erfcx_pos, erfinv_fast};
        use std::cell::Cell;

        thread_local! {
            /// Evaluations of log F (alone or with its slope) on this thread.
            pub static EVALS: Cell<u32> = const { Cell::new(0) };
        }

        /// log of the unnormalised CDF of the visible slope x for `cot(theta) = a`:
        /// `F(x) = integral_{-inf}^{x} (a - t) exp(-t^2) / sqrt(pi) dt`, `x <= a`.
        pub fn log_cdf(a: f64, x: f64) -> f64 {
            EVALS.with(|c| c.set(c.get() + 1));
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
            EVALS.with(|c| c.set(c.get() + 1));
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
        pub fn sample_slope_x(a: f64, u: f64) -> f64 {
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
                let done =
                    (next - x).abs() < 1e-7 * (1.0 + x.abs()) || hi - lo < 1e-9 * (1.0 + x.abs());
                x = next;
                if done {
                    break;
                }
            }
            x
        }
    }

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
            let norm = old::log_cdf(a, a).exp();
            for (b, h) in hist.iter().enumerate() {
                let x0 = lo + (hi - lo) * b as f64 / bins as f64;
                let x1 = lo + (hi - lo) * (b + 1) as f64 / bins as f64;
                let p = (old::log_cdf(a, x1).exp() - old::log_cdf(a, x0).exp()) / norm;
                let got = h / n as f64;
                assert!(
                    (got - p).abs() < 1e-4 + 1e-3 * p,
                    "a {a} bin {b}: {got} vs {p}"
                );
            }
        }
    }

    /// `t = a - x` with `H(t) = u H(0)` by bisection to 1e-14 relative.
    fn reference_t(a: f64, u: f64) -> f64 {
        let target = u * h_total(a);
        let (mut lo, mut hi) = (0.0f64, 1.0 / (1.0 + 2.0 * a.abs()));
        while h_and_e(a, hi).0 > target {
            lo = hi;
            hi *= 2.0;
        }
        for _ in 0..300 {
            let mid = 0.5 * (lo + hi);
            if h_and_e(a, mid).0 > target {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= 1e-14 * hi {
                break;
            }
        }
        0.5 * (lo + hi)
    }

    /// The table [`GUESS`] from its definition; printed as Rust source with
    /// `MSBSDF_PRINT_BECKMANN_GUESS=1`.
    fn generate_guess() -> Vec<Vec<f32>> {
        (0..GUESS_NQ)
            .map(|i| {
                let q = (-1.0 + 2.0 * i as f64 / (GUESS_NQ - 1) as f64)
                    .clamp(-1.0 + 1e-10, 1.0 - 1e-10);
                let a = q / (1.0 - q.abs());
                (0..GUESS_NZ)
                    .map(|j| {
                        let z = GUESS_Z0 + (GUESS_Z1 - GUESS_Z0) * j as f64 / (GUESS_NZ - 1) as f64;
                        let u = 0.5 * erfc(-z);
                        (reference_t(a, u) * guess_scale(a)).ln() as f32
                    })
                    .collect()
            })
            .collect()
    }

    /// The committed table equals its generator.
    #[test]
    fn guess_table_is_current() {
        let table = generate_guess();
        if std::env::var_os("MSBSDF_PRINT_BECKMANN_GUESS").is_some() {
            println!("const GUESS: [[f32; GUESS_NZ]; GUESS_NQ] = [");
            for row in &table {
                let cells: Vec<String> = row.iter().map(|v| format!("{v:e}")).collect();
                println!("    [{}],", cells.join(", "));
            }
            println!("];");
        }
        for (i, row) in table.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!(
                    (v - GUESS[i][j]).abs() <= 1e-6 * (1.0 + v.abs()),
                    "GUESS[{i}][{j}] {} vs {v}",
                    GUESS[i][j]
                );
            }
        }
    }

    /// The sampler against bisection over a grid of views (a = cot theta in
    /// [-1e4, 1e4], near 0 and large) and of u (incl. near 0 and 1).
    #[test]
    fn slope_sampler_matches_bisection() {
        let mut a_grid = vec![
            -1e4, -3e3, -1e3, -100.0, -30.0, -20.000001, -19.99999, -10.0, -5.0, 5.0, 10.0, 30.0,
            100.0, 1e3, 1e4, 1e7, 0.0, 5.999999, 6.0, 1e-9, -1e-9, 1e-4, -1e-4,
        ];
        for i in 0..=200 {
            a_grid.push(-6.0 + 12.0 * i as f64 / 200.0);
        }
        let mut u_grid = vec![
            1e-12,
            1e-9,
            1e-6,
            1e-4,
            1e-3,
            0.999,
            0.9999,
            1.0 - 1e-6,
            1.0 - 6e-8,
            1.0 - 1e-10,
        ];
        for i in 0..1000 {
            u_grid.push((i as f64 + 0.5) / 1000.0);
        }
        let (mut worst_abs, mut worst_scaled) = (0.0f64, 0.0f64);
        let (mut worst_old, mut worst_old_scaled) = (0.0f64, 0.0f64);
        for &a in &a_grid {
            for &u in &u_grid {
                let x = sample_slope_x(a, u);
                let t_ref = reference_t(a, u);
                let x_ref = a - t_ref;
                let err = (x - x_ref).abs();
                assert!(x <= a && x.is_finite(), "a {a} u {u}: x {x}");
                assert!(
                    err <= 1e-6 * (1.0 + x_ref.abs()),
                    "a {a} u {u}: x {x} vs {x_ref}"
                );
                worst_abs = worst_abs.max(err / (1.0 + x_ref.abs()));
                let old_err = (old::sample_slope_x(a, u) - x_ref).abs();
                worst_old = worst_old.max(old_err / (1.0 + x_ref.abs()));
                // Relative to the width of the distribution too (for a << 0
                // it is 1 / (2|a|), far below 1 + |x|), for the u an f32 can
                // hold (closer to 1, u H(0) itself has too few digits).
                if u <= 1.0 - 6e-8 {
                    let s = (1.0 + x_ref.abs()).min(t_ref + 1.0 / (1.0 + 2.0 * a.abs()));
                    assert!(err <= 1e-6 * s, "a {a} u {u}: x {x} vs {x_ref} (scale {s})");
                    worst_scaled = worst_scaled.max(err / s);
                    worst_old_scaled = worst_old_scaled.max(old_err / s);
                }
            }
        }
        println!(
            "max |x - x_ref| / (1 + |x|) = {worst_abs:.2e} (old solver {worst_old:.2e}), / slope scale = {worst_scaled:.2e} (old {worst_old_scaled:.2e})"
        );
    }

    /// Evaluations of `H` per sample for views uniform over the sphere
    /// (alpha 1, so a = cot theta) and uniform u: mostly one.
    #[test]
    fn slope_sampler_evaluations() {
        let mut rng = crate::Rng::new(7, 3);
        let mut hist = [0u32; 8];
        let mut old_evals = 0u64;
        let n = 200_000;
        for _ in 0..n {
            let z = 2.0 * rng.next_f32() as f64 - 1.0;
            let a = (z / (1.0 - z * z).sqrt()).max(-1e4);
            let u = rng.next_f32() as f64;
            let k = solve_slope_x(a, u).1 as usize;
            hist[k.min(7)] += 1;
            // Every evaluation also costs H(0) once per sample; the old
            // solver's count includes its log F(a).
            old::EVALS.with(|c| c.set(0));
            old::sample_slope_x(a, u);
            old_evals += old::EVALS.with(|c| c.get()) as u64;
        }
        let mean = hist
            .iter()
            .enumerate()
            .map(|(k, c)| k as f64 * *c as f64)
            .sum::<f64>()
            / n as f64;
        println!(
            "evaluations of H per sample besides H(0): mean {mean:.3}, histogram {hist:?}; \
             old solver: {:.3} evaluations of log F (incl. log F(a))",
            old_evals as f64 / n as f64
        );
        assert!(mean < 2.0, "mean {mean}");
    }

    /// `H(t)` (both forms) against Simpson quadrature of its definition
    /// `2 int_t^inf tau exp(a^2 - (a - tau)^2) dtau` (scaled by `exp(-a^2)`
    /// in the near form), relative 1e-9.
    #[test]
    fn h_matches_quadrature() {
        for a in [-1e4, -300.0, -20.5, -19.5, -3.0, 0.0, 0.7, 4.0] {
            let w = 1.0 / (1.0 + 2.0 * f64::abs(a));
            for k in [0.0, 0.01, 0.3, 1.0, 3.0] {
                let t = k * w;
                let n = 200_000;
                let len = if a < -1.0 {
                    40.0 * w
                } else {
                    a.max(0.0) + 10.0
                };
                let hs = len / n as f64;
                let g = |tau: f64| 2.0 * tau * (-tau * (tau - 2.0 * a)).exp();
                let mut sum = g(t) + g(t + len);
                for i in 1..n {
                    sum += g(t + i as f64 * hs) * if i % 2 == 1 { 4.0 } else { 2.0 };
                }
                let mut quad = sum * hs / 3.0;
                if a >= A_FAR {
                    quad *= (-a * a).exp();
                }
                let (h, _) = h_and_e(a, t);
                assert!(
                    (h - quad).abs() <= 1e-9 * quad,
                    "a {a} t {t}: {h} vs {quad}"
                );
                if t == 0.0 {
                    assert!((h_total(a) - quad).abs() <= 1e-9 * quad, "a {a}: H(0)");
                }
            }
        }
    }

    /// The starting-point exponential against `f64::exp`.
    #[test]
    fn exp_rough_is_accurate() {
        for i in 0..=14_000 {
            let x = -700.0 + 0.1 * i as f64;
            let (got, want) = (exp_rough(x), x.exp());
            assert!((got - want).abs() <= 3e-8 * want, "x {x}: {got} vs {want}");
        }
    }

    /// Walter et al. 2007's rational `G1` against the exact one over the
    /// whole range of `a = 1 / (alpha tan theta)` that matters: the
    /// relative error of `1 / (1 + Lambda)` stays within 0.4% (measured
    /// 0.35%), and `Lambda` is 0 from `a = 1.6` on.
    #[test]
    fn lambda_rational_matches_exact_g1() {
        let mut worst = 0.0f32;
        for i in 1..=2000 {
            let a = i as f32 * 0.001;
            // alpha = 1 on x: a = z / |x|.
            let theta = (1.0 / a).atan();
            let v = Vec3::new(theta.sin(), 0.0, theta.cos());
            for (ax, ay) in [(1.0, 0.3), (1.0, 2.0)] {
                let exact = 1.0 / (1.0 + lambda_upper(ax, ay, v));
                let fit = 1.0 / (1.0 + lambda_rational(ax, ay, v));
                worst = worst.max((fit / exact - 1.0).abs());
            }
        }
        assert!(worst < 0.004, "worst relative G1 error {worst}");
        assert!(worst > 1e-4, "the fit is not the exact form: {worst}");
    }
}
