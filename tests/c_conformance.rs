//! C conformance of the core C ABI (DESIGN.md section 2).
//!
//! Compiles the C programs of `tests/c` with the system `cc` (C99,
//! `-Wall -Wextra -pedantic -Werror`) against the committed
//! `include/msbsdf.h` and the shared object (and, for some, the static
//! library) that `cargo test` built for this profile, runs them and asserts
//! that each exits 0 and prints `<program>: ALL <n> CHECKS PASSED`. A C
//! program reports every failed rule on its own `FAIL file:line:` line, shown
//! in the panic message. Also checks the exported symbols against
//! `abi/symbols.txt`, the SONAME, that the header compiles alone as C99 and
//! C++11, and that `c_examples/minimal.c` builds and runs.
//!
//! Where the library comes from: `cargo test` builds the crate's `cdylib` and
//! `staticlib` next to the test executables (`target/<profile>/deps/`; it
//! does not copy them up to `target/<profile>/` as `cargo build` does). When
//! neither place has them, the test runs `cargo build` for the same profile.
//! The shared object carries the SONAME `libmsbsdf.so.0`, so programs linked
//! against it look for that name at run time: the test copies the library to
//! `$CARGO_TARGET_TMPDIR/c_conformance-<profile>/lib/` next to a `libmsbsdf.so.0` link
//! and links with an RPATH to that directory.

mod clib;

use clib::{repo, run_ok};
use msbsdf::capi::msbsdf_material_size;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::Duration;

/// Warnings every C and C++ translation unit must compile cleanly with.
const WARNINGS: [&str; 4] = ["-Wall", "-Wextra", "-pedantic", "-Werror"];
/// Libraries a program linked against the Rust staticlib needs on Linux
/// (`rustc --print native-static-libs`).
const STATIC_NATIVE_LIBS: [&str; 7] = [
    "-lgcc_s",
    "-lutil",
    "-lrt",
    "-lpthread",
    "-lm",
    "-ldl",
    "-lc",
];
/// Wall-clock limit for one C program (they take well under a second).
const RUN_TIMEOUT: Duration = Duration::from_secs(120);

/// This test's scratch directory (`$CARGO_TARGET_TMPDIR/c_conformance-<profile>`).
fn work_dir() -> PathBuf {
    clib::work_dir("c_conformance")
}

/// The libraries under test (shared through its SONAME link, static, and
/// the shared object as cargo built it), located or built by `tests/clib`.
struct Lib {
    /// Directory with `libmsbsdf.so` and the `libmsbsdf.so.0` SONAME link.
    dir: PathBuf,
    /// The shared object as cargo built it.
    built_so: PathBuf,
    /// The static library as cargo built it.
    built_a: PathBuf,
}

fn lib() -> &'static Lib {
    static LIB: OnceLock<Lib> = OnceLock::new();
    LIB.get_or_init(|| Lib {
        dir: clib::shared_lib_dir("c_conformance"),
        built_so: clib::built_dir().join("libmsbsdf.so"),
        built_a: clib::static_lib(),
    })
}

/// How a program is linked.
#[derive(Clone, Copy, PartialEq)]
enum Link {
    /// Against `libmsbsdf.so` (through its SONAME link), with an RPATH.
    Shared,
    /// Against `libmsbsdf.a`.
    Static,
}

/// Compiles `sources` (paths under `tests/c`) into `work_dir()/<name>`.
fn compile(name: &str, sources: &[&str], extra: &[String], link: Link) -> PathBuf {
    let lib = lib();
    let dir = work_dir();
    std::fs::create_dir_all(&dir).expect("create work dir");
    let exe = dir.join(name);
    let mut cmd = Command::new("cc");
    cmd.args(["-std=c99", "-O2"])
        .args(WARNINGS)
        .arg("-I")
        .arg(repo().join("include"))
        .arg("-I")
        .arg(repo().join("tests/c"))
        .args(extra);
    for s in sources {
        cmd.arg(repo().join("tests/c").join(s));
    }
    cmd.arg("-o").arg(&exe);
    match link {
        Link::Shared => {
            cmd.arg(format!("-L{}", lib.dir.display()))
                .arg("-lmsbsdf")
                // RPATH (searched before LD_LIBRARY_PATH, which cargo sets).
                .arg(format!("-Wl,-rpath,{}", lib.dir.display()))
                .arg("-Wl,--disable-new-dtags")
                .arg("-lm");
        }
        Link::Static => {
            cmd.arg(&lib.built_a).args(STATIC_NATIVE_LIBS);
        }
    }
    run_ok(&mut cmd, &format!("compiling {name}"));
    exe
}

