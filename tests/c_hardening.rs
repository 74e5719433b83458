//! Hardening of the C ABI (issue 7), on top of tests/c_conformance.rs:
//!
//! - the C conformance programs (`tests/c/{api,rng,storage,threads}.c`) and
//!   `c_examples/minimal.c` built with gcc's AddressSanitizer and
//!   UndefinedBehaviorSanitizer (`-fsanitize=address,undefined
//!   -fno-sanitize-recover=all`), linked against the (uninstrumented) shared
//!   object, run with `ASAN_OPTIONS=detect_leaks=1`; a probe checks that
//!   LeakSanitizer really runs here and sees allocations made inside the
//!   Rust library (a material never destroyed must be reported). The Rust
//!   side needs no suppressions: the runs report nothing. (`no_alloc.c`
//!   interposes malloc itself, which ASan forbids; it is not rerun.)
//! - `valgrind --tool=memcheck --error-exitcode=1` on `tests/c/api.c` (every
//!   entry point with valid and invalid arguments). Not on `storage.c`: its
//!   `memcmp` of caller storage before and after destroy reads the padding
//!   bytes of the Rust struct, which a typed Rust write leaves undefined;
//!   memcheck flags that comparison although the library does nothing wrong.
//!   Miri would be the Rust-side tool, but it needs a nightly toolchain,
//!   which cannot be installed here.
//! - `tests/c/stress.c`: 8 pthreads x `STRESS_CALLS` (10^6 as issue 7 asks; env
//!   `MSBSDF_STRESS_CALLS` overrides) mixed eval / sample /
//!   pdf calls on shared materials of every model create accepts; the bits
//!   equal the single-thread run per seed. Once natively and once under
//!   ThreadSanitizer with fewer calls. TSan instruments only the C side; the
//!   library is read-only after init by construction (no globals, no locks,
//!   no interior mutability), which the equality of the bits checks.
//!
//! When the compiler lacks a sanitizer runtime or valgrind is missing, the
//! step fails under `CI=true` and is recorded as skipped elsewhere
//! (`tests/skip/mod.rs`; scripts/deps.sh installs gcc's runtimes with
//! build-essential, and valgrind).

mod clib;
mod skip;

use clib::{
    WARNINGS, compiler_supports, leak_sanitizer_runs, repo, run_ok, run_program, shared_lib_dir,
    work_dir,
};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// Calls per thread of the native stress run. The issue asks for 10^6; one
/// call costs ~1.5-3.3 us on average here (the random walk dominates), so 8
/// x 10^6 calls single-threaded plus the same threaded take about 18 s on 2
/// cores (once AUTO is given a loose tolerance in stress.c): the full size
/// issue 7 asks for. `MSBSDF_STRESS_CALLS` overrides it for quick runs.
const STRESS_CALLS: u32 = 1_000_000;

