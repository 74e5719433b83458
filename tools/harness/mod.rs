//! Shared code of the speed-vs-accuracy tools (`tools/gen_reference.rs`,
//! `tools/speed_accuracy.rs`, `tools/stability.rs`) and of the tests that run
//! them in a quick mode (`tests/harness_quick.rs`, `tests/auto.rs`): the fixed
//! material suite and direction pairs, the reference CSV, discovery of the
//! (model, estimator) combinations the library accepts, statistics and a
//! small hand-written SVG plotter (no plotting dependency, so the main crate's
//! builds stay fast).
//!
//! Included with `#[path = "..."] mod harness;`, not a crate of its own.

#![allow(dead_code, clippy::needless_range_loop)]

pub mod cli;
pub mod git;
pub mod reference;
pub mod speed;
pub mod suite;
pub mod svg;
pub mod walk;

use std::io::Write as _;
use std::time::{Duration, Instant};

/// A progress bar with ETA on stderr (one line, redrawn at most 4 times a
/// second; nothing when `quiet`).
pub struct Progress {
    label: String,
    total: u64,
    start: Instant,
    last: Instant,
    quiet: bool,
}

impl Progress {
    /// A bar for `total` units of work.
    pub fn new(label: &str, total: u64, quiet: bool) -> Self {
        let now = Instant::now();
        Progress {
            label: label.to_string(),
            total: total.max(1),
            start: now,
            last: now - Duration::from_secs(1),
            quiet,
        }
    }

    /// Redraws with `done` units finished.
    pub fn update(&mut self, done: u64) {
        if self.quiet || self.last.elapsed() < Duration::from_millis(250) && done < self.total {
            return;
        }
        self.last = Instant::now();
        let frac = (done as f64 / self.total as f64).min(1.0);
        let el = self.start.elapsed().as_secs_f64();
        let eta = if frac > 0.0 { el / frac - el } else { f64::NAN };
        let w = 30;
        let filled = (frac * w as f64) as usize;
        eprint!(
            "\r{} [{}{}] {:5.1}% {:6.0}s elapsed, ETA {:6.0}s ",
            self.label,
            "#".repeat(filled),
            ".".repeat(w - filled),
            frac * 100.0,
            el,
            eta
        );
        let _ = std::io::stderr().flush();
    }

    /// Ends the line.
    pub fn finish(&mut self) {
        if !self.quiet {
            self.last = Instant::now() - Duration::from_secs(1);
            self.update(self.total);
            eprintln!();
        }
    }
}

/// Mean and variance accumulator (Welford) for RGB values.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    /// Number of values.
    pub n: u64,
    /// Running mean per channel.
    pub mean: [f64; 3],
    /// Sum of squared deviations per channel.
    pub m2: [f64; 3],
}

impl Stats {
    /// Adds one RGB value.
    pub fn push(&mut self, v: [f64; 3]) {
        self.n += 1;
        let n = self.n as f64;
        for (c, &x) in v.iter().enumerate() {
            let d = x - self.mean[c];
            self.mean[c] += d / n;
            self.m2[c] += d * (x - self.mean[c]);
        }
    }

    /// Merges another accumulator (Chan et al.).
    pub fn merge(&mut self, o: &Stats) {
        if o.n == 0 {
            return;
        }
        let (na, nb) = (self.n as f64, o.n as f64);
        let n = na + nb;
        for c in 0..3 {
            let d = o.mean[c] - self.mean[c];
            self.mean[c] += d * nb / n;
            self.m2[c] += o.m2[c] + d * d * na * nb / n;
        }
        self.n += o.n;
    }

    /// Sample variance per channel.
    pub fn var(&self) -> [f64; 3] {
        let d = (self.n.max(2) - 1) as f64;
        [self.m2[0] / d, self.m2[1] / d, self.m2[2] / d]
    }

    /// Standard error of the mean per channel.
    pub fn se(&self) -> [f64; 3] {
        let v = self.var();
        let n = self.n.max(1) as f64;
        [(v[0] / n).sqrt(), (v[1] / n).sqrt(), (v[2] / n).sqrt()]
    }
}

/// Median of a slice (sorted copy).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    if s.is_empty() {
        f64::NAN
    } else {
        s[s.len() / 2]
    }
}

/// The command line that ran this tool, for CSV headers.
pub fn command_line(example: &str) -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() {
        format!("cargo run --release --example {example}")
    } else {
        format!(
            "cargo run --release --example {example} -- {}",
            args.join(" ")
        )
    }
}

/// Value of `--name value` on the command line.
pub fn arg_value(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

/// True when `--name` is on the command line.
pub fn arg_flag(name: &str) -> bool {
    std::env::args().any(|a| a == name)
}

/// Number of worker threads: `MSBSDF_THREADS` or the available parallelism.
pub fn threads() -> usize {
    std::env::var("MSBSDF_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        })
        .max(1)
}
