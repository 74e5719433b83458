//! What a single microfacet does with light: the facet material shared by all
//! models (Fresnel from `fresnel.rs`, nothing about distributions).

use crate::fresnel;
use glam::Vec3;

/// The scattering of one microfacet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Facet {
    /// A mirror-like conductor with complex index `eta + i k` per RGB channel
    /// (`eta = 0, k = 1` reflects everything: the furnace-test facet).
    Conductor {
        /// Real part of the index per channel.
        eta: Vec3,
        /// Imaginary part (extinction) per channel.
        k: Vec3,
    },
    /// A smooth dielectric interface; `eta` = inside / outside index.
    Dielectric {
        /// Relative index of the material below the surface.
        eta: f32,
    },
    /// A Lambertian facet with the given albedo per channel.
    Diffuse {
        /// Diffuse albedo per channel, each in [0, 1].
        albedo: Vec3,
    },
}

impl Facet {
    /// Conductor Fresnel reflectance for the cosine between the incident
    /// direction and the facet normal (1 for non-conductors, and exactly 1
    /// without computing it for the perfect reflector `eta = 0, k = 1`).
    #[inline]
    pub fn conductor_fresnel(&self, cos_i: f32) -> Vec3 {
        match *self {
            Facet::Conductor { eta, k } if !(eta == Vec3::ZERO && k == Vec3::ONE) => {
                fresnel::conductor_rgb(cos_i, eta, k)
            }
            _ => Vec3::ONE,
        }
    }
}
