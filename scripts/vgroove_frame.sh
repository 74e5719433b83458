#!/usr/bin/env bash
# Frame-level cost of the symmetric V-groove model against SINGLE, like seed
# 002's sec. 7 (whole-frame overhead of a path tracer, not per BSDF call):
# renders c_examples/scenes/conductors.scene (nine conductor spheres, sky and
# point light, NEE + BSDF sampling with MIS) with every material forced to
# SINGLE and to VGROOVE, with the scene's GGX and with Beckmann, same spp,
# one thread, and prints the render time and CPU time (minimum of REPEATS
# runs) and their ratios. Not part of the test suite.
#
# Usage: scripts/vgroove_frame.sh [SPP] [REPEATS] [NDFS] [ALPHA]
#   SPP 16, REPEATS 3, NDFS "beckmann ggx"; ALPHA overrides every roughness
#   (default: the scene's 0.3 / 0.6 / 1.0 columns).
# BASE_LIBDIR=DIR also times the VGROOVE of another build of libmsbsdf.so
# (e.g. the commit before an optimisation) through LD_LIBRARY_PATH (the
# tracer's rpath is a RUNPATH, which LD_LIBRARY_PATH overrides).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
spp=${1:-16}
reps=${2:-3}
ndfs=${3:-"beckmann ggx"}
alpha=${4:-}
cargo build --release >&2
make -s -C c_examples/tracer >&2
tracer=c_examples/tracer/tracer
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ -n "${BASE_LIBDIR:-}" ]; then
    mkdir -p "$tmp/baselib"
    ln -s "$(cd "$BASE_LIBDIR" && pwd)/libmsbsdf.so" "$tmp/baselib/libmsbsdf.so.0"
fi
extra=()
[ -n "$alpha" ] && extra=(--alpha "$alpha")

# min render seconds and min user+sys CPU seconds over the repeats
run() { # scene model [libdir]
    local best_r=1e9 best_c=1e9 out r c
    for _ in $(seq "$reps"); do
        out=$( { LD_LIBRARY_PATH="${3:-}" /usr/bin/time -f "cpu %U %S" \
            "$tracer" "$1" --model "$2" --spp "$spp" --threads 1 --quiet \
            --out "$tmp/img" "${extra[@]}"; } 2>&1 )
        r=$(echo "$out" | sed -n 's/^rendered .*threads, \([0-9.]*\) s,.*/\1/p')
        c=$(echo "$out" | awk '/^cpu / {print $2 + $3}')
        best_r=$(awk -v a="$best_r" -v b="$r" 'BEGIN {print (b < a) ? b : a}')
        best_c=$(awk -v a="$best_c" -v b="$c" 'BEGIN {print (b < a) ? b : a}')
    done
    echo "$best_r $best_c"
}

printf "%-9s %-16s %9s %9s %8s %8s\n" ndf model "render s" "cpu s" "render x" "cpu x"
for ndf in $ndfs; do
    scene="$tmp/conductors_$ndf.scene"
    sed "s/ndf ggx/ndf $ndf/" c_examples/scenes/conductors.scene > "$scene"
    read -r r0 c0 < <(run "$scene" single)
    printf "%-9s %-16s %9.2f %9.2f %8.2f %8.2f\n" "$ndf" single "$r0" "$c0" 1 1
    models=(vgroove)
    [ -n "${BASE_LIBDIR:-}" ] && models+=(vgroove@base)
    for m in "${models[@]}"; do
        if [ "$m" = vgroove@base ]; then
            read -r r c < <(run "$scene" vgroove "$tmp/baselib")
        else
            read -r r c < <(run "$scene" "$m")
        fi
        awk -v n="$ndf" -v m="$m" -v r="$r" -v c="$c" -v r0="$r0" -v c0="$c0" \
            'BEGIN { printf "%-9s %-16s %9.2f %9.2f %8.2f %8.2f\n", n, m, r, c, r / r0, c / c0 }'
    done
done
