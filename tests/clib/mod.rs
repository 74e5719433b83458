//! Helpers for the integration tests that build and run C / C++ programs
//! against the library cargo test built (tests/install.rs,
//! tests/c_hardening.rs, tests/fuzz_corpus.rs, tests/c_conformance.rs).
//!
//! `cargo test` builds the crate's `cdylib` and `staticlib` next to the test
//! executables (`target/<profile>/deps/`); when neither that directory nor
//! `target/<profile>/` has them, `cargo build` runs for the same profile.
//! Programs linked against the shared object find it through its SONAME
//! (`libmsbsdf.so.0`): [`shared_lib_dir`] copies it into a private directory
//! next to that link, for an RPATH.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// Warnings every C and C++ translation unit must compile cleanly with.
pub const WARNINGS: [&str; 4] = ["-Wall", "-Wextra", "-pedantic", "-Werror"];

/// Repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `target/<profile>/deps` and `target/<profile>`, from this executable.
pub fn artifact_dirs() -> (PathBuf, PathBuf) {
    let exe = std::env::current_exe().expect("current_exe");
    let deps = exe
        .parent()
        .expect("test executable has a directory")
        .to_path_buf();
    let profile = deps.parent().expect("deps has a parent").to_path_buf();
    (deps, profile)
}

/// The cargo profile name of this test executable (`debug`, `release`, ...).
pub fn profile_name() -> String {
    let (_, profile) = artifact_dirs();
    profile
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("profile")
        .to_string()
}

/// `$CARGO_TARGET_TMPDIR/<name>-<profile>`, created (the tmp dir is shared
/// by all profiles and test files).
pub fn work_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}-{}", profile_name()));
    std::fs::create_dir_all(&dir).expect("create work dir");
    dir
}

fn find_artifact(name: &str) -> Option<PathBuf> {
    let (deps, profile) = artifact_dirs();
    [deps.join(name), profile.join(name)]
        .into_iter()
        .find(|p| p.is_file())
}

fn cargo_build() {
    let (_, profile) = artifact_dirs();
    let target_dir = profile.parent().expect("target dir");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.arg("build")
        .arg("--lib")
        .arg("--manifest-path")
        .arg(repo().join("Cargo.toml"))
        .arg("--target-dir")
        .arg(target_dir);
    match profile.file_name().and_then(|n| n.to_str()) {
        Some("debug") => {}
        Some("release") => {
            cmd.arg("--release");
        }
        Some(other) => {
            cmd.args(["--profile", other]);
        }
        None => panic!("cannot tell the cargo profile from {}", profile.display()),
    }
    run_ok(&mut cmd, "cargo build");
}

/// The directory holding `libmsbsdf.so` and `libmsbsdf.a` as cargo built them.
pub fn built_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let so = find_artifact("libmsbsdf.so");
        let a = find_artifact("libmsbsdf.a");
        match (so, a) {
            (Some(so), Some(a)) if so.parent() == a.parent() => {
                so.parent().expect("parent").to_path_buf()
            }
            _ => {
                cargo_build();
                let (_, profile) = artifact_dirs();
                profile
            }
        }
    })
}

/// The static library cargo built.
pub fn static_lib() -> PathBuf {
    built_dir().join("libmsbsdf.a")
}

/// A private copy of the shared object in `work_dir(name)/lib`, next to the
/// `libmsbsdf.so.0` SONAME link; link with `-L` and an RPATH to it.
pub fn shared_lib_dir(name: &str) -> PathBuf {
    let dir = work_dir(name).join("lib");
    std::fs::create_dir_all(&dir).expect("create lib dir");
    // Copy (not link) so a concurrent cargo build cannot change the file
    // under a running test; rename makes the copy atomic. The temporary
    // name is unique per call: the tests of one binary run on threads of
    // one process, and two copies through one name raced (one thread's
    // rename took the file the other was about to rename).
    static COPIES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = COPIES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!("libmsbsdf.so.tmp{}-{n}", std::process::id()));
    std::fs::copy(built_dir().join("libmsbsdf.so"), &tmp).expect("copy libmsbsdf.so");
    std::fs::rename(&tmp, dir.join("libmsbsdf.so")).expect("rename libmsbsdf.so");
    let soname_link = dir.join("libmsbsdf.so.0");
    let _ = std::fs::remove_file(&soname_link);
    std::os::unix::fs::symlink("libmsbsdf.so", &soname_link).expect("symlink libmsbsdf.so.0");
    dir
}

/// Runs a command, panicking with its output when it fails; returns
/// stdout + stderr.
pub fn run_ok(cmd: &mut Command, what: &str) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot run {cmd:?}: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{what} failed ({cmd:?}):\n{text}");
    text
}

/// Runs `cmd` with a time limit; returns (exit success, stdout + stderr +
/// the exit status).
pub fn run_program(cmd: &mut Command, timeout: Duration) -> (bool, String) {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let mut out = child.stdout.take().expect("stdout");
    let mut err = child.stderr.take().expect("stderr");
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let out_reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{cmd:?} did not finish within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let text = out_reader.join().expect("stdout reader") + &err_reader.join().expect("reader");
    (status.success(), format!("{text}[{status}]\n"))
}

