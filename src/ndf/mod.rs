//! Microfacet normal distributions: `D`, Smith `Lambda` over the full sphere,
//! masking `G1`, masking-shadowing `G2`, and visible-normal sampling with its
//! density. Nothing here knows about Fresnel or bounces.
//!
//! Conventions: every direction is a unit vector in the local frame (z is the
//! macro-normal); `v` is a direction the microsurface is *seen from*. The
//! visible normals seen from `v` have density `D_v(m) = max(0, v.m) D(m) / sigma(v)`
//! with `sigma(v) = (1 + Lambda(v)) v.z > 0` for every `v` with a visible
//! facet, in either hemisphere; a ray travelling along `w` hits facets
//! distributed as `D_{-w}`.

pub mod beckmann;
pub mod ggx;
pub mod student_t;

use glam::Vec3;

/// `(sin, cos)` of the angle `2 pi u` for `u` in `[0, 1]`, within about
/// 1e-7 absolute (the rounding of single precision), for the azimuths of
/// the samplers: the angle is split into quarter turns `q pi / 2 + a` with
/// `|a| <= pi / 4`, where the Taylor series to `a^9` (sine) and `a^8`
/// (cosine) leave at most 2e-9 and 3e-8; then rotated by `q` quarters. No
/// libm call (`sincosf` was a fifth of a visible-normal draw).
#[inline]
pub fn sin_cos_turn(u: f32) -> (f32, f32) {
    let v = 4.0 * u;
    // Nearest quarter, by truncation of a positive number.
    let q = (v + 0.5) as i32;
    let a = (v - q as f32) * std::f32::consts::FRAC_PI_2;
    let a2 = a * a;
    let s =
        a * (1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (-1.0 / 5040.0 + a2 / 362_880.0))));
    let c = 1.0 + a2 * (-0.5 + a2 * (1.0 / 24.0 + a2 * (-1.0 / 720.0 + a2 / 40_320.0)));
    match q & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Which distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NdfKind {
    /// Beckmann (Gaussian slopes).
    Beckmann,
    /// GGX / Trowbridge-Reitz.
    Ggx,
    /// Student-T with shape [`Ndf::shape`] > 1.5 (d'Eon 2023).
    StudentT,
}

/// A microfacet distribution with its roughness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ndf {
    /// The distribution.
    pub kind: NdfKind,
    /// Roughness along the tangent x.
    pub alpha_x: f32,
    /// Roughness along the bitangent y.
    pub alpha_y: f32,
    /// Shape parameter (Student-T gamma > 1.5; unused by the others).
    pub shape: f32,
}

impl Ndf {
    /// A distribution; roughness is taken as given (validated by the caller).
    pub fn new(kind: NdfKind, alpha_x: f32, alpha_y: f32) -> Self {
        Ndf {
            kind,
            alpha_x,
            alpha_y,
            shape: 2.0,
        }
    }

    /// A distribution with a shape parameter (Student-T gamma > 1.5, validated
    /// by the caller; ignored by the others).
    pub fn with_shape(kind: NdfKind, alpha_x: f32, alpha_y: f32, shape: f32) -> Self {
        Ndf {
            kind,
            alpha_x,
            alpha_y,
            shape,
        }
    }

