//! `MSBSDF_MODEL_NULL_SCATTERING`: multiple scattering from a rough surface
//! seen as a half space of microflakes, for any bounded NDF, including
//! NDFs that extend over the full sphere (d'Eon 2023, section 3; Dupuy et al.
//! 2016's volumetric Smith model).
//!
//! ## Sampling (d'Eon 2023, section 3.1)
//! The walk starts at depth 0 travelling along `w = -wi`. Collisions are
//! drawn against the constant majorant NDF `D_max` (cross-section
//! `pi D_max` for every direction, so free paths are exponential with a
//! constant rate). At each tentative collision a candidate normal is drawn
//! by projecting a uniform point of the disk orthogonal to `w` onto the
//! unit sphere (density `max(0, -w.m) / pi`); the collision is real with
//! probability `D(m) / D_max`, otherwise the walk goes on unchanged (delta
//! tracking in the angular domain). A real collision scatters by the facet:
//! conductor (mirror, weight `F`), dielectric (reflect with probability `F`,
//! else refract to the other side), or Lambertian. The walk ends when the
//! depth becomes negative; the exit direction and weight are returned.
//!
//! Depth is measured in units where a ray straight down meets real facets
//! at rate `integral max(0, m.z) D(m) dm` (1 for height-field NDFs). Then
//! a ray travelling up along `o` from depth `t` escapes with probability
//! `exp(-sigma(-o) t / o.z)`, `sigma(v) = integral max(0, v.m) D(m) dm`;
//! for height fields this is Smith's `C1(h)^Lambda(o)` with `C1 = e^-t`.
//! Dielectrics: the lower medium is the same microsurface seen upside down:
//! directions are negated (its NDF in that frame is again `D`) and the height
//! CDF becomes `1 - C1`, so depth maps to `-ln(1 - e^-t)` (as in Heitz et
//! al. 2016's height walk with `h -> -h`).
//!
//! ## Evaluation (d'Eon 2023, section 3.2)
//! The same walk with next-event estimation. For conductor and dielectric
//! facets the estimate is added at *every tentative* collision with the
//! analytic facet phase density `<-w, h> D(h) / (pi D_max) |dh / do| F`
//! (the probability that this tentative collision is real, has the normal
//! `h` and sends the path to `wo`), so the cross-section of the current
//! direction is never needed. Lambertian facets add `albedo (o.m) / pi` at
//! real collisions with the sampled normal. `eval` averages this estimate
//! with the one of the reverse walk (from `wo` towards `wi`, scaled by the
//! generalised reciprocity), as Heitz et al. 2016 do: a grazing `wo` is
//! reached from one side only by rare collisions near the top, and the
//! one-sided estimate is then heavy-tailed (measured: grazing transmission
//! under-estimated by half with 3e4 estimates). The extinction towards `wo`
//! uses `sigma(-wo)`, computed once per call by integrating the Dirac-NDF
//! cross-section (d'Eon 2023, eqs. 25-33) against `D(u)` with Gauss-Legendre
//! quadrature: pieces split at the kinks `u' = +-sqrt(1 - u^2)` of
//! `sigma_delta` and at `u' = 0` (where height-field NDFs jump to 0); the
//! outer piece in the angle `u' = cos(theta)` (resolves peaks at `u' = 1`),
//! the middle ones in `u' = +-s sin(phi)` (absorbs the square-root edge).
//! With 40 nodes per piece (at most 120 evaluations of `D`; 100 on
//! [-1, 1] as in the paper fails the 1e-4 check for Beckmann at alpha 4,
//! whose mass sits near the horizon) the quadrature matches the closed
//! forms of GGX and Beckmann to 2e-5 for alpha 0.1 to 4, and eq. (42) of
//! K0 to 5e-6 (`tests/null_scattering.rs`).
//! This is what vMF and the exponential NDF use; Beckmann, GGX, Student-T
//! (also anisotropic, where the Dirac Green's function, which needs `D` to
//! depend on `u` only, does not apply) and K0 use their closed forms, which
//! the quadrature matches (tested) at a thousandth of the cost.
//!
//! ## NDFs
//! Beckmann, GGX, Student-T (`gamma >= 2`: below 2 the NDF is unbounded at
//! the horizon, refused), von Mises-Fisher `D = C exp(2 (u - 1) / alpha^2)`
//! on the full sphere (d'Eon 2023, section 5.3), exponential (eq. 43, isotropic)
//! and Bessel K0 (eq. 40 with argument `2 tan / alpha` as eq. 36 gives;
//! eq. 40 drops the `1/u`). K0 is unbounded at `u = 1`, so no constant
//! majorant exists; it is walked "shape-invariantly" instead (the other
//! interface of the paper's facet-forge): free paths from its closed-form
//! cross-section (eq. 42; the up-welling branch of eq. 42 has a sign
//! typo, `exp(-2|u| / (alpha s))` is right) and exact visible normals from
//! its Rayleigh superposition of Beckmann surfaces (eq. 35 with `a = 1`),
//! sampled by rejection ([`k0_sample_visible`]).
//!
//! ## pdf
//! As in the paper (section 3.3), `pdf` is a cosine lobe: `|wo.z| / pi` on
//! the side of `wi` for opaque facets, half of it on each side for
//! dielectrics.
//!
//! ## Cost versus roughness (d'Eon 2023, section 3.3)
//! The tentative-collision rate is `pi D_max`: about `1 / alpha^2` times the
//! real rate at low roughness, and, for GGX, Beckmann, Student-T and the
//! exponential NDF above alpha ~1, large again because their maximum moves
//! to grazing normals (GGX: `D_max = alpha^2 / pi` at the horizon) while
//! the walk meets mostly smaller values. Measured per NDF and roughness in
//! `docs/null_scattering.md`, written by
//! `cargo run --release --example null_scattering_stats`.
//!
//! The cost grows like `1 / alpha^2`; at alpha 0.2 a sample costs about 10
//! times what it costs at alpha 1 (the paper recommends alpha >= 0.4).
//! [`Material::new`](crate::Material::new) refuses roughness below
//! [`MIN_ALPHA`] = 0.2 with `Error::InvalidArgument`. Eval costs more than
//! sample: two walks (reciprocal estimate), a next-event estimate at every
//! tentative collision, and for vMF and exponential two quadrature
//! cross-sections (about 1.3 and 2.3 us each).
//!
//! Composition (`MSBSDF_FACET_MATERIAL`) is not implemented.

