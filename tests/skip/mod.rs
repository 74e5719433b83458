//! The one way a test may decline to run: [`missing`] records why.
//!
//! Under `CI=true` a missing tool is a failure, never a pass: [`missing`]
//! panics with the reason. Elsewhere (a developer's machine without Embree,
//! say) it prints `SKIPPED <test>: <why>` and appends one line to
//! `target/tmp/skipped-tests.txt`, which `scripts/test.sh` counts in its
//! summary. `tests/honest_tests.rs` fails when a `#[test]` function under
//! `tests/` returns early without calling [`missing`] in that statement.
#![allow(dead_code)]

use std::io::Write;
use std::path::PathBuf;

/// True when the environment says this is a CI run (`CI=true` or `CI=1`).
pub fn ci() -> bool {
    matches!(
        std::env::var("CI")
            .as_deref()
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Ok("true") | Ok("1")
    )
}

/// The ledger of skipped tests of this `cargo test` run.
pub fn ledger() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("skipped-tests.txt")
}

/// Records that `test` cannot run here because of `why` (a missing tool or
/// runtime, with the command that installs it). Panics under `CI=true`.
pub fn missing(test: &str, why: &str) {
    assert!(
        !ci(),
        "{test}: cannot run ({why}); under CI=true a missing tool is a failure, \
         not a skip (scripts/deps.sh installs what the tests need)"
    );
    eprintln!("SKIPPED {test}: {why}");
    let line = format!("{test}: {}\n", why.replace('\n', " "));
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(ledger())
        .and_then(|mut f| f.write_all(line.as_bytes()));
    if let Err(e) = written {
        eprintln!("(could not record the skip in {}: {e})", ledger().display());
    }
}