    /// D(m): microfacet normal density per steradian, with
    /// `integral D(m) m.z dm = 1`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        match self.kind {
            NdfKind::Beckmann => beckmann::d(self.alpha_x, self.alpha_y, m),
            NdfKind::Ggx => ggx::d(self.alpha_x, self.alpha_y, m),
            NdfKind::StudentT => student_t::d(self.alpha_x, self.alpha_y, self.shape, m),
        }
    }

    /// Projected area `sigma(v) = (1 + Lambda(v)) v.z` seen from the unit
    /// direction `v`, positive on the whole sphere (0 only from straight below).
    #[inline]
    pub fn sigma(&self, v: Vec3) -> f32 {
        match self.kind {
            NdfKind::Beckmann => beckmann::sigma(self.alpha_x, self.alpha_y, v),
            NdfKind::Ggx => ggx::sigma(self.alpha_x, self.alpha_y, v),
            NdfKind::StudentT => student_t::sigma(self.alpha_x, self.alpha_y, self.shape, v),
        }
    }

    /// Smith Lambda for `v.z > 0` (the direction is taken as given).
    #[inline]
    fn lambda_upper(&self, v: Vec3) -> f32 {
        match self.kind {
            NdfKind::Beckmann => beckmann::lambda_upper(self.alpha_x, self.alpha_y, v),
            NdfKind::Ggx => ggx::lambda_upper(self.alpha_x, self.alpha_y, v),
            NdfKind::StudentT => student_t::lambda_upper(self.alpha_x, self.alpha_y, self.shape, v),
        }
    }

    /// Full-sphere Smith Lambda (Wang et al. 2022, eq. 8): `Lambda(v) >= 0` for
    /// `v.z > 0`, `Lambda(v) = -1 - Lambda(-v) <= -1` for `v.z < 0`.
    #[inline]
    pub fn lambda(&self, v: Vec3) -> f32 {
        if v.z >= 0.0 {
            self.lambda_upper(v)
        } else {
            -1.0 - self.lambda_upper(-v)
        }
    }

    /// Smith masking `G1(v) = 1 / (1 + Lambda(v))` of the direction `v` taken
    /// on the upper side (`|v.z|`); 0 at the horizon.
    #[inline]
    pub fn g1(&self, v: Vec3) -> f32 {
        let up = Vec3::new(v.x, v.y, v.z.abs());
        1.0 / (1.0 + self.lambda_upper(up))
    }

    /// Height-correlated masking-shadowing for reflection,
    /// `1 / (1 + Lambda(wi) + Lambda(wo))`, both taken on the upper side.
    #[inline]
    pub fn g2_correlated(&self, wi: Vec3, wo: Vec3) -> f32 {
        let li = self.lambda_upper(Vec3::new(wi.x, wi.y, wi.z.abs()));
        let lo = self.lambda_upper(Vec3::new(wo.x, wo.y, wo.z.abs()));
        1.0 / (1.0 + li + lo)
    }

    /// Uncorrelated masking-shadowing `G1(wi) G1(wo)` (for comparisons).
    #[inline]
    pub fn g2_uncorrelated(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.g1(wi) * self.g1(wo)
    }

    /// Height-correlated masking-shadowing for transmission (Heitz 2014):
    /// `B(1 + Lambda(wi), 1 + Lambda(wo))` with both directions taken on
    /// their own side (upper-hemisphere Lambda of `|z|`).
    #[inline]
    pub fn g2_transmission_correlated(&self, wi: Vec3, wo: Vec3) -> f32 {
        let li = self.lambda_upper(Vec3::new(wi.x, wi.y, wi.z.abs())) as f64;
        let lo = self.lambda_upper(Vec3::new(wo.x, wo.y, wo.z.abs())) as f64;
        if !(li.is_finite() && lo.is_finite()) {
            return 0.0;
        }
        crate::math::beta(1.0 + li, 1.0 + lo) as f32
    }

    /// Density of visible normals seen from `v`: `max(0, v.m) D(m) / sigma(v)`.
    #[inline]
    pub fn d_visible(&self, v: Vec3, m: Vec3) -> f32 {
        let cos = v.dot(m);
        if cos <= 0.0 {
            return 0.0;
        }
        let s = self.sigma(v);
        if s <= 1e-30 {
            return 0.0;
        }
        cos * self.d(m) / s
    }

    /// Samples a visible normal seen from the unit direction `v` (either
    /// hemisphere) from two uniforms in `[0, 1)`.
    #[inline]
    pub fn sample_visible(&self, v: Vec3, u1: f32, u2: f32) -> Vec3 {
        match self.kind {
            NdfKind::Beckmann => beckmann::sample_visible(self.alpha_x, self.alpha_y, v, u1, u2),
            NdfKind::Ggx => ggx::sample_visible(self.alpha_x, self.alpha_y, v, u1, u2),
            NdfKind::StudentT => {
                student_t::sample_visible(self.alpha_x, self.alpha_y, self.shape, v, u1, u2)
            }
        }
    }
}
