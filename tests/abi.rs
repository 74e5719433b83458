//! ABI snapshot (issue 7): `abi/layout.txt` (size, alignment and field
//! offsets of every public struct, from `size_of` / `align_of` /
//! `offset_of!` on the Rust side), `abi/constants.txt` (every integer
//! `#define MSBSDF_*` of the generated header `include/msbsdf.h`, which
//! tests/header.rs keeps equal to a fresh cbindgen run) and
//! `abi/functions.txt` (every exported function's prototype, parameter names
//! dropped), plus `abi/symbols.txt` (the exported names, which
//! tests/c_conformance.rs compares with the shared object).
//!
//! Each versioned file records the crate version it was taken at. This test
//! regenerates the snapshot and compares it with the committed one:
//! - no difference: pass;
//! - only additions (a new constant, struct, function, or fields appended to
//!   a struct that starts with `struct_size`, growing its size): the minor
//!   version (or the major) must be above the snapshot's;
//! - anything changed or removed: the major version must be above the
//!   snapshot's (the SONAME `libmsbsdf.so.<major>` changes with it).
//!
//! Refresh after a deliberate, correctly versioned change with
//! `MSBSDF_UPDATE_ABI=1 cargo test --test abi` (refused when the version
//! bump does not match the change; `MSBSDF_UPDATE_ABI=force` overrides,
//! e.g. to re-baseline).

mod clib;

use std::collections::BTreeMap;
use std::path::PathBuf;

type Entries = BTreeMap<String, String>;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Version(u32, u32, u32);

impl Version {
    fn parse(s: &str) -> Option<Version> {
        let mut it = s.trim().split('.').map(|x| x.parse::<u32>().ok());
        let v = Version(it.next()??, it.next()??, it.next()??);
        it.next().is_none().then_some(v)
    }
    fn current() -> Version {
        Version::parse(env!("CARGO_PKG_VERSION")).expect("numeric crate version")
    }
}

impl std::fmt::Display for Version {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}.{}", self.0, self.1, self.2)
    }
}

/// Public struct names with their layout, in header order.
const STRUCTS: [&str; 7] = [
    "msbsdf_rng",
    "msbsdf_rgb",
    "msbsdf_material_desc",
    "msbsdf_vec3",
    "msbsdf_sample_result",
    "msbsdf_context",
    "msbsdf_sample_record",
];

fn layout_entries() -> Entries {
    clib::rust_layout()
        .into_iter()
        .map(|item| match item {
            clib::LayoutItem::Size(t, n) => (format!("{t}.size"), n.to_string()),
            clib::LayoutItem::Align(t, n) => (format!("{t}.align"), n.to_string()),
            clib::LayoutItem::Offset(t, f, n) => (format!("{t}.{f}.offset"), n.to_string()),
        })
        .collect()
}

fn header() -> String {
    std::fs::read_to_string(repo().join("include/msbsdf.h")).expect("include/msbsdf.h")
}

/// Every `#define MSBSDF_* <integer>` except the include guard and the
/// version macros (which change with every release by design).
fn constant_entries(header: &str) -> Entries {
    let mut e = Entries::new();
    for line in header.lines() {
        let Some(rest) = line.trim().strip_prefix("#define ") else {
            continue;
        };
        let mut parts = rest.splitn(2, char::is_whitespace);
        let name = parts.next().unwrap_or_default();
        let value = parts.next().unwrap_or_default().trim();
        if !name.starts_with("MSBSDF_") || name == "MSBSDF_H" || name.starts_with("MSBSDF_VERSION")
        {
            continue;
        }
        let digits = value.trim_end_matches(['u', 'U', 'l', 'L']);
        let parsed = if let Some(hex) = digits.strip_prefix("0x") {
            u64::from_str_radix(hex, 16).ok()
        } else {
            digits.parse::<u64>().ok()
        };
        let v = parsed.unwrap_or_else(|| panic!("#define {name} {value}: not an integer literal"));
        e.insert(name.to_string(), v.to_string());
    }
    assert!(
        e.len() > 20,
        "too few constants parsed from the header: {e:?}"
    );
    e
}

