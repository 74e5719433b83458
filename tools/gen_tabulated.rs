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
//! albedo with F = 1 by quadrature). A small instrumented walk (the same
//! microsurface, validated against the library's through the table by
//! `tests/tabulated.rs`) records the cosines at which multiply scattered
//! paths meet facets; three equal-weight quantiles per (NDF, alpha) give the
//! effective Fresnel reflectance of coloured conductors.
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
    K_STORED, LOBE_LEN, MAGIC, MU_N, NDF_N, ORDER0, ORDERS, PEAK, SBAR_LEN, SCALE_ALPHA_N,
    SCALE_FILE_BYTES, SCALE_LEN, SCALE_MAGIC, SCALE_MU_N, albedo_index, alpha_coord, fresnel_index,
    grid_alpha, grid_mu, hat_moment, lobe_index, mu_coord, project_exit, scale_grid_alpha,
    scale_grid_mu, scale_index, split,
};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::single::{G2Form, Single};
use std::f64::consts::PI;
use std::io::Write as _;
use std::sync::atomic::{AtomicUsize, Ordering};

const NDFS: [NdfKind; NDF_N] = [NdfKind::Beckmann, NdfKind::Ggx];
const SEED_LOBE: u64 = 20261124;
const SEED_FRESNEL: u64 = 20261125;
const SEED_GRAM: u64 = 20261126;
const SEED_SCALE: u64 = 20261127;
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
    // Gram entries of the peaked basis function f_ss1 by sampling SINGLE
    // (visible normals, F = 1): f_ss1 |wo.z| / pdf = G2 / G1 <= 1.
    let mut grng = Rng::new(SEED_GRAM, stream);
    for _ in 0..gram {
        let smp = single.sample(wi, &mut grng);
        if smp.wo.z <= 0.0 || smp.pdf <= 0.0 {
            continue;
        }
        let ss1 = single.eval(wi, smp.wo, &mut zero).x as f64;
        let mut mom = [[0.0f64; K_FIT]; MU_N];
        project_exit(smp.wo, ss1 / smp.pdf as f64 / gram as f64, &mut mom);
        let f1 = ss1 / smp.wo.z as f64;
        for ((g, bb), m) in s.gram_kb.iter_mut().zip(s.gram_bb.iter_mut()).zip(&mom) {
            for (gk, mk) in g.iter_mut().zip(m) {
                *gk += mk;
            }
            *bb += m[0] * f1;
        }
    }
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
        let sxy = ((wo.x * wo.x + wo.y * wo.y) as f64).sqrt();
        let c = if sxy > 0.0 { wo.x as f64 / sxy } else { 1.0 };
        let x = mu_coord(wo.z) as f64;
        let j0 = (x as usize).min(MU_N - 2);
        let fr = x - j0 as f64;
        for (j, hw) in [(j0, 1.0 - fr), (j0 + 1, fr)] {
            let ww = w * hw;
            let m = &mut s.moments[j];
            let (mut t0, mut t1) = (1.0, c);
            m[0] += ww;
            m[1] += ww * c;
            for mk in m.iter_mut().skip(2) {
                let t2 = 2.0 * c * t1 - t0;
                *mk += ww * t2;
                (t0, t1) = (t1, t2);
            }
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

fn git_commit() -> String {
    let run = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_default()
    };
    let head = run(&["rev-parse", "HEAD"]);
    let dirty = !run(&["status", "--porcelain", "--untracked-files=no"]).is_empty();
    if dirty {
        format!("{head} (with uncommitted changes)")
    } else {
        head
    }
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
    let mut sbar = vec![0.0f32; SBAR_LEN];
    for (&(n, a, i), v) in sjobs.iter().zip(&schlick) {
        match i {
            Some(i) => first[albedo_index(n, a, i)] = *v as f32,
            None => sbar[n * ALPHA_N + a] = *v as f32,
        }
    }
    let mut scale = vec![1.0f32; SCALE_LEN];
    let (mut worst_before, mut worst_after, mut s_min, mut s_max) =
        (0.0f64, 0.0f64, 1.0f64, 1.0f64);
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
            let mut sc = vec![1.0f64; fine];
            for (i, t) in target.iter().enumerate() {
                let r: f64 = kernel[i].iter().sum();
                if *t > 1e-3 {
                    worst_before = worst_before.max((r / t - 1.0).abs());
                }
            }
            for _ in 0..300 {
                for i in 0..fine {
                    let cur: f64 = (0..fine).map(|y| kernel[i][y] * sc[i] * sc[y]).sum();
                    if cur > 0.0 && target[i] > 0.0 {
                        sc[i] *= (target[i] / cur).sqrt();
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
    let header = format!(
        "MSBSDF-TABULATED-SCALE-v1\n\
         MSBSDF_MODEL_TABULATED furnace scale table (layout: src/multiple/tabulated.rs)\n\
         command: cargo run --release --example gen_tabulated -- {}\n\
         commit: {}\n\
         lobe table: {table} ({table_commit})\n\
         E_ss: SINGLE quadrature 192 x 192; albedo of the peaked part: {samples} SINGLE samples per node, seed Rng::new({SEED_SCALE}, stream = job index)\n\
         albedo of the alpha-interpolated table vs 1 - E_ss: worst relative deviation {worst_before:.3e} (targets > 1e-3); after scaling {worst_after:.3e}; scales in [{s_min:.4}, {s_max:.4}]\n\
         grid: ndf {NDF_N} x alpha {SCALE_ALPHA_N} x mu {SCALE_MU_N}; then the Schlick weights (1 - c)^5 of multiply scattered paths: first facets per (ndf, alpha node, mu node), all facets per (ndf, alpha node); instrumented walk, {schlick_walks} walks per entry, seed Rng::new({SEED_SCHLICK}, stream = job index)\n\
         wall time: {:.0} s on {threads} threads\n",
        args[1..].join(" "),
        git_commit(),
        t0.elapsed().as_secs_f64(),
    );
    eprint!("{header}");
    let mut bytes = Vec::with_capacity(SCALE_FILE_BYTES);
    bytes.extend_from_slice(header.as_bytes());
    assert!(bytes.len() <= HEADER_BYTES, "header too long");
    assert!(bytes.starts_with(SCALE_MAGIC));
    bytes.resize(HEADER_BYTES, 0);
    for v in scale.iter().chain(&first).chain(&sbar) {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(bytes.len(), SCALE_FILE_BYTES);
    std::fs::write(&out, &bytes).expect("write output");
    eprintln!("wrote {out} ({} bytes)", bytes.len());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
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
    let mut lobe = vec![0.0f64; LOBE_LEN];
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
            let b = lobe_index(n, a, i, j);
            let m0 = s.moments[j][0];
            let nw = s.walks as f64;
            // Local least squares per mu_o node (inner product weighted by
            // hat_j mu_o): cosine terms (orthogonal, Gram H_j * norm_k) and
            // the peaked function f_ss1, eliminated by its Schur complement.
            let gkk = |k: usize| h[j] * if k == 0 { 2.0 * PI } else { PI };
            let (mut num, mut den) = (s.peak[j] / nw, s.gram_bb[j]);
            for k in 0..K_FIT {
                num -= s.gram_kb[j][k] * (s.moments[j][k] / nw) / gkk(k);
                den -= s.gram_kb[j][k] * s.gram_kb[j][k] / gkk(k);
            }
            // Capped so that the azimuth-averaged smooth part stays >= 0:
            // eval clamps the sum at 0, and a negative smooth part far from
            // the peak would be clamped away and break the normalisation.
            let cap = if s.gram_kb[j][0] > 0.0 {
                (s.moments[j][0] / nw / s.gram_kb[j][0]).max(0.0)
            } else {
                0.0
            };
            let bpk = if s.gram_bb[j] > 0.0 {
                (num / (den.max(0.0) + RIDGE * s.gram_bb[j])).clamp(0.0, cap)
            } else {
                0.0
            };
            for k in 0..K_STORED {
                lobe[b + k] = (s.moments[j][k] / nw - s.gram_kb[j][k] * bpk) / gkk(k);
            }
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
                    let (bi, bj) = (lobe_index(n, a, i, j), lobe_index(n, a, j, i));
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
                let b = lobe_index(n, a, i, j);
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
            let mut sc = [1.0f64; MU_N];
            for _ in 0..200 {
                for i in 0..MU_N {
                    let cur: f64 = (0..MU_N)
                        .map(|j| cell_albedo(&lobe, i, j) * sc[i] * sc[j])
                        .sum();
                    if cur > 0.0 && target[i] > 0.0 {
                        sc[i] *= (target[i] / cur).sqrt();
                    }
                }
            }
            for i in 0..MU_N {
                for j in 0..MU_N {
                    let b = lobe_index(n, a, i, j);
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
        "MSBSDF-TABULATED-v1\n\
         MSBSDF_MODEL_TABULATED conductor table (layout: src/multiple/tabulated.rs)\n\
         command: cargo run --release --example gen_tabulated -- {}\n\
         commit: {}\n\
         walks: HEITZ_RANDOM_WALK (library, default bounce limit, F = 1) {walks} per (ndf, alpha, mu_i) node, {total_walks} in total; seed Rng::new({SEED_LOBE}, stream = job index)\n\
         fresnel cosines: instrumented walk, {fresnel_walks} walks per (ndf, alpha); seed Rng::new({SEED_FRESNEL}, stream = job index)\n\
         E_ss: SINGLE quadrature 256 x 256 (compensation::single_albedo)\n\
         symmetrisation: azimuth-averaged f(mu_i, mu_o) vs f(mu_o, mu_i): RMS relative difference {:.3e}, max {:.3e} (cells with f > 1e-3); {:.3e} without the three most grazing nodes (mu < 0.025, where the hat smoothing of steep lobes differs between the two)\n\
         albedo before rescaling vs 1 - E_ss: worst relative deviation {:.3e} (targets > 1e-3); after: {:.3e}\n\
         peaked part: Gram entries by {gram} SINGLE samples per node (seed Rng::new({SEED_GRAM}, stream = job index)), ridge {RIDGE} x G_BB\n\
         grid: ndf {NDF_N} x alpha {ALPHA_N} x mu_i {MU_N} x mu_o {MU_N} x {CELL} floats (K = {K_STORED} cosine terms of a {K_FIT}-term fit, peaked weight B, order fractions 2, 3, 4)\n\
         {}wall time: {:.0} s on {threads} threads\n",
        args[1..].join(" "),
        git_commit(),
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
    eprint!("{header}");
    let mut bytes = Vec::with_capacity(FILE_BYTES);
    bytes.extend_from_slice(header.as_bytes());
    assert!(bytes.len() <= HEADER_BYTES, "header too long");
    assert!(bytes.starts_with(MAGIC));
    bytes.resize(HEADER_BYTES, 0);
    for v in lobe.iter().chain(albedo.iter()) {
        bytes.extend_from_slice(&(*v as f32).to_le_bytes());
    }
    for v in &fresnel {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(bytes.len(), FILE_BYTES);
    let mut f = std::fs::File::create(out).expect("create output");
    f.write_all(&bytes).expect("write output");
    eprintln!("wrote {out} ({} bytes)", bytes.len());
}
