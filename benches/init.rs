//! Cost of `msbsdf_material_init` (a material built into caller storage)
//! when roughness and index change on every call, as they do when a
//! renderer reads them from a texture at each hit, per model and facet; and
//! the cost of one `msbsdf_eval` of the materials built.
//!
//! `cargo bench --bench init` prints the median ns per init and per eval
//! (wall clock, noisy on a shared machine). `cargo bench --bench init --
//! --callgrind` also runs each case under `valgrind --tool=callgrind` with
//! collection switched on inside `msbsdf_material_init` (then inside
//! `msbsdf_eval`) only, and prints instructions per call: the
//! load-independent figure, then each case's init instructions relative to
//! SINGLE conductor's and to SINGLE's of the same facet, and AUTO's own
//! overhead: AUTO's init minus that of
//! the models it picks, built directly from the same descriptions (the
//! `: chosen model` cases). A name filter may follow (`-- --callgrind
//! AUTO`; the ratios need `SINGLE conductor` among the cases run).
//!
//! Internally, `--count init|eval CASE N` runs `N` calls of one case (the
//! mode the callgrind runs use).

use msbsdf::capi::*;
use std::hint::black_box;
use std::mem::MaybeUninit;
use std::time::Instant;

/// Materials built per case in the timing mode (and in `--count`).
const N_INIT: usize = 20_000;
/// Evaluations per case.
const N_EVAL: usize = 20_000;

/// One model and facet.
#[derive(Clone, Copy)]
struct Case {
    name: &'static str,
    model: u32,
    ndf: u32,
    facet: u32,
    /// AUTO only: build the model AUTO picks for each description (its
    /// model and estimator in the description) instead of AUTO itself, so
    /// that AUTO's own overhead is the difference of the two cases.
    chosen: bool,
}

const CASES: &[Case] = &[
    Case {
        name: "SINGLE conductor",
        model: MSBSDF_MODEL_SINGLE,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "SINGLE conductor aniso",
        model: MSBSDF_MODEL_SINGLE,
        ndf: MSBSDF_NDF_GGX,
        facet: u32::MAX,
        chosen: false,
    },
    Case {
        name: "SINGLE dielectric",
        model: MSBSDF_MODEL_SINGLE,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "ENERGY_COMPENSATED conductor",
        model: MSBSDF_MODEL_ENERGY_COMPENSATED,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "ENERGY_COMPENSATED conductor aniso",
        model: MSBSDF_MODEL_ENERGY_COMPENSATED,
        ndf: MSBSDF_NDF_GGX,
        facet: u32::MAX, // conductor, alpha_y = 2 alpha_x (see `desc`)
        chosen: false,
    },
    Case {
        name: "ENERGY_COMPENSATED dielectric",
        model: MSBSDF_MODEL_ENERGY_COMPENSATED,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "HEITZ_RANDOM_WALK conductor",
        model: MSBSDF_MODEL_HEITZ_RANDOM_WALK,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "HEITZ_RANDOM_WALK dielectric",
        model: MSBSDF_MODEL_HEITZ_RANDOM_WALK,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "HEITZ_RANDOM_WALK diffuse",
        model: MSBSDF_MODEL_HEITZ_RANDOM_WALK,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIFFUSE,
        chosen: false,
    },
    Case {
        name: "POSITION_FREE conductor",
        model: MSBSDF_MODEL_POSITION_FREE,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "POSITION_FREE dielectric",
        model: MSBSDF_MODEL_POSITION_FREE,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "INVARIANCE conductor",
        model: MSBSDF_MODEL_INVARIANCE,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "BITTERLI_DEON conductor",
        model: MSBSDF_MODEL_BITTERLI_DEON,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "TABULATED conductor",
        model: MSBSDF_MODEL_TABULATED,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "TABULATED conductor aniso",
        model: MSBSDF_MODEL_TABULATED,
        ndf: MSBSDF_NDF_GGX,
        facet: u32::MAX,
        chosen: false,
    },
    Case {
        name: "TABULATED dielectric",
        model: MSBSDF_MODEL_TABULATED,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "VGROOVE conductor",
        model: MSBSDF_MODEL_VGROOVE,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "VGROOVE_NONSYMMETRIC conductor",
        model: MSBSDF_MODEL_VGROOVE_NONSYMMETRIC,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "NULL_SCATTERING conductor",
        model: MSBSDF_MODEL_NULL_SCATTERING,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "NULL_SCATTERING dielectric",
        model: MSBSDF_MODEL_NULL_SCATTERING,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "AUTO conductor",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: false,
    },
    Case {
        name: "AUTO conductor aniso",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: u32::MAX,
        chosen: false,
    },
    Case {
        name: "AUTO dielectric",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: false,
    },
    Case {
        name: "AUTO dielectric aniso",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: DIELECTRIC_ANISO,
        chosen: false,
    },
    Case {
        name: "AUTO conductor: chosen model",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_CONDUCTOR,
        chosen: true,
    },
    Case {
        name: "AUTO conductor aniso: chosen model",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: u32::MAX,
        chosen: true,
    },
    Case {
        name: "AUTO dielectric: chosen model",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: MSBSDF_FACET_DIELECTRIC,
        chosen: true,
    },
    Case {
        name: "AUTO dielectric aniso: chosen model",
        model: MSBSDF_MODEL_AUTO,
        ndf: MSBSDF_NDF_GGX,
        facet: DIELECTRIC_ANISO,
        chosen: true,
    },
];

