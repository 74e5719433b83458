//! Generates `data/tabulated_aniso.bin`, the anisotropic factors and
//! furnace correction of `MSBSDF_MODEL_TABULATED`'s conductors
//! (`msbsdf::multiple::tabulated::corr_values`): per NDF, roughness pair
//! `(alpha_x, alpha_y)` on the grid `tabulated::corr_grid_alpha` (31 nodes
//! per axis: ENERGY_COMPENSATED's 16 and the midpoints between them) and
//! direction node (`tabulated::corr_node_dir`: the albedo table's 16
//! cosines and the midpoints of two intervals near grazing,
//! `tabulated::CORR_MU` = 18, and `tabulated::CORR_PHI` = 17
//! diamond-angle azimuths; in the stretched blocks four midpoints near
//! grazing and one at the normal, `CORR_MU_STRETCHED` = 21, and
//! `CORR_PHI_STRETCHED` = 25 azimuths),
//! the two factors `u = s sqrt(t)`, `v = s sqrt(b)` of the lobe `T u(wi) u(wo) + P v(wi) v(wo)`
//! (`Tabulated::aniso_parts`; `t`, `b` from `Tabulated::aniso_factors`),
//! with `s` such that the lobe has the multiply scattered albedo
//! `1 - E_ss(wi)` at every node, `E_ss` SINGLE's albedo with F = 1. No
//! random numbers: both albedos by deterministic quadrature over normals
//! (the mapping of `compensation::single_albedo`, `--quad N` per side,
//! default 192: 128 resolved the needle-like lobes of strongly anisotropic
//! grazing nodes to about 1%).
//!
//! Per roughness pair, the two parts are integrated once into
//! `M[r][n] = sqrt(t_r t_n) int T(w_r, wo) phi_n(wo) dwo + sqrt(b_r b_n)
//! int P(w_r, wo) phi_n(wo) dwo`, `w_r` the incident direction of node `r`
//! and `phi_n` the bilinear weight of node `n` at `wo` as eval interpolates
//! `u` and `v` (`tabulated::corr_dir_weights`); the albedo from node `r`
//! is then `s_r sum_n M[r][n] s_n` exactly, and the factors solve
//! `s_r (M s)_r = 1 - E_ss(w_r)` by the symmetric Sinkhorn iteration
//! `s_r <- s_r sqrt(target_r / albedo_r)` to a relative residual of 1e-6
//! (or 3000 steps), clamped to `[S_MIN, CORR_MAX]`; `u` and `v` are stored
//! as `u16` (`tabulated::corr_encode` with `CORR_PAIR_MAX`); the header
//! records the residual of the stored values, the clamp hits and the time.
//! (The dielectric's correction, below, stores `s` alone.)
//!
//! `cargo run --release --example gen_tabulated_aniso [-- --quad N]`
//! (every block; about 80 minutes on 2 threads). Environment switches:
//! `PAIRS=n:jx:jy,...` solves the listed blocks only (experiments: the
//! others are 0, and the header's command line says so);
//! `REUSE=PATH` copies the blocks an earlier table (version 12 to 17)
//! has on the same grid and stretch, which this code computes bit for
//! bit, and solves the others (the committed version 18 is version 17
//! without node 0's blocks, every block copied; 17 was made so from 16,
//! 16 from 15, 15 from 14, 14 from 13 and 13 from 12: its header names
//! the runs);
//! `-- --dielectric [--quad N]` writes the dielectric tier's
//! `data/tabulated_aniso_dielectric.bin` the same way ([`dielectric`]);
//! `-- --dielectric-random [COUNT]` measures anisotropic glass's furnace
//! at random materials, indices and directions ([`dielectric_random`]);
//! `-- --dielectric-eta-scan [--quad N]` the error of the correction's
//! interpolation in the index for 6, 11 and 16 nodes
//! ([`dielectric_eta_scan`]);
//! `-- --check [--quad N]` prints where the anisotropic furnace error of
//! the committed table sits (default N = 400): the test's materials, 16
//! random nodes and 32 random materials; `-- --scan NDF AX AY0 AY1 THETA
//! PHI` the furnace error along `alpha_y` from `AY0` to `AY1` (11 steps);
//! `-- --ir MODEL NDF CALLS` the callgrind driver of anisotropic eval
//! (`ir`).

use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::compensation::{
    aniso_grid_mu, broad_reflection_nodes, lower_hemisphere_nodes, single_albedo,
};
use msbsdf::multiple::compensation_aniso_tables::{AN_A, AN_MU, AN_PHI, CONDUCTOR_E_ANISO};
use msbsdf::multiple::tabulated::{
    CORR_A, CORR_GRID_PLAIN, CORR_LEN, CORR_MAGIC, CORR_MAX, CORR_MU, CORR_MU_FINE,
    CORR_MU_FINE_FROM, CORR_PAIR_MAX, CORR_PHI, CORR_PHI_STRETCHED, CORR_PROXY_V, CORR_STRETCH_MAX,
    CORR_STRETCH_POW, CORR_STRETCH_RATIO, CORR_STRETCH_RATIO_ROUGH, CORR_STRETCH_ROUGH_FROM,
    CORR_VALUES, CorrGrid, HEADER_BYTES, Tabulated, corr_azimuth_dir, corr_decode,
    corr_dir_weights, corr_encode, corr_grid, corr_grid_alpha, corr_index, corr_node_dir,
    corr_pair_grid, corr_proxy, corr_stretch, dcorr_dir_weights, dcorr_node_dir,
};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::rng::Rng;
use msbsdf::single::{G2Form, Single};

#[path = "harness/cli.rs"]
mod cli;
#[path = "harness/git.rs"]
mod git;

/// Every option `main` reads (`cli::check_options` rejects the others).
const OPTIONS: &[&str] = &[
    "--alphas",
    "--at",
    "--azimuths",
    "--check",
    "--dielectric",
    "--dielectric-at",
    "--dielectric-eta-scan",
    "--dielectric-random",
    "--dielectric-sweep",
    "--etas",
    "--grazing",
    "--ir",
    "--isotropic",
    "--only",
    "--parts",
    "--quad",
    "--rows",
    "--scan",
    "--sweep",
    "--thetas",
];

const USAGE: &str = "\
gen_tabulated_aniso: the anisotropic correction tables of MSBSDF_MODEL_TABULATED
(the module documentation of tools/gen_tabulated_aniso.rs has the details).

Writes a committed table (run on a clean tree; the header records the commit):
  (no mode option) [--quad N]     data/tabulated_aniso.bin, conductors (~80 min)
  --dielectric [--quad N] [--only K]
                                  data/tabulated_aniso_dielectric.bin (~40 min)
Measures (writes nothing):
  --check [--quad N]              conductor furnace at the test's materials
  --at NDF AX AY THETA PHI0 PHI1 STEP / --sweep / --scan NDF AX AY0 AY1 THETA PHI
                                  conductor furnace along azimuths, sweeps, lines
  --dielectric-at NDF AX AY ETA THETA PHI [--parts]   (MC=N: sampled too)
  --dielectric-sweep [--isotropic] [--etas E,..] [--rows N]
  --dielectric-random [COUNT] [--isotropic] [--grazing]
  --dielectric-eta-scan [--quad N]
  sweeps take --azimuths N --thetas T,.. --alphas A,..
  --ir MODEL NDF CALLS ...        the callgrind driver of anisotropic eval";

const NDFS: [NdfKind; 2] = [NdfKind::Beckmann, NdfKind::Ggx];

/// Smallest stored factor (the lobe scaled by `S_MIN^2` at most).
const S_MIN: f32 = 0.02;

/// Statistics of one block: largest relative residual at the nodes after
/// rounding, clamp hits, Sinkhorn steps.
#[derive(Clone, Copy, Default)]
struct Stats {
    residual: f64,
    clamped: usize,
    /// Stored products at the top of their range (conductor).
    pair_clamped: usize,
    steps: usize,
    /// The worst furnace error at the cosine midpoints and at the nodes
    /// after the balancing of the node targets.
    mid: f64,
    node: f64,
}

