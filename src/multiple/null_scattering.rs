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
//! unit sphere (density `max(0, -w.m) / pi`: a cosine lobe about `-w`);
//! the collision is real with probability `D(m) / D_max`, otherwise the
//! walk goes on unchanged (delta tracking in the angular domain). A real
//! collision scatters by the facet: conductor (mirror, weight `F`),
//! dielectric (reflect with probability `F`, else refract to the other
//! side), or Lambertian. The walk ends when the depth becomes negative; the
//! exit direction and weight are returned.
//!
//! For Beckmann, GGX and Student-T the first real collision is drawn
//! directly instead: a ray entering along `w` meets real facets at the rate
//! `sigma(-w)` (closed form) with normals of density `D_{-w}`, which the
//! walk kernel samples from two uniforms. This is the same distribution
//! (the null collisions only thin the constant-rate process to it), so the
//! first vertex can take the caller's uniforms (`sample_with`: `u[0]`
//! reflect or refract, `u[1], u[2]` the visible normal); the later vertices,
//! and every vertex of vMF, exponential and K0 (normals by rejection), take
//! their numbers from the generator. It also halves the instructions of a
//! GGX sample at alpha 0.5 (`docs/null_scattering.md`).
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
//! Beckmann, GGX, Student-T (the crate's [`Ndf`], whose `D`, cross-section
//! and visible normals the walk uses; `gamma >= 2`: below 2 the NDF is
//! unbounded at the horizon, refused), von Mises-Fisher `D = C exp(2 (u - 1) / alpha^2)`
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
//! dielectrics (the kernel's approximate pdf with no single-scattering part).
//!
//! ## On the walk kernel
//! What every walk shares comes from `microsurface.rs`: the per-side frames
//! and index (a refraction mirrors the frame, `Microsurface::eta`), facet
//! scattering (`Microsurface::scatter_at`: conductor with its Fresnel,
//! dielectric reflect or refract with the side flip, Lambert lobe), the
//! phase function (`Microsurface::phase_over`, the kernel's phase for a
//! normal density over the whole sphere and a given collision rate; diffuse
//! facets with the drawn normal, `Microsurface::phase`), the first vertex's
//! visible normals, the cosine lobe, the reciprocity factor and the
//! approximate pdf. What stays here, and why:
//! - the NDFs that are not the crate's [`Ndf`] (vMF, exponential, K0: see
//!   [`NullNdf`]), the majorant `D_max`, and the Dirac-quadrature
//!   cross-section;
//! - the walk loop itself. The kernel's `DepthState` gives the next *real*
//!   vertex from Smith's `Lambda` and then draws its normal from the
//!   visible normals of an [`Ndf`]; the null-collision walk draws
//!   *tentative* collisions at the constant rate `pi D_max`, proposes the
//!   normal with the collision and accepts it with `D(m) / D_max`, and
//!   eval's next-event estimate is taken at every tentative collision
//!   (normalised by the tentative rate, so `sigma` of the travel direction
//!   is never needed). Its depth is the optical depth `t` (escape
//!   `exp(-sigma(-o) t / o.z)`, mirrored to `-ln(1 - e^-t)` by a
//!   refraction): Heitz et al.'s height with `C1 = e^-t`, defined for
//!   full-sphere NDFs, which have no `Lambda`;
//! - no Russian roulette: the weight is a product of Fresnel factors, and
//!   the walk ends at the bounce limit ([`DEFAULT_BOUNCES`]);
//! - composition (`with_inner`): facets that scatter as another material.
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
//! The cost grows like `1 / alpha^2`; at alpha 0.2 a sample costs 3.5 to 15
//! times what it costs at alpha 1 (Student-T, Beckmann and GGX, whose first
//! collision is drawn directly, 3.5 to 9 times; vMF 8, exponential 15), an
//! eval 5 to 20 times (the paper recommends alpha >= 0.4).
//! [`Material::new`](crate::Material::new) refuses roughness below
//! [`MIN_ALPHA`] = 0.2 with `Error::InvalidArgument`. Eval costs more than
//! sample: two walks (reciprocal estimate), a next-event estimate at every
//! tentative collision, and for vMF and exponential two quadrature
//! cross-sections (about 1.3 and 2.3 us each).
//!
//! Composition (`MSBSDF_FACET_MATERIAL`, d'Eon 2023 section 4): facets that
//! scatter as another opaque material ([`NullScattering::with_inner`]).

