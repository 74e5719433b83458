//! Generates `data/tabulated_aniso.bin`, the anisotropic furnace correction
//! of `MSBSDF_MODEL_TABULATED` (`msbsdf::multiple::tabulated::ANISO_CORRECTION`):
//! per (NDF, alpha_x, alpha_y, azimuth, mu) on the grid of
//! ENERGY_COMPENSATED's anisotropic albedo table, `c = (1 - E) / A` with
//! `E` that table's entry (SINGLE's albedo with F = 1) and `A` the multiply
//! scattered albedo with F = 1 of TABULATED's uncorrected anisotropic lobe,
//! both by the same deterministic quadrature over normals
//! (`compensation::single_albedo`); no random numbers.
//!
//! `cargo run --release --example gen_tabulated_aniso [-- --quad N]`
//! (default N = 64; about 25 s on two threads), then
//! `-- --update` (repeatable, after rebuilding with the new table): a
//! Sinkhorn step, each entry multiplied by `(1 - E) / A` of the corrected
//! lobe.

use glam::Vec3;
use msbsdf::bsdf::ScatterModel;
use msbsdf::facet::Facet;
use msbsdf::multiple::compensation::{
    aniso_grid_alpha, aniso_grid_mu, aniso_grid_phi, single_albedo,
};
use msbsdf::multiple::compensation_aniso_tables::{AN_A, AN_MU, AN_PHI, CONDUCTOR_E_ANISO};
use msbsdf::multiple::tabulated::{ANISO_CORRECTION, Tabulated};
use msbsdf::ndf::{Ndf, NdfKind};
use msbsdf::rng::Rng;
use msbsdf::single::{G2Form, Single};

#[path = "harness/git.rs"]
mod git;

const NDFS: [NdfKind; 2] = [NdfKind::Beckmann, NdfKind::Ggx];

/// Range of the stored correction (a guard for nodes where the target and
/// the albedo are both near 0; the uncorrected lobe's albedo is mostly
/// within a factor 2 of the target).
const CLAMP: (f32, f32) = (0.05, 20.0);

