//! The kaleidoscopic analysis of one V-groove in its cross-section plane
//! (Lee et al. 2018, section 4), for symmetric and nonsymmetric grooves alike.
//!
//! # Conventions (all angles in radians, in the plane perpendicular to the
//! groove axis)
//!
//! A direction at in-plane angle `t` is the unit vector `(sin t, cos t)` in
//! the basis (groove-plane horizontal `e`, macro-normal `n`); `t > 0` leans
//! towards `+e`. The facet hit first has its normal at angle `a` in `[0, pi/2)`
//! (it is the wall going up towards `-e` from the groove bottom); the other
//! facet has its normal at angle `-b`, `b` in `[0, pi/2)`. Both peaks lie on
//! the macro-surface (Lee et al. 2018, sec. 5 assumptions), so the walls have lengths
//! proportional to `sin b` and `sin a`. The aperture is `theta_v = pi - a - b`
//! (Lee et al. 2018, Fig. 5: `|pi + theta_l - theta_r|` with the paper's signs).
//! The symmetric groove of Lee et al. 2018 sec. 4.1 is `a = b = |theta_s|`.
//! `ti` is the in-plane angle of the direction towards the light, in
//! `(-pi/2, pi/2)`.
//!
//! # Method
//!
//! Unfolding the groove about the wall a ray crosses (Lee et al. 2018, Fig. 4a and
//! 5a) turns the reflected path into a straight line through a fan of virtual
//! walls at polar angles `psi_j = psi_a - j theta_v` from the travel
//! direction, alternately of the two lengths. A line at offset `f` from the
//! groove bottom crosses virtual wall `j` iff `psi_j > 0` and
//! `f < L_j sin psi_j` (the paper's offsets `f(p) = i_perp . p`, eq. 6); it
//! leaves the real groove at the first wall it misses. Light reaching the
//! first wall is uniform in `f` over `(f_lo, f_a)`: `f_a = L_a sin psi_a` is
//! the projected width of that wall and rays with `f < f_lo = max(0, f(b))`
//! hit the other wall first (the paper's shadow zone, `f_b = max(f(b), 0)`).
//! So the fraction of the wall's projected width sending light out after
//! exactly `k` reflections is
//!
//! `G_k = (clamp(T_{k-1}) - clamp(T_k)) / f_a`,  `T_m = min_{j <= m} t_j`,
//!
//! with `t_j = L_j sin psi_j` (0 once `psi_j <= 0`) and `clamp` into
//! `[f_lo, f_a]`. This is eq. (6) (symmetric: only two consecutive counts
//! are nonzero, the paper's `k - 1` and `k` of eq. 4 / Appendix B) and eq.
//! (9) (nonsymmetric: the zones of Fig. 5b) written as one formula. Because
//! `sin` is concave on `(0, pi)`, the minimum over each parity of `j` is at
//! an end of the range, so `T_m = min(t_0, t_1, t_{m-1}, t_m)`: `O(1)` per
//! `k`.

// `!(x > 0.0)` is used on purpose: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::f64::consts::{FRAC_PI_2, PI};

/// Rays hitting one wall of one groove first, for one in-plane incident angle.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Polar angle of the first wall's top seen from the bottom, measured
    /// from the travel direction (in `(0, pi)` when the wall faces the light).
    pub psi_a: f64,
    /// Aperture `pi - a - b`.
    pub theta_v: f64,
    /// Length of the first wall (the longer wall has length 1).
    pub la: f64,
    /// Length of the other wall.
    pub lb: f64,
    /// Projected width of the first wall, `la sin psi_a`.
    pub f_a: f64,
    /// Offset below which rays hit the other wall first.
    pub f_lo: f64,
    /// `sin psi_a`.
    pub sin_psi_a: f64,
    /// `sin psi_1 = sin(psi_a - theta_v)`.
    pub sin_psi1: f64,
    /// `cos theta_v`.
    pub cos_tv: f64,
}

impl Hit {
    /// The first-hit analysis for light from in-plane angle `ti` on the
    /// groove `(a, b)`; `None` when the wall faces away from the light or the
    /// groove is degenerate.
    #[inline]
    pub fn new(ti: f64, a: f64, b: f64) -> Option<Hit> {
        let (sti, cti) = ti.sin_cos();
        let (sa, ca) = a.sin_cos();
        let (sb, cb) = b.sin_cos();
        Hit::with_trig(ti, sti, cti, a, sa, ca, b, sb, cb)
    }

