//! The conductor Fresnel reflectance of the V-groove models, evaluated per
//! reflection in closed form on the three RGB channels at once (SIMD
//! `Vec3A`): the real closed form of the unpolarised conductor reflectance
//! (Born and Wolf, Sec. 14.4; the same form as
//! `crate::fresnel::conductor_rgb`, with the material's `eta^2 - k^2` and
//! `4 eta^2 k^2` computed once).
//!
//! The models used to read a per-material table (33 nodes in `sqrt(cos)`,
//! cubic interpolation) built and checked against the closed form when the
//! material was created: 7-8 us per material, most of the V-groove
//! `msbsdf_material_init`. On four SSE lanes the closed form costs about as
//! many instructions per reflection as the cubic interpolation (two square
//! roots and two divisions against a square root, the stencil and four
//! loads), needs nothing at creation, and is exact where the table had to
//! fall back (a reflectance with a kink, `k = 0`, `eta < 1`).
//! `tests/vgroove.rs` checks it against the complex form
//! `crate::fresnel::conductor` on a dense grid for several metals.

use crate::fresnel;
use glam::{Vec3, Vec3A};

/// A conductor's reflectance `F(c)` per RGB channel (complex index
/// `eta + i k`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FresnelTable {
    eta: Vec3,
    k: Vec3,
    /// `eta^2 - k^2` per channel.
    eta2_minus_k2: Vec3A,
    /// `4 eta^2 k^2` per channel.
    four_eta2_k2: Vec3A,
    /// True: every lookup is `crate::fresnel::conductor_rgb` (the
    /// reference for tests).
    exact: bool,
}

impl FresnelTable {
    /// The reflectance of the complex index `eta + i k` (no table is built:
    /// a few multiplications).
    pub fn new(eta: Vec3, k: Vec3) -> Self {
        let (eta2, k2) = (eta * eta, k * k);
        FresnelTable {
            eta,
            k,
            eta2_minus_k2: (eta2 - k2).into(),
            four_eta2_k2: (4.0 * eta2 * k2).into(),
            exact: false,
        }
    }

    /// `F(c)` per channel for the cosine `c` (clamped to `[0, 1]`), in
    /// `[0, 1]`; a non-finite intermediate falls back to
    /// `crate::fresnel::conductor_rgb`.
    #[inline]
    pub fn eval(&self, c: f32) -> Vec3A {
        if self.exact {
            return fresnel::conductor_rgb(c, self.eta, self.k).into();
        }
        // Plain comparisons (one instruction each; NaN goes to 0).
        let c = if c < 1.0 { c } else { 1.0 };
        let c = if c > 0.0 { c } else { 0.0 };
        let f =
            fresnel::conductor_closed_form(Vec3A::splat(c), self.eta2_minus_k2, self.four_eta2_k2);
        if f.is_finite() {
            f.clamp(Vec3A::ZERO, Vec3A::ONE)
        } else {
            fresnel::conductor_rgb(c, self.eta, self.k).into()
        }
    }

    /// The same reflectance through `crate::fresnel::conductor_rgb` at
    /// every lookup (the reference for tests).
    pub fn exact(mut self) -> Self {
        self.exact = true;
        self
    }
}
