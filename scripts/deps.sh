# System packages for the C tests, examples and the Embree tracer (Debian).
# valgrind: memcheck run of a C conformance program (tests/c_hardening.rs);
# clang: libFuzzer harnesses (fuzz/run.sh; the corpus replay uses gcc).
MSBSDF_APT_PACKAGES=(build-essential pkg-config binutils libembree-dev libstb-dev libtinyobjloader-dev clang valgrind)

install_system_deps() {
  local missing=()
  local sudo=""
  [ "$(id -u)" = 0 ] || sudo=sudo
  for p in "${MSBSDF_APT_PACKAGES[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "== installing ${missing[*]}"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
  # libFuzzer's runtime is packaged apart from clang on Debian 12 and later
  # (libclang-rt-<major>-dev); best effort, fuzz/run.sh is not part of the tests.
  if command -v clang >/dev/null 2>&1; then
    local rtdir major
    rtdir=$(clang -print-runtime-dir 2>/dev/null || true)
    major=$(clang -dumpversion 2>/dev/null | cut -d. -f1)
    if [ -n "$major" ] && ! ls "$rtdir"/libclang_rt.fuzzer*.a >/dev/null 2>&1; then
      echo "== installing libclang-rt-$major-dev (libFuzzer)"
      DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
        "libclang-rt-$major-dev" || echo "   (not available: fuzz/run.sh will not link)"
    fi
  fi
}