use crate::bsdf::{Sample, ScatterModel, opposite_sides, same_side};
use crate::facet::Facet;
use crate::frame::{basis_f64, flip_z, reflect, refract};
use crate::fresnel;
use crate::math::{FRAC_1_SQRT_PI, erf, erfcx_pos};
use crate::ndf::{Ndf, NdfKind, beckmann};
use crate::rng::Rng;
use crate::specfun::bessel_k;
use glam::Vec3;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Smallest roughness accepted (see the module docs: below it the rejection
/// rate makes a sample cost over 10 times what it costs at alpha 1).
pub const MIN_ALPHA: f32 = 0.2;

/// Default number of real scattering events followed when the description
/// asks for the model default (`max_bounces = 0`). The walk keeps O(1) state,
/// so it can exceed [`MAX_BOUNCES`](crate::desc::MAX_BOUNCES) (the cap on
/// explicit requests): near-uniform NDFs need long walks. Energy lost to it
/// with F = 1 facets (measured, `examples/bounce_tail.rs`, `wi` at 30
/// degrees): vMF alpha 4: 2.1% at 256 bounces, 0.05% at 1024, < 0.01% at
/// 4096 (mean 28 real collisions); vMF alpha 10: 0.9% at 4096.
pub const DEFAULT_BOUNCES: u32 = 4096;

/// Safety bound on tentative (real or null) collisions per walk.
const MAX_EVENTS: u32 = 1 << 20;

/// The distributions the null-scattering walk supports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NullNdfKind {
    /// Beckmann.
    Beckmann,
    /// GGX.
    Ggx,
    /// Student-T, shape >= 2.
    StudentT,
    /// von Mises-Fisher over the full sphere (d'Eon 2023, section 5.3).
    Vmf,
    /// Exponential slopes (d'Eon 2023, eq. 43).
    Exponential,
    /// Bessel K0 (d'Eon 2023, eqs. 36 and 40-42), walked analytically.
    BesselK0,
}

/// A bounded NDF with its constant majorant (or K0's closed forms).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NullNdf {
    kind: NullNdfKind,
    ax: f32,
    ay: f32,
    shape: f32,
    /// Constant majorant `D_max >= D(m)` for all `m`.
    d_max: f64,
    /// vMF normalisation `C`.
    c: f64,
}

