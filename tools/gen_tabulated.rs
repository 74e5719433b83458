//! Generates `data/tabulated_conductor.bin`, the table of
//! `MSBSDF_MODEL_TABULATED` (layout and grids: `src/multiple/tabulated.rs`).
//!
//! `nice cargo run --release --example gen_tabulated -- --walks 2000000`
//! (`--threads N`, default 2; `--out PATH`). For every NDF (Beckmann, GGX),
//! roughness node and incident cosine node it runs the library's
//! HEITZ_RANDOM_WALK (`Heitz::sample_with_bounces`, perfectly reflecting
//! facets) from `wi` and projects the exit directions of the walks that
//! scattered twice or more onto hat functions in `sqrt(mu_o)` times
//! `cos(k phi)`; it counts orders 2, 3 and 4 apart. The table is then
//! symmetrised in `(mu_i, mu_o)` and rescaled symmetrically so that the
//! interpolant's multiply scattered albedo equals `1 - E_ss(mu_i)` (SINGLE's
//! albedo with F = 1 by quadrature); the file keeps the cells of `mu_i`
//! node `<= mu_o` node (version 2; `--conductor-pack PATH` rewrites a
//! version-1 file, which stored every cell, that way). A small
//! instrumented walk (the same microsurface, validated against the
//! library's through the table by `tests/tabulated.rs`) records the cosines
//! at which multiply scattered paths meet facets; three equal-weight
//! quantiles per (NDF, alpha) give the effective Fresnel reflectance of
//! coloured conductors.
//!
//! The file starts with a 4096-byte text header (command, seeds, sample
//! counts, commit, statistics), then little-endian f32 blocks.

use glam::Vec3;
use msbsdf::Rng;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::frame::reflect;
use msbsdf::multiple::compensation::single_albedo;
use msbsdf::multiple::heitz::{Heitz, default_max_bounces};
use msbsdf::multiple::tabulated::{
    ALBEDO_LEN, ALPHA_N, CELL, FILE_BYTES, FIRST_LEN, FRESNEL_LEN, FRESNEL_Q, HEADER_BYTES,
    K_STORED, LOBE_LEN, MAGIC, MU_N, NDF_N, ORDER0, ORDERS, PEAK, R_PAIRS, SBAR_LEN, SCALE_ALPHA_N,
    SCALE_FILE_BYTES, SCALE_LEN, SCALE_MAGIC, SCALE_MAX, SCALE_MU_N, add_cosines, albedo_index,
    alpha_coord, exit_hats, fresnel_index, grid_alpha, grid_mu, hat_moment, lobe_index, mu_coord,
    project_exit, scale_encode, scale_grid_alpha, scale_grid_mu, scale_index, split,
};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};

#[path = "harness/cli.rs"]
mod cli;
#[path = "harness/git.rs"]
mod git;

/// Every option `main` and its modes read (`cli::check_options` rejects
/// the others).
const OPTIONS: &[&str] = &[
    "--alpha",
    "--base",
    "--below-from",
    "--between",
    "--broad",
    "--cases",
    "--conductor-pack",
    "--corners",
    "--dielectric",
    "--dielectric-check",
    "--dielectric-ir",
    "--dielectric-lobe-pack",
    "--dielectric-normalize",
    "--dielectric-pack",
    "--dielectric-scale",
    "--dielectric-scale-fit",
    "--dielectric-scale-splice",
    "--dielectric-scale-top",
    "--dielectric-v5",
    "--drop",
    "--dry",
    "--dump",
    "--eta",
    "--evals",
    "--exact",
    "--extra-eta",
    "--first-free",
    "--from-alpha",
    "--last-free",
    "--floor",
    "--fresnel-walks",
    "--from",
    "--from-dump",
    "--gram-samples",
    "--grid",
    "--hold-alpha-below",
    "--hold-mu-from",
    "--iterations",
    "--keep",
    "--lawson",
    "--main-only",
    "--low-2d",
    "--low-only",
    "--main-2d",
    "--mu-pilot",
    "--ng",
    "--node-weight",
    "--only",
    "--only-alpha",
    "--only-cases",
    "--only-ndf",
    "--out",
    "--pair",
    "--pilot",
    "--pilot-lawson",
    "--pilot-nodes",
    "--points",
    "--power",
    "--print-rows",
    "--quad",
    "--quadratic",
    "--scale",
    "--sheet",
    "--schlick-walks",
    "--split",
    "--table",
    "--threads",
    "--to-eta",
    "--to-node",
    "--verbose",
    "--walks",
];

const USAGE: &str = "\
gen_tabulated: the tables of MSBSDF_MODEL_TABULATED (the module documentation of
tools/gen_tabulated.rs and of its `dielectric` module has the details).

Writes a committed table (run on a clean tree; the header records the commit):
  (no mode option) [--walks N] [--fresnel-walks N] [--gram-samples N] [--threads N] [--out PATH]
                                  data/tabulated_conductor.bin (the conductor lobes)
  --scale                         data/tabulated_scale.bin (conductor furnace scales)
  --dielectric                    data/tabulated_dielectric.bin (the glass lobes)
  --dielectric-scale [--keep V11.bin]
                                  data/tabulated_dielectric_scale.bin, exact nodes
  --dielectric-scale-fit --exact EXACT.bin [--lawson K] [--low-2d --base FITTED.bin]
                         [--main-2d --base FITTED.bin] [--points FILE] [--hold-mu-from K]
                         [--hold-alpha-below A]
                                  the same table with nodes fitted along roughness
  --dielectric-scale-splice --from FITTED.bin --below-from FITTED_1D.bin --to-node K
                                  the main block's roughness nodes 0..=K from another fit
  --dielectric-scale-top --from TABLE.bin [--first-free K] [--low-only] [--lawson L] [--dry]
                         [--sheet --low-only | --main-only [--to-eta E]] [--from-alpha A]
                                  the same table with the nodes near the normal refitted
  --conductor-pack / --dielectric-pack / --dielectric-lobe-pack / --dielectric-v5 FILE
                                  rewrite an older version of a table
  --dielectric-normalize          the lobe table normalised (--power P --floor F)
Measures (writes nothing):
  --dielectric-check [--evals N]  the glass table against the reference and walks
  --mu-pilot [--quadratic] [--grid lib|v7|plain:N|lobe]
                                  exact scales on a trial cosine grid
  --dielectric-scale --only N,A,E [--alpha X] [--eta E] [--between]
  --dielectric-scale-fit --exact EXACT.bin --pilot N,L,E
                                  one row of the scale solve or fit
  --dielectric-ir MODEL NDF eval|sample|pdf|init CALLS
                                  the callgrind driver of glass calls";

const NDFS: [NdfKind; NDF_N] = [NdfKind::Beckmann, NdfKind::Ggx];
const SEED_LOBE: u64 = 20261124;
const SEED_FRESNEL: u64 = 20261125;
const SEED_GRAM: u64 = 20261126;
const SEED_SCALE: u64 = 20261127;
/// Largest furnace scale the scale solve gives a node (just under the
/// encoding's `SCALE_MAX`).
const SCALE_TOP: f64 = 0.99 * SCALE_MAX as f64;
const SEED_SCHLICK: u64 = 20261128;
/// Cosine terms of the least-squares fit (the file keeps the first K_STORED).
const K_FIT: usize = 8;
/// Ridge of the peaked weight `B`, relative to its Gram entry: keeps `B`
/// near 0 where `f_ss1` is as smooth as the cosine series.
const RIDGE: f64 = 0.05;
/// Incident cosine used for the node at mu = 0 (a walk needs mu > 0).
const MU_GRAZING: f32 = 1e-3;
const CONDUCTOR_F1: Facet = Facet::Conductor {
    eta: Vec3::ZERO,
    k: Vec3::ONE,
};

fn dir(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

fn node_mu(i: usize) -> f32 {
    grid_mu(i).max(MU_GRAZING)
}

/// Raw sums of one (ndf, alpha, mu_i) job: per mu_o node, the K cosine
/// moments and the order-2, 3, 4 azimuth-averaged sums.
struct Sums {
    walks: u64,
    moments: Vec<[f64; K_FIT]>,
    orders: Vec<[f64; ORDERS]>,
    /// Multiply scattered walks (escaped after >= 2 vertices).
    ms: u64,
    /// Per mu_o node: sum of `hat_j f_ss1` over the exits (right-hand side
    /// of the peaked part).
    peak: Vec<f64>,
    /// Per mu_o node: Gram entries `int hat_j cos(k phi) f_ss1 mu dw`
    /// (k < K_STORED) and `int hat_j f_ss1^2 mu dw`, by visible-normal
    /// sampling.
    gram_kb: Vec<[f64; K_FIT]>,
    gram_bb: Vec<f64>,
}

/// Gram entries of the peaked basis function `f_ss1` (SINGLE with F = 1)
/// on the hat functions of `mu_o` times `cos(k phi)`, by sampling SINGLE
/// from `wi` (visible normals: `f_ss1 |wo.z| / pdf = G2 / G1 <= 1`): per
/// node, `int hat_j cos(k phi) f_ss1 mu dw` and `int hat_j f_ss1^2 mu dw`.
fn gram_entries(
    single: &Single,
    wi: Vec3,
    gram: u64,
    grng: &mut Rng,
) -> (Vec<[f64; K_FIT]>, Vec<f64>) {
    let mut zero = Rng::new(0, 0);
    let (mut gram_kb, mut gram_bb) = (vec![[0.0; K_FIT]; MU_N], vec![0.0; MU_N]);
    for _ in 0..gram {
        let smp = single.sample(wi, grng);
        if smp.wo.z <= 0.0 || smp.pdf <= 0.0 {
            continue;
        }
        let ss1 = single.eval(wi, smp.wo, &mut zero).x as f64;
        let mut mom = [[0.0f64; K_FIT]; MU_N];
        project_exit(smp.wo, ss1 / smp.pdf as f64 / gram as f64, &mut mom);
        let f1 = ss1 / smp.wo.z as f64;
        for ((g, bb), m) in gram_kb.iter_mut().zip(gram_bb.iter_mut()).zip(&mom) {
            for (gk, mk) in g.iter_mut().zip(m) {
                *gk += mk;
            }
            *bb += m[0] * f1;
        }
    }
    (gram_kb, gram_bb)
}

/// Local least squares at one `mu_o` node `j` (inner product weighted by
/// `hat_j mu_o`): cosine terms (orthogonal, Gram `H_j * norm_k`) and the
/// peaked function `f_ss1`, eliminated by its Schur complement, from the
/// projected sums `moments` of `walks` walks, the peaked right-hand side
/// `peak` and the Gram entries. Returns the cosine coefficients and `B`
/// (ridge [`RIDGE`], capped so the azimuth-averaged smooth part stays >= 0:
/// eval clamps the sum at 0, and a negative smooth part far from the peak
/// would be clamped away and break the normalisation).
fn fit_node(
    moments: &[f64; K_FIT],
    walks: f64,
    peak: f64,
    gram_kb: &[f64; K_FIT],
    gram_bb: f64,
    h_j: f64,
) -> ([f64; K_FIT], f64) {
    let gkk = |k: usize| h_j * if k == 0 { 2.0 * PI } else { PI };
    let (mut num, mut den) = (peak / walks, gram_bb);
    for k in 0..K_FIT {
        num -= gram_kb[k] * (moments[k] / walks) / gkk(k);
        den -= gram_kb[k] * gram_kb[k] / gkk(k);
    }
    let cap = if gram_kb[0] > 0.0 {
        (moments[0] / walks / gram_kb[0]).max(0.0)
    } else {
        0.0
    };
    let bpk = if gram_bb > 0.0 {
        (num / (den.max(0.0) + RIDGE * gram_bb)).clamp(0.0, cap)
    } else {
        0.0
    };
    (
        std::array::from_fn(|k| (moments[k] / walks - gram_kb[k] * bpk) / gkk(k)),
        bpk,
    )
}

fn lobe_job(kind: NdfKind, alpha: f32, mu_i: f32, walks: u64, gram: u64, stream: u64) -> Sums {
    let ndf = Ndf::new(kind, alpha, alpha);
    let walk = Heitz::new(ndf, CONDUCTOR_F1, 0);
    let single = Single::new(ndf, CONDUCTOR_F1, G2Form::HeightCorrelated);
    let wi = dir(mu_i);
    let mut rng = Rng::new(SEED_LOBE, stream);
    let mut s = Sums {
        walks,
        moments: vec![[0.0; K_FIT]; MU_N],
        orders: vec![[0.0; ORDERS]; MU_N],
        ms: 0,
        peak: vec![0.0; MU_N],
        gram_kb: vec![[0.0; K_FIT]; MU_N],
        gram_bb: vec![0.0; MU_N],
    };
    let mut zero = Rng::new(0, 0);
    let mut grng = Rng::new(SEED_GRAM, stream);
    (s.gram_kb, s.gram_bb) = gram_entries(&single, wi, gram, &mut grng);
    for _ in 0..walks {
        let (smp, bounces) = walk.sample_with_bounces(wi, &mut rng);
        if bounces < 2 || smp.wo.z <= 0.0 {
            continue;
        }
        let w = smp.weight.x as f64;
        if w <= 0.0 {
            continue;
        }
        s.ms += 1;
        let wo = smp.wo;
        let f1 = single.eval(wi, wo, &mut zero).x as f64 / wo.z as f64;
        let (hats, c) = exit_hats(wo);
        for (j, hw) in hats {
            let ww = w * hw;
            add_cosines(&mut s.moments[j], c, ww);
            s.peak[j] += ww * f1;
            if (2..2 + ORDERS as u32).contains(&bounces) {
                s.orders[j][(bounces - 2) as usize] += ww;
            }
        }
    }
    s
}

/// One walk of the F = 1 microsurface from `wi` (same steps as the
/// library's walk: log-height `ln C1`, full-sphere Lambda, visible-normal
/// sampling, mirror reflection), recording in `cos` the cosines `|w.m|` at
/// its facets; true when it escaped after two or more of them.
fn ms_path_cosines(
    ndf: &Ndf,
    max_bounces: u32,
    wi: Vec3,
    rng: &mut Rng,
    cos: &mut Vec<f32>,
) -> bool {
    let mut w = -wi;
    let mut lc = 0.0f64;
    cos.clear();
    for _ in 0..=max_bounces {
        let lam = ndf.lambda(w) as f64;
        let u = ((rng.next_u32() >> 8) as f64 + 0.5) / 16_777_216.0;
        if w.z > 0.0 {
            if lam.is_finite() {
                let esc = (lam * lc).exp();
                if u < esc {
                    return cos.len() >= 2;
                }
                lc = (lc - (1.0 - u + esc).ln() / lam).min(0.0);
            }
        } else if lam.is_finite() && lam < 0.0 {
            lc += u.ln() / (-lam);
        }
        let i = -w;
        let m = ndf.sample_visible(i, rng.next_f32(), rng.next_f32());
        let ci = i.dot(m);
        if ci <= 0.0 || !m.is_finite() {
            return false;
        }
        cos.push(ci);
        w = reflect(i, m);
    }
    false
}

/// A cosine-distributed direction (the azimuth is irrelevant for isotropic
/// roughness but drawn anyway).
fn cosine_dir(rng: &mut Rng) -> Vec3 {
    let mu = rng.next_f32().sqrt().max(MU_GRAZING);
    let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
    let st = (1.0 - mu * mu).max(0.0).sqrt();
    Vec3::new(st * phi.cos(), st * phi.sin(), mu)
}

/// Cosines `|w.m|` at which multiply scattered paths (F = 1) meet facets,
/// from `wi` with cosine-distributed `mu_i`; returns the 1/6, 1/2, 5/6
/// quantiles.
fn fresnel_job(kind: NdfKind, alpha: f32, walks: u64, stream: u64) -> [f32; FRESNEL_Q] {
    let ndf = Ndf::new(kind, alpha, alpha);
    let max_bounces = default_max_bounces(alpha, alpha, &CONDUCTOR_F1);
    let mut rng = Rng::new(SEED_FRESNEL, stream);
    const BINS: usize = 1000;
    let mut hist = vec![0.0f64; BINS];
    let mut cos = Vec::with_capacity(64);
    for _ in 0..walks {
        let wi = cosine_dir(&mut rng);
        if ms_path_cosines(&ndf, max_bounces, wi, &mut rng, &mut cos) {
            for &c in &cos {
                hist[((c * BINS as f32) as usize).min(BINS - 1)] += 1.0;
            }
        }
    }
    let total: f64 = hist.iter().sum();
    let mut out = [1.0f32; FRESNEL_Q];
    if total <= 0.0 {
        return out;
    }
    let mut acc = 0.0;
    let mut q = 0;
    for (b, h) in hist.iter().enumerate() {
        let before = acc;
        acc += h;
        while q < FRESNEL_Q && acc >= total * (q as f64 + 0.5) / FRESNEL_Q as f64 {
            let target = total * (q as f64 + 0.5) / FRESNEL_Q as f64;
            let frac = if *h > 0.0 { (target - before) / h } else { 0.5 };
            out[q] = ((b as f64 + frac) / BINS as f64) as f32;
            q += 1;
        }
    }
    out
}

/// Schlick weights `(1 - c)^5` of multiply scattered paths (F = 1): the mean
/// over their first facets from `wi = mu` (or, with `mu = None`, the mean
/// over all their facets from cosine-distributed directions).
fn schlick_job(kind: NdfKind, alpha: f32, mu: Option<f32>, walks: u64, stream: u64) -> f64 {
    let ndf = Ndf::new(kind, alpha, alpha);
    let max_bounces = default_max_bounces(alpha, alpha, &CONDUCTOR_F1);
    let mut rng = Rng::new(SEED_SCHLICK, stream);
    let mut cos = Vec::with_capacity(64);
    let (mut sum, mut count) = (0.0f64, 0.0f64);
    for _ in 0..walks {
        let wi = match mu {
            Some(m) => dir(m),
            None => cosine_dir(&mut rng),
        };
        if ms_path_cosines(&ndf, max_bounces, wi, &mut rng, &mut cos) {
            let w5 = |c: f32| ((1.0 - c as f64).max(0.0)).powi(5);
            if mu.is_some() {
                sum += w5(cos[0]);
                count += 1.0;
            } else {
                sum += cos.iter().map(|&c| w5(c)).sum::<f64>();
                count += cos.len() as f64;
            }
        }
    }
    if count > 0.0 { sum / count } else { 0.0 }
}

/// Runs jobs on `threads` threads with a progress bar on stderr.
fn parallel<J: Sync, R: Send>(
    jobs: &[J],
    what: &str,
    threads: usize,
    f: impl Fn(usize, &J) -> R + Sync,
) -> Vec<R> {
    let t0 = std::time::Instant::now();
    let total = jobs.len();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let mut parts: Vec<(usize, R)> = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..threads)
            .map(|_| {
                let (f, next, done) = (&f, &next, &done);
                sc.spawn(move || {
                    let mut out = Vec::new();
                    loop {
                        let idx = next.fetch_add(1, Ordering::Relaxed);
                        if idx >= total {
                            break;
                        }
                        out.push((idx, f(idx, &jobs[idx])));
                        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                        let el = t0.elapsed().as_secs_f64();
                        let width = 40;
                        let filled = width * d / total;
                        eprint!(
                            "\r{what} [{}{}] {d}/{total} {el:.0} s, ETA {:.0} s   ",
                            "#".repeat(filled),
                            " ".repeat(width - filled),
                            el / d as f64 * (total - d) as f64
                        );
                    }
                    out
                })
            })
            .collect();
        hs.into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    eprintln!();
    parts.sort_by_key(|p| p.0);
    parts.into_iter().map(|p| p.1).collect()
}
/// Writes a table file: the text `header` (which must start with `magic`)
/// padded with zeros to `header_bytes`, then `values` as little-endian f32;
/// the file must come to `file_bytes` (the layout the library's `const`
/// assertions check).
fn write_table(
    out: &str,
    header: &str,
    magic: &[u8],
    header_bytes: usize,
    file_bytes: usize,
    values: impl IntoIterator<Item = f32>,
) {
    let payload = f32_bytes(values);
    write_bytes(out, header, magic, header_bytes, file_bytes, &payload);
}