/// Exported function name -> prototype with the parameter names dropped.
fn function_entries(header: &str) -> Entries {
    let mut e = Entries::new();
    for line in header.lines().map(str::trim) {
        if line.starts_with("//") || line.starts_with('#') || !line.ends_with(");") {
            continue;
        }
        let Some(open) = line.find('(') else { continue };
        let head = &line[..open];
        let name = head
            .rsplit(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .next()
            .unwrap_or_default();
        if !name.starts_with("msbsdf_") {
            continue;
        }
        let ret = head[..head.len() - name.len()].trim();
        let params: Vec<String> = line[open + 1..line.len() - 2]
            .split(',')
            .map(|p| {
                let p = p.trim();
                if p == "void" {
                    return p.to_string();
                }
                let cut = p.trim_end_matches(|c: char| c.is_ascii_alphanumeric() || c == '_');
                cut.trim().to_string()
            })
            .collect();
        e.insert(name.to_string(), format!("{ret} ({})", params.join(", ")));
    }
    e
}

/// Names of the structs the header defines with a body.
fn header_structs(header: &str) -> Vec<String> {
    let mut v: Vec<String> = header
        .lines()
        .filter_map(|l| l.trim().strip_prefix("typedef struct "))
        .filter(|l| l.trim_end().ends_with('{'))
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect();
    v.sort();
    v
}

#[derive(Debug, PartialEq, Eq, PartialOrd, Ord, Clone, Copy)]
enum Bump {
    None,
    Minor,
    Major,
}

/// Classifies the differences between a snapshot and the current entries;
/// returns the bump they need and a human-readable list.
fn classify(file: &str, old: &Entries, new: &Entries) -> (Bump, Vec<String>) {
    let mut bump = Bump::None;
    let mut notes = Vec::new();
    // Structs that start with `struct_size` may grow at the end.
    let extensible = |key: &str| -> bool {
        key.strip_suffix(".size").is_some_and(|s| {
            old.get(&format!("{s}.struct_size.offset"))
                .map(String::as_str)
                == Some("0")
        })
    };
    for (k, v) in old {
        match new.get(k) {
            None => {
                bump = bump.max(Bump::Major);
                notes.push(format!("{file}: removed `{k} {v}` (major)"));
            }
            Some(n) if n != v => {
                let grew = file == "layout.txt"
                    && extensible(k)
                    && matches!((v.parse::<u64>(), n.parse::<u64>()), (Ok(a), Ok(b)) if b > a);
                if grew {
                    bump = bump.max(Bump::Minor);
                    notes.push(format!(
                        "{file}: `{k}` grew {v} -> {n} (appended fields: minor)"
                    ));
                } else {
                    bump = bump.max(Bump::Major);
                    notes.push(format!("{file}: changed `{k}` {v} -> {n} (major)"));
                }
            }
            Some(_) => {}
        }
    }
    for (k, v) in new {
        if !old.contains_key(k) {
            bump = bump.max(Bump::Minor);
            notes.push(format!("{file}: added `{k} {v}` (minor)"));
        }
    }
    (bump, notes)
}

/// Whether going from the snapshot's version to `current` allows `bump`.
fn allowed(bump: Bump, snapshot: Version, current: Version) -> bool {
    match bump {
        Bump::None => true,
        Bump::Minor => (current.0, current.1) > (snapshot.0, snapshot.1),
        Bump::Major => current.0 > snapshot.0,
    }
}

const FILES: [&str; 3] = ["layout.txt", "constants.txt", "functions.txt"];

fn describe(file: &str) -> &'static str {
    match file {
        "layout.txt" => "size, alignment and field offsets (bytes) of every public struct",
        "constants.txt" => "value of every integer #define MSBSDF_* of include/msbsdf.h",
        _ => "prototype of every exported function (parameter names dropped)",
    }
}

