//! The speed-vs-accuracy measurement: for every (model, estimator) the
//! library accepts and every evaluation count, the median time per query
//! through `msbsdf_eval` and the relative RMS error against the reference.
//!
//! Error of a query that averages `N` evaluations, per material:
//! `sqrt((B + V / N) / R)`, with `R = sum ref^2`, `B = sum (mean - ref)^2 -
//! V / M - se_ref^2` (squared bias, corrected for the noise of both means)
//! and `V = sum var` (variance of one evaluation), sums over the pairs and
//! RGB channels, `M` evaluations per pair. This is the expected mean squared
//! error of averaging `N` independent evaluations, measured once from `M`
//! evaluations rather than by repeating every `N` (same expectation, less
//! noise). A class error is the RMS over its materials.
//!
//! HEITZ_RANDOM_WALK is the reference: its bias is zero by definition (the
//! reference is its expectation, computed with a control variate whose
//! first-order term is checked against the walk in the reference header),
//! so its error is its noise alone; its measured bias (noise-limited:
//! `sqrt(V / M)` with a few dominant pairs) is still written to the
//! per-material CSV as a consistency check.

use super::reference::RefMaterial;
use super::suite::{
    CMaterial, Class, Combo, GROUPS, c_rng, discover, estimator_name, model_name, ndf_name,
};
use super::{Progress, Stats, median};
use msbsdf::NdfId;
use std::fmt::Write as _;
use std::hint::black_box;
use std::time::Instant;

/// Options of a run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Evaluation counts per query (stochastic models), timed directly.
    pub evals: Vec<u32>,
    /// Further evaluation counts for the AUTO table only (error from the
    /// same statistics; time extrapolated linearly from the largest timed
    /// count, since a query is a loop of evaluations).
    pub table_evals: Vec<u32>,
    /// Evaluations per pair for the statistics.
    pub samples: u32,
    /// Timing rounds (median taken; each round times every combination
    /// and material once, so that load changes fall on all alike).
    pub timing_runs: usize,
    /// Evaluations per timing run (at least 4 queries).
    pub timing_evals: u32,
    /// Worker threads for the statistics.
    pub threads: usize,
    /// No progress bar.
    pub quiet: bool,
}

impl Options {
    /// The full run: 1, 2, 4, ..., 256 evaluations timed, up to 65536 for
    /// the AUTO table (stochastic models need thousands of evaluations per
    /// query to reach 1% on this suite).
    pub fn full() -> Self {
        Options {
            evals: (0..9).map(|i| 1 << i).collect(),
            table_evals: (9..17).map(|i| 1 << i).collect(),
            samples: 2048,
            timing_runs: 5,
            timing_evals: 1024,
            threads: super::threads(),
            quiet: false,
        }
    }

    /// A quick run for tests.
    pub fn quick() -> Self {
        Options {
            evals: vec![1, 2, 4],
            table_evals: vec![8],
            samples: 32,
            timing_runs: 3,
            timing_evals: 64,
            threads: 1,
            quiet: true,
        }
    }
}

/// Result of one (combo, material).
#[derive(Clone, Debug, Default)]
pub struct MatResult {
    /// Index into the combos.
    pub combo: usize,
    /// Index into the reference materials.
    pub material: usize,
    /// Squared bias (summed, noise-corrected; may be slightly negative);
    /// 0 for the reference model.
    pub bias2: f64,
    /// The measured squared bias, also for the reference model.
    pub bias2_measured: f64,
    /// Summed variance of one evaluation.
    pub var: f64,
    /// `bias2`, `var` and `den` over the pairs that are not mirror
    /// configurations (see [`is_mirror_pair`]).
    pub off_mirror: [f64; 3],
    /// Standard error of `var` (spread of 8 batch estimates / sqrt(8)).
    pub var_se: f64,
    /// Standard error of `bias2` (normal approximation, see the tests).
    pub bias2_se: f64,
    /// Summed squared reference values.
    pub den: f64,
    /// Median ns per query for each evaluation count (one entry for
    /// deterministic models).
    pub ns: Vec<f64>,
    /// Evaluation counts of `ns`.
    pub evals: Vec<u32>,
    /// Non-finite or negative outputs seen.
    pub bad: u64,
}

impl MatResult {
    /// Relative RMS error of a query averaging `n` evaluations.
    pub fn rel_err(&self, n: u32) -> f64 {
        ((self.bias2.max(0.0) + self.var / n as f64) / self.den.max(1e-300)).sqrt()
    }

