//! Efficiency of the stochastic walks: instructions per eval (callgrind, load
//! independent), ns per eval (wall clock, the second figure), variance of one
//! eval and efficiency `1 / (variance x instructions)` on GGX with perfectly
//! reflecting facets (F = 1), alpha {0.3, 0.5, 1} x theta_i {0, 60, 80},
//! `wi = (-sin, 0, cos)`, 8 outgoing directions per configuration. The
//! efficiency of a pair is relative to HEITZ_RANDOM_WALK as of commit 9f91b5f
//! (`docs/efficiency_baseline.csv`, measured once with this program), and a
//! configuration's figure is the geometric mean over its 8 pairs.
//!
//! ```text
//! cargo build --release --example efficiency
//! target/release/examples/efficiency measure docs/efficiency_current.csv 400000
//! target/release/examples/efficiency report docs/efficiency_baseline.csv docs/efficiency_current.csv
//! ```
//!
//! `measure` runs itself once under `valgrind --tool=callgrind` in `count`
//! mode (`N_COUNT` evals per pair and samples per configuration, each pair in
//! its own `#[inline(never)]` function call dumped separately) and measures
//! the variance and time of `evals` evals per pair in process (at least
//! 4e5 for the committed figures: the walks' estimates are heavy-tailed, so
//! the variance of fewer evals is often underestimated by half). `report`
//! writes `docs/efficiency.md` and `docs/efficiency.svg`. The environment
//! variables `EFFICIENCY_ONLY=<name part>[,<name part>...]` and `EFFICIENCY_CONFIG=<alpha>/<theta_i>`
//! restrict `measure` to some models and one configuration (development runs;
//! it then also prints each measured configuration's efficiency against the
//! baseline in `docs/efficiency_baseline.csv`).
//!
//! Three development modes look at one configuration:
//!
//! ```text
//! # instructions: callgrind on the evals of the 8 pairs
//! valgrind --tool=callgrind --collect-atstart=no --toggle-collect='*measure_eval*' \
//!     target/release/examples/efficiency profile HEITZ 1 60 2000
//! callgrind_annotate --inclusive=yes callgrind.out.<pid>
//! # variance of one eval per pair, and its geometric mean
//! target/release/examples/efficiency var "INVARIANCE PT" 1 60 100000
//! # variance per scattering order of the kernel walk (heitz | segment),
//! # one or two MIS walks, forced segments, delayed roulette
//! target/release/examples/efficiency orders segment 1 60 200000 1 0 1
//! ```

#[allow(dead_code)]
#[path = "../tools/harness/svg.rs"]
mod svg;

use glam::Vec3;
use msbsdf::{Estimator, Material, MaterialDesc, Model, NdfId, Rng};
use std::fmt::Write as _;
use std::time::Instant;

/// Evals per pair (and samples per configuration) under callgrind.
const N_COUNT: usize = 1000;

/// The models measured: name, model, estimator.
const MODELS: [(&str, Model, Estimator); 5] = [
    ("HEITZ_RANDOM_WALK", Model::HeitzRandomWalk, Estimator::Pt),
    ("INVARIANCE PT", Model::Invariance, Estimator::Pt),
    ("INVARIANCE BDPT", Model::Invariance, Estimator::Bdpt),
    ("BITTERLI_DEON", Model::BitterliDeon, Estimator::Pt),
    ("POSITION_FREE PT", Model::PositionFree, Estimator::Pt),
];
const ALPHAS: [f32; 3] = [0.3, 0.5, 1.0];
const THETAS: [f64; 3] = [0.0, 60.0, 80.0];

/// The models measured: all, or those whose name contains one of the
/// comma-separated parts of the environment variable `EFFICIENCY_ONLY` (for
/// development runs).
fn models() -> Vec<(&'static str, Model, Estimator)> {
    let only = std::env::var("EFFICIENCY_ONLY").unwrap_or_default();
    MODELS
        .iter()
        .copied()
        .filter(|m| only.split(',').any(|part| m.0.contains(part)))
        .collect()
}