/// `Ok` when `compiler flags` builds and runs a trivial C program (used to
/// tell whether a sanitizer runtime is installed); otherwise why not, with
/// the compiler's or the program's own words. The probe runs with
/// `ASAN_OPTIONS=detect_leaks=0`: whether LeakSanitizer can run here is a
/// separate question ([`leak_sanitizer_runs`]), and a missing LeakSanitizer
/// must not pass for a missing AddressSanitizer. Probed once per process
/// and flag set (tests run in parallel threads).
pub fn compiler_supports(compiler: &str, flags: &[&str]) -> Result<(), String> {
    probe_once(compiler, flags, "detect_leaks=0")
}

/// `Ok` when LeakSanitizer works here (it needs ptrace, which some
/// containers forbid): an ASan build of a trivial program runs with
/// `detect_leaks=1`.
pub fn leak_sanitizer_runs(compiler: &str) -> Result<(), String> {
    probe_once(compiler, &["-fsanitize=address"], "detect_leaks=1")
}

/// One probe per process and (compiler, flags, options): the lock is held
/// while probing, so parallel tests never write and run the same probe
/// binary at once (which fails with "Text file busy").
fn probe_once(compiler: &str, flags: &[&str], asan_options: &str) -> Result<(), String> {
    static CACHE: Mutex<BTreeMap<String, Result<(), String>>> = Mutex::new(BTreeMap::new());
    let key = format!("{compiler} {flags:?} {asan_options}");
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    cache
        .entry(key)
        .or_insert_with(|| probe_compiler(compiler, flags, asan_options))
        .clone()
}

fn probe_compiler(compiler: &str, flags: &[&str], asan_options: &str) -> Result<(), String> {
    let dir = work_dir(&format!("probe{}", std::process::id()));
    let tag: String = flags
        .iter()
        .chain(std::iter::once(&asan_options))
        .map(|f| f.replace(|c: char| !c.is_ascii_alphanumeric(), "_"))
        .collect();
    let src = dir.join(format!("probe_{compiler}_{tag}.c"));
    let exe = dir.join(format!("probe_{compiler}_{tag}"));
    std::fs::write(&src, "int main(void) { return 0; }\n")
        .map_err(|e| format!("cannot write {}: {e}", src.display()))?;
    let built = Command::new(compiler)
        .args(flags)
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .output()
        .map_err(|e| format!("cannot run `{compiler}`: {e}"))?;
    if !built.status.success() {
        return Err(format!(
            "`{compiler} {}` does not build a trivial program: {}",
            flags.join(" "),
            String::from_utf8_lossy(&built.stderr).trim()
        ));
    }
    let ran = Command::new(&exe)
        .env("ASAN_OPTIONS", asan_options)
        .output()
        .map_err(|e| format!("cannot run the probe {}: {e}", exe.display()))?;
    if !ran.status.success() {
        return Err(format!(
            "a trivial program built with `{compiler} {}` fails under ASAN_OPTIONS={asan_options}: {}",
            flags.join(" "),
            String::from_utf8_lossy(&ran.stderr).trim()
        ));
    }
    Ok(())
}

/// One number of Rust's view of the public C structs.
pub enum LayoutItem {
    /// `size_of` the struct.
    Size(&'static str, usize),
    /// `align_of` the struct.
    Align(&'static str, usize),
    /// `offset_of` a field: struct, field, offset.
    Offset(&'static str, &'static str, usize),
}

/// Size, alignment and every field offset of each public C struct, as Rust
/// lays them out (the one list the layout and ABI tests share).
pub fn rust_layout() -> Vec<LayoutItem> {
    use msbsdf::capi::{
        msbsdf_context, msbsdf_material_desc, msbsdf_rgb, msbsdf_rng, msbsdf_sample_record,
        msbsdf_sample_result, msbsdf_vec3,
    };
    use std::mem::{align_of, offset_of, size_of};
    let mut v = Vec::new();
    macro_rules! layout {
        ($t:ident { $($f:ident),* }) => {
            v.push(LayoutItem::Size(stringify!($t), size_of::<$t>()));
            v.push(LayoutItem::Align(stringify!($t), align_of::<$t>()));
            $(v.push(LayoutItem::Offset(stringify!($t), stringify!($f), offset_of!($t, $f)));)*
        };
    }
    layout!(msbsdf_vec3 { x, y, z });
    layout!(msbsdf_rgb { r, g, b });
    layout!(msbsdf_rng { state, inc });
    layout!(msbsdf_material_desc {
        struct_size,
        model,
        estimator,
        ndf,
        facet,
        alpha_x,
        alpha_y,
        shape,
        eta,
        k,
        albedo,
        max_bounces,
        tolerance,
        inner,
        conductor_sides
    });
    layout!(msbsdf_context {
        struct_size,
        transport,
        lobes,
        rng
    });
    layout!(msbsdf_sample_record {
        struct_size,
        flags,
        wo,
        weight,
        pdf,
        eta
    });
    layout!(msbsdf_sample_result {
        wo,
        weight,
        pdf,
        flags
    });
    v
}