    /// Upper confidence value of the relative RMS error of `n` evaluations:
    /// squared bias and variance each raised by 4 standard errors (the bound
    /// `tests/auto.rs` checks a choice against). The AUTO
    /// table stores this, so that a choice near the tolerance still meets
    /// it when measured again with other random numbers.
    pub fn rel_err_upper(&self, n: u32) -> f64 {
        let b = (self.bias2 + 4.0 * self.bias2_se).max(0.0);
        let v = self.var + 4.0 * self.var_se;
        ((b + v / n as f64) / self.den.max(1e-300)).sqrt()
    }

    /// [`MatResult::rel_err`] over the pairs that are not mirror
    /// configurations.
    pub fn rel_err_off_mirror(&self, n: u32) -> f64 {
        let [b, v, d] = self.off_mirror;
        ((b.max(0.0) + v / n as f64) / d.max(1e-300)).sqrt()
    }

    /// Relative bias alone (as measured, also for the reference model).
    pub fn rel_bias(&self) -> f64 {
        (self.bias2_measured.max(0.0) / self.den.max(1e-300)).sqrt()
    }

    /// Median ns per query of `n` evaluations: measured, or extrapolated
    /// linearly from the largest measured count.
    pub fn ns_for(&self, n: u32) -> f64 {
        if let Some(i) = self.evals.iter().position(|&e| e == n) {
            return self.ns[i];
        }
        match (self.evals.last(), self.ns.last()) {
            (Some(&e), Some(&t)) => t * n as f64 / e as f64,
            _ => f64::NAN,
        }
    }
}

/// A reflection pair whose half vector is within 1 degree of the normal:
/// the exact mirror configuration, where VGROOVE's `1 / sin(theta_h)` of
/// Lee et al. 2018 eq. (14) is singular (evaluated with a floor, so 10^4 times the
/// typical value) and point errors say nothing about the model's accuracy.
pub fn is_mirror_pair(wi: glam::Vec3, wo: glam::Vec3) -> bool {
    if wi.z * wo.z <= 0.0 {
        return false;
    }
    let h = (wi + wo).normalize_or_zero();
    (h.x * h.x + h.y * h.y).sqrt() < 1f32.to_radians().sin()
}

/// Everything a run measured.
pub struct Run {
    /// The combinations measured.
    pub combos: Vec<Combo>,
    /// Per (combo, material) results.
    pub results: Vec<MatResult>,
    /// Options used.
    pub options: Options,
}

fn time_queries(m: &CMaterial, pairs: &[(glam::Vec3, glam::Vec3)], n: u32, o: &Options) -> f64 {
    let q = ((o.timing_evals / n).max(4)) as usize;
    let mut rng = c_rng(99, 1);
    let t = Instant::now();
    for j in 0..q {
        let (wi, wo) = pairs[j % pairs.len()];
        let mut s = [0.0f64; 3];
        for _ in 0..n {
            let v = m.eval(wi, wo, &mut rng);
            s[0] += v[0];
            s[1] += v[1];
            s[2] += v[2];
        }
        black_box(s);
    }
    t.elapsed().as_nanos() as f64 / q as f64
}

