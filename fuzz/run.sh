#!/usr/bin/env bash
# Builds a libFuzzer harness of the C API against the release static library
# and fuzzes it: fuzz/run.sh TARGET SECONDS [extra libFuzzer flags...]
#   TARGET: desc_fuzz or dirs_fuzz (fuzz/TARGET.c).
# Needs clang with libFuzzer (Debian: clang libclang-rt-14-dev; scripts/deps.sh
# installs them). cargo-fuzz needs nightly (-Zsanitizer); this script stays on
# stable: the Rust static library is built with SanitizerCoverage through
# stable codegen flags (-C passes=sancov-module, -C llvm-args=...), so
# libFuzzer is guided by coverage of the Rust code as well as the harness,
# and with debug assertions and overflow checks on (a failed one is a panic,
# which the C boundary reports as MSBSDF_STATUS_PANIC and the harness treats
# as a crash). The C harness gets ASan + UBSan; the Rust code is not
# ASan-instrumented (that needs nightly), but every allocation it makes goes
# through the intercepted malloc. Inputs that crash are written to fuzz/artifacts/TARGET/;
# new coverage goes to fuzz/work/TARGET/ (not committed); fuzz/corpus/TARGET/
# (committed, replayed by tests/fuzz_corpus.rs) seeds each run. Copy crashes
# and interesting inputs there by hand after fixing them.
set -euo pipefail
cd "$(dirname "$0")/.."
target=${1:?usage: fuzz/run.sh TARGET SECONDS}
seconds=${2:?usage: fuzz/run.sh TARGET SECONDS}
shift 2
[ -f "fuzz/$target.c" ] || { echo "no fuzz/$target.c" >&2; exit 2; }
CLANG=${CLANG:-$(command -v clang || command -v clang-14 || true)}
[ -n "$CLANG" ] || { echo "clang not found: apt-get install clang libclang-rt-14-dev" >&2; exit 2; }
host=$(rustc -vV | sed -n 's/^host: //p')
# --target keeps RUSTFLAGS off build scripts and proc macros.
RUSTFLAGS="-C passes=sancov-module -C llvm-args=-sanitizer-coverage-level=4 \
  -C llvm-args=-sanitizer-coverage-inline-8bit-counters \
  -C llvm-args=-sanitizer-coverage-pc-table -C llvm-args=-sanitizer-coverage-trace-compares \
  -C debug-assertions=on -C overflow-checks=on" \
  cargo build --release --lib --target "$host" --target-dir target/fuzz-build
lib="target/fuzz-build/$host/release/libmsbsdf.a"
bin="target/fuzz/$target"
mkdir -p target/fuzz "fuzz/work/$target" "fuzz/artifacts/$target" "fuzz/corpus/$target"
"$CLANG" -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -fno-omit-frame-pointer -Iinclude "fuzz/$target.c" "$lib" \
  -lpthread -ldl -lm -o "$bin"
# Leak detection stays on: a material leaked by the library would be a bug.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
exec "$bin" -max_total_time="$seconds" -print_final_stats=1 -max_len=512 \
  -artifact_prefix="fuzz/artifacts/$target/" "$@" "fuzz/work/$target" "fuzz/corpus/$target"
