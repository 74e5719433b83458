//! Multiple-scattering models, one file per method.

pub mod heitz;
