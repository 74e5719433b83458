//! What every scattering model provides, and the sample record it returns.
//!
//! The [`Material`](crate::Material) dispatches to the models by `match` over
//! an enum (no `dyn`, no heap); each model implements [`ScatterModel`].
//! Directions reaching a model are unit vectors with `wi.z != 0` and
//! `wo.z != 0`; the model returns `f(wi, wo) |wo.z|` ("f times cosine").

use crate::rng::Rng;
use glam::Vec3;

/// `sample` went to the upper hemisphere (same side as `wi`).
pub const SAMPLE_REFLECTION: u32 = 1;
/// `sample` went to the other side of the surface.
pub const SAMPLE_TRANSMISSION: u32 = 2;
/// The path ended inside the surface (or below it for an opaque model);
/// the weight is zero.
pub const SAMPLE_ABSORBED: u32 = 4;

/// The sample is a Dirac lobe (specular regime): `pdf` is the discrete
/// probability of the lobe, not a density (set only in [`SampleRecord`]).
pub const SAMPLE_SPECULAR: u32 = 8;
/// The sample comes from a lobe with a density (set only in [`SampleRecord`]).
pub const SAMPLE_GLOSSY: u32 = 16;

/// The material reflects.
pub const MATERIAL_REFLECTION: u32 = 1;
/// The material transmits (dielectric facets).
pub const MATERIAL_TRANSMISSION: u32 = 2;
/// The material is smooth (alpha below [`SPECULAR_ALPHA`](crate::desc::SPECULAR_ALPHA)):
/// Dirac lobes only, eval and pdf are 0, sample gives the lobes.
pub const MATERIAL_SPECULAR: u32 = 4;
/// The material has lobes with a density (not specular).
pub const MATERIAL_GLOSSY: u32 = 8;
/// The roughness differs along x and y.
pub const MATERIAL_ANISOTROPIC: u32 = 16;
/// eval is a Monte Carlo estimate (it needs an [`Rng`]).
pub const MATERIAL_STOCHASTIC_EVAL: u32 = 32;
/// pdf approximates the density of sample (fine for MIS; pbrt-v4's
/// `pdfIsProportional`).
pub const MATERIAL_APPROXIMATE_PDF: u32 = 64;

/// Lobes a query may use: reflection (the side of `wi`).
pub const LOBE_REFLECTION: u32 = 1;
/// Lobes a query may use: transmission (the other side).
pub const LOBE_TRANSMISSION: u32 = 2;
/// Both lobes.
pub const LOBE_ALL: u32 = LOBE_REFLECTION | LOBE_TRANSMISSION;

/// What the path carries across a refraction (pbrt-v4's `TransportMode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Transport {
    /// Radiance (camera paths): transmission is scaled by `1 / eta^2`, with
    /// `eta` the relative index of the side of `wo` over the side of `wi`.
    #[default]
    Radiance,
    /// Importance (light paths), the flux-conserving form the calls without
    /// a context return.
    Importance,
}

/// Per-call options of the context-taking queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Context {
    /// Radiance or importance.
    pub transport: Transport,
    /// Allowed lobes: [`LOBE_REFLECTION`], [`LOBE_TRANSMISSION`] or both.
    pub lobes: u32,
}

impl Default for Context {
    /// Radiance, both lobes.
    fn default() -> Self {
        Context {
            transport: Transport::Radiance,
            lobes: LOBE_ALL,
        }
    }
}

impl Context {
    /// The context under which the calls without one answer (importance,
    /// both lobes).
    pub const PLAIN: Context = Context {
        transport: Transport::Importance,
        lobes: LOBE_ALL,
    };

    /// True when `wo` lies in an allowed lobe for `wi`.
    #[inline]
    pub fn allows(&self, wi: Vec3, wo: Vec3) -> bool {
        if same_side(wi, wo) {
            self.lobes & LOBE_REFLECTION != 0
        } else if opposite_sides(wi, wo) {
            self.lobes & LOBE_TRANSMISSION != 0
        } else {
            false
        }
    }
}

/// A sample with what an integrator needs besides the direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleRecord {
    /// Direction, weight and pdf (flags as in [`Sample`]).
    pub sample: Sample,
    /// [`Sample::flags`] plus [`SAMPLE_SPECULAR`] or [`SAMPLE_GLOSSY`].
    pub flags: u32,
    /// Relative index of the side of `wo` over the side of `wi` (1 for
    /// reflection and absorption).
    pub eta: f32,
}

