//! The Fresnel tint tables of the conductor multiple-scattering lobe of
//! `MSBSDF_MODEL_ENERGY_COMPENSATED`: compact binary files under
//! `src/tables/` (format: [`super::bintable`]; each file's header records
//! the walk, its seeds and sample counts, the command and the commit),
//! written by `cargo run --release --example gen_compensation -- --ms` from
//! Heitz et al. 2016 walks with F = 1 per (NDF, alpha, mu) grid cell of
//! `compensation_tables`, decoded into these arrays at compile time.
//! Index order: `[ndf: Beckmann, GGX][alpha][mu][bin or F0 node]`.

use super::bintable::{Q16, decode4, decode4_q16};
use super::compensation_tables::{ALPHA_N, MU_N};

/// Uniform cosine bins of [`CONDUCTOR_MS_COS_HIST`].
pub const MS_BINS: usize = 16;
/// Schlick `F0` nodes (uniform on [0, 1]) of [`CONDUCTOR_MS_TINT`].
pub const F0_N: usize = 17;

/// Distribution of the reflection cosines `|w.m|` of multiply scattered
/// paths (every reflection counts once).
pub static CONDUCTOR_MS_COS_HIST: [[[[f32; MS_BINS]; MU_N]; ALPHA_N]; 2] =
    decode4(include_bytes!("../tables/conductor_ms_cos_hist.bin"));
/// Mean over multiply scattered paths of `prod_j S(c_j; F0)`, Schlick's
/// reflectance, in 16 bits ([`Q16`]: the values are in `[0, 1]`; 52 kB
/// less in the library than f32, for the library's size budget, at an
/// absolute rounding error of 7.7e-6).
pub static CONDUCTOR_MS_TINT: [[[[Q16; F0_N]; MU_N]; ALPHA_N]; 2] =
    decode4_q16(include_bytes!("../tables/conductor_ms_tint.bin"));
