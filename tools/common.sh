# Shared by tools/demo, tools/test and tools/bench: install what is missing, build.
# Sourced, not run.

ZONEMAP_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ZONEMAP_PACKAGES=(cmake ninja-build g++ pkg-config libeigen3-dev libpng-dev zlib1g-dev
                  libyaml-cpp-dev libgtest-dev liblcm-dev liblcm-bin libzstd-dev iproute2
                  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev
                  libopencv-calib3d-dev)  # OpenCV: host stereo for ASL recordings only

# Installs the Debian packages that are not installed yet; silent when none is missing.
zonemap_install() {
  local missing=()
  local pkg
  for pkg in "${ZONEMAP_PACKAGES[@]}" "$@"; do
    # An :arch suffix names a foreign-architecture package; dpkg-query takes it as is.
    if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed'; then
      missing+=("$pkg")
    fi
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  echo "zonemap: installing ${missing[*]}" >&2
  "${sudo[@]}" apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}

# The aarch64 cross toolchain and :arm64 libraries (multiarch), for tools/test --cross aarch64.
zonemap_install_cross_aarch64() {
  local sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    echo "zonemap: adding the arm64 architecture" >&2
    "${sudo[@]}" dpkg --add-architecture arm64
    "${sudo[@]}" apt-get update -qq >/dev/null
  fi
  zonemap_install g++-aarch64-linux-gnu qemu-user-static libgtest-dev:arm64 libpng-dev:arm64 \
    zlib1g-dev:arm64 libzstd-dev:arm64 libyaml-cpp0.7:arm64 libglib2.0-0:arm64
  # libyaml-cpp-dev is not Multi-Arch: installing its :arm64 package would remove the
  # native one. Unpack it into a project-owned sysroot instead (the toolchain file
  # adds it to CMAKE_FIND_ROOT_PATH).
  # liblcm-dev and liblcm1 likewise (installing them :arm64 would remove lcm-gen).
  local sysroot="$ZONEMAP_ROOT/build/sysroot-arm64"
  if [ ! -f "$sysroot/usr/include/yaml-cpp/yaml.h" ] || [ ! -f "$sysroot/usr/include/lcm/lcm.h" ]; then
    local tmp
    tmp="$(mktemp -d)"
    (cd "$tmp" && apt-get download -qq libyaml-cpp-dev:arm64 libyaml-cpp0.7:arm64 \
       liblcm-dev:arm64 liblcm1:arm64 >/dev/null 2>&1) || return 1
    mkdir -p "$sysroot"
    for deb in "$tmp"/*.deb; do dpkg-deb -x "$deb" "$sysroot"; done
    rm -rf "$tmp"
  fi
}

# Configures and builds one preset (release by default) quietly unless it fails; the
# targets after the preset, or all.
zonemap_build() {
  local preset="${1:-release}"
  shift || true
  local targets=()
  [ $# -gt 0 ] && targets=(--target "$@")
  local log
  log="$(mktemp)"
  if ! (cd "$ZONEMAP_ROOT" && cmake --preset "$preset" >"$log" 2>&1 &&
        cmake --build --preset "$preset" -j "$(nproc)" "${targets[@]}" >>"$log" 2>&1); then
    cat "$log" >&2
    rm -f "$log"
    echo "zonemap: build ($preset) failed" >&2
    return 1
  fi
  rm -f "$log"
}

# npm packages, each from its lock file (`npm ci`), installed once per lock:
#   tests/js      the independent decoders the tests check our outputs with
#   tools/report  three.js and esbuild, for report.html's 3-D view (bundled at build time)
# Node.js comes from Debian when it is missing. When the registry cannot be reached
# the tests that need the decoders are skipped, and the report has no 3-D view;
# both say so.
zonemap_install_js() {
  if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    zonemap_install nodejs npm || true
  fi
  command -v npm >/dev/null 2>&1 || {
    echo "zonemap: no npm: independent-decoder tests will be skipped, report.html has no 3-D view" >&2
    return 0
  }
  local dir
  for dir in "$ZONEMAP_ROOT/tests/js" "$ZONEMAP_ROOT/tools/report"; do
    [ -f "$dir/node_modules/.package-lock.json" ] &&
      cmp -s "$dir/package-lock.json" "$dir/node_modules/.zonemap-lock" && continue
    if (cd "$dir" && timeout 300 npm ci --no-audit --no-fund --loglevel=error >/dev/null 2>&1); then
      cp "$dir/package-lock.json" "$dir/node_modules/.zonemap-lock"
    else
      echo "zonemap: npm registry unreachable (npm ci in ${dir#"$ZONEMAP_ROOT"/} failed)" >&2
    fi
  done
}

# After a ctest run: one line naming every test that was skipped, and why (the
# test's own "SKIP: ..." or gtest's skip message, from ctest's LastTest.log).
#   zonemap_report_skipped CTEST_OUTPUT BUILD_DIR
zonemap_report_skipped() {
  local names line name reason list=()
  names="$(sed -n 's/^[[:space:]]*[0-9]* - \(.*\) (Skipped)$/\1/p' "$1")"
  while IFS= read -r name; do
    [ -n "$name" ] || continue
    reason="$(awk -v want="$name" '
      $0 ~ /^[0-9]+\/[0-9]+ Testing: / { inside = ($3 == want); next }
      !inside { next }
      next_is_reason { print; exit }
      /SKIP: / { sub(/.*SKIP: /, ""); print; exit }
      /: Skipped$/ { next_is_reason = 1 }
    ' "$2/Testing/Temporary/LastTest.log" 2>/dev/null)"
    list+=("$name (${reason:-no reason given})")
  done <<<"$names"
  if [ ${#list[@]} -eq 0 ]; then
    echo "zonemap: skipped: none"
  else
    local IFS=';'
    echo "zonemap: skipped ${#list[@]}: ${list[*]}"
  fi
}

# Says that a preset's test filter (CMakePresets.json) left the long generated flights out:
# they repeat code paths the shorter tests drive, at 3-10x the cost under the sanitizers
# and qemu; the release run has them all, `--long` runs them in any preset.
zonemap_report_left_out() {
  local preset="$1" long="$2"
  case "$preset" in asan | profile | aarch64) ;; *) return 0 ;; esac
  [ "$long" -eq 1 ] && return 0
  echo "zonemap: the $preset run leaves out the long flights its test preset names in" \
    "CMakePresets.json (the release run has them all; tools/test ... --long runs them here)"
}
