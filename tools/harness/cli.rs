//! Option checking for the tools and table generators, whose default (no
//! mode option) rewrites committed files, for tens of minutes in the
//! generators: a mistyped option must stop them, not fall through to that
//! default. `tests/tool_options.rs` checks that each tool's `OPTIONS` list
//! holds exactly the options its source reads.

/// Prints `usage` and exits 0 on `-h` / `--help`; exits 2 with a message
/// naming the option when a command-line argument starting with `--` is
/// not in `known`. Values (arguments not starting with `--`) are not
/// checked.
pub fn check_options(known: &[&str], usage: &str) {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "-h" || a == "--help") {
        println!("{usage}");
        std::process::exit(0);
    }
    if let Some(bad) = args
        .iter()
        .find(|a| a.starts_with("--") && !known.contains(&a.as_str()))
    {
        eprintln!("unknown option {bad}\n\n{usage}");
        std::process::exit(2);
    }
}