fn stress_calls() -> u32 {
    std::env::var("MSBSDF_STRESS_CALLS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(STRESS_CALLS)
}
/// Calls per thread under ThreadSanitizer (5-15x slower).
const TSAN_CALLS: u32 = 20_000;
const RUN_TIMEOUT: Duration = Duration::from_secs(240);

const ASAN_UBSAN: [&str; 4] = [
    "-fsanitize=address,undefined",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
    "-g",
];

fn lib_dir() -> PathBuf {
    shared_lib_dir("c_hardening")
}

/// Compiles C `sources` with `flags`, linked against the shared object.
fn compile(name: &str, sources: &[PathBuf], flags: &[&str]) -> PathBuf {
    let lib = lib_dir();
    let exe = work_dir("c_hardening").join(name);
    let mut cmd = Command::new("cc");
    cmd.args(["-std=c99", "-O1"])
        .args(WARNINGS)
        .args(flags)
        .arg("-I")
        .arg(repo().join("include"))
        .arg("-I")
        .arg(repo().join("tests/c"))
        .args(sources)
        .arg("-o")
        .arg(&exe)
        .arg(format!("-L{}", lib.display()))
        .arg("-lmsbsdf")
        .arg(format!("-Wl,-rpath,{}", lib.display()))
        .arg("-Wl,--disable-new-dtags")
        .args(["-lm", "-pthread"]);
    run_ok(&mut cmd, &format!("compiling {name}"));
    exe
}

fn sanitizer_env(cmd: &mut Command) -> &mut Command {
    cmd.env(
        "ASAN_OPTIONS",
        "detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1",
    )
    .env("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1")
    .env("TSAN_OPTIONS", "halt_on_error=1:second_deadlock_stack=1")
}

fn run_passing(exe: &Path, args: &[&str], program: &str) -> String {
    let mut cmd = Command::new(exe);
    cmd.args(args);
    let (ok, text) = run_program(sanitizer_env(&mut cmd), RUN_TIMEOUT);
    println!("{text}");
    assert!(
        ok && text.contains(&format!("{program}: ALL ")) && !text.contains("FAIL "),
        "{} failed:\n{text}",
        exe.display()
    );
    for report in [
        "ERROR: AddressSanitizer",
        "runtime error:",
        "LeakSanitizer",
        "WARNING: ThreadSanitizer",
    ] {
        assert!(
            !text.contains(report),
            "{} reported `{report}`:\n{text}",
            exe.display()
        );
    }
    text
}

/// `Ok` when cc builds and runs ASan + UBSan programs with leak detection:
/// every test here runs with `detect_leaks=1`.
fn asan() -> Result<(), String> {
    compiler_supports("cc", &ASAN_UBSAN)
        .map_err(|e| format!("{e} (install gcc's libasan and libubsan: build-essential)"))?;
    leak_sanitizer_runs("cc").map_err(|e| format!("LeakSanitizer cannot run here: {e}"))
}

#[test]
fn conformance_programs_clean_under_asan_and_ubsan() {
    if let Err(why) = asan() {
        return skip::missing("conformance_programs_clean_under_asan_and_ubsan", &why);
    }
    for program in ["api", "rng", "storage", "threads", "growth", "integrator"] {
        let exe = compile(
            &format!("{program}_asan"),
            &[repo().join(format!("tests/c/{program}.c"))],
            &ASAN_UBSAN,
        );
        run_passing(&exe, &[], program);
    }
}

#[test]
fn minimal_example_clean_under_asan_and_ubsan() {
    if let Err(why) = asan() {
        return skip::missing("minimal_example_clean_under_asan_and_ubsan", &why);
    }
    let exe = compile(
        "minimal_asan",
        &[repo().join("c_examples/minimal.c")],
        &ASAN_UBSAN,
    );
    let mut cmd = Command::new(&exe);
    let (ok, text) = run_program(sanitizer_env(&mut cmd), RUN_TIMEOUT);
    assert!(
        ok && text.contains("theta_i"),
        "minimal under ASan:\n{text}"
    );
    assert!(
        !text.contains("Sanitizer") && !text.contains("runtime error:"),
        "{text}"
    );
}

/// LeakSanitizer is live in this environment (no ptrace restriction turns
/// it off) and sees allocations the Rust library makes with the system
/// allocator: a created material that is never destroyed is reported,
/// with msbsdf_material_create on the stack.
#[test]
fn leak_sanitizer_sees_library_allocations() {
    if let Err(why) = asan() {
        return skip::missing("leak_sanitizer_sees_library_allocations", &why);
    }
    let src = work_dir("c_hardening").join("leak_probe.c");
    std::fs::write(
        &src,
        "#include \"msbsdf.h\"\n#include <stdio.h>\nint main(void) {\n  \
         msbsdf_material_desc d = msbsdf_material_desc_default();\n  \
         msbsdf_material *m = NULL;\n  msbsdf_status s = msbsdf_material_create(&d, &m);\n  \
         m = NULL;\n  printf(\"created %u\\n\", (unsigned)s);\n  fflush(stdout);\n  return 0;\n}\n",
    )
    .expect("write probe");
    let exe = compile("leak_probe", &[src], &ASAN_UBSAN);
    let mut cmd = Command::new(&exe);
    let (ok, text) = run_program(sanitizer_env(&mut cmd), RUN_TIMEOUT);
    assert!(
        !ok && text.contains("created 0")
            && text.contains("LeakSanitizer: detected memory leaks")
            && text.contains("msbsdf_material_create"),
        "the deliberate leak was not reported:\n{text}"
    );
}

#[test]
fn api_program_clean_under_valgrind_memcheck() {
    if let Err(e) = Command::new("valgrind").arg("--version").output() {
        return skip::missing(
            "api_program_clean_under_valgrind_memcheck",
            &format!("valgrind cannot run ({e}): apt-get install valgrind"),
        );
    }
    let exe = compile("api_plain", &[repo().join("tests/c/api.c")], &["-g"]);
    let mut cmd = Command::new("valgrind");
    cmd.args([
        "--tool=memcheck",
        "--error-exitcode=1",
        "--leak-check=full",
        "--errors-for-leak-kinds=definite,indirect",
        "-q",
    ])
    .arg(&exe);
    let (ok, text) = run_program(&mut cmd, RUN_TIMEOUT);
    println!("{text}");
    assert!(
        ok && text.contains("api: ALL "),
        "valgrind memcheck:\n{text}"
    );
}

#[test]
fn stress_threads_reproduce_single_thread_bits() {
    let exe = compile("stress", &[repo().join("tests/c/stress.c")], &["-O2"]);
    let calls = stress_calls();
    let text = run_passing(&exe, &[&calls.to_string()], "stress");
    assert!(
        text.contains(&format!("8 threads x {calls} calls")),
        "{text}"
    );
}

#[test]
fn stress_clean_under_thread_sanitizer() {
    let tsan = ["-fsanitize=thread", "-g"];
    if let Err(why) = compiler_supports("cc", &tsan) {
        return skip::missing(
            "stress_clean_under_thread_sanitizer",
            &format!("{why} (install gcc's libtsan: build-essential)"),
        );
    }
    let exe = compile("stress_tsan", &[repo().join("tests/c/stress.c")], &tsan);
    let text = run_passing(&exe, &[&TSAN_CALLS.to_string()], "stress");
    assert!(!text.contains("ThreadSanitizer"), "{text}");
}
