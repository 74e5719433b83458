//! Replays the committed fuzz corpus (`fuzz/corpus/<target>/`: inputs the
//! libFuzzer runs of `fuzz/run.sh` found interesting, crashes after their
//! fix, and hand-written edge cases) through the harnesses of `fuzz/`,
//! compiled WITHOUT libFuzzer: `fuzz/replay_main.c` feeds each file to
//! `LLVMFuzzerTestOneInput` once. Built with gcc's ASan + UBSan
//! (`-fno-sanitize-recover=all`) against the static library; without the
//! runtimes the replay fails under `CI=true` and runs plainly elsewhere,
//! recorded as a skip of the sanitizers (`tests/skip/mod.rs`). Every
//! contract violation in the harness aborts, so the replay must exit 0.

mod clib;
mod skip;

use clib::{
    WARNINGS, compiler_supports, leak_sanitizer_runs, repo, run_ok, run_program, static_lib,
    work_dir,
};
use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

const SAN: [&str; 3] = [
    "-fsanitize=address,undefined",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
];

fn corpus(target: &str) -> Vec<PathBuf> {
    let dir = repo().join("fuzz/corpus").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

fn replay(target: &str, min_inputs: usize) {
    let sanitize = match compiler_supports("cc", &SAN).and_then(|()| leak_sanitizer_runs("cc")) {
        Ok(()) => true,
        Err(why) => {
            skip::missing(&format!("{target} replay under ASan + UBSan"), &why);
            false
        }
    };
    let exe = work_dir("fuzz_corpus").join(format!("{target}_replay"));
    let mut cc = Command::new("cc");
    cc.args(["-std=c11", "-O1", "-g"])
        .args(WARNINGS)
        .arg("-I")
        .arg(repo().join("include"));
    if sanitize {
        cc.args(SAN);
    }
    cc.arg(repo().join("fuzz").join(format!("{target}.c")))
        .arg(repo().join("fuzz/replay_main.c"))
        .arg(static_lib())
        .args(["-lpthread", "-ldl", "-lm"])
        .arg("-o")
        .arg(&exe);
    run_ok(&mut cc, &format!("compiling the {target} replay"));
    let files = corpus(target);
    assert!(
        files.len() >= min_inputs,
        "fuzz/corpus/{target} has {} files, expected at least {min_inputs}",
        files.len()
    );
    let mut cmd = Command::new(&exe);
    cmd.args(&files)
        .env("ASAN_OPTIONS", "detect_leaks=1:abort_on_error=1")
        .env("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1");
    let (ok, text) = run_program(&mut cmd, Duration::from_secs(300));
    println!("{target}: sanitizers {sanitize}; {text}");
    assert!(
        ok && text.contains(&format!("replayed {} inputs", files.len())),
        "replaying fuzz/corpus/{target} failed:\n{text}"
    );
}

#[test]
fn desc_fuzz_corpus_replays_cleanly() {
    replay("desc_fuzz", 20);
}

#[test]
fn dirs_fuzz_corpus_replays_cleanly() {
    replay("dirs_fuzz", 20);
}