/// `values` as little-endian f32 bytes.
fn f32_bytes(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// Writes `header` (padded with zeros to `header_bytes`) and `payload`.
fn write_bytes(
    out: &str,
    header: &str,
    magic: &[u8],
    header_bytes: usize,
    file_bytes: usize,
    payload: &[u8],
) {
    eprint!("{header}");
    let mut bytes = Vec::with_capacity(file_bytes);
    bytes.extend_from_slice(header.as_bytes());
    assert!(bytes.len() <= header_bytes, "header too long");
    assert!(bytes.starts_with(magic));
    bytes.resize(header_bytes, 0);
    bytes.extend_from_slice(payload);
    assert_eq!(bytes.len(), file_bytes);
    std::fs::write(out, &bytes).expect("write output");
    eprintln!("wrote {out} ({} bytes)", bytes.len());
}

/// The `A:B:C` triples of option `name`'s comma-separated value (those
/// that parse), if the option is given.
fn triples_arg<A: std::str::FromStr, B: std::str::FromStr, C: std::str::FromStr>(
    args: &[String],
    name: &str,
) -> Option<Vec<(A, B, C)>> {
    args.iter()
        .position(|a| a == name)
        .and_then(|p| args.get(p + 1))
        .map(|v| {
            v.split(',')
                .filter_map(|t| {
                    let f: Vec<&str> = t.split(':').collect();
                    Some((
                        f.first()?.parse().ok()?,
                        f.get(1)?.parse().ok()?,
                        f.get(2)?.parse().ok()?,
                    ))
                })
                .collect()
        })
}

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> T {
    args.iter()
        .position(|a| a == name)
        .and_then(|p| args.get(p + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// `--scale`: the furnace scale table from the committed lobe table.
fn scale_main(args: &[String]) {
    let samples: u64 = arg(args, "--gram-samples", 100_000);
    let schlick_walks: u64 = arg(args, "--schlick-walks", 100_000);
    let threads: usize = arg(args, "--threads", 2);
    let table: String = arg(args, "--table", "data/tabulated_conductor.bin".to_string());
    let out: String = arg(args, "--out", "data/tabulated_scale.bin".to_string());
    let t0 = std::time::Instant::now();
    let raw = std::fs::read(&table).expect("read the lobe table");
    assert_eq!(raw.len(), FILE_BYTES, "lobe table size");
    // The stored lobe block, read through `lobe_index` (which reads a cell
    // (j, i) as its stored transpose (i, j)).
    let lobe: Vec<f64> = raw[HEADER_BYTES..HEADER_BYTES + 4 * LOBE_LEN]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64)
        .collect();
    let table_header = String::from_utf8_lossy(&raw[..HEADER_BYTES])
        .trim_end_matches('\0')
        .to_string();
    let table_commit = table_header
        .lines()
        .find(|l| l.starts_with("commit:"))
        .unwrap_or("commit: ?")
        .to_string();
    // Per (ndf, scale alpha >= 1, fine mu_i node): 1 - E_ss and
    // Q_y = int hat_y f_ss1 mu dw of the peaked basis function on the fine
    // mu_o hats y.
    let fine = SCALE_MU_N;
    let fine_x = |mu: f64| mu.clamp(0.0, 1.0).sqrt() * (fine - 1) as f64;
    let jobs: Vec<(usize, usize, usize)> = (0..NDF_N)
        .flat_map(|n| (1..SCALE_ALPHA_N).flat_map(move |a| (0..fine).map(move |i| (n, a, i))))
        .collect();
    let res = parallel(&jobs, "scale", threads, |idx, &(n, a, i)| {
        let alpha = scale_grid_alpha(a);
        let ndf = Ndf::new(NDFS[n], alpha, alpha);
        let single = Single::new(ndf, CONDUCTOR_F1, G2Form::HeightCorrelated);
        let wi = dir(scale_grid_mu(i).max(MU_GRAZING));
        let ess = single_albedo(
            |x, y| single.eval(x, y, &mut Rng::new(0, 0)).x,
            alpha,
            alpha,
            wi,
            None,
            192,
        );
        let mut rng = Rng::new(SEED_SCALE, idx as u64);
        let mut q = vec![0.0f64; fine];
        for _ in 0..samples {
            let smp = single.sample(wi, &mut rng);
            if smp.wo.z <= 0.0 || smp.pdf <= 0.0 {
                continue;
            }
            let ss1 = single.eval(wi, smp.wo, &mut Rng::new(0, 0)).x as f64;
            let v = ss1 / smp.pdf as f64 / samples as f64;
            let x = fine_x(smp.wo.z as f64);
            let y0 = (x as usize).min(fine - 2);
            let fr = x - y0 as f64;
            q[y0] += v * (1.0 - fr);
            q[y0 + 1] += v * fr;
        }
        ((1.0 - ess).max(0.0), q)
    });
    // int hat_y(mu) mu dmu on the fine grid (midpoint rule in sqrt(mu)).
    let mut wf = vec![0.0f64; fine];
    let nq = 200_000;
    for t in 0..nq {
        let s = (t as f64 + 0.5) / nq as f64;
        let x = s * (fine - 1) as f64;
        let y0 = (x as usize).min(fine - 2);
        let fr = x - y0 as f64;
        let m = s * s * 2.0 * s / nq as f64;
        wf[y0] += (1.0 - fr) * m * 2.0 * PI;
        wf[y0 + 1] += fr * m * 2.0 * PI;
    }
    // Schlick weights of the first facets (per mu node) and of all facets.
    let sjobs: Vec<(usize, usize, Option<usize>)> = (0..NDF_N)
        .flat_map(|n| {
            (1..ALPHA_N).flat_map(move |a| {
                (0..MU_N)
                    .map(move |i| (n, a, Some(i)))
                    .chain(std::iter::once((n, a, None)))
            })
        })
        .collect();
    let schlick = parallel(&sjobs, "schlick", threads, |idx, &(n, a, i)| {
        schlick_job(
            NDFS[n],
            grid_alpha(a),
            i.map(node_mu),
            schlick_walks,
            idx as u64,
        )
    });
    let mut first = vec![0.0f32; FIRST_LEN];
    let mut sbar = [0.0f32; SBAR_LEN];
    for (&(n, a, i), v) in sjobs.iter().zip(&schlick) {
        match i {
            Some(i) => first[albedo_index(n, a, i)] = *v as f32,
            None => sbar[n * ALPHA_N + a] = *v as f32,
        }
    }
    let mut scale = vec![1.0f32; SCALE_LEN];
    let (mut worst_before, mut worst_after, mut s_min, mut s_max) =
        (0.0f64, 0.0f64, 1.0f64, 1.0f64);
    // Nodes whose target 1 - E_ss is 0 (their scale is 0).
    let mut zero_targets = 0usize;
    for n in 0..NDF_N {
        for a in 1..SCALE_ALPHA_N {
            let (a0, a1, fa) = split(alpha_coord(scale_grid_alpha(a)), ALPHA_N);
            let fa = fa as f64;
            // The runtime interpolant of c0 and B at fine (mu_i, mu_o).
            let interp = |mi: f32, mo: f32, k: usize| {
                let (i0, i1, fi) = split(mu_coord(mi), MU_N);
                let (j0, j1, fj) = split(mu_coord(mo), MU_N);
                let (fi, fj) = (fi as f64, fj as f64);
                let mut v = 0.0;
                for (aa, wa) in [(a0, 1.0 - fa), (a1, fa)] {
                    for (ii, wi) in [(i0, 1.0 - fi), (i1, fi)] {
                        for (jj, wj) in [(j0, 1.0 - fj), (j1, fj)] {
                            v += wa * wi * wj * lobe[lobe_index(n, aa, ii, jj) + k];
                        }
                    }
                }
                v
            };
            let Some(base) = jobs.iter().position(|&x| x == (n, a, 0)) else {
                continue;
            };
            let kernel: Vec<Vec<f64>> = (0..fine)
                .map(|i| {
                    let mi = scale_grid_mu(i);
                    (0..fine)
                        .map(|y| {
                            let mo = scale_grid_mu(y);
                            // Azimuth average of the clamped smooth series,
                            // as eval computes it (midpoint rule, 64 angles).
                            let c: [f64; K_STORED] = std::array::from_fn(|k| interp(mi, mo, k));
                            let mut avg = 0.0;
                            for t in 0..64 {
                                let cp = (PI * (t as f64 + 0.5) / 64.0).cos();
                                let (mut t0, mut t1) = (1.0, cp);
                                let mut v = c[0] + c[1] * cp;
                                for ck in &c[2..] {
                                    let t2 = 2.0 * cp * t1 - t0;
                                    v += ck * t2;
                                    (t0, t1) = (t1, t2);
                                }
                                avg += v.max(0.0) / 64.0;
                            }
                            wf[y] * avg + res[base + i].1[y] * interp(mi, mo, PEAK)
                        })
                        .collect()
                })
                .collect();
            let target: Vec<f64> = (0..fine).map(|i| res[base + i].0).collect();
            zero_targets += target.iter().filter(|&&t| t <= 0.0).count();
            let mut sc = vec![1.0f64; fine];
            for (i, t) in target.iter().enumerate() {
                let r: f64 = kernel[i].iter().sum();
                if *t > 1e-3 {
                    worst_before = worst_before.max((r / t - 1.0).abs());
                }
            }
            for _ in 0..300 {
                for i in 0..fine {
                    // A node whose target is 0 (E_ss = 1: Beckmann at low
                    // roughness near grazing, where the quadrature gives
                    // E_ss >= 1) gets no multiply scattered energy: scale
                    // 0. Before this rule (session 22) such nodes kept
                    // their start value 1, and the unscaled lobe gave
                    // Beckmann alpha 0.002 at 89 degrees an albedo of 1.023.
                    if target[i] <= 0.0 {
                        sc[i] = 0.0;
                        continue;
                    }
                    let cur: f64 = (0..fine).map(|y| kernel[i][y] * sc[i] * sc[y]).sum();
                    // At most just under SCALE_MAX: the encoding's range.
                    // Beckmann alpha 0.0005 at 86 degrees, next to nodes
                    // of target 0, asks for 44 to meet a target of 2e-6.
                    if cur > 0.0 {
                        sc[i] = (sc[i] * (target[i] / cur).sqrt()).min(SCALE_TOP);
                    }
                }
            }
            for (i, t) in target.iter().enumerate() {
                let r: f64 = (0..fine).map(|y| kernel[i][y] * sc[i] * sc[y]).sum();
                if *t > 1e-3 {
                    worst_after = worst_after.max((r / t - 1.0).abs());
                }
                s_min = s_min.min(sc[i]);
                s_max = s_max.max(sc[i]);
                scale[scale_index(n, a, i)] = sc[i] as f32;
            }
        }
    }
    // The scale file: per scale node the pair (s, S_first) as u16 (see
    // SCALE_MAX), S_first resampled bilinearly from the lobe grid's
    // estimates (both grids are uniform in sqrt(alpha) and sqrt(mu), so a
    // scale node's lobe-grid coordinates are linear in its indices).
    assert!(s_max < SCALE_MAX as f64, "scales above SCALE_MAX");
    let first_at = |n: usize, a: usize, i: usize| {
        let xa = (a * (ALPHA_N - 1)) as f64 / (SCALE_ALPHA_N - 1) as f64;
        let xi = (i * (MU_N - 1)) as f64 / (SCALE_MU_N - 1) as f64;
        let (a0, i0) = ((xa as usize).min(ALPHA_N - 2), (xi as usize).min(MU_N - 2));
        let (fa, fi) = (xa - a0 as f64, xi - i0 as f64);
        let g = |aa: usize, ii: usize| first[albedo_index(n, aa, ii)] as f64;
        let row = |aa: usize| g(aa, i0) * (1.0 - fi) + g(aa, i0 + 1) * fi;
        row(a0) * (1.0 - fa) + row(a0 + 1) * fa
    };
    let mut payload = Vec::with_capacity(SCALE_FILE_BYTES - HEADER_BYTES);
    for n in 0..NDF_N {
        for a in 0..SCALE_ALPHA_N {
            for i in 0..SCALE_MU_N {
                let s = scale[scale_index(n, a, i)] as f64;
                payload.extend_from_slice(&scale_encode(s, SCALE_MAX as f64).to_le_bytes());
                payload.extend_from_slice(&scale_encode(first_at(n, a, i), 1.0).to_le_bytes());
            }
        }
    }
    payload.extend(sbar.iter().flat_map(|v| v.to_le_bytes()));
    let header = format!(
        "MSBSDF-TABULATED-SCALE-v2\n\
         MSBSDF_MODEL_TABULATED furnace scale table (layout: src/multiple/tabulated.rs)\n\
         command: cargo run --release --example gen_tabulated -- {}\n\
         commit: {}\n\
         lobe table: {table} ({table_commit})\n\
         E_ss: SINGLE quadrature 192 x 192; albedo of the peaked part: {samples} SINGLE samples per node, seed Rng::new({SEED_SCALE}, stream = job index)\n\
         albedo of the alpha-interpolated table vs 1 - E_ss: worst relative deviation {worst_before:.3e} (targets > 1e-3); after scaling {worst_after:.3e} (before the u16 encoding); scales in [{s_min:.4}, {s_max:.4}]; {zero_targets} nodes with the target 0 (E_ss >= 1 by the quadrature) have the scale 0\n\
         Schlick weights (1 - c)^5 of multiply scattered paths: first facets per (ndf, alpha node, mu node) of the lobe grid, all facets per (ndf, alpha node); instrumented walk, {schlick_walks} walks per entry, seed Rng::new({SEED_SCHLICK}, stream = job index)\n\
         layout: per (ndf {NDF_N}, scale alpha {SCALE_ALPHA_N}, scale mu {SCALE_MU_N}) node two u16: the scale s = {SCALE_MAX} (v / 65535)^2 and the first-facet Schlick weight (v / 65535)^2 (resampled bilinearly from the lobe grid); then the all-facets weights, f32 per (ndf, alpha node)\n\
         wall time: {:.0} s on {threads} threads\n",
        args[1..].join(" "),
        git::commit(),
        t0.elapsed().as_secs_f64(),
    );
    write_bytes(
        &out,
        &header,
        SCALE_MAGIC,
        HEADER_BYTES,
        SCALE_FILE_BYTES,
        &payload,
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    cli::check_options(OPTIONS, USAGE);
    if args.iter().any(|a| a == "--dielectric-ir") {
        dielectric::ir(&args);
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--dielectric-v5") {
        dielectric::v5_main(&args, &args[p + 1..]);
        return;
    }
    if args.iter().any(|a| a == "--dielectric-normalize") {
        dielectric::normalize_main(&args);
        return;
    }
    if args.iter().any(|a| a == "--mu-pilot") {
        dielectric::mu_pilot_main(&args);
        return;
    }
    if args.iter().any(|a| a == "--dielectric-scale-fit") {
        dielectric::scale_fit_main(&args);
        return;
    }
    if args.iter().any(|a| a == "--dielectric-scale-top") {
        dielectric::scale_top_main(&args);
        return;
    }
    if args.iter().any(|a| a == "--dielectric-scale-splice") {
        dielectric::scale_splice_main(&args);
        return;
    }
    if args.iter().any(|a| a == "--dielectric-scale") {
        dielectric::scale_main(&args);
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--dielectric-pack") {
        dielectric::pack_main(&args, &args[p + 1..]);
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--dielectric-lobe-pack") {
        dielectric::lobe_pack_main(&args, &args[p + 1..]);
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--conductor-pack") {
        conductor_pack_main(&args, &args[p + 1..]);
        return;
    }
    if args.iter().any(|a| a == "--dielectric-check") {
        dielectric::check(&args);
        return;
    }
    if args.iter().any(|a| a == "--dielectric") {
        dielectric::main(&args);
        return;
    }
    if args.iter().any(|a| a == "--scale") {
        scale_main(&args);
        return;
    }
    let walks: u64 = arg(&args, "--walks", 2_000_000);
    let fresnel_walks: u64 = arg(&args, "--fresnel-walks", 200_000);
    let gram: u64 = arg(&args, "--gram-samples", 400_000);
    let threads: usize = arg(&args, "--threads", 2);
    let out: String = arg(&args, "--out", "data/tabulated_conductor.bin".to_string());
    let t0 = std::time::Instant::now();

    // Jobs: (ndf, alpha node >= 1, mu_i node).
    let jobs: Vec<(usize, usize, usize)> = (0..NDF_N)
        .flat_map(|n| (1..ALPHA_N).flat_map(move |a| (0..MU_N).map(move |i| (n, a, i))))
        .collect();
    let from_dump: Option<String> = args
        .iter()
        .position(|a| a == "--from-dump")
        .and_then(|p| args.get(p + 1).cloned());
    let dump: Option<String> = args
        .iter()
        .position(|a| a == "--dump")
        .and_then(|p| args.get(p + 1).cloned());
    if let Some(path) = &from_dump {
        let (sums, fq, ess) = load_dump(path, jobs.len());
        return finish(
            &args,
            &jobs,
            &sums,
            &fq,
            &ess,
            walks,
            fresnel_walks,
            gram,
            threads,
            &out,
            t0,
        );
    }
    let sums = parallel(&jobs, "walks", threads, |idx, &(n, a, i)| {
        lobe_job(NDFS[n], grid_alpha(a), node_mu(i), walks, gram, idx as u64)
    });
    let fjobs: Vec<(usize, usize)> = (0..NDF_N)
        .flat_map(|n| (1..ALPHA_N).map(move |a| (n, a)))
        .collect();
    let fq = parallel(&fjobs, "fresnel", threads, |idx, &(n, a)| {
        fresnel_job(NDFS[n], grid_alpha(a), fresnel_walks, idx as u64)
    });
    let ess = parallel(&jobs, "E_ss", threads, |_, &(n, a, i)| {
        let alpha = grid_alpha(a);
        let s = Single::new(
            Ndf::new(NDFS[n], alpha, alpha),
            CONDUCTOR_F1,
            G2Form::HeightCorrelated,
        );
        single_albedo(
            |x, y| s.eval(x, y, &mut Rng::new(0, 0)).x,
            alpha,
            alpha,
            dir(node_mu(i)),
            None,
            256,
        )
    });

    if let Some(path) = &dump {
        save_dump(path, &sums, &fq, &ess);
    }
    finish(
        &args,
        &jobs,
        &sums,
        &fq,
        &ess,
        walks,
        fresnel_walks,
        gram,
        threads,
        &out,
        t0,
    );
}

/// Raw sums as little-endian f64 (`--dump`), so the post-processing can be
/// redone without the walks (`--from-dump`).
fn save_dump(path: &str, sums: &[Sums], fq: &[[f32; FRESNEL_Q]], ess: &[f64]) {
    let mut v: Vec<f64> = Vec::new();
    for s in sums {
        v.push(s.walks as f64);
        v.push(s.ms as f64);
        v.extend(s.moments.iter().flatten());
        v.extend(s.orders.iter().flatten());
        v.extend(&s.peak);
        v.extend(s.gram_kb.iter().flatten());
        v.extend(&s.gram_bb);
    }
    v.extend(fq.iter().flatten().map(|&x| x as f64));
    v.extend(ess);
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes).expect("write dump");
}

/// Reads [`save_dump`]'s file.
fn load_dump(path: &str, jobs: usize) -> (Vec<Sums>, Vec<[f32; FRESNEL_Q]>, Vec<f64>) {
    let raw = std::fs::read(path).expect("read dump");
    let v: Vec<f64> = raw
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]))
        .collect();
    let mut it = v.into_iter();
    let mut take = |n: usize| -> Vec<f64> { it.by_ref().take(n).collect() };
    let rows = |flat: Vec<f64>, w: usize| -> Vec<Vec<f64>> {
        flat.chunks(w).map(|c| c.to_vec()).collect()
    };
    let mut sums = Vec::with_capacity(jobs);
    for _ in 0..jobs {
        let head = take(2);
        let moments = rows(take(MU_N * K_FIT), K_FIT)
            .into_iter()
            .map(|r| std::array::from_fn(|k| r[k]))
            .collect();
        let orders = rows(take(MU_N * ORDERS), ORDERS)
            .into_iter()
            .map(|r| std::array::from_fn(|k| r[k]))
            .collect();
        let peak = take(MU_N);
        let gram_kb = rows(take(MU_N * K_FIT), K_FIT)
            .into_iter()
            .map(|r| std::array::from_fn(|k| r[k]))
            .collect();
        let gram_bb = take(MU_N);
        sums.push(Sums {
            walks: head[0] as u64,
            ms: head[1] as u64,
            moments,
            orders,
            peak,
            gram_kb,
            gram_bb,
        });
    }
    let fjobs = NDF_N * (ALPHA_N - 1);
    let fq = rows(take(fjobs * FRESNEL_Q), FRESNEL_Q)
        .into_iter()
        .map(|r| std::array::from_fn(|k| r[k] as f32))
        .collect();
    let ess = take(jobs);
    (sums, fq, ess)
}

/// Symmetric (Sinkhorn) scaling: factors `s` with
/// `s_i sum_j m(i, j) s_j = target_i` for every node `i` whose target and
/// row are positive (200 sweeps of `s_i *= sqrt(target_i / row_i)`).
/// `m(i, j)` is the albedo contribution of node `j` to row `i`; scaling the
/// lobe by `s_i s_j` keeps any reciprocity of the form
/// `f(i, j) c_j = f(j, i) c_i`. Nodes whose target is 0 keep 1 (the lobe
/// tables' solves, as their data were made); [`sinkhorn_within`] is the
/// furnace scales' variant.
fn sinkhorn(target: &[f64], m: impl Fn(usize, usize) -> f64) -> Vec<f64> {
    sinkhorn_within(target, m, None)
}

/// [`sinkhorn`], with `Some((lo, hi))`: a node whose target is 0 gets the
/// factor 0 (no multiply scattered energy where `E_ss` is 1) and the
/// others stay within `[lo, hi]` during the iteration, so that the rest
/// adapt to a clamped node.
fn sinkhorn_within(
    target: &[f64],
    m: impl Fn(usize, usize) -> f64,
    range: Option<(f64, f64)>,
) -> Vec<f64> {
    let n = target.len();
    let mut sc = vec![1.0f64; n];
    for _ in 0..200 {
        for i in 0..n {
            if let Some((lo, hi)) = range {
                if target[i] <= 0.0 {
                    sc[i] = 0.0;
                    continue;
                }
                let cur: f64 = (0..n).map(|j| m(i, j) * sc[i] * sc[j]).sum();
                if cur > 0.0 {
                    sc[i] = (sc[i] * (target[i] / cur).sqrt()).clamp(lo, hi);
                }
                continue;
            }
            let cur: f64 = (0..n).map(|j| m(i, j) * sc[i] * sc[j]).sum();
            if cur > 0.0 && target[i] > 0.0 {
                sc[i] *= (target[i] / cur).sqrt();
            }
        }
    }
    sc
}

/// Post-processing: coefficients, symmetrisation, normalisation, file.
#[allow(clippy::too_many_arguments)]
fn finish(
    args: &[String],
    jobs: &[(usize, usize, usize)],
    sums: &[Sums],
    fq: &[[f32; FRESNEL_Q]],
    ess: &[f64],
    walks: u64,
    fresnel_walks: u64,
    gram: u64,
    threads: usize,
    out: &str,
    t0: std::time::Instant,
) {
    let fjobs: Vec<(usize, usize)> = (0..NDF_N)
        .flat_map(|n| (1..ALPHA_N).map(move |a| (n, a)))
        .collect();
    let h: Vec<f64> = (0..MU_N).map(hat_moment).collect();
    // Every (mu_i, mu_o) cell (full_index): the symmetrisation and the
    // scaling below work on both halves; the file keeps one (pack).
    let mut lobe = vec![0.0f64; FULL_LOBE_LEN];
    let mut albedo = vec![0.0f64; ALBEDO_LEN];
    let mut fresnel = vec![1.0f32; FRESNEL_LEN];
    // int hat_j f_ss1 mu dw per (ndf, alpha, mu_i) and node j: albedo of the
    // peaked part.
    let mut q_int = vec![0.0f64; ALBEDO_LEN * MU_N];
    let (mut sym_num, mut sym_den, mut sym_max) = (0.0f64, 0.0f64, 0.0f64);
    let (mut sym_num3, mut sym_den3) = (0.0f64, 0.0f64);
    let (mut norm_worst, mut mc_worst) = (0.0f64, 0.0f64);
    let mut total_walks = 0u64;
    for (jidx, &(n, a, i)) in jobs.iter().enumerate() {
        let s = &sums[jidx];
        total_walks += s.walks;
        for j in 0..MU_N {
            let b = full_index(n, a, i, j);
            let m0 = s.moments[j][0];
            let nw = s.walks as f64;
            let (coef, bpk) = fit_node(
                &s.moments[j],
                nw,
                s.peak[j],
                &s.gram_kb[j],
                s.gram_bb[j],
                h[j],
            );
            lobe[b..b + K_STORED].copy_from_slice(&coef[..K_STORED]);
            // At mu = 1 (either side) the lobe does not depend on the
            // azimuth (which is undefined there): no cosine terms k >= 1.
            if i == MU_N - 1 || j == MU_N - 1 {
                for k in 1..K_STORED {
                    lobe[b + k] = 0.0;
                }
            }
            lobe[b + PEAK] = bpk;
            q_int[albedo_index(n, a, i) * MU_N + j] = s.gram_kb[j][0];
            for o in 0..ORDERS {
                lobe[b + ORDER0 + o] = if m0 > 0.0 { s.orders[j][o] / m0 } else { 0.0 };
            }
        }
    }
    for (fidx, &(n, a)) in fjobs.iter().enumerate() {
        let b = fresnel_index(n, a);
        fresnel[b..b + FRESNEL_Q].copy_from_slice(&fq[fidx]);
    }
    // Symmetrise, then rescale symmetrically to the target albedos.
    let w: Vec<f64> = h.iter().map(|x| 2.0 * PI * x).collect();
    for n in 0..NDF_N {
        for a in 1..ALPHA_N {
            for i in 0..MU_N {
                for j in i + 1..MU_N {
                    let (bi, bj) = (full_index(n, a, i, j), full_index(n, a, j, i));
                    // Azimuth-averaged f (smooth + peaked part) of both.
                    let qi = q_int[albedo_index(n, a, i) * MU_N + j];
                    let qj = q_int[albedo_index(n, a, j) * MU_N + i];
                    let x = lobe[bi] + lobe[bi + PEAK] * qi / (2.0 * PI * h[j]);
                    let y = lobe[bj] + lobe[bj + PEAK] * qj / (2.0 * PI * h[i]);
                    let d = (x - y).abs();
                    if i >= 3 {
                        sym_num3 += d * d;
                        sym_den3 += (0.5 * (x + y)).powi(2);
                    }
                    sym_num += d * d;
                    sym_den += (0.5 * (x + y)).powi(2);
                    if x + y > 1e-3 {
                        sym_max = sym_max.max(d / (0.5 * (x + y)));
                    }
                    // Cosine terms, the peaked weight and the order fractions.
                    for k in 0..CELL {
                        let v = 0.5 * (lobe[bi + k] + lobe[bj + k]);
                        lobe[bi + k] = v;
                        lobe[bj + k] = v;
                    }
                }
            }
            let target: Vec<f64> = (0..MU_N)
                .map(|i| {
                    let jidx = jobs
                        .iter()
                        .position(|&x| x == (n, a, i))
                        .unwrap_or_default();
                    (1.0 - ess[jidx]).max(0.0)
                })
                .collect();
            let q_row = |i: usize| &q_int[albedo_index(n, a, i) * MU_N..][..MU_N];
            let cell_albedo = |lobe: &[f64], i: usize, j: usize| -> f64 {
                let b = full_index(n, a, i, j);
                w[j] * lobe[b] + q_row(i)[j] * lobe[b + PEAK]
            };
            let row = |lobe: &[f64], i: usize| -> f64 {
                (0..MU_N).map(|j| cell_albedo(lobe, i, j)).sum()
            };
            for (i, t) in target.iter().enumerate() {
                let r = row(&lobe, i);
                if *t > 1e-3 {
                    mc_worst = mc_worst.max((r / t - 1.0).abs());
                }
            }
            let sc = sinkhorn(&target, |i, j| cell_albedo(&lobe, i, j));
            for i in 0..MU_N {
                for j in 0..MU_N {
                    let b = full_index(n, a, i, j);
                    for k in 0..=PEAK {
                        lobe[b + k] *= sc[i] * sc[j];
                    }
                }
            }
            for (i, t) in target.iter().enumerate() {
                let r = row(&lobe, i);
                albedo[albedo_index(n, a, i)] = r;
                if *t > 1e-4 {
                    norm_worst = norm_worst.max((r / t - 1.0).abs());
                }
            }
        }
    }
    let header = format!(
        "MSBSDF-TABULATED-v2\n\
         MSBSDF_MODEL_TABULATED conductor table (layout: src/multiple/tabulated.rs)\n\
         command: cargo run --release --example gen_tabulated -- {}\n\
         commit: {}\n\
         walks: HEITZ_RANDOM_WALK (library, default bounce limit, F = 1) {walks} per (ndf, alpha, mu_i) node, {total_walks} in total; seed Rng::new({SEED_LOBE}, stream = job index)\n\
         fresnel cosines: instrumented walk, {fresnel_walks} walks per (ndf, alpha); seed Rng::new({SEED_FRESNEL}, stream = job index)\n\
         E_ss: SINGLE quadrature 256 x 256 (compensation::single_albedo)\n\
         symmetrisation: azimuth-averaged f(mu_i, mu_o) vs f(mu_o, mu_i): RMS relative difference {:.3e}, max {:.3e} (cells with f > 1e-3); {:.3e} without the three most grazing nodes (mu < 0.025, where the hat smoothing of steep lobes differs between the two)\n\
         albedo before rescaling vs 1 - E_ss: worst relative deviation {:.3e} (targets > 1e-3); after: {:.3e}\n\
         peaked part: Gram entries by {gram} SINGLE samples per node (seed Rng::new({SEED_GRAM}, stream = job index)), ridge {RIDGE} x G_BB\n\
         grid: ndf {NDF_N} x alpha {ALPHA_N} x (mu_i, mu_o) with mu_i node <= mu_o node ({R_PAIRS} of mu_i {MU_N} x mu_o {MU_N}) x {CELL} floats (K = {K_STORED} cosine terms of a {K_FIT}-term fit, peaked weight B, order fractions 2, 3, 4)\n\
         {}wall time: {:.0} s on {threads} threads\n",
        args[1..].join(" "),
        git::commit(),
        (sym_num / sym_den.max(1e-300)).sqrt(),
        sym_max,
        (sym_num3 / sym_den3.max(1e-300)).sqrt(),
        mc_worst,
        norm_worst,
        match args.iter().position(|a| a == "--from-dump") {
            Some(p) => format!(
                "walk sums: loaded from {} (written with --dump by a run with the same walk arguments)\n",
                args.get(p + 1).map(String::as_str).unwrap_or("?")
            ),
            None => String::new(),
        },
        t0.elapsed().as_secs_f64(),
    );
    let lobe: Vec<f32> = lobe.iter().map(|v| *v as f32).collect();
    write_table(
        out,
        &format!("{header}{PACKED}\n"),
        MAGIC,
        HEADER_BYTES,
        FILE_BYTES,
        pack(&lobe)
            .into_iter()
            .chain(albedo.iter().map(|v| *v as f32))
            .chain(fresnel.iter().copied()),
    );
}

/// Floats of the lobe block in the generator's layout: every `(mu_i,
/// mu_o)` cell, `[ndf][alpha][mu_i][mu_o][CELL]` (the file's version 1).
/// The file stores the `i <= j` half only (`lobe_index`): the
/// symmetrisation in `finish` makes the other half its transpose.
const FULL_LOBE_LEN: usize = NDF_N * ALPHA_N * MU_N * MU_N * CELL;
/// How version 2 stores the lobe (a header line).
const PACKED: &str = "layout: lobe stored for mu_i node <= mu_o node only (row by row; \
    (j, i) reads (i, j), which the symmetrisation makes equal to the bit; \
    tabulated::lobe_index)";

/// Index of a lobe cell in the generator's full layout.
fn full_index(n: usize, a: usize, i: usize, j: usize) -> usize {
    (((n * ALPHA_N + a) * MU_N + i) * MU_N + j) * CELL
}

/// The stored lobe block (`lobe_index`) of a lobe block in the full
/// layout; panics unless every cell equals its transpose to the bit (the
/// half left out would differ).
fn pack(full: &[f32]) -> Vec<f32> {
    assert_eq!(full.len(), FULL_LOBE_LEN);
    let mut out = vec![0.0f32; LOBE_LEN];
    let mut written = vec![false; LOBE_LEN];
    for n in 0..NDF_N {
        for a in 0..ALPHA_N {
            for i in 0..MU_N {
                for j in 0..MU_N {
                    let (src, dst) = (full_index(n, a, i, j), lobe_index(n, a, i, j));
                    let tr = full_index(n, a, j, i);
                    for k in 0..CELL {
                        let (v, t) = (full[src + k], full[tr + k]);
                        assert_eq!(v.to_bits(), t.to_bits(), "({n}, {a}, {i}, {j}) [{k}]");
                        out[dst + k] = v;
                        written[dst + k] = true;
                    }
                }
            }
        }
    }
    assert!(written.iter().all(|&w| w), "a stored cell left unwritten");
    out
}

/// `--conductor-pack PATH`: rewrites a version-1 table (every `(mu_i,
/// mu_o)` cell stored) as version 2 (`pack`) into `--out`, its header
/// kept with a line saying how it was converted. Every stored value is
/// version 1's, bit for bit; the albedo and Fresnel blocks are copied.
fn conductor_pack_main(args: &[String], rest: &[String]) {
    repack(
        args,
        rest,
        &Repack {
            flag: "--conductor-pack",
            out: "data/tabulated_conductor.bin",
            old_magic: b"MSBSDF-TABULATED-v1\n",
            magic: MAGIC,
            file_bytes: FILE_BYTES,
            block_len: FULL_LOBE_LEN,
            rest_len: ALBEDO_LEN + FRESNEL_LEN,
            layout: PACKED,
            ones: 0,
        },
        |full| f32_bytes(pack(full)),
    );
}

