//! Generates `include/msbsdf.h` from `src/capi.rs` with cbindgen, with the
//! version macros taken from Cargo.toml, and sets the shared object's SONAME.
//!
//! The header is always written to `$OUT_DIR/msbsdf.h` (a test compares it
//! with the committed copy); `MSBSDF_UPDATE_HEADER=1 cargo build` also
//! refreshes `include/msbsdf.h`.

use std::env;
use std::path::PathBuf;

fn main() {
    let crate_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let major = env::var("CARGO_PKG_VERSION_MAJOR").expect("version");
    let minor = env::var("CARGO_PKG_VERSION_MINOR").expect("version");
    let patch = env::var("CARGO_PKG_VERSION_PATCH").expect("version");

    let mut config =
        cbindgen::Config::from_file(crate_dir.join("cbindgen.toml")).expect("read cbindgen.toml");
    config.after_includes = Some(format!(
        "\n/** Library version this header describes; msbsdf_version() returns\n    \
         (MSBSDF_VERSION_MAJOR << 16) | (MSBSDF_VERSION_MINOR << 8) | MSBSDF_VERSION_PATCH. */\n\
         #define MSBSDF_VERSION_MAJOR {major}\n\
         #define MSBSDF_VERSION_MINOR {minor}\n\
         #define MSBSDF_VERSION_PATCH {patch}\n\
         #define MSBSDF_VERSION ((MSBSDF_VERSION_MAJOR << 16) | (MSBSDF_VERSION_MINOR << 8) | MSBSDF_VERSION_PATCH)\n"
    ));
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(crate_dir.join("src/capi.rs"))
        .generate()
        .expect("cbindgen could not generate the header from src/capi.rs");
    bindings.write_to_file(out_dir.join("msbsdf.h"));
    if env::var_os("MSBSDF_UPDATE_HEADER").is_some() {
        bindings.write_to_file(crate_dir.join("include/msbsdf.h"));
    }

    let soname_major = major;
    println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libmsbsdf.so.{soname_major}");
    println!("cargo:rerun-if-changed=src/capi.rs");
    println!("cargo:rerun-if-changed=cbindgen.toml");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=MSBSDF_UPDATE_HEADER");
}
