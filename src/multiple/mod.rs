//! Multiple-scattering models, one file per method.

pub mod compensation;
#[doc(hidden)]
pub mod compensation_tables;
pub mod heitz;
pub mod vgroove;
