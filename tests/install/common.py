"""Helpers of the install and systemd tests (tests/install): LCM URLs, tiny configurations, and
processes that are always killed by pid."""

import os
import signal
import time

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


class Failure(Exception):
    pass


def unique_lcm_url(salt):
    """A multicast port of this process's own, as tests/support's unique_lcm_url() picks them."""
    return "udpm://239.255.76.67:%d?ttl=0" % (20000 + (os.getpid() * 7 + salt) % 40000)


def write_tiny_config(folder):
    path = os.path.join(folder, "tiny.yaml")
    with open(path, "w") as f:
        f.write(TINY_CONFIG)
    return path


def kill_pid(pid, grace=3.0):
    """SIGTERM, up to `grace` seconds, then SIGKILL; returns the exit status (None if killed hard)."""
    try:
        os.kill(pid, signal.SIGTERM)
    except ProcessLookupError:
        return None
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        try:
            done, status = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            return None
        if done == pid:
            return os.waitstatus_to_exitcode(status)
        time.sleep(0.02)
    try:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass
    return None


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