/// The result of sampling an outgoing direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Outgoing unit direction (zero when absorbed).
    pub wo: Vec3,
    /// `f(wi, wo) |wo.z| / pdf(wo)` per RGB channel; for stochastic models an
    /// unbiased estimate of it.
    pub weight: Vec3,
    /// Density of `wo` per solid angle as `pdf()` reports it (0 when absorbed).
    pub pdf: f32,
    /// One of [`SAMPLE_REFLECTION`], [`SAMPLE_TRANSMISSION`], [`SAMPLE_ABSORBED`].
    pub flags: u32,
}

impl Sample {
    /// The empty sample: the path was absorbed.
    pub const ABSORBED: Sample = Sample {
        wo: Vec3::ZERO,
        weight: Vec3::ZERO,
        pdf: 0.0,
        flags: SAMPLE_ABSORBED,
    };

    /// A sample in direction `wo` leaving from the side of `wi`.
    #[inline]
    pub fn new(wi: Vec3, wo: Vec3, weight: Vec3, pdf: f32) -> Sample {
        let flags = if same_side(wo, wi) {
            SAMPLE_REFLECTION
        } else {
            SAMPLE_TRANSMISSION
        };
        Sample {
            wo,
            weight,
            pdf,
            flags,
        }
    }
}

/// True when `a` and `b` are strictly on the same side of the surface (both
/// z > 0 or both z < 0). Unlike `a.z * b.z > 0`, this does not underflow to
/// "not the same side" for tiny (subnormal) z, which the C API accepts
/// (found by fuzz/dirs_fuzz.c: wi.z = 1.4e-45 with wo.z = 0.44).
#[inline]
pub fn same_side(a: Vec3, b: Vec3) -> bool {
    (a.z > 0.0 && b.z > 0.0) || (a.z < 0.0 && b.z < 0.0)
}

/// True when `a` and `b` are strictly on opposite sides of the surface
/// (see [`same_side`] for why this is not `a.z * b.z < 0`).
#[inline]
pub fn opposite_sides(a: Vec3, b: Vec3) -> bool {
    (a.z > 0.0 && b.z < 0.0) || (a.z < 0.0 && b.z > 0.0)
}

/// The three queries every model answers. Implementations must not allocate,
/// lock or touch globals.
pub trait ScatterModel {
    /// `f(wi, wo) |wo.z|`, an unbiased estimate for stochastic models.
    fn eval(&self, wi: Vec3, wo: Vec3, rng: &mut Rng) -> Vec3;
    /// Draws `wo` given `wi`.
    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample;
    /// Draws `wo` from caller uniforms: `u[0]` chooses the lobe at the first
    /// vertex, `u[1], u[2]` the 2D sample of the first visible-normal draw;
    /// stochastic models take the rest from `rng`.
    fn sample_with(&self, wi: Vec3, u: [f32; 3], rng: &mut Rng) -> Sample;
    /// Density of `sample` choosing `wo` (an approximation for stochastic models,
    /// positive wherever `sample` can go).
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Subnormal z (accepted by the C API) must not make `a.z * b.z`
    /// underflow into "not the same side" (fuzz/corpus/dirs_fuzz/
    /// regress-subnormal-wi-z-same-side: the random walk reflected a
    /// direction that eval and pdf then called unreachable).
    #[test]
    fn sides_of_subnormal_directions() {
        let tiny = Vec3::new(-1.0, 0.0, 1.4e-45);
        let up = Vec3::new(0.3, 0.2, 0.44);
        assert_eq!(tiny.z * up.z, 0.0, "the product underflows");
        assert!(same_side(tiny, up) && !opposite_sides(tiny, up));
        assert!(opposite_sides(-tiny, up) && !same_side(-tiny, up));
        let flat = Vec3::new(1.0, 0.0, 0.0);
        assert!(!same_side(flat, up) && !opposite_sides(flat, up));
        assert_eq!(
            Sample::new(tiny, up, Vec3::ONE, 1.0).flags,
            SAMPLE_REFLECTION
        );
    }
}