impl NullNdf {
    /// Builds the distribution; `None` when the combination is unsupported
    /// (anisotropic vMF / exponential / K0, Student-T shape below 2).
    pub fn new(kind: NullNdfKind, ax: f32, ay: f32, shape: f32) -> Option<NullNdf> {
        let iso = ax == ay;
        let a = ax.max(ay) as f64;
        let norm = 1.0 / (PI * ax as f64 * ay as f64);
        let mut c = 0.0;
        let d_max = match kind {
            NullNdfKind::Beckmann => {
                // D along the rougher axis peaks at sec^2 = 2 a^2 when 2 a^2 > 1.
                let peak = if 2.0 * a * a > 1.0 {
                    (-(2.0 - 1.0 / (a * a))).exp() * 4.0 * a.powi(4)
                } else {
                    1.0
                };
                norm * peak.max(1.0)
            }
            NullNdfKind::Ggx => norm * (a.powi(4)).max(1.0),
            NullNdfKind::StudentT => {
                let g = shape as f64;
                if g.is_nan() || g < 2.0 {
                    return None;
                }
                if g == 2.0 {
                    norm * (a.powi(4)).max(1.0)
                } else {
                    // d/dx [-g ln(1 + x/((g-1)a^2)) + 2 ln(1 + x)] = 0, x = tan^2.
                    let x = ((2.0 * (g - 1.0) * a * a - g) / (g - 2.0)).max(0.0);
                    let v = (-g * (x / ((g - 1.0) * a * a)).ln_1p() + 2.0 * x.ln_1p()).exp();
                    norm * v.max(1.0)
                }
            }
            NullNdfKind::Vmf => {
                if !iso {
                    return None;
                }
                let k = 2.0 / (a * a);
                let n = (1.0 / k - 1.0 / (k * k)) + (-2.0 * k).exp() * (1.0 / k + 1.0 / (k * k));
                c = 1.0 / (2.0 * PI * n);
                c
            }
            NullNdfKind::Exponential => {
                if !iso {
                    return None;
                }
                // D(t) = 2 e^{-2t/a} (1 + t^2)^2 / (pi a^2), t = tan; local max at
                // t = a + sqrt(a^2 - 1) when a > 1.
                let f = |t: f64| 2.0 * (-2.0 * t / a).exp() * (1.0 + t * t).powi(2) / (PI * a * a);
                let mut m = f(0.0);
                if a > 1.0 {
                    m = m.max(f(a + (a * a - 1.0).sqrt()));
                }
                m
            }
            NullNdfKind::BesselK0 => {
                if !iso {
                    return None;
                }
                f64::INFINITY
            }
        };
        Some(NullNdf {
            kind,
            ax,
            ay,
            shape,
            d_max: d_max * (1.0 + 1e-9),
            c,
        })
    }

    /// The kind.
    pub fn kind(&self) -> NullNdfKind {
        self.kind
    }

    /// The constant majorant `D_max` (infinite for K0).
    pub fn d_max(&self) -> f64 {
        self.d_max
    }

    /// True when the walk uses delta tracking (bounded NDF).
    #[inline]
    fn is_null(&self) -> bool {
        self.kind != NullNdfKind::BesselK0
    }

    #[inline]
    fn closed_ndf(&self) -> Option<Ndf> {
        let k = match self.kind {
            NullNdfKind::Beckmann => NdfKind::Beckmann,
            NullNdfKind::Ggx => NdfKind::Ggx,
            NullNdfKind::StudentT => NdfKind::StudentT,
            _ => return None,
        };
        Some(Ndf::with_shape(k, self.ax, self.ay, self.shape))
    }

    /// `D(m)` per steradian on the whole sphere, `integral D(m) m.z dm = 1`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f64 {
        match self.kind {
            NullNdfKind::Vmf => {
                self.c * (2.0 * (m.z as f64 - 1.0) / (self.ax as f64).powi(2)).exp()
            }
            NullNdfKind::Exponential | NullNdfKind::BesselK0 => self.d_iso(m.z as f64),
            _ => match self.closed_ndf() {
                Some(n) => n.d(m) as f64,
                None => 0.0,
            },
        }
    }

    /// `D` of an isotropic distribution as a function of the cosine `u`.
    pub fn d_iso(&self, u: f64) -> f64 {
        let a = self.ax as f64;
        match self.kind {
            NullNdfKind::Vmf => self.c * (2.0 * (u - 1.0) / (a * a)).exp(),
            NullNdfKind::Exponential => {
                if u <= 0.0 {
                    return 0.0;
                }
                let t = (1.0 - u * u).max(0.0).sqrt() / u;
                let u2 = u * u;
                2.0 * (-2.0 * t / a).exp() / (PI * a * a * u2 * u2) // eq. (43)
            }
            NullNdfKind::BesselK0 => {
                if u <= 0.0 {
                    return 0.0;
                }
                let t = (1.0 - u * u).max(0.0).sqrt() / u;
                let u2 = u * u;
                2.0 * bessel_k(0.0, (2.0 * t / a).max(1e-300)) / (PI * a * a * u2 * u2) // eq. (36), a = 1
            }
            _ => {
                let s = (1.0 - u * u).max(0.0).sqrt();
                self.d(Vec3::new(s as f32, 0.0, u as f32))
            }
        }
    }

    /// Projected area `sigma(v) = integral max(0, v.m) D(m) dm` seen from the
    /// unit direction `v`: the Dirac quadrature (eq. 33) for vMF and the
    /// exponential NDF; the closed forms of Beckmann, GGX, Student-T and K0
    /// (eq. 42) where they exist (equal to the quadrature within 2e-5,
    /// `tests/null_scattering.rs`, and 700 times cheaper: 3 ns against
    /// 2.1-2.5 us, which made eval 2-3 times slower).
    pub fn sigma(&self, v: Vec3) -> f64 {
        match self.kind {
            NullNdfKind::BesselK0 => k0_sigma(self.ax as f64, v.z as f64),
            NullNdfKind::Vmf | NullNdfKind::Exponential => self.sigma_quadrature(v.z as f64),
            _ => match self.closed_ndf() {
                Some(n) => n.sigma(v) as f64,
                None => self.sigma_quadrature(v.z as f64),
            },
        }
    }

    /// d'Eon 2023 eq. (33) by piecewise Gauss-Legendre quadrature (isotropic):
    /// [`GL_NODES_SMOOTH`] nodes per piece for vMF, [`GL_NODES`] otherwise.
    pub fn sigma_quadrature(&self, u: f64) -> f64 {
        let nodes = match self.kind {
            NullNdfKind::Vmf => GL_NODES_SMOOTH,
            _ => GL_NODES,
        };
        sigma_quadrature_nodes(|x| self.d_iso(x), u, nodes)
    }
}