/// Measures every accepted (model, estimator) on `refs`.
pub fn run(refs: &[RefMaterial], o: &Options) -> Run {
    let suite: Vec<_> = refs.iter().map(|r| r.mat.clone()).collect();
    let combos = discover(&suite);
    let mut jobs = Vec::new();
    for ci in 0..combos.len() {
        for mi in 0..refs.len() {
            let d = refs[mi].mat.c_desc(combos[ci].model, combos[ci].estimator);
            if CMaterial::new(&d).is_some() {
                jobs.push((ci, mi));
            }
        }
    }
    let mut bar = Progress::new("accuracy", jobs.len() as u64, o.quiet);
    let stats = super::reference::parallel(
        jobs.len(),
        o.threads,
        &mut bar,
        |_| 1,
        |j| {
            let (ci, mi) = jobs[j];
            let c = combos[ci];
            let r = &refs[mi];
            let Some(m) = CMaterial::new(&r.mat.c_desc(c.model, c.estimator)) else {
                return MatResult::default();
            };
            let samples = if c.stochastic { o.samples } else { 1 };
            let mut res = MatResult {
                combo: ci,
                material: mi,
                ..MatResult::default()
            };
            let mut b2_var = 0.0;
            let mut batch_var = [0.0f64; 8];
            for (pi, p) in r.pairs.iter().enumerate() {
                let mirror = is_mirror_pair(p.wi, p.wo);
                let mut rng = c_rng(1000 + ci as u64, (mi * r.pairs.len() + pi) as u64);
                let mut st = Stats::default();
                let mut batch = [Stats::default(); 8];
                for k in 0..samples {
                    let v = m.eval(p.wi, p.wo, &mut rng);
                    if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
                        res.bad += 1;
                    }
                    st.push(v);
                    batch[(k as usize * 8) / samples as usize].push(v);
                }
                let var = if c.stochastic { st.var() } else { [0.0; 3] };
                for ch in 0..3 {
                    let d = st.mean[ch] - p.value[ch];
                    let noise = var[ch] / samples as f64 + p.se[ch] * p.se[ch];
                    res.bias2 += d * d - noise;
                    if !mirror {
                        res.off_mirror[0] += d * d - noise;
                        res.off_mirror[1] += var[ch];
                        res.off_mirror[2] += p.value[ch] * p.value[ch];
                    }
                    // Var(d^2) for a normal d: 4 mu^2 s + 2 s^2.
                    b2_var += 4.0 * d * d * noise + 2.0 * noise * noise;
                    res.var += var[ch];
                    res.den += p.value[ch] * p.value[ch];
                    if c.stochastic {
                        for (b, bs) in batch.iter().enumerate() {
                            batch_var[b] += bs.var()[ch];
                        }
                    }
                }
            }
            res.bias2_se = b2_var.sqrt();
            if c.stochastic {
                let mean = batch_var.iter().sum::<f64>() / 8.0;
                let sd = (batch_var.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 7.0).sqrt();
                res.var_se = sd / 8f64.sqrt();
            }
            res.bias2_measured = res.bias2;
            if c.model == msbsdf::Model::HeitzRandomWalk {
                res.off_mirror[0] = 0.0;
                res.bias2 = 0.0;
                res.bias2_se = 0.0;
            }
            res
        },
    );
    bar.finish();
    // Timing, one thread, after the statistics: `timing_runs` rounds, each
    // timing every (combination, material, evaluation count) once, and
    // the median over the rounds. Interleaved, so that a change of the
    // shared machine's load during the phase (tens of seconds) falls on
    // every combination alike instead of on whichever was timed then: the
    // costs relative to SINGLE (the Pareto tables, AUTO's table) are
    // ratios of times taken seconds apart, not minutes. Each timed run
    // follows an untimed one of the same queries, so that it measures the
    // warm caches the consecutive runs of the earlier order had (the
    // table models' data would otherwise be evicted by the combinations
    // timed in between).
    let mut results = stats;
    // Per timing: (index in `results`, index in `mats`, evaluations per
    // query); per created material: (the material, its pairs).
    let mut timed = Vec::new();
    let mut mats = Vec::new();
    for (k, res) in results.iter_mut().enumerate() {
        let c = combos[res.combo];
        let r = &refs[res.material];
        if let Some(m) = CMaterial::new(&r.mat.c_desc(c.model, c.estimator)) {
            res.evals = if c.stochastic {
                o.evals.clone()
            } else {
                vec![1]
            };
            for &n in &res.evals {
                timed.push((k, mats.len(), n));
            }
            let pairs: Vec<_> = r.pairs.iter().map(|p| (p.wi, p.wo)).collect();
            mats.push((m, pairs));
        }
    }
    let mut times = vec![Vec::with_capacity(o.timing_runs); timed.len()];
    let mut bar = Progress::new("timing", (o.timing_runs * timed.len()) as u64, o.quiet);
    for round in 0..o.timing_runs {
        for (t, &(_, mi, n)) in timed.iter().enumerate() {
            let (m, pairs) = &mats[mi];
            black_box(time_queries(m, pairs, n, o));
            times[t].push(time_queries(m, pairs, n, o));
            bar.update((round * timed.len() + t + 1) as u64);
        }
    }
    bar.finish();
    // `timed` lists each result's evaluation counts in order.
    for (t, &(k, _, _)) in timed.iter().enumerate() {
        results[k].ns.push(median(&times[t]));
    }
    Run {
        combos,
        results,
        options: o.clone(),
    }
}

