//! Exact Fresnel reflectance: conductors with a complex index of refraction
//! per RGB channel, and dielectrics with total internal reflection. Nothing
//! here knows about microfacets.

use glam::{Vec3, Vec3A, Vec4};
use std::ops::{Add, Div, Mul, Sub};

/// What the conductor closed form needs of its numbers: one value (`f32`,
/// `f64`) or lanes of them (`Vec3`, `Vec3A`, `Vec4`: RGB channels at one
/// cosine, or one channel at four cosines).
pub trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// `sqrt(max(x, 0))` per lane.
    fn sqrt_pos(self) -> Self;
}

impl Lanes for f32 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
    #[inline(always)]
    fn sqrt_pos(self) -> Self {
        self.max(0.0).sqrt()
    }
}

impl Lanes for f64 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x as f64
    }
    #[inline(always)]
    fn sqrt_pos(self) -> Self {
        self.max(0.0).sqrt()
    }
}

impl Lanes for Vec3 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec3::splat(x)
    }
    #[inline(always)]
    fn sqrt_pos(self) -> Self {
        let v = self.max(Vec3::ZERO);
        Vec3::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt())
    }
}

impl Lanes for Vec3A {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec3A::splat(x)
    }
    /// One `sqrtps` for the three lanes on x86-64.
    #[inline(always)]
    fn sqrt_pos(self) -> Self {
        let v = self.max(Vec3A::ZERO);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{__m128, _mm_sqrt_ps};
            // SAFETY: SSE is part of the x86-64 baseline, so the instruction
            // exists on every target this branch compiles for.
            Vec3A::from(unsafe { _mm_sqrt_ps(__m128::from(v)) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Vec3A::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt())
        }
    }
}

impl Lanes for Vec4 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec4::splat(x)
    }
    #[inline(always)]
    fn sqrt_pos(self) -> Self {
        let v = self.max(Vec4::ZERO);
        Vec4::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt(), v.w.sqrt())
    }
}

/// The one closed form of the unpolarised conductor reflectance in real
/// arithmetic (Born and Wolf, Principles of Optics, sec. 14.4), lane by
/// lane: `c` the cosine in `[0, 1]`, `eta2_minus_k2 = eta^2 - k^2` and
/// `four_eta2_k2 = 4 eta^2 k^2` of the complex index `eta + i k`. The raw
/// value: callers clamp it to `[0, 1]` and fall back to the complex form
/// ([`conductor_scalar`]) where a lane is not finite (0 / 0 at `c = 0`
/// with `k = 0`).
#[inline(always)]
pub fn conductor_closed_form<L: Lanes>(c: L, eta2_minus_k2: L, four_eta2_k2: L) -> L {
    let c2 = c * c;
    let s2 = L::splat(1.0) - c2;
    let t0 = eta2_minus_k2 - s2;
    let ab2 = (t0 * t0 + four_eta2_k2).sqrt_pos();
    let a = (L::splat(0.5) * (ab2 + t0)).sqrt_pos();
    let t1 = ab2 + c2;
    let t2 = L::splat(2.0) * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * ab2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    L::splat(0.5) * (rs + rp)
}