use crate::bsdf::{Sample, ScatterModel, same_side};
use crate::desc::{MaterialDesc, NdfId};
use crate::facet::Facet;
use crate::frame::{basis, flip_z};
use crate::math::{FRAC_1_SQRT_PI, erf, erfcx_pos};
use crate::multiple::microsurface::{
    Microsurface, NormalDensity, approximate_pdf, cosine_about, first_uniforms,
};
use crate::ndf::{Ndf, NdfKind, beckmann};
use crate::rng::Rng;
use crate::specfun::bessel_k;
use crate::status::Error;
use glam::Vec3;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Smallest roughness accepted (see the module docs: below it the rejection
/// rate makes an eval cost up to 20 times what it costs at alpha 1).
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
///
/// Beckmann, GGX and Student-T are the crate's [`Ndf`]: `D`, the
/// cross-section and the visible normals come from it, and the majorant is
/// its `D` at the peak. vMF, exponential and K0 are formulas of their own
/// (d'Eon 2023, eqs. 40-43 and sec. 5.3): full-sphere or unbounded at the
/// top, with no Smith `Lambda` in closed form (vMF, exponential) and no
/// visible-normal sampler of two uniforms; they stay here.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NullNdf {
    kind: NullNdfKind,
    /// The crate's NDF (Beckmann, GGX, Student-T), `None` for the others.
    smith: Option<Ndf>,
    /// Roughness of the isotropic vMF, exponential and K0 distributions.
    alpha: f64,
    /// Constant majorant `D_max >= D(m)` for all `m`.
    d_max: f64,
    /// vMF normalisation `C`.
    c: f64,
}

/// Relative margin of the majorant over the peak value of `D`: the crate's
/// `D` is single precision, so the value the walk computes near the peak
/// may exceed the one computed at it by a few ulps.
const MAJORANT_MARGIN: f64 = 1e-5;

/// `D` of a height-field NDF at the normal of slope `sqrt(tan2)` along the
/// x axis (`tan2` infinite: the horizon limit, approached from above).
fn d_at_slope(ndf: &Ndf, tan2: f64) -> f64 {
    let m = if tan2.is_finite() {
        glam::DVec3::new(tan2.sqrt(), 0.0, 1.0)
            .normalize()
            .as_vec3()
    } else {
        Vec3::new(1.0, 0.0, f32::MIN_POSITIVE)
    };
    ndf.d(m) as f64
}

impl NullNdf {
    /// Builds the distribution; `None` when the combination is unsupported
    /// (anisotropic vMF / exponential / K0, Student-T shape below 2).
    pub fn new(kind: NullNdfKind, ax: f32, ay: f32, shape: f32) -> Option<NullNdf> {
        let iso = ax == ay;
        let a = ax.max(ay) as f64;
        let mut c = 0.0;
        let mut smith = None;
        let d_max = match kind {
            NullNdfKind::Beckmann | NullNdfKind::Ggx | NullNdfKind::StudentT => {
                let g = shape as f64;
                let ndf_kind = match kind {
                    NullNdfKind::Beckmann => NdfKind::Beckmann,
                    NullNdfKind::Ggx => NdfKind::Ggx,
                    _ if g.is_nan() || g < 2.0 => return None,
                    _ => NdfKind::StudentT,
                };
                // `D` along the rougher axis, whose slopes it favours, is
                // largest at the top or at `tan^2 theta = x`: Beckmann
                // `2 a^2 - 1`; GGX and Student-T 2 the horizon (`a^4 / (pi
                // a_x a_y)`); Student-T above 2, where
                // d/dx [-g ln(1 + x / ((g - 1) a^2)) + 2 ln(1 + x)] = 0.
                let x = match kind {
                    NullNdfKind::Beckmann => 2.0 * a * a - 1.0,
                    _ if ndf_kind == NdfKind::Ggx || g == 2.0 => f64::INFINITY,
                    _ => (2.0 * (g - 1.0) * a * a - g) / (g - 2.0),
                };
                // The rougher axis as x.
                let (rx, ry) = if ax >= ay { (ax, ay) } else { (ay, ax) };
                let n = Ndf::with_shape(ndf_kind, rx, ry, shape);
                smith = Some(Ndf::with_shape(ndf_kind, ax, ay, shape));
                d_at_slope(&n, 0.0).max(d_at_slope(&n, x.max(0.0)))
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
            smith,
            alpha: a,
            d_max: d_max * (1.0 + MAJORANT_MARGIN),
            c,
        })
    }

