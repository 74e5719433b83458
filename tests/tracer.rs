//! The C path tracer in `c_examples/tracer` (Embree 3 + msbsdf through the C
//! ABI): it builds with `-Wall -Wextra -Werror`, runs clean under ASan +
//! UBSan, its white furnace shows which models conserve energy, its images do
//! not depend on the thread count, and malformed scenes fail with a message.
//!
//! The tracer is linked against the `libmsbsdf.so` that this `cargo test`
//! run built (next to this test executable, in `target/<profile>/deps`), so it
//! sees exactly the models the Rust API below reports; if that file is absent
//! the test builds the release library instead. Build products go to
//! `CARGO_TARGET_TMPDIR`, never into the source tree.
//!
//! Needs `apt-get install -y libembree-dev libstb-dev libtinyobjloader-dev`
//! and make, cc and c++. Without Embree's header the tests fail under
//! `CI=true` and are recorded as skipped elsewhere (`tests/skip/mod.rs`);
//! with Embree present every other failure is a test failure.

mod skip;

use msbsdf::{FacetKind, Material, MaterialDesc, Model, NdfId};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn tmp() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("tracer")
}

struct Tools {
    tracer: PathBuf,
    asan: PathBuf,
}

/// Why the tracer cannot be built here, if Embree itself is missing.
fn embree_missing() -> Option<String> {
    let probe = Command::new("cc")
        .args(["-x", "c", "-fsyntax-only", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            use std::io::Write;
            c.stdin
                .take()
                .expect("stdin")
                .write_all(b"#include <embree3/rtcore.h>\n")?;
            c.wait_with_output()
        });
    match probe {
        Ok(out) if out.status.success() => None,
        Ok(out) => Some(format!(
            "<embree3/rtcore.h> does not compile ({}); install with \
             `apt-get install -y libembree-dev libstb-dev libtinyobjloader-dev`",
            String::from_utf8_lossy(&out.stderr).trim()
        )),
        Err(e) => Some(format!("no C compiler `cc` to probe for Embree: {e}")),
    }
}

/// The directory holding the libmsbsdf.so to link against.
fn library_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("current_exe");
    if let Some(deps) = exe.parent()
        && deps.join("libmsbsdf.so").exists()
    {
        return deps.to_path_buf();
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let st = Command::new(cargo)
        .args(["build", "--release"])
        .current_dir(root())
        .status()
        .expect("run cargo build --release");
    assert!(st.success(), "cargo build --release failed");
    root().join("target/release")
}

/// Builds both binaries once per test process (tests run in parallel);
/// `Err` says why they cannot be built here (Embree missing).
fn tools() -> Result<&'static Tools, String> {
    static TOOLS: OnceLock<Result<Tools, String>> = OnceLock::new();
    TOOLS
        .get_or_init(|| {
            if let Some(why) = embree_missing() {
                return Err(why);
            }
            let dir = tmp();
            std::fs::create_dir_all(&dir).expect("create tmp dir");
            let t = Tools {
                tracer: dir.join("tracer"),
                asan: dir.join("tracer-asan"),
            };
            let out = Command::new("make")
                .arg("-C")
                .arg(root().join("c_examples/tracer"))
                .arg("-j2")
                .arg(format!("LIBDIR={}", library_dir().display()))
                .arg(format!("BUILDDIR={}", dir.join("build").display()))
                .arg(format!("BIN={}", t.tracer.display()))
                .arg(format!("ASAN_BIN={}", t.asan.display()))
                .args(["all", "asan"])
                .output()
                .expect("run make (is it installed?)");
            assert!(
                out.status.success(),
                "building the tracer with -Wall -Wextra -Werror failed:\n{}\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            Ok(t)
        })
        .as_ref()
        .map_err(|why| why.clone())
}

fn scene(name: &str) -> PathBuf {
    root().join("c_examples/scenes").join(name)
}

fn run_with(bin: &Path, args: &[&str], asan_options: &str) -> Output {
    Command::new(bin)
        .args(args)
        .arg("--quiet")
        .env("ASAN_OPTIONS", asan_options)
        .env("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1")
        .output()
        .expect("run the tracer")
}