/// The configurations (alpha, theta_i) measured: all, or the one named by
/// the environment variable `EFFICIENCY_CONFIG=<alpha>/<theta_i>`.
fn configs() -> Vec<(f32, f64)> {
    let only = std::env::var("EFFICIENCY_CONFIG").unwrap_or_default();
    // Any configuration can be named; only those of the table have a baseline.
    if let Some((a, t)) = only.split_once('/')
        && let (Ok(a), Ok(t)) = (a.parse::<f32>(), t.parse::<f64>())
    {
        return vec![(a, t)];
    }
    let mut v = Vec::new();
    for &alpha in &ALPHAS {
        for &theta_i in &THETAS {
            if only.is_empty() || only == format!("{alpha}/{theta_i}") {
                v.push((alpha, theta_i));
            }
        }
    }
    v
}

/// The 8 outgoing directions (theta_o, phi_o) in degrees, phi 0 forward.
fn outs(theta_i: f64) -> [(f64, f64); 8] {
    let mirror = if theta_i == 0.0 { 2.0 } else { theta_i };
    [
        (mirror, 0.0),
        (20.0, 90.0),
        (45.0, 0.0),
        (45.0, 180.0),
        (60.0, 180.0),
        (70.0, 90.0),
        (80.0, 45.0),
        (80.0, 180.0),
    ]
}

fn wi_of(theta_i: f64) -> Vec3 {
    let t = theta_i.to_radians();
    Vec3::new(-t.sin() as f32, 0.0, t.cos() as f32)
}