    /// The kind.
    pub fn kind(&self) -> NullNdfKind {
        self.kind
    }

    /// The crate's NDF for Beckmann, GGX and Student-T; `None` for the
    /// others.
    pub fn smith(&self) -> Option<&Ndf> {
        self.smith.as_ref()
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

    /// `D(m)` per steradian on the whole sphere, `integral D(m) m.z dm = 1`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f64 {
        match (&self.smith, self.kind) {
            (Some(n), _) => n.d(m) as f64,
            (None, NullNdfKind::Vmf) => {
                self.c * (2.0 * (m.z as f64 - 1.0) / (self.alpha * self.alpha)).exp()
            }
            (None, _) => self.d_iso(m.z as f64),
        }
    }

    /// `D` of an isotropic distribution as a function of the cosine `u`.
    pub fn d_iso(&self, u: f64) -> f64 {
        let a = self.alpha;
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
    /// exponential NDF; the closed forms of Beckmann, GGX, Student-T (the
    /// crate's [`Ndf::sigma`]) and K0 (eq. 42), equal to the quadrature
    /// within 2e-5 (`tests/null_scattering.rs`) and 700 times cheaper: 3 ns
    /// against 2.1-2.5 us, which made eval 2-3 times slower.
    pub fn sigma(&self, v: Vec3) -> f64 {
        match (&self.smith, self.kind) {
            (Some(n), _) => n.sigma(v) as f64,
            (None, NullNdfKind::BesselK0) => k0_sigma(self.alpha, v.z as f64),
            (None, _) => self.sigma_quadrature(v.z as f64),
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

impl NormalDensity for NullNdf {
    #[inline]
    fn density(&self, m: Vec3) -> f64 {
        self.d(m)
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
    /// `wo` in the world frame.
    wo: Vec3,
    /// Cosine of `wo` on its own side (> 0).
    esc_z: f64,
    /// Real cross-section for leaving along `wo` on its side:
    /// `sigma(-esc)`, `esc = wo` seen from its side.
    sigma_esc: f64,
}

/// The null-scattering multiple-scattering BSDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NullScattering {
    ndf: NullNdf,
    /// The walk kernel's microsurface: facet scattering, Fresnel, per-side
    /// index, reciprocity, approximate pdf, and for Beckmann, GGX and
    /// Student-T the first vertex's visible normals. Its `ndf` is the
    /// crate's NDF for those kinds; for vMF, exponential and K0 (not an
    /// [`Ndf`]) it is the Beckmann NDF of the same roughness, which nothing
    /// reads: the phase function takes [`NullNdf`]
    /// ([`Microsurface::phase_over`]).
    ms: Microsurface,
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

impl WalkEnd {
    /// Absorbed, cut or lost.
    const LOST: WalkEnd = WalkEnd {
        dir: Vec3::ZERO,
        weight: Vec3::ZERO,
        escaped: false,
    };
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
        let a = ndf.alpha as f32;
        let kernel_ndf = ndf.smith.unwrap_or(Ndf::new(NdfKind::Beckmann, a, a));
        NullScattering {
            ndf,
            ms: Microsurface::new(kernel_ndf, facet, max_bounces),
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

    /// Next-event estimate at a tentative collision at depth `t` of a ray
    /// travelling along `w` (frame of its side, `inside`, index `eta`) with
    /// tentative rate `rate`: the phase function per unit rate times the
    /// probability of leaving towards `wo` (after a refraction, from the
    /// mirrored depth on the other side).
    #[inline]
    fn nee(&self, tg: &Target, inside: bool, eta: f32, t: f64, w: Vec3, rate: f64) -> Vec3 {
        let o = if inside { flip_z(tg.wo) } else { tg.wo };
        let p = self.ms.phase_over(&self.ndf, w, o, eta, rate);
        if p == Vec3::ZERO {
            return Vec3::ZERO;
        }
        p * Self::escape(tg, if o.z < 0.0 { flip_depth(t) } else { t })
    }

    /// Transmittance towards the target from depth `t` on the target's side.
    #[inline]
    fn escape(tg: &Target, t: f64) -> f32 {
        (-tg.sigma_esc * t / tg.esc_z).exp() as f32
    }

    /// The walk from `wi` (world frame; opaque facets are two-sided, a
    /// dielectric seen from below has the inverse index). With a target,
    /// accumulates the next-event estimates into `acc` (then the returned
    /// end is irrelevant). `first`: uniforms for the first vertex (see
    /// [`ScatterModel::sample_with`]), used by Beckmann, GGX and Student-T.
    fn walk(
        &self,
        wi: Vec3,
        first: Option<[f32; 3]>,
        rng: &mut Rng,
        target: Option<&Target>,
        acc: &mut Vec3,
        stats: &mut WalkStats,
    ) -> WalkEnd {
        let ms = &self.ms;
        let mut inside = wi.z < 0.0;
        let to_side = |v: Vec3, inside: bool| if inside { flip_z(v) } else { v };
        let mut w = -to_side(wi, inside);
        let mut eta = ms.eta(inside);
        let mut t = 0.0f64;
        let mut weight = Vec3::ONE;
        let null = self.ndf.is_null();
        let rate_null = PI * self.ndf.d_max;
        let mut events = 0u32;
        // Facets whose phase has no closed form: NEE at real collisions only.
        let diffuse = matches!(ms.facet, Facet::Diffuse { .. }) || self.inner.is_some();
        // The first vertex from the caller's uniforms: the first real
        // collision of a ray entering along `w` is at rate `sigma(-w)`
        // with a normal of density `D_{-w}`, which the kernel samples.
        let mut first = first.and_then(|u| self.ndf.smith.map(|_| u));
        for _bounce in 0..ms.max_bounces {
            // Find the next real collision (or escape).
            let (m, u0) = if let Some(u) = first.take() {
                let rate = self.ndf.sigma(-w);
                if rate.is_nan() || rate <= 0.0 {
                    return WalkEnd::LOST;
                }
                t -= w.z as f64 * (-(1.0 - rng.next_f64()).ln() / rate);
                stats.tentative += 1;
                match ms.facet_normal(w, u[1], u[2]) {
                    Some((m, _)) => (m, u[0]),
                    None => return WalkEnd::LOST,
                }
            } else {
                let m = loop {
                    events += 1;
                    if events > MAX_EVENTS {
                        return WalkEnd::LOST;
                    }
                    let rate = if null { rate_null } else { self.ndf.sigma(-w) };
                    let wz = w.z as f64;
                    if rate.is_nan() || rate <= 0.0 {
                        if wz > 0.0 {
                            break None;
                        }
                        return WalkEnd::LOST;
                    }
                    t -= wz * (-(1.0 - rng.next_f64()).ln() / rate);
                    if t < 0.0 {
                        break None;
                    }
                    stats.tentative += 1;
                    if let (Some(tg), false) = (target, diffuse) {
                        *acc += weight * self.nee(tg, inside, eta, t, w, rate);
                    }
                    if !null {
                        break Some(k0_sample_visible(self.ndf.alpha as f32, -w, rng));
                    }
                    // Candidate normal: a uniform point of the disk
                    // orthogonal to w projected onto the sphere, i.e. a
                    // cosine lobe about -w (d'Eon 2023, sec. 3.1, fig. 4).
                    let m = cosine_about(-w, rng.next_f32(), rng.next_f32());
                    if rng.next_f64() * self.ndf.d_max < self.ndf.d(m) {
                        break Some(m);
                    }
                };
                let Some(m) = m else {
                    return WalkEnd {
                        dir: to_side(w, inside),
                        weight,
                        escaped: true,
                    };
                };
                let u0 = if ms.is_dielectric() {
                    rng.next_f32()
                } else {
                    0.0
                };
                (m, u0)
            };
            stats.real += 1;
            let ci = -w.dot(m);
            if ci <= 0.0 {
                continue; // rounding at the rim: treat as null
            }
            if let Some(inner) = &self.inner {
                // Scatter by the inner material in the facet's frame.
                let (t1, t2) = basis(m);
                let to_local = |v: Vec3| Vec3::new(v.dot(t1), v.dot(t2), v.dot(m));
                if let Some(tg) = target {
                    let o = to_side(tg.wo, inside);
                    if o.dot(m) > 0.0 {
                        let f = inner.eval(-to_local(w), to_local(o), rng);
                        *acc += weight * f * Self::escape(tg, t);
                    }
                }
                let s = inner.sample(-to_local(w), rng);
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
            if let (Some(tg), Facet::Diffuse { .. }) = (target, ms.facet) {
                // NEE with the sampled normal (opaque facets: same side).
                let o = to_side(tg.wo, inside);
                *acc += weight * ms.phase(w, o, eta, 1.0, m) * Self::escape(tg, t);
            }
            let Some(s) = ms.scatter_at(w, m, ci, eta, u0, rng) else {
                break;
            };
            weight *= s.weight;
            if s.refracted {
                inside = !inside;
                eta = 1.0 / eta;
                t = flip_depth(t);
            }
            w = s.w;
        }
        WalkEnd::LOST
    }

    /// One sampled walk with its statistics (for measurements), as
    /// [`ScatterModel::sample`].
    pub fn sample_with_stats(&self, wi: Vec3, rng: &mut Rng, stats: &mut WalkStats) -> Sample {
        // Only the kinds with a visible-normal sampler take uniforms.
        let u = match self.ndf.smith {
            Some(_) => first_uniforms(rng),
            None => [0.0; 3],
        };
        self.sample_uniforms(wi, u, rng, stats)
    }

    /// One sampled walk, `u` as in [`ScatterModel::sample_with`].
    fn sample_uniforms(
        &self,
        wi: Vec3,
        u: [f32; 3],
        rng: &mut Rng,
        stats: &mut WalkStats,
    ) -> Sample {
        let mut acc = Vec3::ZERO;
        let end = self.walk(wi, Some(u), rng, None, &mut acc, stats);
        if !end.escaped || end.dir.z == 0.0 {
            return Sample::ABSORBED;
        }
        Sample::new(wi, end.dir, end.weight, self.pdf(wi, end.dir))
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
        if !self.ms.is_dielectric() && !same_side(wi, wo) {
            return Vec3::ZERO;
        }
        let esc = Vec3::new(wo.x, wo.y, wo.z.abs());
        let tg = Target {
            wo,
            esc_z: esc.z as f64,
            sigma_esc: self.ndf.sigma(-esc),
        };
        let mut acc = Vec3::ZERO;
        self.walk(wi, None, rng, Some(&tg), &mut acc, stats);
        acc
    }

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
        let scale = wo.z.abs() / wi.z.abs() * self.ms.reciprocity_factor(wi, wo);
        0.5 * (a + b * scale)
    }
}

impl ScatterModel for NullScattering {
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3 {
        let mut st = WalkStats::default();
        self.eval_reciprocal(wi, wo, rng, &mut st)
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        self.sample_with_stats(wi, rng, &mut WalkStats::default())
    }

    /// Beckmann, GGX and Student-T: the first vertex takes `u[0]`
    /// (reflect or refract) and `u[1], u[2]` (its visible normal, drawn
    /// by the kernel); the rest of the walk, and for vMF, exponential and
    /// K0 all of it (normals drawn by rejection, d'Eon 2023, sec. 3.1),
    /// comes from `rng`.
    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample {
        self.sample_uniforms(wi, u, rng, &mut WalkStats::default())
    }

    /// The cosine lobe of the paper (section 3.3): the kernel's
    /// approximate pdf with no single-scattering part.
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        approximate_pdf(&self.ms, 1.0, wi, wo)
    }
}

impl NullScattering {
    /// NULL_SCATTERING for a validated description (without an inner
    /// material: `material.rs` composes one with [`Self::with_inner`]):
    /// roughness at least [`MIN_ALPHA`] (`Error::InvalidArgument` below:
    /// the rejection rate makes the walk impractical, d'Eon 2023, section
    /// 3.3); Beckmann, GGX, Student-T, vMF, exponential and K0 NDFs
    /// (`Error::Unsupported` for Phong and for shapes [`NullNdf::new`]
    /// refuses).
    pub(crate) fn from_desc(d: &MaterialDesc, facet: Facet) -> Result<Self, Error> {
        if d.alpha_x.min(d.alpha_y) < MIN_ALPHA {
            return Err(Error::InvalidArgument);
        }
        let kind = match d.ndf {
            NdfId::Beckmann => NullNdfKind::Beckmann,
            NdfId::Ggx => NullNdfKind::Ggx,
            NdfId::StudentT => NullNdfKind::StudentT,
            NdfId::Vmf => NullNdfKind::Vmf,
            NdfId::Exponential => NullNdfKind::Exponential,
            NdfId::BesselK0 => NullNdfKind::BesselK0,
            NdfId::Phong => return Err(Error::Unsupported),
        };
        let ndf = NullNdf::new(kind, d.alpha_x, d.alpha_y, d.shape).ok_or(Error::Unsupported)?;
        Ok(NullScattering::new(ndf, facet, d.max_bounces))
    }
}
