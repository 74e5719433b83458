//! Each tool and table generator rejects the options it does not know
//! (`tools/harness/cli.rs`), so its `OPTIONS` list must name exactly the
//! options its source reads: an option missing from the list would make a
//! documented command stop with "unknown option" (a first hand-written
//! list for `gen_reference` missed 9 of its 24, `--budget` among them),
//! and a listed option nothing reads would be accepted and ignored.

use std::collections::BTreeSet;

/// The tools that call `check_options`.
const TOOLS: [&str; 6] = [
    "gen_tabulated",
    "gen_tabulated_aniso",
    "gen_compensation",
    "gen_reference",
    "speed_accuracy",
    "stability",
];

/// The string literals of `text` that are a whole option (`"--name"`).
fn option_literals(text: &str) -> BTreeSet<String> {
    text.split('"')
        .skip(1)
        .step_by(2)
        .filter(|s| {
            s.len() > 2
                && s.starts_with("--")
                && s[2..]
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
        })
        .map(str::to_string)
        .collect()
}

#[test]
fn option_lists_match_the_options_the_tools_read() {
    let mut failed = String::new();
    for tool in TOOLS {
        let path = format!("{}/tools/{tool}.rs", env!("CARGO_MANIFEST_DIR"));
        let src = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let start = src
            .find("const OPTIONS: &[&str] = &[")
            .unwrap_or_else(|| panic!("{tool}: no OPTIONS list"));
        let end = start
            + src[start..]
                .find("];")
                .unwrap_or_else(|| panic!("{tool}: OPTIONS not closed"));
        let listed = option_literals(&src[start..end]);
        let read = option_literals(&format!("{}{}", &src[..start], &src[end..]));
        assert!(
            src.contains("check_options(OPTIONS, USAGE)"),
            "{tool}: main does not check its options"
        );
        let missing: Vec<_> = read.difference(&listed).collect();
        let unread: Vec<_> = listed.difference(&read).collect();
        println!("{tool}: {} options", listed.len());
        if !missing.is_empty() || !unread.is_empty() {
            failed += &format!(
                "{tool}: read but not listed {missing:?}, listed but not read {unread:?}\n"
            );
        }
    }
    assert!(failed.is_empty(), "{failed}");
}