fn wo_of(theta: f64, phi: f64) -> Vec3 {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

fn material(model: Model, est: Estimator, alpha: f32) -> Option<Material> {
    Material::new(&MaterialDesc {
        model,
        estimator: est,
        ndf: NdfId::Ggx,
        alpha_x: alpha,
        alpha_y: alpha,
        eta: Vec3::ZERO,
        k: Vec3::ONE,
        ..MaterialDesc::default()
    })
    .ok()
}

// Callgrind applies one option per function, so collection is toggled on
// the outer `measure_*` functions and a dump taken after each inner `*_loop`.
#[inline(never)]
fn eval_loop(m: &Material, wi: Vec3, wo: Vec3, n: usize, rng: &mut Rng) -> f32 {
    let mut s = 0.0;
    for _ in 0..n {
        s += m.eval(wi, wo, rng).y;
    }
    s
}

#[inline(never)]
fn measure_eval(m: &Material, wi: Vec3, wo: Vec3, n: usize, rng: &mut Rng) -> f32 {
    eval_loop(m, wi, wo, n, rng)
}

#[inline(never)]
fn sample_loop(m: &Material, wi: Vec3, n: usize, rng: &mut Rng) -> f32 {
    let mut s = 0.0;
    for _ in 0..n {
        s += m.sample(wi, rng).weight.y;
    }
    s
}

#[inline(never)]
fn measure_sample(m: &Material, wi: Vec3, n: usize, rng: &mut Rng) -> f32 {
    sample_loop(m, wi, n, rng)
}

/// The callgrind workload: every pair's evals, then every configuration's
/// samples, in a fixed order (one dump per call).
fn count() {
    let mut sink = 0.0f32;
    for (mi, &(_, model, est)) in models().iter().enumerate() {
        for (alpha, theta_i) in configs() {
            let m = material(model, est, alpha).expect("a supported material");
            let wi = wi_of(theta_i);
            let mut rng = Rng::new(7, mi as u64);
            for (t, p) in outs(theta_i) {
                sink += measure_eval(&m, wi, wo_of(t, p), N_COUNT, &mut rng);
            }
            sink += measure_sample(&m, wi, N_COUNT, &mut rng);
        }
    }
    println!("{sink}");
}

/// Instructions of every dump in `dir` (callgrind.out.<pid>.<n>), by `n`.
fn dumps(dir: &std::path::Path) -> Vec<u64> {
    let mut v: Vec<(u64, u64)> = Vec::new();
    for e in std::fs::read_dir(dir)
        .expect("callgrind directory")
        .flatten()
    {
        let name = e.file_name().to_string_lossy().to_string();
        let Some(n) = name.rsplit('.').next().and_then(|s| s.parse::<u64>().ok()) else {
            continue;
        };
        if name.matches('.').count() != 3 {
            continue;
        }
        let text = std::fs::read_to_string(e.path()).unwrap_or_default();
        let total = text
            .lines()
            .find_map(|l| {
                l.strip_prefix("totals: ")
                    .or_else(|| l.strip_prefix("summary: "))
            })
            .and_then(|s| s.trim().parse::<u64>().ok())
            .unwrap_or(0);
        v.push((n, total));
    }
    v.sort();
    v.into_iter().map(|x| x.1).collect()
}

fn measure(out: &str, evals: usize) {
    let exe = std::env::current_exe().expect("own path");
    let dir = std::env::temp_dir().join(format!("efficiency_cg_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let status = std::process::Command::new("valgrind")
        .arg("--tool=callgrind")
        .arg("--collect-atstart=no")
        .arg("--toggle-collect=*measure_eval*")
        .arg("--toggle-collect=*measure_sample*")
        .arg("--dump-after=*eval_loop*")
        .arg("--dump-after=*sample_loop*")
        .arg(format!(
            "--callgrind-out-file={}/callgrind.out.%p",
            dir.display()
        ))
        .arg(&exe)
        .arg("count")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .expect("valgrind (callgrind) must be installed");
    assert!(status.success(), "callgrind run failed");
    let counts = dumps(&dir);
    let per_model = configs().len() * 9;
    assert!(
        counts.len() >= models().len() * per_model,
        "expected {} dumps, found {}",
        models().len() * per_model,
        counts.len()
    );
    // Dumps are numbered from 1; an extra final dump (program end) may follow.
    let mut csv = String::from("model,alpha,theta_i,kind,theta_o,phi_o,mean,var,ns,instr\n");
    let mut di = 0;
    for (mi, &(name, model, est)) in models().iter().enumerate() {
        for (alpha, theta_i) in configs() {
            let m = material(model, est, alpha).expect("a supported material");
            let wi = wi_of(theta_i);
            let mut rng = Rng::new(1, 100 + mi as u64);
            for (t, p) in outs(theta_i) {
                let wo = wo_of(t, p);
                let (mut s, mut s2) = (0.0f64, 0.0f64);
                let t0 = Instant::now();
                for _ in 0..evals {
                    let v = m.eval(wi, wo, &mut rng).y as f64;
                    s += v;
                    s2 += v * v;
                }
                let ns = t0.elapsed().as_secs_f64() * 1e9 / evals as f64;
                let mean = s / evals as f64;
                let var = (s2 / evals as f64 - mean * mean).max(0.0) * evals as f64
                    / (evals as f64 - 1.0);
                let instr = counts[di] as f64 / N_COUNT as f64;
                di += 1;
                let _ = writeln!(
                    csv,
                    "{name},{alpha},{theta_i},eval,{t},{p},{mean:.6e},{var:.6e},{ns:.1},{instr:.1}"
                );
                eprintln!(
                    "{name} {alpha} {theta_i} ({t}, {p}): mean {mean:.4e} var {var:.3e} {ns:.0} ns {instr:.0} instr"
                );
            }
            let t0 = Instant::now();
            let n = evals / 4;
            std::hint::black_box(measure_sample(&m, wi, n, &mut rng));
            let ns = t0.elapsed().as_secs_f64() * 1e9 / n as f64;
            let instr = counts[di] as f64 / N_COUNT as f64;
            di += 1;
            let _ = writeln!(
                csv,
                "{name},{alpha},{theta_i},sample,,,,,{ns:.1},{instr:.1}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::write(out, csv).expect("write csv");
    if configs().len() < ALPHAS.len() * THETAS.len()
        && let Ok(base) = std::fs::read_to_string("docs/efficiency_baseline.csv")
    {
        let (base, cur) = (
            parse(&base),
            parse(&std::fs::read_to_string(out).expect("csv")),
        );
        for &(name, _, _) in &models() {
            for (alpha, theta_i) in configs() {
                if let Some([eff, instr, _, var]) = summary(&cur, &base, name, alpha, theta_i) {
                    eprintln!(
                        "{name} {alpha}/{theta_i}: efficiency {eff:.2}x, {instr:.0} instr, variance {var:.3e}"
                    );
                }
            }
        }
    }
}

/// One CSV row.
#[derive(Clone, Debug)]
struct Row {
    model: String,
    alpha: f32,
    theta_i: f64,
    kind: String,
    var: f64,
    ns: f64,
    instr: f64,
}

fn read(path: &str) -> Vec<Row> {
    parse(&std::fs::read_to_string(path).expect("csv"))
}

fn parse(text: &str) -> Vec<Row> {
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() < 10 {
                return None;
            }
            Some(Row {
                model: f[0].to_string(),
                alpha: f[1].parse().ok()?,
                theta_i: f[2].parse().ok()?,
                kind: f[3].to_string(),
                var: f[7].parse().unwrap_or(f64::NAN),
                ns: f[8].parse().ok()?,
                instr: f[9].parse().ok()?,
            })
        })
        .collect()
}

fn rows_of<'a>(rows: &'a [Row], model: &str, alpha: f32, theta_i: f64, kind: &str) -> Vec<&'a Row> {
    rows.iter()
        .filter(|r| r.model == model && r.alpha == alpha && r.theta_i == theta_i && r.kind == kind)
        .collect()
}

/// Geometric mean over the pairs of the efficiency relative to the baseline
/// HEITZ walk, and the mean instructions, ns and variance.
fn summary(rows: &[Row], base: &[Row], model: &str, alpha: f32, theta_i: f64) -> Option<[f64; 4]> {
    let r = rows_of(rows, model, alpha, theta_i, "eval");
    let b = rows_of(base, MODELS[0].0, alpha, theta_i, "eval");
    if r.len() != b.len() || r.is_empty() {
        return None;
    }
    let mut log_sum = 0.0;
    for (x, y) in r.iter().zip(&b) {
        let ex = 1.0 / (x.var * x.instr);
        let ey = 1.0 / (y.var * y.instr);
        log_sum += (ex / ey).ln();
    }
    let n = r.len() as f64;
    let mean = |f: &dyn Fn(&Row) -> f64| r.iter().map(|x| f(x)).sum::<f64>() / n;
    Some([
        (log_sum / n).exp(),
        mean(&|x| x.instr),
        mean(&|x| x.ns),
        mean(&|x| x.var),
    ])
}

fn report(base_path: &str, cur_path: &str) {
    let base = read(base_path);
    let cur = read(cur_path);
    let mut md = String::from(
        "# Efficiency of the stochastic walks\n\n\
         Written by `examples/efficiency.rs` (see its docs for the commands). GGX,\n\
         perfectly reflecting facets (eta 0, k 1), `wi = (-sin theta_i, 0, cos theta_i)`,\n\
         8 outgoing directions per configuration. Per pair: instructions per eval\n\
         (callgrind), variance of one eval, efficiency `1 / (variance x instructions)`\n\
         relative to HEITZ_RANDOM_WALK as of commit 9f91b5f (`efficiency_baseline.csv`);\n\
         a configuration's efficiency is the geometric mean over its 8 pairs; instructions,\n\
         ns and variance are plain means over the pairs. ns are wall clock on a shared\n\
         machine (noisy); instructions are the load-independent figure.\n\n",
    );
    for (label, rows) in [("Baseline (commit 9f91b5f)", &base), ("Current", &cur)] {
        let _ = writeln!(md, "## {label}\n");
        md.push_str("| model | alpha | theta_i | efficiency vs baseline HEITZ | instr/eval | ns/eval | variance/eval | instr/sample |\n|---|---|---|---|---|---|---|---|\n");
        for &(name, _, _) in &MODELS {
            for &alpha in &ALPHAS {
                for &theta_i in &THETAS {
                    let Some([eff, instr, ns, var]) = summary(rows, &base, name, alpha, theta_i)
                    else {
                        continue;
                    };
                    let s = rows_of(rows, name, alpha, theta_i, "sample");
                    let si = s.first().map(|r| r.instr).unwrap_or(f64::NAN);
                    let _ = writeln!(
                        md,
                        "| {name} | {alpha} | {theta_i} | {eff:.2}x | {instr:.0} | {ns:.0} | {var:.3e} | {si:.0} |"
                    );
                }
            }
        }
        md.push('\n');
    }
    // Best unbiased model (estimating the HEITZ BSDF) per configuration.
    md.push_str("## Best model per configuration (current)\n\nPOSITION_FREE estimates another BSDF (height-uncorrelated segments), so it is listed but not a candidate.\n\n| alpha | theta_i | best unbiased | its efficiency | HEITZ_RANDOM_WALK | POSITION_FREE PT |\n|---|---|---|---|---|---|\n");
    let mut panels = Vec::new();
    let mut series: Vec<svg::Series> = Vec::new();
    for (ci, &(name, _, _)) in MODELS.iter().enumerate() {
        let mut pts = Vec::new();
        let mut k = 0.0;
        for &alpha in &ALPHAS {
            for &theta_i in &THETAS {
                k += 1.0;
                if let Some([eff, ..]) = summary(&cur, &base, name, alpha, theta_i) {
                    pts.push((k, eff));
                }
            }
        }
        series.push(svg::Series {
            label: name.to_string(),
            points: pts,
            color: ci,
            dashed: false,
            markers: true,
        });
    }
    for &alpha in &ALPHAS {
        for &theta_i in &THETAS {
            let mut best = ("", 0.0);
            for &(name, _, _) in &MODELS[..4] {
                if let Some([eff, ..]) = summary(&cur, &base, name, alpha, theta_i)
                    && eff > best.1
                {
                    best = (name, eff);
                }
            }
            let h = summary(&cur, &base, MODELS[0].0, alpha, theta_i).map_or(f64::NAN, |s| s[0]);
            let p = summary(&cur, &base, MODELS[4].0, alpha, theta_i).map_or(f64::NAN, |s| s[0]);
            let _ = writeln!(
                md,
                "| {alpha} | {theta_i} | {} | {:.2}x | {h:.2}x | {p:.2}x |",
                best.0, best.1
            );
        }
    }
    series.push(svg::Series {
        label: "baseline HEITZ (1)".into(),
        points: (1..=9).map(|k| (k as f64, 1.0)).collect(),
        color: 7,
        dashed: true,
        markers: false,
    });
    panels.push(svg::Panel {
        title: "Efficiency relative to HEITZ_RANDOM_WALK at 9f91b5f (GGX, F = 1)".into(),
        xlabel: "configuration: (alpha, theta_i) = (0.3,0) (0.3,60) (0.3,80) (0.5,0) ... (1,80)"
            .into(),
        ylabel: "efficiency (geometric mean over 8 wo)".into(),
        logx: false,
        logy: true,
        series,
        xrange: Some((0.5, 9.5)),
        yrange: None,
    });
    std::fs::write("docs/efficiency.md", md).expect("write docs/efficiency.md");
    std::fs::write("docs/efficiency.svg", svg::document(&panels, 1))
        .expect("write docs/efficiency.svg");
}

/// `profile <model name part> <alpha> <theta_i> [evals per pair]`: the
/// evals of one configuration's 8 pairs inside `measure_eval`, for
/// `valgrind --tool=callgrind --toggle-collect='*measure_eval*'` and
/// `callgrind_annotate --inclusive=yes`.
fn profile(args: &[String]) {
    let Some(&(_, model, est)) = MODELS.iter().find(|m| m.0.contains(args[0].as_str())) else {
        eprintln!("no model named like {}", args[0]);
        return;
    };
    let alpha: f32 = args[1].parse().unwrap_or(0.5);
    let theta_i: f64 = args[2].parse().unwrap_or(60.0);
    let n: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(10_000);
    let m = material(model, est, alpha).expect("a supported material");
    let wi = wi_of(theta_i);
    let mut rng = Rng::new(7, 1);
    let mut sink = 0.0;
    for (t, p) in outs(theta_i) {
        sink += measure_eval(&m, wi, wo_of(t, p), n, &mut rng);
    }
    println!("{sink}");
}

/// `var <model name part> <alpha> <theta_i> [evals per pair]`: mean and
/// variance of one eval per pair, and the geometric mean of the variances.
fn variance(args: &[String]) {
    let Some(&(_, model, est)) = MODELS.iter().find(|m| m.0.contains(args[0].as_str())) else {
        eprintln!("no model named like {}", args[0]);
        return;
    };
    let alpha: f32 = args[1].parse().unwrap_or(0.5);
    let theta_i: f64 = args[2].parse().unwrap_or(60.0);
    let n: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let m = material(model, est, alpha).expect("a supported material");
    let wi = wi_of(theta_i);
    let mut rng = Rng::new(5, 3);
    let mut log_var = 0.0;
    for (t, p) in outs(theta_i) {
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let v = m.eval(wi, wo_of(t, p), &mut rng).y as f64;
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        log_var += var.ln() / 8.0;
        println!("({t:>2},{p:>3}) mean {mean:.5} var {var:.3e}");
    }
    println!("geometric mean variance {:.3e}", log_var.exp());
}

/// Per-order tally of one walk.
struct Orders([f64; 12]);

impl msbsdf::multiple::microsurface::Tally for Orders {
    fn add(&mut self, order: u32, c: Vec3) {
        self.0[(order as usize).min(11)] += c.y as f64;
    }
}

/// `orders <heitz|segment> <alpha> <theta_i> [evals per pair] [two walks 0/1]
/// [forced] [roulette 0/1]`: where the variance of the walks' estimate
/// comes from, per scattering order (GGX, F = 1): the mean and variance of
/// each order's share of one eval, the vertices per walk and the share of
/// the second moment carried by the 10 largest evals.
fn orders(args: &[String]) {
    use msbsdf::facet::Facet;
    use msbsdf::multiple::heitz::HeightState;
    use msbsdf::multiple::invariance::SegmentTerm;
    use msbsdf::multiple::microsurface::{Microsurface, WalkOptions, walk};
    use msbsdf::ndf::{Ndf, NdfKind};
    let heights = args[0] == "heitz";
    let alpha: f32 = args[1].parse().unwrap_or(0.5);
    let theta_i: f64 = args[2].parse().unwrap_or(60.0);
    let n: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(200_000);
    let two = args.get(4).is_none_or(|s| s == "1");
    let forced: u32 = args.get(5).and_then(|s| s.parse().ok()).unwrap_or(0);
    let roulette = args.get(6).is_none_or(|s| s == "1");
    let facet = Facet::Conductor {
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    };
    let ms = Microsurface::new(Ndf::new(NdfKind::Ggx, alpha, alpha), facet, 10);
    let opt = WalkOptions {
        forced,
        mis: two,
        order_one: false,
        roulette,
    };
    let wi = wi_of(theta_i);
    let mut rng = Rng::new(3, 9);
    for (t, p) in outs(theta_i) {
        let wo = wo_of(t, p);
        let (mut s, mut s2) = ([0.0f64; 12], [0.0f64; 12]);
        let mut all = Vec::with_capacity(n);
        let mut verts = 0u64;
        for _ in 0..n {
            let mut f = Orders([0.0; 12]);
            let run = |a: Vec3, b: Vec3, scale: f64, rng: &mut Rng, f: &mut Orders| {
                let mut g = Orders([0.0; 12]);
                let v = if heights {
                    walk::<HeightState, _>(&ms, a, b, rng, opt, &mut g)
                } else {
                    walk::<SegmentTerm<24>, _>(&ms, a, b, rng, opt, &mut g)
                };
                for k in 0..12 {
                    f.0[k] += g.0[k] * scale;
                }
                v as u64
            };
            verts += run(wi, wo, 1.0, &mut rng, &mut f);
            if two {
                verts += run(wo, wi, (wo.z / wi.z) as f64, &mut rng, &mut f);
            }
            let mut tot = 0.0;
            for k in 0..12 {
                s[k] += f.0[k];
                s2[k] += f.0[k] * f.0[k];
                tot += f.0[k];
            }
            all.push(tot);
        }
        let nf = n as f64;
        let mean: f64 = all.iter().sum::<f64>() / nf;
        let m2: f64 = all.iter().map(|x| x * x).sum::<f64>() / nf;
        all.sort_by(|a, b| b.total_cmp(a));
        let top: f64 = all[..10].iter().map(|x| x * x).sum::<f64>() / nf;
        let single = ms.single(wi, wo).y as f64;
        print!(
            "({t:>2},{p:>3}) single {single:.4} ms {mean:.4} var {:.3e} top10 {:.0}% max/mean {:.0} verts/walk {:.2} |",
            m2 - mean * mean,
            100.0 * top / m2,
            all[0] / mean,
            verts as f64 / nf / if two { 2.0 } else { 1.0 }
        );
        for k in 2..8 {
            let m = s[k] / nf;
            print!(" o{k} {m:.4}/{:.1e}", s2[k] / nf - m * m);
        }
        println!();
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("count") => count(),
        Some("measure") if args.len() >= 3 => {
            let evals = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(400_000);
            measure(&args[2], evals);
        }
        Some("report") if args.len() >= 4 => report(&args[2], &args[3]),
        Some("profile") if args.len() >= 5 => profile(&args[2..]),
        Some("orders") if args.len() >= 5 => orders(&args[2..]),
        Some("var") if args.len() >= 5 => variance(&args[2..]),
        _ => eprintln!(
            "usage: efficiency measure <out.csv> [evals per pair] | report <baseline.csv> <current.csv> | count"
        ),
    }
}