/// A table file's conversion to its next version, which stores its first
/// block another way: a symmetric lobe's `i <= j` half only
/// (`--conductor-pack`, `--dielectric-pack`) or 24-bit lobe values
/// (`--dielectric-lobe-pack`, and `--dielectric-pack` after the half), or
/// the same bytes with a block appended (`--dielectric-v5`).
struct Repack<'a> {
    /// The command-line flag (its usage line).
    flag: &'a str,
    /// Default `--out`.
    out: &'a str,
    /// Magic of the file read.
    old_magic: &'a [u8],
    /// Magic and size of the file written.
    magic: &'a [u8],
    file_bytes: usize,
    /// Floats of the block converted, and of the blocks after it (copied).
    block_len: usize,
    rest_len: usize,
    /// The header line saying how the new version stores the block.
    layout: &'a str,
    /// Floats of 1 appended after the copied blocks: the dielectric
    /// table's normalisation block (version 5), every factor 1 until
    /// `--dielectric-normalize` runs on the table.
    ones: usize,
}

/// Rewrites the table file named by `rest[0]` (`spec.old_magic`, a block
/// of `spec.block_len` floats then `spec.rest_len` floats) with its first
/// block converted by `pack` (to the bytes stored) into `--out`, its
/// header kept (after the new magic) with a line saying how it was
/// converted (command, commit) and `spec.layout`. The blocks after it are
/// copied bit for bit.
fn repack(args: &[String], rest: &[String], spec: &Repack, pack: fn(&[f32]) -> Vec<u8>) {
    let out: String = arg(args, "--out", spec.out.to_string());
    let Some(path) = rest.first() else {
        eprintln!("{} PATH (a table file of the previous version)", spec.flag);
        std::process::exit(2);
    };
    let raw = std::fs::read(path).expect("read the table to convert");
    assert!(
        raw.starts_with(spec.old_magic),
        "not a table of the previous version"
    );
    assert_eq!(
        raw.len(),
        HEADER_BYTES + 4 * (spec.block_len + spec.rest_len)
    );
    let values: Vec<f32> = raw[HEADER_BYTES..]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let (block, kept) = values.split_at(spec.block_len);
    let old = String::from_utf8_lossy(&raw[spec.old_magic.len()..HEADER_BYTES]);
    let header = format!(
        "{}{}converted from {} (the lines above) by: cargo run --release --example \
         gen_tabulated -- {} (commit {})\n{}\n",
        String::from_utf8_lossy(spec.magic),
        old.trim_end_matches('\0'),
        String::from_utf8_lossy(spec.old_magic).trim_end(),
        args[1..].join(" "),
        git::commit(),
        spec.layout,
    );
    let mut payload = pack(block);
    payload.extend(f32_bytes(kept.iter().copied()));
    payload.extend(f32_bytes(std::iter::repeat_n(1.0, spec.ones)));
    write_bytes(
        &out,
        &header,
        spec.magic,
        HEADER_BYTES,
        spec.file_bytes,
        &payload,
    );
}

/// `--dielectric`: the dielectric table `data/tabulated_dielectric.bin`
/// (layout and grids: `src/multiple/tabulated_dielectric.rs`). For every
/// NDF, roughness node, relative index node `E`, side (thin: the walk sees
/// `E`; dense: `1 / E`) and incident cosine node, the library's
/// HEITZ_RANDOM_WALK (`Heitz::sample_with_bounces`, dielectric facets) runs
/// from `wi`; the exits of walks that scattered twice or more are projected
/// (`project_exit`) per lobe (reflection, transmission). SINGLE's reflected
/// plus transmitted albedo `E_ss` by quadrature gives the furnace targets.
mod dielectric {
    use super::{
        CONDUCTOR_F1, K_FIT, NDFS, RIDGE, arg, dir, fit_node, git, gram_entries, node_mu, parallel,
        sinkhorn, sinkhorn_within, triples_arg,
    };
    use glam::Vec3;
    use msbsdf::Rng;
    use msbsdf::bsdf::ScatterModel;
    use msbsdf::facet::Facet;
    use msbsdf::multiple::compensation::{
        broad_reflection_nodes, lower_hemisphere_nodes, single_albedo,
    };
    use msbsdf::multiple::heitz::Heitz;
    use msbsdf::multiple::tabulated::{MU_N, hat_moment, project_exit};
    use msbsdf::multiple::tabulated_dielectric::{
        ALBEDO_LEN, ALPHA_N, ETA_N, FILE_BYTES, HEADER_BYTES, K, LOBE_BYTES, LOBE_LEN, MAGIC,
        NDF_N, NODES, NORM_LEN, PEAK, R_CELL, R_DENSE, R_TERMS, R_THIN, SCALE_FILE_BYTES,
        SCALE_LEN, SCALE_MAGIC, SCALE_STEP, T_THIN, albedo_index, grid_alpha, grid_eta,
        lobe_decode, lobe_encode, lobe_index, node,
    };
    use msbsdf::ndf::Ndf;
    use msbsdf::single::{G2Form, Single};
    use std::f64::consts::PI;

    const SEED: u64 = 20261201;
    const SEED_GRAM: u64 = 20261202;

    /// Raw sums of one (ndf, alpha, eta, side, mu_i) job.
    struct Sums {
        walks: u64,
        /// Per mu_o node, the cosine moments of reflected and transmitted
        /// multiply scattered exits.
        r: [[f64; K_FIT]; MU_N],
        t: [[f64; K]; MU_N],
        /// Per mu_o node: sum of `hat_j f_ss1` over the reflected exits
        /// (right-hand side of the peaked part of the reflection lobe).
        peak: [[f64; 1]; MU_N],
        /// Gram entries of `f_ss1` (see `gram_entries`).
        gram_kb: Vec<[f64; K_FIT]>,
        gram_bb: Vec<f64>,
        /// Summed weights of the multiply scattered exits (R, T).
        ms: [f64; 2],
        /// SINGLE's reflected plus transmitted albedo from this node.
        ess: f64,
    }

    #[allow(clippy::too_many_arguments)]
    fn job(
        n: usize,
        alpha: f32,
        eta: f32,
        dense: bool,
        mu_i: f32,
        walks: u64,
        quad: usize,
        gram: u64,
        stream: u64,
    ) -> Sums {
        let kind = NDFS[n];
        let ndf = Ndf::new(kind, alpha, alpha);
        let walk = Heitz::new(ndf, Facet::Dielectric { eta }, 0);
        let up = dir(mu_i);
        let wi = if dense {
            Vec3::new(up.x, up.y, -up.z)
        } else {
            up
        };
        let mut rng = Rng::new(SEED, stream);
        // The peaked basis function of the reflection lobes: SINGLE's
        // reflection with F = 1 in the frame where wi is up.
        let single1 = Single::new(ndf, CONDUCTOR_F1, G2Form::HeightCorrelated);
        let (gram_kb, gram_bb) = gram_entries(&single1, up, gram, &mut Rng::new(SEED_GRAM, stream));
        let mut zero = Rng::new(0, 0);
        let mut s = Sums {
            walks,
            r: [[0.0; K_FIT]; MU_N],
            t: [[0.0; K]; MU_N],
            peak: [[0.0; 1]; MU_N],
            gram_kb,
            gram_bb,
            ms: [0.0; 2],
            ess: 0.0,
        };
        for _ in 0..walks {
            let (smp, bounces) = walk.sample_with_bounces(wi, &mut rng);
            if bounces < 2 || smp.wo.z == 0.0 {
                continue;
            }
            let w = smp.weight.x as f64;
            if w <= 0.0 || !w.is_finite() {
                continue;
            }
            // In the frame where wi is up; the azimuth is unchanged.
            let wo = smp.wo;
            let out = Vec3::new(wo.x, wo.y, wo.z.abs());
            if (wo.z > 0.0) == (wi.z > 0.0) {
                project_exit(out, w, &mut s.r);
                let f1 = single1.eval(up, out, &mut zero).x as f64 / out.z as f64;
                project_exit(out, w * f1, &mut s.peak);
                s.ms[0] += w;
            } else {
                project_exit(out, w, &mut s.t);
                s.ms[1] += w;
            }
        }
        s.ess = ess(ndf, if dense { 1.0 / eta } else { eta }, up, quad);
        s
    }

    /// SINGLE's reflected plus transmitted albedo `E_ss` of an isotropic
    /// `ndf` at relative index `eta_rel` from `up` (`z > 0`), by
    /// `single_albedo`'s `quad x quad` quadrature.
    fn ess(ndf: Ndf, eta_rel: f32, up: Vec3, quad: usize) -> f64 {
        let single = Single::new(
            ndf,
            Facet::Dielectric { eta: eta_rel },
            G2Form::HeightCorrelated,
        );
        let alpha = ndf.alpha_x;
        single_albedo(
            |x, y| single.eval(x, y, &mut Rng::new(0, 0)).x,
            alpha,
            alpha,
            up,
            Some(eta_rel),
            quad,
        )
    }

    /// The raw sums as little-endian f64, job after job.
    fn save_dump(path: &str, sums: &[Sums]) {
        let mut v: Vec<f64> = Vec::new();
        for s in sums {
            v.push(s.walks as f64);
            v.extend(s.r.iter().flatten());
            v.extend(s.t.iter().flatten());
            v.extend(s.peak.iter().flatten());
            v.extend(s.gram_kb.iter().flatten());
            v.extend(&s.gram_bb);
            v.extend(s.ms);
            v.push(s.ess);
        }
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(path, bytes).expect("write dump");
    }