    /// [`Hit::new`] from the sines and cosines of `ti`, `a` and `b` (no
    /// trigonometric call: every other angle is a sum of these).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn with_trig(
        ti: f64,
        sti: f64,
        cti: f64,
        a: f64,
        sa: f64,
        ca: f64,
        b: f64,
        sb: f64,
        cb: f64,
    ) -> Option<Hit> {
        let psi_a = a - ti + FRAC_PI_2;
        if !(psi_a > 0.0 && psi_a < PI && a >= 0.0 && b >= 0.0) {
            return None;
        }
        let theta_v = PI - a - b;
        if !(theta_v > 0.0) {
            return None;
        }
        let m = sa.max(sb);
        // Peaks at equal height: L_a sin a = L_b sin b (a flat groove has one
        // wall of length 1 and a vanishing other wall).
        let (la, lb) = if m > 0.0 {
            (sb / m, sa / m)
        } else {
            (1.0, 0.0)
        };
        // sin psi_a = cos(a - ti)
        let sin_psi_a = ca * cti + sa * sti;
        let f_a = la * sin_psi_a;
        // psi_b = psi_a + theta_v = 3 pi/2 - ti - b
        let psi_b = psi_a + theta_v;
        let f_lo = if psi_b < PI {
            (-lb * (cti * cb - sti * sb)).max(0.0)
        } else {
            0.0
        };
        // psi_1 = psi_a - theta_v = 2a + b - ti - pi/2: sin = -cos(2a + b - ti)
        let (c2a, s2a) = (ca * ca - sa * sa, 2.0 * sa * ca);
        let (c2ab, s2ab) = (c2a * cb - s2a * sb, s2a * cb + c2a * sb);
        let sin_psi1 = -(c2ab * cti + s2ab * sti);
        Some(Hit {
            psi_a,
            theta_v,
            la,
            lb,
            f_a,
            f_lo,
            sin_psi_a,
            sin_psi1,
            cos_tv: -(ca * cb - sa * sb),
        })
    }

    /// Threshold `t_j` of virtual wall `j`.
    #[inline]
    fn t(&self, j: u32) -> f64 {
        let psi = self.psi_a - j as f64 * self.theta_v;
        if psi <= 0.0 {
            return 0.0;
        }
        match j {
            0 => self.la * self.sin_psi_a,
            1 => self.lb * self.sin_psi1,
            _ if j.is_multiple_of(2) => self.la * psi.sin(),
            _ => self.lb * psi.sin(),
        }
    }

    #[inline]
    fn clamp(&self, x: f64) -> f64 {
        x.max(self.f_lo).min(self.f_a)
    }

    /// Fraction of the wall's projected width that is lit (not shadowed by
    /// the other wall): the sum of [`Hit::g`] over all `k`.
    #[inline]
    pub fn lit(&self) -> f64 {
        if self.f_a <= 0.0 {
            return 0.0;
        }
        ((self.f_a - self.f_lo) / self.f_a).max(0.0)
    }

    /// `T_m` (see the module docs), `O(1)`.
    #[inline]
    fn big_t(&self, m: u32) -> f64 {
        if m == 0 {
            return self.f_a;
        }
        let mut v = self.f_a.min(self.t(1)).min(self.t(m));
        if m >= 2 {
            v = v.min(self.t(m - 1));
        }
        v
    }

    /// `G_k`: the fraction of the wall's projected width whose light leaves
    /// after exactly `k >= 1` reflections (Lee et al. 2018, eqs. 6 and 9).
    #[inline]
    pub fn g(&self, k: u32) -> f64 {
        if k == 0 || self.f_a <= 0.0 || self.f_lo >= self.f_a {
            return 0.0;
        }
        let hi = self.clamp(self.big_t(k - 1));
        let lo = self.clamp(self.big_t(k));
        ((hi - lo) / self.f_a).max(0.0)
    }

    /// [`Hit::g`] without trigonometry: `sines = [sin psi_{k-2},
    /// sin psi_{k-1}, sin psi_k]` (`psi_j = psi_a - j theta_v`) supplied by
    /// the caller (`k = 1` uses none of them, `k = 2` only `sin psi_2`:
    /// `sin psi_0` and `sin psi_1` are known).
    #[inline]
    pub fn g_sines(&self, k: u32, sines: [f64; 3]) -> f64 {
        if k == 0 || self.f_a <= 0.0 || self.f_lo >= self.f_a {
            return 0.0;
        }
        let t = |j: u32, sin_psi: f64| {
            if self.psi_a - j as f64 * self.theta_v <= 0.0 {
                0.0
            } else if j.is_multiple_of(2) {
                self.la * sin_psi
            } else {
                self.lb * sin_psi
            }
        };
        // T_m = min(t_0, t_1, t_{m-1}, t_m) with t_0 = f_a (module docs).
        let base = self.f_a.min(t(1, self.sin_psi1));
        let (hi, lo) = match k {
            1 => (self.f_a, base),
            2 => (base, base.min(t(2, sines[2]))),
            _ => {
                let tk1 = t(k - 1, sines[1]);
                (
                    base.min(tk1).min(t(k - 2, sines[0])),
                    base.min(tk1).min(t(k, sines[2])),
                )
            }
        };
        ((self.clamp(hi) - self.clamp(lo)) / self.f_a).max(0.0)
    }

    /// Largest reflection count any ray of this wall can reach,
    /// `floor(psi_a / theta_v) + 1` (Lee et al. 2018, eq. 4 with `f -> 0`).
    #[inline]
    pub fn max_count(&self) -> u32 {
        let x = self.psi_a / self.theta_v;
        if x >= 1e6 { 1_000_000 } else { x as u32 + 1 }
    }

    /// `G_1 .. G_n` into `out[0..n]` (`n = out.len()`) by the running
    /// minimum; returns the lit fraction.
    pub fn fractions(&self, out: &mut [f64]) -> f64 {
        let mut prev = self.clamp(self.f_a);
        let mut run = self.f_a;
        for (j, slot) in out.iter_mut().enumerate() {
            run = run.min(self.t(j as u32 + 1));
            let cur = self.clamp(run);
            *slot = if self.f_a > 0.0 {
                ((prev - cur) / self.f_a).max(0.0)
            } else {
                0.0
            };
            prev = cur;
        }
        self.lit()
    }

    /// Draws the reflection count for a uniform `u` in `[0, 1)` with
    /// probability `G_k / lit` (Lee et al. 2018, sec. 6: `k` chosen by the
    /// geometric attenuation); `None` when nothing is lit or when the count
    /// exceeds `kmax` (the path is then dropped).
    pub fn choose(&self, u: f64, kmax: u32) -> Option<u32> {
        let lit = self.lit();
        if !(lit > 0.0) {
            return None;
        }
        let target = u * lit * self.f_a;
        let mut prev = self.clamp(self.f_a);
        let mut run = self.f_a;
        let mut acc = 0.0;
        for k in 1..=kmax {
            run = run.min(self.t(k));
            let cur = self.clamp(run);
            acc += (prev - cur).max(0.0);
            if target < acc {
                return Some(k);
            }
            prev = cur;
            if cur <= self.f_lo {
                // Everything is accounted for (rounding left the target above).
                return Some(k);
            }
        }
        None
    }

    /// In-plane cosine factor of the `j`-th reflection (`j = 0` first):
    /// `sin psi_j`; the 3D cosine is this times the in-plane length of the
    /// direction.
    #[inline]
    pub fn sin_psi(&self, j: u32) -> f64 {
        match j {
            0 => self.sin_psi_a,
            1 => self.sin_psi1,
            _ => (self.psi_a - j as f64 * self.theta_v).sin(),
        }
    }
}

