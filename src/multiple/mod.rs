//! The multiple-scattering methods, one file each.

pub mod heitz;
pub mod position_free;
