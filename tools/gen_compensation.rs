//! Generates `src/tables/conductor_e.bin`, `conductor_e_avg.bin` and
//! `dielectric_e.bin`, the single-scattering albedo tables of
//! `MSBSDF_MODEL_ENERGY_COMPENSATED` (compact binary,
//! `msbsdf::multiple::bintable`; decoded at compile time by
//! `src/multiple/compensation_tables.rs`), by deterministic quadrature of
//! the SINGLE model (`msbsdf::multiple::compensation::single_albedo`). Each
//! file's header records the command, the grid, seeds and sample counts
//! where there are any, and the commit the generator ran at.
//!
//! `cargo run --release --example gen_compensation` (about a minute on 2 cores).
//!
//! `cargo run --release --example gen_compensation -- --ms` instead generates
//! `src/tables/conductor_ms_cos_hist.bin` and `conductor_ms_tint.bin`, the
//! Fresnel tint tables of the
//! conductor multiple-scattering lobe, from a random walk of the Heitz 2016
//! microsurface (see [`ms_tables`]; under a minute on 2 cores), and
//! `-- --aniso` generates `src/tables/conductor_e_aniso.bin`, the
//! conductor albedo with F = 1 for anisotropic roughness (see
//! [`aniso_tables`]; under a minute).
//! The grid formulas here must match `grid_mu`, `grid_alpha` and `grid_eta`
//! in `src/multiple/compensation.rs`; `tests/compensation.rs` checks
//! random table entries against SINGLE's sampled albedo.

#[path = "harness/cli.rs"]
mod cli;
#[path = "harness/git.rs"]
mod git;

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::compensation::single_albedo;
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};

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

