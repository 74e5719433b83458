//! What SINGLE's eval costs against the bare formula it evaluates, in
//! instructions (callgrind: load-independent) and nanoseconds:
//! `cargo run --release --example single_cost` (needs valgrind).
//!
//! The bare formula is `D(h) G2(wi, wo) F(wi.h) / (4 wi.z)` for GGX with the
//! height-correlated G2 and the material's Fresnel in its cheapest exact form
//! (1 for the white conductor eta 0, k 1; the closed form of the complex
//! Fresnel equations in real arithmetic per channel for gold), written here
//! with no checks at all, on unit directions in the upper hemisphere. SINGLE
//! is measured through the C entry point `msbsdf_eval` (what a renderer
//! calls) and through the Rust `Material::eval`, on the same 1024 pairs.
//!
//! `single_cost count <what> <material> N` runs exactly N calls and prints
//! nothing else; the driver runs it under callgrind for N and for 0 and
//! divides the difference by N. The result is written to
//! `docs/single_cost.md`.

use glam::Vec3;
use msbsdf::capi::{
    msbsdf_eval, msbsdf_material, msbsdf_material_create, msbsdf_material_desc_default,
    msbsdf_material_destroy, msbsdf_rgb, msbsdf_vec3,
};
use msbsdf::{Material, MaterialDesc, Rng};
use std::process::Command;

const ALPHA: f32 = 0.5;
const GOLD_ETA: Vec3 = Vec3::new(0.143, 0.374, 1.442);
const GOLD_K: Vec3 = Vec3::new(3.983, 2.385, 1.603);

fn material(name: &str) -> Material {
    let (eta, k) = if name == "gold" {
        (GOLD_ETA, GOLD_K)
    } else {
        (Vec3::ZERO, Vec3::ONE)
    };
    Material::new(&MaterialDesc {
        alpha_x: ALPHA,
        alpha_y: ALPHA,
        eta,
        k,
        ..MaterialDesc::default()
    })
    .expect("valid SINGLE material")
}

/// 1024 pairs of unit directions in the upper hemisphere (wi up to 80
/// degrees, wo anywhere above), fixed seed.
fn pairs() -> Vec<(Vec3, Vec3)> {
    let mut rng = Rng::new(3, 9);
    let mut dir = |max_z: f32| {
        let z = (1.0 - rng.next_f32() * (1.0 - max_z)).max(1e-3);
        let p = rng.next_f32() * std::f32::consts::TAU;
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * p.cos(), r * p.sin(), z)
    };
    (0..1024).map(|_| (dir(0.17), dir(0.0))).collect()
}

/// GGX Lambda for a unit direction above the surface (isotropic alpha).
#[inline(never)]
fn lambda(w: Vec3) -> f32 {
    let t = ALPHA * ALPHA * (w.x * w.x + w.y * w.y) / (w.z * w.z);
    t / (2.0 * (1.0 + (1.0 + t).sqrt()))
}

/// Conductor Fresnel reflectance of one channel, closed form in real
/// arithmetic (unpolarised average of s and p).
#[inline]
fn fresnel_conductor(c: f32, eta: f32, k: f32) -> f32 {
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - s2;
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).sqrt();
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t1 = a2b2 + c2;
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    0.5 * (rp + rs)
}

/// The bare formula: D G2 F / (4 wi.z) times wo.z ("f times cosine").
#[inline(never)]
fn bare(wi: Vec3, wo: Vec3, gold: bool) -> Vec3 {
    let h = (wi + wo).normalize();
    let a2 = ALPHA * ALPHA;
    let c2 = h.z * h.z;
    let den = c2 * (a2 - 1.0) + 1.0;
    let d = a2 / (std::f32::consts::PI * den * den);
    let g2 = 1.0 / (1.0 + lambda(wi) + lambda(wo));
    let f = if gold {
        let c = wi.dot(h);
        Vec3::new(
            fresnel_conductor(c, GOLD_ETA.x, GOLD_K.x),
            fresnel_conductor(c, GOLD_ETA.y, GOLD_K.y),
            fresnel_conductor(c, GOLD_ETA.z, GOLD_K.z),
        )
    } else {
        Vec3::ONE
    };
    f * (d * g2 / (4.0 * wi.z))
}

