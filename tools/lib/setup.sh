# Shared by tools/test, tools/demo and tools/bench: install what is missing (Debian 12, as root),
# then configure and build. Source it; it defines ensure_packages and build_tree.
# shellcheck shell=bash

MOTION_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)

ensure_packages() {
  local wanted missing=()
  wanted=$(grep -v '^\s*#' "$MOTION_ROOT/tools/lib/packages.txt" | grep -v '^\s*$')
  for pkg in $wanted; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "==> installing missing Debian packages: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "error: packages missing and not root; run as root or: apt-get install ${missing[*]}" >&2
    return 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

# build_tree DIR [--target T] [cmake args...]: configure (once) and build DIR (all, or target T).
build_tree() {
  local dir=$1 target=()
  shift
  if [ "${1:-}" = --target ]; then
    target=(--target "$2")
    shift 2
  fi
  if [ ! -f "$dir/build.ninja" ]; then
    cmake -S "$MOTION_ROOT" -B "$dir" -G Ninja "$@" >/dev/null
  fi
  cmake --build "$dir" -j "$(nproc)" "${target[@]}"
}
