#!/usr/bin/env bash
# Installs msbsdf like a C library:
#   bash scripts/install.sh PREFIX
# builds with `cargo build --release --lib` and installs
#   PREFIX/lib/libmsbsdf.so.X.Y.Z (SONAME libmsbsdf.so.X, debug info stripped) with the
#     libmsbsdf.so.X and libmsbsdf.so symlinks,
#   PREFIX/lib/libmsbsdf.a,
#   PREFIX/include/msbsdf/msbsdf.h and msbsdf.hpp (the committed headers),
#   PREFIX/lib/pkgconfig/msbsdf.pc (for `pkg-config --cflags --libs msbsdf`).
# Environment: MSBSDF_PREBUILT_DIR=DIR installs libmsbsdf.so/.a from DIR
# instead of building (tests/install.rs uses the libraries cargo test built);
# DESTDIR is honoured as usual for staged installs.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
prefix=${1:?usage: scripts/install.sh PREFIX}
case "$prefix" in
  /*) ;;
  *) prefix="$(pwd)/$prefix" ;;
esac
dest="${DESTDIR:-}$prefix"

# Version from Cargo.toml's [package] section.
version=$(awk -F'"' '/^\[package\]/{p=1; next} /^\[/{p=0} p && /^version *=/{print $2; exit}' \
  "$repo/Cargo.toml")
[[ "$version" =~ ^[0-9]+\.[0-9]+\.[0-9]+$ ]] || { echo "cannot read the version from Cargo.toml" >&2; exit 1; }
major=${version%%.*}

if [ -n "${MSBSDF_PREBUILT_DIR:-}" ]; then
  built="$MSBSDF_PREBUILT_DIR"
else
  (cd "$repo" && cargo build --release --lib)
  built="${CARGO_TARGET_DIR:-$repo/target}/release"
fi
for f in libmsbsdf.so libmsbsdf.a; do
  [ -f "$built/$f" ] || { echo "$built/$f is missing" >&2; exit 1; }
done
if command -v readelf >/dev/null; then
  soname=$(readelf -d "$built/libmsbsdf.so" | sed -n 's/.*(SONAME).*\[\(.*\)\].*/\1/p')
  [ "$soname" = "libmsbsdf.so.$major" ] ||
    { echo "libmsbsdf.so has SONAME '$soname', expected libmsbsdf.so.$major" >&2; exit 1; }
fi

install -d "$dest/lib/pkgconfig" "$dest/include/msbsdf"
install -m 755 "$built/libmsbsdf.so" "$dest/lib/libmsbsdf.so.$version"
# Release artefact without debug info and static symbols (5 MB instead of
# 8 MB; the dynamic symbols stay); the
# build keeps it (profile.release debug = 1) for profiling from the tree.
if command -v strip >/dev/null; then
  strip --strip-unneeded "$dest/lib/libmsbsdf.so.$version"
else
  echo "warning: strip not found: the installed libmsbsdf.so keeps its debug info" >&2
fi
ln -sfn "libmsbsdf.so.$version" "$dest/lib/libmsbsdf.so.$major"
ln -sfn "libmsbsdf.so.$major" "$dest/lib/libmsbsdf.so"
install -m 644 "$built/libmsbsdf.a" "$dest/lib/libmsbsdf.a"
install -m 644 "$repo/include/msbsdf.h" "$repo/include/msbsdf.hpp" "$dest/include/msbsdf/"

# Libs.private: what the Rust staticlib needs from the system, as printed by
# `cargo rustc --release --lib --crate-type staticlib -- --print native-static-libs`
# (x86_64 Linux, glibc).
cat > "$dest/lib/pkgconfig/msbsdf.pc" <<PC
prefix=$prefix
exec_prefix=\${prefix}
libdir=\${exec_prefix}/lib
includedir=\${prefix}/include

Name: msbsdf
Description: Multiple-scattering microfacet BSDFs behind a stable C ABI
Version: $version
Cflags: -I\${includedir}/msbsdf
Libs: -L\${libdir} -lmsbsdf
Libs.private: -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc
PC
echo "installed msbsdf $version into $dest"
