//! The specular regime: a conductor or dielectric surface with roughness
//! below [`SPECULAR_ALPHA`](crate::desc::SPECULAR_ALPHA) (or 0) is a smooth
//! interface with Dirac lobes, as pbrt-v4 does below alpha 1e-3 (Pharr et
//! al. 2023, `TrowbridgeReitzDistribution::EffectivelySmooth`). eval and pdf
//! are 0 for every pair of directions (a Dirac lobe has no density); sample
//! returns the mirror (and refracted) direction with weight Fresnel over the
//! lobe's discrete probability, reported as `pdf`.
//!
//! Conductors are two-sided here as in every model: a `wi` below the surface
//! is mirrored below (the one-sided option is applied by the material).

use crate::bsdf::{LOBE_ALL, LOBE_REFLECTION, LOBE_TRANSMISSION, Sample, ScatterModel};
use crate::facet::Facet;
use crate::frame::{flip_z, reflect, refract};
use crate::fresnel;
use crate::rng::Rng;
use glam::Vec3;

/// A smooth conductor or dielectric interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Specular {
    facet: Facet,
}

impl Specular {
    /// The smooth surface with these facets (conductor or dielectric).
    pub fn new(facet: Facet) -> Self {
        Specular { facet }
    }

    /// Picks the lobe with `u0` among `lobes`: reflection with probability
    /// `F` and refraction with `1 - F` when both are allowed, the allowed
    /// one with probability 1 otherwise; the weight is the lobe's Fresnel
    /// factor over that probability.
    pub fn sample_lobes(&self, wi: Vec3, u0: f32, lobes: u32) -> Sample {
        let n = Vec3::Z;
        match self.facet {
            Facet::Dielectric { eta } => {
                let (wi_l, eta_l, flipped) = if wi.z < 0.0 {
                    (flip_z(wi), 1.0 / eta, true)
                } else {
                    (wi, eta, false)
                };
                let f = fresnel::dielectric(wi_l.z, eta_l);
                let both = lobes & LOBE_ALL == LOBE_ALL;
                let reflect_here = if both {
                    u0 < f
                } else if lobes & LOBE_REFLECTION != 0 {
                    true
                } else if lobes & LOBE_TRANSMISSION != 0 {
                    false
                } else {
                    return Sample::ABSORBED;
                };
                let (wo, fresnel_factor) = if reflect_here {
                    (reflect(wi_l, n), f)
                } else {
                    match refract(wi_l, n, eta_l) {
                        Some(wo) if wo.z < 0.0 => (wo, 1.0 - f),
                        _ => return Sample::ABSORBED,
                    }
                };
                if fresnel_factor <= 0.0 {
                    return Sample::ABSORBED;
                }
                let p = if both { fresnel_factor } else { 1.0 };
                let wo = if flipped { flip_z(wo) } else { wo };
                Sample::new(wi, wo, Vec3::splat(fresnel_factor / p), p)
            }
            _ => {
                if lobes & LOBE_REFLECTION == 0 {
                    return Sample::ABSORBED;
                }
                let cos = wi.z.abs();
                let wo = Vec3::new(-wi.x, -wi.y, wi.z);
                Sample::new(wi, wo, self.facet.conductor_fresnel(cos), 1.0)
            }
        }
    }
}

impl ScatterModel for Specular {
    fn eval(&self, _wi: Vec3, _wo: Vec3, _rng: &mut Rng) -> Vec3 {
        Vec3::ZERO
    }

    fn sample(&self, wi: Vec3, rng: &mut Rng) -> Sample {
        let u0 = match self.facet {
            Facet::Dielectric { .. } => rng.next_f32(),
            _ => 0.0,
        };
        self.sample_lobes(wi, u0, LOBE_ALL)
    }

    fn sample_with(&self, wi: Vec3, u: [f32; 3], _rng: &mut Rng) -> Sample {
        self.sample_lobes(wi, u[0], LOBE_ALL)
    }

    fn pdf(&self, _wi: Vec3, _wo: Vec3) -> f32 {
        0.0
    }
}