/// Runs `exe` with a time limit; returns (exit success, stdout + stderr).
fn run_program(exe: &Path) -> (bool, String) {
    clib::run_program(&mut Command::new(exe), RUN_TIMEOUT)
}

/// Runs a conformance program and asserts that all its checks passed.
fn assert_program_passes(exe: &Path, program: &str) -> String {
    let (ok, text) = run_program(exe);
    println!("{text}");
    let summary = format!("{program}: ALL ");
    assert!(
        ok && text
            .lines()
            .any(|l| l.starts_with(&summary) && l.ends_with(" CHECKS PASSED")),
        "C conformance program `{program}` ({}) failed:\n{text}",
        exe.display()
    );
    assert!(
        !text.contains("FAIL "),
        "`{program}` printed failures:\n{text}"
    );
    text
}

/// `-D` values with Rust's view of every public struct, for `layout.c`.
fn layout_defines() -> Vec<String> {
    let mut d: Vec<String> = clib::rust_layout()
        .into_iter()
        .map(|item| match item {
            clib::LayoutItem::Size(t, n) => format!("-DRUST_SIZEOF_{t}={n}"),
            clib::LayoutItem::Align(t, n) => format!("-DRUST_ALIGNOF_{t}={n}"),
            clib::LayoutItem::Offset(t, f, n) => format!("-DRUST_OFFSETOF_{t}_{f}={n}"),
        })
        .collect();
    let v = |s: &str| s.parse::<u32>().expect("numeric version");
    let (major, minor, patch) = (
        v(env!("CARGO_PKG_VERSION_MAJOR")),
        v(env!("CARGO_PKG_VERSION_MINOR")),
        v(env!("CARGO_PKG_VERSION_PATCH")),
    );
    d.push(format!("-DRUST_VERSION_MAJOR={major}"));
    d.push(format!("-DRUST_VERSION_MINOR={minor}"));
    d.push(format!("-DRUST_VERSION_PATCH={patch}"));
    d.push(format!(
        "-DRUST_VERSION_PACKED={}u",
        (major << 16) | (minor << 8) | patch
    ));
    d.push(format!("-DRUST_MATERIAL_SIZE={}u", msbsdf_material_size()));
    d
}

#[test]
fn layout_and_version_match_rust_as_c99() {
    let exe = compile("layout_c99", &["layout.c"], &layout_defines(), Link::Shared);
    assert_program_passes(&exe, "layout");
}

#[test]
fn layout_and_version_match_rust_as_c11() {
    let mut flags = layout_defines();
    flags.push("-std=c11".into());
    let exe = compile("layout_c11", &["layout.c"], &flags, Link::Shared);
    assert_program_passes(&exe, "layout");
}

/// A mismatch between Rust and C is a compile error, not a silent pass.
#[test]
fn layout_check_rejects_a_wrong_rust_value() {
    let mut flags: Vec<String> = layout_defines()
        .into_iter()
        .filter(|f| !f.starts_with("-DRUST_OFFSETOF_msbsdf_material_desc_inner="))
        .collect();
    flags.push("-DRUST_OFFSETOF_msbsdf_material_desc_inner=76".into());
    for std in ["-std=c99", "-std=c11"] {
        let out = Command::new("cc")
            .args([std, "-fsyntax-only"])
            .args(WARNINGS)
            .arg("-I")
            .arg(repo().join("include"))
            .arg("-I")
            .arg(repo().join("tests/c"))
            .args(&flags)
            .arg(repo().join("tests/c/layout.c"))
            .output()
            .expect("run cc");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains("offsetof_msbsdf_material_desc_inner"),
            "{std}: a wrong offset was not caught:\n{err}"
        );
    }
}

#[test]
fn api_statuses_and_zeroed_outputs_shared() {
    let exe = compile("api_shared", &["api.c"], &[], Link::Shared);
    assert_program_passes(&exe, "api");
}

#[test]
fn api_statuses_and_zeroed_outputs_static() {
    let exe = compile("api_static", &["api.c"], &[], Link::Static);
    assert_program_passes(&exe, "api");
}

#[test]
fn rng_matches_reference_pcg32() {
    for (name, link) in [("rng_shared", Link::Shared), ("rng_static", Link::Static)] {
        let exe = compile(name, &["rng.c"], &[], link);
        assert_program_passes(&exe, "rng");
    }
}