#[derive(Clone, Copy, Debug)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    fn new(re: f32, im: f32) -> Self {
        Complex { re, im }
    }
    fn add(self, o: Self) -> Self {
        Complex::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Self) -> Self {
        Complex::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Self) -> Self {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn norm2(self) -> f32 {
        self.re * self.re + self.im * self.im
    }
    fn div(self, o: Self) -> Self {
        let d = o.norm2();
        Complex::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    /// Principal square root.
    fn sqrt(self) -> Self {
        let n = self.norm2().sqrt();
        if n == 0.0 {
            return Complex::new(0.0, 0.0);
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Complex::new(t1, t2)
        } else {
            Complex::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

/// Unpolarised reflectance of a conductor with complex relative index
/// `eta + i k` for the cosine `cos_i` of the angle between the incident
/// direction and the facet normal (clamped to [0, 1]).
pub fn conductor_scalar(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let n = Complex::new(eta, k);
    let sin2_i = 1.0 - c * c;
    // cos_t = sqrt(1 - sin^2_i / n^2)
    let sin2_t = Complex::new(sin2_i, 0.0).div(n.mul(n));
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let ci = Complex::new(c, 0.0);
    let n_cos_t = n.mul(cos_t);
    let r_s = ci.sub(n_cos_t).div(ci.add(n_cos_t));
    let n_cos_i = n.mul(ci);
    let r_p = n_cos_i.sub(cos_t).div(n_cos_i.add(cos_t));
    let f = 0.5 * (r_s.norm2() + r_p.norm2());
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// [`conductor_scalar`] per RGB channel.
#[inline]
pub fn conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        conductor_scalar(cos_i, eta.x, k.x),
        conductor_scalar(cos_i, eta.y, k.y),
        conductor_scalar(cos_i, eta.z, k.z),
    )
}

/// [`conductor`] for all three channels at once by the real-valued closed
/// form of the unpolarised conductor reflectance (Born and Wolf, Sec. 14.4;
/// `a^2 + b^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2)`), evaluated with
/// vector operations: the same values as [`conductor`] (to ~1e-6) at a
/// fraction of the cost of three complex evaluations. Used in the hot loop of
/// the random walks.
#[inline]
pub fn conductor_rgb(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let (eta2, k2) = (Vec3A::from(eta * eta), Vec3A::from(k * k));
    Vec3::from(conductor_lanes(cos_i, eta2 - k2, 4.0 * eta2 * k2, |c| {
        Vec3A::from(conductor(c, eta, k))
    }))
}

/// A conductor's indices prepared once per material for [`conductor_rgb`]'s
/// closed form: `eta^2 - k^2` and `4 eta^2 k^2` per channel, so that a query
/// evaluates the three channels at once in SIMD lanes with no per-call setup.
/// Stored as `Vec3` (12-byte aligned) to keep the material small.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConductorLanes {
    eta2_minus_k2: Vec3,
    four_eta2_k2: Vec3,
}

impl ConductorLanes {
    /// Prepares the indices `eta + i k` (per channel).
    pub fn new(eta: Vec3, k: Vec3) -> Self {
        let (eta2, k2) = (eta * eta, k * k);
        ConductorLanes {
            eta2_minus_k2: eta2 - k2,
            four_eta2_k2: 4.0 * eta2 * k2,
        }
    }

    /// [`conductor_rgb`] for the indices `eta + i k` these were prepared
    /// from (the same closed form, in SIMD lanes; `eta` and `k` are read
    /// only when it is not finite).
    #[inline]
    pub fn eval(&self, cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
        Vec3::from(conductor_lanes(
            cos_i,
            Vec3A::from(self.eta2_minus_k2),
            Vec3A::from(self.four_eta2_k2),
            |c| Vec3A::from(conductor(c, eta, k)),
        ))
    }
}

/// [`conductor_rgb`]'s closed form in SIMD lanes from the prepared
/// `eta^2 - k^2` and `4 eta^2 k^2` per channel ([`ConductorLanes`]), at the
/// cosine clamped to `[0, 1]`; where it is not finite (`c = 0` with
/// `k = 0`), `complex(c)`: the complex form, in a cold call (its inputs are
/// not loaded on the common path). One scalar finiteness test for the
/// three lanes: a sum of finite reflectances is finite, one with a NaN or
/// infinite lane is not.
#[inline(always)]
pub fn conductor_lanes(
    cos_i: f32,
    eta2_minus_k2: Vec3A,
    four_eta2_k2: Vec3A,
    complex: impl FnOnce(f32) -> Vec3A,
) -> Vec3A {
    let c = cos_i.clamp(0.0, 1.0);
    let f = conductor_closed_form(Vec3A::splat(c), eta2_minus_k2, four_eta2_k2);
    if (f.x + f.y + f.z).is_finite() {
        f.clamp(Vec3A::ZERO, Vec3A::ONE)
    } else {
        cold(|| complex(c))
    }
}

/// Calls `f` on a path the compiler keeps out of line.
#[cold]
#[inline(never)]
fn cold<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// [`conductor_rgb`]'s closed form for one channel in `f64` (for tables
/// built once per material, e.g. the V-groove model's Fresnel table).
pub fn conductor_f64(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c = cos_i.clamp(0.0, 1.0);
    let (eta2, k2) = (eta * eta, k * k);
    let f = conductor_closed_form(c, eta2 - k2, 4.0 * eta2 * k2);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        conductor_scalar(c as f32, eta as f32, k as f32) as f64
    }
}

/// Unpolarised reflectance of a dielectric interface, `eta` = n_transmitted /
/// n_incident, for `cos_i >= 0` measured on the incident side. Returns 1 under
/// total internal reflection.
pub fn dielectric(cos_i: f32, eta: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (c - eta * cos_t) / (c + eta * cos_t);
    let r_p = (eta * c - cos_t) / (eta * c + cos_t);
    let f = 0.5 * (r_s * r_s + r_p * r_p);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Fresnel reflectance of a refraction pair (`ci` on the incident side with
/// relative index `eta`, `co` the cosine on the other side), computed from
/// the optically thinner side, where its slope is finite: the same value from
/// both directions, so transmission stays reciprocal near the critical angle.
#[inline]
pub fn dielectric_pair(ci: f32, co: f32, eta: f32) -> f32 {
    if eta >= 1.0 {
        dielectric(ci, eta)
    } else {
        dielectric(co.abs(), 1.0 / eta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_mirror_is_one() {
        for i in 0..=20 {
            let c = i as f32 / 20.0;
            assert!(
                (conductor_scalar(c, 0.0, 1.0) - 1.0).abs() < 1e-6,
                "cos {c}"
            );
        }
    }

    #[test]
    fn conductor_with_zero_k_equals_dielectric() {
        for i in 1..=20 {
            let c = i as f32 / 20.0;
            let a = conductor_scalar(c, 1.5, 0.0);
            let b = dielectric(c, 1.5);
            assert!((a - b).abs() < 1e-5, "cos {c}: {a} vs {b}");
        }
    }

    #[test]
    fn dielectric_normal_incidence_and_tir() {
        // ((n-1)/(n+1))^2 = 0.04 for n = 1.5.
        assert!((dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        // Critical angle of glass to air: sin = 1/1.5.
        let c = (1.0f32 - (1.0 / 1.5f32).powi(2)).sqrt();
        assert_eq!(dielectric(c - 1e-3, 1.0 / 1.5), 1.0);
        assert!(dielectric(c + 1e-3, 1.0 / 1.5) < 1.0);
    }

    #[test]
    fn conductor_rgb_matches_complex_form() {
        let etas = [
            Vec3::new(0.143, 0.374, 1.442),
            Vec3::new(0.0, 1.5, 0.2),
            Vec3::new(0.27, 0.68, 1.3),
        ];
        let ks = [
            Vec3::new(3.983, 2.385, 1.603),
            Vec3::new(1.0, 0.0, 3.0),
            Vec3::new(3.6, 2.6, 2.3),
        ];
        for (eta, k) in etas.into_iter().zip(ks) {
            for i in 0..=200 {
                let c = i as f32 / 200.0;
                let a = conductor_rgb(c, eta, k);
                let b = conductor(c, eta, k);
                assert!(
                    (a - b).abs().max_element() < 2e-5,
                    "cos {c} eta {eta} k {k}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn conductor_f64_matches_complex_form() {
        for (eta, k) in [(0.143, 3.983), (1.5, 0.0), (0.27, 2.6), (0.0, 1.0)] {
            for i in 0..=200 {
                let c = i as f32 / 200.0;
                let a = conductor_f64(c as f64, eta as f64, k as f64);
                let b = conductor_scalar(c, eta, k) as f64;
                assert!((a - b).abs() < 2e-5, "cos {c} eta {eta} k {k}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn gold_normal_incidence() {
        // |(n - 1 + ik) / (n + 1 + ik)|^2 at normal incidence.
        let (n, k) = (0.143f32, 3.983f32);
        let expect = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((conductor_scalar(1.0, n, k) - expect).abs() < 1e-5);
        // Grazing: reflectance tends to 1.
        assert!(conductor_scalar(0.0, n, k) > 0.999);
    }
}
