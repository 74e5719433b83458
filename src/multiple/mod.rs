//! Multiple-scattering models, one module per method.

pub mod vgroove;