#[test]
fn material_init_in_caller_storage() {
    let exe = compile("storage", &["storage.c"], &[], Link::Shared);
    assert_program_passes(&exe, "storage");
}

#[test]
fn hot_path_never_allocates() {
    let exe = compile(
        "no_alloc",
        &["no_alloc.c", "malloc_count.c"],
        &[],
        Link::Shared,
    );
    let text = assert_program_passes(&exe, "no_alloc");
    assert!(
        text.contains("0 allocations, 0 frees"),
        "allocation summary missing:\n{text}"
    );
    assert!(
        text.contains("0 allocations after warm-up"),
        "all-models phase missing:\n{text}"
    );
}

#[test]
fn threads_reproduce_single_thread_bits() {
    let exe = compile(
        "threads",
        &["threads.c"],
        &["-pthread".into()],
        Link::Shared,
    );
    assert_program_passes(&exe, "threads");
}

#[test]
fn header_compiles_alone_as_c99_and_cxx11() {
    let src = repo().join("tests/c/header_only.c");
    let dir = work_dir();
    std::fs::create_dir_all(&dir).expect("create work dir");
    for (compiler, lang) in [
        ("cc", &["-std=c99"][..]),
        ("c++", &["-std=c++11", "-x", "c++"][..]),
    ] {
        let obj = dir.join(format!("header_only_{compiler}.o"));
        run_ok(
            Command::new(compiler)
                .args(lang)
                .args(WARNINGS)
                .arg("-I")
                .arg(repo().join("include"))
                .arg("-c")
                .arg(&src)
                .arg("-o")
                .arg(&obj),
            &format!("compiling include/msbsdf.h alone with {compiler} {lang:?}"),
        );
    }
}

/// Symbols `nm -D --defined-only` lists for a shared object, sorted.
fn exported_symbols(so: &Path) -> Vec<String> {
    let text = run_ok(
        Command::new("nm").args(["-D", "--defined-only"]).arg(so),
        "nm -D",
    );
    let mut syms: Vec<String> = text
        .lines()
        .filter_map(|l| l.split_whitespace().last())
        .map(|s| s.split('@').next().unwrap_or(s).to_string())
        .collect();
    syms.sort();
    syms.dedup();
    syms
}

#[test]
fn exported_symbols_match_abi_list() {
    let listed = std::fs::read_to_string(repo().join("abi/symbols.txt")).expect("abi/symbols.txt");
    let listed: Vec<&str> = listed.lines().filter(|l| !l.trim().is_empty()).collect();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(
        listed, sorted,
        "abi/symbols.txt must be sorted bytewise (`LC_ALL=C sort`), one symbol per line"
    );
    let got = exported_symbols(&lib().built_so);
    assert_eq!(
        got,
        listed,
        "the symbols exported by {} differ from abi/symbols.txt; a new function needs its \
         name added there (sorted), and a symbol must never disappear",
        lib().built_so.display()
    );
    assert!(
        got.iter().all(|s| s.starts_with("msbsdf_")),
        "only msbsdf_* symbols may be exported: {got:?}"
    );
}

#[test]
fn shared_object_soname_is_libmsbsdf_so_major() {
    let text = run_ok(
        Command::new("readelf").arg("-d").arg(&lib().built_so),
        "readelf -d",
    );
    let sonames: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("(SONAME)"))
        .filter_map(|l| l.split('[').nth(1))
        .filter_map(|l| l.split(']').next())
        .collect();
    let want = format!("libmsbsdf.so.{}", env!("CARGO_PKG_VERSION_MAJOR"));
    assert_eq!(sonames, [want.as_str()], "readelf -d:\n{text}");
    assert_eq!(want, "libmsbsdf.so.0", "DESIGN.md fixes the SONAME of 0.x");
}

