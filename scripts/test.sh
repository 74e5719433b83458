#!/usr/bin/env bash
# Runs every check and test of msbsdf on a fresh Debian machine: installs the
# system packages the C tests and the Embree tracer need, then formatting,
# clippy, and the whole cargo test suite (Rust unit and integration tests,
# the C conformance programs, the tracer tests).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/deps.sh
source scripts/deps.sh
install_system_deps
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --all-targets -- -D warnings
echo "== cargo test"
cargo test
