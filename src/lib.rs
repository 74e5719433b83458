//! # msbsdf: multiple-scattering microfacet BSDFs behind a stable C ABI
//!
//! A material is built from a [`MaterialDesc`] and answers three queries in
//! the local shading frame (z = macro-surface normal, x = tangent along
//! `alpha_x`, `wi` and `wo` both pointing away from the surface, `wo.z < 0`
//! meaning transmission):
//!
//! - [`Material::eval`]: `f(wi, wo) |cos theta_o|` per RGB channel;
//! - [`Material::sample`]: a direction `wo` with weight `f |cos theta_o| / pdf`;
//! - [`Material::pdf`]: the density `sample` uses.
//!
//! Transmission is the flux-conserving form (with non-absorbing facets the
//! reflected plus transmitted albedo is 1); the context-taking queries
//! ([`Material::eval_pdf`], [`Material::sample_ctx`]) apply the `1 / eta^2`
//! of radiance transport when asked ([`bsdf::Context`]). The conventions, the
//! ABI rules and the models' ranges: `docs/design.md`.
//!
//! The C API (`include/msbsdf.h`, generated from [`capi`]) is a thin skin
//! over this Rust API. Nothing in eval/sample/pdf allocates, locks or uses
//! `dyn` dispatch.
//!
//! ```
//! use msbsdf::{Material, MaterialDesc, Rng};
//! use glam::Vec3;
//! let gold = Material::new(&MaterialDesc {
//!     eta: Vec3::new(0.143, 0.374, 1.442),
//!     k: Vec3::new(3.983, 2.385, 1.603),
//!     ..MaterialDesc::default()
//! }).unwrap();
//! let mut rng = Rng::new(42, 54);
//! let s = gold.sample(Vec3::new(0.3, 0.0, 1.0), &mut rng);
//! assert!(s.weight.is_finite());
//! ```

#![deny(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

pub mod bsdf;
pub mod capi;
pub mod desc;
pub mod dispatch;
pub mod facet;
pub mod frame;
pub mod fresnel;
pub mod material;
pub mod math;
pub mod multiple;
pub mod ndf;
pub mod rng;
pub mod single;
pub mod specfun;
pub mod specular;
pub mod status;

pub use bsdf::{SAMPLE_ABSORBED, SAMPLE_REFLECTION, SAMPLE_TRANSMISSION, Sample};
pub use desc::{Estimator, FacetKind, MAX_BOUNCES, MaterialDesc, Model, NdfId};
pub use material::Material;
pub use rng::Rng;
pub use status::Error;

/// The header cbindgen generated from this build (compared in tests with the
/// committed `include/msbsdf.h`).
#[doc(hidden)]
pub const GENERATED_HEADER: &str = include_str!(concat!(env!("OUT_DIR"), "/msbsdf.h"));