fn render(file: &str, version: Version, entries: &Entries) -> String {
    let mut s = format!(
        "# msbsdf ABI snapshot: {}.\n# Regenerate with MSBSDF_UPDATE_ABI=1 cargo test --test abi (see tests/abi.rs).\nversion {version}\n",
        describe(file)
    );
    for (k, v) in entries {
        s.push_str(&format!("{k} {v}\n"));
    }
    s
}

fn parse(text: &str) -> (Option<Version>, Entries) {
    let mut version = None;
    let mut e = Entries::new();
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if let Some(v) = line.strip_prefix("version ") {
            version = Version::parse(v);
            continue;
        }
        // Keys never contain spaces; values (prototypes) may.
        let (k, v) = line.split_once(' ').unwrap_or((line, ""));
        e.insert(k.to_string(), v.to_string());
    }
    (version, e)
}

fn current_entries() -> BTreeMap<&'static str, Entries> {
    let h = header();
    let mut m = BTreeMap::new();
    m.insert("layout.txt", layout_entries());
    m.insert("constants.txt", constant_entries(&h));
    m.insert("functions.txt", function_entries(&h));
    m
}

#[test]
fn abi_snapshot_matches_or_version_bumped() {
    let current = Version::current();
    let entries = current_entries();
    let mut notes = Vec::new();
    let mut failures = Vec::new();
    let mut pending_refresh = false;
    for file in FILES {
        let path = repo().join("abi").join(file);
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let (snap_version, old) = parse(&text);
        let new = &entries[file];
        let (bump, mut n) = classify(file, &old, new);
        let Some(snap_version) = snap_version else {
            failures.push(format!("abi/{file} is missing or has no `version` line"));
            continue;
        };
        if snap_version > current {
            failures.push(format!(
                "abi/{file} was taken at {snap_version}, newer than the crate ({current})"
            ));
        }
        if !allowed(bump, snap_version, current) {
            failures.push(format!(
                "abi/{file} (taken at {snap_version}) needs a {bump:?} version bump, but the crate is {current}"
            ));
        }
        pending_refresh |= bump != Bump::None || text != render(file, snap_version, new);
        notes.append(&mut n);
    }
    let update = std::env::var("MSBSDF_UPDATE_ABI").ok();
    if let Some(mode) = update.as_deref() {
        assert!(
            failures.is_empty() || mode == "force",
            "refusing to refresh abi/ (MSBSDF_UPDATE_ABI=force overrides):\n{}\n{}",
            failures.join("\n"),
            notes.join("\n")
        );
        for file in FILES {
            std::fs::write(
                repo().join("abi").join(file),
                render(file, current, &entries[file]),
            )
            .expect("write snapshot");
        }
        let mut names: Vec<&String> = entries["functions.txt"].keys().collect();
        names.sort();
        let symbols: String = names.iter().map(|n| format!("{n}\n")).collect();
        std::fs::write(repo().join("abi/symbols.txt"), symbols).expect("write symbols");
        println!("abi/ refreshed at {current}:\n{}", notes.join("\n"));
    }
    assert!(
        update.is_some() || failures.is_empty(),
        "ABI changes without the version bump they need:\n{}\n\nDifferences:\n{}\n\n\
         Additions need a minor bump, changes and removals a major bump (Cargo.toml), then \
         `MSBSDF_UPDATE_ABI=1 cargo test --test abi`.",
        failures.join("\n"),
        notes.join("\n")
    );
    if pending_refresh {
        println!(
            "ABI differs from abi/ but the version bump covers it; refresh with \
             MSBSDF_UPDATE_ABI=1 cargo test --test abi:\n{}",
            notes.join("\n")
        );
    }
}

