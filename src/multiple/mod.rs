//! Multiple-scattering models, one file per method.

pub mod null_scattering;