/// One row of the class summary.
#[derive(Clone, Debug)]
pub struct Row {
    /// The combination.
    pub combo: Combo,
    /// Evaluations per query.
    pub evals: u32,
    /// Per reporting group (`suite::GROUPS`: conductor, dielectric,
    /// anisotropic dielectric): RMS relative error, mean ns per query,
    /// materials covered.
    pub class: [Option<(f64, f64, usize)>; GROUPS.len()],
}

/// The class summary: one row per (model, estimator, evaluations).
pub fn summary(run: &Run, refs: &[RefMaterial]) -> Vec<Row> {
    let mut rows = Vec::new();
    for (ci, c) in run.combos.iter().enumerate() {
        let evals: Vec<u32> = if c.stochastic {
            run.options.evals.clone()
        } else {
            vec![1]
        };
        for (ei, &n) in evals.iter().enumerate() {
            let mut class = [None; GROUPS.len()];
            for (k, slot) in class.iter_mut().enumerate() {
                let rs: Vec<&MatResult> = run
                    .results
                    .iter()
                    .filter(|r| r.combo == ci && refs[r.material].mat.group() == k)
                    .filter(|r| r.ns.len() > ei)
                    .collect();
                if rs.is_empty() {
                    continue;
                }
                let e2: f64 =
                    rs.iter().map(|r| r.rel_err(n).powi(2)).sum::<f64>() / rs.len() as f64;
                let ns: f64 = rs.iter().map(|r| r.ns[ei]).sum::<f64>() / rs.len() as f64;
                *slot = Some((e2.sqrt(), ns, rs.len()));
            }
            rows.push(Row {
                combo: *c,
                evals: n,
                class,
            });
        }
    }
    rows
}

/// Header line of the summary CSV.
pub const SUMMARY_COLUMNS: &str = "model,estimator,evaluations,conductor_rel_rms_error,conductor_ns_per_query,conductor_materials,dielectric_rel_rms_error,dielectric_ns_per_query,dielectric_materials,dielectric_anisotropic_rel_rms_error,dielectric_anisotropic_ns_per_query,dielectric_anisotropic_materials";

/// The summary CSV text.
pub fn summary_csv(header: &[String], rows: &[Row]) -> String {
    let mut s = String::new();
    for h in header {
        let _ = writeln!(s, "# {h}");
    }
    let _ = writeln!(s, "{SUMMARY_COLUMNS}");
    for r in rows {
        let _ = write!(
            s,
            "{},{},{}",
            model_name(r.combo.model),
            estimator_name(r.combo.estimator),
            r.evals
        );
        for c in r.class {
            match c {
                Some((e, ns, n)) => {
                    let _ = write!(s, ",{e:.5e},{ns:.1},{n}");
                }
                None => s.push_str(",,,0"),
            }
        }
        s.push('\n');
    }
    s
}

/// The per-material CSV text.
pub fn materials_csv(header: &[String], run: &Run, refs: &[RefMaterial]) -> String {
    let mut s = String::new();
    for h in header {
        let _ = writeln!(s, "# {h}");
    }
    s.push_str("model,estimator,evaluations,material,class,ndf,alpha_x,alpha_y,rel_rms_error,ns_per_query,rel_bias,rel_noise_one_eval,bad_outputs\n");
    for r in &run.results {
        let c = run.combos[r.combo];
        let m = &refs[r.material].mat;
        for (ei, &n) in r.evals.iter().enumerate() {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{:.5e},{:.1},{:.4e},{:.4e},{}",
                model_name(c.model),
                estimator_name(c.estimator),
                n,
                m.name,
                m.class.name(),
                ndf_name(m.ndf),
                m.alpha_x,
                m.alpha_y,
                r.rel_err(n),
                r.ns[ei],
                r.rel_bias(),
                (r.var / r.den.max(1e-300)).sqrt(),
                r.bad
            );
        }
    }
    s
}

