//! Generates `src/multiple/compensation_tables.rs`, the single-scattering
//! albedo tables of `MSBSDF_MODEL_ENERGY_COMPENSATED`, by deterministic
//! quadrature of the SINGLE model (`msbsdf::multiple::compensation::single_albedo`).
//!
//! `cargo run --release --example gen_compensation` (about a minute on 2 cores).
//! The grid formulas here must match `grid_mu`, `grid_alpha` and `grid_eta`
//! in `src/multiple/compensation.rs`; `tests/compensation.rs` checks table
//! entries against a fresh quadrature at those grid points.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::compensation::single_albedo;
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};
use std::fmt::Write as _;
use std::io::Write as _;

const MU_N: usize = 32;
const ALPHA_N: usize = 24;
const ETA_N: usize = 16;
const MU_MIN: f32 = 0.01;
const MAX_ALPHA: f32 = 2.0;
const MAX_ETA: f32 = 3.0;
const QUAD_N: usize = 128;
const NDFS: [NdfKind; 2] = [NdfKind::Beckmann, NdfKind::Ggx];

fn grid_mu(i: usize) -> f32 {
    MU_MIN + (1.0 - MU_MIN) * i as f32 / (MU_N - 1) as f32
}
fn grid_alpha(j: usize) -> f32 {
    let s = j as f32 / (ALPHA_N - 1) as f32;
    MAX_ALPHA * s * s
}
fn grid_eta(k: usize) -> f32 {
    let s = k as f32 / (ETA_N - 1) as f32;
    1.0 + (MAX_ETA - 1.0) * s * s
}
fn dir(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// Albedo with F = 1 conductor facets.
fn conductor(kind: NdfKind, alpha: f32, mu: f32) -> f32 {
    if alpha == 0.0 {
        return 1.0;
    }
    let ndf = Ndf::new(kind, alpha, alpha);
    let facet = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let s = Single::new(ndf, facet, G2Form::HeightCorrelated);
    single_albedo(
        |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
        alpha,
        alpha,
        dir(mu),
        None,
        QUAD_N,
    ) as f32
}

/// Reflected + transmitted albedo for relative index `eta` seen from wi.
fn dielectric(kind: NdfKind, alpha: f32, eta: f32, mu: f32) -> f32 {
    if alpha == 0.0 || eta == 1.0 {
        return 1.0;
    }
    let ndf = Ndf::new(kind, alpha, alpha);
    let s = Single::new(ndf, Facet::Dielectric { eta }, G2Form::HeightCorrelated);
    single_albedo(
        |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
        alpha,
        alpha,
        dir(mu),
        Some(eta),
        QUAD_N,
    ) as f32
}

fn fmt_row(v: &[f32]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:.6}")).collect();
    format!("[{}]", items.join(", "))
}

