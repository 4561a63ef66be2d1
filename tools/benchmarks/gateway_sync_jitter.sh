#!/usr/bin/env bash
# SYNC 1 kHz period jitter of a real motion-gateway (README "Performance"): motion-sim and one
# gateway of a simulated 1 Mbit/s CAN bus (bit-timed) with one UC57 on event-driven TPDOs and
# poll_hz 1000, so the bus's only periodic frame is the gateway's SYNC at 1 kHz; `motionctl dump`
# records the SYNCs' end-of-frame times for S seconds. Jitter = |interval - 1 ms|: p50, p99, max,
# and the intervals over 1.5 ms (a period missed), p99 over the 50 us goal. Run once with the bus's
# realtime_priority 0 (normal scheduling), once with P (SCHED_FIFO), and once with P and the bus's
# timer_spin_us SPIN (the loop woken SPIN early, the rest waited busy); then normal scheduling and
# SCHED_FIFO again with the bus's cpu_latency_us 0 (idle CPUs poll, as cyclictest has them while
# it measures the floor below). motion-sim runs under
# SCHED_FIFO 40 when permitted, so that the simulated wire's own wake-ups (it dates the frames) stay
# out of the gateway's figure. Everything runs in a temporary folder on its own LCM port; the
# processes are stopped by pid.
# The bound of the same run: the host's own wake-up latency (cyclictest, rt-tests: a bare thread
# under SCHED_FIFO P woken every 1 ms for S seconds, nothing else). A wake-up L late makes a period
# of 1 ms + L, so its "over 1.5 ms" counts wake-ups more than 500 us late: on a virtual machine
# those come from the hypervisor, and no gateway setting takes them out.
#   tools/benchmarks/gateway_sync_jitter.sh [BIN_DIR] [SECONDS] [PRIORITY] [SPIN]   (build/bin, 8, 50, 100)
set -euo pipefail
BIN=${1:-$(cd "$(dirname "$0")/../.." && pwd)/build/bin}
SECS=${2:-8}
PRIO=${3:-50}
SPIN=${4:-100}
DIR=$(mktemp -d /tmp/motion-sync-jitter-XXXXXX)
PIDS=()
cleanup() {
  for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT
SIM_CHRT=()
if chrt -f 40 true 2>/dev/null; then SIM_CHRT=(chrt -f 40); fi

run() {  # run RT SPIN [CPU_LATENCY]: prints one line of figures
  local rt=$1 spin=$2 lat=${3:--1} d="$DIR/rt$1-spin$2-lat${3:-host}" port=$((20000 + (RANDOM % 30000)))
  local lat_key=""
  if [ "$lat" -ge 0 ]; then lat_key=", cpu_latency_us: $lat"; fi
  local url="udpm://239.255.76.67:$port?ttl=0"
  mkdir -p "$d/sim"
  cat >"$d/lab.yaml" <<YAML
lcm: {url: "$url", channel_prefix: "SJ_"}
buses:
  - {name: can9, transport: simcan:can9, bitrate: 1000000, bus_timing: true, poll_hz: 1000, realtime_priority: $rt, timer_spin_us: $spin$lat_key}
drives:
  - {name: a-drive, family: uc57, bus: can9, node_id: 1, setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: event}}
axes:
  - {name: a, drive: a-drive, steps_per_unit: 8.888888888888889, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
YAML
  export MOTION_SIM_DIR="$d/sim"
  "${SIM_CHRT[@]}" "$BIN/motion-sim" --config "$d/lab.yaml" --lcm-url "$url" --log-level warn >"$d/sim.log" 2>&1 &
  local sim=$!
  PIDS+=("$sim")
  sleep 1
  "$BIN/motion-gateway" --config "$d/lab.yaml" --lcm-url "$url" --bus can9 --log-level info >"$d/gateway.log" 2>&1 &
  local gw=$!
  PIDS+=("$gw")
  sleep 3  # the drive set up, the SYNC running
  "$BIN/motionctl" --config "$d/lab.yaml" --lcm-url "$url" dump can9 --for "$SECS" >"$d/dump.txt" 2>"$d/dump.err"
  kill "$gw" "$sim" 2>/dev/null || true
  wait "$gw" "$sim" 2>/dev/null || true
  local sched="normal scheduling"
  if [ "$rt" -gt 0 ]; then
    sched="realtime_priority $rt ($(grep -q "SCHED_FIFO at priority" "$d/gateway.log" && echo SCHED_FIFO || echo refused: normal))"
  fi
  if [ "$spin" -gt 0 ]; then sched="$sched, timer_spin_us $spin"; fi
  if [ "$lat" -ge 0 ]; then
    sched="$sched, cpu_latency_us $lat ($(grep -q "wake from idle within" "$d/gateway.log" && echo held || echo refused))"
  fi
  /usr/bin/python3 - "$d/dump.txt" "$sched" <<'PY'
import re, sys
stamps = []
for line in open(sys.argv[1]):
    m = re.match(r"\((\d+)\.(\d+)\) \S+ 080#", line)
    if m:
        stamps.append(int(m.group(1)) * 1_000_000 + int(m.group(2)))
intervals = [b - a for a, b in zip(stamps, stamps[1:])]
if len(intervals) < 100:
    sys.exit(f"{sys.argv[2]}: only {len(stamps)} SYNCs recorded")
jitter = sorted(abs(i - 1000) for i in intervals)
def nearest_rank(q):
    return jitter[max(0, -(-len(jitter) * q // 100) - 1)]
missed = sum(1 for i in intervals if i > 1500)
print(f"gateway SYNC 1 kHz, {sys.argv[2]}: {len(intervals)} periods, jitter p50 {nearest_rank(50)} us, "
      f"p99 {nearest_rank(99)} us, max {jitter[-1]} us, {missed} over 1.5 ms; p99 / 50 us goal = {nearest_rank(99) / 50:.2f}")
PY
}

floor() {  # the host's timer wake-up latency under SCHED_FIFO PRIO, as one line of figures
  if ! command -v cyclictest >/dev/null; then
    echo "host floor: cyclictest not installed (Debian package rt-tests)"
    return
  fi
  local steal_before steal_after
  steal_before=$(awk '/^cpu /{print $9}' /proc/stat)
  if ! cyclictest -m -p "$PRIO" -i 1000 -l $((SECS * 1000)) -q -h 20000 >"$DIR/cyclictest.txt" 2>"$DIR/cyclictest.err"; then
    echo "host floor: cyclictest failed: $(head -1 "$DIR/cyclictest.err")"
    return
  fi
  steal_after=$(awk '/^cpu /{print $9}' /proc/stat)
  /usr/bin/python3 - "$DIR/cyclictest.txt" "$PRIO" "$((steal_after - steal_before))" <<'PY'
import sys
late = []
for line in open(sys.argv[1]):
    if line.startswith("#") or not line.strip():
        continue
    us, count = line.split()[:2]
    late += [int(us)] * int(count)
late.sort()
if not late:
    sys.exit("host floor: cyclictest gave no histogram")
def nearest_rank(q):
    return late[max(0, -(-len(late) * q // 100) - 1)]
print(f"host floor (cyclictest, SCHED_FIFO {sys.argv[2]}, 1 ms): {len(late)} wake-ups, late p50 {nearest_rank(50)} us, "
      f"p99 {nearest_rank(99)} us, max {late[-1]} us, {sum(1 for x in late if x > 500)} over 500 us "
      f"(periods over 1.5 ms); steal {sys.argv[3]} jiffies meanwhile")
PY
}

echo "load average $(cut -d' ' -f1-3 /proc/loadavg); motion-sim ${SIM_CHRT[*]:-under normal scheduling (chrt -f refused)}"
floor
run 0 0
run "$PRIO" 0
run "$PRIO" "$SPIN"
run 0 0 0
run "$PRIO" 0 0
floor
[ -n "${KEEP:-}" ] && echo "kept $DIR" || rm -rf "$DIR"
