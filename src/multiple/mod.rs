//! The multiple-scattering methods, one file each.

pub mod compensation;
#[doc(hidden)]
pub mod compensation_tables;
pub mod heitz;
pub mod position_free;
pub mod vgroove;
