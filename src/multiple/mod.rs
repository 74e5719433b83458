//! The multiple-scattering methods, one file each.

pub mod position_free;
