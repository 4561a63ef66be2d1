#!/usr/bin/env python3
"""Wire-format loopback with a C++ (liblcm) peer, used by ctest test_clients.

Publishes on <prefix>REQUEST, as client "py-loopback", a small request_t (request_id 1, one LC02
datagram) and a large one (request_id 2, 300 axes "a000".."a299" with values i/4: LC03 fragments),
repeating every 0.2 s, until the peer has answered on <prefix>REPLY with a small reply_t
(request_id 1, DONE) and a large one (request_id 2, DONE, 300 axes, positions i/2: LC03 from
liblcm). Prints "loopback ok ..." and exits 0; exits 1 after --timeout seconds.
"""
import argparse
import sys

import _paths

_paths.add_lcmtypes()
from motionclient.lcm_udp import SHORT_MESSAGE_MAX, LcmUdp, encode_datagrams  # noqa: E402
from motionlcm import param_t, reply_t, request_t  # noqa: E402

LARGE = 300


def make_request(request_id, axes, values):
    m = request_t()
    m.utime = 1
    m.client_id = "py-loopback"
    m.request_id = request_id
    m.kind = request_t.MOVE_ABSOLUTE
    m.axes = axes
    m.num_axes = len(axes)
    m.values = values
    m.param = param_t()
    return m.encode()


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--lcm-url", default=None)
    p.add_argument("--prefix", default="MOTION_")
    p.add_argument("--timeout", type=float, default=15.0)
    args = p.parse_args()
    small = make_request(1, ["small"], [1.5])
    large = make_request(2, [f"a{i:03d}" for i in range(LARGE)], [i / 4 for i in range(LARGE)])
    assert len(encode_datagrams(args.prefix + "REQUEST", small, 0)) == 1
    fragments = len(encode_datagrams(args.prefix + "REQUEST", large, 0))
    assert fragments > 1 and len(large) > SHORT_MESSAGE_MAX
    got = {}
    problems = []

    def on_reply(_channel, payload):
        r = reply_t.decode(payload)
        if r.client_id != "py-loopback" or r.request_id in got:
            return
        if r.request_id == 1:
            if r.status == reply_t.DONE and r.reason == "small ok":
                got[1] = len(payload)
            else:
                problems.append(f"bad small reply: status {r.status} reason {r.reason!r}")
        elif r.request_id == 2:
            expected = [i / 2 for i in range(LARGE)]
            if r.status == reply_t.DONE and r.num_axes == LARGE and list(r.positions) == expected and \
                    list(r.axes) == [f"a{i:03d}" for i in range(LARGE)]:
                got[2] = len(payload)
            else:
                problems.append(f"bad large reply: status {r.status} num_axes {r.num_axes}")

    import time
    with LcmUdp(args.lcm_url) as lcm:
        lcm.subscribe(args.prefix + "REPLY", on_reply)
        deadline = time.monotonic() + args.timeout
        while len(got) < 2 and not problems and time.monotonic() < deadline:
            lcm.publish(args.prefix + "REQUEST", small)
            lcm.publish(args.prefix + "REQUEST", large)
            end = time.monotonic() + 0.2
            while len(got) < 2 and time.monotonic() < end:
                lcm.handle(0.05)
    if problems or len(got) < 2:
        print("loopback FAILED: " + ("; ".join(problems) or f"replies received: {sorted(got)}"))
        return 1
    print(f"loopback ok: sent request_t of {len(small)} bytes (LC02) and {len(large)} bytes "
          f"(LC03, {fragments} fragments); received reply_t of {got[1]} and {got[2]} bytes from liblcm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