fn run(bin: &Path, args: &[&str]) -> Output {
    let out = run_with(bin, args, "detect_leaks=1:abort_on_error=0:exitcode=99");
    // LeakSanitizer needs ptrace, which some containers forbid; it then dies
    // with this message before checking anything. Only in that case (and
    // never under CI=true, where skip::missing fails the test), run again
    // without leak detection (ASan and UBSan proper still apply).
    if String::from_utf8_lossy(&out.stderr).contains("LeakSanitizer has encountered a fatal error")
    {
        skip::missing(
            "tracer leak checks",
            "LeakSanitizer cannot run here (no ptrace?)",
        );
        return run_with(bin, args, "detect_leaks=0:abort_on_error=0:exitcode=99");
    }
    out
}

fn text(out: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Reads a little-endian RGB PFM (as the tracer writes it).
fn read_pfm(path: &Path) -> (usize, usize, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("read {}: {e}", path.display()));
    let mut lines = 0;
    let mut pos = 0;
    while lines < 3 {
        if bytes[pos] == b'\n' {
            lines += 1;
        }
        pos += 1;
    }
    let head = String::from_utf8_lossy(&bytes[..pos]).to_string();
    let mut it = head.split_whitespace();
    assert_eq!(it.next(), Some("PF"));
    let w: usize = it.next().and_then(|s| s.parse().ok()).expect("width");
    let h: usize = it.next().and_then(|s| s.parse().ok()).expect("height");
    assert_eq!(it.next(), Some("-1.0"), "little-endian scale");
    let px: Vec<f32> = bytes[pos..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(px.len(), w * h * 3);
    (w, h, px)
}

fn out_prefix(name: &str) -> String {
    let p = tmp().join("out").join(name);
    p.display().to_string()
}

fn no_sanitizer_report(out: &Output) {
    let err = String::from_utf8_lossy(&out.stderr);
    for pat in [
        "AddressSanitizer",
        "LeakSanitizer",
        "runtime error",
        "UndefinedBehaviorSanitizer",
    ] {
        assert!(
            !err.contains(pat),
            "sanitizer report ({pat}):\n{}",
            text(out)
        );
    }
}

#[test]
fn tracer_runs_clean_under_asan_and_ubsan() {
    let t = match tools() {
        Ok(t) => t,
        Err(why) => return skip::missing("tracer_runs_clean_under_asan_and_ubsan", &why),
    };
    let cases: Vec<Vec<String>> = vec![
        vec![scene("matpreview.scene").display().to_string()],
        vec![scene("showcase.scene").display().to_string()],
        vec![scene("furnace.scene").display().to_string()],
        vec![
            scene("matpreview.scene").display().to_string(),
            "--compare".into(),
            "single,heitz_random_walk,vgroove".into(),
        ],
    ];
    for (i, c) in cases.iter().enumerate() {
        let mut args: Vec<&str> = c.iter().map(|s| s.as_str()).collect();
        let prefix = out_prefix(&format!("asan{i}"));
        args.extend([
            "--width",
            "32",
            "--height",
            "32",
            "--spp",
            "2",
            "--threads",
            "2",
            "--out",
            &prefix,
        ]);
        let out = run(&t.asan, &args);
        no_sanitizer_report(&out);
        assert!(out.status.success(), "{:?}\n{}", args, text(&out));
        let outputs: &[&str] = if c.len() > 1 {
            &[
                "_single.pfm",
                "_single.png",
                "_compare.png",
                "_compare_diff.png",
            ]
        } else {
            &[".pfm", ".png"]
        };
        for suffix in outputs {
            let f = format!("{prefix}{suffix}");
            let len = std::fs::metadata(&f).map(|m| m.len()).unwrap_or(0);
            assert!(len > 0, "{f} missing or empty\n{}", text(&out));
        }
    }
}

const ENERGY_CONSERVING: [(Model, &str); 9] = [
    (Model::HeitzRandomWalk, "heitz_random_walk"),
    (Model::PositionFree, "position_free"),
    (Model::Invariance, "invariance"),
    (Model::BitterliDeon, "bitterli_deon"),
    (Model::VGroove, "vgroove"),
    (Model::VGrooveNonsymmetric, "vgroove_nonsymmetric"),
    (Model::NullScattering, "null_scattering"),
    (Model::EnergyCompensated, "energy_compensated"),
    (Model::Tabulated, "tabulated"),
];

/// A furnace render (background radiance 1) of one model at 64x64.
struct Furnace {
    /// mean |pixel - 1| over pixels and channels, per pixel
    dev: f64,
    /// the same after averaging 8x8 pixel blocks (noise / 8, bias kept)
    dev8: f64,
    /// mean pixel value
    mean: f64,
}

fn furnace(t: &Tools, model: &str, spp: &str, extra: &[&str]) -> Furnace {
    let prefix = out_prefix(&format!("furnace_{model}_{}", extra.join("_")));
    let sc = scene("furnace.scene").display().to_string();
    let mut args = vec![
        sc.as_str(),
        "--model",
        model,
        "--width",
        "64",
        "--height",
        "64",
        "--spp",
        spp,
        "--threads",
        "2",
        "--out",
        &prefix,
    ];
    args.extend_from_slice(extra);
    let out = run(&t.tracer, &args);
    // Exit status 3: the tracer could not build the model (refused or not
    // in this build): a failure, since every model listed must be tested.
    assert!(
        out.status.success(),
        "furnace of {model} {extra:?}: {}",
        text(&out)
    );
    let (w, h, px) = read_pfm(Path::new(&format!("{prefix}.pfm")));
    let n = px.len() as f64;
    let dev = px.iter().map(|&v| (v as f64 - 1.0).abs()).sum::<f64>() / n;
    let mean = px.iter().map(|&v| v as f64).sum::<f64>() / n;
    let b = 8;
    let mut dev8 = 0.0;
    for by in (0..h).step_by(b) {
        for bx in (0..w).step_by(b) {
            for c in 0..3 {
                let mut s = 0.0;
                for y in by..by + b {
                    for x in bx..bx + b {
                        s += px[3 * (y * w + x) + c] as f64;
                    }
                }
                dev8 += (s / (b * b) as f64 - 1.0).abs();
            }
        }
    }
    dev8 /= (3 * (w / b) * (h / b)) as f64;
    Furnace { dev, dev8, mean }
}

/// White furnace: F = 1 conductor spheres (alpha 0.3 to 1.0, GGX and
/// Beckmann) under a uniform environment of radiance 1, 64x64 pixels.
///
/// Criterion: mean |pixel - 1| < 1% with NEE off at 64 spp, measured on
/// 8x8-pixel block averages (4096 samples each), so that the per-pixel noise
/// of models whose sample weight is not exactly 1 does not count as energy
/// loss, while a loss over a sphere's area (several blocks) does; plus
/// |image mean - 1| < 1% with NEE + MIS on (16 spp).
///
/// Measured at 32 spp, NEE off (per pixel / 8x8 blocks / image mean with
/// NEE on): SINGLE alpha 1.0 37% / 37%; SINGLE alpha 0.01 0.23% / -;
/// HEITZ_RANDOM_WALK 0.35% / 0.07% / 1.0001; ENERGY_COMPENSATED 4.6% / 0.78%
/// / 1.0005 (0.70% in blocks at 64 spp: part of it is bias, ~0.5%);
/// POSITION_FREE 0.35% / 0.06% / 0.9998; VGROOVE 2.2% / 0.50% / 1.0004;
/// VGROOVE_NONSYMMETRIC 1.4% / 0.24% / 1.0010 (the last three on a scratch
/// merge of their branches).
#[test]
fn furnace_energy_conserving_models_vanish() {
    let t = match tools() {
        Ok(t) => t,
        Err(why) => return skip::missing("furnace_energy_conserving_models_vanish", &why),
    };
    // Controls: the metric separates a lossy model from a (nearly) lossless one.
    let rough = furnace(t, "single", "32", &["--alpha", "1.0", "--nee", "off"]);
    eprintln!(
        "furnace single alpha 1.0: mean |p - 1| = {:.4} per pixel, {:.4} in 8x8 blocks",
        rough.dev, rough.dev8
    );
    assert!(
        rough.dev8 > 0.03,
        "single scattering should lose energy at alpha 1: {}",
        rough.dev8
    );
    let smooth = furnace(t, "single", "32", &["--alpha", "0.01", "--nee", "off"]);
    eprintln!(
        "furnace single alpha 0.01: mean |p - 1| = {:.4} per pixel",
        smooth.dev
    );
    assert!(
        smooth.dev < 0.01,
        "near-mirror single scattering: {}",
        smooth.dev
    );
    let smooth_nee = furnace(t, "single", "16", &["--alpha", "0.01", "--nee", "on"]);
    assert!(
        (smooth_nee.mean - 1.0).abs() < 0.01,
        "MIS biased: image mean {}",
        smooth_nee.mean
    );

    let mut tested = 0;
    for (model, name) in ENERGY_CONSERVING {
        let desc = MaterialDesc {
            model,
            ndf: NdfId::Ggx,
            facet: FacetKind::Conductor,
            alpha_x: 1.0,
            alpha_y: 1.0,
            ..MaterialDesc::default()
        };
        // Every listed model must be built and accept the furnace material:
        // a refusal is a failure, not a skip.
        if let Err(e) = Material::new(&desc) {
            panic!("furnace: {name} refuses GGX alpha 1 F = 1: {e:?}");
        }
        let off = furnace(t, name, "64", &["--nee", "off"]);
        let on = furnace(t, name, "16", &["--nee", "on"]);
        eprintln!(
            "furnace {name}: mean |p - 1| = {:.4} per pixel, {:.4} in 8x8 blocks (NEE off); \
             image mean {:.4} (NEE off), {:.4} (NEE on)",
            off.dev, off.dev8, off.mean, on.mean
        );
        assert!(
            off.dev8 < 0.01,
            "{name}: furnace deviation {} >= 1%",
            off.dev8
        );
        assert!(
            (on.mean - 1.0).abs() < 0.01,
            "{name}: furnace mean with NEE {}",
            on.mean
        );
        tested += 1;
    }
    eprintln!("furnace: {tested} energy-conserving model(s) tested");
    assert_eq!(
        tested,
        ENERGY_CONSERVING.len(),
        "every energy-conserving model must be tested"
    );
}

#[test]
fn same_seed_gives_identical_images_for_1_and_2_threads() {
    let t = match tools() {
        Ok(t) => t,
        Err(why) => {
            return skip::missing("same_seed_gives_identical_images_for_1_and_2_threads", &why);
        }
    };
    // showcase: textured roughness (per-thread material storage), glass, OBJ
    for sc in ["showcase.scene", "matpreview.scene"] {
        let path = scene(sc).display().to_string();
        let mut images = Vec::new();
        for (threads, seed) in [("1", "5"), ("2", "5"), ("2", "6")] {
            let prefix = out_prefix(&format!("det_{sc}_{threads}_{seed}"));
            let out = run(
                &t.tracer,
                &[
                    &path,
                    "--width",
                    "48",
                    "--height",
                    "32",
                    "--spp",
                    "3",
                    "--threads",
                    threads,
                    "--seed",
                    seed,
                    "--out",
                    &prefix,
                ],
            );
            assert!(out.status.success(), "{}", text(&out));
            images.push(std::fs::read(format!("{prefix}.pfm")).expect("pfm"));
        }
        assert!(images[0] == images[1], "{sc}: 1 and 2 threads differ");
        assert!(images[1] != images[2], "{sc}: the seed has no effect");
    }
}

#[test]
fn malformed_scenes_fail_with_file_line_and_reason() {
    let t = match tools() {
        Ok(t) => t,
        Err(why) => return skip::missing("malformed_scenes_fail_with_file_line_and_reason", &why),
    };
    let dir = tmp().join("bad");
    std::fs::create_dir_all(&dir).expect("mkdir");
    // A model this build refuses for dielectric facets (INVARIANCE is
    // conductor-only by design), found at run time.
    let unsupported = [
        (Model::Invariance, "invariance"),
        (Model::BitterliDeon, "bitterli_deon"),
        (Model::VGroove, "vgroove"),
    ]
    .into_iter()
    .find(|(m, _)| {
        let d = MaterialDesc {
            model: *m,
            facet: FacetKind::Dielectric,
            eta: glam::Vec3::splat(1.5),
            ..MaterialDesc::default()
        };
        Material::new(&d).is_err()
    })
    .map(|(_, n)| n)
    .expect("some conductor-only model refuses dielectric facets");
    let unsupported_line = format!("material glass model {unsupported} facet dielectric eta 1.5");
    let cases: Vec<(&str, String, usize, String)> = vec![
        (
            "unknown_key.scene",
            "camera position 0 0 5 look_at 0 0 0\nmaterial a model single foo 3\n".into(),
            2,
            "unknown key 'foo'".into(),
        ),
        (
            "bad_number.scene",
            "# comment\n\nmaterial a model single alpha 0.x3\n".into(),
            3,
            "bad number '0.x3'".into(),
        ),
        (
            "unknown_model.scene",
            "material a model blinn_phong\n".into(),
            1,
            "unknown model 'blinn_phong'".into(),
        ),
        (
            "missing_obj.scene",
            "material a\nobj does_not_exist.obj material a\n".into(),
            2,
            "cannot load OBJ".into(),
        ),
        (
            "missing_hdr.scene",
            "env hdr does_not_exist.hdr\n".into(),
            1,
            "cannot open HDR map".into(),
        ),
        (
            "unknown_statement.scene",
            "material a\ncylinder radius 1 material a\n".into(),
            2,
            "unknown statement 'cylinder'".into(),
        ),
        (
            "undefined_material.scene",
            "sphere center 0 0 0 radius 1 material nothing\n".into(),
            1,
            "undefined material 'nothing'".into(),
        ),
        (
            "bad_integer.scene",
            "render spp -5\n".into(),
            1,
            "'spp' must be in".into(),
        ),
        (
            "missing_value.scene",
            "light point position 1 2\n".into(),
            1,
            "expects a number".into(),
        ),
        (
            "unsupported_model.scene",
            format!("\n{unsupported_line}\nsphere material glass\n"),
            2,
            format!("refused model '{unsupported}'"),
        ),
    ];
    for (file, content, line, reason) in &cases {
        let path = dir.join(file);
        std::fs::write(&path, content).expect("write scene");
        let p = path.display().to_string();
        let out = run(
            &t.asan,
            &[&p, "--width", "8", "--height", "8", "--spp", "1"],
        );
        no_sanitizer_report(&out);
        let code = out.status.code();
        assert!(
            matches!(code, Some(c) if c != 0 && c != 99),
            "{file}: want a clean non-zero exit, got {}",
            text(&out)
        );
        let err = String::from_utf8_lossy(&out.stderr);
        let where_ = format!("{p}:{line}:");
        assert!(
            err.contains(&where_) && err.contains(reason.as_str()),
            "{file}: want '{where_}' and '{reason}' in stderr, got {}",
            text(&out)
        );
    }
    // the scene file itself missing
    let missing = dir.join("no_such.scene").display().to_string();
    let out = run(&t.asan, &[&missing]);
    no_sanitizer_report(&out);
    assert!(
        matches!(out.status.code(), Some(c) if c != 0 && c != 99),
        "{}",
        text(&out)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&missing) && err.contains("cannot open scene file"),
        "{}",
        text(&out)
    );
    // an unsupported model is exit status 3 (callers can tell it from errors)
    let out = run(
        &t.tracer,
        &[&dir.join("unsupported_model.scene").display().to_string()],
    );
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
}

