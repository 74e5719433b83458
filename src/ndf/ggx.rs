//! GGX (Trowbridge-Reitz) microfacet distribution, anisotropic.
//!
//! Smith quantities are defined over the full sphere of directions (Wang et al. 2022,
//! eqs. 8-9): for `v.z < 0`, `Lambda(v) = -1 - Lambda(-v)`, and the projected
//! area `sigma(v) = (1 + Lambda(v)) v.z` stays positive.

use glam::{DVec3, Vec3};
use std::f32::consts::PI;

/// The slope term `(m.x / ax)^2 + (m.y / ay)^2` of `D(m)`.
#[inline(always)]
fn slope2(ax: f32, ay: f32, m: Vec3) -> f32 {
    (m.x / ax).powi(2) + (m.y / ay).powi(2)
}

/// `tau = ((ax v.x)^2 + (ay v.y)^2) / v.z^2` of `Lambda(v)` (`v.z != 0`).
#[inline(always)]
fn tau(ax: f32, ay: f32, v: Vec3) -> f32 {
    ((ax * v.x).powi(2) + (ay * v.y).powi(2)) / (v.z * v.z)
}

/// `Lambda = (sqrt(1 + tau) - 1) / 2`, stable for small `tau`.
#[inline(always)]
fn lambda_of_tau(t: f32) -> f32 {
    t / (2.0 * (1.0 + (1.0 + t).sqrt()))
}

/// D(m) for a unit normal `m` (0 below the macro-surface).
#[inline]
pub fn d(ax: f32, ay: f32, m: Vec3) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let t = slope2(ax, ay, m) + m.z * m.z;
    1.0 / (PI * ax * ay * t * t)
}

/// Projected area of the microsurface seen from the unit direction `v`,
/// `sigma(v) = integral of max(0, v.m) D(m) dm = (1 + Lambda(v)) v.z`.
/// One closed form holds on the whole sphere.
#[inline]
pub fn sigma(ax: f32, ay: f32, v: Vec3) -> f32 {
    let r2 = (ax * v.x).powi(2) + (ay * v.y).powi(2);
    let root = (v.z * v.z + r2).sqrt();
    if v.z >= 0.0 {
        0.5 * (v.z + root)
    } else {
        // (root - |z|) / 2 without cancellation.
        0.5 * r2 / (root - v.z)
    }
}

/// Smith Lambda of the unit direction `v` for `v.z > 0` (infinite at z = 0).
#[inline]
pub fn lambda_upper(ax: f32, ay: f32, v: Vec3) -> f32 {
    if v.z * v.z == 0.0 {
        return f32::INFINITY;
    }
    lambda_of_tau(tau(ax, ay, v))
}

/// `[D(m), Lambda(wi), Lambda(wo)]` at roughness `(ax, ay)` and at `(w ax,
/// w ay)` (`w2 = w^2`), from one set of slope terms: [`d`] and
/// [`lambda_upper`] (`m.z > 0`, `wi.z > 0`, `wo.z > 0`) of both NDFs, as
/// TABULATED's anisotropic GGX lobe needs them (SINGLE's term and the
/// peaked part share the half vector).
#[inline(always)]
pub fn d_lambda_scaled(
    ax: f32,
    ay: f32,
    w2: f32,
    m: Vec3,
    wi: Vec3,
    wo: Vec3,
) -> ([f32; 3], [f32; 3]) {
    // D: the slope term over w^2 at the scaled roughness.
    let q = slope2(ax, ay, m);
    let z2 = m.z * m.z;
    let (t, tw) = (q + z2, q / w2 + z2);
    let k = 1.0 / (PI * ax * ay);
    let d = k / (t * t);
    let dw = k / (w2 * tw * tw);
    // Lambda: tau times w^2 at the scaled roughness.
    let lam = |v: Vec3| -> (f32, f32) {
        if v.z * v.z == 0.0 {
            return (f32::INFINITY, f32::INFINITY);
        }
        let t = tau(ax, ay, v);
        (lambda_of_tau(t), lambda_of_tau(w2 * t))
    };
    let ((li, liw), (lo, low)) = (lam(wi), lam(wo));
    ([d, li, lo], [dw, liw, low])
}