/// The `facet` of a case: dielectric with `alpha_y = min(2 alpha_x, 1)`
/// (see `desc`; `u32::MAX` is the same for conductors).
const DIELECTRIC_ANISO: u32 = u32::MAX - 1;

/// The `i`-th description of a case: roughness in [0.2, 0.9] and the index
/// (conductor: around gold; dielectric: 1.2 to 2) change on every call, by
/// a low-discrepancy sequence (as texels would).
fn desc(c: &Case, i: usize) -> msbsdf_material_desc {
    let u = (i as f64 * 0.618_033_988_749_895).fract() as f32;
    let v = (i as f64 * 0.754_877_666_246_693).fract() as f32;
    let mut d = msbsdf_material_desc_default();
    d.model = c.model;
    d.ndf = c.ndf;
    d.alpha_x = 0.2 + 0.7 * u;
    d.alpha_y = d.alpha_x;
    match c.facet {
        MSBSDF_FACET_DIELECTRIC | DIELECTRIC_ANISO => {
            d.facet = MSBSDF_FACET_DIELECTRIC;
            if c.facet == DIELECTRIC_ANISO {
                d.alpha_y = (2.0 * d.alpha_x).min(1.0);
            }
            let eta = 1.2 + 0.8 * v;
            d.eta = msbsdf_rgb {
                r: eta,
                g: eta,
                b: eta,
            };
        }
        MSBSDF_FACET_DIFFUSE => {
            d.facet = MSBSDF_FACET_DIFFUSE;
            d.albedo = msbsdf_rgb {
                r: 0.5 + 0.4 * v,
                g: 0.5,
                b: 0.3,
            };
        }
        f => {
            d.facet = MSBSDF_FACET_CONDUCTOR;
            if f == u32::MAX {
                d.alpha_y = (2.0 * d.alpha_x).min(1.0);
            }
            // Gold, with the index scaled by up to 20%.
            let s = 0.9 + 0.2 * v;
            d.eta = msbsdf_rgb {
                r: 0.143 * s,
                g: 0.374 * s,
                b: 1.442 * s,
            };
            d.k = msbsdf_rgb {
                r: 3.983 * s,
                g: 2.385 * s,
                b: 1.603 * s,
            };
        }
    }
    if c.chosen {
        // What AUTO picks for this description (built with
        // `msbsdf_material_create`, outside the measured function).
        let mut m: *mut msbsdf_material = std::ptr::null_mut();
        // SAFETY: `d` and `m` are valid locals.
        let st = unsafe { msbsdf_material_create(&d, &mut m) };
        assert_eq!(st, MSBSDF_STATUS_OK, "{}: AUTO refused", c.name);
        let (mut model, mut est, mut n) = (0u32, 0u32, 0u32);
        // SAFETY: `m` is live; the outputs are valid locals.
        let st = unsafe { msbsdf_material_model(m, &mut model, &mut est, &mut n) };
        assert_eq!(st, MSBSDF_STATUS_OK);
        // SAFETY: created above, not used after.
        unsafe { msbsdf_material_destroy(m) };
        d.model = model;
        d.estimator = est;
    }
    d
}

