//! The committed `include/msbsdf.h` is exactly what cbindgen generates from
//! this build's `src/capi.rs` (`msbsdf::GENERATED_HEADER`, written by
//! `build.rs`), so C users never compile against a stale header.

#[test]
fn committed_header_equals_fresh_cbindgen_output() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/include/msbsdf.h");
    let committed = std::fs::read_to_string(path).expect("read include/msbsdf.h");
    let fresh = msbsdf::GENERATED_HEADER;
    if committed != fresh {
        let first_diff = committed
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| committed.lines().count().min(fresh.lines().count()));
        let line = |s: &str| {
            s.lines()
                .nth(first_diff)
                .unwrap_or("<end of file>")
                .to_string()
        };
        panic!(
            "include/msbsdf.h is stale: it differs from the header cbindgen generates from \
             src/capi.rs, first at line {}:\n  committed: {}\n  generated: {}\n\
             Regenerate it with `MSBSDF_UPDATE_HEADER=1 cargo build` and commit \
             include/msbsdf.h.",
            first_diff + 1,
            line(&committed),
            line(fresh)
        );
    }
}

#[test]
fn header_declares_every_exported_function() {
    // abi/symbols.txt lists the exported symbols (checked against the shared
    // object in tests/c_conformance.rs); each must be declared in the header.
    let symbols = include_str!("../abi/symbols.txt");
    for name in symbols.lines().filter(|l| !l.is_empty()) {
        let declared = msbsdf::GENERATED_HEADER
            .lines()
            .any(|l| l.contains(&format!(" {name}(")) || l.contains(&format!("*{name}(")));
        assert!(
            declared,
            "{name} is exported but not declared in the header"
        );
    }
}
