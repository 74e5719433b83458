//! Per-material table of the conductor Fresnel reflectance over the cosine,
//! so that the `k` reflections of a `k`-bounce term cost `k` table lookups
//! instead of `k` closed-form evaluations (each with six square roots and
//! two divisions per channel).
//!
//! The table holds `F(c)` (RGB, `f32`) at `c = (j / M)^2`, `j = 0..=M`
//! (uniform in `sqrt(c)`: a metal's reflectance changes fastest at grazing
//! cosines, on a scale of about `1 / |eta + i k|`), computed
//! in `f64` from the real closed form of the unpolarised conductor
//! reflectance (Born and Wolf, Sec. 14.4; the same form as
//! `crate::fresnel::conductor_rgb`), and interpolates it with the cubic
//! through the four nearest nodes in `sqrt(c)` (one-sided at the ends). For
//! a complex index with `k > 0`, `F` is a smooth (analytic) function of `c`
//! on `[0, 1]`, so the interpolation error is `O(M^-4)`. `M = 32` keeps the
//! table at 528 bytes (every material is as large as the largest model) for
//! a relative error of 2e-6 (silver) to 3.7e-5 (chromium); `M = 104` gave
//! 1e-7 for 1904-byte materials, 9.5x the size of the other models'.
//!
//! The error is not assumed: [`FresnelTable::new`] compares the
//! interpolant with the closed form at three points inside every interval
//! and keeps the table only when the largest deviation is below
//! [`TABLE_TOL`] (relative, with an absolute floor of [`TABLE_FLOOR`]);
//! otherwise (e.g. `k = 0, eta < 1`, whose reflectance has a kink at the
//! critical angle, or `F` near 0) every lookup falls back to
//! `crate::fresnel::conductor_rgb`. `tests/vgroove.rs` checks the bound
//! against `conductor_rgb` on a dense grid for several metals.

// `!(x > 0.0)` is used on purpose: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::fresnel;
use glam::{DVec3, Vec3, Vec3A};

/// Intervals of the table (`M`); `M + 1` nodes of 16 bytes (SIMD `Vec3A`).
pub const TABLE_M: usize = 32;

/// Largest accepted relative deviation of the interpolant from the closed
/// form at the check points.
pub const TABLE_TOL: f64 = 5e-5;

/// Absolute floor of the accepted deviation (for `F` near 0).
pub const TABLE_FLOOR: f64 = 1e-9;

/// `F(c)` at `TABLE_M + 1` uniform cosines, or the exact fallback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FresnelTable {
    nodes: [Vec3A; TABLE_M + 1],
    eta: Vec3,
    k: Vec3,
    /// False when the check failed: [`FresnelTable::eval`] is exact.
    use_table: bool,
    /// Largest relative deviation found by the check.
    max_rel: f32,
}

/// Unpolarised conductor reflectance in `f64` for one channel (Born and
/// Wolf, Sec. 14.4; `a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2)`).
fn conductor_f64(c: f64, eta: f64, k: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let (eta2, k2) = (eta * eta, k * k);
    let t0 = eta2 - k2 - s2;
    let ab2 = (t0 * t0 + 4.0 * eta2 * k2).max(0.0).sqrt();
    let a = (0.5 * (ab2 + t0)).max(0.0).sqrt();
    let t1 = ab2 + c2;
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * ab2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    let f = 0.5 * (rs + rp);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        fresnel::conductor_scalar(c as f32, eta as f32, k as f32) as f64
    }
}

fn conductor_rgb_f64(c: f64, eta: Vec3, k: Vec3) -> DVec3 {
    DVec3::new(
        conductor_f64(c, eta.x as f64, k.x as f64),
        conductor_f64(c, eta.y as f64, k.y as f64),
        conductor_f64(c, eta.z as f64, k.z as f64),
    )
}

