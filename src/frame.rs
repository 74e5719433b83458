//! Local shading frame helpers. z is the macro-surface normal, x the tangent
//! along `alpha_x`; all directions point away from the surface.

use glam::Vec3;

/// Mirror `v` about the unit normal `m`: `2 (v.m) m - v`.
#[inline]
pub fn reflect(v: Vec3, m: Vec3) -> Vec3 {
    2.0 * v.dot(m) * m - v
}

/// Refract `v` (pointing away, on the side `m` faces) through the facet `m`
/// with relative index `eta` = n_transmitted / n_incident. Returns `None` on
/// total internal reflection. The result points away from the facet on the
/// other side.
#[inline]
pub fn refract(v: Vec3, m: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = v.dot(m);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-v / eta + (cos_i / eta - cos_t) * m).normalize_or_zero())
}

/// Two unit tangents `(t, b)` completing the unit vector `n` to a
/// right-handed orthonormal basis (Duff et al. 2017, "Building an
/// orthonormal basis, revisited"; continuous except across `n.z = 0`).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// [`basis`] in f64.
#[inline]
pub fn basis_f64(n: glam::DVec3) -> (glam::DVec3, glam::DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        glam::DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        glam::DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Direction from spherical angles (theta from +z, phi from +x).
#[inline]
pub fn spherical(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

/// The same direction with z negated (mirror through the macro-surface).
#[inline]
pub fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

/// True when every component is finite and the vector is not zero-length.
#[inline]
pub fn is_valid_direction(v: Vec3) -> bool {
    v.is_finite() && v.length_squared() > 0.0
}

/// A refraction pair's generalised half vector (Walter et al. 2007).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefractionHalf {
    /// The facet normal, facing up (z >= 0).
    pub h: Vec3,
    /// `wi.h` (> 0).
    pub ci: f32,
    /// `wo.h` (< 0).
    pub co: f32,
    /// `|d omega_h / d omega_o| = eta^2 |wo.h| / (wi.h + eta wo.h)^2`.
    pub jacobian: f32,
}

/// Generalised half vector of a refraction from `wi` (upper side, index 1)
/// to `wo` (lower side, relative index `eta`), facing up; `None` when the
/// pair cannot be a refraction through an upward facet (or is the Dirac
/// straight-through direction of `eta = 1`). Computed in f64: `wi.h + eta
/// wo.h` cancels near grazing refraction.
#[inline]
pub fn refraction_half(wi: Vec3, wo: Vec3, eta: f32) -> Option<RefractionHalf> {
    let (wi, wo, eta) = (wi.as_dvec3(), wo.as_dvec3(), eta as f64);
    let h = -(wi + eta * wo);
    let len2 = h.length_squared();
    if len2 < 1e-12 || !len2.is_finite() {
        return None;
    }
    let mut h = h / len2.sqrt();
    if h.z < 0.0 {
        h = -h;
    }
    let ci = wi.dot(h);
    let co = wo.dot(h);
    if ci <= 0.0 || co >= 0.0 {
        return None;
    }
    let denom = ci + eta * co;
    let denom2 = denom * denom;
    if denom2 < 1e-12 {
        return None;
    }
    Some(RefractionHalf {
        h: h.as_vec3(),
        ci: ci as f32,
        co: co as f32,
        jacobian: (eta * eta * (-co) / denom2) as f32,
    })
}