/// Next-event estimation with MIS must not change the expected image: with
/// only an environment map (no delta lights, which NEE alone can reach),
/// the per-pixel difference between NEE + MIS and pure BSDF sampling has
/// mean zero. Paired test over pixels: |mean(d)| < 4 standard errors, where
/// the standard error comes from the spread of the per-pixel differences d.
/// This checks the environment map's sampling pdf against its lookup, and
/// the MIS weights.
#[test]
fn nee_and_mis_agree_with_bsdf_sampling_under_an_hdr_map() {
    let t = match tools() {
        Ok(t) => t,
        Err(why) => {
            return skip::missing(
                "nee_and_mis_agree_with_bsdf_sampling_under_an_hdr_map",
                &why,
            );
        }
    };
    let dir = tmp().join("mis");
    std::fs::create_dir_all(&dir).expect("mkdir");
    let hdr = scene("assets/studio.hdr").display().to_string();
    let path = dir.join("mis.scene");
    std::fs::write(
        &path,
        format!(
            "camera position 0 1 5 look_at 0 0.3 0 fov 40\n\
             render max_depth 8 tonemap aces\n\
             env hdr \"{hdr}\" rotate 30\n\
             material gold model single preset gold alpha 0.3\n\
             material copper model single preset copper alpha 0.08\n\
             material glass model single preset glass alpha 0.2\n\
             material floor model single preset aluminium alpha 0.6\n\
             sphere center -1.1 0.5 0 radius 0.5 material gold\n\
             sphere center 0 0.5 0 radius 0.5 material glass\n\
             sphere center 1.1 0.5 0 radius 0.5 material copper\n\
             plane center 0 0 0 normal 0 1 0 size 6 material floor\n"
        ),
    )
    .expect("write scene");
    let p = path.display().to_string();
    let mut images = Vec::new();
    for nee in ["on", "off"] {
        let prefix = out_prefix(&format!("mis_{nee}"));
        let out = run(
            &t.tracer,
            &[
                &p, "--width", "48", "--height", "32", "--spp", "64", "--nee", nee, "--out",
                &prefix,
            ],
        );
        assert!(out.status.success(), "{}", text(&out));
        images.push(read_pfm(Path::new(&format!("{prefix}.pfm"))).2);
    }
    let d: Vec<f64> = images[0]
        .iter()
        .zip(&images[1])
        .map(|(&a, &b)| a as f64 - b as f64)
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    let level = images[1].iter().map(|&v| v as f64).sum::<f64>() / n;
    eprintln!(
        "NEE+MIS minus BSDF-only: mean {mean:.5} (image mean {level:.4}), standard error {se:.5}"
    );
    assert!(
        mean.abs() < 4.0 * se,
        "NEE + MIS changes the image by {mean} (4 sigma = {})",
        4.0 * se
    );
    // the comparison has teeth: 4 sigma is a small fraction of the image
    assert!(
        4.0 * se < 0.03 * level,
        "too noisy to judge: se {se}, level {level}"
    );
}