/// In-plane angle of the outgoing direction after `k` reflections starting
/// on the wall `a` (Lee et al. 2018, eq. 8; eq. 5 for `a = b`), wrapped to
/// `(-pi, pi]`:
/// odd `k`: `(k + 1) a + (k - 1) b - ti`; even `k`: `ti - pi - k (a + b)`.
#[inline]
pub fn exit_angle(ti: f64, a: f64, b: f64, k: u32) -> f64 {
    let kf = k as f64;
    let t = if k % 2 == 1 {
        (kf + 1.0) * a + (kf - 1.0) * b - ti
    } else {
        ti - PI - kf * (a + b)
    };
    wrap(t)
}

/// Wraps an angle to `(-pi, pi]`.
#[inline]
pub fn wrap(t: f64) -> f64 {
    let two_pi = 2.0 * PI;
    let mut r = t - two_pi * (t / two_pi).round();
    if r <= -PI {
        r += two_pi;
    }
    r
}

/// `d theta_h / d a` at fixed `b` for `k` reflections: `k` for symmetric
/// grooves (Lee et al. 2018, eq. 28), `(k + 1) / 2` (odd `k`) or `k / 2` (even `k`)
/// for nonsymmetric ones (Lee et al. 2018, after eq. 23:
/// `0.5 |0.5 - (-1)^k (k + 0.5)|`).
#[inline]
pub fn dtheta_h(k: u32, symmetric: bool) -> f64 {
    if symmetric {
        k as f64
    } else if k % 2 == 1 {
        (k as f64 + 1.0) * 0.5
    } else {
        k as f64 * 0.5
    }
}