/// d'Eon 2023 eq. (42) (with the up-welling exponent's sign corrected):
/// the K0 cross-section for a direction of cosine `u`.
pub fn k0_sigma(alpha: f64, u: f64) -> f64 {
    let s = (1.0 - u * u).max(0.0).sqrt();
    if s <= 0.0 {
        return u.max(0.0);
    }
    let tail = 0.25 * alpha * s * (-2.0 * u.abs() / (alpha * s)).exp();
    if u > 0.0 { u + tail } else { tail }
}

/// The Dirac-NDF cross-section `sigma_delta(u, u_n)` (d'Eon 2023, eqs. 26-30):
/// the projected area, seen from a direction of cosine `u`, of unit density
/// of normals on the ring of cosine `u_n` (`integral_0^{2 pi} max(0, v.m) dphi`).
pub fn sigma_dirac(u: f64, un: f64) -> f64 {
    let s2 = 1.0 - u * u;
    let sn2 = 1.0 - un * un;
    let r = s2 - un * un; // = 1 - u^2 - u_n^2
    if r <= 0.0 {
        // eq. (27) alone: 2 pi u u_n where u u_n > 0.
        return if u * un > 0.0 { 2.0 * PI * u * un } else { 0.0 };
    }
    let den = (s2 * sn2).sqrt();
    let c = if den > 0.0 {
        (-u * un / den).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    (2.0 * (r.sqrt() + u * un * c.acos())).max(0.0) // eq. (30)
}

/// Gauss-Legendre nodes per piece of the quadrature (the default, needed
/// by peaked or horizon-heavy NDFs such as Beckmann at alpha 4).
pub const GL_NODES: usize = 40;

/// Nodes per piece for the smooth vMF NDF: equal to the 40-node result
/// within 5e-6 relative for alpha 0.2 to 10 (tested; the exponential NDF
/// at alpha 4 differs by 1.3e-3 and keeps 40).
pub const GL_NODES_SMOOTH: usize = 20;

/// Gauss-Legendre nodes and weights on [-1, 1] for `n` points (first `n`
/// entries), by Newton iteration on `P_n`.
fn compute_gl(n: usize) -> ([f64; GL_NODES], [f64; GL_NODES]) {
    let (mut x, mut w) = ([0.0; GL_NODES], [0.0; GL_NODES]);
    for i in 0..n {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
            let dz = p1 / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    (x, w)
}

/// Gauss-Legendre rule with [`GL_NODES`] or [`GL_NODES_SMOOTH`] points
/// (computed once, thread-safely); other counts fall back to the default.
pub fn gauss_legendre(n: usize) -> &'static ([f64; GL_NODES], [f64; GL_NODES]) {
    static FULL: OnceLock<([f64; GL_NODES], [f64; GL_NODES])> = OnceLock::new();
    static SMOOTH: OnceLock<([f64; GL_NODES], [f64; GL_NODES])> = OnceLock::new();
    if n == GL_NODES_SMOOTH {
        SMOOTH.get_or_init(|| compute_gl(GL_NODES_SMOOTH))
    } else {
        FULL.get_or_init(|| compute_gl(GL_NODES))
    }
}

/// `integral_{-1}^{1} sigma_delta(u, u') D(u') du'` for any `D(u')`
/// (d'Eon 2023, eq. 33), split at `u' = +-s`, `s = sqrt(1 - u^2)`, and `0`.
pub fn sigma_quadrature_with(d: impl Fn(f64) -> f64, u: f64) -> f64 {
    sigma_quadrature_nodes(d, u, GL_NODES)
}

/// [`sigma_quadrature_with`] with `nodes` ([`GL_NODES`] or
/// [`GL_NODES_SMOOTH`]) points per piece.
pub fn sigma_quadrature_nodes(d: impl Fn(f64) -> f64, u: f64, nodes: usize) -> f64 {
    let n = if nodes == GL_NODES_SMOOTH {
        GL_NODES_SMOOTH
    } else {
        GL_NODES
    };
    let (x, w) = gauss_legendre(n);
    let s = (1.0 - u * u).max(0.0).sqrt();
    let mut total = 0.0;
    // Outer pieces [s, 1] and [-1, -s]: sigma_delta = 2 pi u u' where u u' > 0;
    // integrated in the angle (u' = cos(theta)) to resolve peaks at u' = 1.
    if s < 1.0 && u != 0.0 {
        let th = s.clamp(-1.0, 1.0).acos().min(0.5 * PI); // theta at u' = s
        let h = 0.5 * th; // half-length of [0, th]
        let mut acc = 0.0;
        for i in 0..n {
            let t = h * (1.0 + x[i]);
            let (st, ct) = t.sin_cos();
            let up = if u > 0.0 { ct } else { -ct };
            acc += w[i] * 2.0 * PI * u.abs() * ct * d(up) * st;
        }
        total += acc * h;
    }
    // Middle pieces u' = +-s sin(phi), phi in [0, pi/2]: split at u' = 0 where
    // height-field NDFs jump to zero.
    if s > 0.0 {
        let h = 0.25 * PI;
        let mut acc = 0.0;
        for i in 0..n {
            let phi = h * (1.0 + x[i]);
            let (sp, cp) = phi.sin_cos();
            let up = s * sp;
            acc += w[i] * s * cp * (sigma_dirac(u, up) * d(up) + sigma_dirac(u, -up) * d(-up));
        }
        total += acc * h;
    }
    total
}

/// Samples a K0 visible normal seen from the unit direction `v` (either
/// hemisphere), exactly: the mixture index `t` of the Beckmann component of
/// roughness `alpha t / sqrt(2)` (d'Eon 2023, eq. 35 with `a = 1`: Rayleigh
/// weights) has density `t e^{-t^2/2} sigma_B(v; alpha t / sqrt 2)`, which
/// is bounded by `t e^{-t^2/2} (u+ + alpha_B s / (2 sqrt pi))` (Rayleigh plus
/// Maxwell components) and sampled by rejection.
pub fn k0_sample_visible(alpha: f32, v: Vec3, rng: &mut Rng) -> Vec3 {
    let u = v.z as f64;
    let s = (1.0 - u * u).max(0.0).sqrt();
    let a = alpha as f64;
    let inv_sqrt2 = std::f64::consts::FRAC_1_SQRT_2;
    let mut t = 1.0;
    for _ in 0..100_000 {
        let w_rayleigh = u.max(0.0);
        let w_maxwell = 0.25 * a * s; // integral of the Maxwell part
        t = if rng.next_f64() * (w_rayleigh + w_maxwell) < w_rayleigh {
            (-2.0 * (1.0 - rng.next_f64()).ln()).sqrt()
        } else {
            let (x, y, z) = (
                crate::specfun::normal(rng),
                crate::specfun::normal(rng),
                crate::specfun::normal(rng),
            );
            (x * x + y * y + z * z).sqrt()
        };
        let ab = a * t * inv_sqrt2;
        if s <= 0.0 {
            break;
        }
        let mu_a = u / (ab * s); // Beckmann's a = cot / alpha_B
        let tail = ab * s * 0.5 * FRAC_1_SQRT_PI;
        let (sigma_b, bound) = if u > 0.0 {
            (
                0.5 * u * (1.0 + erf(mu_a)) + tail * (-mu_a * mu_a).exp(),
                u + tail,
            )
        } else {
            let x = -mu_a;
            (
                tail * (-x * x).exp() * (1.0 - PI.sqrt() * x * erfcx_pos(x)),
                tail,
            )
        };
        if rng.next_f64() * bound < sigma_b {
            break;
        }
    }
    let ab = ((a * t * inv_sqrt2).clamp(1e-7, 1e7)) as f32;
    beckmann::sample_visible(ab, ab, v, rng.next_f32(), rng.next_f32())
}

/// Depth on the other side of a dielectric microsurface: height CDF
/// `C1 -> 1 - C1` with `C1 = e^-t`.
#[inline]
fn flip_depth(t: f64) -> f64 {
    -(-(-t).exp_m1()).ln()
}

/// Where `eval` sends its next-event estimates.
#[derive(Clone, Copy)]
struct Target {
    /// `wo` in the oriented world frame.
    wo: Vec3,
    /// Side (0 upper, 1 lower) the escape happens on.
    side: u8,
    /// Escape travel direction in that side's frame (z > 0).
    esc: Vec3,
    /// Real cross-section for travelling along `esc`: `sigma(-esc)`.
    sigma_esc: f64,
}

/// The null-scattering multiple-scattering BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NullScattering {
    ndf: NullNdf,
    facet: Facet,
    max_bounces: u32,
    /// Composition (d'Eon 2023 section 4): the facets scatter as this opaque
    /// material, in a frame whose z is the facet normal.
    inner: Option<crate::dispatch::Inner>,
}

