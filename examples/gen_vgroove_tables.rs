//! Generates `src/tables/vgroove_partner_{beckmann,ggx,phong}.bin`, the
//! inverse CDFs of the partner-facet density `P(theta_r)` (Lee et al. 2018,
//! eq. 20) that `MSBSDF_MODEL_VGROOVE_NONSYMMETRIC` samples from, with the
//! library's own `fill_*` functions (bisection of the closed-form CDFs for
//! Beckmann and GGX, a trapezoid integration per column for Phong; no
//! random numbers). Compact binary (`msbsdf::multiple::bintable`), decoded
//! at compile time by `src/multiple/vgroove/dist.rs`.
//!
//! `cargo run --release --example gen_vgroove_tables` (a few seconds).

#[path = "../tools/harness/git.rs"]
mod git;

use msbsdf::multiple::bintable::encode;
use msbsdf::multiple::vgroove::dist::{
    PHONG_LEN, PHONG_W, STRIDE, TABLE_N, fill_beckmann, fill_ggx, fill_phong,
};

/// Name, header text, fill function and length of one table.
type Table = (&'static str, String, fn(&mut [f32]), usize);

fn main() {
    let commit = git::commit();
    let common = format!(
        "Index j: u = j / {TABLE_N}; value: eta(u) = atan(tan(theta) / scale), f32.\n\
         Command: cargo run --release --example gen_vgroove_tables\nCommit: {commit}\n"
    );
    let tables: [Table; 3] = [
        (
            "beckmann",
            format!(
                "V-groove partner inverse CDF, Beckmann: CDF(t) = erf(t) - 2 t exp(-t^2) / \
                 sqrt(pi), t = tan(eta), inverted by 60 bisection steps.\nShape: [{STRIDE}].\n"
            ),
            fill_beckmann,
            STRIDE,
        ),
        (
            "ggx",
            format!(
                "V-groove partner inverse CDF, GGX: CDF(eta) = (2 eta - sin 2 eta) / pi, \
                 inverted by 60 bisection steps.\nShape: [{STRIDE}].\n"
            ),
            fill_ggx,
            STRIDE,
        ),
        (
            "phong",
            format!(
                "V-groove partner inverse CDFs, Phong: column c (w = c / {PHONG_W} = \
                 sqrt(2 / (e + 2))) inverts the density of cos^e theta sin^2 theta in \
                 eta = atan(tan theta / w) by a 2^14-step trapezoid integration; column 0 \
                 is the Beckmann limit.\nShape: [column: {}][{STRIDE}].\n",
                PHONG_W + 1
            ),
            fill_phong,
            PHONG_LEN,
        ),
    ];
    for (name, text, fill, n) in tables {
        let mut v = vec![0.0f32; n];
        fill(&mut v);
        let path = format!(
            "{}/src/tables/vgroove_partner_{name}.bin",
            env!("CARGO_MANIFEST_DIR")
        );
        std::fs::write(&path, encode(&format!("{text}{common}"), &v)).expect("write the table");
        eprintln!("wrote {path}");
    }
}
