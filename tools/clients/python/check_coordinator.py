#!/usr/bin/env python3
"""Checks the Python client against a running motion-coordinator (used by ctest test_clients):
hears its heartbeat, sends a request for an unknown axis and one with a non-finite value, and prints
one line per check:
    health: process=coordinator role=coordinator state=OK
    unknown-axis: status=rejected error_code=2 reason=unknown axis 'no_such_axis' (axes: ...)
    malformed: status=rejected error_code=1 reason=value for axis x is not a finite number
Exit 0 when all three came as expected, 1 otherwise, 4 when LCM is unavailable.

    check_coordinator.py --lcm-url URL [--prefix MOTION_] [--axis x]
"""
import argparse
import sys

import _paths

_paths.add_lcmtypes()
from motionclient import HEALTH_STATES, Client, status_name  # noqa: E402
from motionlcm import reply_t, request_t  # noqa: E402


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--lcm-url", default=None)
    p.add_argument("--prefix", default="MOTION_")
    p.add_argument("--axis", default="x", help="a configured axis (for the malformed-value request)")
    args = p.parse_args()
    try:
        client = Client(args.lcm_url, prefix=args.prefix, client_id="check_coordinator.py")
    except OSError as e:
        print(f"check_coordinator: {e}", file=sys.stderr)
        return 4
    except ValueError as e:  # a URL this client does not understand
        print(f"check_coordinator: {e}", file=sys.stderr)
        return 2
    ok = True
    with client:
        h = client.wait_for_heartbeat("coordinator", timeout=10.0)
        if h is None:
            print("health: none within 10 s")
            ok = False
        else:
            print(f"health: process={h.process} role={h.role} state={HEALTH_STATES.get(h.state, h.state)}")
        r = client.request(request_t.MOVE_ABSOLUTE, ["no_such_axis"], [1.0], timeout=5.0)
        print(f"unknown-axis: status={status_name(r.status)} error_code={r.error_code} reason={r.reason}")
        ok = ok and r.status == reply_t.REJECTED and r.error_code == 2
        r = client.request(request_t.MOVE_ABSOLUTE, [args.axis], [float("nan")], timeout=5.0)
        print(f"malformed: status={status_name(r.status)} error_code={r.error_code} reason={r.reason}")
        ok = ok and r.status == reply_t.REJECTED and r.error_code == 1
    sys.stdout.flush()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
