//! The multiple-scattering methods, one file each.

pub mod auto;
pub mod auto_table;
pub mod bintable;
pub mod bitterli_deon;
pub mod compensation;
#[doc(hidden)]
pub mod compensation_aniso_tables;
#[doc(hidden)]
pub mod compensation_ms_tables;
#[doc(hidden)]
pub mod compensation_tables;
pub mod heitz;
pub mod invariance;
pub mod microsurface;
pub mod null_scattering;
pub mod position_free;
pub mod tabulated;
pub mod tabulated_dielectric;
pub mod vgroove;
