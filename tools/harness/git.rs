//! The commit a table generator runs at, for the headers of the tables it
//! writes.

/// `git rev-parse HEAD` of the crate's repository, with `-dirty` when the
/// worktree has changes, or "unknown" when git is not available.
pub fn commit() -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match git(&["rev-parse", "HEAD"]) {
        Some(h) if git(&["status", "--porcelain"]).is_some_and(|s| !s.is_empty()) => {
            format!("{h}-dirty")
        }
        Some(h) => h,
        None => "unknown".into(),
    }
}