/// The specular regime in the tracer (issue 14): F = 1 conductor spheres at
/// alpha 0 are Dirac mirrors (MSBSDF_MATERIAL_SPECULAR: the tracer skips NEE
/// on them, and msbsdf_sample_with returns weight 1), so the furnace keeps
/// all energy with NEE on and off; what noise remains is Russian roulette
/// (q = 0.95 from depth 3) and paths cut at the depth limit between spheres.
/// Criterion as for the glossy models: 8x8 block means within 1%, image mean
/// within 0.5% (32 spp).
#[test]
fn furnace_specular_regime_alpha_0() {
    let t = match tools() {
        Ok(t) => t,
        Err(why) => return skip::missing("furnace_specular_regime_alpha_0", &why),
    };
    for nee in ["off", "on"] {
        let f = furnace(t, "single", "32", &["--alpha", "0", "--nee", nee]);
        eprintln!(
            "furnace single alpha 0, NEE {nee}: mean |p - 1| = {:.2e} per pixel, {:.2e} in 8x8 blocks, mean {:.5}",
            f.dev, f.dev8, f.mean
        );
        assert!(f.dev8 < 0.01, "specular furnace, NEE {nee}: {}", f.dev8);
        assert!(
            (f.mean - 1.0).abs() < 0.005,
            "specular furnace, NEE {nee}: mean {}",
            f.mean
        );
    }
}
