//! The single-scattering albedo with F = 1 of anisotropic conductor facets
//! for `MSBSDF_MODEL_ENERGY_COMPENSATED`: a compact binary file under
//! `src/tables/` (format: [`super::bintable`]; its header records the
//! quadrature, the command and the commit), written by
//! `cargo run --release --example gen_compensation -- --aniso` and decoded
//! into this array at compile time, each value rounded to 16 bits
//! ([`Q16`]: absolute error at most 7.8e-6; 115 kB instead of 229 kB).
//! Index order: `[ndf: Beckmann, GGX][alpha_x][alpha_y][phi][mu]`.

use super::bintable::{Q16, decode5_q16};

/// Number of mu grid points.
pub const AN_MU: usize = 16;
/// Number of azimuth grid points on [0, pi/2].
pub const AN_PHI: usize = 7;
/// Number of alpha grid points per axis.
pub const AN_A: usize = 16;

/// Conductor albedo with F = 1 ([`Q16`]).
pub static CONDUCTOR_E_ANISO: [[[[[Q16; AN_MU]; AN_PHI]; AN_A]; AN_A]; 2] =
    decode5_q16(include_bytes!("../tables/conductor_e_aniso.bin"));