/// The table file `src/tables/auto.bin` (format
/// `msbsdf::multiple::bintable`, layout in its header and in
/// `src/multiple/auto_table.rs`): per (NDF, facet, roughness) of the suite,
/// every measured (model, estimator, evaluations) with its error (worst
/// over the suite's materials with that key: the three metals for
/// conductors) and its cost (largest median ns per query among them)
/// relative to SINGLE's in the same row; first SINGLE's median ns over the
/// rows (the reference AUTO reports ns with). `commit` goes in the header.
pub fn auto_table_bytes(run: &Run, refs: &[RefMaterial], command: &str, commit: &str) -> Vec<u8> {
    use msbsdf::multiple::auto_table::{ESTIMATOR_CODES, MODEL_CODES};
    // Keys in suite order.
    let mut keys: Vec<(NdfId, Class, f32, f32)> = Vec::new();
    for r in refs {
        let k = (r.mat.ndf, r.mat.class, r.mat.alpha_x, r.mat.alpha_y);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    // Per row: (ndf, facet, alpha_x, alpha_y, [(model, estimator, n, error, ns)]).
    type Cand = (f32, f32, u32, f32, f64);
    let mut rows: Vec<(f32, f32, f32, f32, Vec<Cand>)> = Vec::new();
    for (ndf, class, ax, ay) in keys {
        let mut cands = Vec::new();
        for (ci, c) in run.combos.iter().enumerate() {
            let rs: Vec<&MatResult> = run
                .results
                .iter()
                .filter(|r| {
                    let m = &refs[r.material].mat;
                    r.combo == ci
                        && m.ndf == ndf
                        && m.class == class
                        && m.alpha_x == ax
                        && m.alpha_y == ay
                        && !r.ns.is_empty()
                })
                .collect();
            if rs.is_empty() {
                continue;
            }
            let mut counts = rs[0].evals.clone();
            if c.stochastic {
                counts.extend(run.options.table_evals.iter().copied());
            }
            let model = MODEL_CODES
                .iter()
                .position(|m| *m == c.model)
                .expect("a model with a table code") as f32;
            let est = ESTIMATOR_CODES
                .iter()
                .position(|e| *e == c.estimator)
                .expect("an estimator with a table code") as f32;
            for n in counts {
                let err = rs.iter().map(|r| r.rel_err_upper(n)).fold(0.0, f64::max);
                let ns = rs.iter().map(|r| r.ns_for(n)).fold(0.0, f64::max);
                cands.push((model, est, n, err as f32, ns.max(0.1).round()));
            }
        }
        let ndf_code = if ndf == NdfId::Beckmann { 0.0 } else { 1.0 };
        let facet_code = match class {
            Class::Conductor => 0.0,
            Class::Dielectric => 1.0,
        };
        rows.push((ndf_code, facet_code, ax, ay, cands));
    }
    let single = |c: &[Cand]| {
        c.iter()
            .find(|x| x.0 == 0.0 && x.2 == 1)
            .map(|x| x.4)
            .expect("SINGLE measured in every row")
    };
    let mut singles: Vec<f64> = rows.iter().map(|r| single(&r.4)).collect();
    singles.sort_by(f64::total_cmp);
    let reference = singles[singles.len() / 2] as f32;
    let mut v = vec![reference, rows.len() as f32];
    for (ndf, facet, ax, ay, cands) in &rows {
        let s = single(cands) as f32;
        v.extend([*ndf, *facet, *ax, *ay, cands.len() as f32]);
        for &(m, e, n, err, ns) in cands {
            v.extend([m, e, n as f32, err, ns as f32 / s]);
        }
    }
    let text = format!(
        "AUTO's table: measured error and cost of every (model, estimator, evaluations) per \
         NDF, facet and roughness of the speed-vs-accuracy suite.\n\
         error: relative RMS error of one query averaging `evaluations` calls of eval against \
         the converged HEITZ_RANDOM_WALK reference over 64 direction pairs (worst over the \
         suite's materials with that key), as an upper confidence value (squared bias and \
         variance each raised by 4 standard errors); HEITZ_RANDOM_WALK's error is its noise \
         alone.\n\
         cost: median time per query through msbsdf_eval (largest over those materials) \
         divided by SINGLE's (1 evaluation) in the same row, on the machine that measured it; \
         above 256 evaluations extrapolated linearly from the 256-evaluation timing.\n\
         Layout (f32): reference_ns (median over rows of SINGLE's ns per query, {reference} \
         ns, for reporting ns), n_rows, then per row: ndf (0 Beckmann, 1 GGX), facet (0 \
         conductor, 1 dielectric), alpha_x, alpha_y, n_candidates, then per candidate: model \
         (index in MSBSDF_MODEL_* order), estimator (0 PT, 1 BDPT), evaluations, error, cost.\n\
         Measured from data/reference_values.csv by: {command}\n\
         Commit: {commit}\n"
    );
    msbsdf::multiple::bintable::encode(&text, &v)
}
