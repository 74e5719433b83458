#!/usr/bin/env bash
# Builds libmsbsdf (release), builds the Embree path tracer against it and
# renders the default scene c_examples/scenes/matpreview.scene into out/,
# then the tiers (SINGLE, TABULATED, HEITZ_RANDOM_WALK) of
# c_examples/scenes/tiers.scene side by side (out/tiers_compare.png).
# Extra arguments go to the tracer (e.g. --spp 16, --threads 2, --seconds 30).
#
# Needs: Rust (cargo), make, cc, c++ and
#   apt-get install -y libembree-dev libstb-dev libtinyobjloader-dev
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
cd "$root"

now() { date +%s.%N; }
t0=$(now)
cargo build --release
t1=$(now)
make -C c_examples/tracer
t2=$(now)
mkdir -p out
./c_examples/tracer/tracer c_examples/scenes/matpreview.scene --out out/matpreview "$@"
# The tiers side by side, each panel labelled with its render time.
./c_examples/tracer/tracer c_examples/scenes/tiers.scene --out out/tiers \
    --compare single,tabulated,heitz_random_walk "$@"
t3=$(now)

echo
echo "outputs:"
for f in out/matpreview.png out/matpreview.pfm out/tiers_compare.png; do
    echo "  $root/$f"
done
awk -v a="$t0" -v b="$t1" -v c="$t2" -v d="$t3" 'BEGIN {
    printf "timing: library build %.1f s, tracer build %.1f s, render %.1f s, total %.1f s\n",
           b - a, c - b, d - c, d - a }'
