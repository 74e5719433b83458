//! Measured error and cost of every model, per NDF, facet and roughness:
//! the table [`super::auto`] picks from. A compact binary file,
//! `src/tables/auto.bin` (format: [`super::bintable`]; its header states
//! what each value is, the command and the commit), written by
//! `cargo run --release --example speed_accuracy` from
//! `data/reference_values.csv` and decoded into [`ROWS`] at compile time.
//!
//! `error` is the relative RMS error of one query averaging `evaluations`
//! calls of eval, against the converged HEITZ_RANDOM_WALK reference over
//! 64 direction pairs (worst over the suite's materials with that key),
//! as an upper confidence value (squared bias and variance each raised by
//! 3 of their standard errors); HEITZ_RANDOM_WALK's error is its noise
//! alone (it is the reference). `cost` is the median time per query
//! through `msbsdf_eval` (largest over those materials) relative to
//! SINGLE's in the same row, so it does not depend on the machine's speed;
//! above 256 evaluations it is extrapolated linearly from the
//! 256-evaluation timing.

use super::auto::{Candidate, Row};
use super::bintable::{f32_at, layout};
use crate::desc::{Estimator, FacetKind, Model, NdfId};

/// The table file.
const FILE: &[u8] = include_bytes!("../tables/auto.bin");

/// Byte offset of the values.
const DATA: usize = layout(FILE).0;

/// Value `i` of the file.
const fn at(i: usize) -> f32 {
    f32_at(FILE, DATA, i)
}

/// Models by their code in the file (the `MSBSDF_MODEL_*` order).
pub const MODEL_CODES: [Model; 11] = [
    Model::Single,
    Model::EnergyCompensated,
    Model::HeitzRandomWalk,
    Model::PositionFree,
    Model::Invariance,
    Model::BitterliDeon,
    Model::VGroove,
    Model::VGrooveNonsymmetric,
    Model::NullScattering,
    Model::Auto,
    Model::Tabulated,
];
/// Estimators by their code in the file.
pub const ESTIMATOR_CODES: [Estimator; 2] = [Estimator::Pt, Estimator::Bdpt];
/// NDFs by their code in the file.
pub const NDF_CODES: [NdfId; 2] = [NdfId::Beckmann, NdfId::Ggx];
/// Facets by their code in the file.
pub const FACET_CODES: [FacetKind; 2] = [FacetKind::Conductor, FacetKind::Dielectric];

/// Values per row header and per candidate.
const ROW_HEAD: usize = 5;
const CAND: usize = 5;

/// SINGLE's median time per query over the rows on the machine that
/// measured the table, in ns: `Choice::ns` reports `cost` times this.
pub const REFERENCE_NS: f32 = at(0);

/// Number of rows.
const N_ROWS: usize = at(1) as usize;

/// Number of candidates over all rows.
const N_CANDIDATES: usize = {
    let (mut r, mut o, mut n) = (0, 2, 0);
    while r < N_ROWS {
        let k = at(o + 4) as usize;
        n += k;
        o += ROW_HEAD + CAND * k;
        r += 1;
    }
    n
};

/// Every candidate, row after row.
static CANDIDATES: [Candidate; N_CANDIDATES] = {
    let mut out = [Candidate {
        model: Model::Single,
        estimator: Estimator::Pt,
        evaluations: 0,
        error: 0.0,
        cost: 0.0,
    }; N_CANDIDATES];
    let (mut r, mut o, mut n) = (0, 2, 0);
    while r < N_ROWS {
        let k = at(o + 4) as usize;
        let mut c = 0;
        while c < k {
            let b = o + ROW_HEAD + CAND * c;
            out[n] = Candidate {
                model: MODEL_CODES[at(b) as usize],
                estimator: ESTIMATOR_CODES[at(b + 1) as usize],
                evaluations: at(b + 2) as u32,
                error: at(b + 3),
                cost: at(b + 4),
            };
            n += 1;
            c += 1;
        }
        o += ROW_HEAD + CAND * k;
        r += 1;
    }
    out
};

/// Every measured row.
pub static ROWS: [Row; N_ROWS] = {
    let empty: &[Candidate] = &[];
    let mut out = [Row {
        ndf: NdfId::Beckmann,
        facet: FacetKind::Conductor,
        alpha_x: 0.0,
        alpha_y: 0.0,
        candidates: empty,
    }; N_ROWS];
    let (mut r, mut o, mut n) = (0, 2, 0);
    while r < N_ROWS {
        let k = at(o + 4) as usize;
        let (_, rest) = CANDIDATES.split_at(n);
        let (cands, _) = rest.split_at(k);
        out[r] = Row {
            ndf: NDF_CODES[at(o) as usize],
            facet: FACET_CODES[at(o + 1) as usize],
            alpha_x: at(o + 2),
            alpha_y: at(o + 3),
            candidates: cands,
        };
        n += k;
        o += ROW_HEAD + CAND * k;
        r += 1;
    }
    out
};
