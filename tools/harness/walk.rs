//! The reference generator's walk: the library's HEITZ_RANDOM_WALK walk
//! (`msbsdf::multiple::microsurface::walk` with Heitz et al. 2016's height
//! state), called with its variance-reduction options and a per-order
//! tally, so the reference estimates exactly the library's BSDF:
//!
//! - **Forced collision** on the upward segments leaving the first
//!   `forced` vertices: the walk always hits, at a height drawn from the
//!   hit distribution conditioned on a hit, and the throughput is
//!   multiplied by the hit probability `1 - G1`. At low roughness the
//!   second collision is rare (`1 - G1 ~ 1e-3` for most first reflections).
//! - **Multiple importance sampling** of the forward walk (from `wi`) and the
//!   reverse walk (from `wo`), balance heuristic over the whole path
//!   (`msbsdf::multiple::heitz::HeightState` documents the densities); the
//!   caller adds the two walks.
//! - **Order one** on or off (the analytic SINGLE term replaces it in the
//!   reference).
//!
//! Facets: conductor and dielectric (the suite's); diffuse facets are not
//! supported here.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::facet::Facet;
use msbsdf::multiple::heitz::Heitz;
use msbsdf::multiple::microsurface::{self, Tally};
use msbsdf::ndf::Ndf;

/// Orders kept separately in [`Contribution::by_order`] (index = order;
/// orders `>= ORDERS - 1` are pooled in the last slot).
pub const ORDERS: usize = 8;

/// Variance-reduction switches of [`RefWalk::run`] (the library's
/// `microsurface::WalkOptions` without roulette).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WalkOptions {
    /// Upward segments leaving vertices `1..=forced` always hit (weighted
    /// by the hit probability).
    pub forced: u32,
    /// Balance-heuristic weights between the forward and reverse walks
    /// (otherwise the caller averages them).
    pub mis: bool,
    /// Also compute the next event at vertex 1 (order 1: the analytic
    /// SINGLE term replaces it in the reference).
    pub order_one: bool,
}

impl WalkOptions {
    /// The library's analog walk.
    pub const ANALOG: WalkOptions = WalkOptions {
        forced: 0,
        mis: false,
        order_one: true,
    };
}

/// What one walk contributed, per scattering order.
#[derive(Clone, Copy, Debug, Default)]
pub struct Contribution {
    /// Next-event estimates (MIS-weighted when asked) per order.
    pub by_order: [Vec3; ORDERS],
    /// Vertices visited.
    pub vertices: u32,
}

impl Tally for Contribution {
    fn add(&mut self, order: u32, c: Vec3) {
        self.by_order[(order as usize).min(ORDERS - 1)] += c;
    }
}

/// The walk of one material.
#[derive(Clone, Copy, Debug)]
pub struct RefWalk {
    heitz: Heitz,
    diffuse: bool,
}

impl RefWalk {
    /// The walk with the library's default bounce limit (`max_bounces = 0`)
    /// or the given one.
    pub fn new(ndf: Ndf, facet: Facet, max_bounces: u32) -> Self {
        RefWalk {
            heitz: Heitz::new(ndf, facet, max_bounces),
            diffuse: matches!(facet, Facet::Diffuse { .. }),
        }
    }

    /// One walk from `wi` with next-event estimates towards `wo`, per order.
    pub fn run(&self, wi: Vec3, wo: Vec3, rng: &mut Rng, opt: WalkOptions) -> Contribution {
        let mut out = Contribution::default();
        if self.diffuse {
            return out;
        }
        let max = self.heitz.max_bounces();
        let opt = microsurface::WalkOptions {
            forced: opt.forced,
            mis: opt.mis,
            order_one: opt.order_one,
            roulette: false,
        };
        out.vertices = self.heitz.walk_with(wi, wo, rng, opt, &mut out).min(max);
        out
    }
}