/// A correction table file: `magic`, the text `header` padded with zeros
/// to `HEADER_BYTES`, then the values as little-endian `u16`.
fn table_bytes(magic: &[u8], header: &str, table: &[u16]) -> Vec<u8> {
    let mut bytes = magic.to_vec();
    bytes.extend_from_slice(header.as_bytes());
    assert!(bytes.len() < HEADER_BYTES, "header too long");
    bytes.resize(HEADER_BYTES, 0);
    for v in table {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes
}

/// Runs `work` on every job on `threads` threads (each takes the next job
/// not yet taken), with a progress line counting `what`; returns, per
/// thread, `(job index, factors, statistics)`.
fn run_jobs<J: Sync, V: Send>(
    jobs: &[J],
    threads: usize,
    what: &str,
    t0: std::time::Instant,
    work: impl Fn(&J) -> (Vec<V>, Stats) + Sync,
) -> Vec<Vec<(usize, Vec<V>, Stats)>> {
    let total = jobs.len();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                let (next, work) = (&next, &work);
                sc.spawn(move || {
                    let mut out = Vec::new();
                    loop {
                        let idx = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(job) = jobs.get(idx) else {
                            break;
                        };
                        let (s, st) = work(job);
                        out.push((idx, s, st));
                        let el = t0.elapsed().as_secs_f32();
                        eprint!(
                            "\r{}/{total} {what}, {el:.0} s, ETA {:.0} s   ",
                            idx + 1,
                            el / (idx + 1) as f32 * (total - idx - 1) as f32
                        );
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
    results
}

/// A cosine midpoint of a block (`block`): its direction, its
/// furnace target `1 - E_ss`, the lobe's two parts integrated against the
/// interpolation weights of `wo`, and eval's interpolation weights of the
/// direction itself.
struct Mid {
    w: Vec3,
    t: f64,
    a: Vec<f64>,
    b: Vec<f64>,
    wts: [(usize, f32); 4],
}

/// The stored values of roughness pair `(jx, jy)` of NDF `n`: per node
/// `[s sqrt(t), s sqrt(b)]` (`[1, 1]` where an axis has roughness < 1e-3:
/// no multiply scattered energy to correct), and the statistics with the
/// residual of the rounded values.
/// Roughness below which a block's quadrature has at least [`QUAD_LOW`]
/// points per axis (both axes below it: nodes 1-4, version 17).
const LOW_ALPHA: f32 = 0.05;
/// The quadrature of the blocks whose roughness is below [`LOW_ALPHA`] on
/// both axes: at 192 the narrow lobe of Beckmann (0.0022, 0.0089) left its
/// node material at +0.82% at 89.17 degrees (a node), -0.13% at 400.
const QUAD_LOW: usize = 400;

/// Whether block `(jx, jy)` has both roughness values below [`LOW_ALPHA`]
/// (its quadrature is [`QUAD_LOW`], its nearly-zero targets factor
/// `S_MIN`, [`solve_within`]).
fn low_block(jx: usize, jy: usize) -> bool {
    corr_grid_alpha(jx.max(jy)) < LOW_ALPHA
}

/// The quadrature of block `(jx, jy)` for the command's `quad`.
fn block_quad(jx: usize, jy: usize, quad: usize) -> usize {
    if low_block(jx, jy) {
        quad.max(QUAD_LOW)
    } else {
        quad
    }
}

fn block(n: usize, jx: usize, jy: usize, quad: usize) -> (Vec<[f32; 2]>, Stats) {
    let quad = block_quad(jx, jy, quad);
    let (ax, ay) = (corr_grid_alpha(jx), corr_grid_alpha(jy));
    // The block's azimuth stretch (its nodes and eval's weights).
    let rho = corr_stretch(jx, jy);
    // Its nodes: `nphi` azimuth rows of `nmu` cosines.
    let grid = corr_grid(rho);
    let (nphi, nmu, nb) = (grid.phi, grid.mu, grid.nodes());
    if ax < 1e-3 || ay < 1e-3 {
        // Factors 1, `v` times the nodes' proxies (`corr_proxy`).
        let g = (0..nb).map(|r| [1.0, corr_proxy(n, ax, ay, corr_node_dir(r, rho))]);
        return (g.collect(), Stats::default());
    }
    // On the diagonal the model is isotropic; the factors there are read by
    // anisotropic materials between nodes, so they are taken for a barely
    // anisotropic one.
    let ay = if jx == jy { ay * 1.0001 } else { ay };
    let white = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let ndf = Ndf::new(NDFS[n], ax, ay);
    let tab = Tabulated::new(ndf, white).without_aniso_correction();
    let single = Single::new(ndf, white, G2Form::HeightCorrelated);
    let mut rng = Rng::new(0, 0);
    // The uncorrected factors sqrt(t), sqrt(b) at every node.
    let fac: Vec<(f64, f64)> = (0..nb)
        .map(|r| {
            let (t, b) = tab
                .aniso_factors(corr_node_dir(r, rho))
                .expect("anisotropic");
            (t as f64, b as f64)
        })
        .collect();
    // The peaked factor's proxies at the nodes (`CORR_PROXY_V`, 1 for
    // GGX): the table stores `v g(n)`, and eval divides the interpolated
    // value by the proxy of its own direction.
    let proxy: Vec<f64> = (0..nb)
        .map(|r| corr_proxy(n, ax, ay, corr_node_dir(r, rho)) as f64)
        .collect();
    // A direction's furnace target `1 - E_ss` and the lobe's two parts
    // integrated against the interpolation weights of wo (the peaked
    // one's `v(wo) = sum_n phi_n(wo) v_n g(n) / g(wo)`).
    let mut rows = |wi: Vec3| {
        let target =
            1.0 - single_albedo(|x, y| single.eval(x, y, &mut rng).x, ax, ay, wi, None, quad);
        let (mut mt, mut mp) = (vec![0.0f64; nb], vec![0.0f64; nb]);
        // The lobe is broad: the normals' nodes alone leave most of the
        // hemisphere nearly empty when the roughness is strongly
        // anisotropic (`broad_reflection_nodes`).
        broad_reflection_nodes(ax, ay, wi, quad, (2 * quad / 3, 4 * quad / 3), |wo, w| {
            let Some((t, p)) = tab.aniso_parts(wi, wo) else {
                return;
            };
            let (t, p) = (
                t as f64 * w,
                p as f64 * w / corr_proxy(n, ax, ay, wo) as f64,
            );
            for (node, b) in corr_dir_weights(wo, rho) {
                mt[node] += t * b as f64;
                mp[node] += p * b as f64 * proxy[node];
            }
        });
        (target, mt, mp)
    };
    let (mut target, mut mt, mut mp) = (Vec::new(), Vec::new(), Vec::new());
    for r in 0..nb {
        let (t, a, b) = rows(corr_node_dir(r, rho));
        target.push(t);
        mt.push(a);
        mp.push(b);
    }
    // The cosine midpoints between the nodes of each azimuth node (where
    // the linear interpolation of the factors strays most: near grazing
    // and in the wide last interval next to the normal): their
    // directions, targets, rows and eval's interpolation weights.
    let mids: Vec<_> = (0..nphi)
        .flat_map(|k| (1..nmu - 1).map(move |i| (k, i)))
        .map(|(k, i)| {
            let w = corr_azimuth_dir(k, grid.mu_at(i as f32 + 0.5), rho);
            let (t, a, b) = rows(w);
            Mid {
                w,
                t,
                a,
                b,
                wts: corr_dir_weights(w, rho),
            }
        })
        .collect();
    // With u = s sqrt(t), v = s sqrt(b) at every node, the albedo from node
    // r is s_r sum_n M[r][n] s_n.
    let m: Vec<Vec<f64>> = (0..nb)
        .map(|r| {
            (0..nb)
                .map(|c| fac[r].0 * fac[c].0 * mt[r][c] + fac[r].1 * fac[c].1 * mp[r][c])
                .collect()
        })
        .collect();
    // The node targets the solve meets (shifted by the balancing).
    let mut shifted = target.clone();
    let low = low_block(jx, jy);
    let (mut s, mut stats) = solve_within(&m, &target, low);
    // The node targets shifted so that the furnace error at each node
    // and the mean error of its adjacent cosine midpoints come out equal
    // and opposite (the interpolant's overshoot split in two), a few
    // fixed-point steps.
    let node_albedo =
        |s: &[f32], r: usize| s[r] as f64 * (0..nb).map(|c| m[r][c] * s[c] as f64).sum::<f64>();
    let mid_error = |s: &[f32], q: &Mid| {
        let Mid { w, t, a, b, wts } = q;
        let (mut u, mut v) = (0.0f64, 0.0f64);
        for &(nd, wt) in wts {
            u += wt as f64 * s[nd] as f64 * fac[nd].0;
            v += wt as f64 * s[nd] as f64 * fac[nd].1 * proxy[nd];
        }
        v /= corr_proxy(n, ax, ay, *w) as f64;
        let at: f64 = (0..nb).map(|c| a[c] * fac[c].0 * s[c] as f64).sum();
        let bt: f64 = (0..nb).map(|c| b[c] * fac[c].1 * s[c] as f64).sum();
        u * at + v * bt - t
    };
    for _ in 0..3 {
        let e: Vec<f64> = mids.iter().map(|q| mid_error(&s, q)).collect();
        for r in 0..nb {
            let (k, i) = (r / nmu, r % nmu);
            // Midpoint j (of nmu - 2 per azimuth node) lies between
            // cosine nodes j + 1 and j + 2; none below node 1: node i's
            // adjacent midpoints are i - 2 and i - 1 where they exist.
            let row = &e[k * (nmu - 2)..(k + 1) * (nmu - 2)];
            let adj = &row[i.saturating_sub(2)..i.min(nmu - 2)];
            // The last cosine node is the normal, the same direction
            // for every azimuth node: its target moves by the mean of
            // the last midpoints' errors over all azimuth nodes, so
            // that its factors stay equal across the azimuth nodes.
            let em = if i + 1 == nmu {
                (0..nphi).map(|kk| e[kk * (nmu - 2) + nmu - 3]).sum::<f64>() / nphi as f64
            } else if adj.is_empty() {
                continue;
            } else {
                adj.iter().sum::<f64>() / adj.len() as f64
            };
            let en = node_albedo(&s, r) - target[r];
            shifted[r] -= 0.5 * (em + en);
        }
        let (s2, st2) = solve_within(&m, &shifted, low);
        s = s2;
        stats = st2;
    }
    let e: Vec<f64> = mids.iter().map(|q| mid_error(&s, q)).collect();
    stats.mid = e.iter().fold(0.0f64, |w, x| w.max(x.abs()));
    stats.node = (0..nb)
        .filter(|&r| target[r] >= 1e-4)
        .fold(0.0f64, |w, r| w.max((node_albedo(&s, r) - target[r]).abs()));
    let round = |x: f64| corr_decode(corr_encode(x as f32, CORR_PAIR_MAX), CORR_PAIR_MAX) as f64;
    let uv: Vec<[f64; 2]> = (0..nb)
        .map(|r| {
            [
                round(s[r] as f64 * fac[r].0),
                round(s[r] as f64 * fac[r].1 * proxy[r]),
            ]
        })
        .collect();
    stats.pair_clamped = uv
        .iter()
        .flatten()
        .filter(|&&x| x >= CORR_PAIR_MAX as f64 * 0.999)
        .count();
    // The residual of what is stored.
    stats.residual = 0.0;
    for r in 0..nb {
        if shifted[r] < 1e-4 {
            continue;
        }
        let a: f64 = (0..nb)
            .map(|c| {
                let peaked = uv[r][1] / proxy[r] * mp[r][c] * uv[c][1] / proxy[c];
                uv[r][0] * mt[r][c] * uv[c][0] + peaked
            })
            .sum();
        if a > 1e-4 {
            stats.residual = stats.residual.max((a - shifted[r]).abs());
        }
    }
    (uv.iter().map(|v| v.map(|x| x as f32)).collect(), stats)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    cli::check_options(OPTIONS, USAGE);
    let quad_arg: Option<usize> = args
        .iter()
        .position(|a| a == "--quad")
        .and_then(|p| args.get(p + 1))
        .and_then(|v| v.parse().ok());
    if let Some(p) = args.iter().position(|a| a == "--dielectric-at") {
        // NDF AX AY ETA THETA PHI (degrees; THETA > 90 from inside).
        let v: Vec<f32> = args[p + 1..]
            .iter()
            .filter_map(|a| a.parse().ok())
            .collect();
        use msbsdf::multiple::tabulated_dielectric::TabulatedDielectric;
        let (ax, ay, eta) = (v[1], v[2], v[3]);
        let ndf = Ndf::new(NDFS[v[0] as usize], ax, ay);
        let facet = Facet::Dielectric { eta };
        let t = TabulatedDielectric::new(ndf, facet);
        let s = Single::new(ndf, facet, G2Form::HeightCorrelated);
        let (th, ph) = (v[4].to_radians(), v[5].to_radians());
        let wi = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
        println!("{:+.4}", glass_albedo(&t, &s, wi, ax, ay, eta) - 1.0);
        // MC=N: the mean of N sample weights (independent of the quadrature).
        if let Some(count) = std::env::var("MC").ok().and_then(|v| v.parse::<u64>().ok()) {
            let mut rng = Rng::new(7, 11);
            let (mut sum, mut sq) = (0.0f64, 0.0f64);
            for _ in 0..count.max(2) {
                let w = t.sample(wi, &mut rng).weight.x as f64;
                sum += w;
                sq += w * w;
            }
            let n = count.max(2) as f64;
            let mean = sum / n;
            let se = ((sq / n - mean * mean).max(0.0) / n).sqrt();
            println!("sampled {:+.4} +- {se:.4}", mean - 1.0);
        }
        if args.iter().any(|a| a == "--parts") {
            let u = t.without_aniso_correction();
            println!(
                "uncorrected {:+.4}",
                glass_albedo(&u, &s, wi, ax, ay, eta) - 1.0
            );
            // SINGLE against itself: the rest is 0, the albedo is E_ss.
            let e = glass_albedo(&s, &s, wi, ax, ay, eta);
            println!("single {e:.4}");
        }
        return;
    }
    if args.iter().any(|a| a == "--dielectric-random") {
        dielectric_random(&args);
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--at") {
        conductor_at(&args[p + 1..]);
        return;
    }
    if args.iter().any(|a| a == "--sweep") {
        conductor_sweep(azimuths_arg(&args), &thetas_arg(&args), &alphas_arg(&args));
        return;
    }
    if args.iter().any(|a| a == "--dielectric-sweep") {
        let iso = args.iter().any(|a| a == "--isotropic");
        let etas = list_arg(&args, "--etas")
            .filter(|v| !v.is_empty())
            .unwrap_or_else(|| SWEEP_ETAS.to_vec());
        dielectric_sweep(
            azimuths_arg(&args),
            &thetas_arg(&args),
            &alphas_arg(&args),
            &etas,
            iso,
            count_arg(&args, "--rows", 15),
        );
        return;
    }
    if args.iter().any(|a| a == "--dielectric-eta-scan") {
        dielectric_eta_scan(quad_arg.unwrap_or(64));
        return;
    }
    if args.iter().any(|a| a == "--dielectric") {
        dielectric(&args, quad_arg.unwrap_or(48));
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--ir") {
        ir(&args[p + 1..]);
        return;
    }
    if let Some(p) = args.iter().position(|a| a == "--scan") {
        let v: Vec<f32> = args[p + 1..]
            .iter()
            .filter_map(|a| a.parse().ok())
            .collect();
        let white = Facet::Conductor {
            eta: Vec3::ZERO,
            k: Vec3::ONE,
        };
        for t in 0..=10 {
            let ay = v[2] + (v[3] - v[2]) * t as f32 / 10.0;
            let ndf = Ndf::new(NDFS[v[0] as usize], v[1], ay);
            let tab = Tabulated::new(ndf, white);
            let (th, ph) = (v[4].to_radians(), v[5].to_radians());
            let wi = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
            let mut rng = Rng::new(0, 0);
            let q = single_albedo(|x, y| tab.eval(x, y, &mut rng).x, v[1], ay, wi, None, 400);
            println!("ay {ay:.4}: {:+.4}", q - 1.0);
        }
        return;
    }
    if args.iter().any(|a| a == "--check") {
        check(quad_arg.unwrap_or(400));
        return;
    }
    let quad = quad_arg.unwrap_or(192);
    let t0 = std::time::Instant::now();
    // Jobs: (ndf, jx, jy) with jx <= jy (the stored pairs), the dearest
    // (both axes rough: nothing skipped) first.
    // Node 0's pairs are not stored (`tabulated::CORR_PAIRS`).
    let mut jobs: Vec<(usize, usize, usize)> = (0..2)
        .flat_map(|n| (1..CORR_A).flat_map(move |jx| (jx..CORR_A).map(move |jy| (n, jx, jy))))
        .collect();
    jobs.sort_by_key(|&(_, jx, _)| usize::MAX - jx);
    // Experiments: `PAIRS=n:jx:jy,...` solves those blocks only (the
    // others are left at 0: not a table to commit; the header's command
    // line says so).
    let pairs = std::env::var("PAIRS").ok();
    if let Some(p) = &pairs {
        eprintln!("PAIRS={p}: an experiment's table, the other blocks are 0");
        let keep: Vec<(usize, usize, usize)> = p
            .split(',')
            .filter_map(|t| {
                let v: Vec<usize> = t.split(':').filter_map(|x| x.parse().ok()).collect();
                (v.len() == 3).then(|| (v[0], v[1], v[2]))
            })
            .collect();
        jobs.retain(|j| keep.contains(j));
    }
    // `REUSE=PATH`: the blocks whose grid and stretch an earlier table
    // (version 12 to 17) shares are copied from it: this code computes
    // them bit for bit (the same nodes, rows, balancing and solve); only
    // the others are solved. The header's command line says so.
    let reuse = std::env::var("REUSE").ok().map(|path| {
        let raw = std::fs::read(&path).expect("read the REUSE table");
        let old = OldLayout::of(&raw)
            .expect("REUSE needs a version-12 to -17 conductor correction table");
        // Version 16 and earlier solved every block alike: the
        // low-roughness ones (`low_block`) are solved again.
        jobs.retain(|&(_, jx, jy)| !old.shares(jx, jy) || (old.version < 17 && low_block(jx, jy)));
        (path, raw, old)
    });
    let threads: usize = std::env::var("THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2);
    let results = run_jobs(&jobs, threads, "roughness pairs", t0, |&(n, jx, jy)| {
        block(n, jx, jy, quad)
    });
    let mut table = vec![0u16; CORR_VALUES * CORR_LEN];
    if let Some((_, raw, old)) = &reuse {
        old.copy_shared_blocks(raw, &mut table);
    }
    let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
    let mut stats = Stats::default();
    for (idx, block, st) in results.into_iter().flatten() {
        let (n, jx, jy) = jobs[idx];
        stats.residual = stats.residual.max(st.residual);
        stats.clamped += st.clamped;
        stats.pair_clamped += st.pair_clamped;
        stats.steps = stats.steps.max(st.steps);
        stats.mid = stats.mid.max(st.mid);
        stats.node = stats.node.max(st.node);
        let g = corr_pair_grid(jx, jy);
        let nmu = g.mu;
        for k in 0..g.phi {
            for i in 0..nmu {
                let at = corr_index(n, jx, jy, k, i);
                for (c, &v) in block[k * nmu + i].iter().enumerate() {
                    table[CORR_VALUES * at + c] = corr_encode(v, CORR_PAIR_MAX);
                }
            }
        }
    }
    // The stored range over every block (solved or copied).
    for pair in table.chunks_exact(CORR_VALUES) {
        for (c, &q) in pair.iter().enumerate() {
            let v = msbsdf::multiple::tabulated::corr_decode(q, CORR_PAIR_MAX);
            lo[c] = lo[c].min(v);
            hi[c] = hi[c].max(v);
        }
    }
    let command: Vec<String> = args.iter().skip(1).cloned().collect();
    let header = format!(
        "ANISO_CORRECTION v18 (MSBSDF_MODEL_TABULATED): per [ndf: Beckmann, GGX][roughness \
         pair (1 <= jx <= jy) of {CORR_A} x {CORR_A}: alpha = 2 (j / {})^2; node 0's pairs \
         are not stored, a roughness below node 1 reads node 1][azimuth n: {CORR_PHI} \
         nodes, {CORR_PHI_STRETCHED} in the stretched blocks (tabulated::corr_pair_grid), of the diamond angle rho |y| / (|x| + rho |y|) from 0 to 1, rho the block's \
         stretch (tabulated::corr_stretch: 1 up to alpha_y / alpha_x = {CORR_STRETCH_RATIO}, \
         {CORR_STRETCH_RATIO_ROUGH} where the rougher axis is at node {CORR_STRETCH_ROUGH_FROM} or above, \
         above it (alpha_y / alpha_x)^{CORR_STRETCH_POW}, at most {CORR_STRETCH_MAX}; tabulated::corr_dirs)][mu: \
         {CORR_MU}] (tabulated::corr_grid_mu_at: ENERGY_COMPENSATED's anisotropic cosine grid \
         with its intervals {} to {} halved) the two factors \
         u = s sqrt(t), v = s sqrt(b) of the lobe's table and peaked parts \
         (Tabulated::aniso_parts, aniso_factors), Beckmann's v times the node's proxy \
         exp({} L), L = (1 - cos theta) ln(proj / mean) (tabulated::corr_proxy_ln; eval \
         divides by its own direction's), as little-endian u16 pairs x, value = \
         {CORR_PAIR_MAX} (x / 65535)^2, after this {HEADER_BYTES}-byte header; (jx > jy, k) \
         reads (jy, jx, n - 1 - k). The lobe parts.0 u(wi) u(wo) + parts.1 v(wi) v(wo), u and v \
         interpolated as eval does, has the multiply scattered albedo 1 - E_ss at every \
         node, E_ss SINGLE's albedo with F = 1 (at targets shifted by three fixed-point \
         steps so that the furnace error at each node and the mean one at its adjacent \
         cosine midpoints, those from the second cosine node on, balance; the normal's \
         node, shared by the azimuth nodes, by the mean of the midpoints next to it: worst \
         then {:.4} at the midpoints and {:.4} at the nodes); both by deterministic quadrature \
         (E_ss over compensation::single_albedo's normals, {quad} x {quad} per node, {QUAD_LOW} where both roughness values are below {LOW_ALPHA}; the \
         lobe over compensation::broad_reflection_nodes: those normals and a {} x {} \
         direction grid split by node density), s by the \
         symmetric Sinkhorn iteration on the integrated interpolation weights (residual 1e-6 \
         or 3000 steps); no random numbers. Diagonal nodes at alpha_y (1 + 1e-4); s clamped to [{S_MIN}, {CORR_MAX}]. Stored range u \
         {:.4} - {:.4}, v {:.4} - {:.4}; worst |albedo - (1 - E_ss)| at the nodes with the \
         stored values {:.2e}; {} clamped factors s, {} stored values at the top of the \
         range; at most {} Sinkhorn steps.\n\
         Command: {}cargo run --release --example gen_tabulated_aniso{}{}\nCommit: {}\n\
         Time: {:.0} s\n",
        CORR_A - 1,
        CORR_MU_FINE_FROM,
        CORR_MU_FINE_FROM + CORR_MU_FINE,
        CORR_PROXY_V[0],
        stats.mid,
        stats.node,
        2 * quad / 3,
        4 * quad / 3,
        lo[0],
        hi[0],
        lo[1],
        hi[1],
        stats.residual,
        stats.clamped,
        stats.pair_clamped,
        stats.steps,
        pairs.map_or(String::new(), |p| format!("PAIRS={p} "))
            + &reuse
                .as_ref()
                .map_or(String::new(), |(p, _, _)| format!("REUSE={p} ")),
        if command.is_empty() { "" } else { " -- " },
        command.join(" "),
        git::commit(),
        t0.elapsed().as_secs_f32()
    );
    // A reused table's own lines (its statistics cover its blocks, and
    // its command and commit say where they came from).
    let header = match &reuse {
        Some((p, raw, layout)) => {
            let old = String::from_utf8_lossy(&raw[..HEADER_BYTES]);
            let old = old.trim_end_matches('\0');
            let keep: Vec<&str> = old
                .lines()
                .filter(|l| ["Command:", "Commit:"].iter().any(|p| l.starts_with(p)))
                .collect();
            // Its own REUSE line (the runs before it) and statistics stay
            // in its header: the chain outgrew the 4096 bytes (version 18).
            format!(
                "{header}REUSE: the blocks of the same grid and stretch ({} per NDF) copied \
                 from {p}, a version-{} table made by the same code for them (its {}; its \
                 header, with the runs before it and its statistics, is in the repository's \
                 history of this file); the statistics above cover the {} blocks solved here\n",
                layout.shared(),
                layout.version,
                keep.join("; "),
                jobs.len()
            )
        }
        None => header,
    };
    let bytes = table_bytes(CORR_MAGIC, &header, &table);
    let path = format!("{}/data/tabulated_aniso.bin", env!("CARGO_MANIFEST_DIR"));
    std::fs::write(&path, bytes).expect("write the table file");
    eprintln!("{header}wrote {path}");
}

/// The block layout of an earlier conductor correction table (`REUSE`):
/// version 12 (every block plain), 13 (blocks of anisotropy ratio above
/// 8 stretched, on 25 x 20 nodes) or 14 (also those of ratio 5-8 with the
/// rougher axis at node 20 or above).
struct OldLayout {
    version: u32,
    /// Stretch ratio threshold of the stretched blocks (`None`: none),
    /// and the lower threshold and the rougher node from which it holds.
    ratio: Option<(usize, Option<(usize, usize)>)>,
    /// The stretched blocks' grid.
    stretched: CorrGrid,
    /// The largest stretch (version 16 on).
    cap: f32,
}

/// The stretched blocks' grid of versions 13 and 14.
const V14_STRETCHED: CorrGrid = CorrGrid {
    phi: 25,
    mu: 20,
    fine: 4,
    tail: 0,
};

/// The stretched blocks' grid of version 15 (that of version 16).
const V15_STRETCHED: CorrGrid = CorrGrid {
    phi: 25,
    mu: 21,
    fine: 4,
    tail: 1,
};

impl OldLayout {
    /// The layout of `raw` from its magic, checked against its size.
    fn of(raw: &[u8]) -> Option<OldLayout> {
        let old = if raw.starts_with(b"MSBSDF-TABULATED-ANISO-F-v12\n") {
            OldLayout {
                version: 12,
                ratio: None,
                stretched: V14_STRETCHED,
                cap: f32::INFINITY,
            }
        } else if raw.starts_with(b"MSBSDF-TABULATED-ANISO-F-v13\n") {
            OldLayout {
                version: 13,
                ratio: Some((8, None)),
                stretched: V14_STRETCHED,
                cap: f32::INFINITY,
            }
        } else if raw.starts_with(b"MSBSDF-TABULATED-ANISO-F-v14\n") {
            OldLayout {
                version: 14,
                ratio: Some((8, Some((5, 20)))),
                stretched: V14_STRETCHED,
                cap: f32::INFINITY,
            }
        } else if raw.starts_with(b"MSBSDF-TABULATED-ANISO-F-v15\n") {
            OldLayout {
                version: 15,
                ratio: Some((8, Some((5, 20)))),
                stretched: V15_STRETCHED,
                cap: f32::INFINITY,
            }
        } else if let Some(version) = [16, 17]
            .into_iter()
            .find(|v| raw.starts_with(format!("MSBSDF-TABULATED-ANISO-F-v{v}\n").as_bytes()))
        {
            // Version 17 has version 16's layout (its low-roughness blocks
            // solved anew).
            OldLayout {
                version,
                ratio: Some((8, Some((5, 20)))),
                stretched: V15_STRETCHED,
                cap: 10.0,
            }
        } else {
            return None;
        };
        let nodes: usize = Self::pairs()
            .map(|(lo, hi)| old.grid_of(lo, hi).nodes())
            .sum();
        (raw.len() == HEADER_BYTES + 2 * CORR_VALUES * 2 * nodes).then_some(old)
    }

    /// The stored pairs `lo <= hi` in file order (node 0's too: versions
    /// 12 to 17 stored them).
    fn pairs() -> impl Iterator<Item = (usize, usize)> {
        (0..CORR_A).flat_map(|lo| (lo..CORR_A).map(move |hi| (lo, hi)))
    }

    /// The grid of the old table's block `(lo, hi)`.
    fn grid_of(&self, lo: usize, hi: usize) -> CorrGrid {
        let (a, b) = (lo * lo, hi * hi);
        let Some((r, rough)) = self.ratio else {
            return CORR_GRID_PLAIN;
        };
        let r = match rough {
            Some((r5, from)) if hi >= from => r5,
            _ => r,
        };
        if lo > 0 && (b > r * a || a > r * b) {
            self.stretched
        } else {
            CORR_GRID_PLAIN
        }
    }

    /// The old table's stretch of its block `(lo, hi)`, `lo <= hi`: 1 on
    /// the plain grid, else `(alpha_hi / alpha_lo)^0.5 = hi / lo`
    /// (versions 12-15 had no `CORR_STRETCH_MAX`, version 16 10).
    fn stretch_of(&self, lo: usize, hi: usize) -> f32 {
        if self.grid_of(lo, hi) == CORR_GRID_PLAIN {
            1.0
        } else {
            (hi as f32 / lo as f32).min(self.cap)
        }
    }

    /// Whether the old table's block `(jx, jy)` has the new one's grid
    /// and stretch (the grids compare every field; `corr_stretch` within
    /// f32 rounding); node 0's blocks are not in the new layout.
    fn shares(&self, jx: usize, jy: usize) -> bool {
        let (lo, hi) = (jx.min(jy), jx.max(jy));
        if lo == 0 {
            return false;
        }
        let (old, new) = (self.stretch_of(lo, hi), corr_stretch(lo, hi));
        self.grid_of(lo, hi) == corr_pair_grid(lo, hi) && (old - new).abs() <= 1e-5 * new
    }

    /// Blocks per NDF that [`OldLayout::copy_shared_blocks`] copies.
    fn shared(&self) -> usize {
        Self::pairs()
            .filter(|&(lo, hi)| self.shares(lo, hi))
            .count()
    }

    /// Copies the blocks the old table `raw` shares with the new layout
    /// into `table` (the new layout's `u16`).
    fn copy_shared_blocks(&self, raw: &[u8], table: &mut [u16]) {
        let values = |lo, hi| self.grid_of(lo, hi).nodes() * CORR_VALUES;
        let ndf_len: usize = Self::pairs().map(|(lo, hi)| values(lo, hi)).sum();
        let mut copied = 0;
        for n in 0..2 {
            // The block's first value in the old table.
            let mut old = n * ndf_len;
            for (lo, hi) in Self::pairs() {
                let len = values(lo, hi);
                if self.shares(lo, hi) {
                    let new = corr_index(n, lo, hi, 0, 0) * CORR_VALUES;
                    for v in 0..len {
                        let b = HEADER_BYTES + 2 * (old + v);
                        table[new + v] = u16::from_le_bytes([raw[b], raw[b + 1]]);
                    }
                    copied += 1;
                }
                old += len;
            }
        }
        eprintln!("REUSE: {copied} blocks copied");
    }
}

/// `CONDUCTOR_E_ANISO` read as eval reads it (bilinear in the two alpha
/// coordinates, linear in azimuth and in the cosine coordinate).
fn e_table(n: usize, ax: f32, ay: f32, w: Vec3) -> f32 {
    let split = |x: f32, len: usize| {
        let x = x.clamp(0.0, (len - 1) as f32);
        let i = (x as usize).min(len - 2);
        (i, x - i as f32)
    };
    let ac = |a: f32| (a / 2.0).clamp(0.0, 1.0).sqrt() * (AN_A - 1) as f32;
    let (jx, fx) = split(ac(ax), AN_A);
    let (jy, fy) = split(ac(ay), AN_A);
    let phi = w.y.abs().atan2(w.x.abs());
    let (k, fk) = split(
        phi / std::f32::consts::FRAC_PI_2 * (AN_PHI - 1) as f32,
        AN_PHI,
    );
    let m0 = aniso_grid_mu(0);
    let (i, fi) = split(
        ((w.z.abs() - m0) / (1.0 - m0)).clamp(0.0, 1.0).sqrt() * (AN_MU - 1) as f32,
        AN_MU,
    );
    let mut v = 0.0;
    for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
        for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (dk, wk) in [(0, 1.0 - fk), (1, fk)] {
                for (di, wi) in [(0, 1.0 - fi), (1, fi)] {
                    v += wx
                        * wy
                        * wk
                        * wi
                        * CONDUCTOR_E_ANISO[n][jx + dx][jy + dy][k + dk][i + di].get();
                }
            }
        }
    }
    v
}

/// `--check`: where the anisotropic furnace error sits. Per case (NDF,
/// roughness pair, incident direction): the albedo of TABULATED's eval by
/// quadrature (`--quad`, default 400) minus 1, split into SINGLE's albedo
/// minus the interpolated `E` the lobe is normalised to (the target's
/// error) and the multiply scattered albedo minus `1 - E` (the lobe's
/// error), and the latter at the generator's quadrature (96).
fn check(quad: usize) {
    let white = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let mut cases = Vec::new();
    for n in 0..2 {
        for (ax, ay) in [(0.1f32, 0.6f32), (0.3, 1.0)] {
            for theta in [0.0f32, 45.0, 80.0, 89.0] {
                for phi in [0.0f32, 45.0, 90.0] {
                    cases.push((n, ax, ay, theta.to_radians(), phi.to_radians()));
                }
            }
        }
    }
    let mut pick = Rng::new(2718, 2);
    let mut nodes = 0;
    while nodes < 16 {
        let n = (pick.next_u32() % 2) as usize;
        let jx = (pick.next_u32() % CORR_A as u32) as usize;
        let jy = (pick.next_u32() % CORR_A as u32) as usize;
        let (ax, ay) = (corr_grid_alpha(jx), corr_grid_alpha(jy));
        if jx == jy || ax < 0.05 || ay < 0.05 {
            continue;
        }
        nodes += 1;
        let g = corr_pair_grid(jx, jy);
        let k = (pick.next_u32() % g.phi as u32) as usize;
        let nmu = g.mu;
        let i = (pick.next_u32() % nmu as u32) as usize;
        let w = corr_node_dir(k * nmu + i, corr_stretch(jx, jy));
        cases.push((n, ax, ay, w.z.acos(), w.y.atan2(w.x)));
    }
    // Random materials and directions (between nodes in general).
    let mut pick = Rng::new(31415, 9);
    for _ in 0..32 {
        let n = (pick.next_u32() % 2) as usize;
        let ax = 0.05 + 1.95 * pick.next_f32() * pick.next_f32();
        let ay = 0.05 + 1.95 * pick.next_f32();
        let theta = (89.0 * pick.next_f32().sqrt()).to_radians();
        cases.push((
            n,
            ax,
            ay,
            theta,
            std::f32::consts::FRAC_PI_2 * pick.next_f32(),
        ));
    }
    println!("ndf (ax, ay) theta phi: total-1 | E_exact-E_tab | A_ms-(1-E_tab) | A_ms(96)-A_ms");
    let (mut worst, mut worst_e, mut worst_a) = (0.0f64, 0.0f64, 0.0f64);
    for (n, ax, ay, theta, phi) in cases {
        let ndf = Ndf::new(NDFS[n], ax, ay);
        let tab = Tabulated::new(ndf, white);
        let single = Single::new(ndf, white, G2Form::HeightCorrelated);
        let (st, ct) = theta.sin_cos();
        let wi = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
        let mut rng = Rng::new(0, 0);
        let mut r2 = Rng::new(0, 0);
        let e_exact = single_albedo(|x, y| single.eval(x, y, &mut rng).x, ax, ay, wi, None, quad);
        let ms = |q: usize, rng: &mut Rng| {
            single_albedo(
                |x, y| tab.eval(x, y, rng).x - single.eval(x, y, rng).x,
                ax,
                ay,
                wi,
                None,
                q,
            )
        };
        let a = ms(quad, &mut r2);
        let a96 = ms(96, &mut r2);
        let e_tab = e_table(n, ax, ay, wi) as f64;
        // E_exact interpolated in azimuth and cosine only (the material's
        // own roughness): the floor of any finer roughness grid.
        let e_dir = {
            let mut v = 0.0;
            for (r, wt) in corr_dir_weights(wi, 1.0) {
                if wt == 0.0 {
                    continue;
                }
                let mut rr = Rng::new(0, 0);
                v += wt as f64
                    * single_albedo(
                        |x, y| single.eval(x, y, &mut rr).x,
                        ax,
                        ay,
                        corr_node_dir(r, 1.0),
                        None,
                        quad,
                    );
            }
            v
        };
        println!(
            "   E_exact - E interpolated in direction only: {:+.4}",
            e_exact - e_dir
        );
        let total = e_exact + a - 1.0;
        worst = worst.max(total.abs());
        worst_e = worst_e.max((e_exact - e_tab).abs());
        worst_a = worst_a.max((a - (1.0 - e_tab)).abs());
        println!(
            "{:?} ({ax:.3}, {ay:.3}) {:.1} {:.1}: {:+.4} | {:+.4} | {:+.4} | {:+.4}",
            NDFS[n],
            theta.to_degrees(),
            phi.to_degrees(),
            total,
            e_exact - e_tab,
            a - (1.0 - e_tab),
            a96 - a
        );
    }
    println!(
        "worst |total - 1| {worst:.4}, |E_exact - E_tab| {worst_e:.4}, |A_ms - (1 - E_tab)| {worst_a:.4}"
    );
}

/// `--ir MODEL NDF CALLS [glass] [sample] [alpha=AX,AY]` (MODEL `single`
/// or `tabulated`, NDF `ggx` or `beckmann`): CALLS evals (samples with
/// `sample`, from the pairs' first directions) through `Material` of gold (or glass
/// 1.5) with roughness (0.1, 0.6) (or `(AX, AY)`) on 1024 fixed random pairs (directions
/// up to 85 degrees, both above for gold, on either side for glass), for
/// callgrind: `(Ir(CALLS) - Ir(0)) / CALLS` is the cost per
/// eval.
fn ir(args: &[String]) {
    use msbsdf::{FacetKind, Material, MaterialDesc, Model, NdfId};
    let get = |i: usize| args.get(i).map(String::as_str).unwrap_or("");
    let model = if get(0) == "tabulated" {
        Model::Tabulated
    } else {
        Model::Single
    };
    let ndf = if get(1) == "beckmann" {
        NdfId::Beckmann
    } else {
        NdfId::Ggx
    };
    let calls: usize = get(2).parse().unwrap_or(0);
    let glass = get(3) == "glass";
    // `alpha=AX,AY` anywhere after CALLS: another roughness pair.
    let (alpha_x, alpha_y) = args
        .iter()
        .find_map(|a| a.strip_prefix("alpha="))
        .and_then(|a| a.split_once(','))
        .and_then(|(x, y)| Some((x.parse().ok()?, y.parse().ok()?)))
        .unwrap_or((0.1, 0.6));
    let d = if glass {
        MaterialDesc {
            model,
            ndf,
            facet: FacetKind::Dielectric,
            alpha_x,
            alpha_y,
            eta: Vec3::splat(1.5),
            ..Default::default()
        }
    } else {
        MaterialDesc {
            model,
            ndf,
            facet: FacetKind::Conductor,
            alpha_x,
            alpha_y,
            eta: Vec3::new(0.143, 0.374, 1.442),
            k: Vec3::new(3.983, 2.385, 1.603),
            ..Default::default()
        }
    };
    let Ok(m) = Material::new(&d) else {
        eprintln!("material refused");
        return;
    };
    let mut r = Rng::new(3, 9);
    let mut dir = || {
        let z = 1.0 - r.next_f32() * (1.0 - 0.087);
        let ph = r.next_f32() * std::f32::consts::TAU;
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * ph.cos(), s * ph.sin(), z)
    };
    // Glass: wi on either side, wo anywhere.
    let mut flip = Rng::new(7, 7);
    let pairs: Vec<(Vec3, Vec3)> = (0..1024)
        .map(|_| {
            let (mut a, mut b) = (dir(), dir());
            if glass && flip.next_f32() < 0.5 {
                a.z = -a.z;
            }
            if glass && flip.next_f32() < 0.5 {
                b.z = -b.z;
            }
            (a, b)
        })
        .collect();
    let mut rng = Rng::new(5, 5);
    let mut acc = Vec3::ZERO;
    if args.iter().any(|a| a == "sample") {
        for j in 0..calls {
            acc += m.sample(pairs[j & 1023].0, &mut rng).weight;
        }
    } else {
        for j in 0..calls {
            let (a, b) = pairs[j & 1023];
            acc += m.eval(a, b, &mut rng);
        }
    }
    std::hint::black_box(acc);
}

/// One block of the dielectric correction: NDF `n`, lobe roughness nodes
/// `1 <= jx <= jy`, index node `e` of the correction (glass-like material
/// `eta = dcorr_grid_eta(e)`, at least 1: the thin side outside). Rows and columns `side * 112 + node`.
/// The target is `1 - E_ss` with `E_ss` SINGLE's reflected plus transmitted
/// albedo (`quad` x `quad` normals); the uncorrected lobe's reflection is
/// integrated over the same normals, its transmission over a `2 quad / 3
/// x 4 quad / 3` grid of directions in `(sqrt(1 - |z|), phi)` (the
/// transmitted multiply scattered lobe is broad).
fn dielectric_block(n: usize, jx: usize, jy: usize, e: usize, quad: usize) -> (Vec<f32>, Stats) {
    let (m, target) = dielectric_system(
        n,
        jx,
        jy,
        msbsdf::multiple::tabulated_dielectric::dcorr_grid_eta(e),
        quad,
    );
    solve(&m, &target)
}

/// The system of [`dielectric_block`] at any index `eta >= 1`: the matrix
/// `M` (rows and columns `side * 112 + node`) and the targets `1 - E_ss`.
fn dielectric_system(
    n: usize,
    jx: usize,
    jy: usize,
    eta: f32,
    quad: usize,
) -> (Vec<Vec<f64>>, Vec<f64>) {
    use msbsdf::multiple::tabulated_dielectric::{DCORR_BLOCK, TabulatedDielectric, grid_alpha};
    let (ax, ay) = (grid_alpha(jx), grid_alpha(jy));
    let ay = if jx == jy { ay * 1.0001 } else { ay };
    let facet = Facet::Dielectric { eta };
    let ndf = Ndf::new(NDFS[n], ax, ay);
    let tab = TabulatedDielectric::new(ndf, facet).without_aniso_correction();
    let single = Single::new(ndf, facet, G2Form::HeightCorrelated);
    let mut rng = Rng::new(0, 0);
    // The block's azimuth nodes are stretched by its own anisotropy.
    let rho = msbsdf::multiple::tabulated_dielectric::dcorr_stretch(jx, jy);
    let rows = DCORR_BLOCK;
    let half = rows / 2;
    let mut target = vec![0.0f64; rows];
    let mut m = vec![vec![0.0f64; rows]; rows];
    let (nz, np) = (2 * quad / 3, 4 * quad / 3);
    for r in 0..rows {
        let side = r / half;
        let sign = if side == 0 { 1.0 } else { -1.0 };
        let up = dcorr_node_dir(r % half, rho);
        let world = |v: Vec3| Vec3::new(v.x, v.y, v.z * sign);
        let wi = world(up);
        let eta_l = if side == 0 { eta } else { 1.0 / eta };
        target[r] = 1.0
            - single_albedo(
                |a, b| single.eval(world(a), world(b), &mut rng).x,
                ax,
                ay,
                up,
                Some(eta_l),
                quad,
            );
        let mut add = |wo: Vec3, w: f64, col_side: usize, rng: &mut Rng| {
            let l0 = (tab.eval(wi, wo, rng).x - single.eval(wi, wo, rng).x).max(0.0);
            if l0 > 0.0 {
                for (node, b) in dcorr_dir_weights(wo, rho) {
                    m[r][col_side * half + node] += l0 as f64 * w * b as f64;
                }
            }
        };
        // Reflection: the lobe is broad, and with strongly anisotropic
        // roughness the normals' reflections alone leave most of the
        // hemisphere empty (the solve then boosted what they missed).
        broad_reflection_nodes(ax, ay, up, quad, (nz, np), |wo, w| {
            add(world(wo), w, side, &mut rng)
        });
        lower_hemisphere_nodes(nz, np, |wo, w| add(world(wo), w, 1 - side, &mut rng));
    }
    (m, target)
}

/// The symmetric Sinkhorn iteration `s_r <- s_r sqrt(target_r / albedo_r)`,
/// `albedo_r = s_r (M s)_r`, to 1e-6 or 3000 steps, clamped to `[S_MIN,
/// CORR_MAX]`, then rounded to the stored `u16`; rows without energy to
/// correct keep 1.
fn solve<R: AsRef<[f64]>>(m: &[R], target: &[f64]) -> (Vec<f32>, Stats) {
    solve_within(m, target, false)
}

/// [`solve`]; with `zero_empty`, a row whose target is below 1e-4 (`E_ss`
/// about 1) and whose lobe is not empty gets the factor [`S_MIN`]
/// instead of 1 (the low-roughness blocks of version 17: with 1 the
/// uncorrected lobe kept its energy there, Beckmann (0.0022, 0.0089) at
/// 89 degrees on the smooth axis +0.9%).
fn solve_within<R: AsRef<[f64]>>(m: &[R], target: &[f64], zero_empty: bool) -> (Vec<f32>, Stats) {
    let rows = target.len();
    let active: Vec<bool> = (0..rows)
        .map(|r| target[r] >= 1e-4 && m[r].as_ref().iter().sum::<f64>() >= 1e-4)
        .collect();
    // Inactive rows' factor: 1, or S_MIN where the target is (nearly) 0.
    let rest = |r: usize| {
        if zero_empty && target[r] < 1e-4 && m[r].as_ref().iter().sum::<f64>() > 0.0 {
            S_MIN as f64
        } else {
            1.0
        }
    };
    let (lo, hi) = (S_MIN as f64, CORR_MAX as f64);
    let albedo =
        |s: &[f64], r: usize| s[r] * m[r].as_ref().iter().zip(s).map(|(a, b)| a * b).sum::<f64>();
    let mut s: Vec<f64> = (0..rows)
        .map(|r| if active[r] { 1.0 } else { rest(r) })
        .collect();
    let mut stats = Stats::default();
    for step in 0..3000 {
        let mut worst = 0.0f64;
        let next: Vec<f64> = (0..rows)
            .map(|r| {
                if !active[r] {
                    return rest(r);
                }
                let a = albedo(&s, r);
                worst = worst.max((a / target[r] - 1.0).abs());
                (s[r] * (target[r] / a).sqrt()).clamp(lo, hi)
            })
            .collect();
        s = next;
        stats.steps = step + 1;
        if worst < 1e-6 {
            break;
        }
    }
    let s: Vec<f64> = s
        .iter()
        .map(|&v| corr_decode(corr_encode(v as f32, CORR_MAX), CORR_MAX) as f64)
        .collect();
    for r in (0..rows).filter(|&r| active[r]) {
        stats.residual = stats.residual.max((albedo(&s, r) - target[r]).abs());
        stats.clamped += (s[r] <= lo * 1.001 || s[r] >= hi * 0.999) as usize;
    }
    (s.iter().map(|&v| v as f32).collect(), stats)
}

/// `--dielectric`: `data/tabulated_aniso_dielectric.bin`, the anisotropic
/// furnace correction of TABULATED's dielectric tier: per NDF, pair of the
/// lobe table's roughness nodes `1 <= jx <= jy` (9 per axis), index node
/// (`DCORR_ETA_N`: the lobe table's 6, the midpoints in `ln E` of its
/// intervals, the first quarter point of the lowest, 1.107, and its
/// first eighth point, 1.078) and
/// side, on `DCORR_PHI` azimuths (`tabulated::dcorr_dir`) and
/// ENERGY_COMPENSATED's cosine grid, factors
/// `s` such that the lobe (read at the pair's effective roughness, with
/// its isotropic furnace scales) scaled by `s(wi) s(wo)` has the multiply
/// scattered albedo `1 - E_ss` (reflected plus transmitted) at every node
/// from both sides; solved per block like the conductor's (`block`).
fn dielectric(args: &[String], quad: usize) {
    use msbsdf::multiple::tabulated_dielectric::{
        ALPHA_N, DCORR_BLOCK, DCORR_ETA_N, DCORR_LEN, DCORR_MAGIC, DCORR_PHI, ETA_MAX, ETA_MIN,
        dcorr_index,
    };
    let t0 = std::time::Instant::now();
    let only: Option<usize> = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|p| args.get(p + 1))
        .and_then(|v| v.parse().ok());
    let mut jobs: Vec<(usize, usize, usize, usize)> = Vec::new();
    for n in 0..2 {
        for jx in 1..ALPHA_N {
            for jy in jx..ALPHA_N {
                for e in 0..DCORR_ETA_N {
                    jobs.push((n, jx, jy, e));
                }
            }
        }
    }
    jobs.sort_by_key(|&(_, jx, jy, _)| usize::MAX - jx - jy);
    if let Some(k) = only {
        jobs.truncate(k);
    }
    let results = run_jobs(&jobs, 2, "blocks", t0, |&(n, jx, jy, e)| {
        dielectric_block(n, jx, jy, e, quad)
    });
    let one = corr_encode(1.0, CORR_MAX);
    let mut table = vec![one; DCORR_LEN];
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    let mut stats = Stats::default();
    let half = DCORR_BLOCK / 2;
    for (idx, block, st) in results.into_iter().flatten() {
        let (n, jx, jy, e) = jobs[idx];
        stats.residual = stats.residual.max(st.residual);
        stats.clamped += st.clamped;
        stats.steps = stats.steps.max(st.steps);
        for (r, &v) in block.iter().enumerate() {
            lo = lo.min(v);
            hi = hi.max(v);
            let (side, node) = (r / half, r % half);
            table[dcorr_index(n, jx, jy, e, side, node / AN_MU, node % AN_MU)] =
                corr_encode(v, CORR_MAX);
        }
    }
    let command: Vec<String> = args.iter().skip(1).cloned().collect();
    let header = format!(
        "DIELECTRIC ANISO_CORRECTION v12 (MSBSDF_MODEL_TABULATED, dielectric facets): factors s \
         per [ndf: Beckmann, GGX][pair of the lobe table's roughness nodes 1 <= jx <= jy <= \
         {}][index node: {DCORR_ETA_N}, in ln E from {ETA_MIN} to {ETA_MAX}: the lobe \
         table's nodes, the midpoints of its intervals, the first quarter point of the lowest \
         and its first eighth point (tabulated_dielectric::dcorr_grid_eta)][side: thin, \
         dense][phi: {DCORR_PHI}][mu: {AN_MU}] \
         (azimuth: uniform nodes from 0 to 1 of u = c - 0.4637 c (1 - c) (1 - 2 c), c = rho \
         |y| / (|x| + rho |y|) the diamond angle stretched by the block's rho = sqrt(jy / jx) \
         (tabulated::dcorr_stretch), tabulated::dcorr_phi, within 0.35 degrees of phi / 90 \
         degrees at rho = 1; mu: ENERGY_COMPENSATED's anisotropic cosine grid without its \
         second node and with one at the angle midpoint of its last interval, \
         tabulated::dcorr_grid_mu) as little-endian u16 v, \
         s = {CORR_MAX} (v / 65535)^2, after this {HEADER_BYTES}-byte header; (jx > jy, k) \
         reads (jy, jx, {} - k); an axis at node 0 reads 1. The lobe \
         (TabulatedDielectric::without_aniso_correction minus SINGLE) scaled by s(wi) s(wo) \
         has the multiply scattered albedo 1 - E_ss (reflection plus transmission) at every \
         node of both sides; E_ss by quadrature over {quad} x {quad} normals, the \
         reflection over compensation::broad_reflection_nodes (those normals and the upper \
         half of the transmission's grid, split by node density), the transmission over a \
         {} x {} direction grid; symmetric Sinkhorn \
         iteration per block (residual 1e-6 or 3000 steps); no random numbers. Diagonal \
         nodes at alpha_y (1 + 1e-4); clamped to [{S_MIN}, {CORR_MAX}]. Range {lo:.4} - \
         {hi:.4}; worst |albedo - (1 - E_ss)| at the nodes after rounding {:.2e}; {} clamped \
         factors; at most {} Sinkhorn steps.\n\
         Command: cargo run --release --example gen_tabulated_aniso{}{}\nCommit: {}\n\
         Time: {:.0} s\n",
        ALPHA_N - 1,
        DCORR_PHI - 1,
        2 * quad / 3,
        4 * quad / 3,
        stats.residual,
        stats.clamped,
        stats.steps,
        if command.is_empty() { "" } else { " -- " },
        command.join(" "),
        git::commit(),
        t0.elapsed().as_secs_f32()
    );
    let bytes = table_bytes(DCORR_MAGIC, &header, &table);
    let path = format!(
        "{}/data/tabulated_aniso_dielectric.bin",
        env!("CARGO_MANIFEST_DIR")
    );
    if only.is_some() {
        eprintln!("{header}(--only: not written)");
        return;
    }
    std::fs::write(&path, bytes).expect("write the table file");
    eprintln!("{header}wrote {path}");
}

/// A solved dielectric correction block with its system: `M`, the
/// targets and the factors.
type Solved = (Vec<Vec<f64>>, Vec<f64>, Vec<f32>);

/// `--dielectric-eta-scan [--quad N]` (default 64): how the dielectric
/// correction's linear interpolation in `ln E` fares with 6, 11 and 16
/// index nodes: per NDF and a few roughness node pairs, the factors solved
/// at the index nodes and interpolated to the midpoints between them, and
/// the furnace error there at the correction's directions, `max_r |s_r (M
/// s)_r - t_r|` with `M` and the targets `t` at the midpoint's index,
/// printed as `midpoint:error/error of the factors solved there[side, phi
/// node, mu node (hex) of the worst row, its factor solved there and at
/// the two nodes]`.
fn dielectric_eta_scan(quad: usize) {
    use msbsdf::multiple::tabulated_dielectric::{ETA_MAX, ETA_MIN};
    let from = |u: f32| (ETA_MIN.ln() + u * (ETA_MAX.ln() - ETA_MIN.ln())).exp();
    let combos: Vec<(usize, usize, usize)> = [(2, 5), (1, 3), (3, 7), (5, 8)]
        .iter()
        .flat_map(|&(a, b)| [(0, a, b), (1, a, b)])
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    std::thread::scope(|sc| {
        for _ in 0..2 {
            sc.spawn(|| {
                loop {
                    let idx = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(&(n, jx, jy)) = combos.get(idx) else {
                        break;
                    };
                    let mut cache: std::collections::HashMap<u32, Solved> =
                        std::collections::HashMap::new();
                    let mut get = |eta: f32| {
                        cache
                            .entry(eta.to_bits())
                            .or_insert_with(|| {
                                let (m, t) = dielectric_system(n, jx, jy, eta, quad);
                                let s = solve(&m, &t).0;
                                (m, t, s)
                            })
                            .clone()
                    };
                    let ns: &[usize] = if std::env::var("QUAD_ONLY").is_ok() {
                        &[]
                    } else {
                        &[6, 11, 16]
                    };
                    for &nn in ns {
                        let mut per = Vec::new();
                        for k in 0..nn - 1 {
                            let (ea, eb) = (
                                from(k as f32 / (nn - 1) as f32),
                                from((k + 1) as f32 / (nn - 1) as f32),
                            );
                            let em = from((k as f32 + 0.5) / (nn - 1) as f32);
                            let (sa, sb) = (get(ea).2, get(eb).2);
                            let (m, t, se) = get(em);
                            let s: Vec<f64> = sa
                                .iter()
                                .zip(&sb)
                                .map(|(a, b)| 0.5 * (*a as f64 + *b as f64))
                                .collect();
                            let se: Vec<f64> = se.iter().map(|&v| v as f64).collect();
                            let (mut worst, mut floor, mut wr) = (0.0f64, 0.0f64, 0);
                            for r in 0..t.len() {
                                if t[r] < 1e-4 || m[r].iter().sum::<f64>() < 1e-4 {
                                    continue;
                                }
                                let albedo = |s: &[f64]| {
                                    s[r] * m[r].iter().zip(s).map(|(x, y)| x * y).sum::<f64>()
                                };
                                let a = albedo(&s);
                                if (a - t[r]).abs() > worst {
                                    worst = (a - t[r]).abs();
                                    wr = r;
                                }
                                floor = floor.max((albedo(&se) - t[r]).abs());
                            }
                            let half = t.len() / 2;
                            let (side, k, i) = (wr / half, wr % half / AN_MU, wr % AN_MU);
                            per.push(format!(
                                "{em:.3}:{worst:.4}/{floor:.4}[{side}{k}{i:x} {:.2} {:.2}-{:.2}]",
                                se[wr], sa[wr], sb[wr]
                            ));
                        }
                        println!("ndf {n} ({jx},{jy}) ln E N={nn}: {}", per.join(" "));
                    }
                    // 11 nodes: linear between neighbours against quadratic
                    // through the three nodes of each lobe interval, at
                    // its quarter points.
                    let mut per = Vec::new();
                    for k in 0..5 {
                        let e3: Vec<f32> =
                            (0..3).map(|d| from((2 * k + d) as f32 / 10.0)).collect();
                        let s3: Vec<Vec<f32>> = e3.iter().map(|&e| get(e).2).collect();
                        for t in [0.25f64, 0.75] {
                            let em = from((2.0 * k as f32 + 2.0 * t as f32) / 10.0);
                            let (m, tg, _) = get(em);
                            let (l0, l1, l2) = (
                                2.0 * (t - 0.5) * (t - 1.0),
                                -4.0 * t * (t - 1.0),
                                2.0 * t * (t - 0.5),
                            );
                            let quad: Vec<f64> = (0..tg.len())
                                .map(|r| {
                                    (l0 * s3[0][r] as f64
                                        + l1 * s3[1][r] as f64
                                        + l2 * s3[2][r] as f64)
                                        .max(0.0)
                                })
                                .collect();
                            let (a, b, u) = if t < 0.5 {
                                (0, 1, 2.0 * t)
                            } else {
                                (1, 2, 2.0 * t - 1.0)
                            };
                            let lin: Vec<f64> = (0..tg.len())
                                .map(|r| s3[a][r] as f64 * (1.0 - u) + s3[b][r] as f64 * u)
                                .collect();
                            let worst = |s: &[f64]| {
                                let mut w = 0.0f64;
                                for r in 0..tg.len() {
                                    if tg[r] < 1e-4 || m[r].iter().sum::<f64>() < 1e-4 {
                                        continue;
                                    }
                                    let al =
                                        s[r] * m[r].iter().zip(s).map(|(x, y)| x * y).sum::<f64>();
                                    w = w.max((al - tg[r]).abs());
                                }
                                w
                            };
                            per.push(format!("{em:.3}:{:.4}/{:.4}", worst(&lin), worst(&quad)));
                        }
                    }
                    println!(
                        "ndf {n} ({jx},{jy}) N=11 linear/quadratic: {}",
                        per.join(" ")
                    );
                }
            });
        }
    });
}

/// `--dielectric-random [COUNT]`: the white furnace of anisotropic
/// TABULATED glass at `COUNT` (default 200) random cases: NDF, `alpha_x`
/// and `alpha_y` (log-uniform in [0.05, 1.9]), relative index `E`
/// (log-uniform in [1.05, 3]) seen from a random side, and incident
/// direction (cosine uniform from `cos 89` degrees to 1, azimuth uniform);
/// the albedo by the quadrature of `tests/tabulated_dielectric.rs` (SINGLE
/// and the multiply scattered reflection over 400 x 400 normals, 800 x 800
/// above alpha 1, the transmission over a third by two thirds of that in
/// directions). Prints the worst `|albedo - 1|` per range of `E` and the
/// worst cases. `--isotropic`: `alpha_y = alpha_x` (log-uniform in
/// [0.002, 1.9]); `--grazing`: `theta` uniform in [80, 89] degrees.
fn dielectric_random(args: &[String]) {
    use msbsdf::multiple::tabulated_dielectric::TabulatedDielectric;
    let count: usize = args
        .iter()
        .position(|a| a == "--dielectric-random")
        .and_then(|p| args.get(p + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(200);
    let isotropic = args.iter().any(|a| a == "--isotropic");
    let grazing = args.iter().any(|a| a == "--grazing");
    let mut rng = Rng::new(2026, 11);
    let cases: Vec<(usize, f32, f32, f32, Vec3)> = (0..count)
        .map(|_| {
            let mut u = || rng.next_f32();
            let n = (u() < 0.5) as usize;
            let lo: f32 = if isotropic { 0.002 } else { 0.05 };
            let la = |v: f32| (lo.ln() + v * (1.9f32.ln() - lo.ln())).exp();
            let ax = la(u());
            let ay = if isotropic { ax } else { la(u()) };
            let e = (1.05f32.ln() + u() * (3.0f32.ln() - 1.05f32.ln())).exp();
            let eta = if u() < 0.5 { e } else { 1.0 / e };
            let mu = if grazing {
                (80.0 + 9.0 * u()).to_radians().cos()
            } else {
                89f32.to_radians().cos() + u() * (1.0 - 89f32.to_radians().cos())
            };
            let phi = u() * std::f32::consts::TAU;
            let st = (1.0 - mu * mu).max(0.0).sqrt();
            let side = if u() < 0.5 { 1.0 } else { -1.0 };
            (
                n,
                ax,
                ay,
                eta,
                Vec3::new(st * phi.cos(), st * phi.sin(), side * mu),
            )
        })
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let out = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|sc| {
        for _ in 0..2 {
            sc.spawn(|| {
                loop {
                    let idx = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(&(n, ax, ay, eta, wi)) = cases.get(idx) else {
                        break;
                    };
                    let ndf = Ndf::new(NDFS[n], ax, ay);
                    let facet = Facet::Dielectric { eta };
                    let t = TabulatedDielectric::new(ndf, facet);
                    let s = Single::new(ndf, facet, G2Form::HeightCorrelated);
                    let q = glass_albedo(&t, &s, wi, ax, ay, eta);
                    out.lock().expect("out").push((idx, q - 1.0));
                }
            });
        }
    });
    let mut res = out.into_inner().expect("out");
    res.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    let ranges = [(1.0f32, 1.3f32), (1.3, 2.0), (2.0, 3.01)];
    for (lo, hi) in ranges {
        let sel: Vec<f64> = res
            .iter()
            .filter(|(i, _)| {
                let e = cases[*i].3.max(1.0 / cases[*i].3);
                (lo..hi).contains(&e)
            })
            .map(|r| r.1.abs())
            .collect();
        let mut sorted = sel.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        let pct = |p: f64| {
            sorted
                .get(((sorted.len() as f64 - 1.0) * p) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        println!(
            "E in [{lo}, {hi}): {} cases, worst {:.4}, 90% {:.4}, median {:.4}",
            sel.len(),
            pct(1.0),
            pct(0.9),
            pct(0.5)
        );
    }
    for &(i, d) in res.iter().take(12) {
        let (n, ax, ay, eta, wi) = cases[i];
        println!(
            "{:?} ({ax:.3},{ay:.3}) eta {eta:.3} wi ({:.3},{:.3},{:.3}) theta {:.1}: {d:+.4}",
            NDFS[n],
            wi.x,
            wi.y,
            wi.z,
            wi.z.abs().acos().to_degrees()
        );
    }
}

/// Roughness values of the furnace sweeps (pairs `alpha_x < alpha_y`).
const SWEEP_ALPHAS: [f32; 6] = [0.05, 0.11, 0.3, 0.6, 1.0, 1.9];

/// The sweeps' azimuth count: `--azimuths N` (at least 2), 9 by default
/// (11.25 degrees apart; features of the correction between its azimuth
/// nodes can hide between them: 33 is 2.8 degrees apart).
fn azimuths_arg(args: &[String]) -> usize {
    count_arg(args, "--azimuths", 9).max(2)
}

/// The count after `flag` (`--rows 40`), `default` if absent or not a
/// number.
fn count_arg(args: &[String], flag: &str, default: usize) -> usize {
    args.iter()
        .position(|a| a == flag)
        .and_then(|p| args.get(p + 1)?.parse().ok())
        .unwrap_or(default)
}

/// The comma-separated numbers after `flag` (`--thetas 60,75`), if given.
fn list_arg(args: &[String], flag: &str) -> Option<Vec<f32>> {
    args.iter()
        .position(|a| a == flag)
        .and_then(|p| args.get(p + 1))
        .map(|v| v.split(',').filter_map(|t| t.trim().parse().ok()).collect())
}

/// The sweeps' roughness values: `--alphas A,B,...` (pairs `alpha_x <
/// alpha_y` of them), [`SWEEP_ALPHAS`] by default.
fn alphas_arg(args: &[String]) -> Vec<f32> {
    list_arg(args, "--alphas")
        .filter(|v| v.len() >= 2)
        .unwrap_or_else(|| SWEEP_ALPHAS.to_vec())
}

/// The polar angles of the sweeps in degrees: `--thetas A,B,...`, by
/// default 0, 30, 60, 75, 85 and 89.
fn thetas_arg(args: &[String]) -> Vec<f32> {
    list_arg(args, "--thetas")
        .filter(|v| !v.is_empty())
        .unwrap_or_else(|| vec![0.0, 30.0, 60.0, 75.0, 85.0, 89.0])
}

/// Incident directions of the furnace sweeps: the polar angles `thetas`
/// in degrees ([`thetas_arg`]) times `azimuths` uniform azimuths from 0 to
/// 90 degrees.
fn sweep_dirs(azimuths: usize, thetas: &[f32]) -> impl Iterator<Item = Vec3> + '_ {
    let step = 90.0 / (azimuths - 1) as f32;
    thetas.iter().flat_map(move |&th| {
        (0..azimuths).map(move |k| {
            let (th, ph) = (th.to_radians(), (k as f32 * step).to_radians());
            Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
        })
    })
}

/// Prints the spread of furnace errors `albedo - 1`: their count, the
/// worst, 99th and 90th percentiles and median of their magnitudes, and
/// how many exceed 0.5%.
fn print_spread(errors: impl Iterator<Item = f64>) {
    let mut a: Vec<f64> = errors.map(f64::abs).collect();
    a.sort_by(|x, y| y.total_cmp(x));
    let pct = |p: f64| {
        a.get(((a.len().max(1) - 1) as f64 * (1.0 - p)) as usize)
            .copied()
    };
    println!(
        "{} directions: worst {:.4}, 99% {:.4}, 90% {:.4}, median {:.4}, over 0.5%: {}",
        a.len(),
        pct(1.0).unwrap_or(0.0),
        pct(0.99).unwrap_or(0.0),
        pct(0.9).unwrap_or(0.0),
        pct(0.5).unwrap_or(0.0),
        a.iter().filter(|&&e| e > 0.005).count()
    );
}

/// The albedo (first channel) of a reflecting model from `wi` by the
/// furnace sweeps' quadrature: `compensation::broad_reflection_nodes`,
/// 400 x 400 normals and a 266 x 533 direction grid.
fn conductor_albedo<T: ScatterModel>(m: &T, ax: f32, ay: f32, wi: Vec3) -> f64 {
    let mut rng = Rng::new(0, 0);
    let mut q = 0.0;
    broad_reflection_nodes(ax, ay, wi, 400, (266, 533), |wo, w| {
        q += m.eval(wi, wo, &mut rng).x as f64 * w;
    });
    q
}

/// `--at NDF AX AY THETA PHI0 PHI1 STEP` (NDF 0 Beckmann, 1 GGX; angles
/// in degrees): the white furnace of anisotropic TABULATED with F = 1 at
/// `THETA` and azimuths from `PHI0` to `PHI1`, with the uncorrected lobe's
/// and SINGLE's albedo beside it ([`conductor_albedo`]).
fn conductor_at(args: &[String]) {
    let v: Vec<f32> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let [n, ax, ay, theta, phi0, phi1, step] = v[..] else {
        eprintln!("--at NDF AX AY THETA PHI0 PHI1 STEP");
        std::process::exit(2);
    };
    let white = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let ndf = Ndf::new(NDFS[(n as usize).min(1)], ax, ay);
    let tab = Tabulated::new(ndf, white);
    let bare = tab.without_aniso_correction();
    let single = Single::new(ndf, white, G2Form::HeightCorrelated);
    let th = theta.to_radians();
    let mut phi = phi0;
    while phi <= phi1 + 1e-3 {
        let p = phi.to_radians();
        let wi = Vec3::new(th.sin() * p.cos(), th.sin() * p.sin(), th.cos());
        let q = conductor_albedo(&tab, ax, ay, wi);
        let qb = conductor_albedo(&bare, ax, ay, wi);
        let qs = conductor_albedo(&single, ax, ay, wi);
        // With MC=N: the mean of N sample weights (an estimate independent
        // of the quadrature) and its standard error.
        let mc = match std::env::var("MC").ok().and_then(|v| v.parse::<u64>().ok()) {
            Some(count) if count > 1 => {
                let mut rng = Rng::new(7, 11);
                let (mut sum, mut sq) = (0.0f64, 0.0f64);
                for _ in 0..count {
                    let w = tab.sample(wi, &mut rng).weight.x as f64;
                    sum += w;
                    sq += w * w;
                }
                let mean = sum / count as f64;
                let se = ((sq / count as f64 - mean * mean).max(0.0) / count as f64).sqrt();
                format!(", sampled {:+.4} +- {se:.4}", mean - 1.0)
            }
            _ => String::new(),
        };
        println!(
            "phi {phi:6.2}: {:+.4} (uncorrected {:+.4}, SINGLE {qs:.4}{mc})",
            q - 1.0,
            qb - 1.0
        );
        phi += step.max(0.01);
    }
}

/// `--sweep [--azimuths N]`: the furnace of anisotropic TABULATED with F
/// = 1 (eval over `compensation::broad_reflection_nodes`, 400 x 400
/// normals and a 266 x 533 grid) on the grid of [`dielectric_sweep`]
/// without the index: both NDFs, roughness pairs `alpha_x < alpha_y` of
/// {0.05, 0.11, 0.3, 0.6, 1, 1.9}, `wi` at 0, 30, 60, 75, 85 and 89
/// degrees (or `--thetas`, [`thetas_arg`]), `N` azimuths from 0 to 90 (9
/// by default, [`azimuths_arg`]).
fn conductor_sweep(azimuths: usize, thetas: &[f32], alphas: &[f32]) {
    let white = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let mut materials = Vec::new();
    for n in 0..NDFS.len() {
        for (i, &ax) in alphas.iter().enumerate() {
            for &ay in &alphas[i + 1..] {
                materials.push((n, ax, ay));
            }
        }
    }
    let t0 = std::time::Instant::now();
    let results = run_jobs(&materials, 2, "materials", t0, |&(n, ax, ay)| {
        let tab = Tabulated::new(Ndf::new(NDFS[n], ax, ay), white);
        let rows = sweep_dirs(azimuths, thetas)
            .map(|wi| (wi, conductor_albedo(&tab, ax, ay, wi) - 1.0))
            .collect();
        (rows, Stats::default())
    });
    let mut res: Vec<(usize, f32, f32, Vec3, f64)> = results
        .into_iter()
        .flatten()
        .flat_map(|(idx, rows, _)| {
            let (n, ax, ay) = materials[idx];
            rows.into_iter().map(move |(wi, d)| (n, ax, ay, wi, d))
        })
        .collect();
    res.sort_by(|a, b| b.4.abs().total_cmp(&a.4.abs()));
    print_spread(res.iter().map(|r| r.4));
    // Per material: the worst direction and how many exceed 0.5%.
    for &(n, ax, ay) in &materials {
        let of = res.iter().filter(|r| (r.0, r.1, r.2) == (n, ax, ay));
        let (worst, over) = of.fold((0.0f64, 0), |(w, o), r| {
            (w.max(r.4.abs()), o + (r.4.abs() > 0.005) as usize)
        });
        println!(
            "{:?} ({ax:.3},{ay:.3}): worst {worst:.4}, over 0.5%: {over}",
            NDFS[n]
        );
    }
    for &(n, ax, ay, wi, d) in res.iter().take(12) {
        println!(
            "{:?} ({ax:.3},{ay:.3}) theta {:.0} phi {:.1}: {d:+.4}",
            NDFS[n],
            wi.z.acos().to_degrees(),
            wi.y.atan2(wi.x).to_degrees()
        );
    }
}

/// Relative indices `E` of the dielectric sweep (each seen from both
/// sides: `E` and `1 / E`); `--etas A,B,...` replaces them.
const SWEEP_ETAS: [f32; 5] = [1.05, 1.2, 1.5, 2.0, 3.0];

/// `--dielectric-sweep`: the furnace of anisotropic glass on a fixed grid
/// (no random numbers) that reaches the corners of the range: both NDFs,
/// roughness pairs `alpha_x < alpha_y` of {0.05, 0.11, 0.3, 0.6, 1, 1.9},
/// indices 1.05, 1.2, 1.5, 2 and 3 (or `--etas`) seen from both sides, `wi` at 0, 30,
/// 60, 75, 85 and 89 degrees (or `--thetas`) and `--azimuths N` azimuths from 0 to 90
/// degrees (9 by default, [`azimuths_arg`]). Prints
/// the worst, 99th and 90th percentiles and median of `|albedo - 1|` and
/// the `rows` worst cases (`--rows N`, 15 by default; a large `N` prints
/// every row, to see the furnace along `--thetas`). With `isotropic`, the
/// roughness pairs are `(a, a)` for each `a` of `alphas` instead
/// (isotropic glass; `--isotropic`).
fn dielectric_sweep(
    azimuths: usize,
    thetas: &[f32],
    alphas: &[f32],
    etas: &[f32],
    isotropic: bool,
    rows: usize,
) {
    use msbsdf::multiple::tabulated_dielectric::TabulatedDielectric;
    let mut materials = Vec::new();
    for n in 0..2 {
        for (i, &ax) in alphas.iter().enumerate() {
            let others = if isotropic {
                &alphas[i..=i]
            } else {
                &alphas[i + 1..]
            };
            for &ay in others {
                for &e in etas {
                    for eta in [e, 1.0 / e] {
                        materials.push((n, ax, ay, eta));
                    }
                }
            }
        }
    }
    let t0 = std::time::Instant::now();
    let results = run_jobs(&materials, 2, "materials", t0, |&(n, ax, ay, eta)| {
        let ndf = Ndf::new(NDFS[n], ax, ay);
        let facet = Facet::Dielectric { eta };
        let t = TabulatedDielectric::new(ndf, facet);
        let s = Single::new(ndf, facet, G2Form::HeightCorrelated);
        let rows = sweep_dirs(azimuths, thetas)
            .map(|wi| (wi, glass_albedo(&t, &s, wi, ax, ay, eta) - 1.0))
            .collect();
        (rows, Stats::default())
    });
    let mut res: Vec<(usize, Vec3, f64)> = results
        .into_iter()
        .flatten()
        .flat_map(|(idx, rows, _)| rows.into_iter().map(move |(wi, d)| (idx, wi, d)))
        .collect();
    res.sort_by(|a, b| b.2.abs().total_cmp(&a.2.abs()));
    print_spread(res.iter().map(|r| r.2));
    // The worst per roughness pair (the list is sorted: first seen).
    let mut pairs: Vec<(f32, f32, f64)> = Vec::new();
    for &(i, _, d) in &res {
        let (_, ax, ay, _) = materials[i];
        if !pairs.iter().any(|p| (p.0, p.1) == (ax, ay)) {
            pairs.push((ax, ay, d));
        }
    }
    pairs.sort_by(|a, b| {
        (a.0, a.1)
            .partial_cmp(&(b.0, b.1))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let line: Vec<String> = pairs
        .iter()
        .map(|(ax, ay, d)| format!("({ax},{ay}) {:.4}", d.abs()))
        .collect();
    println!("worst per roughness pair: {}", line.join(", "));
    for &(i, wi, d) in res.iter().take(rows) {
        let (n, ax, ay, eta) = materials[i];
        println!(
            "{:?} ({ax:.3},{ay:.3}) eta {eta:.3} theta {:.1} phi {:.1}: {d:+.4}",
            NDFS[n],
            wi.z.abs().acos().to_degrees(),
            wi.y.atan2(wi.x).to_degrees()
        );
    }
}

/// Reflected plus transmitted albedo of TABULATED glass `t` (SINGLE `s`)
/// from `wi` by the quadrature of `tests/tabulated_dielectric.rs`
/// (`compensation::glass_albedo`).
fn glass_albedo<T: ScatterModel, S: ScatterModel>(
    t: &T,
    s: &S,
    wi: Vec3,
    ax: f32,
    ay: f32,
    eta: f32,
) -> f64 {
    msbsdf::multiple::compensation::glass_albedo(
        |a, b| t.eval(a, b, &mut Rng::new(0, 0)).x,
        |a, b| s.eval(a, b, &mut Rng::new(0, 0)).x,
        wi,
        ax,
        ay,
        eta,
    )
}