/// `c_examples/minimal.c` builds with its Makefile (pointed at this test's
/// library; with the same flags directly when `make` is not installed) and
/// prints its albedo table.
#[test]
fn c_example_minimal_builds_and_prints_albedo_table() {
    let dir = work_dir().join("minimal");
    std::fs::create_dir_all(&dir).expect("create dir");
    let exe = dir.join("minimal");
    let _ = std::fs::remove_file(&exe);
    let examples = repo().join("c_examples");
    if Command::new("make").arg("--version").output().is_ok() {
        run_ok(
            Command::new("make")
                .arg("-s")
                .arg("-C")
                .arg(&examples)
                .arg(format!("LIBDIR={}", lib().dir.display()))
                .arg(format!("OUT={}", exe.display()))
                .arg(exe.display().to_string()),
            "make -C c_examples",
        );
    } else {
        run_ok(
            Command::new("cc")
                .args(["-std=c99", "-O2"])
                .args(WARNINGS)
                .arg("-I")
                .arg(repo().join("include"))
                .arg("-o")
                .arg(&exe)
                .arg(examples.join("minimal.c"))
                .arg(format!("-L{}", lib().dir.display()))
                .arg("-lmsbsdf")
                .arg(format!("-Wl,-rpath,{}", lib().dir.display()))
                .arg("-lm"),
            "compiling c_examples/minimal.c",
        );
    }
    let (ok, text) = run_program(&exe);
    println!("{text}");
    assert!(ok, "minimal failed:\n{text}");
    // The table: a header, then theta_i = 0, 10, ..., 80 with finite
    // albedos in [0, 1.05] (Monte Carlo estimates of values <= 1).
    let header = text
        .lines()
        .position(|l| l.starts_with("theta_i"))
        .unwrap_or_else(|| panic!("no albedo table in the output:\n{text}"));
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(header + 1)
        .take_while(|l| !l.trim().is_empty())
        .map(|l| {
            l.split_whitespace()
                .map(|x| x.parse::<f64>().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 9, "expected 9 rows (0..80 degrees):\n{text}");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[0], 10.0 * i as f64, "row {i}:\n{text}");
        assert!(
            row.len() >= 7
                && row[1..]
                    .iter()
                    .all(|a| a.is_finite() && (0.0..=1.05).contains(a)),
            "row {i} has albedos outside [0, 1.05]:\n{text}"
        );
    }
}

/// Frozen 0.2 desc layout, a larger future layout, the init macros and the
/// growth of the context and sample record (tests/c/growth.c).
#[test]
fn struct_growth_old_and_future_layouts() {
    for (name, link) in [
        ("growth_shared", Link::Shared),
        ("growth_static", Link::Static),
    ] {
        let exe = compile(name, &["growth.c"], &[], link);
        assert_program_passes(&exe, "growth");
    }
}

/// The integrator calls: eval_pdf against eval and pdf bit for bit, same
/// uniforms same sample, stratification, radiance against importance,
/// restricted lobes, the specular regime (tests/c/integrator.c).
#[test]
fn integrator_calls_eval_pdf_uniforms_transport_lobes_specular() {
    let exe = compile(
        "integrator",
        &["integrator.c"],
        &["-lm".into()],
        Link::Shared,
    );
    let text = assert_program_passes(&exe, "integrator");
    assert!(text.contains("pdf integrates to"), "{text}");
}

/// `msbsdf_sample_with` on the walks (tests/c/uniforms_walks.c): their
/// first vertex follows the uniforms (NULL_SCATTERING with its GGX default).
#[test]
fn sample_with_uniforms_walks() {
    let exe = compile(
        "uniforms_walks",
        &["uniforms_walks.c"],
        &["-lm".into()],
        Link::Shared,
    );
    assert_program_passes(&exe, "uniforms_walks");
}

/// A composition outlives its inner material: AddressSanitizer watches the
/// program destroy the inner material first and then use the outer one.
#[test]
fn inner_material_destroyed_first_under_asan() {
    let asan = ["-fsanitize=address", "-fno-omit-frame-pointer"];
    if let Err(why) = clib::compiler_supports("cc", &asan) {
        panic!("cc cannot build and run -fsanitize=address programs: {why}");
    }
    let flags: Vec<String> = asan.iter().map(|s| s.to_string()).collect();
    let exe = compile(
        "inner_lifetime_asan",
        &["inner_lifetime.c"],
        &flags,
        Link::Shared,
    );
    let text = assert_program_passes(&exe, "inner_lifetime");
    assert!(!text.contains("AddressSanitizer"), "{text}");
}

/// The first fenced block of `lang` after the heading `heading` of README.md.
fn readme_block(heading: &str, lang: &str) -> String {
    let readme = std::fs::read_to_string(repo().join("README.md")).expect("README.md");
    let start = readme
        .find(&format!("\n{heading}\n"))
        .unwrap_or_else(|| panic!("README has no `{heading}`"));
    let rest = &readme[start..];
    let open = format!("```{lang}\n");
    let from = rest
        .find(&open)
        .unwrap_or_else(|| panic!("no ```{lang} block after `{heading}`"))
        + open.len();
    let len = rest[from..].find("```").expect("closing fence");
    rest[from..from + len].to_string()
}