/// The correction at one node: `(1 - E) / A`, 1 where there is no multiply
/// scattered energy to correct (an axis of roughness 0).
#[allow(clippy::too_many_arguments)]
fn entry(
    kind: NdfKind,
    n: usize,
    jx: usize,
    jy: usize,
    k: usize,
    i: usize,
    quad: usize,
    update: bool,
) -> f32 {
    let (ax, ay) = (aniso_grid_alpha(jx), aniso_grid_alpha(jy));
    if ax < 1e-3 || ay < 1e-3 {
        return 1.0;
    }
    // On the diagonal the model is isotropic; the correction there is read
    // by anisotropic materials between nodes, so it is taken for a barely
    // anisotropic one.
    let ay = if jx == jy { ay * 1.0001 } else { ay };
    let white = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let ndf = Ndf::new(kind, ax, ay);
    // --update: the lobe with the committed correction, whose entry is then
    // multiplied by target / albedo (a Sinkhorn step of the symmetric
    // scaling); otherwise the uncorrected lobe.
    let tab = if update {
        Tabulated::new(ndf, white)
    } else {
        Tabulated::new(ndf, white).without_aniso_correction()
    };
    let old = if update {
        ANISO_CORRECTION[n][jx][jy][k][i]
    } else {
        1.0
    };
    let single = Single::new(ndf, white, G2Form::HeightCorrelated);
    let (mu, phi) = (aniso_grid_mu(i), aniso_grid_phi(k));
    let st = (1.0 - mu * mu).max(0.0).sqrt();
    let wi = Vec3::new(st * phi.cos(), st * phi.sin(), mu);
    let mut rng = Rng::new(0, 0);
    let a = single_albedo(
        |x, y| {
            let m = tab.eval(x, y, &mut rng).x - single.eval(x, y, &mut rng).x;
            m.max(0.0)
        },
        ax,
        ay,
        wi,
        None,
        quad,
    ) as f32;
    let target = 1.0 - CONDUCTOR_E_ANISO[n][jx][jy][k][i];
    if a < 1e-4 || target < 1e-4 {
        return 1.0;
    }
    (old * target / a).clamp(CLAMP.0, CLAMP.1)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quad: usize = args
        .iter()
        .position(|a| a == "--quad")
        .and_then(|p| args.get(p + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(64);
    let update = args.iter().any(|a| a == "--update");
    let t0 = std::time::Instant::now();
    // Jobs: (ndf, jx, jy) blocks with jx <= jy; the others by the symmetry
    // (alpha_x, alpha_y, phi) -> (alpha_y, alpha_x, pi/2 - phi).
    let jobs: Vec<(usize, usize, usize)> = (0..2)
        .flat_map(|n| (0..AN_A).flat_map(move |jx| (jx..AN_A).map(move |jy| (n, jx, jy))))
        .collect();
    let total = jobs.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<Vec<(usize, Vec<f32>)>> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..2)
            .map(|th| {
                let (jobs, done) = (&jobs, &done);
                sc.spawn(move || {
                    let mut out = Vec::new();
                    for (idx, &(n, jx, jy)) in jobs.iter().enumerate().filter(|(i, _)| i % 2 == th)
                    {
                        let block: Vec<f32> = (0..AN_PHI)
                            .flat_map(|k| (0..AN_MU).map(move |i| (k, i)))
                            .map(|(k, i)| entry(NDFS[n], n, jx, jy, k, i, quad, update))
                            .collect();
                        out.push((idx, block));
                        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        let el = t0.elapsed().as_secs_f32();
                        let bar = "#".repeat(30 * d / total);
                        eprint!(
                            "\r[{bar:<30}] {d}/{total} (alpha_x, alpha_y) blocks, {el:.0} s, ETA {:.0} s",
                            el / d as f32 * (total - d) as f32
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
    let mut table = vec![0f32; 2 * AN_A * AN_A * AN_PHI * AN_MU];
    let at = |n: usize, jx: usize, jy: usize, k: usize, i: usize| {
        (((n * AN_A + jx) * AN_A + jy) * AN_PHI + k) * AN_MU + i
    };
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    for (idx, block) in results.into_iter().flatten() {
        let (n, jx, jy) = jobs[idx];
        for k in 0..AN_PHI {
            for i in 0..AN_MU {
                let v = block[k * AN_MU + i];
                lo = lo.min(v);
                hi = hi.max(v);
                table[at(n, jx, jy, k, i)] = v;
                table[at(n, jy, jx, AN_PHI - 1 - k, i)] = v;
            }
        }
    }
    let command: Vec<String> = args.iter().skip(1).cloned().collect();
    // With --update, the earlier passes' commands and commits (the history
    // of the table this pass started from).
    let history = if update {
        let previous =
            msbsdf::multiple::bintable::header_text(include_bytes!("../data/tabulated_aniso.bin"));
        previous
            .lines()
            .filter(|l| {
                l.starts_with("Command:") || l.starts_with("Commit:") || l.starts_with("Earlier")
            })
            .map(|l| format!("Earlier {}\n", l.trim_start_matches("Earlier ")))
            .collect::<String>()
    } else {
        String::new()
    };
    let header = format!(
        "ANISO_CORRECTION (MSBSDF_MODEL_TABULATED): c = (1 - E) / A per [ndf: Beckmann, GGX]\
         [alpha_x: {AN_A}][alpha_y: {AN_A}][phi: {AN_PHI}][mu: {AN_MU}] f32 on the grid of \
         CONDUCTOR_E_ANISO; E that table's entry, A the multiply scattered albedo with F = 1 \
         of the anisotropic lobe (Tabulated::without_aniso_correction minus SINGLE; with \
         --update the previous table times (1 - E) / A of the corrected lobe) by \
         deterministic quadrature (compensation::single_albedo, {quad} x {quad} \
         normals per entry); no random numbers. 1 where an axis has roughness < 1e-3; \
         clamped to [{}, {}]; diagonal nodes at alpha_y (1 + 1e-4). Range {lo:.4} - {hi:.4}.\n\
         Command: cargo run --release --example gen_tabulated_aniso{}{}\nCommit: {}\n\
         Time: {:.0} s\n{history}",
        CLAMP.0,
        CLAMP.1,
        if command.is_empty() { "" } else { " -- " },
        command.join(" "),
        git::commit(),
        t0.elapsed().as_secs_f32()
    );
    let path = format!("{}/data/tabulated_aniso.bin", env!("CARGO_MANIFEST_DIR"));
    let bytes = msbsdf::multiple::bintable::encode(&header, &table);
    std::fs::write(&path, bytes).expect("write the table file");
    eprintln!(
        "wrote {path} in {:.0} s (range {lo:.4} - {hi:.4})",
        t0.elapsed().as_secs_f32()
    );
}