fn main() {
    let t0 = std::time::Instant::now();
    let mut cond = vec![vec![vec![0f32; MU_N]; ALPHA_N]; 2];
    let mut cond_avg = vec![vec![0f32; ALPHA_N]; 2];
    let mut diel = vec![vec![vec![vec![vec![0f32; MU_N]; ALPHA_N]; ETA_N]; 2]; 2];
    // Work items: (ndf, side or conductor, eta index, alpha index), split over 2 threads.
    let jobs: Vec<(usize, usize, usize, usize)> = (0..2)
        .flat_map(|n| {
            (0..3).flat_map(move |kind| {
                let etas = if kind == 0 { 1 } else { ETA_N };
                (0..etas).flat_map(move |k| (0..ALPHA_N).map(move |j| (n, kind, k, j)))
            })
        })
        .collect();
    let total = jobs.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    type Row = ((usize, usize, usize, usize), Vec<f32>, f32);
    let results: Vec<Vec<Row>> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..2)
            .map(|t| {
                let jobs = &jobs;
                let done = &done;
                sc.spawn(move || {
                    let mut out = Vec::new();
                    for (idx, &(n, kind, k, j)) in jobs.iter().enumerate() {
                        if idx % 2 != t {
                            continue;
                        }
                        let alpha = grid_alpha(j);
                        let row: Vec<f32> = (0..MU_N)
                            .map(|i| match kind {
                                0 => conductor(NDFS[n], alpha, grid_mu(i)),
                                1 => dielectric(NDFS[n], alpha, grid_eta(k), grid_mu(i)),
                                _ => dielectric(NDFS[n], alpha, 1.0 / grid_eta(k), grid_mu(i)),
                            })
                            .collect();
                        // E_avg = 2 int E(mu) mu dmu = int_0^1 E(sqrt(s)) ds, 32 midpoints.
                        let avg = if kind == 0 {
                            (0..32)
                                .map(|i| {
                                    conductor(NDFS[n], alpha, ((i as f32 + 0.5) / 32.0).sqrt())
                                })
                                .sum::<f32>()
                                / 32.0
                        } else {
                            0.0
                        };
                        out.push(((n, kind, k, j), row, avg));
                        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        let el = t0.elapsed().as_secs_f32();
                        if d.is_multiple_of(40) || d == total {
                            eprintln!(
                                "{d}/{total} rows, {el:.0} s, ETA {:.0} s   ",
                                el / d as f32 * (total - d) as f32
                            );
                        }
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("worker"))
            .collect()
    });
    eprintln!();
    for ((n, kind, k, j), row, avg) in results.into_iter().flatten() {
        if kind == 0 {
            cond[n][j] = row;
            cond_avg[n][j] = avg;
        } else {
            diel[n][kind - 1][k][j] = row;
        }
    }
    let mut s = String::new();
    writeln!(
        s,
        "//! Generated by `cargo run --release --example gen_compensation`: do not edit."
    )
    .ok();
    writeln!(
        s,
        "//! Single-scattering directional albedo (height-correlated Smith G2) by"
    )
    .ok();
    writeln!(
        s,
        "//! quadrature on a {QUAD_N} x {QUAD_N} grid of normals per entry. Index order:"
    )
    .ok();
    writeln!(
        s,
        "//! [ndf: Beckmann, GGX][side: eta >= 1, 1/eta]?[eta][alpha][mu]."
    )
    .ok();
    writeln!(
        s,
        "#![allow(clippy::excessive_precision, clippy::approx_constant)]\n"
    )
    .ok();
    writeln!(
        s,
        "/// Number of mu (cosine) grid points.\npub const MU_N: usize = {MU_N};"
    )
    .ok();
    writeln!(
        s,
        "/// Number of alpha grid points.\npub const ALPHA_N: usize = {ALPHA_N};"
    )
    .ok();
    writeln!(
        s,
        "/// Number of eta grid points.\npub const ETA_N: usize = {ETA_N};"
    )
    .ok();
    writeln!(
        s,
        "/// Smallest tabulated mu.\npub const MU_MIN: f32 = {MU_MIN:?};"
    )
    .ok();
    writeln!(
        s,
        "/// Conductor albedo with F = 1.\npub static CONDUCTOR_E: [[[f32; MU_N]; ALPHA_N]; 2] = ["
    )
    .ok();
    for table in &cond {
        writeln!(s, "  [").ok();
        for row in table {
            writeln!(s, "    {},", fmt_row(row)).ok();
        }
        writeln!(s, "  ],").ok();
    }
    writeln!(s, "];").ok();
    writeln!(s, "/// Cosine-weighted average of the conductor albedo.\npub static CONDUCTOR_E_AVG: [[f32; ALPHA_N]; 2] = [").ok();
    for row in &cond_avg {
        writeln!(s, "  {},", fmt_row(row)).ok();
    }
    writeln!(s, "];").ok();
    writeln!(s, "/// Dielectric reflected + transmitted albedo.\npub static DIELECTRIC_E: [[[[[f32; MU_N]; ALPHA_N]; ETA_N]; 2]; 2] = [").ok();
    for per_ndf in &diel {
        writeln!(s, "  [").ok();
        for per_side in per_ndf {
            writeln!(s, "    [").ok();
            for per_eta in per_side {
                writeln!(s, "      [").ok();
                for row in per_eta {
                    writeln!(s, "        {},", fmt_row(row)).ok();
                }
                writeln!(s, "      ],").ok();
            }
            writeln!(s, "    ],").ok();
        }
        writeln!(s, "  ],").ok();
    }
    writeln!(s, "];").ok();
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/src/multiple/compensation_tables.rs"
    );
    let mut f = std::fs::File::create(path).expect("create the tables file");
    f.write_all(s.as_bytes()).expect("write the tables file");
    eprintln!("wrote {path} in {:.0} s", t0.elapsed().as_secs_f32());
}