/// Visible normal sampling from direction `v` (any hemisphere; `v.z > -1`)
/// by the spherical-cap method (Dupuy and Benyoub 2023): in the stretched
/// configuration the visible normals of the hemisphere are `v + c` with `c`
/// uniform on the cap `c.z > -v.z`.
/// Computed in f64 when seen steeply from below (at low roughness the cap
/// is tiny and `c + v` cancels catastrophically in f32). The azimuth's sine
/// and cosine are single precision ([`super::sin_cos_turn`]; the f64
/// `sin_cos` was 9% of a walk's instructions): their absolute error, about
/// 1e-7, is scaled by the cap's
/// `sin theta`, so the normal keeps single precision relative to `|c + v|`
/// except within about 1e-7 of the cap's rim (normals at grazing angles to
/// `v`, of vanishing visible density).
///
/// Except seen steeply from below (stretched `vs.z < -1 + 1/64`), the cap
/// height `1 + vs.z` does not cancel and the whole computation is single
/// precision (`sample_visible_cap`).
#[inline]
pub fn sample_visible(ax: f32, ay: f32, v: Vec3, u1: f32, u2: f32) -> Vec3 {
    let vs = Vec3::new(ax * v.x, ay * v.y, v.z).normalize_or_zero();
    if vs.z >= SINGLE_PRECISION_CAP {
        return sample_visible_cap(ax, ay, vs, u1, u2);
    }
    let (ax, ay) = (ax as f64, ay as f64);
    let vs = DVec3::new(ax * v.x as f64, ay * v.y as f64, v.z as f64).normalize();
    let z = (1.0 - u2 as f64) * (1.0 + vs.z) - vs.z;
    let sin_theta = (1.0 - z * z).max(0.0).sqrt();
    let (sp, cp) = super::sin_cos_turn(u1);
    let (sp, cp) = (sp as f64, cp as f64);
    let h = DVec3::new(sin_theta * cp, sin_theta * sp, z) + vs;
    // h.z can round to 0 on the rim of the cap; keep the normal strictly upward.
    let m = DVec3::new(ax * h.x, ay * h.y, h.z.max(1e-9));
    let len2 = m.length_squared();
    if len2 > 0.0 && len2.is_finite() {
        (m / len2.sqrt()).as_vec3()
    } else {
        Vec3::Z
    }
}

/// Lowest `z` of the stretched view direction for which [`sample_visible`]
/// computes in single precision: the cap height `1 + vs.z >= 1/64` then
/// has a relative error below 4e-6, and the normal `c + vs`, of length at
/// least `sqrt(2 (1 + vs.z)) = 0.18` away from the rim, keeps a relative
/// error of about 3e-7.
const SINGLE_PRECISION_CAP: f32 = -1.0 + 1.0 / 64.0;

/// [`sample_visible`] in single precision for a stretched view direction
/// `vs` with `vs.z >= SINGLE_PRECISION_CAP` (every view from above, and
/// from below all but the steepest): `z` lies in `[-vs.z, 1]`, and the
/// normal keeps single precision (relative to `|c + v|`) except within
/// about 1e-7 of the cap's rim, where the visible density vanishes.
#[inline]
fn sample_visible_cap(ax: f32, ay: f32, vs: Vec3, u1: f32, u2: f32) -> Vec3 {
    let z = (1.0 - u2) * (1.0 + vs.z) - vs.z;
    let sin_theta = (1.0 - z * z).max(0.0).sqrt();
    let (sp, cp) = super::sin_cos_turn(u1);
    let h = Vec3::new(sin_theta * cp, sin_theta * sp, z) + vs;
    // h.z can round to 0 on the rim of the cap; keep the normal strictly upward.
    let m = Vec3::new(ax * h.x, ay * h.y, h.z.max(1e-9));
    let len2 = m.length_squared();
    if len2 > 0.0 && len2.is_finite() {
        m * len2.sqrt().recip()
    } else {
        Vec3::Z
    }
}