/// Caller storage for one material.
struct Storage {
    buf: Vec<MaybeUninit<u128>>,
    size: usize,
}

impl Storage {
    fn new() -> Storage {
        let size = msbsdf_material_size();
        assert!(msbsdf_material_align() <= std::mem::align_of::<u128>());
        Storage {
            buf: vec![MaybeUninit::uninit(); size.div_ceil(16)],
            size,
        }
    }

    /// `msbsdf_material_init` into this storage.
    fn init(&mut self, d: &msbsdf_material_desc) -> (msbsdf_status, *mut msbsdf_material) {
        let mut m: *mut msbsdf_material = std::ptr::null_mut();
        // SAFETY: `d` and `m` are valid locals; the buffer holds `size`
        // bytes aligned to 16 >= msbsdf_material_align().
        let st =
            unsafe { msbsdf_material_init(d, self.buf.as_mut_ptr().cast(), self.size, &mut m) };
        (st, m)
    }
}

/// Direction pairs spread over the upper hemisphere (reflection).
fn pairs() -> Vec<(msbsdf_vec3, msbsdf_vec3)> {
    let dir = |a: f32, b: f32| {
        let z = 1.0 - 0.95 * b;
        let r = (1.0 - z * z).max(0.0).sqrt();
        msbsdf_vec3 {
            x: r * (std::f32::consts::TAU * a).cos(),
            y: r * (std::f32::consts::TAU * a).sin(),
            z,
        }
    };
    (0..256)
        .map(|i| {
            let f = |k: f64| ((i as f64 + 0.5) * k).fract() as f32;
            (
                dir(f(0.618_034), f(0.414_214)),
                dir(f(0.732_051), f(0.236_068)),
            )
        })
        .collect()
}

/// Calls `msbsdf_material_init` `n` times on the case; returns how many
/// succeeded.
fn run_init(c: &Case, n: usize) -> usize {
    let mut s = Storage::new();
    let descs: Vec<msbsdf_material_desc> = (0..1024).map(|i| desc(c, i)).collect();
    let mut ok = 0;
    for i in 0..n {
        let (st, m) = s.init(&descs[i & 1023]);
        ok += usize::from(st == MSBSDF_STATUS_OK);
        black_box(m);
    }
    ok
}

/// Calls `msbsdf_eval` `n` times on one material of the case (built from
/// its first description), with a seeded generator.
fn run_eval(c: &Case, n: usize) -> bool {
    let mut s = Storage::new();
    let (st, m) = s.init(&desc(c, 1));
    if st != MSBSDF_STATUS_OK {
        return false;
    }
    let dirs = pairs();
    let mut rng = msbsdf_rng::default();
    // SAFETY: rng is a valid local.
    unsafe { msbsdf_rng_seed(&mut rng, 7, 1) };
    let mut out = msbsdf_rgb::default();
    for i in 0..n {
        let (wi, wo) = dirs[i & 255];
        // SAFETY: `m` lives in `s`; rng and out are valid locals.
        black_box(unsafe { msbsdf_eval(m, wi, wo, &mut rng, &mut out) });
    }
    true
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Median over 7 runs of ns per call.
fn ns_per_call(n: usize, mut f: impl FnMut()) -> f64 {
    median(
        (0..7)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_nanos() as f64 / n as f64
            })
            .collect(),
    )
}