/// The snapshot covers every struct the header defines, and the exported
/// names in `abi/symbols.txt` are exactly the functions of the snapshot.
#[test]
fn snapshot_is_complete() {
    let h = header();
    let mut listed: Vec<String> = STRUCTS.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(
        header_structs(&h),
        listed,
        "a struct was added to or removed from the header: list it in STRUCTS and layout_entries()"
    );
    let symbols = std::fs::read_to_string(repo().join("abi/symbols.txt")).expect("symbols.txt");
    let symbols: Vec<&str> = symbols.lines().filter(|l| !l.is_empty()).collect();
    let functions = function_entries(&h);
    let names: Vec<&str> = functions.keys().map(String::as_str).collect();
    assert_eq!(
        symbols, names,
        "abi/symbols.txt differs from the header's functions"
    );
    // The parsers see what they should.
    assert_eq!(
        functions.get("msbsdf_eval").map(String::as_str),
        Some(
            "msbsdf_status (const struct msbsdf_material *, struct msbsdf_vec3, struct msbsdf_vec3, \
             struct msbsdf_rng *, struct msbsdf_rgb *)"
        )
    );
    assert_eq!(
        functions.get("msbsdf_version").map(String::as_str),
        Some("uint32_t (void)")
    );
    let constants = constant_entries(&h);
    assert_eq!(
        constants
            .get("MSBSDF_STATUS_UNKNOWN_CONSTANT")
            .map(String::as_str),
        Some("10")
    );
    assert_eq!(
        constants.get("MSBSDF_MAX_BOUNCES").map(String::as_str),
        Some("256")
    );
    assert!(!constants.contains_key("MSBSDF_VERSION_MAJOR"));
}

/// The version rule itself, on synthetic snapshots.
#[test]
fn version_rule_classifies_changes() {
    let e = |pairs: &[(&str, &str)]| -> Entries {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let base = e(&[
        ("d.size", "8"),
        ("d.align", "4"),
        ("d.struct_size.offset", "0"),
        ("d.x.offset", "4"),
        ("v.size", "12"),
        ("v.x.offset", "0"),
    ]);
    assert_eq!(classify("layout.txt", &base, &base).0, Bump::None);
    // Appending a field to a struct_size-versioned struct: minor.
    let mut grown = base.clone();
    grown.insert("d.size".into(), "12".into());
    grown.insert("d.y.offset".into(), "8".into());
    assert_eq!(classify("layout.txt", &base, &grown).0, Bump::Minor);
    // Growing a plain struct, moving or removing a field: major.
    let mut plain = base.clone();
    plain.insert("v.size".into(), "16".into());
    assert_eq!(classify("layout.txt", &base, &plain).0, Bump::Major);
    let mut moved = base.clone();
    moved.insert("d.x.offset".into(), "8".into());
    assert_eq!(classify("layout.txt", &base, &moved).0, Bump::Major);
    let mut shrunk = base.clone();
    shrunk.insert("d.size".into(), "4".into());
    assert_eq!(classify("layout.txt", &base, &shrunk).0, Bump::Major);
    let mut removed = base.clone();
    removed.remove("v.x.offset");
    assert_eq!(classify("layout.txt", &base, &removed).0, Bump::Major);
    // A new constant: minor; a changed value: major.
    let c = e(&[("MSBSDF_A", "1")]);
    assert_eq!(
        classify(
            "constants.txt",
            &c,
            &e(&[("MSBSDF_A", "1"), ("MSBSDF_B", "2")])
        )
        .0,
        Bump::Minor
    );
    assert_eq!(
        classify("constants.txt", &c, &e(&[("MSBSDF_A", "2")])).0,
        Bump::Major
    );
    // Which versions allow which bump.
    let v = |s: &str| Version::parse(s).expect("version");
    assert!(allowed(Bump::None, v("0.1.0"), v("0.1.0")));
    assert!(!allowed(Bump::Minor, v("0.1.0"), v("0.1.1")));
    assert!(allowed(Bump::Minor, v("0.1.0"), v("0.2.0")));
    assert!(allowed(Bump::Minor, v("0.1.3"), v("1.0.0")));
    assert!(!allowed(Bump::Major, v("0.1.0"), v("0.2.0")));
    assert!(allowed(Bump::Major, v("0.1.0"), v("1.0.0")));
    // Round trip of the file format.
    let text = render(
        "functions.txt",
        v("0.1.0"),
        &e(&[("msbsdf_f", "int (float *, void)")]),
    );
    assert_eq!(
        parse(&text),
        (Some(v("0.1.0")), e(&[("msbsdf_f", "int (float *, void)")]))
    );
}
