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
         #define MSBSDF_VERSION ((MSBSDF_VERSION_MAJOR << 16) | (MSBSDF_VERSION_MINOR << 8) | MSBSDF_VERSION_PATCH)\n\n\
         /** Initialisers that write exactly the struct this program compiled (they\n    \
         pass its sizeof, as Embree's rtcInit*Arguments): use them, not\n    \
         msbsdf_material_desc_default(), so that a program built against this\n    \
         header keeps working with later libraries. Since 0.3.0. */\n\
         #define msbsdf_material_desc_init(desc) msbsdf_material_desc_init_sized((desc), sizeof(*(desc)))\n\
         #define msbsdf_context_init(ctx) msbsdf_context_init_sized((ctx), sizeof(*(ctx)))\n\
         #define msbsdf_sample_record_init(rec) msbsdf_sample_record_init_sized((rec), sizeof(*(rec)))\n"
    ));
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(crate_dir.join("src/capi.rs"))
        .generate()
        .expect("cbindgen could not generate the header from src/capi.rs");
    let mut text = Vec::new();
    bindings.write(&mut text);
    // C89 has no `//` comments: cbindgen's C++ guards carry some.
    let text = String::from_utf8(text)
        .expect("cbindgen output is UTF-8")
        .replace("// __cplusplus", "/* __cplusplus */")
        .replace("}  // extern \"C\"", "}  /* extern \"C\" */");
    std::fs::write(out_dir.join("msbsdf.h"), &text).expect("write $OUT_DIR/msbsdf.h");
    if env::var_os("MSBSDF_UPDATE_HEADER").is_some() {
        std::fs::write(crate_dir.join("include/msbsdf.h"), &text).expect("write include/msbsdf.h");
    }

    let soname_major = major;
    println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libmsbsdf.so.{soname_major}");
    println!("cargo:rerun-if-changed=src/capi.rs");
    println!("cargo:rerun-if-changed=cbindgen.toml");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=MSBSDF_UPDATE_HEADER");
}