/// Instructions per call of `function` for `N` calls of `what` on `case`,
/// measured by callgrind on this executable; `None` when valgrind fails.
fn callgrind(what: &str, case: &str, function: &str, n: usize) -> Option<f64> {
    let exe = std::env::current_exe().ok()?;
    let out = std::env::temp_dir().join(format!("msbsdf_init_bench.{}.cg", std::process::id()));
    let status = std::process::Command::new("valgrind")
        .arg("--tool=callgrind")
        .arg(format!("--callgrind-out-file={}", out.display()))
        .arg(format!("--toggle-collect={function}"))
        .arg(&exe)
        .args(["--count", what, case, &n.to_string()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .ok()?;
    let text = std::fs::read_to_string(&out).ok();
    std::fs::remove_file(&out).ok();
    if !status.success() {
        return None;
    }
    let total: f64 = text?
        .lines()
        .find_map(|l| {
            l.strip_prefix("totals:")
                .or_else(|| l.strip_prefix("summary:"))
        })?
        .split_whitespace()
        .next()?
        .parse()
        .ok()?;
    Some(total / n as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(p) = args.iter().position(|a| a == "--count") {
        let what = args.get(p + 1).map(String::as_str).unwrap_or("init");
        let name = args.get(p + 2).map(String::as_str).unwrap_or("");
        let n: usize = args.get(p + 3).and_then(|s| s.parse().ok()).unwrap_or(1000);
        let Some(c) = CASES.iter().find(|c| c.name == name) else {
            eprintln!("unknown case {name:?}");
            std::process::exit(2);
        };
        let ok = if what == "eval" {
            run_eval(c, n)
        } else {
            run_init(c, n) == n
        };
        std::process::exit(if ok { 0 } else { 1 });
    }
    let with_callgrind = args.iter().any(|a| a == "--callgrind");
    let filter = args.iter().find(|a| !a.starts_with('-') && *a != "init");
    println!(
        "{:<36} {:>9} {:>9} {:>11} {:>11}",
        "model and facet", "init ns", "eval ns", "init instr", "eval instr"
    );
    // Init instructions per case, for the ratios printed at the end.
    let mut init_instr: Vec<(&str, f64)> = Vec::new();
    for c in CASES
        .iter()
        .filter(|c| filter.is_none_or(|f| c.name.contains(f.as_str())))
    {
        if run_init(c, 1024) != 1024 {
            println!("{:<36} refused", c.name);
            continue;
        }
        let init = ns_per_call(N_INIT, || {
            black_box(run_init(c, N_INIT));
        });
        let eval = ns_per_call(N_EVAL, || {
            black_box(run_eval(c, N_EVAL));
        });
        let (ci, ce) = if with_callgrind {
            let i = callgrind("init", c.name, "msbsdf_material_init", 2000);
            if let Some(i) = i {
                init_instr.push((c.name, i));
            }
            let f = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.0}"));
            (f(i), f(callgrind("eval", c.name, "msbsdf_eval", 2000)))
        } else {
            ("-".into(), "-".into())
        };
        println!("{:<36} {init:>9.1} {eval:>9.1} {ci:>11} {ce:>11}", c.name);
    }
    // Init instructions relative to SINGLE conductor's, and AUTO's own
    // overhead (AUTO minus the model it picks, built directly).
    let get = |n: &str| init_instr.iter().find(|x| x.0 == n).map(|x| x.1);
    if let Some(single) = get("SINGLE conductor") {
        // Also against SINGLE of the same facet (dielectric cases against
        // SINGLE dielectric's), the per-facet reading of the 2x rule.
        let single_d = get("SINGLE dielectric");
        println!(
            "\ninit instructions / SINGLE conductor's ({single:.0}), / SINGLE of the same facet:"
        );
        for (n, i) in &init_instr {
            let own = match single_d {
                Some(sd) if n.contains("dielectric") => i / sd,
                _ => i / single,
            };
            println!("  {n:<36} {:>6.2} {own:>6.2}", i / single);
        }
        for (n, i) in &init_instr {
            if let Some(chosen) = get(&format!("{n}: chosen model")) {
                println!(
                    "  {n}: AUTO overhead {:.0} instructions ({:.2} x SINGLE), chosen model {chosen:.0} ({:.2} x SINGLE)",
                    i - chosen,
                    (i - chosen) / single,
                    chosen / single
                );
            }
        }
    }
}
