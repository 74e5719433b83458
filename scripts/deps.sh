# System packages for the C tests, examples and the Embree tracer (Debian).
MSBSDF_APT_PACKAGES=(build-essential pkg-config binutils libembree-dev libstb-dev libtinyobjloader-dev)

install_system_deps() {
  local missing=()
  for p in "${MSBSDF_APT_PACKAGES[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "== installing ${missing[*]}"
    local sudo=""
    [ "$(id -u)" = 0 ] || sudo=sudo
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
}
