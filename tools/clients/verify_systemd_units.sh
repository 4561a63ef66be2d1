#!/usr/bin/env bash
# Checks the unit templates of config/systemd with `systemd-analyze verify` (syntax, directives,
# specifiers, dependencies), the gateway template instantiated as motion-gateway@can0. verify also
# wants ExecStart's program to exist: /usr/local/bin/motion-* is pointed at BIN_DIR/motion-* when
# built there, else at /usr/bin/true.
#   verify_systemd_units.sh SOURCE_DIR BIN_DIR
set -euo pipefail
src=$1/config/systemd
bin=$2
command -v systemd-analyze >/dev/null || { echo "FAIL: systemd-analyze not found (apt-get install systemd)"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$src"/*.service "$src"/*.target "$work"/
mv "$work/motion-gateway@.service" "$work/motion-gateway@can0.service"
for prog in motion-coordinator motion-gateway motion-sim; do
  target=/usr/bin/true
  [ -x "$bin/$prog" ] && target=$bin/$prog
  sed -i "s#/usr/local/bin/$prog #$target #" "$work"/*.service
done
cd "$work"
out=$(systemd-analyze verify --man=no ./motion-coordinator.service ./motion-sim.service ./motion-gateway@can0.service ./motionbus.target 2>&1) || {
  echo "$out"; echo "FAIL: systemd-analyze verify"; exit 1; }
# verify exits 0 on some warnings: treat any output as a failure.
[ -z "$out" ] || { echo "$out"; echo "FAIL: systemd-analyze verify printed warnings"; exit 1; }
echo "systemd units verified"
