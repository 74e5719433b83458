//! The reference generator's variance-reduced estimator
//! (`tools/harness/reference.rs`, on the library's walk through
//! `tools/harness/walk.rs`) estimates the library's HEITZ_RANDOM_WALK:
//!
//! - with MIS and forced collisions its mean agrees with the library's HEITZ
//!   eval and with the library's walks from `wi` and from `wo`, within the
//!   combined standard error (Sidak-corrected z, fixed seeds), on hard
//!   (grazing, low roughness, grazing glass transmission) and easy pairs;
//! - resuming pools the samples of independent passes exactly.

#[path = "../tools/harness/mod.rs"]
mod harness;

use harness::reference::{self, EstimatorKind, GenOptions};
use harness::suite;

fn options(pilot: u64) -> GenOptions {
    GenOptions {
        pairs: 16,
        seed: 11,
        pilot,
        target: 1e-3,
        budget: 0.0,
        max_samples: 1 << 40,
        albedo_pilot: 0,
        threads: harness::threads().min(2),
        quiet: true,
        estimator: EstimatorKind::DEFAULT,
    }
}

#[test]
fn reduced_estimator_matches_heitz() {
    let o = options(0);
    let r = reference::check_estimators(&reference::check_items(), 300_000, 20_261_127, &o);
    for l in &r.lines {
        eprintln!("{l}");
    }
    // The check must test something on hard and easy pairs alike.
    assert!(r.tests >= 45, "only {} tests counted", r.tests);
    assert!(
        r.worst_z <= r.sidak_z,
        "worst |z| {:.2} above the Sidak 1% threshold {:.2}",
        r.worst_z,
        r.sidak_z
    );
}

#[test]
fn resume_pools_passes() {
    let suite = suite::quick_suite();
    let a = reference::generate(&suite, &options(200), None);
    let mut o = options(300);
    o.seed = 31;
    let b = reference::generate(&suite, &o, Some(&a.data));
    // The same 300 samples alone.
    let c = reference::generate(&suite, &o, None);
    for ((ma, mb), mc) in a.data.iter().zip(&b.data).zip(&c.data) {
        for ((pa, pb), pc) in ma.pairs.iter().zip(&mb.pairs).zip(&mc.pairs) {
            assert_eq!(pb.n, pa.n + pc.n);
            for ch in 0..3 {
                let pooled = (pa.value[ch] * pa.n as f64 + pc.value[ch] * pc.n as f64)
                    / (pa.n + pc.n) as f64;
                assert!(
                    (pb.value[ch] - pooled).abs() <= 1e-12 * pooled.abs().max(1e-30),
                    "{}: {} vs pooled {pooled}",
                    ma.mat.name,
                    pb.value[ch]
                );
                // Pooled variance: the standard error falls by about
                // sqrt(n_a / n) (or less, when the means differ).
                let n = (pa.n + pc.n) as f64;
                let se_low = (pa.se[ch].powi(2) * pa.n as f64 * (pa.n as f64 - 1.0)
                    + pc.se[ch].powi(2) * pc.n as f64 * (pc.n as f64 - 1.0))
                    / ((n - 1.0) * n);
                assert!(pb.se[ch] * pb.se[ch] >= se_low * (1.0 - 1e-9) - 1e-300);
            }
        }
    }
    let header = vec![
        "seeds: Rng::new(20261122, stream = item), Rng::new(20261123, x)".to_string(),
        "earlier run: Rng::new(7".to_string(),
    ];
    assert_eq!(reference::max_seed(&header), 20_261_123);
}
