//! Multiple-scattering models, one file per method.

pub mod auto;
pub mod auto_table;
pub mod compensation;
#[doc(hidden)]
pub mod compensation_tables;
pub mod heitz;