/// Outcome of one walk.
struct WalkEnd {
    dir: Vec3,
    weight: Vec3,
    escaped: bool,
}

/// Statistics of walks (for the documentation's measurements).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WalkStats {
    /// Tentative collisions (real + null).
    pub tentative: u64,
    /// Real collisions.
    pub real: u64,
}

impl NullScattering {
    /// The model for `ndf` and `facet`, following at most `max_bounces`
    /// real collisions (0 = [`DEFAULT_BOUNCES`]).
    pub fn new(ndf: NullNdf, facet: Facet, max_bounces: u32) -> Self {
        let max_bounces = if max_bounces == 0 {
            DEFAULT_BOUNCES
        } else {
            max_bounces.min(crate::desc::MAX_BOUNCES)
        };
        NullScattering {
            ndf,
            facet,
            max_bounces,
            inner: None,
        }
    }

    /// The same walk with facets that scatter as the opaque material `inner`
    /// (microsurface as a BSDF, d'Eon 2023 section 4: e.g. a rough conductor
    /// on a rough macro-structure, biscale roughness). The facet's tangent
    /// frame is built from its normal alone, so an anisotropic `inner` has an
    /// arbitrary azimuth on each facet. `eval` uses next-event estimation at
    /// real collisions with the sampled normal (as for diffuse facets).
    pub fn with_inner(self, inner: crate::dispatch::Inner) -> Self {
        NullScattering {
            inner: Some(inner),
            ..self
        }
    }

