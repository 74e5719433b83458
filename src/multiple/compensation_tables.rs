//! The single-scattering albedo tables of `MSBSDF_MODEL_ENERGY_COMPENSATED`:
//! compact binary files under `src/tables/` (format: [`super::bintable`];
//! each file's header records what it holds, its shape, the generating
//! command and the commit), written by
//! `cargo run --release --example gen_compensation` from the SINGLE model by
//! deterministic quadrature and decoded into these arrays at compile time
//! (`DIELECTRIC_E` rounded to 16 bits, [`Q16`]: absolute error at most
//! 7.8e-6; 98 kB instead of 197 kB).
//! Index order: `[ndf: Beckmann, GGX][side: eta >= 1, 1/eta]?[eta][alpha][mu]`.

use super::bintable::{Q16, decode2, decode3, decode5_q16};

/// Number of mu (cosine) grid points.
pub const MU_N: usize = 32;
/// Number of alpha grid points.
pub const ALPHA_N: usize = 24;
/// Number of eta grid points.
pub const ETA_N: usize = 16;
/// Smallest tabulated mu.
pub const MU_MIN: f32 = 0.01;

/// Conductor albedo with F = 1.
pub static CONDUCTOR_E: [[[f32; MU_N]; ALPHA_N]; 2] =
    decode3(include_bytes!("../tables/conductor_e.bin"));
/// Cosine-weighted average of the conductor albedo.
pub static CONDUCTOR_E_AVG: [[f32; ALPHA_N]; 2] =
    decode2(include_bytes!("../tables/conductor_e_avg.bin"));
/// Dielectric reflected + transmitted albedo ([`Q16`]).
pub static DIELECTRIC_E: [[[[[Q16; MU_N]; ALPHA_N]; ETA_N]; 2]; 2] =
    decode5_q16(include_bytes!("../tables/dielectric_e.bin"));
