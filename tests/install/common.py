"""Helpers of the install and systemd tests (tests/install): LCM URLs, tiny configurations, and
processes that are always killed by pid."""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support", "python"))
from motion_testproc import Failure, kill_pid, unique_lcm_url, wait_for  # noqa: E402,F401 (re-exported)

# One simulated CAN bus with one UIM342 drive and one axis: enough for every program to start.
TINY_CONFIG = """\
lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"   # the tests override it with --lcm-url
  channel_prefix: "MOTION_"
buses:
  - {name: can0, transport: "simcan:can0", bitrate: 500000}
drives:
  - {name: x-drive, family: uim342, bus: can0, node_id: 5}
axes:
  - name: x
    drive: x-drive
    unit: mm
    steps_per_unit: 640
    limits: {min: -50, max: 300, velocity: 50, acceleration: 400}
"""


def write_tiny_config(folder):
    path = os.path.join(folder, "tiny.yaml")
    with open(path, "w") as f:
        f.write(TINY_CONFIG)
    return path


class Processes:
    """Started programs, killed by pid in close() whatever happened."""

    def __init__(self):
        self.pids = []

    def add(self, proc):
        self.pids.append(proc.pid)
        return proc

    def stop(self, proc, grace=3.0):
        """Stops one (SIGTERM) and returns its exit status."""
        self.pids.remove(proc.pid)
        status = kill_pid(proc.pid, grace)
        proc.returncode = status  # reaped here: Popen must not wait on the pid again
        return status

    def close(self):
        for pid in self.pids:
            kill_pid(pid, grace=1.0)
        self.pids = []
