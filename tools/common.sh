# Shared by tools/demo, tools/test and tools/bench: install what is missing, build.
# Sourced, not run.

ZONEMAP_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ZONEMAP_PACKAGES=(cmake ninja-build g++ pkg-config libeigen3-dev libpng-dev zlib1g-dev
                  libyaml-cpp-dev libgtest-dev)

# Installs the Debian packages that are not installed yet; silent when none is missing.
zonemap_install() {
  local missing=()
  local pkg
  for pkg in "${ZONEMAP_PACKAGES[@]}" "$@"; do
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

# Configures and builds one preset (release by default) quietly unless it fails.
zonemap_build() {
  local preset="${1:-release}"
  local log
  log="$(mktemp)"
  if ! (cd "$ZONEMAP_ROOT" && cmake --preset "$preset" >"$log" 2>&1 &&
        cmake --build --preset "$preset" -j "$(nproc)" >>"$log" 2>&1); then
    cat "$log" >&2
    rm -f "$log"
    echo "zonemap: build ($preset) failed" >&2
    return 1
  fi
  rm -f "$log"
}
