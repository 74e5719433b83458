//! What `MSBSDF_MODEL_AUTO` picks, per facet, NDF, roughness and
//! tolerance, from the committed table (`src/tables/auto.bin`): the model,
//! its evaluations per query, the error the table predicts and the cost
//! relative to SINGLE. Writes `docs/auto_picks.md` (or prints it with
//! `--stdout`); the header's and README's description of AUTO's default is
//! read off this table.
//!
//! `cargo run --release --example auto_picks`

#[path = "../tools/harness/mod.rs"]
mod harness;

use harness::suite::{AUTO_PICK_ROUGHNESS, auto_pick_desc};
use msbsdf::desc::{Estimator, FacetKind, MaterialDesc, Model, NdfId};
use msbsdf::material::Material;
use msbsdf::multiple::auto_table::REFERENCE_NS;
use std::fmt::Write as _;

/// Tolerances shown (the default's column is marked).
const TOLERANCES: [f32; 5] = [0.02, 0.1, 0.05, 0.03, 0.01];

fn short(m: Model, e: Estimator) -> String {
    let name = match m {
        Model::Single => "SINGLE",
        Model::EnergyCompensated => "EC",
        Model::HeitzRandomWalk => "HEITZ",
        Model::PositionFree => "POSITION_FREE",
        Model::Invariance => "INVARIANCE",
        Model::BitterliDeon => "BITTERLI_DEON",
        Model::VGroove => "VGROOVE",
        Model::VGrooveNonsymmetric => "VGROOVE_NS",
        Model::NullScattering => "NULL_SCATTERING",
        Model::Auto => "AUTO",
        Model::Tabulated => "TABULATED",
    };
    match e {
        Estimator::Bdpt => format!("{name}/BDPT"),
        _ => name.to_string(),
    }
}

fn main() {
    let stdout = std::env::args().any(|a| a == "--stdout");
    let default_tol = MaterialDesc::default().tolerance;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# What AUTO picks (generated)\n\n`cargo run --release --example auto_picks`, from the \
         committed table `src/tables/auto.bin`. Each cell: the model (EC = ENERGY_COMPENSATED), \
         `xN` the evaluations averaged per query when more than one, the relative RMS error the \
         table predicts (an upper confidence value) and the cost per query relative to SINGLE's. \
         Conductor: gold; dielectric: glass 1.5. The default tolerance is {default_tol}.\n"
    );
    for (facet, fname) in [
        (FacetKind::Conductor, "conductor"),
        (FacetKind::Dielectric, "dielectric"),
    ] {
        for (ndf, nname) in [(NdfId::Ggx, "GGX"), (NdfId::Beckmann, "Beckmann")] {
            let _ = writeln!(out, "## {nname} {fname}\n");
            let mut head = String::from("| roughness |");
            let mut rule = String::from("|---|");
            for t in TOLERANCES {
                let mark = if t == default_tol { " (default)" } else { "" };
                let _ = write!(head, " tolerance {t}{mark} |");
                rule += "---|";
            }
            let _ = writeln!(out, "{head}\n{rule}");
            for (ax, ay) in AUTO_PICK_ROUGHNESS {
                let mut line = if ax == ay {
                    format!("| {ax} |")
                } else {
                    format!("| ({ax}, {ay}) |")
                };
                for tolerance in TOLERANCES {
                    let d = auto_pick_desc(ndf, facet, (ax, ay), tolerance);
                    let cell = match Material::new(&d) {
                        Ok(m) => {
                            let c = m.chosen();
                            let n = if c.evaluations > 1 {
                                format!(" x{}", c.evaluations)
                            } else {
                                String::new()
                            };
                            format!(
                                "{}{n} {:.3}, {:.1}x",
                                short(c.model, c.estimator),
                                c.error,
                                c.ns / REFERENCE_NS
                            )
                        }
                        Err(e) => format!("refused: {e:?}"),
                    };
                    let _ = write!(line, " {cell} |");
                }
                let _ = writeln!(out, "{line}");
            }
            let _ = writeln!(out);
        }
    }
    if stdout {
        print!("{out}");
        return;
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/auto_picks.md");
    if let Err(e) = std::fs::write(path, &out) {
        eprintln!("auto_picks: cannot write {path}: {e}");
        std::process::exit(1);
    }
    eprintln!("auto_picks: wrote {path}");
}
