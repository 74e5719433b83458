//! Multiple-scattering models, one file per method.

pub mod bitterli_deon;
pub mod heitz;
pub mod invariance;
