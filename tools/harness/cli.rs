//! Option checking for the table generators, whose default (no mode
//! option) regenerates a committed table for tens of minutes: a mistyped
//! option must stop them, not fall through to that default.

/// Prints `usage` and exits 0 on `-h` / `--help`; exits 2 with a message
/// naming the option when an argument starting with `--` is not in
/// `known`. Values (arguments not starting with `--`) are not checked.
pub fn check_options(args: &[String], known: &[&str], usage: &str) {
    if args.iter().skip(1).any(|a| a == "-h" || a == "--help") {
        println!("{usage}");
        std::process::exit(0);
    }
    if let Some(bad) = args
        .iter()
        .skip(1)
        .find(|a| a.starts_with("--") && !known.contains(&a.as_str()))
    {
        eprintln!("unknown option {bad}\n\n{usage}");
        std::process::exit(2);
    }
}