/// Runs `f(index, job)` on every job over two threads (job `i` on thread
/// `i % 2`), printing progress every `every` jobs; results in job order.
fn parallel<J: Sync, R: Send>(
    jobs: &[J],
    what: &str,
    every: usize,
    f: impl Fn(usize, &J) -> R + Sync,
) -> Vec<R> {
    let t0 = std::time::Instant::now();
    let total = jobs.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let parts: Vec<Vec<(usize, R)>> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..2)
            .map(|th| {
                let (f, done) = (&f, &done);
                sc.spawn(move || {
                    let mut out = Vec::new();
                    for (idx, job) in jobs.iter().enumerate().filter(|(i, _)| i % 2 == th) {
                        out.push((idx, f(idx, job)));
                        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        if d.is_multiple_of(every) || d == total {
                            let el = t0.elapsed().as_secs_f32();
                            eprintln!(
                                "{d}/{total} {what}, {el:.0} s, ETA {:.0} s",
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
    let mut all: Vec<(usize, R)> = parts.into_iter().flatten().collect();
    all.sort_by_key(|(i, _)| *i);
    all.into_iter().map(|(_, r)| r).collect()
}

/// Writes `src/tables/{name}.bin` (format `msbsdf::multiple::bintable`)
/// with `text` and the command line and commit as its header.
fn write_table(name: &str, text: &str, values: &[f32], t0: std::time::Instant) {
    let command: Vec<String> = std::env::args().skip(1).collect();
    let header = format!(
        "{text}Command: cargo run --release --example gen_compensation{}{}\nCommit: {}\n",
        if command.is_empty() { "" } else { " -- " },
        command.join(" "),
        git::commit()
    );
    let path = format!("{}/src/tables/{name}.bin", env!("CARGO_MANIFEST_DIR"));
    let bytes = msbsdf::multiple::bintable::encode(&header, values);
    std::fs::write(&path, bytes).expect("write the table file");
    eprintln!("wrote {path} in {:.0} s", t0.elapsed().as_secs_f32());
}

/// The values of a nested table in index order.
fn flat3(v: &[Vec<Vec<f32>>]) -> Vec<f32> {
    v.iter().flatten().flatten().copied().collect()
}

/// Every option `main` reads (`cli::check_options` rejects the others).
const OPTIONS: &[&str] = &["--ms", "--aniso"];

const USAGE: &str = "\
gen_compensation: ENERGY_COMPENSATED's tables under src/tables (the module documentation
of tools/gen_compensation.rs has the details).
  (no option)  conductor_e.bin, conductor_e_avg.bin, dielectric_e.bin (about a minute)
  --ms         conductor_ms_cos_hist.bin, conductor_ms_tint.bin
  --aniso      conductor_e_aniso.bin";

fn main() {
    cli::check_options(OPTIONS, USAGE);
    if std::env::args().any(|a| a == "--ms") {
        ms_tables();
        return;
    }
    if std::env::args().any(|a| a == "--aniso") {
        aniso_tables();
        return;
    }
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
    let results = parallel(&jobs, "rows", 40, |_, &(n, kind, k, j)| {
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
                .map(|i| conductor(NDFS[n], alpha, ((i as f32 + 0.5) / 32.0).sqrt()))
                .sum::<f32>()
                / 32.0
        } else {
            0.0
        };
        (row, avg)
    });
    for (&(n, kind, k, j), (row, avg)) in jobs.iter().zip(results) {
        if kind == 0 {
            cond[n][j] = row;
            cond_avg[n][j] = avg;
        } else {
            diel[n][kind - 1][k][j] = row;
        }
    }
    let quad = format!(
        "Single-scattering directional albedo (height-correlated Smith G2) of the SINGLE \
         model by deterministic quadrature (msbsdf::multiple::compensation::single_albedo) \
         on a {QUAD_N} x {QUAD_N} grid of normals per entry; no random numbers.\n\
         Grid: mu = {MU_MIN} + {} i / {}, alpha = {MAX_ALPHA} (j / {})^2, eta = 1 + {} (k / {})^2.\n",
        1.0 - MU_MIN,
        MU_N - 1,
        ALPHA_N - 1,
        MAX_ETA - 1.0,
        ETA_N - 1
    );
    write_table(
        "conductor_e",
        &format!(
            "CONDUCTOR_E: albedo of conductor facets with F = 1.\n\
             Shape: [ndf: Beckmann, GGX][alpha: {ALPHA_N}][mu: {MU_N}] f32.\n{quad}"
        ),
        &flat3(&cond),
        t0,
    );
    write_table(
        "conductor_e_avg",
        &format!(
            "CONDUCTOR_E_AVG: 2 int E(mu) mu dmu of the conductor albedo with F = 1, by 32 \
             midpoints in mu^2 of the same quadrature.\n\
             Shape: [ndf: Beckmann, GGX][alpha: {ALPHA_N}] f32.\n{quad}"
        ),
        &cond_avg.iter().flatten().copied().collect::<Vec<f32>>(),
        t0,
    );
    let diel_flat: Vec<f32> = diel.iter().flatten().flat_map(|x| flat3(x)).collect();
    write_table(
        "dielectric_e",
        &format!(
            "DIELECTRIC_E: reflected + transmitted albedo of dielectric facets, relative \
             index eta (side 0) or 1 / eta (side 1) seen from wi.\n\
             Shape: [ndf: Beckmann, GGX][side: 2][eta: {ETA_N}][alpha: {ALPHA_N}][mu: {MU_N}] f32.\n{quad}"
        ),
        &diel_flat,
        t0,
    );
}

/// Cosine bins of the multiple-scattering bounce histogram.
const MS_BINS: usize = 16;
/// Schlick `F0` nodes of the tint table (uniform on [0, 1]).
const F0_N: usize = 17;
/// Bounce limit of the walk (the walk with F = 1 loses less than 1e-4 of
/// the energy to it up to alpha 2).
const MS_MAX_BOUNCES: usize = 96;
/// Walks per cell: batches until this many multiply scattered paths...
const MS_TARGET_PATHS: u64 = 6000;
/// ...or this many walks.
const MS_MAX_WALKS: u64 = 300_000;

/// One walk of Heitz et al. 2016 over conductor facets with F = 1: the
/// library's HEITZ_RANDOM_WALK sampler (`microsurface::sample_walk` with the
/// height state), `MS_MAX_BOUNCES - 1` vertices at most: true if it leaves
/// the surface, with the cosine `|w.m|` of every reflection in `cos`.
fn ms_walk(ndf: &Ndf, wi: Vec3, rng: &mut Rng, cos: &mut Vec<f32>) -> bool {
    use msbsdf::multiple::heitz::HeightState;
    use msbsdf::multiple::microsurface::{Microsurface, first_uniforms, sample_walk};
    cos.clear();
    let white = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let ms = Microsurface::new(*ndf, white, MS_MAX_BOUNCES as u32 - 1);
    let u = first_uniforms(rng);
    sample_walk::<HeightState, _>(&ms, wi, u, rng, |c| cos.push(c)).is_ok()
}

fn schlick(c: f32, f0: f64) -> f64 {
    f0 + (1.0 - f0) * (1.0 - c as f64).powi(5)
}

/// Per (NDF, alpha, mu) cell, from walks with F = 1 restricted to the paths
/// that leave after two or more reflections (the energy of the
/// multiple-scattering lobe): the histogram of their reflection cosines
/// (`MS_BINS` uniform bins, normalised) and the mean of the product of the
/// Schlick reflectances `prod_j S(c_j; F0)` for `F0_N` values of `F0`, i.e.
/// the fraction of that energy a Schlick conductor keeps. Also checks the
/// single-reflection fraction against the quadrature table `CONDUCTOR_E`.
fn ms_tables() {
    use msbsdf::multiple::compensation_tables as t;
    let t0 = std::time::Instant::now();
    let cells: Vec<(usize, usize, usize)> = (0..2)
        .flat_map(|n| (0..ALPHA_N).flat_map(move |j| (0..MU_N).map(move |i| (n, j, i))))
        .collect();
    let results = parallel(&cells, "cells", 64, |idx, &(n, j, i)| {
        let mut cos = Vec::new();
        let alpha = grid_alpha(j);
        let mut hist = [0f64; MS_BINS];
        let mut tint = [0f64; F0_N];
        let (mut walks, mut paths, mut singles) = (0u64, 0u64, 0u64);
        if alpha > 0.0 {
            let ndf = Ndf::new(NDFS[n], alpha, alpha);
            let wi = dir(grid_mu(i));
            let mut rng = Rng::new(20_261_122 + idx as u64, 7);
            while paths < MS_TARGET_PATHS && walks < MS_MAX_WALKS {
                walks += 1;
                if !ms_walk(&ndf, wi, &mut rng, &mut cos) {
                    continue;
                }
                if cos.len() == 1 {
                    singles += 1;
                    continue;
                }
                paths += 1;
                // Every reflection counts once.
                for &c in &cos {
                    hist[((c * MS_BINS as f32) as usize).min(MS_BINS - 1)] += 1.0;
                }
                for (q, tq) in tint.iter_mut().enumerate() {
                    let f0 = q as f64 / (F0_N - 1) as f64;
                    *tq += cos.iter().map(|&c| schlick(c, f0)).product::<f64>();
                }
            }
        }
        let (hist, tint): (Vec<f32>, Vec<f32>) = if paths > 0 {
            let hs: f64 = hist.iter().sum();
            (
                hist.iter().map(|h| (h / hs) as f32).collect(),
                tint.iter().map(|x| (x / paths as f64) as f32).collect(),
            )
        } else {
            // No multiple scattering (alpha 0): the tint is never used;
            // keep a sane uniform histogram.
            (
                vec![1.0 / MS_BINS as f32; MS_BINS],
                (0..F0_N)
                    .map(|q| {
                        let f0 = q as f32 / (F0_N - 1) as f32;
                        f0 * f0
                    })
                    .collect(),
            )
        };
        let z = if walks > 0 {
            let p = singles as f64 / walks as f64;
            let e = t::CONDUCTOR_E[n][j][i] as f64;
            // Binomial error of the walk, floored at the table's quadrature
            // accuracy (2e-5, rounding included).
            let var = (e * (1.0 - e)).max(p * (1.0 - p)) / walks as f64;
            ((p - e).abs() - 2e-5).max(0.0) / var.sqrt().max(1e-6)
        } else {
            0.0
        };
        (hist, tint, walks, paths, z)
    });
    let mut hist = vec![vec![vec![vec![0f32; MS_BINS]; MU_N]; ALPHA_N]; 2];
    let mut tint = vec![vec![vec![vec![0f32; F0_N]; MU_N]; ALPHA_N]; 2];
    let (mut walks, mut worst_z, mut fewest) = (0u64, 0f64, u64::MAX);
    for (&(n, j, i), (h, tq, w, p, z)) in cells.iter().zip(results) {
        hist[n][j][i] = h;
        tint[n][j][i] = tq;
        walks += w;
        worst_z = worst_z.max(z);
        if z > 5.0 {
            eprintln!(
                "  cell ndf {n} alpha {} mu {}: single-reflection fraction off by {z:.1} sigma",
                grid_alpha(j),
                grid_mu(i)
            );
        }
        if j > 0 && t::CONDUCTOR_E[n][j][i] < 0.99 {
            fewest = fewest.min(p);
        }
    }
    eprintln!(
        "{walks} walks; single-reflection fraction vs CONDUCTOR_E: worst |z| {worst_z:.2}; \
         fewest multiply scattered paths where E < 0.99: {fewest}"
    );
    let walk = format!(
        "Heitz et al. 2016 random walks on the microsurface with conductor facets and F = 1, \
         per (NDF, alpha, mu) grid cell of CONDUCTOR_E (heights by the log of the uniform \
         height CDF, at most {MS_MAX_BOUNCES} reflections): msbsdf::Rng seed 20261122 + cell \
         index (cell = (ndf * {ALPHA_N} + alpha) * {MU_N} + mu), stream 7; per cell until \
         {MS_TARGET_PATHS} paths with two or more reflections or {MS_MAX_WALKS} walks; \
         {walks} walks in all. Single-reflection fraction vs CONDUCTOR_E: worst |z| {worst_z:.2}.\n"
    );
    write_table(
        "conductor_ms_cos_hist",
        &format!(
            "CONDUCTOR_MS_COS_HIST: distribution of the reflection cosines |w.m| of the paths \
             that leave after two or more reflections (every reflection counts once), \
             {MS_BINS} uniform bins.\n\
             Shape: [ndf: Beckmann, GGX][alpha: {ALPHA_N}][mu: {MU_N}][bin: {MS_BINS}] f32.\n{walk}"
        ),
        &hist.iter().flat_map(|x| flat3(x)).collect::<Vec<f32>>(),
        t0,
    );
    write_table(
        "conductor_ms_tint",
        &format!(
            "CONDUCTOR_MS_TINT: mean over the paths that leave after two or more reflections \
             of prod_j S(c_j; F0), Schlick's reflectance, at F0 = q / {}.\n\
             Shape: [ndf: Beckmann, GGX][alpha: {ALPHA_N}][mu: {MU_N}][F0: {F0_N}] f32.\n{walk}",
            F0_N - 1
        ),
        &tint.iter().flat_map(|x| flat3(x)).collect::<Vec<f32>>(),
        t0,
    );
}

/// Grid of the anisotropic albedo table: mu (quadratic spacing, dense
/// towards grazing), azimuth in [0, pi/2] (the albedo is even in both wx and
/// wy), and alpha along x and y (uniform in sqrt(alpha / MAX_ALPHA)). The
/// formulas must match `aniso_grid_*` in `src/multiple/compensation.rs`.
const AN_MU: usize = 16;
const AN_PHI: usize = 7;
const AN_A: usize = 16;
const AN_QUAD_N: usize = 96;

fn aniso_grid_mu(i: usize) -> f32 {
    let s = i as f32 / (AN_MU - 1) as f32;
    MU_MIN + (1.0 - MU_MIN) * s * s
}
fn aniso_grid_phi(k: usize) -> f32 {
    std::f32::consts::FRAC_PI_2 * k as f32 / (AN_PHI - 1) as f32
}
fn aniso_grid_alpha(j: usize) -> f32 {
    let s = j as f32 / (AN_A - 1) as f32;
    MAX_ALPHA * s * s
}

/// Single-scattering albedo with F = 1 of anisotropic conductor facets per
/// (NDF, alpha_x, alpha_y, azimuth, mu), by the same quadrature as the
/// isotropic table (`AN_QUAD_N`^2 normals per entry).
fn aniso_tables() {
    let t0 = std::time::Instant::now();
    let jobs: Vec<(usize, usize, usize)> = (0..2)
        .flat_map(|n| (0..AN_A).flat_map(move |jx| (0..AN_A).map(move |jy| (n, jx, jy))))
        .collect();
    let results = parallel(&jobs, "(alpha_x, alpha_y) blocks", 16, |_, &(n, jx, jy)| {
        // A smooth axis: the quadrature's warp needs alpha > 0; use the
        // smallest positive one.
        let (ax, ay) = (
            aniso_grid_alpha(jx).max(1e-4),
            aniso_grid_alpha(jy).max(1e-4),
        );
        (0..AN_PHI)
            .map(|k| {
                (0..AN_MU)
                    .map(|i| aniso_entry(NDFS[n], ax, ay, k, i))
                    .collect::<Vec<f32>>()
            })
            .collect::<Vec<_>>()
    });
    let mut table = vec![vec![vec![vec![vec![0f32; AN_MU]; AN_PHI]; AN_A]; AN_A]; 2];
    for (&(n, jx, jy), block) in jobs.iter().zip(results) {
        table[n][jx][jy] = block;
    }
    write_table(
        "conductor_e_aniso",
        &format!(
            "CONDUCTOR_E_ANISO: single-scattering directional albedo with F = 1 \
             (height-correlated Smith G2) of anisotropic conductor facets by deterministic \
             quadrature (msbsdf::multiple::compensation::single_albedo) on a {AN_QUAD_N} x \
             {AN_QUAD_N} grid of normals per entry; no random numbers.\n\
             Shape: [ndf: Beckmann, GGX][alpha_x: {AN_A}][alpha_y: {AN_A}][phi: {AN_PHI}][mu: {AN_MU}] f32.\n\
             Grid: mu = {MU_MIN} + {} (i / {})^2, phi = (pi / 2) k / {}, alpha = {MAX_ALPHA} (j / {})^2 \
             (0 stored at 1e-4).\n",
            1.0 - MU_MIN,
            AN_MU - 1,
            AN_PHI - 1,
            AN_A - 1
        ),
        &table
            .iter()
            .flat_map(|a| a.iter().flat_map(|b| flat3(b)))
            .collect::<Vec<f32>>(),
        t0,
    );
}

/// One entry of the anisotropic table (also used by the tests' recomputation).
fn aniso_entry(kind: NdfKind, ax: f32, ay: f32, k: usize, i: usize) -> f32 {
    let ndf = Ndf::new(kind, ax, ay);
    let facet = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let s = Single::new(ndf, facet, G2Form::HeightCorrelated);
    let mu = aniso_grid_mu(i);
    let phi = aniso_grid_phi(k);
    let st = (1.0 - mu * mu).max(0.0).sqrt();
    let wi = Vec3::new(st * phi.cos(), st * phi.sin(), mu);
    single_albedo(
        |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
        ax,
        ay,
        wi,
        None,
        AN_QUAD_N,
    ) as f32
}
