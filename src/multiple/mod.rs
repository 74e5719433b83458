//! Multiple-scattering models, one file per method.

pub mod bitterli_deon;
pub mod invariance;