fn v3(v: Vec3) -> msbsdf_vec3 {
    msbsdf_vec3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// The same material through the C API (`msbsdf_material_create`).
fn c_material(name: &str) -> *mut msbsdf_material {
    let mut d = msbsdf_material_desc_default();
    d.alpha_x = ALPHA;
    d.alpha_y = ALPHA;
    if name == "gold" {
        d.eta = msbsdf_rgb {
            r: GOLD_ETA.x,
            g: GOLD_ETA.y,
            b: GOLD_ETA.z,
        };
        d.k = msbsdf_rgb {
            r: GOLD_K.x,
            g: GOLD_K.y,
            b: GOLD_K.z,
        };
    }
    let mut out = std::ptr::null_mut();
    // SAFETY: `d` is a valid description of the library's own layout and
    // `out` a valid place for the handle.
    let status = unsafe { msbsdf_material_create(&d, &mut out) };
    assert_eq!(status, 0, "msbsdf_material_create failed");
    out
}

fn run(what: &str, mat: &str, n: usize) -> Vec3 {
    let pairs = pairs();
    let m = material(mat);
    let handle = c_material(mat);
    let gold = mat == "gold";
    let mut rng = Rng::new(1, 1);
    let mut acc = Vec3::ZERO;
    for i in 0..n {
        let (wi, wo) = pairs[i & 1023];
        acc += match what {
            "bare" => bare(std::hint::black_box(wi), wo, gold),
            "rust" => m.eval(std::hint::black_box(wi), wo, &mut rng),
            _ => {
                let mut out = msbsdf_rgb {
                    r: 0.0,
                    g: 0.0,
                    b: 0.0,
                };
                // SAFETY: `handle` is a live material from
                // msbsdf_material_create, `out` is a valid msbsdf_rgb, and a
                // deterministic model accepts a NULL rng.
                let status = unsafe {
                    msbsdf_eval(
                        handle,
                        v3(std::hint::black_box(wi)),
                        v3(wo),
                        std::ptr::null_mut(),
                        &mut out,
                    )
                };
                assert_eq!(status, 0, "msbsdf_eval failed");
                Vec3::new(out.r, out.g, out.b)
            }
        };
    }
    // SAFETY: created above, destroyed once.
    unsafe { msbsdf_material_destroy(handle) };
    std::hint::black_box(acc)
}

/// Instructions per call of `what` on `mat`, by callgrind (N and 0 calls).
fn instructions(what: &str, mat: &str) -> Option<f64> {
    let exe = std::env::current_exe().ok()?;
    let n = 1 << 16;
    let count = |calls: usize| -> Option<f64> {
        let out = Command::new("valgrind")
            .args(["--tool=callgrind", "--callgrind-out-file=/dev/null"])
            .arg(&exe)
            .args(["count", what, mat, &calls.to_string()])
            .output()
            .ok()?;
        let err = String::from_utf8_lossy(&out.stderr);
        let line = err.lines().find(|l| l.contains("Collected :"))?;
        line.rsplit(':').next()?.trim().parse::<f64>().ok()
    };
    Some((count(n)? - count(0)?) / n as f64)
}

fn nanoseconds(what: &str, mat: &str) -> f64 {
    let n = 1 << 20;
    let mut best = f64::MAX;
    for _ in 0..7 {
        let t = std::time::Instant::now();
        run(what, mat, n);
        best = best.min(t.elapsed().as_secs_f64() * 1e9 / n as f64);
    }
    best
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 5 && args[1] == "count" {
        run(&args[2], &args[3], args[4].parse().unwrap_or(0));
        return;
    }
    // The formula and SINGLE agree (same pairs), so the comparison is fair.
    for mat in ["white", "gold"] {
        let m = material(mat);
        let mut rng = Rng::new(1, 1);
        for &(wi, wo) in &pairs() {
            let (a, b) = (bare(wi, wo, mat == "gold"), m.eval(wi, wo, &mut rng));
            let rel = ((a - b).abs() / b.abs().max(Vec3::splat(1e-30))).max_element();
            assert!(rel < 1e-3, "{mat} {wi} {wo}: bare {a} vs SINGLE {b}");
        }
    }
    let mut table = String::from(
        "| material | bare formula | msbsdf_eval | Material::eval | C entry / bare |\n|---|---|---|---|---|\n",
    );
    println!("instructions per eval (callgrind), fastest of 7 runs in ns");
    for mat in ["white", "gold"] {
        let ins: Vec<Option<f64>> = ["bare", "capi", "rust"]
            .iter()
            .map(|w| instructions(w, mat))
            .collect();
        let ns: Vec<f64> = ["bare", "capi", "rust"]
            .iter()
            .map(|w| nanoseconds(w, mat))
            .collect();
        let cell = |i: usize| match ins[i] {
            Some(x) => format!("{x:.0} ins, {:.1} ns", ns[i]),
            None => format!("(no valgrind), {:.1} ns", ns[i]),
        };
        let ratio = match (ins[0], ins[1]) {
            (Some(b), Some(c)) => format!("{:.2}x", c / b),
            _ => format!("{:.2}x (ns)", ns[1] / ns[0]),
        };
        let line = format!(
            "| GGX alpha {ALPHA} {mat} | {} | {} | {} | {ratio} |",
            cell(0),
            cell(1),
            cell(2)
        );
        println!("{line}");
        table += &line;
        table.push('\n');
    }
    let doc = format!(
        "# SINGLE eval against the bare formula\n\n\
         Written by `cargo run --release --example single_cost` (see its docs): \
         instructions per call by callgrind (difference of 2^16 calls and none, \
         over 1024 fixed pairs of upper-hemisphere directions, wi up to 80 degrees) \
         and the fastest of 7 timed runs of 2^20 calls on this machine.\n\n{table}"
    );
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/single_cost.md");
    if let Err(e) = std::fs::write(path, doc) {
        eprintln!("cannot write {path}: {e}");
    }
}