    /// The NDF.
    pub fn ndf(&self) -> &NullNdf {
        &self.ndf
    }

    /// Relative index of the side the walk is on.
    #[inline]
    fn eta(&self, side: u8) -> f32 {
        match self.facet {
            Facet::Dielectric { eta } => {
                if side == 0 {
                    eta
                } else {
                    1.0 / eta
                }
            }
            _ => 1.0,
        }
    }

    /// Analytic phase density (per solid angle of `o`) that a collision of a
    /// travel direction `w` with event rate `rate` is real, has a normal
    /// sending the path to the travel direction `o` (same frame), times the
    /// facet weight. `o` on the same side (`o.z` of either sign) is a
    /// reflection; `refr` asks for a refraction.
    #[inline]
    fn phase(&self, w: Vec3, o: Vec3, refr: bool, side: u8, rate: f64) -> Vec3 {
        let wi = -w;
        if !refr {
            let h = (wi + o).normalize_or_zero();
            let ci = wi.dot(h);
            if ci <= 0.0 {
                return Vec3::ZERO;
            }
            let dens = ci as f64 * self.ndf.d(h) / (rate * 4.0 * ci as f64);
            let f = match self.facet {
                Facet::Dielectric { .. } => Vec3::splat(fresnel::dielectric(ci, self.eta(side))),
                _ => self.facet.conductor_fresnel(ci),
            };
            f * dens as f32
        } else {
            let eta = self.eta(side);
            let h = -(wi + eta * o);
            let len = h.length();
            if len.is_nan() || len <= 1e-6 {
                return Vec3::ZERO;
            }
            let mut h = h / len;
            if wi.dot(h) < 0.0 {
                h = -h;
            }
            let (ci, co) = (wi.dot(h), o.dot(h));
            if ci <= 0.0 || co >= 0.0 {
                return Vec3::ZERO;
            }
            let den = ci + eta * co;
            let jac = (eta * eta * -co / (den * den)) as f64;
            let f = fresnel::dielectric(ci, eta);
            Vec3::splat(((1.0 - f) as f64 * ci as f64 * self.ndf.d(h) / rate * jac) as f32)
        }
    }

    /// Next-event estimate at a collision on `side`, depth `t`, travel `w`:
    /// analytic phase times the escape probability.
    #[inline]
    fn nee_analytic(&self, tg: &Target, side: u8, t: f64, w: Vec3, rate: f64) -> Vec3 {
        let o = if side == 0 { tg.wo } else { -tg.wo };
        let refr = side != tg.side;
        let p = self.phase(w, o, refr, side, rate);
        if p == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let t_esc = if refr { flip_depth(t) } else { t };
        p * (-tg.sigma_esc * t_esc / tg.esc.z as f64).exp() as f32
    }