    /// Reads [`save_dump`]'s file.
    fn load_dump(path: &str, jobs: usize) -> Vec<Sums> {
        let raw = std::fs::read(path).expect("read dump");
        let mut it = raw
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]));
        let mut next = || it.next().unwrap_or(0.0);
        (0..jobs)
            .map(|_| {
                let walks = next() as u64;
                let r = std::array::from_fn(|_| std::array::from_fn(|_| next()));
                let t = std::array::from_fn(|_| std::array::from_fn(|_| next()));
                let peak = std::array::from_fn(|_| [next()]);
                let gram_kb = (0..MU_N).map(|_| std::array::from_fn(|_| next())).collect();
                let gram_bb = (0..MU_N).map(|_| next()).collect();
                let ms = [next(), next()];
                let ess = next();
                Sums {
                    walks,
                    r,
                    t,
                    peak,
                    gram_kb,
                    gram_bb,
                    ms,
                    ess,
                }
            })
            .collect()
    }

    /// `--dielectric-ir MODEL NDF OP CALLS` (MODEL `single` or `tabulated`,
    /// NDF `ggx` or `beckmann`, OP `eval`, `sample`, `pdf` or `init`): CALLS
    /// calls through `Material` on glass 1.5 at alpha 0.5 with 1024 fixed
    /// pairs (`wi` on both sides up to 80 degrees, `wo` anywhere), for
    /// callgrind: `(Ir(CALLS) - Ir(0)) / CALLS` is the cost per call
    /// (`init`: `Material::new` with the roughness changing on every call).
    pub fn ir(args: &[String]) {
        use msbsdf::{Material, MaterialDesc, Model, NdfId};
        let p = args
            .iter()
            .position(|a| a == "--dielectric-ir")
            .unwrap_or(0);
        let get = |i: usize| args.get(p + i).map(String::as_str).unwrap_or("");
        let model = if get(1) == "tabulated" {
            Model::Tabulated
        } else {
            Model::Single
        };
        let ndf = if get(2) == "beckmann" {
            NdfId::Beckmann
        } else {
            NdfId::Ggx
        };
        let op = get(3);
        let calls: usize = get(4).parse().unwrap_or(0);
        let d = MaterialDesc {
            model,
            ndf,
            facet: msbsdf::FacetKind::Dielectric,
            alpha_x: 0.5,
            alpha_y: 0.5,
            eta: Vec3::splat(1.5),
            ..Default::default()
        };
        let m = Material::new(&d).expect("material");
        let mut r = Rng::new(3, 9);
        let mut dir = |max_z: f32, both: bool| {
            let z = (1.0 - r.next_f32() * (1.0 - max_z)).max(1e-3);
            let ph = r.next_f32() * std::f32::consts::TAU;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let z = if both && r.next_f32() < 0.5 { -z } else { z };
            Vec3::new(s * ph.cos(), s * ph.sin(), z)
        };
        let pairs: Vec<(Vec3, Vec3)> = (0..1024)
            .map(|_| (dir(0.17, true), dir(0.0, true)))
            .collect();
        let mut rng = Rng::new(5, 5);
        let mut acc = Vec3::ZERO;
        for j in 0..calls {
            let (a, b) = pairs[j & 1023];
            match op {
                "sample" => acc += m.sample(a, &mut rng).weight,
                "pdf" => acc.x += m.pdf(a, b),
                "init" => {
                    let alpha = 0.2 + (j & 63) as f32 * 0.01;
                    let dd = MaterialDesc {
                        alpha_x: alpha,
                        alpha_y: alpha,
                        ..d
                    };
                    std::hint::black_box(Material::new(&dd).ok());
                }
                _ => acc += m.eval(a, b, &mut rng),
            }
        }
        std::hint::black_box(acc);
    }

    /// How [`lobe_rows`] integrates over `wo`: `broad > 0` the tests'
    /// nodes (`broad_reflection_nodes` `broad x broad` and
    /// `lower_hemisphere_nodes` `broad / 3 x 2 broad / 3`, twice as fine per
    /// axis above roughness 1), otherwise `ng x ng` visible normals and
    /// cosine directions for reflection and an `ng x 2 ng` grid for
    /// transmission (`--dielectric-scale`'s doc).
    #[derive(Clone, Copy)]
    struct Quadrature {
        ng: usize,
        broad: usize,
    }

    /// A cosine's interpolation weights on a grid's nodes: up to three
    /// (node, weight) pairs (unused ones of weight 0).
    type Basis = [(usize, f64); 3];

    /// Linear interpolation at node coordinate `x` on a grid of `fm` nodes.
    fn linear_basis(x: f32, fm: usize) -> Basis {
        let x = x as f64;
        let y0 = (x as usize).min(fm - 2);
        let fr = x - y0 as f64;
        [(y0, 1.0 - fr), (y0 + 1, fr), (0, 0.0)]
    }

    /// `M(x, y)`: the albedo of `tab`'s unscaled multiply scattered lobe
    /// (`multiple_unscaled`, exactly as eval reads it) from source node `x =
    /// (side, i)` (side 0 the outside, `z > 0`; cosine `mu(i)`) split onto
    /// the hat functions of the grid of `fm` cosines per side (the node
    /// weights of a cosine `basis(mu)`) at `wo`'s side
    /// and cosine, `y = (side, j)`; `2 fm x 2 fm`.
    fn lobe_rows(
        tab: &msbsdf::multiple::tabulated_dielectric::TabulatedDielectric,
        alpha: f32,
        q: Quadrature,
        fm: usize,
        mu: impl Fn(usize) -> f32,
        basis: impl Fn(f32) -> Basis,
    ) -> Vec<Vec<f64>> {
        let mus: Vec<f32> = (0..fm).map(mu).collect();
        lobe_rows_at(tab, alpha, q, fm, &mus, basis)
    }

    /// [`lobe_rows`] from the source cosines `mus` on each side (rows `(side,
    /// k)` at `side * mus.len() + k`), split onto a grid of `fm` cosines
    /// per side: `2 mus.len() x 2 fm`.
    fn lobe_rows_at(
        tab: &msbsdf::multiple::tabulated_dielectric::TabulatedDielectric,
        alpha: f32,
        q: Quadrature,
        fm: usize,
        mus: &[f32],
        basis: impl Fn(f32) -> Basis,
    ) -> Vec<Vec<f64>> {
        let Quadrature { ng, broad } = q;
        let nr = mus.len();
        // Reflection proposal: GGX visible normals (see `scale_main`).
        let proposal = Ndf::new(msbsdf::ndf::NdfKind::Ggx, alpha, alpha);
        let single1 = Single::new(proposal, CONDUCTOR_F1, G2Form::HeightCorrelated);
        let mut m = vec![vec![0.0f64; 2 * fm]; 2 * nr];
        let add = |row: &mut Vec<f64>, side: usize, mu: f32, v: f64| {
            for (y, w) in basis(mu.clamp(0.0, 1.0)) {
                row[side * fm + y] += v * w;
            }
        };
        for sd in 0..2 {
            let flip = |v: Vec3| {
                if sd == 1 {
                    Vec3::new(v.x, v.y, -v.z)
                } else {
                    v
                }
            };
            for (i, &mu) in mus.iter().enumerate() {
                let up = dir(mu);
                let wi = flip(up);
                let row = &mut m[sd * nr + i];
                // The transmission grid's size.
                let (tz, tp) = if broad > 0 {
                    // The tests' quadrature (`compensation::glass_albedo`:
                    // twice as fine above roughness 1).
                    let nb = if alpha > 1.0 { 2 * broad } else { broad };
                    let (nz, np) = (nb / 3, 2 * nb / 3);
                    broad_reflection_nodes(alpha, alpha, up, nb, (nz, np), |wo, w| {
                        let g = tab.multiple_unscaled(wi, flip(wo)) as f64;
                        add(row, sd, wo.z, g * w);
                    });
                    (nz, np)
                } else {
                    // Reflection: visible normals (F = 1) and cosine lobe.
                    for strategy in 0..2 {
                        for p in 0..ng {
                            for q in 0..ng {
                                let u1 = (p as f32 + 0.5) / ng as f32;
                                let u2 = (q as f32 + 0.5) / ng as f32;
                                let wo = if strategy == 0 {
                                    let h = proposal.sample_visible(up, u1, u2);
                                    msbsdf::frame::reflect(up, h)
                                } else {
                                    let r = u1.sqrt();
                                    let ph = 2.0 * std::f32::consts::PI * u2;
                                    Vec3::new(
                                        r * ph.cos(),
                                        r * ph.sin(),
                                        (1.0 - u1).max(0.0).sqrt(),
                                    )
                                };
                                if wo.z <= 0.0 {
                                    continue;
                                }
                                let pv = single1.pdf(up, wo) as f64;
                                let pc = wo.z as f64 / PI;
                                let g = tab.multiple_unscaled(wi, flip(wo)) as f64;
                                if pv + pc > 0.0 {
                                    add(row, sd, wo.z, g / ((ng * ng) as f64 * (pv + pc)));
                                }
                            }
                        }
                    }
                    (ng, 2 * ng)
                };
                // Transmission: grid over the other hemisphere.
                lower_hemisphere_nodes(tz, tp, |wo, w| {
                    let g = tab.multiple_unscaled(wi, flip(wo)) as f64;
                    add(row, 1 - sd, -wo.z, g * w);
                });
            }
        }
        m
    }

    /// `--dielectric-v5 PATH`: rewrites a version-4 table (no
    /// normalisation block) as version 5 into `--out`: the same lobe and
    /// albedo bytes, every normalisation factor 1 (the walk's lobes), its
    /// header kept with a line saying how it was converted. Build the
    /// library with it before `--dielectric-normalize`.
    pub fn v5_main(args: &[String], rest: &[String]) {
        // Version 4's payload (24-bit lobe values, then f32 albedos) is a
        // whole number of 4-byte words: `repack` copies it bit for bit as
        // the "rest" after an empty block and appends the factors.
        const V4_PAYLOAD: usize = FILE_BYTES - HEADER_BYTES - 4 * NORM_LEN;
        const _: () = assert!(V4_PAYLOAD.is_multiple_of(4));
        super::repack(
            args,
            rest,
            &super::Repack {
                flag: "--dielectric-v5",
                out: "data/tabulated_dielectric.bin",
                old_magic: b"MSBSDF-TABULATED-DIELECTRIC-v4\n",
                magic: MAGIC,
                file_bytes: FILE_BYTES,
                block_len: 0,
                rest_len: V4_PAYLOAD / 4,
                layout: UNNORMALISED,
                ones: NORM_LEN,
            },
            |_| Vec::new(),
        );
    }

    /// `--dielectric-normalize`: rewrites the compiled lobe table (which
    /// must hold the walk's lobes: every normalisation factor 1, as
    /// `--dielectric` and `--dielectric-v5` write it) with each node's
    /// lobes normalised, into `--out`. Per node (NDF, roughness node >= 1,
    /// index node), [`lobe_rows`] integrates the library's unscaled lobe at
    /// the node's own material (`--broad N`, 400 by default, or `--ng N`)
    /// from every cosine node of both sides (`mu` at least 1e-5) onto the
    /// lobe grid's hat functions: `M(x, y)`, row sums `A(x)`. The target
    /// albedo is `max(A, floor)^power` (`--floor` 1e-3, `--power` 0.3):
    /// from `u = sqrt(target / A)`, `--iterations` (4) Jacobi steps of the
    /// symmetric scaling `u_x <- u_x sqrt(target_x / sum_y u_x M(x, y)
    /// u_y)` on the rows with `A >= floor`. The stored cells `(i, j)` are
    /// multiplied by `u(side_i, i) u(side_j, j)` and `u` is written to the
    /// normalisation block. Why: the furnace scale table makes the albedo
    /// `1 - E_ss` at its nodes and is linear between them; with the walk's
    /// lobes the lobe interpolated between two roughness nodes had an
    /// albedo dominated by the larger one (glass 1.05 from inside at 89
    /// degrees: ten times), so the scale it needed dipped and rose within
    /// one interval (`--dielectric-scale --only N,A,E --alpha X --between`
    /// measures it). The power trades that against the opposite error: with
    /// the albedo 1 at every node (power 0) the scales carry all of `1 -
    /// E_ss`'s variation in roughness, and their linear interpolation
    /// overshoots where it is convex (module docs of `tabulated_dielectric`,
    /// `docs/tabulated_dielectric.md`). The albedos block (the sampler's)
    /// is kept: the walk's.
    pub fn normalize_main(args: &[String]) {
        use msbsdf::multiple::tabulated::grid_mu;
        use msbsdf::multiple::tabulated_dielectric::{
            TabulatedDielectric, albedo_value, header, lobe_norm, lobe_value,
        };
        let threads: usize = arg(args, "--threads", 2);
        let ng: usize = arg(args, "--ng", 48);
        let broad: usize = arg(args, "--broad", 400);
        let floor: f64 = arg(args, "--floor", 1e-3);
        let iters: usize = arg(args, "--iterations", 4);
        let power: f64 = arg(args, "--power", 0.3);
        let out: String = arg(args, "--out", "data/tabulated_dielectric.bin".to_string());
        let t0 = std::time::Instant::now();
        let jobs: Vec<(usize, usize, usize)> = (0..NDF_N)
            .flat_map(|n| (1..ALPHA_N).flat_map(move |a| (0..ETA_N).map(move |e| (n, a, e))))
            .collect();
        // The albedos are the walk's lobes' only when the compiled table
        // is not normalised yet (`--dielectric-v5` writes one).
        let normalised = jobs
            .iter()
            .any(|&(n, a, e)| (0..2).any(|sd| (0..MU_N).any(|i| lobe_norm(n, a, e, sd, i) != 1.0)));
        if normalised {
            eprintln!(
                "--dielectric-normalize: the compiled table is normalised already; build with \
                 the walk's table (--dielectric-v5 on version 4) first"
            );
            std::process::exit(2);
        }
        let n2 = 2 * MU_N;
        let res = parallel(&jobs, "dielectric normalize", threads, |_, &(n, a, e)| {
            let (alpha, eta) = (grid_alpha(a), grid_eta(e));
            let ndf = Ndf::new(NDFS[n], alpha, alpha);
            let tab = TabulatedDielectric::new(ndf, Facet::Dielectric { eta });
            let q = Quadrature { ng, broad };
            let m = lobe_rows(
                &tab,
                alpha,
                q,
                MU_N,
                |i| grid_mu(i).max(1e-5),
                |mu| linear_basis(mu.sqrt() * (MU_N - 1) as f32, MU_N),
            );
            // Target `max(A, floor)^power`, `A` the lobe's albedo from the
            // node; a few Jacobi steps of the symmetric scaling from
            // `u = sqrt(target / A)`, not a solve to convergence: where a
            // side's reflection is weak the converged scaling has a free
            // gauge (one side times c, the other over c; GGX 2 glass 1.05
            // to the albedo 1: 620 and 0.017 at normal incidence), which
            // turns the thin side's transmission into reflection.
            let albedo: Vec<f64> = (0..n2).map(|x| m[x].iter().sum::<f64>()).collect();
            let target: Vec<f64> = albedo.iter().map(|a| a.max(floor).powf(power)).collect();
            let mut u: Vec<f64> = (0..n2)
                .map(|x| (target[x] / albedo[x].max(floor)).sqrt())
                .collect();
            for _ in 0..iters {
                let now: Vec<f64> = (0..n2)
                    .map(|x| (0..n2).map(|y| u[x] * m[x][y] * u[y]).sum::<f64>())
                    .collect();
                for x in 0..n2 {
                    if albedo[x] >= floor && now[x] > 0.0 {
                        u[x] *= (target[x] / now[x]).sqrt();
                    }
                }
            }
            let after_of = |x: usize| (0..n2).map(|y| u[x] * m[x][y] * u[y]).sum::<f64>();
            let after = (0..n2)
                .filter(|&x| albedo[x] >= floor)
                .map(|x| (after_of(x) / target[x] - 1.0).abs())
                .fold(0.0f64, f64::max);
            (u, after)
        });
        let mut lobe: Vec<f32> = (0..LOBE_LEN).map(lobe_value).collect();
        let mut norm = vec![1.0f32; NORM_LEN];
        let mut after = 0.0f64;
        let (mut umin, mut umax) = (f64::INFINITY, 0.0f64);
        for (&(n, a, e), (u, af)) in jobs.iter().zip(&res) {
            after = after.max(*af);
            for &v in u {
                (umin, umax) = (umin.min(v), umax.max(v));
            }
            // Lobe, side of mu_i, side of mu_o, cell width.
            for (l, si, so, width) in [
                (R_THIN, 0, 0, R_CELL),
                (R_DENSE, 1, 1, R_CELL),
                (T_THIN, 0, 1, K),
            ] {
                for i in 0..MU_N {
                    // A reflection lobe stores i <= j only.
                    let j0 = if l == T_THIN { 0 } else { i };
                    for j in j0..MU_N {
                        let f = (u[si * MU_N + i] * u[so * MU_N + j]) as f32;
                        let at = lobe_index(n, a, e, l, i, j);
                        for v in &mut lobe[at..at + width] {
                            *v *= f;
                        }
                    }
                }
            }
            for sd in 0..2 {
                for i in 0..MU_N {
                    norm[(node(n, a, e) * 2 + sd) * MU_N + i] = u[sd * MU_N + i] as f32;
                }
            }
        }
        let old = header();
        let kept: String = old
            .lines()
            .skip(1)
            .filter(|l| !l.starts_with("normalisation:"))
            .map(|l| format!("{l}\n"))
            .collect();
        let head = format!(
            "{}{kept}\
             normalisation: cargo run --release --example gen_tabulated -- {} (commit {}): per node the lobes times u(mu_i) u(mu_o) towards the albedo max(A, {floor})^{power} from every cosine node of both sides, A the walk's lobe's ({iters} symmetric Jacobi steps from u = sqrt(target / A); factors {umin:.4e} .. {umax:.4e}); albedo after vs the target: worst relative deviation {after:.3e} (A >= {floor}); quadrature {}; {:.0} s on {threads} threads\n",
            String::from_utf8_lossy(MAGIC),
            args[1..].join(" "),
            git::commit(),
            if broad > 0 {
                format!("--broad {broad}")
            } else {
                format!("--ng {ng}")
            },
            t0.elapsed().as_secs_f64(),
        );
        let mut payload = lobe_bytes(&lobe);
        payload.extend(super::f32_bytes((0..ALBEDO_LEN).map(albedo_value)));
        payload.extend(super::f32_bytes(norm));
        super::write_bytes(&out, &head, MAGIC, HEADER_BYTES, FILE_BYTES, &payload);
    }

    /// `--dielectric-scale`: the furnace scale table
    /// `data/tabulated_dielectric_scale.bin` from the committed lobe table
    /// (compiled into the library). Per NDF, scale-grid roughness and index
    /// and source node `x = (side, mu)`, the library's unscaled multiply
    /// scattered eval (`TabulatedDielectric::multiple_unscaled`: the clamped,
    /// interpolated table exactly as eval reads it) is integrated over `wo`
    /// and split onto the scale grid's hat functions of `wo`'s side and
    /// cosine: `M(x, y)`. Reflection: two stratified 48 x 48 point sets, the
    /// visible normals of SINGLE with F = 1 (they follow the peaked part;
    /// GGX's of the same roughness for both NDFs: Beckmann's own sampler,
    /// stratified, converges slowly from grazing angles on rough surfaces,
    /// 3% high at 48 x 48 and 0.1% at 192 x 192 for alpha 2 from inside at
    /// 80 degrees, where GGX's is within 0.1% at 48 x 48) and a cosine lobe,
    /// combined by the balance heuristic; transmission: a
    /// 48 x 96 grid in `(sqrt(1 - |z|), phi)`. The scales solve
    /// `s_x sum_y M(x, y) s_y = 1 - E_ss(x)` (Sinkhorn), and eval multiplies
    /// the lobe by `s(wi) s(wo)` interpolated linearly in `sqrt(mu)`, so the
    /// scaled albedo is the target at every node; a product keeps both
    /// reciprocity rules. The scales are written as 16-bit steps
    /// ([`scale_steps`]). The committed table (since session 23) uses
    /// `--broad 400` below, and since session 28 its nodes are fitted
    /// (`--dielectric-scale-fit`, [`scale_fit_main`]) to a table this
    /// command wrote.
    ///
    /// Options: `--ng N` the reflection sets' and transmission grid's size
    /// (48); `--broad N` instead integrates both over the tests' nodes
    /// (`compensation::glass_albedo`: [`broad_reflection_nodes`] `N x N`
    /// and [`lower_hemisphere_nodes`] `N / 3 x 2 N / 3`, `2 N` for `N`
    /// above roughness 1; `--broad 400` is the tests' quadrature); `--only N,A,E`
    /// solves one node (NDF, roughness and index node) and prints its rows
    /// instead of writing the table, with `--alpha A` at roughness `A`
    /// instead of the node's (what the scales between two nodes would
    /// have to be) and `--eta X` at relative index `X` (at least 1)
    /// instead of the node's; `--between` with them also solves the three
    /// scale nodes of the scale triangle holding `(A, X)` (`X` the index
    /// node's when `--eta` is not given) and prints the furnace there with
    /// their scales interpolated on the triangle, as eval reads them (at the
    /// scale grid's cosines, the scales' 16-bit rounding left out);
    /// `--pair A0,A1` replaces that triangle by two nodes of roughness
    /// `A0` and `A1` at the index `X` (interpolated linearly in
    /// `sqrt(alpha)`), `--corners A:E:W,...` by up to three nodes of any
    /// roughness `A` and index `E` with weights `W` (what another grid
    /// would give, before building it). `--only`'s roughness node is one
    /// of the main block's grid.
    /// `--keep V11.bin` copies the nodes of a version-11 table that did not
    /// move in version 12 and solves the others (the low-index block's
    /// index nodes 1 and 2 and its roughness nodes at `SCALE_LOW_KNOTS`:
    /// version 12's exact nodes from version 11's, and the base of its fit
    /// from the committed version 11): the generator is deterministic, so
    /// with the same lobe table a full run computes the same values for
    /// the kept nodes. (Until version 12 `--keep` read a version-10 table
    /// and solved the low-index block's `SCALE_LOW_HALF_NODE`, commit
    /// 3eccb26; until version 11 a version-9 table, commit 9434f94; until
    /// version 10 a version-5 table, commit 745213e.)
    pub fn scale_main(args: &[String]) {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_ALPHA_N, SCALE_ETA_N, SCALE_ETA_PLAIN_N, SCALE_ETA_SPLIT, SCALE_FINE_INTERVALS,
            SCALE_FINE_SPLIT, SCALE_HALF_INTERVAL, SCALE_LOW_ALPHA_N, SCALE_LOW_ETA_N,
            SCALE_LOW_KNOTS, SCALE_MAX, SCALE_MU_ELEMS, SCALE_MU_N, SCALE_PAD, SCALE_ROOT_N,
            header, scale_grid_alpha, scale_grid_eta, scale_grid_mu, scale_index,
            scale_low_grid_alpha,
        };
        // Roughness of node `a` of the low-index block (`low`) or the main
        // block.
        let grid_alpha_of = |low: bool, a: usize| {
            if low {
                scale_low_grid_alpha(a)
            } else {
                scale_grid_alpha(a)
            }
        };
        let scale_max = SCALE_MAX as f64;
        let quad: usize = arg(args, "--quad", 128);
        let threads: usize = arg(args, "--threads", 2);
        let out: String = arg(
            args,
            "--out",
            "data/tabulated_dielectric_scale.bin".to_string(),
        );
        let t0 = std::time::Instant::now();
        let fm = SCALE_MU_N;
        let ng: usize = arg(args, "--ng", 48);
        let broad: usize = arg(args, "--broad", 0);
        // `--only N,A,E`: one node's solve, its rows printed, nothing written.
        let only: Option<Vec<usize>> = args
            .iter()
            .position(|a| a == "--only")
            .and_then(|p| args.get(p + 1))
            .map(|v| v.split(',').filter_map(|t| t.parse().ok()).collect());
        let at_alpha: Option<f32> = only
            .as_ref()
            .and_then(|_| args.iter().position(|a| a == "--alpha"))
            .and_then(|p| args.get(p + 1))
            .and_then(|v| v.parse().ok());
        let at_eta: Option<f32> = only
            .as_ref()
            .and_then(|_| args.iter().position(|a| a == "--eta"))
            .and_then(|p| args.get(p + 1))
            .and_then(|v| v.parse().ok())
            .map(|e: f32| e.max(1.0 / e));
        // `--between` (with `--only N,A,E --alpha X [--eta Y]`): also the
        // three scale nodes of the triangle holding (X, Y), and the furnace
        // with their scales interpolated as eval does.
        let between = only.is_some() && args.iter().any(|a| a == "--between");
        // (NDF, low-index block, roughness node, index node, roughness,
        // index); `--only N,A,E` is node A of the main block's roughness
        // grid (any index node).
        let mut jobs: Vec<(usize, bool, usize, usize, f32, f32)> = match &only {
            Some(v) if v.len() == 3 => vec![(
                v[0],
                false,
                v[1],
                v[2],
                at_alpha.unwrap_or(scale_grid_alpha(v[1])),
                at_eta.unwrap_or(scale_grid_eta(v[2])),
            )],
            _ => (0..NDF_N)
                .flat_map(|n| {
                    let low = (1..SCALE_LOW_ALPHA_N).flat_map(move |a| {
                        (0..SCALE_LOW_ETA_N).map(move |e| {
                            (n, true, a, e, scale_low_grid_alpha(a), scale_grid_eta(e))
                        })
                    });
                    let main = (1..SCALE_ALPHA_N).flat_map(move |a| {
                        (SCALE_LOW_ETA_N - 1..SCALE_ETA_N)
                            .map(move |e| (n, false, a, e, scale_grid_alpha(a), scale_grid_eta(e)))
                    });
                    low.chain(main)
                })
                .collect(),
        };
        // The corners' weights (jobs 1 to 3) for `--between`.
        let mut weights = [0.0f64; 3];
        // `--pair A0,A1` (with `--between`): instead of the scale table's
        // triangle, two nodes at roughness A0 and A1 and the index of
        // `--eta`, interpolated linearly in `sqrt(alpha)` (what a finer
        // roughness grid would give).
        let pair: Option<Vec<f32>> = args
            .iter()
            .position(|a| a == "--pair")
            .and_then(|p| args.get(p + 1))
            .map(|v| v.split(',').filter_map(|t| t.parse().ok()).collect());
        // `--corners A:E:W,...` (with `--between`): any nodes and weights.
        let corners_arg: Option<Vec<(f32, f32, f64)>> = triples_arg(args, "--corners");
        if let (true, Some(cs)) = (between, corners_arg.as_ref()) {
            let n = jobs[0].0;
            for (k, &(a, e, w)) in cs.iter().enumerate().take(3) {
                weights[k] = w;
                jobs.push((n, false, 0, 0, a, e));
            }
        } else if let (true, Some(p)) = (between, pair.as_ref().filter(|p| p.len() == 2)) {
            let (n, _, _, _, alpha, eta) = jobs[0];
            let t = (alpha.sqrt() - p[0].sqrt()) / (p[1].sqrt() - p[0].sqrt());
            weights = [1.0 - t as f64, t as f64, 0.0];
            jobs.push((n, false, 0, 0, p[0], eta));
            jobs.push((n, false, 0, 0, p[1], eta));
        } else if between {
            let (n, _, _, _, alpha, eta) = jobs[0];
            let (low, corners) = msbsdf::multiple::tabulated_dielectric::scale_corners(alpha, eta);
            for (k, ((a, e), w)) in corners.into_iter().enumerate() {
                weights[k] = w as f64;
                jobs.push((n, low, a, e, grid_alpha_of(low, a), scale_grid_eta(e)));
            }
        }
        // `--keep V11.bin`: the nodes of a version-11 table that did not
        // move (`moved_node`) are copied from it (the generator is
        // deterministic: a full run with the same lobe table computes the
        // same values), only the moved ones are solved.
        let keep = table_arg(args, "--keep", PREV_SCALE_MAGIC, PREV_SCALE_FILE_BYTES);
        if keep.is_some() && only.is_none() {
            jobs.retain(|&(_, low, a, e, _, _)| moved_node(low, a, e));
        }
        let res = parallel(
            &jobs,
            "dielectric scale",
            threads,
            |_, &(n, _, _, _, alpha, eta)| {
                let ScaleSolve {
                    sc,
                    before,
                    after,
                    m,
                    target,
                } = solve_scales(n, alpha, eta, Quadrature { ng, broad }, quad);
                if only.is_some() && !between {
                    for x in 0..2 * fm {
                        let r = furnace_row(&sc, &m, x);
                        let raw: f64 = m[x].iter().sum();
                        eprintln!(
                            "side {} mu {:.5}: target {:.5} unscaled {raw:.5} scale {:.4} scaled {r:.5}",
                            x / fm,
                            scale_grid_mu(x % fm),
                            target[x],
                            sc[x]
                        );
                    }
                }
                (sc, before, after, m, target)
            },
        );
        if between {
            let (_, _, _, m, target) = &res[0];
            let s: Vec<f64> = (0..2 * fm)
                .map(|x| {
                    (0..res.len() - 1)
                        .map(|k| weights[k] * res[k + 1].0[x])
                        .sum()
                })
                .collect();
            let mut worst = (0.0f64, 0);
            for x in 0..2 * fm {
                let r = furnace_row(&s, m, x);
                let exact = res[0].0[x];
                eprintln!(
                    "side {} mu {:.5}: target {:.5} scale exact {exact:.4} interpolated {:.4} furnace {:+.4}%",
                    x / fm,
                    scale_grid_mu(x % fm),
                    target[x],
                    s[x],
                    100.0 * (r - target[x])
                );
                if (r - target[x]).abs() > worst.0 {
                    worst = ((r - target[x]).abs(), x);
                }
            }
            let corner = |k: usize| match jobs.get(k + 1) {
                Some(j) if pair.is_none() && corners_arg.is_none() => {
                    format!(
                        "({}{}, {}) {:.3}",
                        if j.1 { "low " } else { "" },
                        j.2,
                        j.3,
                        weights[k]
                    )
                }
                Some(j) => format!("(alpha {} eta {}) {:.3}", j.4, j.5, weights[k]),
                None => "-".to_string(),
            };
            eprintln!(
                "roughness {} index {}, scale nodes (roughness, index) weight {}, {}, {}: worst furnace {:.4}% at side {} mu {:.5}",
                jobs[0].4,
                jobs[0].5,
                corner(0),
                corner(1),
                corner(2),
                100.0 * worst.0,
                worst.1 / fm,
                scale_grid_mu(worst.1 % fm)
            );
            return;
        }
        if only.is_some() {
            return;
        }
        // Roughness node 0 (no multiple scattering) keeps 1.
        let mut scale = vec![scale_steps(1.0); SCALE_LEN];
        if let Some((raw, _)) = &keep {
            for (i, v) in scale.iter_mut().enumerate() {
                if let Some(j) = prev_index(i) {
                    *v = table_step(raw, j);
                }
            }
        }
        let (mut before, mut after) = (0.0f64, 0.0f64);
        let (mut smin, mut smax) = (f64::INFINITY, 0.0f64);
        // Nodes of target 0 (scale 0).
        let mut zeros = 0usize;
        for (&(n, low, a, e, _, _), (sc, b, af, _, _)) in jobs.iter().zip(&res) {
            before = before.max(*b);
            after = after.max(*af);
            zeros += sc.iter().filter(|&&v| v == 0.0).count();
            for sd in 0..2 {
                for i in 0..fm {
                    let v = sc[sd * fm + i];
                    smin = smin.min(v);
                    smax = smax.max(v);
                    scale[scale_index(n, low, a, e, sd, i)] = scale_steps(v);
                }
            }
        }
        let table_commit = header()
            .lines()
            .find(|l| l.starts_with("commit:"))
            .unwrap_or("commit: ?")
            .to_string();
        let quadrature = if broad > 0 {
            format!(
                "reflection compensation::broad_reflection_nodes {broad} x {broad} normals and a {} x {} grid, transmission compensation::lower_hemisphere_nodes {} x {}; twice as many per axis above roughness 1 (the tests' compensation::glass_albedo with --broad 400)",
                broad / 3,
                2 * broad / 3,
                broad / 3,
                2 * broad / 3
            )
        } else {
            format!(
                "reflection 2 x {ng} x {ng} (GGX visible normals of the same roughness with F = 1, for both NDFs, and cosine; balance heuristic), transmission {ng} x {}",
                2 * ng
            )
        };
        let kept = match &keep {
            Some((raw, path)) => {
                let line = |key: &str| header_line(raw, key);
                format!(
                    "kept: the nodes of version 11's grid copied from {path} (version 11; its {}; {}); the low-index block's index nodes 1 and 2 and its roughness nodes at SCALE_LOW_KNOTS {SCALE_LOW_KNOTS:?} of their plain interval (version 11: 1/3 and 2/3) solved here\n",
                    line("command:"),
                    line("commit:")
                )
            }
            None => String::new(),
        };
        let head = format!(
            "{}\
             MSBSDF_MODEL_TABULATED dielectric furnace scales (layout: src/multiple/tabulated_dielectric.rs)\n\
             command: cargo run --release --example gen_tabulated -- {}\n\
             commit: {}\n\
             lobe table: data/tabulated_dielectric.bin, {table_commit}\n\
             quadrature: {quadrature}; deterministic, no seeds\n\
             E_ss: SINGLE reflection + transmission quadrature {quad} x {quad} (compensation::single_albedo)\n\
             albedo of the unscaled lobe vs 1 - E_ss: worst relative deviation {before:.3e} (targets > 1e-3); after scaling: {after:.3e} (targets > 1e-4, rows not empty; scales within [0, {scale_max}] during the solve, 0 where the target is 0: {zeros} nodes)\n\
             scales between {smin:.4} and {smax:.4}\n\
             grid: index nodes {SCALE_ETA_N} (uniform in ln E with {SCALE_ETA_PLAIN_N} nodes, its first two intervals split in {SCALE_ETA_SPLIT:?}, the first at the fractions {SCALE_LOW_KNOTS:?}); low-index block ndf {NDF_N} x alpha {SCALE_LOW_ALPHA_N} (uniform in sqrt(alpha / 2) with {SCALE_ROOT_N} nodes, its first {SCALE_FINE_INTERVALS} intervals split in {SCALE_FINE_SPLIT}, then per lobe interval its first two split as the index's (the first at the same fractions), and interval {SCALE_HALF_INTERVAL} in 2) x eta {SCALE_LOW_ETA_N} (the first) x side 2 x mu {SCALE_MU_N}, then the main block ndf {NDF_N} x alpha {SCALE_ALPHA_N} (the same sqrt(alpha) grid, its first {SCALE_FINE_INTERVALS} intervals split in {SCALE_FINE_SPLIT} and interval {SCALE_HALF_INTERVAL} in 2) x eta {} (from node {}) x side 2 x mu {SCALE_MU_N} (the ends and midpoints of {SCALE_MU_ELEMS} elements on the lobe table's cosine nodes, the scale quadratic in sqrt(mu) on each: tabulated_dielectric::scale_mu_basis), then {SCALE_PAD} zero steps\n\
             {kept}\
             wall time: {:.0} s on {threads} threads\n\
             {SCALE_STORAGE}\n",
            String::from_utf8_lossy(SCALE_MAGIC),
            args[1..].join(" "),
            git::commit(),
            SCALE_ETA_N + 1 - SCALE_LOW_ETA_N,
            SCALE_LOW_ETA_N - 1,
            t0.elapsed().as_secs_f64(),
        );
        write_scale_table(&out, &head, &scale);
    }

    /// Writes a scale table file: the header `head`, the 16-bit steps and
    /// the zero padding.
    fn write_scale_table(out: &str, head: &str, scale: &[u16]) {
        use msbsdf::multiple::tabulated_dielectric::SCALE_PAD;
        let payload: Vec<u8> = scale
            .iter()
            .chain(&[0; SCALE_PAD])
            .flat_map(|q| q.to_le_bytes())
            .collect();
        super::write_bytes(
            out,
            head,
            SCALE_MAGIC,
            HEADER_BYTES,
            SCALE_FILE_BYTES,
            &payload,
        );
    }

    /// A table file's text header without its first line (the magic),
    /// each line indented by two spaces: what a table derived from it
    /// quotes after its own header. The headers it quotes itself (its
    /// indented lines) are left out, so that a chain of derived tables
    /// keeps within [`HEADER_BYTES`]; the commit it names has them.
    fn nested_header(raw: &[u8]) -> String {
        let text = String::from_utf8_lossy(&raw[..HEADER_BYTES.min(raw.len())]);
        let own = text
            .trim_end_matches('\0')
            .lines()
            .skip(1)
            .filter(|l| !l.starts_with("  "))
            .map(|l| format!("  {l}\n"));
        let quoted = text.lines().any(|l| l.starts_with("  "));
        own.chain(quoted.then(|| "  (the headers it quotes: in the commit above)\n".to_string()))
            .collect()
    }

    /// The first line of a table file's text header that starts with
    /// `key` ("?" if none).
    fn header_line(raw: &[u8], key: &str) -> String {
        String::from_utf8_lossy(&raw[..HEADER_BYTES.min(raw.len())])
            .lines()
            .find(|l| l.starts_with(key))
            .unwrap_or("?")
            .to_string()
    }

    /// The bytes and path of the scale table file named by option `name`,
    /// if given; it must start with `magic` and be `len` bytes long.
    fn table_arg(
        args: &[String],
        name: &str,
        magic: &[u8],
        len: usize,
    ) -> Option<(Vec<u8>, String)> {
        let path = args.get(args.iter().position(|a| a == name)? + 1)?;
        let raw = std::fs::read(path).unwrap_or_else(|e| panic!("{name}: read {path}: {e}"));
        assert!(
            raw.starts_with(magic) && raw.len() == len,
            "{name}: {path} is not a scale table of the expected version and layout"
        );
        Some((raw, path.clone()))
    }

    /// Step `i` (a `scale_index`, or a version-10 table's [`prev_index`])
    /// of the scale table file `raw`.
    fn table_step(raw: &[u8], i: usize) -> u16 {
        let b = HEADER_BYTES + 2 * i;
        u16::from_le_bytes([raw[b], raw[b + 1]])
    }

    /// First bytes of the previous layout of the scale table (version 11:
    /// the first index interval's nodes, and the low-index block's
    /// roughness nodes that follow the crease through them, at 1/3 and 2/3
    /// instead of `SCALE_LOW_KNOTS`), which `--dielectric-scale --keep`
    /// reads. It has as many nodes as version 12.
    const PREV_SCALE_MAGIC: &[u8] = b"MSBSDF-TABULATED-DIELECTRIC-SCALE-v11\n";
    /// Size of a version-11 scale table file in bytes.
    const PREV_SCALE_FILE_BYTES: usize = {
        use msbsdf::multiple::tabulated_dielectric::SCALE_FILE_BYTES;
        SCALE_FILE_BYTES
    };

    /// Whether node `(a, e)` of a block (the low-index block's if `low`)
    /// lies where version 11 had no node: in the low-index block, the index
    /// nodes 1 and 2 (`SCALE_LOW_KNOTS`), and the roughness nodes at those
    /// fractions of their plain interval (version 11's inner nodes of the
    /// same intervals were at 1/3 and 2/3; the other intervals split in 3,
    /// below roughness 0.031, keep theirs).
    fn moved_node(low: bool, a: usize, e: usize) -> bool {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_LOW_ALPHA_N, SCALE_LOW_KNOTS, SCALE_ROOT_N, scale_low_grid_alpha,
        };
        if !low {
            return false;
        }
        // The grid's last node is the largest roughness.
        let top = scale_low_grid_alpha(SCALE_LOW_ALPHA_N - 1) as f64;
        let x = (scale_low_grid_alpha(a) as f64 / top).sqrt() * (SCALE_ROOT_N - 1) as f64;
        let f = x - x.floor();
        let at_knot = SCALE_LOW_KNOTS.iter().any(|&k| (f - k as f64).abs() < 1e-3);
        at_knot || e == 1 || e == 2
    }

    /// The index in a version-11 scale table of entry `i` of the current
    /// layout (`scale_index`), if it has one: the same entry where its node
    /// did not move ([`moved_node`]).
    fn prev_index(i: usize) -> Option<usize> {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_LOW_ALPHA_N, SCALE_LOW_ETA_N, SCALE_LOW_LEN, SCALE_MU_N,
        };
        if i >= SCALE_LOW_LEN {
            return Some(i);
        }
        let node = i / (2 * SCALE_MU_N);
        let e = node % SCALE_LOW_ETA_N;
        let a = (node / SCALE_LOW_ETA_N) % SCALE_LOW_ALPHA_N;
        (!moved_node(true, a, e)).then_some(i)
    }

    /// One point's furnace scales (`--dielectric-scale`'s solve): the
    /// scales `sc` over the `2 SCALE_MU_N` source nodes `(side, mu)`, the
    /// unscaled lobe's worst relative deviation from the target (`before`,
    /// targets over 1e-3) and the scaled one's (`after`), the lobe rows
    /// `m` ([`lobe_rows`]) and the targets `1 - E_ss`.
    struct ScaleSolve {
        sc: Vec<f64>,
        before: f64,
        after: f64,
        m: Vec<Vec<f64>>,
        target: Vec<f64>,
    }

    /// The furnace scales of NDF `n` at roughness `alpha` and relative index
    /// `eta` (at least 1) on the scale grid's cosines ([`ScaleSolve`]).
    fn solve_scales(n: usize, alpha: f32, eta: f32, q: Quadrature, quad: usize) -> ScaleSolve {
        use msbsdf::multiple::tabulated_dielectric::{SCALE_MU_N, scale_grid_mu};
        solve_scales_on(
            n,
            alpha,
            eta,
            q,
            quad,
            SCALE_MU_N,
            &scale_grid_mu,
            &lib_basis,
        )
    }

    /// The library's interpolation weights of a cosine on the scale
    /// table's grid (`scale_mu_basis`: quadratic elements).
    fn lib_basis(mu: f32) -> Basis {
        let (i0, w) = msbsdf::multiple::tabulated_dielectric::scale_mu_basis(mu.sqrt());
        [(i0, w.x as f64), (i0 + 1, w.y as f64), (i0 + 2, w.z as f64)]
    }

    /// [`solve_scales`] on any cosine grid of `fm` nodes per side: node
    /// `i`'s cosine `grid_mu(i)`, a cosine's interpolation weights on the
    /// nodes `basis(mu)`.
    #[allow(clippy::too_many_arguments)]
    fn solve_scales_on(
        n: usize,
        alpha: f32,
        eta: f32,
        q: Quadrature,
        quad: usize,
        fm: usize,
        grid_mu: &dyn Fn(usize) -> f32,
        basis: &dyn Fn(f32) -> Basis,
    ) -> ScaleSolve {
        use msbsdf::multiple::tabulated_dielectric::{SCALE_MAX, TabulatedDielectric};
        let ndf = Ndf::new(NDFS[n], alpha, alpha);
        let tab = TabulatedDielectric::new(ndf, Facet::Dielectric { eta });
        let m = lobe_rows(&tab, alpha, q, fm, |i| grid_mu(i).max(1e-3), basis);
        let mut target = vec![0.0f64; 2 * fm];
        for sd in 0..2 {
            for i in 0..fm {
                let up = dir(grid_mu(i).max(1e-3));
                let eta_rel = if sd == 1 { 1.0 / eta } else { eta };
                target[sd * fm + i] = (1.0 - ess(ndf, eta_rel, up, quad)).max(0.0);
            }
        }
        let before = (0..2 * fm)
            .filter(|&x| target[x] > 1e-3)
            .map(|x| (m[x].iter().sum::<f64>() / target[x] - 1.0).abs())
            .fold(0.0f64, f64::max);
        // Scales are kept within [0, SCALE_MAX] (the encoding's range)
        // during the solve, and a node whose target is 0 (`E_ss` = 1:
        // low roughness near grazing) gets 0. Until session 22 the
        // solve's result was clamped to [0.25, 4] afterwards, which
        // left Beckmann alpha 0.005 glass 1.5 at 88 degrees (E_ss = 1)
        // a quarter of its unscaled lobe: albedo 1.036.
        let sc: Vec<f64> = sinkhorn_within(&target, |x, y| m[x][y], Some((0.0, SCALE_MAX as f64)));
        let after = (0..2 * fm)
            .filter(|&x| target[x] > 1e-4 && m[x].iter().sum::<f64>() > 0.0)
            .map(|x| (furnace_row(&sc, &m, x) / target[x] - 1.0).abs())
            .fold(0.0f64, f64::max);
        ScaleSolve {
            sc,
            before,
            after,
            m,
            target,
        }
    }

    /// `--mu-pilot --cases N:ALPHA:ETA,... [--grid G] [--split J:K,...]
    /// [--drop J,...] [--print-rows]`: how a cosine grid for the furnace
    /// scales does between its nodes, before a table is built on it. Per
    /// case (NDF `N`, 0 Beckmann, 1 GGX; roughness; relative index, seen
    /// from inside when below 1) the scales are solved exactly on the grid
    /// (as `--dielectric-scale` solves the table's nodes) and the furnace
    /// is read at the eighths of every lobe grid interval (in `sqrt(mu)`;
    /// the same points for every grid) from the normal to 89 degrees, the
    /// scales linear in the grid's coordinate between its nodes as eval
    /// reads them. Printed: the worst `|albedo - 1|` per lobe interval
    /// over the cases, and per case the worst and the RMS. Grids (node
    /// positions in `sqrt(mu)`): `lib` (default) the library's; `v7`
    /// version 7's (`p / 31`, `p` = 0 and 3 to 30, the last interval in
    /// thirds); `plain:N` the nodes `p / N`; `lobe` the lobe table's `j /
    /// 19`, interval `J` (lobe node `J` to `J + 1`) split in `K` parts by
    /// `--split`, the lobe nodes of `--drop` left out. `--quadratic`: the
    /// scales quadratic in `sqrt(mu)` on elements of three consecutive
    /// nodes (the grid needs an odd number), as the library's grid since
    /// version 9 (`lib` always reads the library's interpolation).
    pub fn mu_pilot_main(args: &[String]) {
        use msbsdf::multiple::tabulated_dielectric::{SCALE_MU_N, scale_grid_mu};
        let grid: String = arg(args, "--grid", "lib".to_string());
        let split: Vec<(usize, usize)> = args
            .iter()
            .position(|a| a == "--split")
            .and_then(|p| args.get(p + 1))
            .map(|v| {
                v.split(',')
                    .filter_map(|t| {
                        let (j, k) = t.split_once(':')?;
                        Some((j.parse().ok()?, k.parse().ok()?))
                    })
                    .collect()
            })
            .unwrap_or_default();
        let roots: Vec<f64> = match grid.as_str() {
            "lib" => (0..SCALE_MU_N)
                .map(|i| (scale_grid_mu(i) as f64).sqrt())
                .collect(),
            "v7" => std::iter::once(0.0)
                .chain((3..31).map(f64::from))
                .chain([30.0 + 1.0 / 3.0, 30.0 + 2.0 / 3.0, 31.0])
                .map(|p| p / 31.0)
                .collect(),
            "lobe" => {
                let n = (MU_N - 1) as f64;
                let mut r = vec![0.0];
                for j in 0..MU_N - 1 {
                    let k = split.iter().find(|s| s.0 == j).map_or(1, |s| s.1);
                    r.extend((1..=k).map(|q| (j as f64 + q as f64 / k as f64) / n));
                }
                // `--drop J,...`: lobe nodes left out.
                let drop: Vec<f64> = args
                    .iter()
                    .position(|a| a == "--drop")
                    .and_then(|p| args.get(p + 1))
                    .map(|v| {
                        v.split(',')
                            .filter_map(|t| t.parse::<f64>().ok())
                            .map(|j| j / n)
                            .collect()
                    })
                    .unwrap_or_default();
                r.retain(|x| !drop.iter().any(|d| (d - x).abs() < 1e-9));
                r
            }
            g => {
                let n: usize = g
                    .strip_prefix("plain:")
                    .and_then(|v| v.parse().ok())
                    .expect("--grid lib | v7 | plain:N | lobe");
                (0..=n).map(|p| p as f64 / n as f64).collect()
            }
        };
        let fm = roots.len();
        // `--quadratic`: the scales quadratic in `sqrt(mu)` on elements of
        // three consecutive nodes (0-2, 2-4, ...), continuous at their
        // ends; linear between nodes otherwise.
        let quadratic = args.iter().any(|a| a == "--quadratic");
        assert!(
            !quadratic || fm % 2 == 1,
            "--quadratic needs an odd number of nodes, the grid has {fm}"
        );
        let basis = |mu: f32| -> Basis {
            let r = (mu.max(0.0) as f64).sqrt();
            if grid == "lib" {
                lib_basis(mu.max(0.0))
            } else if quadratic {
                let k = (roots.partition_point(|&x| x <= r).clamp(1, fm - 1) - 1) / 2 * 2;
                let k = k.min(fm - 3);
                let (a, m, b) = (roots[k], roots[k + 1], roots[k + 2]);
                let u = ((r - a) / (b - a)).clamp(0.0, 1.0);
                let um = (m - a) / (b - a);
                [
                    (k, (u - um) * (u - 1.0) / um),
                    (k + 1, u * (u - 1.0) / (um * (um - 1.0))),
                    (k + 2, u * (u - um) / (1.0 - um)),
                ]
            } else {
                let k = roots.partition_point(|&x| x <= r).clamp(1, fm - 1) - 1;
                let x =
                    (k as f64 + (r - roots[k]) / (roots[k + 1] - roots[k])).min((fm - 1) as f64);
                linear_basis(x as f32, fm)
            }
        };
        let cases: Vec<(usize, f32, f32)> = triples_arg(args, "--cases").unwrap_or_default();
        let q = Quadrature {
            ng: 48,
            broad: arg(args, "--broad", 400),
        };
        let quad: usize = arg(args, "--quad", 128);
        let threads: usize = arg(args, "--threads", 2);
        let print_rows = args.iter().any(|a| a == "--print-rows");
        let grazing = (89f64.to_radians().cos()).sqrt();
        // Test points: eighths of the lobe grid's intervals (in
        // `sqrt(mu)`) from the normal to 89 degrees, the same for every
        // grid.
        let tests: Vec<f32> = (0..=8 * (MU_N - 1))
            .map(|k| k as f64 / (8 * (MU_N - 1)) as f64)
            .filter(|&r| r >= grazing)
            .map(|r| (r * r) as f32)
            .collect();
        println!(
            "grid {grid} {split:?}: {fm} nodes, {} test cosines",
            tests.len()
        );
        let res = parallel(&cases, "pilot", threads, |_, &(n, alpha, eta_rel)| {
            let eta = eta_rel.max(1.0 / eta_rel);
            let sd = usize::from(eta_rel < 1.0);
            let sol = solve_scales_on(
                n,
                alpha,
                eta,
                q,
                quad,
                fm,
                &|i| (roots[i] * roots[i]) as f32,
                &basis,
            );
            let ndf = Ndf::new(NDFS[n], alpha, alpha);
            let tab = msbsdf::multiple::tabulated_dielectric::TabulatedDielectric::new(
                ndf,
                Facet::Dielectric { eta },
            );
            let mut worst = (0.0f64, 0.0f32);
            let mut per_j = [0.0f64; MU_N - 1];
            let mut sum2 = 0.0;
            for chunk in tests.chunks(fm) {
                let m = lobe_rows(
                    &tab,
                    alpha,
                    q,
                    fm,
                    |i| chunk[i.min(chunk.len() - 1)].max(1e-3),
                    basis,
                );
                for (k, &mu) in chunk.iter().enumerate() {
                    let row = &m[sd * fm + k];
                    let inner: f64 = (0..2 * fm).map(|y| row[y] * sol.sc[y]).sum();
                    let s: f64 = basis(mu)
                        .iter()
                        .map(|&(y, w)| sol.sc[sd * fm + y] * w)
                        .sum();
                    let target = (1.0 - ess(ndf, eta_rel, dir(mu.max(1e-3)), quad)).max(0.0);
                    let e = s * inner - target;
                    if print_rows {
                        println!(
                            "  {:.2} deg: s {s:.4} inner {inner:.4} target {target:.4} e {e:+.4}",
                            mu.acos().to_degrees()
                        );
                    }
                    sum2 += e * e;
                    let j = ((mu.sqrt() * (MU_N - 1) as f32) as usize).min(MU_N - 2);
                    per_j[j] = per_j[j].max(e.abs());
                    if e.abs() > worst.0.abs() {
                        worst = (e, mu.acos().to_degrees());
                    }
                }
            }
            (worst, (sum2 / tests.len() as f64).sqrt(), per_j)
        });
        let mut all = 0.0f64;
        let mut per_j = [0.0f64; MU_N - 1];
        for r in &res {
            for (a, b) in per_j.iter_mut().zip(&r.2) {
                *a = a.max(*b);
            }
        }
        println!(
            "worst per lobe interval (j = 0 grazing): {}",
            per_j
                .iter()
                .map(|v| format!("{:.4}", v))
                .collect::<Vec<_>>()
                .join(" ")
        );
        for (&(n, alpha, eta), ((e, th), rms, _)) in cases.iter().zip(&res) {
            println!(
                "{n}:{alpha}:{eta}: worst {:+.4} at {th:.1} deg, rms {rms:.4}",
                e
            );
            all = all.max(e.abs());
        }
        println!("worst of all {all:.4}");
    }

    /// First bytes of a `--points` file of the scale fit.
    const POINTS_MAGIC: &[u8; 24] = b"MSBSDF-SCALE-POINTS-v2\n\0";

    /// The quadrature of a `--points` file ([`solved_points`]): `--ng`,
    /// `--broad` and `--quad` as little-endian `u32`.
    fn points_quadrature(q: Quadrature, quad: usize) -> Vec<u8> {
        [q.ng, q.broad, quad]
            .iter()
            .flat_map(|&v| (v as u32).to_le_bytes())
            .collect()
    }

    /// The scale solves of the fit's points `(NDF, roughness, index)`
    /// (`--dielectric-scale-fit`): read from `cache` if it exists (it must
    /// hold the same points, to the bit, and quadrature), else solved
    /// ([`solve_scales`]) and, with `cache`, written there: after the
    /// magic the quadrature (`--ng`, `--broad`, `--quad` as `u32`), then
    /// per point its NDF, roughness and index and the scales and targets
    /// of every source node as f64 (the
    /// fit reads nothing else; the lobe rows are not kept). A refit with
    /// other weights or Lawson steps then takes seconds instead of the
    /// solves' 20-50 minutes. Also returns where the solves came from
    /// (for the table's header).
    fn solved_points(
        cache: Option<String>,
        what: &str,
        pts: Vec<(usize, f32, f32)>,
        threads: usize,
        q: Quadrature,
        quad: usize,
    ) -> (Vec<ScaleSolve>, String) {
        use msbsdf::multiple::tabulated_dielectric::SCALE_MU_N;
        let len = 2 * SCALE_MU_N;
        let rec = 12 + 16 * len;
        if let Some((path, Ok(raw))) = cache.as_deref().map(|p| (p, std::fs::read(p))) {
            let body = raw.strip_prefix(&POINTS_MAGIC[..]).unwrap_or_else(|| {
                panic!("--points: {path} is not a points file (delete it to solve anew)")
            });
            let (quadrature, body) = body.split_at(12.min(body.len()));
            assert!(
                quadrature == points_quadrature(q, quad),
                "--points: {path} was solved with another --ng / --broad / --quad (delete it to solve anew)"
            );
            assert!(
                body.len() == pts.len() * rec,
                "--points: {path} holds {} points, this fit needs {} (delete it to solve anew)",
                body.len() / rec,
                pts.len()
            );
            let f64_at = |b: &[u8], k: usize| {
                f64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes"))
            };
            let out = pts
                .iter()
                .zip(body.chunks_exact(rec))
                .map(|(&(n, alpha, eta), r)| {
                    let key = [n as u32, alpha.to_bits(), eta.to_bits()];
                    let got: Vec<u32> = r[..12]
                        .chunks_exact(4)
                        .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
                        .collect();
                    assert!(
                        got == key,
                        "--points: {path} holds other points than this fit's (delete it to solve anew)"
                    );
                    let v = &r[12..];
                    ScaleSolve {
                        sc: (0..len).map(|k| f64_at(v, k)).collect(),
                        target: (0..len).map(|k| f64_at(v, len + k)).collect(),
                        before: 0.0,
                        after: 0.0,
                        m: Vec::new(),
                    }
                })
                .collect();
            eprintln!("{what}: {} solves read from {path}", pts.len());
            return (out, format!("read from {path}"));
        }
        let out = parallel(
            &pts,
            &format!("scale fit points ({what})"),
            threads,
            |_, &(n, a, e)| solve_scales(n, a, e, q, quad),
        );
        if let Some(path) = cache.as_deref() {
            let mut raw = POINTS_MAGIC.to_vec();
            raw.extend(points_quadrature(q, quad));
            for (&(n, alpha, eta), p) in pts.iter().zip(&out) {
                for k in [n as u32, alpha.to_bits(), eta.to_bits()] {
                    raw.extend(k.to_le_bytes());
                }
                for v in p.sc.iter().chain(&p.target) {
                    raw.extend(v.to_le_bytes());
                }
            }
            std::fs::write(path, raw).unwrap_or_else(|e| panic!("--points: writing {path}: {e}"));
            eprintln!("{what}: {} solves written to {path}", pts.len());
            return (out, format!("solved here, kept in {path}"));
        }
        (out, "solved here".to_string())
    }

    /// The scaled multiply scattered albedo `s_x sum_y M(x, y) s_y` from
    /// source node `x` with scales `s`.
    fn furnace_row(s: &[f64], m: &[Vec<f64>], x: usize) -> f64 {
        (0..s.len()).map(|y| s[x] * m[x][y] * s[y]).sum()
    }

    /// The fit's weights of a row's midpoints for source node `x`: `(t /
    /// s)^2` with the midpoint's target `t = 1 - E_ss` and exact scale `s`
    /// (the furnace error a relative change of the scale makes), 0 where
    /// the target is below 1e-4 or the midpoint was not solved.
    fn mid_weights(mid: &[Option<&ScaleSolve>], x: usize) -> Vec<f64> {
        mid.iter()
            .map(|p| p.map_or(0.0, |p| point_weight(p, x)))
            .collect()
    }

    /// A solved point's weight for source node `x` ([`mid_weights`]).
    fn point_weight(p: &ScaleSolve, x: usize) -> f64 {
        if p.target[x] > 1e-4 && p.sc[x] > 1e-6 {
            (p.target[x] / p.sc[x]).powi(2)
        } else {
            0.0
        }
    }

    /// The fitted node values of one sheet of the scale table (one NDF and
    /// block, `na` roughness by `ne` index nodes, node `a ne + e`) for one
    /// source node (`--dielectric-scale-fit`): the exact node scales `s`
    /// (roughness node 0 and nodes of scale 0 fixed), the exact scales at
    /// the midpoints of the roughness intervals `mr` (`a ne + e` between
    /// nodes `(a, e)` and `(a + 1, e)`) and of the index intervals `me` (`a
    /// (ne - 1) + e` between `(a, e)` and `(a, e + 1)`), `None` where not
    /// solved, with their weights `wr`, `we`; a node's weight is the mean of
    /// its solved midpoints' (and `1e-6` of the largest, so that every node
    /// is held). The weighted sum of squares over nodes and midpoints
    /// (eval's interpolation at a midpoint is the mean of its two nodes)
    /// is minimised by conjugate gradients; then `lawson` steps of Lawson's
    /// reweighting (each weight times the point's weighted residual over
    /// the mean) move the solution towards the minimax one.
    #[allow(clippy::too_many_arguments)]
    fn fit_sheet(
        s: &[f64],
        na: usize,
        ne: usize,
        mr: &[Option<f64>],
        wr: &[f64],
        me: &[Option<f64>],
        we: &[f64],
        lawson: usize,
    ) -> Vec<f64> {
        use msbsdf::multiple::tabulated_dielectric::SCALE_MAX;
        let nn = na * ne;
        // Terms: two nodes with coefficients, the value, the base weight.
        let mut terms: Vec<([usize; 2], [f64; 2], f64, f64)> = Vec::new();
        let mut near = vec![(0.0f64, 0usize); nn];
        let mut mid_term = |p: usize, q: usize, m: f64, w: f64| {
            for k in [p, q] {
                near[k].0 += w;
                near[k].1 += 1;
            }
            ([p, q], [0.5, 0.5], m, w)
        };
        let mut mids = Vec::new();
        for a in 0..na.saturating_sub(1) {
            for e in 0..ne {
                if let Some(m) = mr[a * ne + e] {
                    mids.push(mid_term(a * ne + e, (a + 1) * ne + e, m, wr[a * ne + e]));
                }
            }
        }
        for a in 0..na {
            for e in 0..ne.saturating_sub(1) {
                let k = a * (ne - 1) + e;
                if let Some(m) = me[k] {
                    mids.push(mid_term(a * ne + e, a * ne + e + 1, m, we[k]));
                }
            }
        }
        let wmax = mids.iter().map(|t| t.3).fold(0.0f64, f64::max);
        let lambda = 1e-6 * wmax + 1e-12;
        for (k, &(w, c)) in near.iter().enumerate() {
            let w = if c > 0 { w / c as f64 } else { 0.0 };
            terms.push(([k, k], [1.0, 0.0], s[k], w + lambda));
        }
        terms.extend(mids);
        let fixed = |k: usize| k / ne == 0 || s[k] == 0.0;
        // Unknowns: the free nodes.
        let free: Vec<usize> = (0..nn).filter(|&k| !fixed(k)).collect();
        let mut slot = vec![usize::MAX; nn];
        for (i, &k) in free.iter().enumerate() {
            slot[k] = i;
        }
        let nf = free.len();
        let mut v = s.to_vec();
        let mut u = vec![1.0f64; terms.len()];
        for step in 0..=lawson {
            // Normal equations A v = b over the free nodes (A as triplets).
            let mut trip: Vec<(usize, usize, f64)> = Vec::new();
            let mut b = vec![0.0f64; nf];
            for (t, &(nodes, c, m, w)) in terms.iter().enumerate() {
                let w = w * u[t];
                // The fixed nodes' part moves to the value.
                let mut val = m;
                for j in 0..2 {
                    if c[j] != 0.0 && slot[nodes[j]] == usize::MAX {
                        val -= c[j] * s[nodes[j]];
                    }
                }
                for i in 0..2 {
                    let si = slot[nodes[i]];
                    if c[i] == 0.0 || si == usize::MAX {
                        continue;
                    }
                    b[si] += w * c[i] * val;
                    for j in 0..2 {
                        let sj = slot[nodes[j]];
                        if c[j] != 0.0 && sj != usize::MAX {
                            trip.push((si, sj, w * c[i] * c[j]));
                        }
                    }
                }
            }
            let mut diag = vec![0.0f64; nf];
            for &(i, j, a) in &trip {
                if i == j {
                    diag[i] += a;
                }
            }
            let mul = |x: &[f64]| {
                let mut y = vec![0.0f64; nf];
                for &(i, j, a) in &trip {
                    y[i] += a * x[j];
                }
                y
            };
            // Jacobi-preconditioned conjugate gradients from the exact
            // values (or the previous step's).
            let mut x: Vec<f64> = free.iter().map(|&k| v[k]).collect();
            let ax = mul(&x);
            let mut r: Vec<f64> = (0..nf).map(|i| b[i] - ax[i]).collect();
            let mut z: Vec<f64> = (0..nf).map(|i| r[i] / diag[i]).collect();
            let mut p = z.clone();
            let mut rz: f64 = (0..nf).map(|i| r[i] * z[i]).sum();
            let bnorm = b.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300);
            for _ in 0..20 * nf.max(1) {
                if r.iter().map(|v| v * v).sum::<f64>().sqrt() <= 1e-13 * bnorm {
                    break;
                }
                let ap = mul(&p);
                let pap: f64 = (0..nf).map(|i| p[i] * ap[i]).sum();
                if pap <= 0.0 {
                    break;
                }
                let alpha = rz / pap;
                for i in 0..nf {
                    x[i] += alpha * p[i];
                    r[i] -= alpha * ap[i];
                }
                z = (0..nf).map(|i| r[i] / diag[i]).collect();
                let rz_new: f64 = (0..nf).map(|i| r[i] * z[i]).sum();
                for i in 0..nf {
                    p[i] = z[i] + rz_new / rz * p[i];
                }
                rz = rz_new;
            }
            for (i, &k) in free.iter().enumerate() {
                v[k] = x[i].clamp(0.0, SCALE_MAX as f64);
            }
            if step == lawson {
                break;
            }
            // Weighted residuals and the update.
            let res: Vec<f64> = terms
                .iter()
                .map(|&(nodes, c, m, w)| {
                    w.sqrt() * (c[0] * v[nodes[0]] + c[1] * v[nodes[1]] - m).abs()
                })
                .collect();
            let mean = res.iter().sum::<f64>() / res.len().max(1) as f64;
            if mean <= 0.0 {
                break;
            }
            for (ut, r) in u.iter_mut().zip(&res) {
                *ut *= (r / mean).max(1e-3);
            }
        }
        v
    }

    /// `--dielectric-scale-fit --exact EXACT.bin`: the furnace scale table
    /// with its nodes fitted by least squares along roughness instead of
    /// solved exactly at each node. Eval interpolates the scales linearly
    /// between roughness nodes, and between two nodes the exact scale bends
    /// (GGX glass 1.55 from the dense side at 84 degrees, nodes 0.096 and
    /// 0.125: exact 0.570 and 0.677, 0.588 at the midpoint against the
    /// interpolated 0.624; furnace 1.06% off there), so exact nodes put the
    /// whole of that error between them. Here the exact scales at the
    /// midpoints of every roughness interval of every row (NDF, block and
    /// index node) are solved as `--dielectric-scale` solves a node, and per
    /// row and source node `x = (side, mu)` the node values `v` minimise
    /// `sum_nodes w (v - s)^2 + sum_midpoints w ((v_a + v_a+1) / 2 - m)^2`
    /// ([`fit_sheet`]), `s` the exact node scales read from
    /// `EXACT.bin` (a table `--dielectric-scale` wrote for the same lobe
    /// table), `m` the midpoints', `w = (t / s)^2` with the midpoint's
    /// target `t = 1 - E_ss` and scale (the furnace error a relative change
    /// of the scale makes; a node's the mean of its midpoints'). Roughness
    /// node 0 and nodes of scale 0 (target 0) keep their exact values. A
    /// convex bend of depth `d` between nodes then leaves about `d / 2` at
    /// the nodes and the midpoints instead of 0 and `d`.
    ///
    /// `--lawson K` (default 0) takes `K` steps of Lawson's reweighting
    /// ([`fit_sheet`]) towards the minimax fit; the committed table uses 3.
    /// `--low-2d --base FITTED.bin` refits the low-index block (index
    /// 1.05-1.166) as one sheet per NDF and source node over the midpoints
    /// of its index intervals too (solved at `sqrt(E_e E_e+1)`: eval's index
    /// coordinate is linear in `ln E` there), where the scales bend in `ln
    /// E` next to 1.05, and copies the rest from `FITTED.bin` (a table this
    /// command wrote without `--low-2d`); the committed table is made so.
    ///
    /// `--main-2d --base FITTED.bin` fits the main block as `--low-2d`
    /// fits the low-index block: one sheet per NDF and source node over
    /// the midpoints of its roughness and index intervals (version 10:
    /// between the index nodes the exact scales bend too, Beckmann 1.3
    /// glass 1.2 from inside at the normal: 0.60% off with exact nodes,
    /// 0.12% with the roughness interpolated alone), and copies the rest
    /// (the low-index block) from `FITTED.bin`, whose low-index block must
    /// be a `--low-2d` fit. (Version 10 was made with the form of commit
    /// 9434f94, `--low-from FITTED_V9.bin --main-2d`, which took the
    /// low-index block from a version-9 table; version 11 changed only the
    /// low-index block and keeps version 10's main block through `--keep`
    /// and `--base`.)
    ///
    /// `--hold-mu-from K` (with `--low-2d` or `--main-2d`) keeps the exact values of the
    /// fitted block's cosine nodes `K` and above (`scale_grid_mu`; 32
    /// is 26.2 degrees, the lobe table's node 18, to the normal). The fit
    /// sees the furnace at the cosine nodes only; near the normal the
    /// scale bends between them (Beckmann 1.9 glass 1.079 from inside at
    /// 8 degrees: 0.52% with exact nodes), and the fit's trade for the
    /// index midpoints put it at 0.68% there (scale table version 12,
    /// session 35); held exact, 0.53%. Version 12 is made with 32.
    /// `--hold-alpha-below A` likewise keeps the exact values of the fitted
    /// block's roughness nodes below `A`: there the fit's trade moved the
    /// low-index block's nodes next to 1.05 (Beckmann 0.03 glass 1.061
    /// from outside at 88 degrees: +0.73% fitted, 0.08% with exact nodes;
    /// version 10 copied the main block's nodes to 0.049 from a fit along
    /// roughness for the same reason). Version 12 is made with 0.05.
    ///
    /// `--points FILE` keeps the midpoints' solves in `FILE.roughness` and
    /// `FILE.index` ([`solved_points`]) or reads them from there when they
    /// exist, so that a refit with other `--lawson` steps takes seconds.
    ///
    /// `--pilot N,L,E` (NDF, 1 for the low-index block, index node) fits one
    /// row with each number of Lawson steps of `--pilot-lawson K,K,...`
    /// (default 0,5,20) and prints the furnace (the worst `|albedo - 1|`
    /// over the scale grid's cosines to 89.1 degrees) at the nodes, the
    /// quarter points and the midpoints up to roughness node `--pilot-nodes
    /// K` (default 20) with the exact and the fitted nodes interpolated;
    /// nothing is written. `--broad`, `--ng`, `--quad`, `--threads`,
    /// `--out` as for `--dielectric-scale`.
    pub fn scale_fit_main(args: &[String]) {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_ALPHA_N, SCALE_ETA_N, SCALE_LOW_ALPHA_N, SCALE_LOW_ETA_N, SCALE_MU_N, header,
            scale_grid_alpha, scale_grid_eta, scale_index, scale_low_grid_alpha,
        };
        let t0 = std::time::Instant::now();
        let fm = SCALE_MU_N;
        let quad: usize = arg(args, "--quad", 128);
        let threads: usize = arg(args, "--threads", 2);
        let ng: usize = arg(args, "--ng", 48);
        let broad: usize = arg(args, "--broad", 400);
        let q = Quadrature { ng, broad };
        let out: String = arg(
            args,
            "--out",
            "data/tabulated_dielectric_scale.bin".to_string(),
        );
        let (raw, exact_path) = table_arg(args, "--exact", SCALE_MAGIC, SCALE_FILE_BYTES)
            .expect("--exact EXACT.bin: the exact scale table");
        let exact_head = String::from_utf8_lossy(&raw[..HEADER_BYTES]).to_string();
        assert!(
            !exact_head.lines().any(|l| l.starts_with("fit:")),
            "--exact: this table's nodes are fitted, not exact"
        );
        let exact = |i: usize| table_step(&raw, i) as f64 * SCALE_STEP as f64;
        let grid_alpha_of = |low: bool, a: usize| {
            if low {
                scale_low_grid_alpha(a)
            } else {
                scale_grid_alpha(a)
            }
        };
        // Roughness at fraction `f` of interval `a` of a block's grid
        // (linear in `sqrt(alpha)`, as eval interpolates).
        let alpha_at = |low: bool, a: usize, f: f64| {
            let (r0, r1) = (
                (grid_alpha_of(low, a) as f64).sqrt(),
                (grid_alpha_of(low, a + 1) as f64).sqrt(),
            );
            let r = r0 + f * (r1 - r0);
            (r * r) as f32
        };
        // Rows (NDF, low-index block, index node) and their roughness nodes.
        let pilot: Option<Vec<usize>> = args
            .iter()
            .position(|a| a == "--pilot")
            .and_then(|p| args.get(p + 1))
            .map(|v| v.split(',').filter_map(|t| t.parse().ok()).collect());
        // `--low-2d --base FITTED.bin`: the low-index block refitted over
        // the midpoints of its index intervals too, the rest copied from
        // `FITTED.bin`.
        let low2d = args.iter().any(|a| a == "--low-2d");
        let base = table_arg(args, "--base", SCALE_MAGIC, SCALE_FILE_BYTES);
        assert!(!low2d || base.is_some(), "--low-2d needs --base");
        // `--main-2d --base FITTED.bin`: the main block fitted as one
        // sheet per NDF and source node over the midpoints of its index
        // intervals too, the low-index block copied from `FITTED.bin`.
        let main2d = args.iter().any(|a| a == "--main-2d");
        assert!(
            !main2d || !(low2d || pilot.is_some()),
            "--main-2d is for the main block's fit alone"
        );
        assert!(!main2d || base.is_some(), "--main-2d needs --base");
        if let (true, Some((raw, _))) = (main2d, &base) {
            assert!(
                header_line(raw, "low-2d:") != "?",
                "--base: the table's low-index block is not the 2-d fit"
            );
        }
        let rows: Vec<(usize, bool, usize)> = match &pilot {
            Some(v) if v.len() == 3 => vec![(v[0], v[1] == 1, v[2])],
            Some(_) => panic!("--pilot N,L,E"),
            None if low2d => (0..NDF_N)
                .flat_map(|n| (0..SCALE_LOW_ETA_N).map(move |e| (n, true, e)))
                .collect(),
            None if main2d => (0..NDF_N)
                .flat_map(|n| (SCALE_LOW_ETA_N - 1..SCALE_ETA_N).map(move |e| (n, false, e)))
                .collect(),
            None => (0..NDF_N)
                .flat_map(|n| {
                    (0..SCALE_LOW_ETA_N)
                        .map(move |e| (n, true, e))
                        .chain((SCALE_LOW_ETA_N - 1..SCALE_ETA_N).map(move |e| (n, false, e)))
                })
                .collect(),
        };
        let nodes_of = |low: bool| {
            if low {
                SCALE_LOW_ALPHA_N
            } else {
                SCALE_ALPHA_N
            }
        };
        let pilot_nodes: usize = arg(args, "--pilot-nodes", 20);
        let lawson: usize = arg(args, "--lawson", 0);
        let hold_alpha_below: Option<f32> = args
            .iter()
            .position(|a| a == "--hold-alpha-below")
            .map(|p| {
                let v = args.get(p + 1).map(|v| v.parse::<f32>());
                match v {
                    Some(Ok(v)) => v,
                    _ => panic!("--hold-alpha-below needs a number"),
                }
            });
        let hold_mu_from: Option<usize> =
            args.iter().position(|a| a == "--hold-mu-from").map(|p| {
                let v = args.get(p + 1).map(|v| v.parse::<usize>());
                match v {
                    Some(Ok(v)) => v,
                    _ => panic!("--hold-mu-from needs a number"),
                }
            });
        let pilot_lawson: Vec<usize> = arg(args, "--pilot-lawson", "0,5,20".to_string())
            .split(',')
            .filter_map(|t| t.parse().ok())
            .collect();
        // Points solved: (row, interval, fraction); the midpoints, and in a
        // pilot the nodes and quarter points too.
        let fracs: &[f64] = if pilot.is_some() {
            &[0.0, 0.25, 0.5, 0.75]
        } else {
            &[0.5]
        };
        let mut jobs: Vec<(usize, usize, f64)> = Vec::new();
        for (r, &(_, low, _)) in rows.iter().enumerate() {
            let last = if pilot.is_some() {
                pilot_nodes.min(nodes_of(low) - 1)
            } else {
                nodes_of(low) - 1
            };
            for a in 0..last {
                for &f in fracs {
                    if a > 0 || f > 0.0 {
                        jobs.push((r, a, f));
                    }
                }
            }
            if pilot.is_some() {
                jobs.push((r, last, 0.0));
            }
        }
        // `--points FILE`: the points' solves kept in (or read from)
        // `FILE.roughness` and `FILE.index`.
        let points: Option<String> = args
            .iter()
            .position(|a| a == "--points")
            .and_then(|p| args.get(p + 1))
            .cloned();
        assert!(
            points.is_none() || pilot.is_none(),
            "--points is for the fit, not --pilot"
        );
        let solved = |tag: &str, pts: Vec<(usize, f32, f32)>| {
            solved_points(
                points.as_deref().map(|p| format!("{p}.{tag}")),
                tag,
                pts,
                threads,
                q,
                quad,
            )
        };
        let (res, res_from) = solved(
            "roughness",
            jobs.iter()
                .map(|&(r, a, f)| {
                    let (n, low, e) = rows[r];
                    (n, alpha_at(low, a, f), scale_grid_eta(e))
                })
                .collect(),
        );
        // The midpoint solve of row `r`'s roughness interval `a`, if any.
        let mid_of: std::collections::HashMap<(usize, usize), &ScaleSolve> = jobs
            .iter()
            .zip(&res)
            .filter(|((_, _, f), _)| *f == 0.5)
            .map(|(&(r, a, _), p)| ((r, a), p))
            .collect();
        let row_mids = |r: usize, na: usize| -> Vec<Option<&ScaleSolve>> {
            (0..na - 1).map(|a| mid_of.get(&(r, a)).copied()).collect()
        };
        // `--low-2d` / `--main-2d`: the midpoints of the block's index
        // intervals (NDF, roughness node, lower index node).
        let (sheet_e0, sheet_na, sheet_ne) = if main2d {
            (
                SCALE_LOW_ETA_N - 1,
                SCALE_ALPHA_N,
                SCALE_ETA_N + 1 - SCALE_LOW_ETA_N,
            )
        } else {
            (0, SCALE_LOW_ALPHA_N, SCALE_LOW_ETA_N)
        };
        let ijobs: Vec<(usize, usize, usize)> = if low2d || main2d {
            (0..NDF_N)
                .flat_map(|n| {
                    (1..sheet_na).flat_map(move |a| {
                        (sheet_e0..sheet_e0 + sheet_ne - 1).map(move |e| (n, a, e))
                    })
                })
                .collect()
        } else {
            Vec::new()
        };
        let (ires, ires_from) = solved(
            "index",
            ijobs
                .iter()
                .map(|&(n, a, e)| {
                    // Eval's index coordinate is linear in `ln E` between
                    // nodes.
                    let eta = (scale_grid_eta(e) * scale_grid_eta(e + 1)).sqrt();
                    (n, grid_alpha_of(low2d, a), eta)
                })
                .collect(),
        );
        let mut scale: Vec<u16> = match &base {
            Some((raw, _)) => (0..SCALE_LEN).map(|i| table_step(raw, i)).collect(),
            None => (0..SCALE_LEN).map(|i| scale_steps(exact(i))).collect(),
        };
        // The largest relative change of a node, and where.
        let (mut moved, mut moved_at) = (0.0f64, String::new());
        let mut note = |v: f64, s: f64, n: usize, low: bool, a: usize, e: usize, x: usize| {
            let dv = (v - s).abs() / s.max(1e-3);
            if dv > moved {
                moved = dv;
                moved_at = format!(
                    "NDF {n} {} index {:.4} roughness {:.4} side {} mu {:.4}",
                    if low { "low block" } else { "main block" },
                    scale_grid_eta(e),
                    grid_alpha_of(low, a),
                    x / fm,
                    msbsdf::multiple::tabulated_dielectric::scale_grid_mu(x % fm)
                );
            }
        };
        // The index midpoint solve of (NDF, roughness node, lower index
        // node).
        let imid_of: std::collections::HashMap<(usize, usize, usize), &ScaleSolve> =
            ijobs.iter().copied().zip(&ires).collect();
        if low2d || main2d {
            let (low, e0, na, ne) = (low2d, sheet_e0, sheet_na, sheet_ne);
            for n in 0..NDF_N {
                let row_of = |e: usize| rows.iter().position(|&r| r == (n, low, e0 + e));
                let rmid =
                    |a: usize, e: usize| row_of(e).and_then(|r| mid_of.get(&(r, a)).copied());
                let imid = |a: usize, e: usize| imid_of.get(&(n, a, e0 + e)).copied();
                for x in 0..2 * fm {
                    let sx: Vec<f64> = (0..na * ne)
                        .map(|k| exact(scale_index(n, low, k / ne, e0 + k % ne, x / fm, x % fm)))
                        .collect();
                    let rpts: Vec<Option<&ScaleSolve>> =
                        (0..(na - 1) * ne).map(|k| rmid(k / ne, k % ne)).collect();
                    let ipts: Vec<Option<&ScaleSolve>> = (0..na * (ne - 1))
                        .map(|k| imid(k / (ne - 1), k % (ne - 1)))
                        .collect();
                    let value = |p: &Option<&ScaleSolve>| p.map(|p| p.sc[x]);
                    let v = fit_sheet(
                        &sx,
                        na,
                        ne,
                        &rpts.iter().map(value).collect::<Vec<_>>(),
                        &mid_weights(&rpts, x),
                        &ipts.iter().map(value).collect::<Vec<_>>(),
                        &mid_weights(&ipts, x),
                        lawson,
                    );
                    // `--hold-mu-from K`: the cosine nodes from K on keep
                    // their exact values.
                    let v = if hold_mu_from.is_some_and(|h| x % fm >= h) {
                        sx.clone()
                    } else {
                        v
                    };
                    for (k, vk) in v.iter().enumerate() {
                        let (a, e) = (k / ne, e0 + k % ne);
                        // `--hold-alpha-below A`: nodes of a lower roughness
                        // keep their exact values.
                        let vk = if hold_alpha_below.is_some_and(|h| grid_alpha_of(low, a) < h) {
                            &sx[k]
                        } else {
                            vk
                        };
                        note(*vk, sx[k], n, low, a, e, x);
                        scale[scale_index(n, low, a, e, x / fm, x % fm)] = scale_steps(*vk);
                    }
                }
            }
        }
        // Row `r` fitted along roughness with `steps` Lawson steps: the
        // node values `[a][x]`.
        let fit_one_row = |r: usize, steps: usize| -> Vec<Vec<f64>> {
            let (n, low, e) = rows[r];
            let na = nodes_of(low);
            let mid = row_mids(r, na);
            let cols: Vec<Vec<f64>> = (0..2 * fm)
                .map(|x| {
                    let sx: Vec<f64> = (0..na)
                        .map(|a| exact(scale_index(n, low, a, e, x / fm, x % fm)))
                        .collect();
                    let mx: Vec<Option<f64>> = mid.iter().map(|p| p.map(|p| p.sc[x])).collect();
                    fit_sheet(&sx, na, 1, &mx, &mid_weights(&mid, x), &[], &[], steps)
                })
                .collect();
            (0..na)
                .map(|a| cols.iter().map(|c| c[a]).collect())
                .collect()
        };
        if !low2d && !main2d && pilot.is_none() {
            for (r, &(n, low, e)) in rows.iter().enumerate() {
                for (a, va) in fit_one_row(r, lawson).iter().enumerate() {
                    for (x, &v) in va.iter().enumerate() {
                        let i = scale_index(n, low, a, e, x / fm, x % fm);
                        note(v, exact(i), n, low, a, e, x);
                        scale[i] = scale_steps(v);
                    }
                }
            }
        }
        if pilot.is_some() {
            let (n, low, e) = rows[0];
            let s = |a: usize, x: usize| exact(scale_index(n, low, a, e, x / fm, x % fm));
            // The furnace is reported to 89 degrees: cosine nodes from the
            // first at or above cos(89.1 degrees).
            let mu_min = 89.1f32.to_radians().cos();
            let x_ok =
                |x: usize| msbsdf::multiple::tabulated_dielectric::scale_grid_mu(x % fm) >= mu_min;
            let fits: Vec<(usize, Vec<Vec<f64>>)> = pilot_lawson
                .iter()
                .map(|&steps| (steps, fit_one_row(0, steps)))
                .collect();
            let mut worst = vec![[0.0f64; 3]; fits.len() + 1];
            for (&(_, a, f), p) in jobs.iter().zip(&res) {
                let b = if f > 0.0 { a + 1 } else { a };
                let err = |val: &dyn Fn(usize) -> f64| {
                    let sc: Vec<f64> = (0..2 * fm).map(val).collect();
                    (0..2 * fm)
                        .filter(|&x| x_ok(x))
                        .map(|x| (furnace_row(&sc, &p.m, x) - p.target[x]).abs())
                        .fold(0.0f64, f64::max)
                };
                let kind = if f == 0.0 {
                    0
                } else if f == 0.5 {
                    2
                } else {
                    1
                };
                let mut line = format!(
                    "roughness {:.5} (node {a} + {f}): furnace exact nodes {:.4}%",
                    alpha_at(low, a, f),
                    100.0 * {
                        let e0 = err(&|x| (1.0 - f) * s(a, x) + f * s(b, x));
                        worst[0][kind] = worst[0][kind].max(e0);
                        e0
                    }
                );
                for (k, (steps, v)) in fits.iter().enumerate() {
                    let e1 = err(&|x| (1.0 - f) * v[a][x] + f * v[b][x]);
                    worst[k + 1][kind] = worst[k + 1][kind].max(e1);
                    line += &format!(", fitted (Lawson {steps}) {:.4}%", 100.0 * e1);
                }
                eprintln!("{line}");
            }
            for (k, w) in worst.iter().enumerate() {
                eprintln!(
                    "{}: worst at nodes {:.4}%, quarter points {:.4}%, midpoints {:.4}%",
                    if k == 0 {
                        "exact nodes".to_string()
                    } else {
                        format!("fitted (Lawson {})", fits[k - 1].0)
                    },
                    100.0 * w[0],
                    100.0 * w[1],
                    100.0 * w[2]
                );
            }
            return;
        }
        let exact_line = |key: &str| header_line(&raw, key);
        let table_commit = header()
            .lines()
            .find(|l| l.starts_with("commit:"))
            .unwrap_or("commit: ?")
            .to_string();
        let head = format!(
            "{}\
             MSBSDF_MODEL_TABULATED dielectric furnace scales (layout: src/multiple/tabulated_dielectric.rs), nodes fitted by least squares along roughness\n\
             command: cargo run --release --example gen_tabulated -- {}\n\
             commit: {}\n\
             lobe table: data/tabulated_dielectric.bin, {table_commit}\n\
             fit: per row (NDF, block, index node) and source node (side, mu), node values v minimising sum_nodes w (v - s)^2 + sum_midpoints w ((v_a + v_a+1) / 2 - m)^2, s the exact node scales of {exact_path}, m the exact scales at the {} midpoints of the roughness intervals, w = (t / s)^2 at the midpoint (1 - E_ss over its scale; a node's the mean of its midpoints'); roughness node 0 and scale-0 nodes fixed; largest change of a node {:.2}% ({moved_at})\n\
             {}\
             exact nodes: {}; {}\n\
             points: the roughness midpoints' solves {res_from}, the index midpoints' {ires_from}\n\
             quadrature: --broad {broad} (as --dielectric-scale); E_ss quadrature {quad} x {quad}; deterministic, no seeds\n\
             wall time: {:.0} s on {threads} threads\n\
             {SCALE_STORAGE}\n",
            String::from_utf8_lossy(SCALE_MAGIC),
            args[1..].join(" "),
            git::commit(),
            jobs.len(),
            100.0 * moved,
            match &base {
                Some((raw, path)) if main2d => {
                    let line = |key: &str| header_line(raw, key);
                    format!(
                        "main-2d: the main block fitted over the midpoints of its roughness and index intervals ({} index midpoints, at sqrt(E_e E_e+1); eval interpolates a node's two neighbours there too), by conjugate gradients on its whole sheet per NDF and source node; the low-index block copied from {path} ({}; {}; {})\n",
                        ijobs.len(),
                        line("command:"),
                        line("commit:"),
                        line("low-2d:")
                    )
                }
                Some((raw, path)) => {
                    let line = |key: &str| header_line(raw, key);
                    format!(
                        "low-2d: the low-index block refitted over the midpoints of its roughness and index intervals ({} index midpoints; eval interpolates a node's two neighbours there too), by conjugate gradients on its whole sheet per NDF and source node{}; the main block copied from {path} ({}; {})\n",
                        ijobs.len(),
                        match hold_mu_from {
                            Some(h) => format!(
                                ", except its cosine nodes {h} and above (from {:.2} degrees), which keep their exact values",
                                msbsdf::multiple::tabulated_dielectric::scale_grid_mu(h)
                                    .acos()
                                    .to_degrees()
                            ),
                            None => String::new(),
                        } + &match hold_alpha_below {
                            Some(h) => format!(
                                ", and its roughness nodes below {h}, which keep theirs too"
                            ),
                            None => String::new(),
                        },
                        line("command:"),
                        line("commit:")
                    )
                }
                None => String::new(),
            },
            exact_line("command:"),
            exact_line("commit:"),
            t0.elapsed().as_secs_f64(),
        );
        write_scale_table(&out, &head, &scale);
    }

    /// `--dielectric-scale-splice --from FITTED.bin --below-from
    /// FITTED_1D.bin --to-node K` (the committed version 10, `K` = 13):
    /// the table `FITTED.bin` (`--dielectric-scale-fit --main-2d` wrote it)
    /// with the main block's roughness nodes `0..=K` (roughness up to
    /// 0.049 for 13) copied from a table of the same layout fitted along
    /// roughness alone. (Version 10 was spliced with the form of commit
    /// 9434f94, which read a version-9 `--below-from`: its main block's
    /// nodes 0 to 13 are the same nodes in both layouts.) Near
    /// grazing at low roughness the scales change fastest with roughness
    /// and the 2-d fit moved those nodes (Beckmann's by up to 0.36 of
    /// scale): Beckmann 0.0096 glass 1.85 from inside at 88.7 degrees was
    /// -1.16% with the 2-d fit's nodes there, -0.09% with version 9's.
    /// Written to `--out` (default the committed table); nothing is
    /// solved.
    pub fn scale_splice_main(args: &[String]) {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_ALPHA_N, SCALE_ETA_N, SCALE_LEN, SCALE_LOW_ETA_N, SCALE_MU_N, scale_index,
        };
        let (from, from_path) = table_arg(args, "--from", SCALE_MAGIC, SCALE_FILE_BYTES)
            .expect("--from FITTED.bin: a scale table of this version");
        let (below, below_path) = table_arg(args, "--below-from", SCALE_MAGIC, SCALE_FILE_BYTES)
            .expect("--below-from FITTED_1D.bin: a fitted scale table of this version");
        assert!(
            header_line(&from, "main-2d:") != "?" && header_line(&below, "fit:") != "?",
            "--from must be a --main-2d fit, --below-from a fitted table"
        );
        let k: usize = arg(args, "--to-node", usize::MAX);
        assert!(k < SCALE_ALPHA_N, "--to-node K below {SCALE_ALPHA_N}");
        let out: String = arg(
            args,
            "--out",
            "data/tabulated_dielectric_scale.bin".to_string(),
        );
        let mut scale: Vec<u16> = (0..SCALE_LEN).map(|i| table_step(&from, i)).collect();
        let mut copied = 0usize;
        for n in 0..NDF_N {
            for a in 0..=k {
                for e in SCALE_LOW_ETA_N - 1..SCALE_ETA_N {
                    for x in 0..2 * SCALE_MU_N {
                        let i = scale_index(n, false, a, e, x / SCALE_MU_N, x % SCALE_MU_N);
                        scale[i] = table_step(&below, i);
                        copied += 1;
                    }
                }
            }
        }
        let from_head = nested_header(&from);
        let head = format!(
            "{}\
             MSBSDF_MODEL_TABULATED dielectric furnace scales (layout: src/multiple/tabulated_dielectric.rs), spliced\n\
             command: cargo run --release --example gen_tabulated -- {}\n\
             commit: {}\n\
             splice: the main block's roughness nodes 0 to {k} ({copied} values) from {below_path} (fitted along roughness alone; {}; {}), the rest from {from_path}, whose header follows\n\
             {from_head}",
            String::from_utf8_lossy(SCALE_MAGIC),
            args[1..].join(" "),
            git::commit(),
            header_line(&below, "command:"),
            header_line(&below, "commit:"),
        );
        write_scale_table(&out, &head, &scale);
    }

    /// `--dielectric-scale-top --from TABLE.bin [--first-free K]
    /// [--low-only] [--only N,A,E] [--lawson L] [--threads T] [--dry]
    /// [--out PATH]`: the scale table `TABLE.bin` with the cosine nodes
    /// from `K` (default 33, 16.1 degrees) to the normal of every node
    /// material (NDF, roughness node, index node; the low-index block's
    /// alone with `--low-only`; with `--only`, NDF `N`'s roughness node `A`
    /// and index node `E` of the blocks that have it) refitted along the cosine. The other
    /// fits see the furnace only at the cosine nodes, and near the normal
    /// the exact scale of rough glass at low index seen from its dense side
    /// bends more than the quadratic elements follow (Beckmann 2 glass
    /// 1.079 from inside, exact nodes: -0.37% at 16.1 degrees, +0.59% at
    /// 9.3, `--mu-pilot`). Here the furnace error `r_p = s_p inner_p - (1 -
    /// E_ss)` (an absolute albedo error) is read at the nodes of the
    /// elements that hold a free node and at the eighths of those elements
    /// (in `sqrt(mu)`), on both sides, with the material's lobe as eval
    /// reads it (`lobe_rows_at`, `--broad`'s quadrature), and the free
    /// nodes of both sides move by the least-squares step of the
    /// linearised errors, reweighted `L` times (default 8) by Lawson's rule
    /// towards the smallest worst error (a side's `inner` sums over both
    /// sides' scales, the transmission's coupling included). A material
    /// keeps its nodes where the step does not lower its worst error (by
    /// the linearisation). The nodes below `K` and their furnace are left
    /// as they are (a free node's change moves their `inner` by its
    /// lobe's share, under a hundredth of the change). `--dry` prints each
    /// material's worst error before and after (linearised) and writes
    /// nothing.
    pub fn scale_top_main(args: &[String]) {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_ALPHA_N, SCALE_ETA_N, SCALE_LEN, SCALE_LOW_ALPHA_N, SCALE_LOW_ETA_N, SCALE_MAX,
            SCALE_MU_N, TabulatedDielectric, scale_grid_alpha, scale_grid_eta, scale_grid_mu,
            scale_index, scale_low_grid_alpha,
        };
        let t0 = std::time::Instant::now();
        let (from, from_path) = table_arg(args, "--from", SCALE_MAGIC, SCALE_FILE_BYTES)
            .expect("--from TABLE.bin: a scale table of this version");
        let first: usize = arg(args, "--first-free", 33);
        assert!(
            (1..SCALE_MU_N).contains(&first),
            "--first-free K: a cosine node from 1 to {}",
            SCALE_MU_N - 1
        );
        let lawson: usize = arg(args, "--lawson", 8);
        // `--node-weight F`: the errors at the cosine nodes count `F` times
        // in the minimax (eval interpolates the nodes in roughness and
        // index too, and what the fit trades at a node adds to that
        // interpolation's own error between nodes).
        let node_weight: f64 = arg(args, "--node-weight", 1.0);
        assert!(node_weight >= 1.0, "--node-weight F: at least 1");
        let threads: usize = arg(args, "--threads", 2);
        let low_only = args.iter().any(|a| a == "--low-only");
        let dry = args.iter().any(|a| a == "--dry");
        let only: Option<(usize, usize, usize)> =
            args.iter().position(|a| a == "--only").map(|p| {
                let v: Vec<usize> = args
                    .get(p + 1)
                    .map(|v| v.split(',').filter_map(|t| t.parse().ok()).collect())
                    .unwrap_or_default();
                match v[..] {
                    [n, a, e] => (n, a, e),
                    _ => panic!("--only N,A,E: NDF, roughness node, index node"),
                }
            });
        let q = Quadrature {
            ng: 48,
            broad: arg(args, "--broad", 400),
        };
        let quad: usize = arg(args, "--quad", 128);
        let out: String = arg(
            args,
            "--out",
            "data/tabulated_dielectric_scale.bin".to_string(),
        );
        // The elements that hold a free node, their nodes and eighths.
        let elem0 = (first - 1) / 2;
        let nodes: Vec<usize> = (2 * elem0..SCALE_MU_N).collect();
        let mut mus: Vec<f32> = nodes.iter().map(|&i| scale_grid_mu(i)).collect();
        let root = |i: usize| (scale_grid_mu(i) as f64).sqrt();
        for e in elem0..(SCALE_MU_N - 1) / 2 {
            let (a, b) = (root(2 * e), root(2 * e + 2));
            for k in [1, 2, 3, 5, 6, 7] {
                let r = a + (b - a) * k as f64 / 8.0;
                mus.push((r * r) as f32);
            }
        }
        // `--last-free L`: the nodes after `L` keep their values too.
        let last: usize = arg(args, "--last-free", SCALE_MU_N - 1);
        assert!(
            (first..SCALE_MU_N).contains(&last),
            "--last-free L: a cosine node from --first-free to {}",
            SCALE_MU_N - 1
        );
        let free: Vec<usize> = (first..=last).collect();
        let (np, nf) = (mus.len(), free.len());
        if args.iter().any(|a| a == "--sheet") {
            assert!(
                low_only != args.iter().any(|a| a == "--main-only") && only.is_none(),
                "--sheet fits one block: with --low-only or --main-only, without --only"
            );
            let top = Top {
                from: &from,
                from_path: &from_path,
                mus: &mus,
                n_nodes: nodes.len(),
                free: &free,
                q,
                quad,
                lawson,
                node_weight,
                threads,
            };
            return scale_top_sheet(args, &top, &out, dry, t0);
        }
        // Node materials: (NDF, low block, roughness node, index node).
        let mut jobs: Vec<(usize, bool, usize, usize)> = Vec::new();
        for n in 0..NDF_N {
            for a in 0..SCALE_LOW_ALPHA_N {
                for e in 0..SCALE_LOW_ETA_N {
                    jobs.push((n, true, a, e));
                }
            }
            if !low_only {
                for a in 0..SCALE_ALPHA_N {
                    for e in SCALE_LOW_ETA_N - 1..SCALE_ETA_N {
                        jobs.push((n, false, a, e));
                    }
                }
            }
        }
        if let Some(o) = only {
            jobs.retain(|&(n, _, a, e)| (n, a, e) == o);
            assert!(
                !jobs.is_empty(),
                "--only N,A,E: no such node (roughness nodes: {SCALE_LOW_ALPHA_N} in the low-index block, {SCALE_ALPHA_N} in the main; index nodes 0-{} and {}-{})",
                SCALE_LOW_ETA_N - 1,
                SCALE_LOW_ETA_N - 1,
                SCALE_ETA_N - 1
            );
        }
        println!(
            "{} node materials, free cosine nodes {first}-{} (from {:.2} degrees), {np} points per side",
            jobs.len(),
            SCALE_MU_N - 1,
            scale_grid_mu(first).acos().to_degrees()
        );
        // Per material: the new steps of the free nodes (side-major) and the
        // worst error before and after (linearised).
        let res = parallel(&jobs, "top fit", threads, |_, &(n, low, a, e)| {
            let alpha = if low {
                scale_low_grid_alpha(a)
            } else {
                scale_grid_alpha(a)
            };
            let eta = scale_grid_eta(e);
            let idx = |sd: usize, i: usize| scale_index(n, low, a, e, sd, i);
            let s: Vec<f64> = (0..2 * SCALE_MU_N)
                .map(|x| {
                    table_step(&from, idx(x / SCALE_MU_N, x % SCALE_MU_N)) as f64
                        * SCALE_STEP as f64
                })
                .collect();
            let ndf = Ndf::new(NDFS[n], alpha, alpha);
            let tab = TabulatedDielectric::new(ndf, Facet::Dielectric { eta });
            let m = lobe_rows_at(&tab, alpha, q, SCALE_MU_N, &mus, lib_basis);
            // Residuals and their derivatives in the free nodes, row (sd, p).
            let mut r = vec![0.0f64; 2 * np];
            let mut jac = vec![vec![0.0f64; 2 * nf]; 2 * np];
            for sd in 0..2 {
                let eta_rel = if sd == 1 { 1.0 / eta } else { eta };
                for (p, &mu) in mus.iter().enumerate() {
                    let row = &m[sd * np + p];
                    let inner: f64 = (0..2 * SCALE_MU_N).map(|y| row[y] * s[y]).sum();
                    let b = lib_basis(mu);
                    let sp: f64 = b.iter().map(|&(y, w)| s[sd * SCALE_MU_N + y] * w).sum();
                    let target = (1.0 - ess(ndf, eta_rel, dir(mu.max(1e-3)), quad)).max(0.0);
                    // Rows of node points scaled by `--node-weight`.
                    let f = if p < nodes.len() { node_weight } else { 1.0 };
                    r[sd * np + p] = f * (sp * inner - target);
                    for su in 0..2 {
                        for (u, &k) in free.iter().enumerate() {
                            let own: f64 = if su == sd {
                                b.iter().filter(|bw| bw.0 == k).map(|bw| bw.1).sum()
                            } else {
                                0.0
                            };
                            jac[sd * np + p][su * nf + u] =
                                f * (own * inner + sp * row[su * SCALE_MU_N + k]);
                        }
                    }
                }
            }
            let worst = |d: &[f64]| -> f64 {
                (0..2 * np)
                    .map(|x| (r[x] + (0..2 * nf).map(|u| jac[x][u] * d[u]).sum::<f64>()).abs())
                    .fold(0.0, f64::max)
            };
            let before = worst(&vec![0.0; 2 * nf]);
            // Lawson: weighted least squares, the weights times the
            // residuals' sizes after each step.
            let mut w = vec![1.0f64; 2 * np];
            let mut best = (before, vec![0.0f64; 2 * nf]);
            for _ in 0..=lawson {
                let nu = 2 * nf;
                let mut ata = vec![0.0f64; nu * nu];
                let mut atb = vec![0.0f64; nu];
                for x in 0..2 * np {
                    for u in 0..nu {
                        atb[u] -= w[x] * jac[x][u] * r[x];
                        for v in 0..nu {
                            ata[u * nu + v] += w[x] * jac[x][u] * jac[x][v];
                        }
                    }
                }
                // A small ridge keeps a node the errors do not see (a zero
                // scale, no lobe) where it is.
                let tr: f64 = (0..nu).map(|u| ata[u * nu + u]).sum::<f64>() / nu as f64;
                for u in 0..nu {
                    ata[u * nu + u] += 1e-6 * tr.max(1e-30);
                }
                let Some(d) = cholesky_solve(ata, atb) else {
                    break;
                };
                let wd = worst(&d);
                if wd < best.0 {
                    best = (wd, d.clone());
                }
                let sum: f64 = (0..2 * np)
                    .map(|x| {
                        let e = (r[x] + (0..2 * nf).map(|u| jac[x][u] * d[u]).sum::<f64>()).abs();
                        w[x] *= e;
                        w[x]
                    })
                    .sum();
                if sum <= 0.0 {
                    break;
                }
                w.iter_mut().for_each(|v| *v /= sum);
            }
            let steps: Vec<u16> = (0..2 * nf)
                .map(|u| {
                    let (sd, k) = (u / nf, free[u % nf]);
                    let v = (s[sd * SCALE_MU_N + k] + best.1[u]).clamp(0.0, SCALE_MAX as f64);
                    if s[sd * SCALE_MU_N + k] == 0.0 {
                        // A zero scale (`E_ss` = 1) stays zero.
                        0
                    } else {
                        scale_steps(v)
                    }
                })
                .collect();
            (steps, before, best.0, alpha, eta)
        });
        let mut scale: Vec<u16> = (0..SCALE_LEN).map(|i| table_step(&from, i)).collect();
        let (mut wb, mut wa) = ((0.0f64, String::new()), (0.0f64, String::new()));
        let mut changed = 0usize;
        for (&(n, low, a, e), (steps, before, after, alpha, eta)) in jobs.iter().zip(&res) {
            let name = format!(
                "{} {alpha:.4} glass {eta:.4} ({} block, nodes {a}, {e})",
                ["Beckmann", "GGX"][n],
                if low { "low-index" } else { "main" }
            );
            println!(
                "{name}: worst {:.4}% -> {:.4}%",
                100.0 * before,
                100.0 * after
            );
            if *before > wb.0 {
                wb = (*before, name.clone());
            }
            if *after > wa.0 {
                wa = (*after, name);
            }
            for (u, &q) in steps.iter().enumerate() {
                let i = scale_index(n, low, a, e, u / nf, free[u % nf]);
                changed += usize::from(scale[i] != q);
                scale[i] = q;
            }
        }
        println!(
            "worst over the materials' points: {:.4}% ({}) -> {:.4}% ({}, linearised); {changed} values changed",
            100.0 * wb.0,
            wb.1,
            100.0 * wa.0,
            wa.1
        );
        if dry {
            return;
        }
        let from_head = nested_header(&from);
        let head = format!(
            "{}\
             MSBSDF_MODEL_TABULATED dielectric furnace scales (layout: src/multiple/tabulated_dielectric.rs), the nodes near the normal refitted along the cosine\n\
             command: cargo run --release --example gen_tabulated -- {}\n\
             commit: {}\n\
             top: cosine nodes {first} to {} (from {:.2} degrees) of {} node materials refitted (minimax by Lawson's rule, {lawson} reweightings, on the linearised furnace errors at the nodes and eighths of cosine elements {elem0} to {}, both sides; quadrature --broad {} as --dielectric-scale, E_ss {quad} x {quad}); worst over those points {:.4}% -> {:.4}% (linearised), {changed} values changed; wall time {:.0} s on {threads} threads; the rest from {from_path}, whose header follows\n\
             {from_head}",
            String::from_utf8_lossy(SCALE_MAGIC),
            args[1..].join(" "),
            git::commit(),
            SCALE_MU_N - 1,
            scale_grid_mu(first).acos().to_degrees(),
            jobs.len(),
            (SCALE_MU_N - 1) / 2 - 1,
            q.broad,
            100.0 * wb.0,
            100.0 * wa.0,
            t0.elapsed().as_secs_f64(),
        );
        write_scale_table(&out, &head, &scale);
    }

    /// What `--dielectric-scale-top` passes to [`scale_top_sheet`]: the
    /// table read, the points' cosines (the nodes first, `n_nodes` of
    /// them), the free cosine nodes and the fit's settings.
    struct Top<'a> {
        from: &'a [u8],
        from_path: &'a str,
        mus: &'a [f32],
        n_nodes: usize,
        free: &'a [usize],
        q: Quadrature,
        quad: usize,
        lawson: usize,
        node_weight: f64,
        threads: usize,
    }

    /// `--dielectric-scale-top --low-only --sheet [--from-alpha A]`: the
    /// free cosine nodes of the low-index block refitted jointly over its
    /// whole sheet per NDF (roughness nodes from `A`, default 0.4, up;
    /// the rest keep their values; `--main-only [--to-eta E]` instead:
    /// the main block's, its index nodes up to `E`), with the furnace read, as in
    /// [`scale_top_main`], at the nodes and eighths of the free elements,
    /// both sides, of the node materials and of the materials between
    /// them: the midpoints of the roughness intervals (in `sqrt(alpha)`),
    /// of the index intervals (at `sqrt(E_e E_e+1)`) and of both (the
    /// triangles' diagonals), each with the scales interpolated over its
    /// triangle as eval reads them (`scale_corners`). Eval's error between
    /// nodes is the cosine interpolation's and the roughness and index
    /// interpolation's together, and a fit of each node material alone
    /// trades at the nodes what adds to the latter (Beckmann 1.9 glass
    /// 1.095 from inside at the normal, -0.60%). The linearised errors'
    /// weighted least squares is one dense system per NDF (Cholesky),
    /// reweighted `--lawson` times by Lawson's rule.
    fn scale_top_sheet(args: &[String], top: &Top, out: &str, dry: bool, t0: std::time::Instant) {
        use msbsdf::multiple::tabulated_dielectric::{
            SCALE_ALPHA_N, SCALE_ETA_N, SCALE_LEN, SCALE_LOW_ALPHA_N, SCALE_LOW_ETA_N, SCALE_MAX,
            SCALE_MU_N, TabulatedDielectric, scale_corners, scale_grid_alpha, scale_grid_eta,
            scale_grid_mu, scale_index, scale_low_grid_alpha,
        };
        let from_alpha: f32 = arg(args, "--from-alpha", 0.4);
        // `--main-only`: the main block, its index nodes up to `--to-eta`.
        let main = args.iter().any(|a| a == "--main-only");
        let to_eta: f32 = arg(args, "--to-eta", 3.0);
        let block = if main {
            "main block"
        } else {
            "low-index block"
        };
        let (np, nf) = (top.mus.len(), top.free.len());
        let na = if main {
            SCALE_ALPHA_N
        } else {
            SCALE_LOW_ALPHA_N
        };
        let grid_a = |a: usize| {
            if main {
                scale_grid_alpha(a) as f64
            } else {
                scale_low_grid_alpha(a) as f64
            }
        };
        let (e_lo, e_hi) = if main {
            let hi = (SCALE_LOW_ETA_N - 1..SCALE_ETA_N)
                .filter(|&e| scale_grid_eta(e) <= to_eta * 1.0001)
                .max()
                .expect("--to-eta E: at least the main block's first index node");
            (SCALE_LOW_ETA_N - 1, hi)
        } else {
            (0, SCALE_LOW_ETA_N - 1)
        };
        let ne = e_hi - e_lo + 1;
        let a_first = (0..na)
            .find(|&a| grid_a(a) >= from_alpha as f64)
            .expect("--from-alpha A: at most the largest roughness");
        let grid_e = |e: usize| scale_grid_eta(e) as f64;
        // Materials `(kind, NDF, alpha, eta)`: kind 0 node, 1 roughness
        // midpoint, 2 index midpoint, 3 both.
        let mut mats: Vec<(usize, usize, f32, f32)> = Vec::new();
        for n in 0..NDF_N {
            for a in a_first.saturating_sub(1)..na {
                for e in e_lo..=e_hi {
                    if a >= a_first {
                        mats.push((0, n, grid_a(a) as f32, grid_e(e) as f32));
                    }
                    let am = (a + 1 < na)
                        .then(|| ((grid_a(a).sqrt() + grid_a(a + 1).sqrt()) / 2.0).powi(2));
                    let em = (e < e_hi).then(|| (grid_e(e) * grid_e(e + 1)).sqrt());
                    if let Some(am) = am {
                        mats.push((1, n, am as f32, grid_e(e) as f32));
                    }
                    if let (Some(em), true) = (em, a >= a_first) {
                        mats.push((2, n, grid_a(a) as f32, em as f32));
                    }
                    if let (Some(am), Some(em)) = (am, em) {
                        mats.push((3, n, am as f32, em as f32));
                    }
                }
            }
        }
        // Unknown of (roughness node, index node, side, free node k).
        let unknowns = (na - a_first) * ne * 2 * nf;
        let unknown = |a: usize, e: usize, su: usize, kk: usize| -> Option<usize> {
            (a >= a_first && (e_lo..=e_hi).contains(&e))
                .then(|| (((a - a_first) * ne + e - e_lo) * 2 + su) * nf + kk)
        };
        let value = |n: usize, a: usize, e: usize, x: usize| -> f64 {
            table_step(
                top.from,
                scale_index(n, !main, a, e, x / SCALE_MU_N, x % SCALE_MU_N),
            ) as f64
                * SCALE_STEP as f64
        };
        println!(
            "sheet of the {block}: {} materials (roughness nodes {a_first}-{} free, from {:.3}; index nodes {e_lo}-{e_hi}), {unknowns} unknowns per NDF, {np} points per side",
            mats.len(),
            na - 1,
            grid_a(a_first)
        );
        // Per material: its corners (node, weight), and per point row the
        // error `r` and the derivatives `A[su][kk]` by a corner's free node
        // (times the corner's weight).
        type Rows = Vec<(f64, Vec<f64>)>;
        type Material = Option<(msbsdf::multiple::tabulated_dielectric::TriNodes, Rows)>;
        let res: Vec<Material> =
            parallel(&mats, "top sheet", top.threads, |_, &(_, n, alpha, eta)| {
                let (low, corners) = scale_corners(alpha, eta);
                if low == main {
                    return None;
                }
                let s: Vec<f64> = (0..2 * SCALE_MU_N)
                    .map(|x| {
                        corners
                            .iter()
                            .map(|&((a, e), w)| w as f64 * value(n, a, e, x))
                            .sum()
                    })
                    .collect();
                let ndf = Ndf::new(NDFS[n], alpha, alpha);
                let tab = TabulatedDielectric::new(ndf, Facet::Dielectric { eta });
                let m = lobe_rows_at(&tab, alpha, top.q, SCALE_MU_N, top.mus, lib_basis);
                let mut rows: Rows = Vec::with_capacity(2 * np);
                for sd in 0..2 {
                    let eta_rel = if sd == 1 { 1.0 / eta } else { eta };
                    for (p, &mu) in top.mus.iter().enumerate() {
                        let f = if p < top.n_nodes {
                            top.node_weight
                        } else {
                            1.0
                        };
                        let row = &m[sd * np + p];
                        let inner: f64 = (0..2 * SCALE_MU_N).map(|y| row[y] * s[y]).sum();
                        let b = lib_basis(mu);
                        let sp: f64 = b.iter().map(|&(y, w)| s[sd * SCALE_MU_N + y] * w).sum();
                        let target =
                            (1.0 - ess(ndf, eta_rel, dir(mu.max(1e-3)), top.quad)).max(0.0);
                        let d: Vec<f64> = (0..2 * nf)
                            .map(|u| {
                                let (su, k) = (u / nf, top.free[u % nf]);
                                let own: f64 = if su == sd {
                                    b.iter().filter(|bw| bw.0 == k).map(|bw| bw.1).sum()
                                } else {
                                    0.0
                                };
                                f * (own * inner + sp * row[su * SCALE_MU_N + k])
                            })
                            .collect();
                        rows.push((f * (sp * inner - target), d));
                    }
                }
                Some((corners, rows))
            });
        let mut scale: Vec<u16> = (0..SCALE_LEN).map(|i| table_step(top.from, i)).collect();
        let mut summary = String::new();
        let mut changed = 0usize;
        for n in 0..NDF_N {
            // The rows of this NDF as (error, [(unknown, derivative)]).
            // (error, derivatives by unknown, material kind)
            type Row = (f64, Vec<(usize, f64)>, usize);
            let mut sys: Vec<Row> = Vec::new();
            for (&(kind, mn, _, _), r) in mats.iter().zip(&res) {
                let Some((corners, rows)) = r else { continue };
                if mn != n {
                    continue;
                }
                for (r0, d) in rows {
                    let mut cols = Vec::new();
                    for &((a, e), w) in corners {
                        for (u, &dv) in d.iter().enumerate() {
                            let (su, kk) = (u / nf, u % nf);
                            // A zero scale (`E_ss` = 1) stays zero.
                            if value(n, a, e, su * SCALE_MU_N + top.free[kk]) == 0.0 {
                                continue;
                            }
                            if let Some(x) = unknown(a, e, su, kk) {
                                cols.push((x, w as f64 * dv));
                            }
                        }
                    }
                    sys.push((*r0, cols, kind));
                }
            }
            let worst_of = |d: &[f64]| -> [f64; 4] {
                let mut w = [0.0f64; 4];
                for (r0, cols, kind) in &sys {
                    let e = (r0 + cols.iter().map(|&(x, v)| v * d[x]).sum::<f64>()).abs();
                    w[*kind] = w[*kind].max(e);
                }
                w
            };
            let zero = vec![0.0f64; unknowns];
            let before = worst_of(&zero);
            let mut weights = vec![1.0f64; sys.len()];
            let mut best = (before.iter().fold(0.0f64, |a, &b| a.max(b)), zero.clone());
            for _ in 0..=top.lawson {
                let mut ata = vec![0.0f64; unknowns * unknowns];
                let mut atb = vec![0.0f64; unknowns];
                for ((r0, cols, _), &w) in sys.iter().zip(&weights) {
                    for &(x, vx) in cols {
                        atb[x] -= w * vx * r0;
                        for &(y, vy) in cols {
                            ata[x * unknowns + y] += w * vx * vy;
                        }
                    }
                }
                let tr: f64 =
                    (0..unknowns).map(|x| ata[x * unknowns + x]).sum::<f64>() / unknowns as f64;
                for x in 0..unknowns {
                    // A node no error sees keeps its value.
                    ata[x * unknowns + x] += 1e-6 * tr.max(1e-30);
                }
                let Some(d) = cholesky_solve(ata, atb) else {
                    break;
                };
                let wd = worst_of(&d).iter().fold(0.0f64, |a, &b| a.max(b));
                if wd < best.0 {
                    best = (wd, d.clone());
                }
                let mut sum = 0.0;
                for ((r0, cols, _), w) in sys.iter().zip(weights.iter_mut()) {
                    let e = (r0 + cols.iter().map(|&(x, v)| v * d[x]).sum::<f64>()).abs();
                    *w *= e;
                    sum += *w;
                }
                if sum <= 0.0 {
                    break;
                }
                weights.iter_mut().for_each(|w| *w /= sum);
            }
            let after = worst_of(&best.1);
            let line = format!(
                "{}: worst at nodes / roughness midpoints / index midpoints / both {} -> {} (linearised)",
                ["Beckmann", "GGX"][n],
                before.map(|v| format!("{:.4}%", 100.0 * v)).join(" / "),
                after.map(|v| format!("{:.4}%", 100.0 * v)).join(" / "),
            );
            println!("{line}");
            summary += &line;
            summary += "; ";
            for a in a_first..na {
                for e in e_lo..=e_hi {
                    for su in 0..2 {
                        for (kk, &k) in top.free.iter().enumerate() {
                            let x = su * SCALE_MU_N + k;
                            let v0 = value(n, a, e, x);
                            if v0 == 0.0 {
                                continue;
                            }
                            let Some(u) = unknown(a, e, su, kk) else {
                                continue;
                            };
                            let i = scale_index(n, !main, a, e, su, k);
                            let q = scale_steps((v0 + best.1[u]).clamp(0.0, SCALE_MAX as f64));
                            changed += usize::from(scale[i] != q);
                            scale[i] = q;
                        }
                    }
                }
            }
        }
        println!("{changed} values changed");
        if dry {
            return;
        }
        let from_head = nested_header(top.from);
        let head = format!(
            "{}\
             MSBSDF_MODEL_TABULATED dielectric furnace scales (layout: src/multiple/tabulated_dielectric.rs), the {block}'s nodes near the normal refitted along the cosine over its sheet\n\
             command: cargo run --release --example gen_tabulated -- {}\n\
             commit: {}\n\
             top sheet: cosine nodes {} to {} (from {:.2} degrees) of the {block}'s roughness nodes {a_first} to {} and index nodes {e_lo} to {e_hi} refitted per NDF (minimax by Lawson's rule, {} reweightings, node errors weighted {}, on the linearised furnace errors at the nodes and eighths of the free elements, both sides, of {} materials: the nodes and the midpoints of the roughness and index intervals and of both; quadrature --broad {} as --dielectric-scale, E_ss {} x {}); {summary}{changed} values changed; wall time {:.0} s on {} threads; the rest from {}, whose header follows\n\
             {from_head}",
            String::from_utf8_lossy(SCALE_MAGIC),
            args[1..].join(" "),
            git::commit(),
            top.free[0],
            top.free[nf - 1],
            scale_grid_mu(top.free[0]).acos().to_degrees(),
            na - 1,
            top.lawson,
            top.node_weight,
            mats.len(),
            top.q.broad,
            top.quad,
            top.quad,
            t0.elapsed().as_secs_f64(),
            top.threads,
            top.from_path,
        );
        write_scale_table(out, &head, &scale);
    }

    /// The solution of `a x = b` for a symmetric positive definite `a`
    /// (`n x n`, row-major) by Cholesky's factorisation (`None` if it is
    /// not positive definite).
    fn cholesky_solve(mut a: Vec<f64>, mut b: Vec<f64>) -> Option<Vec<f64>> {
        let n = b.len();
        // Lower factor L stored in the lower triangle (row-major).
        for j in 0..n {
            let mut d = a[j * n + j];
            for k in 0..j {
                d -= a[j * n + k] * a[j * n + k];
            }
            if d <= 0.0 || !d.is_finite() {
                return None;
            }
            let d = d.sqrt();
            a[j * n + j] = d;
            for i in j + 1..n {
                let mut v = a[i * n + j];
                let (ri, rj) = (i * n, j * n);
                for k in 0..j {
                    v -= a[ri + k] * a[rj + k];
                }
                a[i * n + j] = v / d;
            }
        }
        for i in 0..n {
            let s: f64 = (0..i).map(|k| a[i * n + k] * b[k]).sum();
            b[i] = (b[i] - s) / a[i * n + i];
        }
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|k| a[k * n + i] * b[k]).sum();
            b[i] = (b[i] - s) / a[i * n + i];
        }
        Some(b)
    }

    /// How versions 2 and 3 of the scale table store the scales (a header
    /// line).
    const SCALE_STORAGE: &str = "storage: little-endian u16 q per scale, s = q * SCALE_STEP \
        (4 / 65535; s / SCALE_STEP rounded to nearest)";

    /// The stored 16-bit value of a furnace scale `s` in `[0, SCALE_MAX]`:
    /// `s / SCALE_STEP` rounded to the nearest integer (within half a step,
    /// 3.1e-5).
    fn scale_steps(s: f64) -> u16 {
        let q = (s / SCALE_STEP as f64).round();
        assert!((0.0..=65535.0).contains(&q), "scale {s} outside [0, 4]");
        q as u16
    }

    /// Mean of two estimates weighted by the (hat-weighted) numbers of
    /// exits behind them (their inverse variances, up to a common factor).
    fn mean_by_counts(x: f64, cx: f64, y: f64, cy: f64) -> f64 {
        if cx + cy > 0.0 {
            (x * cx + y * cy) / (cx + cy)
        } else {
            0.5 * (x + y)
        }
    }

    pub fn main(args: &[String]) {
        let walks: u64 = arg(args, "--walks", 200_000);
        let quad: usize = arg(args, "--quad", 192);
        let gram: u64 = arg(args, "--gram-samples", 100_000);
        let threads: usize = arg(args, "--threads", 2);
        let out: String = arg(args, "--out", "data/tabulated_dielectric.bin".to_string());
        let t0 = std::time::Instant::now();
        // Jobs: (ndf, alpha node >= 1, eta node, side, mu_i node).
        // `--only-ndf N --only-alpha A` restrict the jobs (pilots).
        let only_ndf: usize = arg(args, "--only-ndf", usize::MAX);
        let only_alpha: usize = arg(args, "--only-alpha", usize::MAX);
        let verbose = args.iter().any(|a| a == "--verbose");
        let jobs: Vec<(usize, usize, usize, usize, usize)> = (0..NDF_N)
            .filter(|&n| only_ndf == usize::MAX || n == only_ndf)
            .flat_map(|n| {
                (1..ALPHA_N)
                    .filter(move |&a| only_alpha == usize::MAX || a == only_alpha)
                    .flat_map(move |a| {
                        (0..ETA_N).flat_map(move |e| {
                            (0..2).flat_map(move |sd| (0..MU_N).map(move |i| (n, a, e, sd, i)))
                        })
                    })
            })
            .collect();
        // `--dump PATH` saves the raw sums, `--from-dump PATH` redoes the
        // post-processing from them without the walks (same job arguments).
        let opt = |name: &str| {
            args.iter()
                .position(|a| a == name)
                .and_then(|p| args.get(p + 1).cloned())
        };
        let sums = match opt("--from-dump") {
            Some(path) => load_dump(&path, jobs.len()),
            None => parallel(
                &jobs,
                "dielectric walks",
                threads,
                |idx, &(n, a, e, sd, i)| {
                    job(
                        n,
                        grid_alpha(a),
                        grid_eta(e),
                        sd == 1,
                        node_mu(i),
                        walks,
                        quad,
                        gram,
                        idx as u64,
                    )
                },
            ),
        };
        if let Some(path) = opt("--dump") {
            save_dump(&path, &sums);
        }
        let empty = Sums {
            walks: 1,
            r: [[0.0; K_FIT]; MU_N],
            t: [[0.0; K]; MU_N],
            peak: [[0.0; 1]; MU_N],
            gram_kb: vec![[0.0; K_FIT]; MU_N],
            gram_bb: vec![0.0; MU_N],
            ms: [0.0; 2],
            ess: 1.0,
        };
        let find = |n, a, e, sd, i| match jobs.iter().position(|&x| x == (n, a, e, sd, i)) {
            Some(p) => &sums[p],
            None => &empty,
        };
        let h: Vec<f64> = (0..MU_N).map(hat_moment).collect();
        let gkk = |j: usize, k: usize| h[j] * if k == 0 { 2.0 * PI } else { PI };
        let w: Vec<f64> = h.iter().map(|x| 2.0 * PI * x).collect();
        let mut lobe = vec![0.0f64; FULL_LOBE_LEN];
        let mut albedo = vec![0.0f64; ALBEDO_LEN];
        let (mut sym_num, mut sym_den) = (0.0f64, 0.0f64);
        let (mut t_num, mut t_den) = (0.0f64, 0.0f64);
        let (mut mc_worst, mut norm_worst, mut walk_worst) = (0.0f64, 0.0f64, 0.0f64);
        let mut total_walks = 0u64;
        for n in 0..NDF_N {
            for a in 1..ALPHA_N {
                for e in 0..ETA_N {
                    let e2 = (grid_eta(e) as f64).powi(2);
                    let li = |l: usize, i: usize, j: usize| full_index(n, a, e, l, i, j);
                    for i in 0..MU_N {
                        let (thin, dense) = (find(n, a, e, 0, i), find(n, a, e, 1, i));
                        total_walks += thin.walks + dense.walks;
                        for j in 0..MU_N {
                            // Reflection: R_TERMS cosine terms and the peaked weight.
                            for (l, sm) in [(R_THIN, thin), (R_DENSE, dense)] {
                                let (coef, bpk) = fit_node(
                                    &sm.r[j],
                                    sm.walks as f64,
                                    sm.peak[j][0],
                                    &sm.gram_kb[j],
                                    sm.gram_bb[j],
                                    h[j],
                                );
                                let b = li(l, i, j);
                                lobe[b..b + R_TERMS].copy_from_slice(&coef[..R_TERMS]);
                                lobe[b + PEAK] = bpk;
                            }
                            for k in 0..K {
                                let nt = thin.walks as f64;
                                // T(thin i -> dense j): directly, and from the
                                // dense walks at j by f(i, j) = E^2 f(j -> i).
                                let direct = thin.t[j][k] / (nt * gkk(j, k));
                                let dj = find(n, a, e, 1, j);
                                let rev = e2 * dj.t[i][k] / (dj.walks as f64 * gkk(i, k));
                                if k == 0 {
                                    t_num += (direct - rev).powi(2);
                                    t_den += (0.5 * (direct + rev)).powi(2);
                                }
                                // Inverse-variance weights: the hat-weighted
                                // counts of exits behind each estimate.
                                lobe[li(T_THIN, i, j) + k] =
                                    mean_by_counts(direct, thin.t[j][0], rev, dj.t[i][0]);
                            }
                            // At mu = 1 the azimuth is undefined: no cosine
                            // terms k >= 1 (the peaked weight stays).
                            if i == MU_N - 1 || j == MU_N - 1 {
                                for (l, terms) in
                                    [(R_THIN, R_TERMS), (R_DENSE, R_TERMS), (T_THIN, K)]
                                {
                                    for k in 1..terms {
                                        lobe[li(l, i, j) + k] = 0.0;
                                    }
                                }
                            }
                        }
                        for (sd, s) in [(0, thin), (1, dense)] {
                            let got = (s.ms[0] + s.ms[1]) / s.walks as f64;
                            let want = 1.0 - s.ess;
                            if want > 1e-3 {
                                walk_worst = walk_worst.max((got / want - 1.0).abs());
                            }
                            if verbose && s.walks > 1 {
                                eprintln!(
                                    "ndf {n} alpha {:.3} eta {:.3} side {sd} mu {:.4}: walk MS albedo R {:.5} T {:.5} sum {:.5} vs 1 - E_ss {:.5}",
                                    grid_alpha(a),
                                    grid_eta(e),
                                    node_mu(i),
                                    s.ms[0] / s.walks as f64,
                                    s.ms[1] / s.walks as f64,
                                    got,
                                    want
                                );
                            }
                        }
                    }
                    // Reflection lobes: average with the transposes.
                    for l in [R_THIN, R_DENSE] {
                        for i in 0..MU_N {
                            for j in i + 1..MU_N {
                                let (x, y) = (lobe[li(l, i, j)], lobe[li(l, j, i)]);
                                sym_num += (x - y).powi(2);
                                sym_den += (0.5 * (x + y)).powi(2);
                                let sd = (l == R_DENSE) as usize;
                                let (ci, cj) =
                                    (find(n, a, e, sd, i).r[j][0], find(n, a, e, sd, j).r[i][0]);
                                for k in 0..R_CELL {
                                    let v = mean_by_counts(
                                        lobe[li(l, i, j) + k],
                                        ci,
                                        lobe[li(l, j, i) + k],
                                        cj,
                                    );
                                    lobe[li(l, i, j) + k] = v;
                                    lobe[li(l, j, i) + k] = v;
                                }
                            }
                        }
                    }
                    // Furnace: nodes 0..MU_N thin, MU_N..2 MU_N dense. The
                    // albedo of a cell: c_0 w_j, plus B Q_ij for reflection
                    // (Q_ij = int hat_j f_ss1 mu dw from wi = mu_i).
                    let m = |lobe: &[f64], x: usize, y: usize| -> f64 {
                        let (xi, yi) = (x % MU_N, y % MU_N);
                        let refl = |l: usize, sd: usize| {
                            let b = li(l, xi, yi);
                            let q = find(n, a, e, sd, xi).gram_kb[yi][0];
                            lobe[b] * w[yi] + lobe[b + PEAK] * q
                        };
                        match (x < MU_N, y < MU_N) {
                            (true, true) => refl(R_THIN, 0),
                            (false, false) => refl(R_DENSE, 1),
                            (true, false) => lobe[li(T_THIN, xi, yi)] * w[yi],
                            (false, true) => lobe[li(T_THIN, yi, xi)] / e2 * w[yi],
                        }
                    };
                    let target: Vec<f64> = (0..2 * MU_N)
                        .map(|x| (1.0 - find(n, a, e, x / MU_N, x % MU_N).ess).max(0.0))
                        .collect();
                    for (x, t) in target.iter().enumerate() {
                        let r: f64 = (0..2 * MU_N).map(|y| m(&lobe, x, y)).sum();
                        if *t > 1e-3 {
                            mc_worst = mc_worst.max((r / t - 1.0).abs());
                        }
                    }
                    let sc = sinkhorn(&target, |x, y| m(&lobe, x, y));
                    for i in 0..MU_N {
                        for j in 0..MU_N {
                            let fac = [
                                (R_THIN, sc[i] * sc[j]),
                                (R_DENSE, sc[MU_N + i] * sc[MU_N + j]),
                                (T_THIN, sc[i] * sc[MU_N + j]),
                            ];
                            for (l, f) in fac {
                                let width = if l == T_THIN { K } else { R_CELL };
                                for k in 0..width {
                                    lobe[li(l, i, j) + k] *= f;
                                }
                            }
                        }
                    }
                    for (x, t) in target.iter().enumerate() {
                        let (sd, i) = (x / MU_N, x % MU_N);
                        let rr: f64 = (0..MU_N).map(|y| m(&lobe, x, sd * MU_N + y)).sum();
                        let tt: f64 = (0..MU_N).map(|y| m(&lobe, x, (1 - sd) * MU_N + y)).sum();
                        albedo[albedo_index(n, a, e, sd, 0, i)] = rr;
                        albedo[albedo_index(n, a, e, sd, 1, i)] = tt;
                        if *t > 1e-4 {
                            norm_worst = norm_worst.max(((rr + tt) / t - 1.0).abs());
                        }
                    }
                }
            }
        }
        let header = format!(
            "{}\
             MSBSDF_MODEL_TABULATED dielectric table (layout: src/multiple/tabulated_dielectric.rs)\n\
             command: cargo run --release --example gen_tabulated -- {}\n\
             commit: {}\n\
             walks: HEITZ_RANDOM_WALK (library, default bounce limit, dielectric facets) {walks} per (ndf, alpha, eta, side, mu_i) node, {total_walks} in total; seed Rng::new({SEED}, stream = job index)\n\
             E_ss: SINGLE reflection + transmission quadrature {quad} x {quad} (compensation::single_albedo)\n\
             walk multiply scattered albedo vs 1 - E_ss: worst relative deviation {walk_worst:.3e} (targets > 1e-3)\n\
             reflection symmetrisation: RMS relative difference of f(i, j) and f(j, i) {:.3e}\n\
             transmission from both sides (f(thin i -> dense j) vs E^2 f(dense j -> thin i)): RMS relative difference {:.3e}\n\
             albedo before rescaling vs 1 - E_ss: worst relative deviation {mc_worst:.3e} (targets > 1e-3); after: {norm_worst:.3e}\n\
             peaked part of the reflection lobes: Gram entries by {gram} SINGLE (F = 1) samples per node (seed Rng::new({SEED_GRAM}, stream = job index)), ridge {RIDGE} x G_BB\n\
             {}grid: ndf {NDF_N} x alpha nodes 1 to {} of {ALPHA_N} (node 0, a smooth surface, is 0 and not stored) x eta {ETA_N} x lobe 3 x mu_i {MU_N} x mu_o {MU_N} (reflection: {R_TERMS} cosine terms of a {K_FIT}-term fit and the peaked weight; transmission: {K} cosine terms); albedos ndf x alpha x eta x side 2 x mu_i x lobe 2\n\
             wall time: {:.0} s on {threads} threads\n",
            String::from_utf8_lossy(MAGIC),
            args[1..].join(" "),
            git::commit(),
            (sym_num / sym_den.max(1e-300)).sqrt(),
            (t_num / t_den.max(1e-300)).sqrt(),
            match opt("--from-dump") {
                Some(p) => format!(
                    "walk sums: loaded from {p} (written with --dump by a run with the same walk arguments; that run took 1378 s of walks on 2 threads at commit 603e4846, whose walk and fitting code this commit keeps)\n"
                ),
                None => String::new(),
            },
            ALPHA_N - 1,
            t0.elapsed().as_secs_f64(),
        );
        let lobe: Vec<f32> = lobe.iter().map(|v| *v as f32).collect();
        let mut payload = lobe_bytes(&pack(&lobe));
        payload.extend(super::f32_bytes(albedo.iter().map(|v| *v as f32)));
        payload.extend(super::f32_bytes(std::iter::repeat_n(1.0, NORM_LEN)));
        super::write_bytes(
            &out,
            &format!("{header}{PACKED}\n{LOBE_STORAGE}\n{UNNORMALISED}\n"),
            MAGIC,
            HEADER_BYTES,
            FILE_BYTES,
            &payload,
        );
    }

    /// The normalisation block of a table the walks (or a conversion)
    /// just wrote (a header line).
    const UNNORMALISED: &str = "normalisation: every factor 1 (the walk's lobes as they are; \
        gen_tabulated -- --dielectric-normalize, run with this table compiled in, normalises them)";

    /// How version 4 stores the lobe values (a header line).
    const LOBE_STORAGE: &str = "storage: lobe values as 24-bit floats, 3 little-endian bytes \
        each (the f32 bits rounded to nearest at the 16-bit significand, (bits + 0x80) >> 8, \
        tabulated_dielectric::lobe_encode; read as the little-endian u32 at the value's byte \
        shifted left by 8 bits, lobe_decode), albedos little-endian f32";

    /// The stored bytes of the lobe block `values` (`lobe_encode`,
    /// [`LOBE_BYTES`] each); panics on a value that is not finite or
    /// rounds to infinity, and unless every stored value is within half
    /// its step of the f32 (below 2^-16 relative; the worst difference is
    /// printed).
    fn lobe_bytes(values: &[f32]) -> Vec<u8> {
        let (mut worst, mut at) = (0.0f64, 0);
        let mut out = Vec::with_capacity(LOBE_BYTES * values.len());
        for (i, &v) in values.iter().enumerate() {
            let b = lobe_encode(v)
                .unwrap_or_else(|| panic!("lobe value {i} ({v:e}) is not finite as 24 bits"));
            let d = lobe_decode([b[0], b[1], b[2], 0]) as f64;
            let (v, tiny) = (v as f64, v.abs() < f32::MIN_POSITIVE);
            // Half a step: 2^-16 of the value's power of two, 2^-142 for
            // subnormals.
            if tiny {
                assert!(
                    (d - v).abs() <= 2f64.powi(-142),
                    "value {i}: {v:e} -> {d:e}"
                );
            } else if (d / v - 1.0).abs() > worst {
                (worst, at) = ((d / v - 1.0).abs(), i);
            }
            out.extend(b);
        }
        eprintln!(
            "24-bit lobe values: worst relative difference from the f32 {worst:.4e} \
             ({:.5} x 2^-16; value {at}, {:e})",
            worst * 65536.0,
            values.get(at).copied().unwrap_or(0.0),
        );
        assert!(worst < 2f64.powi(-16), "a value off by half a step or more");
        out
    }

    /// Floats of a node in the generator's lobe layout: every `(mu_i,
    /// mu_o)` cell of each of the three lobes (the file's version 2). The
    /// file stores a reflection lobe's `i <= j` half only (`lobe_index`):
    /// the symmetrisation above makes the other half its transpose.
    const FULL_NODE_LEN: usize = MU_N * MU_N * (2 * R_CELL + K);
    /// Floats of the lobe block in the generator's layout.
    const FULL_LOBE_LEN: usize = NODES * FULL_NODE_LEN;
    /// How version 3 stores the lobes (a header line).
    const PACKED: &str = "layout: reflection lobes stored for mu_i node <= mu_o node only \
        (row by row; (j, i) reads (i, j), which the symmetrisation makes equal to the bit), \
        transmission lobe for every pair (tabulated_dielectric::lobe_index)";

    /// Index of a lobe cell in the generator's full layout.
    fn full_index(n: usize, a: usize, e: usize, l: usize, i: usize, j: usize) -> usize {
        let width = if l == T_THIN { K } else { R_CELL };
        node(n, a, e) * FULL_NODE_LEN + l * MU_N * MU_N * R_CELL + (i * MU_N + j) * width
    }

    /// The stored lobe block (`lobe_index`) of a lobe block in the full
    /// layout; panics unless every reflection cell equals its transpose
    /// to the bit (the half left out would differ).
    fn pack(full: &[f32]) -> Vec<f32> {
        assert_eq!(full.len(), FULL_LOBE_LEN);
        // A written flag per value, not a NaN marker: a table may hold NaN
        // (a short test run does), which would pass for an unwritten cell.
        let (mut out, mut written) = (vec![0.0f32; LOBE_LEN], vec![false; LOBE_LEN]);
        for n in 0..NDF_N {
            for a in 1..ALPHA_N {
                for e in 0..ETA_N {
                    for l in [R_THIN, R_DENSE, T_THIN] {
                        let width = if l == T_THIN { K } else { R_CELL };
                        for i in 0..MU_N {
                            for j in 0..MU_N {
                                let (src, dst) =
                                    (full_index(n, a, e, l, i, j), lobe_index(n, a, e, l, i, j));
                                for k in 0..width {
                                    let v = full[src + k];
                                    if l != T_THIN {
                                        let t = full[full_index(n, a, e, l, j, i) + k];
                                        assert_eq!(v.to_bits(), t.to_bits(), "lobe {l} ({i}, {j})");
                                    }
                                    out[dst + k] = v;
                                    written[dst + k] = true;
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(written.iter().all(|&w| w), "a stored cell left unwritten");
        out
    }

    /// `--dielectric-pack PATH`: rewrites a version-2 table (every cell of
    /// the reflection lobes stored) as the current version into `--out`:
    /// the reflection lobes' `i <= j` half (`pack`, version 3; every value
    /// version 2's, bit for bit) as 24-bit values ([`lobe_bytes`], version
    /// 4), its header kept with a line saying how it was converted.
    pub fn pack_main(args: &[String], rest: &[String]) {
        super::repack(
            args,
            rest,
            &super::Repack {
                flag: "--dielectric-pack",
                out: "data/tabulated_dielectric.bin",
                old_magic: b"MSBSDF-TABULATED-DIELECTRIC-v2\n",
                magic: MAGIC,
                file_bytes: FILE_BYTES,
                block_len: FULL_LOBE_LEN,
                rest_len: ALBEDO_LEN,
                layout: &format!("{PACKED}\n{LOBE_STORAGE}\n{UNNORMALISED}"),
                ones: NORM_LEN,
            },
            |full| lobe_bytes(&pack(full)),
        );
    }

    /// `--dielectric-lobe-pack PATH`: rewrites a version-3 table (f32 lobe
    /// values) as version 4 (24-bit lobe values, [`lobe_bytes`]) into
    /// `--out`, its header kept with a line saying how it was converted;
    /// the albedos are copied bit for bit.
    pub fn lobe_pack_main(args: &[String], rest: &[String]) {
        super::repack(
            args,
            rest,
            &super::Repack {
                flag: "--dielectric-lobe-pack",
                out: "data/tabulated_dielectric.bin",
                old_magic: b"MSBSDF-TABULATED-DIELECTRIC-v3\n",
                magic: MAGIC,
                file_bytes: FILE_BYTES,
                block_len: LOBE_LEN,
                rest_len: ALBEDO_LEN,
                layout: &format!("{LOBE_STORAGE}\n{UNNORMALISED}"),
                ones: NORM_LEN,
            },
            lobe_bytes,
        );
    }

    /// A suite material: name, NDF, roughness, index and its pairs
    /// `(wi, wo, reference)`.
    type SuiteGlass = (String, msbsdf::NdfId, f32, f32, f32, Vec<(Vec3, Vec3, f64)>);

    /// Relative RMS error `sqrt(sum (v - ref)^2 / sum ref^2)` of a list of
    /// `(value, reference)`.
    fn rel_rms(v: &[(f64, f64)]) -> f64 {
        let num: f64 = v.iter().map(|(x, r)| (x - r) * (x - r)).sum();
        let den: f64 = v.iter().map(|(_, r)| r * r).sum();
        (num / den.max(1e-300)).sqrt()
    }

    fn material(
        model: msbsdf::Model,
        ndf: msbsdf::NdfId,
        ax: f32,
        ay: f32,
        eta: f32,
    ) -> msbsdf::Material {
        let d = msbsdf::MaterialDesc {
            model,
            ndf,
            facet: msbsdf::FacetKind::Dielectric,
            alpha_x: ax,
            alpha_y: ay,
            eta: Vec3::splat(eta),
            ..Default::default()
        };
        msbsdf::Material::new(&d).expect("material")
    }

    /// `--dielectric-check`: the TABULATED dielectric against the suite's
    /// reference (`data/reference_values.csv`, class dielectric) and, outside
    /// the suite, against the library's HEITZ_RANDOM_WALK eval averaged over
    /// `--evals` evaluations (glass from inside, water, diamond, Beckmann,
    /// anisotropic roughness), relative RMS per lobe.
    pub fn check(args: &[String]) {
        use msbsdf::{Model, NdfId};
        let evals: u32 = arg(args, "--evals", 4000);
        let verbose = args.iter().any(|a| a == "--verbose");
        let only: String = arg(args, "--only", "inside".to_string());
        let only = only.as_str();
        let text = std::fs::read_to_string("data/reference_values.csv").expect("reference");
        // material -> (ndf, alpha, eta, pairs (wi, wo, ref))
        let mut mats: Vec<SuiteGlass> = Vec::new();
        for line in text.lines() {
            let c: Vec<&str> = line.split(',').collect();
            if line.starts_with('#') || c.len() != 25 || c[1] != "dielectric" {
                continue;
            }
            let f = |i: usize| c[i].parse::<f32>().unwrap_or(0.0);
            let ndf = if c[2] == "ggx" {
                NdfId::Ggx
            } else {
                NdfId::Beckmann
            };
            let pair = (
                Vec3::new(f(12), f(13), f(14)),
                Vec3::new(f(15), f(16), f(17)),
                c[18].parse::<f64>().unwrap_or(0.0),
            );
            match mats.last_mut() {
                Some(m) if m.0 == c[0] => m.5.push(pair),
                _ => mats.push((c[0].to_string(), ndf, f(3), f(4), f(5), vec![pair])),
            }
        }
        let mut rng = Rng::new(1, 1);
        let mut class = (0.0, 0.0, 0usize);
        for (name, ndf, ax, ay, eta, pairs) in &mats {
            let mut line = format!("suite {name}:");
            for model in [Model::Tabulated, Model::Single] {
                let m = material(model, *ndf, *ax, *ay, *eta);
                let mut all = Vec::new();
                let (mut r, mut t) = (Vec::new(), Vec::new());
                for &(wi, wo, rf) in pairs {
                    let v = m.eval(wi, wo, &mut rng).x as f64;
                    all.push((v, rf));
                    if wo.z > 0.0 {
                        r.push((v, rf))
                    } else {
                        t.push((v, rf))
                    }
                }
                let e = rel_rms(&all);
                if model == Model::Tabulated {
                    class.0 += e * e;
                    class.2 += 1;
                } else {
                    class.1 += e * e;
                }
                line += &format!(
                    " {model:?} {e:.4} (R {:.4}, T {:.4})",
                    rel_rms(&r),
                    rel_rms(&t)
                );
            }
            println!("{line}");
        }
        let k = class.2.max(1) as f64;
        println!(
            "suite dielectric class error (RMS over materials): TABULATED {:.4}, SINGLE {:.4}",
            (class.0 / k).sqrt(),
            (class.1 / k).sqrt()
        );
        // Outside the suite: (label, ndf, alpha_x, alpha_y, eta, from inside).
        let extra: f32 = arg(args, "--extra-eta", 0.0);
        let extra_label = format!("GGX eta {extra} a0.5 inside");
        let mut cases: Vec<(&str, NdfId, f32, f32, f32, bool)> = vec![
            ("GGX glass 1.5 a0.5 inside", NdfId::Ggx, 0.5, 0.5, 1.5, true),
            ("GGX glass 1.5 a1.0 inside", NdfId::Ggx, 1.0, 1.0, 1.5, true),
            ("GGX glass 1.5 a0.2 inside", NdfId::Ggx, 0.2, 0.2, 1.5, true),
            ("GGX water 1.33 a0.5", NdfId::Ggx, 0.5, 0.5, 1.33, false),
            (
                "GGX water 1.33 a0.5 inside",
                NdfId::Ggx,
                0.5,
                0.5,
                1.33,
                true,
            ),
            ("GGX diamond 2.42 a0.5", NdfId::Ggx, 0.5, 0.5, 2.42, false),
            (
                "GGX diamond 2.42 a0.5 inside",
                NdfId::Ggx,
                0.5,
                0.5,
                2.42,
                true,
            ),
            ("GGX glass 1.5 a0.3", NdfId::Ggx, 0.3, 0.3, 1.5, false),
            (
                "Beckmann glass 1.5 a0.5",
                NdfId::Beckmann,
                0.5,
                0.5,
                1.5,
                false,
            ),
            (
                "Beckmann glass 1.5 a1.0 inside",
                NdfId::Beckmann,
                1.0,
                1.0,
                1.5,
                true,
            ),
            (
                "GGX glass 1.5 aniso (0.1, 0.6)",
                NdfId::Ggx,
                0.1,
                0.6,
                1.5,
                false,
            ),
            (
                "GGX glass 1.5 aniso (0.3, 1.0) inside",
                NdfId::Ggx,
                0.3,
                1.0,
                1.5,
                true,
            ),
        ];
        if extra > 0.0 {
            cases.insert(0, (&extra_label, NdfId::Ggx, 0.5, 0.5, extra, true));
        }
        let only_cases = args.iter().any(|a| a == "--only-cases");
        println!(
            "outside the suite, against HEITZ_RANDOM_WALK x{evals} (relative RMS per lobe; SINGLE for comparison):"
        );
        for (label, ndf, ax, ay, eta, inside) in cases {
            if only_cases && !label.contains(only) {
                continue;
            }
            let tab = material(Model::Tabulated, ndf, ax, ay, eta);
            let single = material(Model::Single, ndf, ax, ay, eta);
            let walk = material(Model::HeitzRandomWalk, ndf, ax, ay, eta);
            let eta_rel = if inside { 1.0 / eta } else { eta };
            let (mut tr, mut tt, mut sr, mut st) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
            let mut se_max = 0.0f64;
            // Reference noise per lobe: sum se^2 (R, T).
            let mut noise = [0.0f64; 2];
            for (a, ti) in [0.0f32, 20.0, 40.0, 55.0, 70.0, 80.0, 85.0, 89.0]
                .iter()
                .enumerate()
            {
                let pi = 37.0 * a as f32;
                let sph = |t: f32, p: f32, up: bool| {
                    let (t, p) = (t.to_radians(), p.to_radians());
                    let z = t.cos();
                    Vec3::new(
                        t.sin() * p.cos(),
                        t.sin() * p.sin(),
                        if up { z } else { -z },
                    )
                };
                let flip = |v: Vec3| if inside { Vec3::new(v.x, v.y, -v.z) } else { v };
                let wi = flip(sph(*ti, pi, true));
                let back = pi + 180.0;
                let s = ti.to_radians().sin() / eta_rel;
                let tt_deg = if s < 1.0 { s.asin().to_degrees() } else { 75.0 };
                let outs = [
                    (sph(*ti, back, true), true),
                    (sph(50.0, pi + 90.0, true), true),
                    (sph(20.0, back + 10.0, true), true),
                    (sph(88.0, back, true), true),
                    (sph(tt_deg, back, false), false),
                    (sph((tt_deg + 12.0).min(89.0), back + 6.0, false), false),
                    (sph(60.0, pi, false), false),
                    (sph(87.0, back, false), false),
                ];
                for (wo, refl) in outs {
                    let wo = flip(wo);
                    let mut sum = 0.0f64;
                    let mut sum2 = 0.0f64;
                    for _ in 0..evals {
                        let v = walk.eval(wi, wo, &mut rng).x as f64;
                        sum += v;
                        sum2 += v * v;
                    }
                    let mean = sum / evals as f64;
                    let se = ((sum2 / evals as f64 - mean * mean).max(0.0) / evals as f64).sqrt();
                    if mean > 0.0 {
                        se_max = se_max.max(se / mean);
                    }
                    let vt = tab.eval(wi, wo, &mut rng).x as f64;
                    let vs = single.eval(wi, wo, &mut rng).x as f64;
                    noise[!refl as usize] += se * se;
                    if verbose && label.contains(only) {
                        eprintln!(
                            "    theta_i {ti} wo ({:.3}, {:.3}, {:.3}): walk {mean:.5} +- {se:.1e}, TABULATED {vt:.5}, SINGLE {vs:.5}",
                            wo.x, wo.y, wo.z
                        );
                    }
                    if refl {
                        tr.push((vt, mean));
                        sr.push((vs, mean));
                    } else {
                        tt.push((vt, mean));
                        st.push((vs, mean));
                    }
                }
            }
            let den = |v: &[(f64, f64)]| v.iter().map(|(_, r)| r * r).sum::<f64>().max(1e-300);
            println!(
                "  {label}: TABULATED R {:.4} T {:.4}; SINGLE R {:.4} T {:.4} (reference noise, relative RMS: R {:.4} T {:.4}; worst relative SE of one value {:.3})",
                rel_rms(&tr),
                rel_rms(&tt),
                rel_rms(&sr),
                rel_rms(&st),
                (noise[0] / den(&tr)).sqrt(),
                (noise[1] / den(&tt)).sqrt(),
                se_max
            );
        }
    }
}
