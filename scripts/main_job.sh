#!/usr/bin/env bash
# The main job on a fresh Debian machine: installs the system packages,
# builds libmsbsdf and the Embree example tracer, and renders the default
# scene (c_examples/scenes/matpreview.scene) into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/deps.sh
source scripts/deps.sh
install_system_deps
exec bash c_examples/run_main_job.sh "$@"