    /// The walk. With a target, accumulates the next-event estimates into
    /// `acc` (then the returned end is irrelevant).
    fn walk(
        &self,
        wi: Vec3,
        rng: &mut Rng,
        target: Option<&Target>,
        acc: &mut Vec3,
        stats: &mut WalkStats,
    ) -> WalkEnd {
        let mut side = 0u8;
        let mut w = -wi;
        let mut t = 0.0f64;
        let mut weight = Vec3::ONE;
        let null = self.ndf.is_null();
        let rate_null = PI * self.ndf.d_max;
        let mut events = 0u32;
        // Facets whose phase has no closed form: NEE at real collisions only.
        let diffuse = matches!(self.facet, Facet::Diffuse { .. }) || self.inner.is_some();
        for _bounce in 0..self.max_bounces {
            // Find the next real collision (or escape).
            let m = loop {
                events += 1;
                if events > MAX_EVENTS {
                    return WalkEnd {
                        dir: Vec3::ZERO,
                        weight: Vec3::ZERO,
                        escaped: false,
                    };
                }
                let rate = if null { rate_null } else { self.ndf.sigma(-w) };
                let wz = w.z as f64;
                if rate.is_nan() || rate <= 0.0 {
                    if wz > 0.0 {
                        break None;
                    }
                    return WalkEnd {
                        dir: Vec3::ZERO,
                        weight: Vec3::ZERO,
                        escaped: false,
                    };
                }
                let dist = -(1.0 - rng.next_f64()).ln() / rate;
                t -= wz * dist;
                if t < 0.0 {
                    break None;
                }
                stats.tentative += 1;
                if let (Some(tg), false) = (target, diffuse) {
                    *acc += weight * self.nee_analytic(tg, side, t, w, rate);
                }
                if !null {
                    break Some(k0_sample_visible(self.ndf.ax, -w, rng));
                }
                // Candidate normal: uniform disk orthogonal to w, onto the sphere.
                let wd = w.as_dvec3().normalize();
                let (e1, e2) = basis_f64(wd);
                let r = rng.next_f64().sqrt();
                let phi = 2.0 * PI * rng.next_f64();
                let m = (e1 * (r * phi.cos()) + e2 * (r * phi.sin())
                    - wd * (1.0 - r * r).max(0.0).sqrt())
                .as_vec3();
                if rng.next_f64() * self.ndf.d_max < self.ndf.d(m) {
                    break Some(m);
                }
            };
            let Some(m) = m else {
                let dir = if side == 0 { w } else { -w };
                return WalkEnd {
                    dir,
                    weight,
                    escaped: true,
                };
            };
            stats.real += 1;
            let wi_l = -w;
            let ci = wi_l.dot(m);
            if ci <= 0.0 {
                continue; // rounding at the rim: treat as null
            }
            if let Some(inner) = &self.inner {
                // Scatter by the inner material in the facet's frame.
                let (t1, t2) = basis_f64(m.as_dvec3());
                let (t1, t2) = (t1.as_vec3(), t2.as_vec3());
                let to_local = |v: Vec3| Vec3::new(v.dot(t1), v.dot(t2), v.dot(m));
                let wi_loc = to_local(wi_l);
                if let Some(tg) = target
                    && tg.wo.dot(m) > 0.0
                {
                    let f = inner.eval(wi_loc, to_local(tg.wo), rng);
                    let tr = (-tg.sigma_esc * t / tg.esc.z as f64).exp() as f32;
                    *acc += weight * f * tr;
                }
                let s = inner.sample(wi_loc, rng);
                if s.flags != crate::bsdf::SAMPLE_REFLECTION {
                    break;
                }
                weight *= s.weight;
                w = (t1 * s.wo.x + t2 * s.wo.y + m * s.wo.z).normalize_or_zero();
                if weight.max_element() <= 0.0 || !w.is_finite() || w == Vec3::ZERO {
                    break;
                }
                continue;
            }
            match self.facet {
                Facet::Conductor { .. } => {
                    weight *= self.facet.conductor_fresnel(ci);
                    w = reflect(wi_l, m);
                }
                Facet::Diffuse { albedo } => {
                    if let Some(tg) = target {
                        // NEE with the sampled normal (opaque facets: side 0).
                        let cm = tg.wo.dot(m);
                        if cm > 0.0 {
                            let tr = (-tg.sigma_esc * t / tg.esc.z as f64).exp() as f32;
                            *acc += weight * albedo * (cm * std::f32::consts::FRAC_1_PI * tr);
                        }
                    }
                    weight *= albedo;
                    let (e1, e2) = basis_f64(m.as_dvec3());
                    let r = rng.next_f64().sqrt();
                    let phi = 2.0 * PI * rng.next_f64();
                    let d = e1 * (r * phi.cos())
                        + e2 * (r * phi.sin())
                        + m.as_dvec3() * (1.0 - r * r).max(0.0).sqrt();
                    w = d.normalize().as_vec3();
                }
                Facet::Dielectric { .. } => {
                    let eta = self.eta(side);
                    let f = fresnel::dielectric(ci, eta);
                    if rng.next_f32() < f {
                        w = reflect(wi_l, m);
                    } else {
                        match refract(wi_l, m, eta) {
                            Some(wt) => {
                                w = -wt;
                                side ^= 1;
                                t = flip_depth(t);
                            }
                            None => w = reflect(wi_l, m),
                        }
                    }
                }
            }
            if weight.max_element() <= 0.0 || !w.is_finite() || w == Vec3::ZERO {
                break;
            }
        }
        WalkEnd {
            dir: Vec3::ZERO,
            weight: Vec3::ZERO,
            escaped: false,
        }
    }

