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
    /// Draws wo from caller uniforms: u[0] chooses the lobe at the first vertex, u[1], u[2] the 2D sample of the first visible-normal draw; stochastic models take the rest from rng.
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
