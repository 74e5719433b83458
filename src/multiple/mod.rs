//! Multiple-scattering models, one file per method.

pub mod heitz;
pub mod null_scattering;
