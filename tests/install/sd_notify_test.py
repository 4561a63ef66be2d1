#!/usr/bin/python3
"""The systemd service-manager protocol of the daemons (services/app, Type=notify units): started
with $NOTIFY_SOCKET on a datagram socket this test owns, as systemd would start them.

  motion-coordinator, $WATCHDOG_USEC = 400 ms, stderr a pipe named by $JOURNAL_STREAM:
    READY=1 with a STATUS= line, then WATCHDOG=1 about every 200 ms from its poll loop;
    log lines without timestamps, each starting with its syslog priority ("<6>coordinator: ...");
    SIGTERM: STOPPING=1 and exit 0.
  motion-gateway --bus can0 with no simulator (the bus cannot open), no $WATCHDOG_USEC, plain stderr:
    READY=1 with a STATUS= saying what it waits for, no WATCHDOG=1, timestamped log lines.

Every process is killed by pid at the end.
  sd_notify_test.py --bin BUILD/bin
"""

import argparse
import os
import re
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import Failure, Processes, unique_lcm_url, write_tiny_config  # noqa: E402


class NotifySocket:
    def __init__(self, path):
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(path)

    def messages(self, seconds):
        """Every datagram within `seconds`, as lists of their NAME=VALUE lines, with arrival times."""
        out = []
        deadline = time.monotonic() + seconds
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return out
            self.sock.settimeout(left)
            try:
                data = self.sock.recv(4096)
            except socket.timeout:
                return out
            out.append((time.monotonic(), data.decode().split("\n")))

    def wait_for(self, line_prefix, seconds):
        """The first datagram with a line starting with `line_prefix`, and everything before it."""
        seen = []
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            for item in self.messages(min(0.2, max(0.0, deadline - time.monotonic()))):
                seen.append(item)
                if any(line.startswith(line_prefix) for line in item[1]):
                    return item[1], seen
        raise Failure("no %s within %.0f s; received: %r" % (line_prefix, seconds, [m for _, m in seen]))

    def close(self):
        self.sock.close()


def status_of(lines):
    return next((line[len("STATUS="):] for line in lines if line.startswith("STATUS=")), None)


def check_coordinator(args, work, procs, config):
    notify = NotifySocket(os.path.join(work, "coordinator.notify"))
    try:
        read_end, write_end = os.pipe()
        st = os.fstat(write_end)
        env = dict(os.environ, NOTIFY_SOCKET=notify.path, WATCHDOG_USEC="400000",
                   JOURNAL_STREAM="%d:%d" % (st.st_dev, st.st_ino))
        env.pop("WATCHDOG_PID", None)
        proc = procs.add(subprocess.Popen(
            [os.path.join(args.bin, "motion-coordinator"), "--config", config, "--lcm-url", unique_lcm_url(11)],
            stdout=subprocess.DEVNULL, stderr=write_end, env=env))
        os.close(write_end)
        ready, _ = notify.wait_for("READY=1", 10)
        status = status_of(ready)
        if not status or not status.startswith("degraded: no heartbeat from gateway:can0"):
            raise Failure("coordinator: READY=1 without the expected STATUS= line: %r" % ready)
        pings = [t for t, lines in notify.messages(1.5) if "WATCHDOG=1" in lines]
        # 400 ms asked for: a ping every 200 ms, so about 7 in 1.5 s; a loop that pinged once, or
        # not from a timer, would send 0 or 1.
        if len(pings) < 5:
            raise Failure("coordinator: %d WATCHDOG=1 in 1.5 s with WATCHDOG_USEC=400000 (expected about 7)" % len(pings))
        gaps = [b - a for a, b in zip(pings, pings[1:])]
        if max(gaps) >= 0.4:
            raise Failure("coordinator: a gap of %.0f ms between watchdog pings, not less than the 400 ms asked for" % (max(gaps) * 1000))
        code = procs.stop(proc)
        stopping = [lines for _, lines in notify.messages(0.5) if "STOPPING=1" in lines]
        if code != 0 or not stopping:
            raise Failure("coordinator: after SIGTERM exit %s, STOPPING=1 %s" % (code, "sent" if stopping else "not sent"))
        with os.fdopen(read_end, errors="replace") as f:
            log = f.read().splitlines()
        if not log or not all(re.match(r"<[0-7]>coordinator: ", line) for line in log):
            raise Failure("coordinator: log lines for the journal must start with <N>coordinator: \n%s" % "\n".join(log))
        if not any(line.startswith("<6>coordinator: coordinator running") for line in log):
            raise Failure("coordinator: no info line <6>...running in the journal log:\n%s" % "\n".join(log))
        if any(re.search(r"\d{4}-\d\d-\d\dT\d\d:\d\d", line) for line in log):
            raise Failure("coordinator: timestamps in journal log lines:\n%s" % "\n".join(log))
        print("coordinator: READY=1 (STATUS=%s), %d watchdog pings in 1.5 s (largest gap %.0f ms), STOPPING=1, "
              "%d journal log lines" % (status, len(pings), max(gaps) * 1000, len(log)))
    finally:
        notify.close()


def check_gateway(args, work, procs, config):
    notify = NotifySocket(os.path.join(work, "gateway.notify"))
    try:
        env = dict(os.environ, NOTIFY_SOCKET=notify.path, MOTION_SIM_DIR=os.path.join(work, "sim"))
        for name in ("WATCHDOG_USEC", "WATCHDOG_PID", "JOURNAL_STREAM"):
            env.pop(name, None)
        log_path = os.path.join(work, "gateway.log")
        with open(log_path, "wb") as log:
            proc = procs.add(subprocess.Popen(
                [os.path.join(args.bin, "motion-gateway"), "--config", config, "--bus", "can0", "--lcm-url", unique_lcm_url(12)],
                stdout=subprocess.DEVNULL, stderr=log, env=env))
        ready, _ = notify.wait_for("READY=1", 10)
        status = status_of(ready)
        if not status or "can0" not in status or not status.startswith("degraded"):
            raise Failure("gateway: READY=1 without a STATUS= saying what the bus waits for: %r" % ready)
        later = notify.messages(0.6)
        if any("WATCHDOG=1" in lines for _, lines in later):
            raise Failure("gateway: WATCHDOG=1 sent without WATCHDOG_USEC")
        code = procs.stop(proc)
        with open(log_path, errors="replace") as f:
            log = f.read().splitlines()
        if code != 0 or not log or not all(re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3} gateway:can0\[\d+\] ", line) for line in log):
            raise Failure("gateway: exit %s; log lines outside the journal must keep their timestamps:\n%s" % (code, "\n".join(log)))
        print("gateway: READY=1 (STATUS=%s), no watchdog pings unasked, timestamped log" % status)
    finally:
        notify.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin", required=True, help="folder of the built programs (build/bin)")
    args = parser.parse_args()
    procs = Processes()
    start = time.monotonic()
    try:
        with tempfile.TemporaryDirectory(prefix="motion-sd-notify-") as work:
            config = write_tiny_config(work)
            check_coordinator(args, work, procs, config)
            check_gateway(args, work, procs, config)
    except Failure as e:
        print("FAIL: %s" % e)
        return 1
    finally:
        procs.close()
    print("sd_notify checks passed in %.1f s" % (time.monotonic() - start))
    return 0


if __name__ == "__main__":
    sys.exit(main())