/// Compiles `source` (written to the work dir as `name.ext`) with `compiler
/// flags`, links the shared library and runs it; returns its output.
fn compile_and_run_snippet(
    name: &str,
    ext: &str,
    compiler: &str,
    flags: &[&str],
    source: &str,
) -> String {
    let dir = work_dir().join("snippets");
    std::fs::create_dir_all(&dir).expect("create dir");
    let src = dir.join(format!("{name}.{ext}"));
    let exe = dir.join(name);
    std::fs::write(&src, source).expect("write snippet");
    run_ok(
        Command::new(compiler)
            .args(flags)
            .args(WARNINGS)
            .arg("-I")
            .arg(repo().join("include"))
            .arg(&src)
            .arg("-o")
            .arg(&exe)
            .arg(format!("-L{}", lib().dir.display()))
            .arg("-lmsbsdf")
            .arg(format!("-Wl,-rpath,{}", lib().dir.display())),
        &format!("compiling {name}"),
    );
    let (ok, text) = run_program(&exe);
    assert!(ok, "{name} failed:\n{text}");
    text
}

/// README's C and C++ programs compile as printed and run (issue 14).
#[test]
fn readme_c_and_cxx_snippets_compile_and_run() {
    let c = readme_block("## Using it from C", "c");
    assert!(c.contains("int main(void)"), "{c}");
    let out = compile_and_run_snippet("readme_c", "c", "cc", &["-std=c99"], &c);
    assert!(out.contains("flags") && out.contains("weight.g"), "{out}");
    let cxx = readme_block("## Using it from C++", "cpp");
    let out = compile_and_run_snippet("readme_cpp", "cpp", "c++", &["-std=c++11"], &cxx);
    assert!(out.contains("weight.g"), "{out}");
}

/// The example in msbsdf.hpp's header comment compiles and runs.
#[test]
fn hpp_comment_example_compiles_and_runs() {
    let hpp = std::fs::read_to_string(repo().join("include/msbsdf.hpp")).expect("msbsdf.hpp");
    let start = hpp
        .find(" * Example (")
        .expect("example marker in msbsdf.hpp");
    let body: Vec<&str> = hpp[start..]
        .lines()
        .skip(2)
        .take_while(|l| l.starts_with(" *   "))
        .map(|l| &l[5..])
        .collect();
    assert!(body.len() > 5, "example too short: {body:?}");
    let source = format!(
        "#include <cstdint>\n#include <cstdio>\n#include <msbsdf.hpp>\n\n{}\n\nint main() {{\n    \
         float w = sampled_weight(7, 0);\n    std::printf(\"weight %g\\n\", w);\n    \
         return w >= 0.0f ? 0 : 1;\n}}\n",
        body.join("\n")
    );
    let out = compile_and_run_snippet("hpp_example", "cpp", "c++", &["-std=c++11"], &source);
    assert!(out.contains("weight"), "{out}");
}

/// The header is clean C89 (`-std=c89 -pedantic`): no `//` comments, no
/// `inline`, no mixed declarations in its macros.
#[test]
fn header_compiles_as_c89_pedantic() {
    let dir = work_dir();
    std::fs::create_dir_all(&dir).expect("create work dir");
    let src = dir.join("c89.c");
    std::fs::write(
        &src,
        "#include \"msbsdf.h\"\nint main(void)\n{\n    msbsdf_material_desc d;\n    \
         msbsdf_context c;\n    msbsdf_sample_record r;\n    msbsdf_material_desc_init(&d);\n    \
         msbsdf_context_init(&c);\n    msbsdf_sample_record_init(&r);\n    \
         return (int)(d.model + c.lobes + r.flags) - 3;\n}\n",
    )
    .expect("write c89.c");
    let exe = dir.join("c89");
    run_ok(
        Command::new("cc")
            .arg("-std=c89")
            .args(WARNINGS)
            .arg("-I")
            .arg(repo().join("include"))
            .arg(&src)
            .arg("-o")
            .arg(&exe)
            .arg(format!("-L{}", lib().dir.display()))
            .arg("-lmsbsdf")
            .arg(format!("-Wl,-rpath,{}", lib().dir.display())),
        "compiling msbsdf.h as C89",
    );
    let (ok, text) = run_program(&exe);
    assert!(
        ok,
        "the C89 program's defaults are wrong (exit status):\n{text}"
    );
}
