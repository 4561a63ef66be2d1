#!/usr/bin/env bash
# The installed C++ client as a program outside this tree uses it: `cmake --install` (component
# dev) into a temporary prefix, then example_move.cpp built twice against that prefix only, with
# find_package(motion) (CMakeLists.txt beside this script) and with pkg-config (motion-client.pc),
# and each build run: --help (0), a URL LCM refuses (4), and no coordinator listening (1, the
# client's "no terminal reply" reason).
#   install_test.sh BUILD_DIR CPP_DIR CMAKE GENERATOR CXX PKG_CONFIG [CXXFLAGS]
set -euo pipefail
build=$1 cpp=$2 cmake=$3 generator=$4 cxx=$5 pkg_config=$6 cxxflags=${7:-}
fail() { echo "FAIL: $*"; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix

echo "== cmake --install $build --prefix $prefix --component dev"
"$cmake" --install "$build" --prefix "$prefix" --component dev >"$work/install.log" 2>&1 || {
  cat "$work/install.log"; fail "cmake --install (are motion_client, motion_lcm, motion_core built?)"; }
for f in include/motion/client/client.hpp include/motion/lcm/node.hpp include/motion/core/event_loop.hpp \
         include/motion/core/version.hpp include/motionlcm/reply_t.hpp; do
  [ -f "$prefix/$f" ] || fail "$f not installed"
done
config=$(find "$prefix" -name motionConfig.cmake)
pc=$(find "$prefix" -name motion-client.pc)
[ -n "$config" ] || fail "motionConfig.cmake not installed"
[ -n "$pc" ] || fail "motion-client.pc not installed"
# Relocatable: nothing installed points back into the build or source tree.
source_root=$(cd "$cpp/../../.." && pwd)
if grep -rIl -e "$build" -e "$source_root/" "$prefix"; then
  fail "installed files name the build or source tree (above)"
fi

# Runs one build of example_move: --help, a refused LCM URL, no coordinator.
check_example() {
  local exe=$1 out rc
  [ -x "$exe" ] || fail "$exe not built"
  out=$("$exe" --help 2>&1) || fail "$exe --help exited $?: $out"
  [[ $out == *--targets* ]] || fail "$exe --help does not list --targets: $out"
  rc=0; out=$("$exe" --lcm-url 'nonsense://nowhere' 2>&1) || rc=$?
  [ "$rc" -eq 4 ] || fail "$exe with a refused LCM URL exited $rc, not 4: $out"
  local url="udpm://239.255.76.67:$((20000 + ($$ * 7 + 3) % 40000))?ttl=0"
  rc=0; out=$("$exe" --lcm-url "$url" --timeout 0.5 2>&1) || rc=$?
  [ "$rc" -eq 1 ] || fail "$exe without a coordinator exited $rc, not 1: $out"
  [[ $out == *"no reply from the coordinator within"*"channel MOTION_REQUEST"* ]] || fail "$exe without a coordinator: $out"
  echo "$exe: --help 0, refused URL 4, no coordinator 1"
}

echo "== find_package(motion): cmake -S $cpp -DCMAKE_PREFIX_PATH=$prefix"
"$cmake" -S "$cpp" -B "$work/find-package" -G "$generator" -DCMAKE_CXX_COMPILER="$cxx" \
  -DCMAKE_CXX_FLAGS="$cxxflags" -DCMAKE_PREFIX_PATH="$prefix" >"$work/configure.log" 2>&1 || {
  cat "$work/configure.log"; fail "configuring the find_package consumer"; }
grep -q "^motion_DIR:PATH=$prefix/" "$work/find-package/CMakeCache.txt" || fail "find_package(motion) did not use $prefix"
"$cmake" --build "$work/find-package" >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "building the find_package consumer"; }
check_example "$work/find-package/example_move"

echo "== pkg-config: PKG_CONFIG_PATH=$(dirname "$pc") $pkg_config --cflags --libs motion-client"
PKG_CONFIG_PATH=$(dirname "$pc")
export PKG_CONFIG_PATH
flags=$("$pkg_config" --cflags --libs motion-client) || fail "pkg-config motion-client"
echo "$flags"
mkdir "$work/pkg-config"
# shellcheck disable=SC2086  # the flags are words
"$cxx" -std=c++20 $cxxflags "$cpp/example_move.cpp" $flags -o "$work/pkg-config/example_move" || fail "building with pkg-config"
check_example "$work/pkg-config/example_move"

echo "C++ client install test passed"