    /// Orients `wi` upwards (two-sided opaque facets mirror; a dielectric
    /// seen from below has the inverse index). Returns the model to use.
    #[inline]
    fn oriented(&self, wi: Vec3) -> (NullScattering, bool) {
        if wi.z >= 0.0 {
            return (*self, false);
        }
        let mut m = *self;
        if let Facet::Dielectric { eta } = self.facet {
            m.facet = Facet::Dielectric { eta: 1.0 / eta };
        }
        (m, true)
    }

    /// One sampled walk with its statistics (for measurements).
    pub fn sample_with_stats(&self, wi: Vec3, rng: &mut Rng, stats: &mut WalkStats) -> Sample {
        let (model, flipped) = self.oriented(wi);
        let wi_l = if flipped { flip_z(wi) } else { wi };
        let mut acc = Vec3::ZERO;
        let end = model.walk(wi_l, rng, None, &mut acc, stats);
        if !end.escaped {
            return Sample::ABSORBED;
        }
        let wo = if flipped { flip_z(end.dir) } else { end.dir };
        if wo.z == 0.0 {
            return Sample::ABSORBED;
        }
        let pdf = self.pdf(wi, wo);
        Sample::new(wi, wo, end.weight, pdf)
    }

    /// One eval estimate from the walk started at `wi` alone, with its
    /// statistics (for measurements; [`ScatterModel::eval`] averages it with
    /// the reverse walk).
    pub fn eval_with_stats(
        &self,
        wi: Vec3,
        wo: Vec3,
        rng: &mut Rng,
        stats: &mut WalkStats,
    ) -> Vec3 {
        let (model, flipped) = self.oriented(wi);
        let (wi_l, wo_l) = if flipped {
            (flip_z(wi), flip_z(wo))
        } else {
            (wi, wo)
        };
        let side = if wo_l.z > 0.0 { 0 } else { 1 };
        if side == 1 && !matches!(self.facet, Facet::Dielectric { .. }) {
            return Vec3::ZERO;
        }
        let esc = if side == 0 { wo_l } else { -wo_l };
        let tg = Target {
            wo: wo_l,
            side,
            esc,
            sigma_esc: model.ndf.sigma(-esc),
        };
        let mut acc = Vec3::ZERO;
        model.walk(wi_l, rng, Some(&tg), &mut acc, stats);
        acc
    }
}

impl NullScattering {
    /// The reciprocal eval estimate: the mean of the walk from `wi` with
    /// next-event estimation towards `wo` and the walk from `wo` towards
    /// `wi`, the latter scaled by the generalised reciprocity
    /// `f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2`. One direction alone is
    /// unbiased too ([`NullScattering::eval_with_stats`]) but heavy-tailed
    /// for grazing `wo` (a grazing exit needs a collision near the top), which
    /// the reverse walk samples directly (as Heitz et al. 2016 average).
    pub fn eval_reciprocal(
        &self,
        wi: Vec3,
        wo: Vec3,
        rng: &mut Rng,
        stats: &mut WalkStats,
    ) -> Vec3 {
        let a = self.eval_with_stats(wi, wo, rng, stats);
        let b = self.eval_with_stats(wo, wi, rng, stats);
        let mut scale = wo.z.abs() / wi.z.abs();
        if let (Facet::Dielectric { eta }, true) = (self.facet, opposite_sides(wi, wo)) {
            let r = if wi.z > 0.0 { eta } else { 1.0 / eta }; // eta_o / eta_i
            scale *= r * r;
        }
        0.5 * (a + b * scale)
    }
}

impl ScatterModel for NullScattering {
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let mut st = WalkStats::default();
        self.eval_reciprocal(wi, wo, rng, &mut st)
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        let mut st = WalkStats::default();
        self.sample_with_stats(wi, rng, &mut st)
    }

    fn sample_with(&self, wi: Vec3, _u: [f32; 3], rng: &mut Rng) -> Sample {
        // The null-collision walk draws its collision distances and facet
        // normals by rejection (d'Eon 2023, sec. 3.1): a fixed number of
        // caller uniforms cannot select them, so all of the walk's numbers
        // come from rng.
        self.sample(wi, rng)
    }

    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let c = wo.z.abs() * std::f32::consts::FRAC_1_PI;
        match self.facet {
            Facet::Dielectric { .. } => 0.5 * c,
            _ => {
                if same_side(wi, wo) {
                    c
                } else {
                    0.0
                }
            }
        }
    }
}
