#!/usr/bin/env bash
# Instructions per call (callgrind, load-independent) of eval / sample / pdf
# for SINGLE and the V-groove models on gold, via the `ir` mode of
# examples/vgroove_timing.rs: (Ir(CALLS) - Ir(0)) / CALLS.
# Usage: scripts/vgroove_ir.sh [CALLS] [MODELS] [NDFS] [ALPHAS] [OPS]
#   e.g. scripts/vgroove_ir.sh 4000 "single vgroove" "ggx beckmann" "0.2 0.5 1" "eval pdf sample"
# MAXB=n: max_bounces n; BIN=path: that binary instead of building one.
# Needs valgrind. Not part of the test suite.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
calls=${1:-4000}
MAXB=${MAXB:-}  # MAXB=1: the k = 1 term alone
models=${2:-"single vgroove"}
ndfs=${3:-"ggx beckmann"}
alphas=${4:-"0.2 0.5 1"}
ops=${5:-"eval pdf sample"}
# BIN=path: a previously built vgroove_timing (e.g. of another commit).
if [ -n "${BIN:-}" ]; then
    bin=$BIN
else
    cargo build --release --example vgroove_timing >&2
    bin=target/release/examples/vgroove_timing
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
total() {
    valgrind --tool=callgrind --callgrind-out-file="$tmp/out" "$bin" ir "$@" $MAXB >/dev/null 2>&1
    awk '/^summary:/ {print $2}' "$tmp/out"
}
printf "%-12s %-9s %-5s %-7s %10s\n" model ndf alpha op "Ir/call"
for ndf in $ndfs; do
    for alpha in $alphas; do
        for model in $models; do
            for op in $ops; do
                a=$(total "$model" "$ndf" "$alpha" "$op" 0)
                b=$(total "$model" "$ndf" "$alpha" "$op" "$calls")
                awk -v m="$model" -v n="$ndf" -v al="$alpha" -v o="$op" -v a="$a" -v b="$b" -v c="$calls" \
                    'BEGIN { printf "%-12s %-9s %-5s %-7s %10.0f\n", m, n, al, o, (b - a) / c }'
            done
        done
    done
done