/// First node of the four used on `x = u M` and the local coordinate in
/// `[0, 3]`.
#[inline]
fn stencil(x: f32) -> (usize, f32) {
    // floor(x) (up to ties) without the branches of a saturating cast:
    // adding 1.5 * 2^23 rounds to an integer held in the low mantissa bits
    // (x is in [0, M]).
    const MAGIC: f32 = 12_582_912.0;
    let r = ((x - 0.5 + MAGIC).to_bits() & 0x007f_ffff) as i32 - 0x0040_0000;
    let j = r.clamp(1, TABLE_M as i32 - 2) - 1;
    (j as usize, x - j as f32)
}

/// Cubic Lagrange weights on the nodes `0, 1, 2, 3` at `t`.
#[inline]
fn weights(t: f32) -> [f32; 4] {
    const SIXTH: f32 = 1.0 / 6.0;
    let (t1, t2, t3) = (t - 1.0, t - 2.0, t - 3.0);
    let (p01, p23) = (t * t1, t2 * t3);
    [
        -SIXTH * t1 * p23,
        0.5 * t * p23,
        -0.5 * p01 * t3,
        SIXTH * p01 * t2,
    ]
}

impl FresnelTable {
    /// Builds and checks the table for the complex index `eta + i k`.
    pub fn new(eta: Vec3, k: Vec3) -> Self {
        let mut nodes = [Vec3A::ZERO; TABLE_M + 1];
        for (j, n) in nodes.iter_mut().enumerate() {
            let u = j as f64 / TABLE_M as f64;
            *n = Vec3A::from(conductor_rgb_f64(u * u, eta, k).as_vec3());
        }
        let mut t = FresnelTable {
            nodes,
            eta,
            k,
            use_table: true,
            max_rel: 0.0,
        };
        let mut worst = 0.0f64;
        for j in 0..TABLE_M {
            for q in [0.25, 0.5, 0.75] {
                let u = (j as f64 + q) / TABLE_M as f64;
                let c = u * u;
                let exact = conductor_rgb_f64(c, eta, k);
                let got = Vec3::from(t.interpolate(c as f32)).as_dvec3();
                let err = (got - exact).abs();
                for ch in 0..3 {
                    let scale = exact[ch].abs().max(TABLE_FLOOR / TABLE_TOL);
                    let rel = err[ch] / scale;
                    if !(rel <= worst) {
                        worst = if rel.is_nan() { f64::INFINITY } else { rel };
                    }
                }
            }
        }
        t.max_rel = worst as f32;
        t.use_table = worst <= TABLE_TOL;
        t
    }

    /// The table interpolant at `c` (clamped to `[0, 1]`), whether or not
    /// the table passed its check. Not clamped: it may leave `[0, 1]` by
    /// the interpolation error (callers clamp products).
    #[inline]
    pub fn interpolate(&self, c: f32) -> Vec3A {
        // Plain comparisons (one instruction each; NaN goes to 0).
        let c = if c < 1.0 { c } else { 1.0 };
        let c = if c > 0.0 { c } else { 0.0 };
        let (b, t) = stencil(c.sqrt() * TABLE_M as f32);
        let w = weights(t);
        // One bounds check for the four nodes.
        let n = &self.nodes[b..b + 4];
        n[0] * w[0] + n[1] * w[1] + n[2] * w[2] + n[3] * w[3]
    }

    /// `F(c)` per channel: the interpolant when the table passed its
    /// check, else `crate::fresnel::conductor_rgb`. Within [`TABLE_TOL`]
    /// (relative) of `[0, 1]`.
    #[inline]
    pub fn eval(&self, c: f32) -> Vec3A {
        if self.use_table {
            self.interpolate(c)
        } else {
            fresnel::conductor_rgb(c, self.eta, self.k).into()
        }
    }

    /// The same reflectance without the table: every lookup is
    /// `crate::fresnel::conductor_rgb` (the reference for tests).
    pub fn exact(mut self) -> Self {
        self.use_table = false;
        self
    }

    /// True when lookups use the table (the check passed).
    pub fn uses_table(&self) -> bool {
        self.use_table
    }

    /// Largest relative deviation of the interpolant from the `f64` closed
    /// form found at the check points (absolute below [`TABLE_FLOOR`]
    /// divided by [`TABLE_TOL`]).
    pub fn max_checked_error(&self) -> f32 {
        self.max_rel
    }
}
