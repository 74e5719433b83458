#!/usr/bin/env bash
# The main job on a fresh Debian machine: installs the system packages, builds
# the library and the Embree tracer, renders the default scene into out/ and
# prints the output paths and timing (c_examples/run_main_job.sh does the work;
# extra arguments go to the tracer).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/deps.sh
source scripts/deps.sh
install_system_deps
exec bash c_examples/run_main_job.sh "$@"
