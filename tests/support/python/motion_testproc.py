"""Helpers shared by the Python tests (tests/install, tests/integration/web_view_test.py): failures,
a per-process LCM URL, polling, and killing a process by pid."""

import os
import signal
import time


class Failure(Exception):
    pass


def unique_lcm_url(salt):
    """A multicast port of this process's own, as tests/support's unique_lcm_url() picks them."""
    return "udpm://239.255.76.67:%d?ttl=0" % (20000 + (os.getpid() * 7 + salt) % 40000)


def wait_for(what, predicate, timeout, period=0.1):
    """Polls predicate() until it returns something truthy; Failure naming `what` on timeout."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise Failure("timed out after %.0f s waiting for %s" % (timeout, what))
        time.sleep(period)


def kill_pid(pid, grace=3.0):
    """SIGTERM, up to `grace` seconds, then SIGKILL. Returns a child's exit status; None when it was
    killed hard, was gone already, or is not our child (then its end is polled)."""
    try:
        os.kill(pid, signal.SIGTERM)
    except ProcessLookupError:
        return None
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        try:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done == pid:
                return os.waitstatus_to_exitcode(status)
        except ChildProcessError:  # not our child: poll its existence
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                return None
        time.sleep(0.02)
    try:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass
    return None
